"""The Monte Carlo kernel of the studies: a machine's position error at a set of points for
many coefficient vectors, chunked by samples x point blocks, folded in task order.

A study evaluates, for every sample ``s`` (a coefficient vector ``theta_s`` drawn by a
:class:`ThetaSource`) and every point ``i``::

    f_s(i) = e(q_i, theta_s)[:3] + offset_i        (m)

the position part of the exact volumetric error (:func:`~volerr_pin.model.volumetric_error`), plus a
fixed offset (zero for an error map; for the residual after a compensation the nominal
displacement from the desired to the commanded position). Each task (a chunk of
:data:`SAMPLE_CHUNK` samples x a block of :data:`POINT_BLOCK` points) returns, per sample,
the largest ``|f|`` over its block (and where) and the sum of ``|f|^2``; per point, the sums
and sums of squares of ``fx, fy, fz, |f|`` over its samples (about a reference value, for
accuracy). A task holds one block's errors for one sample at a time: about ``POINT_BLOCK``
x 14 doubles (1 MB), whatever the study's size. The fold keeps, per sample, the worst point
and the mean square over all points; per point, the mean and standard deviation over all
samples. Maxima are exact; sums are added in task order, so the numbers do not depend on the
engine or the number of workers.

Coverage intervals at every point need the samples' values there together:
:func:`point_quantiles` evaluates the first ``m`` samples (the same draws) block by block,
each task holding ``m`` x block x 4 doubles (at most :data:`QUANTILE_TASK_BYTES`).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from ..base import InputError, require_memory
from ..model import Machine, check_covariates, check_q, check_theta, volumetric_error
from ._evaluator import CALL_POINTS, evaluator_of
from ._engine import Engine, InProcess, PortableMachine, chunk_rng, plan_chunks, tasks_of

__all__ = ["MonteCarlo", "NormalSource", "POINT_BLOCK", "Points", "QUANTILE_TASK_BYTES", "RowsSource", "SAMPLE_CHUNK",
           "ThetaSource", "grid_points", "make_points", "point_quantiles", "run_monte_carlo"]

#: samples per task: what the random streams are cut by (results depend on it, not on workers)
SAMPLE_CHUNK = 256
#: points per task (the kernels' block; a task's memory is about 14 doubles per point)
POINT_BLOCK = 8192
#: the largest array a coverage-interval task holds [bytes]
QUANTILE_TASK_BYTES = 32 << 20


class ThetaSource(Protocol):
    """Where the coefficient vectors of a study come from.

    Attributes
    ----------
    parameters : int
        Length P of each vector.
    """

    parameters: int

    def rows(self, chunk: int, start: int, stop: int) -> np.ndarray:
        """The coefficient vectors of samples ``start`` to ``stop``.

        Parameters
        ----------
        chunk : int
            Index of the chunk the samples belong to (random sources draw from its stream).
        start, stop : int
            Sample range.

        Returns
        -------
        ndarray, shape (stop - start, P)
            Coefficient vectors [SI].
        """
        ...


@dataclass(frozen=True)
class NormalSource(ThetaSource):
    """Coefficients drawn from a multivariate normal: ``mean + factor @ z``, ``z`` standard normal.

    Attributes
    ----------
    mean : ndarray, shape (P,)
        The mean (the estimate) [SI].
    factor : ndarray, shape (P, r)
        A square root of the covariance (``factor @ factor.T``) [SI].
    seed : int
        The study's seed.

    Notes
    -----
    The methods of :class:`ThetaSource` (documented there) do
    here:

    - ``rows``: draws of chunk ``chunk`` (its own random stream).
    """

    mean: np.ndarray
    factor: np.ndarray
    seed: int

    @property
    def parameters(self) -> int:
        """Length of the coefficient vector (int)."""
        return len(self.mean)

    def rows(self, chunk: int, start: int, stop: int) -> np.ndarray:
        z = chunk_rng(self.seed, chunk).standard_normal((stop - start, self.factor.shape[1]))
        return self.mean + z @ self.factor.T


@dataclass(frozen=True)
class RowsSource(ThetaSource):
    """Coefficient vectors given in advance (a design such as Saltelli's).

    Attributes
    ----------
    matrix : ndarray, shape (S, P)
        One row per sample [SI].

    Notes
    -----
    The methods of :class:`ThetaSource` (documented there) do
    here:

    - ``rows``: rows ``start`` to ``stop``.
    """

    matrix: np.ndarray

    @property
    def parameters(self) -> int:
        """Length of the coefficient vector (int)."""
        return self.matrix.shape[1]

    def rows(self, chunk: int, start: int, stop: int) -> np.ndarray:
        return self.matrix[start:stop]


@dataclass(frozen=True)
class Points:
    """Where a study evaluates the machine.

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        NC positions to evaluate at [m, rad].
    offset : ndarray, shape (N, 3)
        Added to the position error [m] (zeros for an error map).
    reference : ndarray, shape (N, 4)
        ``fx, fy, fz, |f|`` at the nominal coefficients [m]: the sums are taken about it.
    extrapolate : bool
        Whether ``q`` may leave the travel (compensated commands at its ends).
    key : str
        Identifies ``q`` and ``extrapolate`` (a digest): workers keep the error terms' bases of
        a block under it.
    """

    q: np.ndarray
    offset: np.ndarray
    reference: np.ndarray
    extrapolate: bool = False
    key: str = ""

    @property
    def scatter_key(self) -> str:
        """Names the whole content (positions, offsets, reference): an engine keeps the points on
        its workers under it (str)."""
        digest = hashlib.sha1(self.key.encode() + np.ascontiguousarray(self.offset).tobytes()
                              + np.ascontiguousarray(self.reference).tobytes()).hexdigest()
        return "points-" + digest

    @property
    def n(self) -> int:
        """Number of points (int)."""
        return len(self.q)


def make_points(machine: Machine, q: np.ndarray, theta=None, offset=None, extrapolate: bool = False) -> Points:
    """:class:`Points` at ``q`` with their reference values at ``theta``.

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : array_like, shape (P,), optional
        Coefficients of the reference values (default the machine's).
    offset : ndarray, shape (N, 3), optional
        Added to the position error [m] (default zero).
    extrapolate : bool, default False
        Allow positions outside the travel.

    Returns
    -------
    Points
        The points, their positions checked (the study's tasks evaluate them unchecked).

    Raises
    ------
    InputError
        If ``q`` or ``theta`` is invalid (:func:`~volerr_pin.model.check_q`,
        :func:`~volerr_pin.model.check_theta`).
    """
    model = machine.model
    q = check_q(model, q, extrapolate)
    offset = np.zeros((len(q), 3)) if offset is None else np.asarray(offset, dtype=float)
    theta = machine.theta if theta is None else check_theta(model, theta)
    f = volumetric_error(model, q, theta, check_covariates(model, len(q), None, machine.state))[:, :3] + offset
    key = hashlib.sha1(np.ascontiguousarray(q).tobytes() + bytes([extrapolate])).hexdigest()
    return Points(q, offset, np.column_stack([f, np.linalg.norm(f, axis=1)]), extrapolate, key)


def _values(machine: PortableMachine, points: Points, thetas: np.ndarray, block: tuple) -> np.ndarray:
    """(n, nb, 4): fx, fy, fz, |f| of every vector at the points of ``block``."""
    _, p0, p1 = block
    evaluator = evaluator_of(machine.key, machine.machine())
    f = evaluator.errors(points.q[p0:p1], thetas, key=(points.key, p0, p1))
    f += points.offset[p0:p1]
    return np.concatenate([f, np.sqrt(np.einsum("sij,sij->si", f, f))[..., None]], axis=2)


def evaluate_task(machine: PortableMachine, source: ThetaSource, points: Points, chunk: tuple, block: tuple,
                  per_point: bool) -> dict:
    """One task: the samples of ``chunk`` at the points of ``block``.

    Parameters
    ----------
    machine : PortableMachine
        The machine.
    source : ThetaSource
        The coefficient vectors.
    points : Points
        All the study's points.
    chunk : tuple of int
        ``(index, start, stop)`` of the samples.
    block : tuple of int
        ``(index, start, stop)`` of the points.
    per_point : bool
        Also return the per-point sums.

    Returns
    -------
    dict
        ``max`` (n,) largest ``|f|`` over the block [m], ``argmax`` (n,) its point index,
        ``sumsq`` (n,) sum of ``|f|^2`` over the block [m^2]; with ``per_point``, ``sum`` and
        ``sumsq_points`` (nb, 4) over the samples, about ``points.reference`` [m, m^2].
    """
    k, s0, s1 = chunk
    _, p0, p1 = block
    theta = source.rows(k, s0, s1)
    n = s1 - s0
    out = {"max": np.empty(n), "argmax": np.empty(n, dtype=np.int64), "sumsq": np.empty(n)}
    if per_point:
        ref = points.reference[p0:p1]
        total = np.zeros((p1 - p0, 4))
        total2 = np.zeros((p1 - p0, 4))
    step = max(1, CALL_POINTS // max(1, p1 - p0))
    for a in range(0, n, step):
        b = min(n, a + step)
        v = _values(machine, points, theta[a:b], block)
        norm = v[:, :, 3]
        j = np.argmax(norm, axis=1)
        out["max"][a:b] = norm[np.arange(b - a), j]
        out["argmax"][a:b] = p0 + j
        out["sumsq"][a:b] = np.einsum("si,si->s", norm, norm)
        if per_point:
            for d in v - ref:  # in sample order: the same sums whatever the batch
                total += d
                total2 += d * d
    if per_point:
        out["sum"], out["sumsq_points"] = total, total2
    return out


@dataclass(frozen=True)
class MonteCarlo:
    """What a Monte Carlo run over a set of points found (SI).

    Attributes
    ----------
    samples : int
        Number of samples S.
    max : ndarray, shape (S,)
        Per sample, the largest position error ``|f|`` over the points [m].
    argmax : ndarray of int, shape (S,)
        Per sample, the point where it is (the first such point).
    rms : ndarray, shape (S,)
        Per sample, the RMS of ``|f|`` over the points [m].
    mean : ndarray, shape (N, 4) or None
        Per point, the mean of ``fx, fy, fz, |f|`` over the samples [m].
    std : ndarray, shape (N, 4) or None
        Per point, their standard deviation (n - 1) [m]; None with one sample.
    """

    samples: int
    max: np.ndarray
    argmax: np.ndarray
    rms: np.ndarray
    mean: np.ndarray | None = None
    std: np.ndarray | None = None


def _check_samples(samples) -> int:
    if isinstance(samples, bool) or not float(samples).is_integer() or samples < 1:
        raise InputError(f"samples must be a positive whole number, got {samples!r}", parameters=("samples",))
    return int(samples)


def run_monte_carlo(machine: Machine, source: ThetaSource, points: Points, samples: int, *,
                    engine: Engine | None = None, per_point: bool = True, chunk: int = SAMPLE_CHUNK,
                    block: int = POINT_BLOCK, progress: Callable[[int, int], None] | None = None) -> MonteCarlo:
    """Evaluate ``samples`` coefficient vectors at every point and fold the results.

    Parameters
    ----------
    machine : Machine
        The machine (its coefficient layout; the vectors come from ``source``).
    source : ThetaSource
        The coefficient vectors, P = ``len(machine.parameter_names)``.
    points : Points
        Where to evaluate.
    samples : int
        Number of samples (>= 1).
    engine : Engine, optional
        Where the tasks run (default :class:`InProcess`).
    per_point : bool, default True
        Also the per-point means and standard deviations.
    chunk : int, default SAMPLE_CHUNK
        Samples per task (the draws depend on it).
    block : int, default POINT_BLOCK
        Points per task.
    progress : callable(done, total), optional
        Called as tasks finish.

    Returns
    -------
    MonteCarlo
        Per sample the worst point and the RMS; per point the mean and standard deviation.

    Raises
    ------
    InputError
        If ``samples`` is not a positive whole number, the source's vectors do not fit the
        machine, or the per-sample results would not fit in memory.
    """
    samples = _check_samples(samples)
    if source.parameters != len(machine.parameter_names):
        raise InputError(f"the coefficient vectors have {source.parameters} entries; {machine.name} has "
                         f"{len(machine.parameter_names)}")
    require_memory(samples * 24.0 + points.n * 100.0, f"a study of {samples:,} samples at {points.n:,} points",
                   ("samples", "grid"))
    engine = engine or InProcess()
    chunks = plan_chunks(samples, chunk)
    blocks = plan_chunks(points.n, block)
    tasks = [(c, b, per_point) for c, b in tasks_of(chunks, blocks)]
    smax = np.zeros(samples)
    sarg = np.zeros(samples, dtype=np.int64)
    ssum = np.zeros(samples)
    psum = np.zeros((points.n, 4)) if per_point else None
    psq = np.zeros((points.n, 4)) if per_point else None
    report = (lambda done: progress(done, len(tasks))) if progress else None
    results = engine.map(evaluate_task, (PortableMachine(machine), source, points), tasks, report)
    for (c, b, _), part in zip(tasks, results):
        rows = slice(c[1], c[2])
        if b[0] == 0:
            smax[rows], sarg[rows], ssum[rows] = part["max"], part["argmax"], part["sumsq"]
        else:
            better = part["max"] > smax[rows]
            smax[rows] = np.where(better, part["max"], smax[rows])
            sarg[rows] = np.where(better, part["argmax"], sarg[rows])
            ssum[rows] += part["sumsq"]
        if per_point:
            psum[b[1]:b[2]] += part["sum"]
            psq[b[1]:b[2]] += part["sumsq_points"]
    mean = std = None
    if per_point:
        mean = points.reference + psum / samples
        std = (np.sqrt(np.clip(psq - psum**2 / samples, 0.0, None) / (samples - 1)) if samples > 1 else None)
    return MonteCarlo(samples, smax, sarg, np.sqrt(ssum / points.n), mean, std)


def quantile_task(machine: PortableMachine, source: ThetaSource, points: Points, samples: int, chunk: int,
                  probabilities: tuple, block: tuple) -> np.ndarray:
    """Quantiles over the first ``samples`` samples at the points of ``block``.

    Parameters
    ----------
    machine : PortableMachine
        The machine.
    source : ThetaSource
        The coefficient vectors.
    points : Points
        All the study's points.
    samples : int
        How many samples (the first ones).
    chunk : int
        Samples per chunk (as in the run, so that the draws are the same).
    probabilities : tuple of float
        The quantiles' probabilities.
    block : tuple of int
        ``(index, start, stop)`` of the points.

    Returns
    -------
    ndarray, shape (nb, 4, len(probabilities))
        Quantiles of ``fx, fy, fz, |f|`` at each point [m].
    """
    _, p0, p1 = block
    values = np.empty((samples, p1 - p0, 4))
    for k, s0, s1 in plan_chunks(samples, chunk):
        values[s0:s1] = _values(machine, points, source.rows(k, s0, s1), block)
    return np.moveaxis(np.quantile(values, probabilities, axis=0), 0, -1)


def point_quantiles(machine: Machine, source: ThetaSource, points: Points, samples: int,
                    probabilities=(0.025, 0.975), *, engine: Engine | None = None, chunk: int = SAMPLE_CHUNK,
                    progress: Callable[[int, int], None] | None = None) -> np.ndarray:
    """Quantiles of the position error at every point over the first ``samples`` samples.

    Parameters
    ----------
    machine : Machine
        The machine.
    source : ThetaSource
        The coefficient vectors (the same draws as :func:`run_monte_carlo` with ``chunk``).
    points : Points
        Where.
    samples : int
        How many samples (>= 2).
    probabilities : sequence of float, default (0.025, 0.975)
        The quantiles' probabilities (a 95 % probabilistically symmetric interval).
    engine : Engine, optional
        Where the tasks run (default :class:`InProcess`).
    chunk : int, default SAMPLE_CHUNK
        Samples per chunk of the draws.
    progress : callable(done, total), optional
        Called as tasks finish.

    Returns
    -------
    ndarray, shape (N, 4, len(probabilities))
        Quantiles of ``fx, fy, fz, |f|`` [m].

    Raises
    ------
    InputError
        If ``samples`` is below 2.
    """
    samples = _check_samples(samples)
    if samples < 2:
        raise InputError(f"interval_samples must be >= 2, got {samples}", parameters=("interval_samples",))
    per_point = samples * 4 * 8
    if per_point > QUANTILE_TASK_BYTES:
        raise InputError(f"interval_samples: {samples:,} samples at one point need more than "
                         f"{QUANTILE_TASK_BYTES >> 20} MB", parameters=("interval_samples",))
    engine = engine or InProcess()
    size = max(1, min(POINT_BLOCK, QUANTILE_TASK_BYTES // per_point))
    blocks = plan_chunks(points.n, size)
    report = (lambda done: progress(done, len(blocks))) if progress else None
    shared = (PortableMachine(machine), source, points, samples, chunk, tuple(float(p) for p in probabilities))
    out = np.empty((points.n, 4, len(probabilities)))
    for b, part in zip(blocks, engine.map(quantile_task, shared, [(b,) for b in blocks], report)):
        out[b[1]:b[2]] = part
    return out


def grid_points(machine: Machine, counts) -> np.ndarray:
    """The study grid: a full-factorial grid over every axis' travel (ends included).

    Parameters
    ----------
    machine : Machine
        The machine.
    counts : int or sequence of int
        Points per axis: one count for every axis, or one per axis (>= 1; an axis with one
        point sits at mid travel).

    Returns
    -------
    ndarray, shape (N, n_axes)
        NC positions [m, rad], N the product of the counts.

    Raises
    ------
    InputError
        Naming ``grid``, if a count is below 1, there are neither one nor ``n_axes`` counts,
        or the grid would not fit in memory.
    """
    from ..model import grid

    counts = [int(c) for c in np.atleast_1d(counts)]
    n_axes = len(machine.axes)
    if len(counts) == 1:
        counts = counts * n_axes
    if len(counts) != n_axes or min(counts) < 1:
        raise InputError(f"grid: give 1 or {n_axes} counts of at least 1 (axes {', '.join(machine.axes)}), got "
                         f"{counts}", parameters=("grid",))
    total = float(np.prod(np.array(counts, dtype=float)))
    require_memory(total * n_axes * 8 * 12, f"a workspace of {total:,.0f} points", ("grid",))
    return grid(machine, tuple(counts))
