"""Tolerance studies: which component tolerances a machine can afford.

Every component error is drawn within its tolerance (:mod:`.tolerances`), as one value over
its axis' travel (a constant, as ``volerr rank`` sizes tolerances: an offset for a
translation, a tilt for an angle, whose Abbe arm varies over the workspace). The machine's
own terms are replaced by these constants. For every draw the exact volumetric error is
evaluated at every grid point; the study reports the distribution of the largest and of the
RMS position error over the grid, the probability that the largest stays within a target
``T``, the components that drive it (Sobol' first-order and total indices of the largest
error, :mod:`.sobol`) and a least-cost re-allocation of the tolerances that meets ``T`` at a
stated probability, checked by re-simulation (:mod:`.allocation`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base.errors import InputError
from ..model.machine import Machine
from ..model.spec import parse_component_name
from ..model.specio import replace_terms
from ..base.safeio import require_memory
from ..base.units import UM_PER_M
from .allocation import Reallocation, reallocate
from .engine import Engine, InProcess
from .montecarlo import MonteCarlo, RowsSource, ToleranceSource, make_points, run_monte_carlo
from .sobol import SobolIndices, sobol_indices
from .tolerances import Tolerances

__all__ = ["ToleranceStudy", "check_arguments", "study_tolerances", "tolerance_machine", "tolerance_source"]


def tolerance_machine(machine: Machine) -> tuple[Machine, np.ndarray]:
    """The machine with every component replaced by one constant (zero) coefficient.

    Parameters
    ----------
    machine : Machine
        The machine (its state is kept).

    Returns
    -------
    machine : Machine
        The new machine.
    index : ndarray of int, shape (n_components,)
        The coefficient of each of ``machine.components`` in the new machine's theta.
    """
    tables = {c: {"kind": "constant", ("value_arcsec" if parse_component_name(c)[0] in "ABC" else "value_um"): 0.0}
              for c in machine.components}
    constant = replace_terms(machine, tables)
    names = constant.parameter_names
    owner = [n.split(".", 1)[0] for n in names]
    index = np.array([owner.index(c) for c in machine.components], dtype=int)
    return constant, index


@dataclass(frozen=True)
class ToleranceStudy:
    """Result of :func:`study_tolerances` (SI).

    Attributes
    ----------
    machine : str
        Machine name.
    tolerances : Tolerances
        The tolerances studied.
    points : int
        Grid points.
    samples : int
        Monte Carlo draws.
    seed : int
        Their seed.
    workers : int
        Worker processes.
    run : MonteCarlo
        Per draw, the largest and the RMS position error over the grid.
    target : float or None
        The target ``T`` [m].
    target_probability : float
        The probability a re-allocation must meet ``T`` with.
    sobol : SobolIndices or None
        Drivers of the largest error (None when not asked for).
    reallocation : Reallocation or None
        The suggestion (None without a target, or when not asked for).
    """

    machine: str
    tolerances: Tolerances
    points: int
    samples: int
    seed: int
    workers: int
    run: MonteCarlo
    target: float | None
    target_probability: float
    sobol: SobolIndices | None
    reallocation: Reallocation | None

    @property
    def probability(self) -> float | None:
        """Fraction of the draws whose largest error is within the target (None without one)."""
        return None if self.target is None else float(np.mean(self.run.max <= self.target))

    def to_dict(self) -> dict:
        """The JSON report (docs/reports.md).

        Returns
        -------
        dict
            ``machine``, ``samples``, ``workers``, ``seed``, ``points``, ``max_error_um``
            {``mean``, ``std``, ``p50``, ``p95``, ``p99``, ``max``}, ``rms_error_um`` {``mean``,
            ``std``, ``p95``}, ``target_um``, ``probability_within_target`` and its
            ``probability_se``, ``target_probability``, ``drivers`` (``component``,
            ``first_order``, ``total``, ``first_order_conf``, ``total_conf``), ``sobol_runs``,
            ``sobol_resolution`` (:meth:`~volerr_pin.studies.sobol.SobolIndices.resolution`; null
            without indices), ``tolerances`` and ``reallocation``.
        """
        mx, rms = self.run.max * UM_PER_M, self.run.rms * UM_PER_M
        p = self.probability
        return {"machine": self.machine, "samples": self.samples, "workers": self.workers, "seed": self.seed,
                "points": self.points,
                "max_error_um": {"mean": float(mx.mean()), "std": float(mx.std(ddof=1)) if len(mx) > 1 else 0.0,
                                 "p50": float(np.quantile(mx, 0.5)), "p95": float(np.quantile(mx, 0.95)),
                                 "p99": float(np.quantile(mx, 0.99)), "max": float(mx.max())},
                "rms_error_um": {"mean": float(rms.mean()), "std": float(rms.std(ddof=1)) if len(rms) > 1 else 0.0,
                                 "p95": float(np.quantile(rms, 0.95))},
                "target_um": None if self.target is None else self.target * UM_PER_M,
                "probability_within_target": p,
                "probability_se": None if p is None else math.sqrt(p * (1 - p) / self.samples),
                "target_probability": self.target_probability,
                "drivers": [] if self.sobol is None else self.sobol.rows(),
                "sobol_runs": 0 if self.sobol is None else self.sobol.runs,
                "sobol_resolution": None if self.sobol is None else self.sobol.resolution(),
                "tolerances": self.tolerances.to_dict(),
                "reallocation": None if self.reallocation is None else self.reallocation.to_dict()}


def tolerance_source(tolerances: Tolerances, index: np.ndarray, n_params: int, seed: int) -> ToleranceSource:
    """The draws of a tolerance study: each component's coefficient within its tolerance.

    Parameters
    ----------
    tolerances : Tolerances
        One per component.
    index : ndarray of int, shape (n_components,)
        The coefficient of each component (from :func:`tolerance_machine`).
    n_params : int
        Coefficients of the tolerance machine.
    seed : int
        The study's seed.

    Returns
    -------
    ToleranceSource
        Scales and distributions per coefficient.
    """
    from .distributions import DISTRIBUTIONS

    scale = np.zeros(n_params)
    dists = [DISTRIBUTIONS["uniform"]] * n_params
    for e, k in zip(tolerances.entries, index):
        scale[k] = e.value
        dists[k] = e.distribution
    return ToleranceSource(scale, tuple(dists), seed)


def check_arguments(samples, seed, target=None, target_probability: float = 0.95, sobol_samples=None
                    ) -> tuple[int, int]:
    """Check the size, seed and target of a tolerance study before any work.

    Parameters
    ----------
    samples : int
        Monte Carlo draws (>= 2).
    seed : int
        Seed (>= 0).
    target : float, optional
        Target ``T`` [m] (> 0).
    target_probability : float, default 0.95
        Strictly between 0 and 1.
    sobol_samples : int, optional
        A power of 2 (at least 4), or None / 0 for none.

    Returns
    -------
    tuple of int
        ``samples`` and ``seed``.

    Raises
    ------
    InputError
        Naming the parameter that is out of range.
    """
    if isinstance(samples, bool) or not float(samples).is_integer() or samples < 2:
        raise InputError(f"samples must be a whole number >= 2, got {samples!r}", parameters=("samples",))
    if isinstance(seed, bool) or int(seed) != seed or seed < 0:
        raise InputError(f"seed must be a non-negative whole number, got {seed!r}", parameters=("seed",))
    if target is not None and not (isinstance(target, (int, float)) and math.isfinite(target) and target > 0):
        raise InputError(f"target must be a positive length, got {target!r}", parameters=("target",))
    if not 0 < target_probability < 1:
        raise InputError(f"target_probability must lie between 0 and 1, got {target_probability!r}",
                         parameters=("target_probability",))
    n = sobol_samples
    if n and (isinstance(n, bool) or int(n) != n or n < 4 or int(n) & (int(n) - 1)):
        raise InputError(f"sobol_samples must be a power of 2 (at least 4), got {n!r}", parameters=("sobol_samples",))
    require_memory(samples * 24.0, f"a study of {samples:,} draws", ("samples",))
    return int(samples), int(seed)


def study_tolerances(machine: Machine, tolerances: Tolerances, q: np.ndarray, *, samples: int = 10_000,
                     seed: int = 0, target: float | None = None, target_probability: float = 0.95,
                     sobol_samples: int | None = 256, reallocation: bool = True, engine: Engine | None = None,
                     progress=None) -> ToleranceStudy:
    """Monte Carlo over the tolerances of every component, on a grid.

    Parameters
    ----------
    machine : Machine
        The machine (geometry, state); its own error values are not used.
    tolerances : Tolerances
        One per component (:func:`~volerr_pin.studies.tolerances.read_tolerance_file`).
    q : ndarray, shape (N, n_axes)
        Grid of NC positions [m, rad].
    samples : int, default 10000
        Monte Carlo draws.
    seed : int, default 0
        Seed (chunk ``k`` draws from ``SeedSequence(seed, spawn_key=(k,))``; Sobol' design
        and re-simulations from seeds derived from it).
    target : float, optional
        Largest admissible position error ``T`` [m].
    target_probability : float, default 0.95
        Probability the re-allocation must meet ``T`` with.
    sobol_samples : int or None, default 256
        Base samples N of the Sobol' design (a power of 2; ``N (D + 2)`` runs for D
        toleranced components); None or 0 skips the indices.
    reallocation : bool, default True
        Suggest a re-allocation (needs ``target``).
    engine : Engine, optional
        Where the runs go (default this process).
    progress : callable(stage, done, total), optional
        Called as tasks finish.

    Returns
    -------
    ToleranceStudy
        The distribution, the probability, the drivers and the suggestion.

    Raises
    ------
    InputError
        If ``samples`` is not a whole number >= 2, ``seed`` is negative, ``target`` is not a
        positive length, ``target_probability`` is not between 0 and 1, ``sobol_samples`` is
        not a power of 2, the tolerances are not those of this machine, or ``q`` is invalid.
    """
    samples, seed = check_arguments(samples, seed, target, target_probability, sobol_samples)
    if tolerances.components != machine.components:
        raise InputError(f"tolerances: {tolerances.source} gives the components {', '.join(tolerances.components)}, "
                         f"not those of {machine.name}", parameters=("tolerances",))
    engine = engine or InProcess()
    constant, index = tolerance_machine(machine)
    points = make_points(constant, q)
    source = tolerance_source(tolerances, index, len(constant.parameter_names), int(seed))
    stage = (lambda name: (lambda done, total: progress(name, done, total))) if progress else (lambda name: None)
    run = run_monte_carlo(constant, source, points, samples, engine=engine, per_point=False,
                          progress=stage("Monte Carlo"))
    indices = None
    active = [k for k, e in enumerate(tolerances.entries) if e.value > 0]
    if sobol_samples and active:
        runs = sobol_samples * (len(active) + 2)
        require_memory(runs * (len(active) + len(constant.parameter_names) + 4) * 8.0,
                       f"a Sobol' design of {runs:,} runs", ("sobol_samples",))
        problem = {"num_vars": len(active), "names": [tolerances.entries[k].component for k in active],
                   "bounds": [], "dists": []}
        for k in active:
            e = tolerances.entries[k]
            name, bound = e.distribution.salib(e.value)
            problem["dists"].append(name)
            problem["bounds"].append(bound)

        def model(X: np.ndarray) -> np.ndarray:
            rows = np.zeros((len(X), len(constant.parameter_names)))
            rows[:, index[active]] = X
            return run_monte_carlo(constant, RowsSource(rows), points, len(X), engine=engine, per_point=False,
                                   progress=stage("Sobol' indices")).max

        indices = sobol_indices(problem, model, sobol_samples, seed)
    suggestion = None
    if reallocation and target is not None and active:
        suggestion = reallocate(constant, tolerances, index, points, source, target, target_probability, run,
                                samples=samples, seed=int(seed), engine=engine, progress=progress)
    return ToleranceStudy(machine.name, tolerances, points.n, samples, int(seed), engine.workers, run, target,
                          target_probability, indices, suggestion)
