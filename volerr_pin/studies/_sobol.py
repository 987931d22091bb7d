"""Variance-based sensitivity indices (Sobol' first order and total) with SALib.

SALib (a maintained, cited library: Herman and Usher 2017, Iwanaga et al. 2022) draws the
Saltelli design (Sobol' sequence, ``N (D + 2)`` model runs without second-order indices) and
estimates the first-order indices with Saltelli et al. (2010) and the total ones with
Jansen's estimator, with bootstrap confidence intervals. Hand-written estimators would only
repeat it less well.
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..base import InputError

__all__ = ["SobolIndices", "sobol_indices"]


@dataclass(frozen=True)
class SobolIndices:
    """First-order and total Sobol' indices of one output.

    Attributes
    ----------
    names : tuple of str
        The inputs.
    first_order, total : ndarray, shape (D,)
        The indices (fractions of the output's variance).
    first_order_conf, total_conf : ndarray, shape (D,)
        Half-widths of their 95 % bootstrap intervals.
    runs : int
        Model runs, ``N (D + 2)``.
    base : int
        The base samples ``N`` (0 where not known).
    """

    names: tuple[str, ...]
    first_order: np.ndarray
    total: np.ndarray
    first_order_conf: np.ndarray
    total_conf: np.ndarray
    runs: int
    base: int = 0

    def resolution(self, top: int | None = None) -> dict:
        """Which indices their 95 % intervals separate from zero, and the base samples that
        would separate the rest (an interval's half-width falls as ``1 / sqrt(N)``).

        Parameters
        ----------
        top : int, optional
            Look at the inputs with the ``top`` largest total indices only (default all).

        Returns
        -------
        dict
            ``first_order_unresolved`` and ``total_unresolved`` (the inputs whose interval
            includes zero; estimates below zero, and totals below their first-order index, are
            such noise), ``samples_needed`` (the power of 2 at which the interval of the input
            with the largest first-order estimate would clear zero; None when it already does
            or no estimate is above zero) and ``samples``.
        """
        order = np.argsort(-self.total, kind="stable")[:top]
        s1, c1, st, ct = self.first_order[order], self.first_order_conf[order], self.total[order], self.total_conf[order]
        names = [self.names[i] for i in order]
        needed = None
        lead = int(np.argmax(s1)) if len(s1) else 0
        if len(s1) and s1[lead] > 0 and c1[lead] >= s1[lead] and self.base:
            needed = int(2 ** math.ceil(math.log2(self.base * (c1[lead] / s1[lead]) ** 2 * 1.05)))
        return {"first_order_unresolved": [n for n, v, c in zip(names, s1, c1) if v - c <= 0],
                "total_unresolved": [n for n, v, c in zip(names, st, ct) if v - c <= 0],
                "samples_needed": needed, "samples": self.base}

    def rows(self) -> list[dict]:
        """One row per input, largest total index first.

        Returns
        -------
        list of dict
            ``component``, ``first_order``, ``total``, ``first_order_conf``, ``total_conf``.
        """
        order = np.argsort(-self.total, kind="stable")
        return [{"component": self.names[i], "first_order": float(self.first_order[i]), "total": float(self.total[i]),
                 "first_order_conf": float(self.first_order_conf[i]), "total_conf": float(self.total_conf[i])}
                for i in order]


def saltelli_design(problem: dict, n: int, seed: int) -> np.ndarray:
    """The Saltelli design of SALib for ``problem`` (no second-order indices).

    Parameters
    ----------
    problem : dict
        SALib's problem: ``num_vars``, ``names``, ``bounds``, ``dists``.
    n : int
        Base samples N (a power of 2).
    seed : int
        Seed of the scrambled Sobol' sequence.

    Returns
    -------
    ndarray, shape (N (D + 2), D)
        Model inputs.
    """
    from SALib.sample import sobol

    return sobol.sample(problem, n, calc_second_order=False, scramble=True, seed=seed)


def sobol_indices(problem: dict, model: Callable[[np.ndarray], np.ndarray], n: int = 512, seed: int = 0
                  ) -> SobolIndices:
    """First-order and total Sobol' indices of ``model`` over ``problem``'s inputs.

    Parameters
    ----------
    problem : dict
        SALib's problem: ``num_vars`` D, ``names``, ``bounds``, ``dists`` (``unif`` with
        [low, high], ``norm`` with [mean, standard deviation]) and optionally ``groups`` (one
        name per input; the indices are then those of the groups, in order of first
        appearance, and the runs ``N (G + 2)`` for G groups).
    model : callable
        Maps the design, shape (runs, D), to the output, shape (runs,).
    n : int, default 512
        Base samples N, a power of 2; the model runs ``N (D + 2)`` times (``N (G + 2)`` with groups).
    seed : int, default 0
        Seed of the design and the bootstrap.

    Returns
    -------
    SobolIndices
        The indices and their confidence half-widths.

    Raises
    ------
    InputError
        If ``n`` is not a power of 2 (at least 4), or the output has no variance.
    """
    if isinstance(n, bool) or int(n) != n or n < 4 or int(n) & (int(n) - 1):
        raise InputError(f"sobol_samples must be a power of 2 (at least 4), got {n!r}", parameters=("sobol_samples",))
    from SALib.analyze import sobol

    X = saltelli_design(problem, int(n), seed)
    Y = np.asarray(model(X), dtype=float)
    if not np.isfinite(Y).all() or np.var(Y) <= 0:
        raise InputError("the output does not vary over the inputs' ranges: no sensitivity indices")
    # SALib seeds its bootstrap only when ``seed`` is truthy (seed 0 would draw from the global state, and the
    # confidence intervals would change from run to run): give it a nonzero seed derived from ours.
    bootstrap_seed = int(np.random.SeedSequence(int(seed)).generate_state(1)[0]) | 1
    result = sobol.analyze(problem, Y, calc_second_order=False, num_resamples=200, conf_level=0.95,
                           seed=bootstrap_seed, print_to_console=False)
    names = tuple(dict.fromkeys(problem["groups"])) if problem.get("groups") else tuple(problem["names"])
    return SobolIndices(names, np.asarray(result["S1"]), np.asarray(result["ST"]),
                        np.asarray(result["S1_conf"]), np.asarray(result["ST_conf"]), int(len(X)), int(n))
