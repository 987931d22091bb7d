"""Tolerance studies: which component tolerances a machine can afford.

Every component error is drawn within its tolerance (:mod:`._tolerances`) as the shape the
standard means by it (:mod:`._shapes`): a positioning error or a straightness deviation along
the travel, less the offset (and, for straightness, the slope) they exclude; an angular
deviation less its offset; a rotary axis' error motions over its angle; a squareness or other
location error as the constant it is. What a work offset removes is left out: a component
whose effect is the same translation everywhere is not drawn. The machine's own terms are
replaced by these shapes. For every draw the exact volumetric error is
evaluated at every grid point; the study reports the distribution of the largest and of the
RMS position error over the grid, the probability that the largest stays within a target
``T``, the components that drive it (Sobol' first-order and total indices of the largest
error, :mod:`._sobol`) and a least-cost re-allocation of the tolerances that meets ``T`` at a
stated probability, checked by re-simulation (:mod:`._allocation`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base import UM_PER_M, InputError, require_memory
from ..model import Machine
from ._allocation import Reallocation, reallocate
from ._engine import Engine, InProcess
from ._montecarlo import make_points, MonteCarlo, run_monte_carlo, ThetaSource
from ._shapes import LEFT_OUT, Shape, ShapedSource, shape_machine, shapes_of, work_offset_components
from ._sobol import SobolIndices, sobol_indices
from ._tolerances import Tolerances

__all__ = ["DesignSource", "ToleranceStudy", "check_arguments", "study_tolerances", "tolerance_source"]


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
    shapes : tuple of Shape
        How each component was drawn.
    left_out : tuple of str
        The components not drawn: a work offset removes them.
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
    shapes: tuple[Shape, ...] = ()
    left_out: tuple[str, ...] = ()

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
            ``sobol_resolution`` (:meth:`~volerr_pin.studies._sobol.SobolIndices.resolution`; null
            without indices), ``tolerances``, ``reallocation``, ``shapes`` (per component
            ``component``, ``shape``, ``excludes``, ``basis``) and ``left_out`` (per component
            left out, ``component`` and ``reason``).
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
                "reallocation": None if self.reallocation is None else self.reallocation.to_dict(),
                "shapes": [{"component": s.component, "shape": s.name, "excludes": s.excluded, "basis": s.basis}
                           for s in self.shapes],
                "left_out": [{"component": c, "reason": LEFT_OUT} for c in self.left_out]}


def tolerance_source(machine: Machine, tolerances: Tolerances, seed: int) -> tuple[Machine, ShapedSource]:
    """The study's machine and its draws: every component as its shape (:mod:`._shapes`), within
    its tolerance.

    Parameters
    ----------
    machine : Machine
        The machine (its state is kept; its own error values are not used).
    tolerances : Tolerances
        One per component.
    seed : int
        The study's seed.

    Returns
    -------
    machine : Machine
        The machine with every component's terms replaced by its shape's, all zero.
    source : ShapedSource
        The draws.
    """
    shapes = shapes_of(machine)
    shaped, columns = shape_machine(machine, shapes)
    return shaped, ShapedSource(shapes, columns, tolerances.values, tuple(e.distribution for e in tolerances.entries),
                                len(shaped.parameter_names), int(seed))


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
        One per component (:func:`~volerr_pin.studies.read_tolerance_file`).
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
    shaped, source = tolerance_source(machine, tolerances, int(seed))
    points = make_points(shaped, q)
    left_out = work_offset_components(shaped, source.columns, points.q, source.shapes)
    drawn = tolerances.values.copy()
    drawn[left_out] = 0.0
    source = source.with_tolerance(drawn)
    stage = (lambda name: (lambda done, total: progress(name, done, total))) if progress else (lambda name: None)
    run = run_monte_carlo(shaped, source, points, samples, engine=engine, per_point=False,
                          progress=stage("Monte Carlo"))
    indices = None
    active = [k for k in range(len(drawn)) if drawn[k] > 0]
    if sobol_samples and active:
        problem = source.design_problem(active, [tolerances.entries[k].component for k in active])
        runs = sobol_samples * (len(active) + 2)
        require_memory(runs * (problem["num_vars"] + 4) * 8.0, f"a Sobol' design of {runs:,} runs",
                       ("sobol_samples",))

        def model(X: np.ndarray) -> np.ndarray:
            return run_monte_carlo(shaped, DesignSource(source, X, tuple(active)), points, len(X), engine=engine,
                                   per_point=False, progress=stage("Sobol' indices")).max

        indices = sobol_indices(problem, model, sobol_samples, seed)
    suggestion = None
    if reallocation and target is not None and active:
        suggestion = reallocate(shaped, tolerances, points, source, target, target_probability, run,
                                samples=samples, seed=int(seed), engine=engine, progress=progress,
                                left_out=left_out)
    return ToleranceStudy(machine.name, tolerances, points.n, samples, int(seed), engine.workers, run, target,
                          target_probability, indices, suggestion, source.shapes,
                          tuple(tolerances.entries[k].component for k in left_out))


@dataclass(frozen=True)
class DesignSource(ThetaSource):
    """The coefficient vectors of a design (Saltelli's), made where they are evaluated: only the
    design's inputs travel (a few numbers per component and run), not the vectors.

    Attributes
    ----------
    source : ShapedSource
        The study's shapes.
    design : ndarray, shape (runs, inputs)
        Per active component its magnitude, then its shape's uniform numbers.
    active : tuple of int
        The components the design varies.

    Notes
    -----
    The methods of :class:`~volerr_pin.studies._montecarlo.ThetaSource` (documented there) do
    here:

    - ``rows``: coefficient vectors of runs ``start`` to ``stop`` (ThetaSource).
    """

    source: ShapedSource
    design: np.ndarray
    active: tuple[int, ...]

    @property
    def parameters(self) -> int:
        """Length of the coefficient vector (int)."""
        return self.source.parameters

    def rows(self, chunk: int, start: int, stop: int) -> np.ndarray:
        return self.source.design_rows(self.design[start:stop], self.active)
