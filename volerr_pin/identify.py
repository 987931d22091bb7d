"""Identification of error-term coefficients from measurements, with an honest report.

Any mix of point measurements (tool against workpiece) and axis runs (positioning,
straightness, angular) becomes one set of weighted observations ``y = w . e(q) + nuisance``
where ``w`` picks the measured error direction and the nuisance terms are the instrument's
zero (every run) and its alignment slope (straightness runs). Before fitting,
:func:`volerr_pin.identifiability.analyse` finds what the data cannot determine; those
coefficients are held at their prior values (``convention="prior"``, the default) or the
update is the minimum-norm one (``"min-norm"``). The fit is weighted Gauss-Newton on the
exact sensitivities; uncertainties come from the covariance scaled by the residual; the
held-out RMS from k-fold cross-validation over poses (points at the same positions stay
together).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .errors import InputError
from .identifiability import Analysis, analyse
from .machine import Machine
from .measurements.protocol import Measurement, ObservationBlock, ObservationOptions
from .safeio import require_memory
from .units import UM_PER_M, URAD_PER_RAD
from .workspace import _fraction, _integer, _positive

#: above this condition number of the column-scaled design, rounding (about condition x 2.2e-16
#: of the coefficients' scale) reaches 1e-4: fewer than four of double precision's sixteen
#: digits are left along the weakest direction, and a fit says so
CONDITION_LIMIT = 1e12
#: largest observation a fit takes, in standard deviations: far beyond any measurement (1e94 m
#: at 1 um), and far enough below overflow (1e154) that the sums of squares of residuals and
#: trial residuals stay finite
WEIGHTED_LIMIT = 1e100


@dataclass
class Observations:
    """Weighted observations of a machine's error, ready for the solver (SI).

    ``q`` and ``covariates`` per point; one row per observation with its point ``point``,
    6-vector ``w`` (prediction ``w . e(q_point)``), value ``y``, standard deviation ``sigma``,
    ``angular`` flag, and the nuisance design ``nuisance`` with names ``nuisance_names``;
    ``sources`` and ``lines`` say where each row came from.

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        NC positions of the points [m, rad].
    covariates : dict
        Keyword covariates of the points for :meth:`Machine.volumetric_error` (``t`` (N,) [s],
        ``temperatures`` {sensor: (N,)} [degC], ``forces`` (N, 3) [N], ``directions`` (N, n_axes)).
    point : ndarray of int, shape (rows,)
        The point each observation row belongs to.
    w : ndarray, shape (rows, 6)
        Weights of the error components dx, dy, dz, rx, ry, rz in each observation.
    y : ndarray, shape (rows,)
        Observed values [m or rad].
    sigma : ndarray, shape (rows,)
        Standard deviations of the observations [m or rad].
    angular : ndarray of bool, shape (rows,)
        True for rotation observations (rad), False for position ones (m).
    nuisance : ndarray, shape (rows, n_nuisance)
        Design of the nuisance terms (instrument zero, alignment slope, tracker placement,
        ballbar set-up).
    nuisance_names : list of str
        Names of the nuisance columns (e.g. ``offset[positioning run FILE]``).
    sources : list of str
        File of each row.
    lines : ndarray, shape (rows,)
        File line (or sample index) of each row.
    nuisance_angular : ndarray of bool, shape (n_nuisance,), optional
        True for nuisance terms in rad (reported in urad). Default: a term is angular when a
        row it acts on is.
    pose : ndarray of int, shape (N,), optional
        The pose of every point (the points of one pose are held out together). Default:
        points at the same positions (to 1e-12) are one pose.
    """

    q: np.ndarray
    covariates: dict
    point: np.ndarray
    w: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    angular: np.ndarray
    nuisance: np.ndarray
    nuisance_names: list[str]
    sources: list[str]
    lines: np.ndarray
    nuisance_angular: np.ndarray | None = None
    pose: np.ndarray | None = None

    def __post_init__(self):
        if self.nuisance_angular is None:
            self.nuisance_angular = np.array([bool(np.any(self.angular[self.nuisance[:, c] != 0]))
                                              for c in range(np.shape(self.nuisance)[1])], dtype=bool)

    @property
    def n_points(self) -> int:
        """Number of points (rows of ``q``), int."""
        return len(self.q)

    def subset(self, points: np.ndarray) -> "Observations":
        """The observations of the given points (nuisance columns kept).

        Parameters
        ----------
        points : ndarray of int, shape (M,)
            Indices of the points to keep, in the order the new points take.

        Returns
        -------
        Observations
            The rows of those points, with ``point`` renumbered to 0..M-1.
        """
        keep = np.isin(self.point, points)
        remap = -np.ones(self.n_points, dtype=int)
        remap[points] = np.arange(len(points))
        cov = _take_covariates(self.covariates, points)
        return Observations(self.q[points], cov, remap[self.point[keep]], self.w[keep], self.y[keep],
                            self.sigma[keep], self.angular[keep], self.nuisance[keep],
                            self.nuisance_names, [s for s, k in zip(self.sources, keep) if k],
                            self.lines[keep], self.nuisance_angular, None if self.pose is None else self.pose[points])

    def poses(self) -> np.ndarray:
        """The pose of every point, numbered from 0 (see :attr:`pose`).

        Returns
        -------
        ndarray of int, shape (N,)
            :attr:`pose` when given, else the index of each point's positions (rounded to
            1e-12) among the distinct positions, in sorted order.
        """
        if self.pose is not None:
            return np.asarray(self.pose)
        _, group = np.unique(np.round(self.q, 12), axis=0, return_inverse=True)
        return group.ravel()


def _take_covariates(cov: dict, idx) -> dict:
    out = {}
    for key, value in cov.items():
        out[key] = {k: v[idx] for k, v in value.items()} if isinstance(value, dict) else value[idx]
    return out


def build_observations(machine: Machine, data, *, sigma_um: float = 1.0, sigma_urad: float = 1.0,
                       run_axis: str | None = None, run_at: dict[str, float] | None = None
                       ) -> Observations:
    """Turn measurements into observations: each measurement gives its own block (see
    :class:`~volerr_pin.measurements.protocol.Measurement`), stacked here.

    Point measurements observe each measured deviation direction. Runs: the moving axis is
    the run's (or ``run_axis``); the other axes stand at the run's ``# at:`` positions,
    ``run_at`` (mm / deg), or mid travel (rotary axes at 0). A positioning run observes the
    error along the axis' own motion; a component run the component's direction. Every run
    file gets an offset (the instrument zero); straightness runs also a slope (the reference
    line's alignment). A tracker file gets six nuisance terms (a small translation and
    rotation of the tracker), a ballbar file three (the set-up's centre offset along both
    plane axes and the bar's length error).

    Parameters
    ----------
    machine : Machine
        The machine observed.
    data : iterable of measurements, or one measurement
        Objects following :class:`~volerr_pin.measurements.protocol.Measurement`:
        :class:`~volerr_pin.measurements.points.PointMeasurements`,
        :class:`~volerr_pin.measurements.runs.Runs`,
        :class:`~volerr_pin.measurements.tracker.TrackerMeasurements`,
        :class:`~volerr_pin.measurements.ballbar.BallbarRun`, or a registered kind's.
    sigma_um : float, default 1.0
        Standard deviation of position observations [um].
    sigma_urad : float, default 1.0
        Standard deviation of rotation observations [urad].
    run_axis : str, optional
        Moving axis of runs that do not name it.
    run_at : dict of str to float, optional
        Positions of the other axes during runs [mm, deg]; overrides the files' ``# at:``.

    Returns
    -------
    Observations
        The stacked observations; covariates given by some files only are merged (see the
        warnings and errors below).

    Raises
    ------
    InputError
        If ``sigma_um`` or ``sigma_urad`` is not positive and finite, a run's axis is unknown
        or not given, its target unit does not fit the axis kind, its positions leave the
        travel, a component run belongs to another axis, an object is not a measurement,
        there are no observations, or a covariate the model reads is missing from some files.
    """
    sigma_um = _positive("sigma_um", sigma_um)
    sigma_urad = _positive("sigma_urad", sigma_urad)
    options = ObservationOptions(sigma_um, sigma_urad, run_axis, run_at)
    if isinstance(data, Measurement):
        data = [data]  # one measurement object
    blocks = []
    for item in data:
        if not isinstance(item, Measurement):
            raise InputError(f"cannot use {type(item).__name__} as measurements")
        blocks.append(item.observations(machine, options))
    return stack_blocks(blocks, machine)


def stack_blocks(blocks: list[ObservationBlock], machine: Machine) -> Observations:
    """The observations of several measurements as one set: points, rows and nuisance columns
    in the order of the blocks.

    Parameters
    ----------
    blocks : list of ObservationBlock
        The measurements' observations.
    machine : Machine
        The machine observed (which covariates it reads).

    Returns
    -------
    Observations
        The stacked observations. Poses: the points of a block that gives its ``poses`` keep
        them; all other points at the same commanded positions (to 1e-12) are one pose.

    Raises
    ------
    InputError
        If there are no observation rows, or a covariate the model reads is missing from some
        blocks.
    """
    if not sum(len(b.point) for b in blocks):
        raise InputError("no observations")
    sizes = [len(b.q) for b in blocks]
    q = np.vstack([b.q for b in blocks])
    covariates = _merge_covariates([b.covariates for b in blocks], sizes, machine)
    starts = np.cumsum([0] + sizes)
    rows = np.cumsum([0] + [len(b.point) for b in blocks])
    cols = np.cumsum([0] + [len(b.nuisance_terms) for b in blocks])
    nuisance = np.zeros((int(rows[-1]), int(cols[-1])))
    for k, b in enumerate(blocks):
        nuisance[rows[k]:rows[k + 1], cols[k]:cols[k + 1]] = b.nuisance
    terms = [t for b in blocks for t in b.nuisance_terms]
    return Observations(
        q, covariates, np.concatenate([b.point + start for b, start in zip(blocks, starts)]).astype(int),
        np.vstack([b.w for b in blocks]).astype(float), np.concatenate([b.y for b in blocks]).astype(float),
        np.concatenate([b.sigma for b in blocks]).astype(float),
        np.concatenate([b.angular for b in blocks]).astype(bool), nuisance, [t.name for t in terms],
        [src for b in blocks for src in [b.source] * len(b.point)],
        np.concatenate([b.lines for b in blocks]), np.array([t.angular for t in terms], dtype=bool),
        _stacked_poses(blocks, q, starts))


def _stacked_poses(blocks: list[ObservationBlock], q: np.ndarray, starts: np.ndarray) -> np.ndarray | None:
    """Pose labels over all points; None when no block gives its own (poses are then found by
    position when asked for, :meth:`Observations.poses`)."""
    if all(b.poses is None for b in blocks):
        return None
    pose = np.empty(len(q), dtype=int)
    by_position = np.concatenate([np.arange(starts[k], starts[k + 1]) for k, b in enumerate(blocks)
                                  if b.poses is None] or [np.zeros(0, int)])
    count = 0
    if by_position.size:
        _, group = np.unique(np.round(q[by_position], 12), axis=0, return_inverse=True)
        pose[by_position] = group.ravel()
        count = int(group.max()) + 1
    for k, b in enumerate(blocks):
        if b.poses is not None:
            _, labels = np.unique(np.asarray(b.poses), return_inverse=True)
            pose[starts[k]:starts[k + 1]] = labels.ravel() + count
            count += int(labels.max()) + 1 if labels.size else 0
    return pose


def _merge_covariates(parts: list[dict], sizes: list[int], machine: Machine) -> dict:
    """Stack per-file covariates; a covariate the model reads must be in every file or in none
    (directions default to +1 where a file does not give them); one it does not read and only
    some files give is left out with a warning."""
    keys = set().union(*[p.keys() for p in parts]) if parts else set()
    merged: dict = {}
    for key in keys:
        if key == "directions":
            merged[key] = np.vstack([p.get(key, np.ones((n, len(machine.axes))))
                                     for p, n in zip(parts, sizes)])
            continue
        missing = [i for i, p in enumerate(parts) if key not in p]
        if missing:
            if key in machine.covariates_used:
                raise InputError(f"covariate '{key}' is in some measurement files but not in others "
                                 f"(missing from {len(missing)} of {len(parts)}); the model of "
                                 f"{machine.name} needs it at every point")
            warnings.warn(f"covariate '{key}' is in some measurement files but not in others; "
                          f"{machine.name}'s model does not read it, so it is not used", stacklevel=5)
            continue
        if key == "temperatures":
            sensors = set(parts[0][key])
            if any(set(p[key]) != sensors for p in parts):
                raise InputError("the measurement files name different temperature sensors")
            merged[key] = {s: np.concatenate([p[key][s] for p in parts]) for s in sensors}
        else:
            merged[key] = np.concatenate([p[key] for p in parts])
    return merged


@dataclass
class Identification:
    """Result of :func:`identify`; :meth:`to_dict` gives the JSON report (docs/reports.md).

    Attributes
    ----------
    machine : Machine
        The machine with the fitted coefficients.
    prior : Machine
        The machine as given (prior values).
    free : ndarray of int
        Indices (into theta) of the coefficients that were free to move.
    analysis : Analysis
        Identifiability of the columns [nuisance | free coefficients].
    fitted : ndarray of int
        Indices (into theta) actually fitted.
    held : ndarray of int
        Free but unidentifiable: held at prior (or min-norm).
    uncertainty : ndarray, shape (P,)
        Standard uncertainties (SI unit of each coefficient), NaN where not fitted.
    nuisance : dict of str to float
        Fitted nuisance values (SI: m or rad).
    rms_fit_um : float
        RMS over points of the position residual norm [um] (0.0 without position rows).
    rms_fit_urad : float or None
        Same for the rotation residual [urad]; None without rotation rows.
    rms_holdout_um : float or None
        Held-out RMS of the position residual [um]; None without cross-validation.
    holdout : str
        How the held-out RMS was obtained (or why not).
    n_points : int
        Number of points.
    n_observations : int
        Number of observation rows.
    iterations : int
        Gauss-Newton iterations.
    convention : str
        "prior" or "min-norm".
    residual_sigma : float
        Weighted residual standard deviation (1 = as stated); NaN without degrees of freedom.
    groups : list of IdentifiabilityGroup
        The unidentifiable groups.
    angular_nuisance : frozenset of str
        Names of the nuisance terms in rad (reported in urad).
    solver : str
        "converged", "stalled" or "iteration limit" (see :attr:`solver_text`).
    ill_conditioned : bool
        The column-scaled design is numerically rank-deficient or its condition number
        exceeds :data:`CONDITION_LIMIT`: the fitted values along its weakest directions are
        rounding noise.
    """

    machine: Machine                  # with the fitted coefficients
    prior: Machine
    free: np.ndarray                  # indices of the coefficients that were free to move
    analysis: Analysis                # identifiability of [nuisance | free coefficients]
    fitted: np.ndarray                # indices (into theta) actually fitted
    held: np.ndarray                  # free but unidentifiable: held at prior (or min-norm)
    uncertainty: np.ndarray           # (P,) standard uncertainties, NaN where not fitted
    nuisance: dict[str, float]
    rms_fit_um: float
    rms_fit_urad: float | None
    rms_holdout_um: float | None
    holdout: str
    n_points: int
    n_observations: int
    iterations: int
    convention: str
    residual_sigma: float             # weighted residual standard deviation (1 = as stated)
    groups: list = field(default_factory=list)
    angular_nuisance: frozenset = frozenset()
    solver: str = "converged"         # or "stalled", "iteration limit": see _solve
    ill_conditioned: bool = False     # beyond what double precision resolves: see CONDITION_LIMIT

    @property
    def converged(self) -> bool:
        """True when the solver converged (bool)."""
        return self.solver == "converged"

    @property
    def solver_text(self) -> str:
        """The solver status in words, for reports (str)."""
        return {"converged": "converged",
                "stalled": "stalled (no step lowered the residual the linearised model said it would: "
                           "far from linear here, or ill-conditioned)",
                "iteration limit": "stopped at the iteration limit before converging"}[self.solver]

    def to_dict(self) -> dict:
        """The JSON report (docs/reports.md).

        Returns
        -------
        dict
            ``machine``, ``n_points``, ``n_observations``, ``rank``, ``n_parameters``,
            ``condition_number``, ``ill_conditioned`` (the design is numerically
            rank-deficient or conditioned beyond what double precision resolves),
            ``unidentifiable``, ``convention``, ``solver``,
            ``rms_fit_um``, ``rms_fit_urad``, ``rms_holdout_um``, ``holdout``,
            ``residual_sigma``, ``iterations``, ``nuisance`` (value in um or urad, with its
            ``unit``) and ``parameters``: per coefficient its ``value``, ``prior`` and
            ``uncertainty`` in the spec's display unit, the ``unit`` and a ``status``.
        """
        m, prior = self.machine, self.prior
        params = {}
        units = parameter_units(m)
        for k, name in enumerate(m.parameter_names):
            factor, unit = units[name]
            status = ("fitted" if k in set(self.fitted.tolist()) else
                      "held (not identifiable)" if k in set(self.held.tolist()) else "fixed (not selected)")
            if status == "fitted" and self.solver != "converged":
                status = f"not fitted: the fit {self.solver_text}"
            elif status == "fitted" and self.uncertainty[k] > _undetermined_limit(m, k):
                status = "fitted, not determined (its uncertainty exceeds any plausible value)"
            params[name] = {
                "value": float(m.theta[k] / factor), "prior": float(prior.theta[k] / factor),
                "uncertainty": (float(self.uncertainty[k] / factor) if math.isfinite(self.uncertainty[k])
                                else None),
                "unit": unit, "status": status}
        return {
            "machine": m.name, "n_points": self.n_points, "n_observations": self.n_observations,
            "rank": sum(c >= len(self.nuisance) for c in self.analysis.kept), "n_parameters": int(len(self.free)),
            "condition_number": self.analysis.condition,
            "ill_conditioned": self.ill_conditioned,
            "unidentifiable": [g.to_dict() for g in self.groups],
            "convention": self.convention,
            "solver": self.solver,
            "rms_fit_um": self.rms_fit_um, "rms_fit_urad": self.rms_fit_urad,
            "rms_holdout_um": self.rms_holdout_um, "holdout": self.holdout,
            "residual_sigma": self.residual_sigma, "iterations": self.iterations,
            "nuisance": {n: {"value": v * (URAD_PER_RAD if n in self.angular_nuisance else UM_PER_M),
                             "unit": "urad" if n in self.angular_nuisance else "um"}
                         for n, v in self.nuisance.items()},
            "parameters": params,
        }


def _undetermined_limit(machine: Machine, k: int) -> float:
    """An uncertainty beyond which a coefficient is not determined at all (SI): 10 mm for a
    length, 0.01 rad (0.6 deg) for an angle, ten times its value for a non-linear one."""
    if k in set(machine.nonlinear_parameters):
        return 10.0 * abs(machine.theta[k])
    return 0.01  # m or rad alike (coefficients per newton or per kelvin are far below it)


def parameter_units(machine: Machine) -> dict[str, tuple[float, str]]:
    """Coefficient name -> (SI per display unit, display unit), the spec's units.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    dict of str to tuple of (float, str)
        For every coefficient name, the SI value of one display unit and the unit's name.
    """
    return {name: unit for comp in machine.spec.components for tspec in comp.terms
            for name, unit in zip(tspec.names(comp.name), tspec.term.coefficient_units())}


def predict_observations(machine: Machine, obs: Observations, theta: np.ndarray, free: np.ndarray,
            first_order: bool = False):
    """Prediction of every observation row and its Jacobian with respect to the free coefficients.

    Parameters
    ----------
    machine : Machine
        The machine.
    obs : Observations
        The observations.
    theta : ndarray, shape (P,)
        Coefficients (SI).
    free : ndarray of int, shape (F,)
        Indices of the coefficients to differentiate by.
    first_order : bool, default False
        The Jacobian of the first-order model, where dependencies are exact.

    Returns
    -------
    pred : ndarray, shape (rows,)
        ``w . e(q_point)`` of every row [m or rad] (without the nuisance terms).
    A : ndarray, shape (rows, F)
        d pred / d theta[free] [m or rad per SI unit of the coefficient].
    """
    error = machine.volumetric_error(obs.q, theta, **obs.covariates)
    S = machine.sensitivity(obs.q, theta, parameters=free, first_order=first_order, **obs.covariates)
    return _rows_of(obs.w, obs.point, error, S)


def _rows_of(w: np.ndarray, point: np.ndarray, error: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``w . e`` and ``w . S`` of every row from per-point errors (N, 6) and sensitivities
    (N, 6, F), one error direction at a time: gathering S for every row would take six times
    the memory of the result."""
    pred = np.einsum("rk,rk->r", w, error[point])
    direction = np.argmax(np.abs(w), axis=1)
    if np.array_equal(w, np.eye(6)[direction]):  # each row one error direction (point measurements)
        return pred, S[point, direction, :]
    A = np.zeros((len(point), S.shape[2]))
    for k in range(6):
        if np.any(w[:, k]):
            A += w[:, k, None] * S[point, k, :]
    return pred, A


def _column_scale(J: np.ndarray, rtol: float = 1e-9, typical: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Column norms for scaling, and the columns scaled to unit norm; columns whose effect
    (norm x ``typical`` size of the coefficient, default 1) is negligible against the
    median (below ``rtol`` of it: rounding noise) are zeroed, not blown up."""
    norms = np.linalg.norm(J, axis=0)
    effect = norms if typical is None else norms * typical
    positive = effect[effect > 0]
    floor = rtol * (np.median(positive) if positive.size else 1.0)
    ok = effect > floor
    scale = np.where(ok, norms, 1.0)
    scaled = np.where(ok, J / scale, 0.0)
    return scale, scaled


def _residual(machine: Machine, obs: Observations, theta: np.ndarray, nuisance: np.ndarray) -> np.ndarray:
    """Weighted residual (y - model) / sigma."""
    error = machine.volumetric_error(obs.q, theta, **obs.covariates)
    pred = np.einsum("rk,rk->r", obs.w, error[obs.point])
    return (obs.y - pred - obs.nuisance @ nuisance) / obs.sigma


#: the design is reduced over chunks of points whose sensitivities take about this much memory
CHUNK_BYTES = 48 << 20


def _point_chunks(obs: Observations, n_columns: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Chunks of points whose sensitivities (6 x ``n_columns`` each, a few copies) take about
    :data:`CHUNK_BYTES`: (point indices, indices of their observation rows)."""
    size = max(64, CHUNK_BYTES // (6 * 8 * 4 * max(n_columns, 1)))
    order = np.argsort(obs.point, kind="stable")
    bounds = np.searchsorted(obs.point[order], np.arange(0, obs.n_points + size, size).clip(max=obs.n_points))
    return [(np.arange(start, min(start + size, obs.n_points)), order[a:b])
            for start, a, b in zip(range(0, obs.n_points, size), bounds[:-1], bounds[1:])]


def _reduce(machine: Machine, obs: Observations, theta: np.ndarray, columns: np.ndarray,
            nuisance: np.ndarray, first_order: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The weighted residual and the triangular factor of the weighted design, built chunk by
    chunk so that neither the design nor the sensitivities are ever held for every point.

    With ``J = [obs.nuisance | d pred / d theta[columns]] / sigma`` (rows x n) and ``r`` the
    weighted residual, ``[J | r] = Q R`` with Q orthonormal: every least-squares quantity of J
    and r follows from ``R = [R_J | z]`` (``J^T J = R_J^T R_J``, ``|r - J x| = |z - R_J x|``,
    equal column norms and inner products), so the fit and the identifiability analysis work
    on R, whose size does not grow with the data.

    Returns
    -------
    r : ndarray, shape (rows,)
        The weighted residual (y - model - nuisance) / sigma.
    R : ndarray, shape (min(rows, n + 1), n + 1)
        Upper-triangular factor of ``[J | r]``.
    """
    width = obs.nuisance.shape[1] + len(columns) + 1
    R = np.zeros((0, width))
    r = np.empty(len(obs.y))
    for points, rows in _point_chunks(obs, len(columns)):
        cov = _take_covariates(obs.covariates, points)
        q = obs.q[points]
        error = machine.volumetric_error(q, theta, **cov)
        S = machine.sensitivity(q, theta, parameters=columns, first_order=first_order, **cov)
        pred, A = _rows_of(obs.w[rows], obs.point[rows] - points[0], error, S)
        sigma = obs.sigma[rows]
        r[rows] = (obs.y[rows] - pred - obs.nuisance[rows] @ nuisance) / sigma
        block = np.hstack([obs.nuisance[rows] / sigma[:, None], A / sigma[:, None], r[rows, None]])
        if not np.all(np.isfinite(block)):
            _refuse_non_finite(obs, {"residuals or sensitivities": block})
        R = np.linalg.qr(np.vstack([R, block]), mode="r")
    return r, R


def _rcond(rows: int, columns: int) -> float:
    """What ``lstsq(rcond=None)`` cuts on the full design (rows x columns), for the same cut
    on its triangular factor."""
    return float(np.finfo(float).eps * max(rows, columns))


def _solve(machine: Machine, obs: Observations, theta0: np.ndarray, free: np.ndarray,
           columns: np.ndarray | None, convention: str, max_iter: int, tol: float,
           step: Callable[[int], None] | None = None):
    """Gauss-Newton on [nuisance | free[columns]], damped (Levenberg-Marquardt, growing
    damping) when a full step does not lower the residual or would make a time constant or
    period non-positive;
    returns theta, nuisance, R_J (the triangular factor of the weighted design, see
    :func:`_reduce`), r, iterations, status: "converged" (the linearised model cannot
    lower the residual; a full Gauss-Newton step, or three damped ones running, lower the
    weighted RSS by less than 0.001 or 1e-10 of itself; or the step is below ``tol``),
    "stalled" (no step, however damped, lowers the residual although the linearised model
    says one should: the model is far from linear there, or badly conditioned) or "iteration limit"."""
    theta = theta0.copy()
    n_nu = obs.nuisance.shape[1]
    nuisance = np.zeros(n_nu)
    use = np.arange(len(free)) if columns is None else columns
    positive = np.array([k in set(machine.nonlinear_parameters) for k in free[use]], dtype=bool)
    n_cols = n_nu + len(use)
    rcond = 1e-9 if convention == "min-norm" else _rcond(len(obs.y), n_cols)
    it = 0
    status = "iteration limit"
    flat = 0
    for it in range(1, max_iter + 1):
        r, R = _reduce(machine, obs, theta, free[use], nuisance)
        z = R[:, -1]
        scale, Rs = _column_scale(R[:, :-1], typical=_typical(machine, theta, free[use], n_nu))
        step_scaled = np.linalg.lstsq(Rs, z, rcond=rcond)[0]
        delta = step_scaled / scale
        rss = float(r @ r)
        predicted = z - Rs @ step_scaled
        gain = float(z @ z) - float(predicted @ predicted)
        if gain <= 1e-12 * rss:
            status = "converged"  # the linearised model cannot lower the residual
            break
        # Gauss-Newton first; if its step does not lower the residual (far from linear, or
        # nearly singular directions that passed the rank test), Levenberg-Marquardt steps
        # with growing damping on the column-scaled problem, down to gradient-descent ones
        accepted = None
        for damping in (0.0, *(10.0 ** k for k in range(-6, 7))):
            if damping:
                augmented = np.vstack([Rs, math.sqrt(damping) * np.eye(Rs.shape[1])])
                step_scaled = np.linalg.lstsq(augmented, np.concatenate([z, np.zeros(Rs.shape[1])]),
                                              rcond=_rcond(len(obs.y) + n_cols, n_cols))[0]
                delta = step_scaled / scale
            trial_theta = theta.copy()
            trial_theta[free[use]] += delta[n_nu:]
            trial_nu = nuisance + delta[:n_nu]
            if not np.all(trial_theta[free[use]][positive] > 0):
                continue
            trial_r = _residual(machine, obs, trial_theta, trial_nu)
            if float(trial_r @ trial_r) <= rss * (1 + 1e-12) + 1e-300:
                accepted = damping
                break
        if accepted is None:
            # no step decreases the residual: at the minimum to rounding when the promised
            # gain is at the rounding level, otherwise stuck
            status = "converged" if gain <= 1e-6 * rss else "stalled"
            break
        theta, nuisance = trial_theta, trial_nu
        if step:
            step(it)
        flat = flat + 1 if rss - float(trial_r @ trial_r) <= max(1e-10 * rss, 1e-3) else 0
        if (accepted == 0.0 and flat) or flat >= 3:
            # chi-square (weighted RSS) moved by less than 0.001 in a full step, or in three
            # damped ones running: the parameters move by far less than their uncertainties -
            # a flat valley is being crawled, not descended
            status = "converged"
            break
        # step size in units of the observations' standard deviations
        if accepted == 0.0 and np.abs(delta * scale).max(initial=0.0) < tol:
            status = "converged"
            break
    r, R = _reduce(machine, obs, theta, free[use], nuisance)
    return theta, nuisance, R[:, :-1], r, it, status


def point_squares(point: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """Squared norm of the residual at each point that has rows.

    Parameters
    ----------
    point : ndarray of int, shape (rows,)
        The point each observation row belongs to (:attr:`Observations.point`).
    residual : ndarray, shape (rows,)
        Residual of each row (components of one point add up to its squared norm), in any
        unit.

    Returns
    -------
    ndarray, shape (points with rows,)
        Sum of the squared residuals of each point's rows, in the order of the points
        (unit of ``residual`` squared).
    """
    used, index = np.unique(point, return_inverse=True)
    return np.bincount(index, residual ** 2, minlength=used.size)


def residual_rms(obs: Observations, residual_si: np.ndarray, angular: bool = False) -> float | None:
    """RMS over points of the norm of the position (or rotation) residual.

    Parameters
    ----------
    obs : Observations
        The observations.
    residual_si : ndarray, shape (rows,)
        Residual of every row [m or rad].
    angular : bool, default False
        Use the rotation rows [urad] instead of the position rows [um].

    Returns
    -------
    float or None
        The RMS [um] (``angular``: [urad]); None without such rows.
    """
    rows = obs.angular == angular
    if not rows.any():
        return None
    return float(np.sqrt(point_squares(obs.point[rows], residual_si[rows]).mean()) * (URAD_PER_RAD if angular else UM_PER_M))


def identify(machine: Machine, data, *, terms=None, free=None, convention: str = "prior", folds: int = 5,
             holdout: float | None = None, seed: int = 0, max_iter: int = 50, tol: float = 1e-8,
             sigma_um: float = 1.0, sigma_urad: float = 1.0, run_axis: str | None = None,
             run_at: dict | None = None, rtol: float = 1e-9, progress=None,
             initialise: bool = True) -> Identification:
    """Fit the machine's coefficients to measurements.

    Parameters
    ----------
    machine : Machine
        The machine: its coefficients are the prior and the start values.
    data : list of measurement objects, or an :class:`Observations`
        Measurement objects as :func:`build_observations` takes them (point measurements,
        runs, tracker, ballbar), or observations built already.
    terms : list of component names, optional
        Components whose coefficients may move (default: all); the rest stay as given.
    free : array of coefficient indices, optional
        The coefficients that may move, one by one (overrides ``terms``).
    convention : "prior" or "min-norm"
        What to do with what the data cannot determine (see the module docstring).
    folds : int, default 5
        k-fold cross-validation over poses (``folds`` >= 2; the points at one pose are held
        out together); ``folds=0`` skips it.
    holdout : float, optional
        One random split keeping the fraction ``holdout`` (0 to 1) of the poses out
        (overrides ``folds``).
    seed : int, default 0
        Seed of the cross-validation's shuffling of the poses.
    max_iter : int, default 50
        Gauss-Newton iteration limit.
    tol : float, default 1e-8
        Convergence threshold on the largest component of a full Gauss-Newton step, in units of
        the observations' standard deviations (column-scaled).
    sigma_um : float, default 1.0
        Standard deviation of position observations [um] (weights); only when ``data`` is
        not an :class:`Observations`.
    sigma_urad : float, default 1.0
        Standard deviation of rotation observations [urad] (weights); likewise.
    run_axis : str, optional
        Moving axis of runs that do not name it (see :func:`build_observations`).
    run_at : dict, optional
        Positions of the other axes during runs [mm, deg] (see :func:`build_observations`).
    rtol : float, default 1e-9
        Relative tolerance of the identifiability tests (:func:`~volerr_pin.identifiability.analyse`).
    progress : callable(str, int), optional
        Called with a stage name and a step count, for progress bars.
    initialise : bool, default True
        Start the non-linear coefficients (time constants, periods) from a grid search
        (default); False starts them from the machine's values, for callers that already
        have good ones.

    Returns
    -------
    Identification
        The fitted machine, the identifiability analysis, uncertainties, residual RMS values
        and the held-out RMS.

    Raises
    ------
    InputError
        If ``convention`` is invalid, ``sigma_um`` or ``sigma_urad``, ``tol`` or ``rtol`` is
        not a positive finite number (``rtol`` below 1), ``folds`` is not 0 or >= 2,
        ``holdout`` is not a fraction between 0 and 1 or leaves no pose to fit, ``seed`` is
        negative, ``max_iter`` is below 1, ``terms`` names an unknown component or ``free``
        an index that is not a coefficient's, there is nothing to fit, the data are invalid
        (see :func:`build_observations`; observations that are not finite, or whose squares
        overflow), or the fit comes out non-finite (values too large to fit).

    Warns
    -----
    UserWarning
        When the column-scaled design is numerically rank-deficient or its condition number
        exceeds :data:`CONDITION_LIMIT` (also :attr:`Identification.ill_conditioned`).
    """
    if convention not in ("prior", "min-norm"):
        raise InputError(f"convention must be 'prior' or 'min-norm', got {convention!r}",
                         parameters=("convention",))
    folds = _integer("folds", folds, 2, also=(0,), what=" (0: no cross-validation)")
    if holdout is not None:
        holdout = _fraction("holdout", holdout)
    seed = _integer("seed", seed, 0)
    max_iter = _integer("max_iter", max_iter, 1)
    tol = _positive("tol", tol)
    rtol = _positive("rtol", rtol)
    if rtol >= 1:
        raise InputError(f"rtol must be below 1, got {rtol}", parameters=("rtol",))
    obs = data if isinstance(data, Observations) else build_observations(
        machine, data, sigma_um=sigma_um, sigma_urad=sigma_urad, run_axis=run_axis, run_at=run_at)
    if isinstance(data, Observations):
        _positive("sigma_um", sigma_um), _positive("sigma_urad", sigma_urad)
    check_observations(obs)
    require_memory(_memory_needed(obs, folds if holdout is None else 1),
                   f"fitting {obs.n_points} points ({len(obs.y)} observations) of {_data_names(obs)}")
    n_params = len(machine.parameter_names)
    if free is not None:
        try:
            free = np.unique(np.asarray(free, dtype=int).ravel())
        except (TypeError, ValueError):
            raise InputError(f"free must hold coefficient indices (integers), got {free!r}",
                             parameters=("free",)) from None
        if free.size and (free[0] < 0 or free[-1] >= n_params):
            bad = free[0] if free[0] < 0 else free[-1]
            raise InputError(f"free: {bad} is not the index of a coefficient of {machine.name} "
                             f"(0 to {n_params - 1})", parameters=("free",))
    elif terms:
        terms = [terms] if isinstance(terms, str) else list(terms)  # one name, not its letters
        unknown = sorted(set(terms) - set(machine.components))
        if unknown:
            raise InputError(f"terms: {', '.join(unknown)} not among the error terms of "
                             f"{machine.name} ({', '.join(machine.components)})", parameters=("terms",))
        free = np.array([k for k, n in enumerate(machine.parameter_names)
                         if n.split(".", 1)[0] in set(terms)], dtype=int)
    else:
        free = np.arange(n_params)
    if free.size == 0 and obs.nuisance.shape[1] == 0:
        raise InputError(f"{machine.name} has no coefficients to fit")
    if holdout is not None:
        _holdout_split(obs, holdout, seed)  # refuses a split that leaves nothing to fit, before the fit
    theta0 = (_initialise_nonlinear(machine, obs, machine.theta, free, rtol, progress) if initialise
              else machine.theta.copy())
    # identifiability of the first-order model: exact dependencies, untouched by second-order
    # differences that the errors' own size brings in
    n_nu = obs.nuisance.shape[1]
    _, R0 = _reduce(machine, obs, theta0, free, np.zeros(n_nu), first_order=True)
    names = obs.nuisance_names + [machine.parameter_names[k] for k in free]
    analysis = analyse(R0[:, :-1], names, protected=n_nu, rtol=rtol, what="these measurements",
                       typical=_typical(machine, theta0, free, n_nu))
    kept_theta = np.array([c - n_nu for c in analysis.kept if c >= n_nu], dtype=int)
    held = np.array(sorted(set(range(len(free))) - set(kept_theta.tolist())), dtype=int)
    columns = kept_theta if convention == "prior" else None
    tick = (lambda i: progress("fit", i)) if progress else None
    theta, nuisance, R, r, iterations, solver = _solve(machine, obs, theta0, free, columns, convention,
                                                       max_iter, tol, tick)
    dof = len(r) - R.shape[1] if convention == "prior" else len(r) - analysis.rank
    residual_sigma = float(np.sqrt(r @ r / dof)) if dof > 0 else math.nan
    uncertainty = np.full(len(theta), np.nan)
    ill = _ill_conditioned(analysis.singular_values, len(r))
    if convention == "prior" and dof > 0:
        std, rank_deficient = _standard_uncertainties(R, len(r), _typical(machine, theta, free[kept_theta], n_nu))
        uncertainty[free[kept_theta]] = std[n_nu:] * residual_sigma
        ill = ill or rank_deficient
    residual_si = r * obs.sigma
    fitted_machine = machine.with_theta(theta)
    rms_fit = residual_rms(obs, residual_si)
    rms_fit_rot = residual_rms(obs, residual_si, angular=True)
    fitted_idx = free[kept_theta] if convention == "prior" else free
    _refuse_non_finite(obs, {"coefficients": theta[fitted_idx], "nuisance terms": nuisance,
                             "residual RMS": [rms_fit or 0.0, rms_fit_rot or 0.0],
                             "residual standard deviation": [0.0 if dof <= 0 else residual_sigma],
                             # infinite where the design is rank-deficient (then flagged and said)
                             "uncertainties": [] if ill or convention != "prior" or dof <= 0
                             else uncertainty[fitted_idx]})
    if ill:
        warnings.warn(_conditioning_note(analysis, len(r)), stacklevel=2)
    rms_holdout, how = None, "none"
    if holdout is not None or folds >= 2:
        rms_holdout, how = _cross_validate(machine, obs, theta0, free, columns, convention, folds,
                                           holdout, seed, max_iter, tol, progress)
        _refuse_non_finite(obs, {"held-out RMS": [rms_holdout or 0.0]})
    held_idx = free[held] if convention == "prior" else np.array([], dtype=int)
    groups = [g for g in analysis.groups]
    return Identification(
        fitted_machine, machine, free, analysis, fitted_idx, held_idx, uncertainty,
        dict(zip(obs.nuisance_names, (float(v) for v in nuisance))), rms_fit or 0.0, rms_fit_rot,
        rms_holdout, how, obs.n_points, len(obs.y), iterations, convention, residual_sigma, groups,
        frozenset(n for n, angular in zip(obs.nuisance_names, obs.nuisance_angular) if angular), solver, ill)


def _memory_needed(obs: Observations, folds: int) -> float:
    """Peak memory of a fit [bytes]: the observations copied into training and test sets,
    residual vectors and per-point evaluations, and the chunk buffers of :func:`_reduce` (the
    design itself is never held whole)."""
    per_row = 8 * (12 + obs.nuisance.shape[1]) * (2 if folds >= 2 else 1)
    per_point = 8 * (obs.q.shape[1] + 6) * 3
    return per_row * len(obs.y) + per_point * obs.n_points + 4 * CHUNK_BYTES


def _ill_conditioned(singular_values: np.ndarray, rows: int) -> bool:
    """Whether a column-scaled design with these singular values is numerically
    rank-deficient (the smallest at rounding level of the largest) or conditioned beyond
    :data:`CONDITION_LIMIT`."""
    sv = np.asarray(singular_values)
    if sv.size == 0:
        return False
    return bool(sv[-1] <= sv[0] * _rcond(rows, sv.size) or sv[0] > CONDITION_LIMIT * sv[-1])


def _conditioning_note(analysis: Analysis, rows: int) -> str:
    sv = analysis.singular_values
    what = (f"condition number {analysis.condition:.3g}" if sv.size and sv[-1] > sv[0] * _rcond(rows, sv.size)
            else "numerically rank-deficient")
    return (f"the fit is ill-conditioned: its column-scaled design ({analysis.rank} columns kept) is "
            f"{what}, beyond what double precision resolves (limit {CONDITION_LIMIT:.0e}); "
            "the fitted values along its weakest directions are rounding noise: fit fewer terms or lower "
            "degrees, or add data that separate them")


def _standard_uncertainties(R: np.ndarray, rows: int, typical: np.ndarray) -> tuple[np.ndarray, bool]:
    """Standard uncertainties of the columns of a design from its triangular factor ``R``
    (unit weighted-residual scale), by the SVD of the column-scaled factor (the normal
    matrix would square its condition), and whether directions below rounding were cut: the
    columns they involve are not determined (infinite uncertainty)."""
    scale, Rs = _column_scale(R, typical=typical)
    if Rs.size == 0:
        return np.zeros(R.shape[1]), False
    _, s, Vt = np.linalg.svd(Rs, full_matrices=False)
    keep = s > s[0] * _rcond(rows, Rs.shape[1]) if s.size and s[0] > 0 else np.zeros(s.size, bool)
    var = (Vt[keep] ** 2 / s[keep, None] ** 2).sum(axis=0)
    undetermined = np.zeros(Rs.shape[1], bool)
    if Vt.shape[0] < Rs.shape[1] or not keep.all():
        # directions of no effect (cut, or beyond the factor's rank): the columns in them
        basis = Vt[keep]
        undetermined = 1.0 - (basis ** 2).sum(axis=0) > 1e-12
    var[undetermined] = np.inf
    return np.sqrt(var) / scale, bool(undetermined.any())


def _refuse_non_finite(obs: Observations, results: dict) -> None:
    """A fit that comes out non-finite is refused, naming the data and its largest value."""
    bad = [what for what, values in results.items() if not np.all(np.isfinite(np.asarray(values, dtype=float)))]
    if not bad:
        return
    weighted = np.abs(obs.y / obs.sigma)
    i = int(np.argmax(np.where(np.isfinite(weighted), weighted, np.inf)))
    unit, factor = ("urad", URAD_PER_RAD) if obs.angular[i] else ("um", UM_PER_M)
    raise InputError(f"the fit to {_data_names(obs)} gives non-finite {' and '.join(bad)}: the data hold "
                     f"values too large to fit (the largest against its sigma: {obs.y[i] * factor:.6g} {unit} at "
                     f"{obs.sources[i]}:{obs.lines[i]})")


def _data_names(obs: Observations) -> str:
    names = list(dict.fromkeys(obs.sources))
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def check_observations(obs: Observations) -> None:
    """Refuse observations a fit cannot use, naming the file and line of the first bad row.

    Parameters
    ----------
    obs : Observations
        The observations.

    Raises
    ------
    InputError
        If the arrays do not have one entry per row (or point indices leave the points, or
        the nuisance flags or poses do not have one per column or point), a
        value, weight or nuisance entry is not finite, a standard deviation is not
        positive and finite, a position is not finite, or an observation exceeds
        :data:`WEIGHTED_LIMIT` standard deviations (the fit's sums of squares would overflow).
    """
    rows = len(obs.y)
    shapes = {"point": np.shape(obs.point), "w": np.shape(obs.w), "sigma": np.shape(obs.sigma),
              "angular": np.shape(obs.angular), "nuisance": np.shape(obs.nuisance)[:1], "lines": np.shape(obs.lines)}
    expected = {"w": (rows, 6), "nuisance": (rows,)}
    for name, shape in shapes.items():
        if shape != expected.get(name, (rows,)):
            raise InputError(f"obs.{name} has shape {shape}; expected {expected.get(name, (rows,))} (one per row)",
                             parameters=("obs",))
    if len(obs.sources) != rows or np.shape(obs.nuisance)[1:] != (len(obs.nuisance_names),):
        raise InputError("obs.sources and obs.nuisance_names must name every row and nuisance column",
                         parameters=("obs",))
    if np.shape(obs.nuisance_angular) != (len(obs.nuisance_names),):
        raise InputError(f"obs.nuisance_angular has shape {np.shape(obs.nuisance_angular)}; expected "
                         f"({len(obs.nuisance_names)},) (one per nuisance column)", parameters=("obs",))
    if obs.pose is not None and (np.shape(obs.pose) != (obs.n_points,)
                                 or not np.issubdtype(np.asarray(obs.pose).dtype, np.integer)):
        raise InputError(f"obs.pose must hold one integer pose per point ({obs.n_points}), got shape "
                         f"{np.shape(obs.pose)}", parameters=("obs",))
    if rows and (obs.point.min() < 0 or obs.point.max() >= obs.n_points):
        raise InputError(f"obs.point refers to points outside 0 to {obs.n_points - 1}", parameters=("obs",))
    bad_q = np.argwhere(~np.isfinite(obs.q))
    if bad_q.size:
        i = int(bad_q[0][0])
        rows = np.flatnonzero(obs.point == i)
        where = f"{obs.sources[rows[0]]}:{obs.lines[rows[0]]}" if rows.size else f"point {i}"
        raise InputError(f"{where}: position {obs.q[i, bad_q[0][1]]} is not a finite number")
    checks = (("value", ~np.isfinite(obs.y)), ("standard deviation", ~(np.isfinite(obs.sigma) & (obs.sigma > 0))),
              ("weight", ~np.all(np.isfinite(obs.w), axis=1)),
              ("nuisance design", ~np.all(np.isfinite(obs.nuisance), axis=1)))
    for what, mask in checks:
        if mask.any():
            i = int(np.argmax(mask))
            raise InputError(f"{obs.sources[i]}:{obs.lines[i]}: observation {what} is not a "
                             f"{'positive ' if what == 'standard deviation' else ''}finite number")
    with np.errstate(over="ignore"):
        weighted = np.abs(obs.y / obs.sigma)
    if not weighted.max(initial=0.0) <= WEIGHTED_LIMIT:
        i = int(np.argmax(weighted))
        unit, factor = ("urad", URAD_PER_RAD) if obs.angular[i] else ("um", UM_PER_M)
        raise InputError(f"{obs.sources[i]}:{obs.lines[i]}: observation {obs.y[i] * factor:.6g} {unit} is too large "
                         f"to fit: {weighted[i]:.3g} times its standard deviation (the sums of squares a fit forms "
                         f"overflow double precision beyond {WEIGHTED_LIMIT:.0e})")


def _typical(machine: Machine, theta: np.ndarray, free: np.ndarray, n_nuisance: int) -> np.ndarray:
    """Typical size of each column's coefficient for the zero test of :func:`analyse`: 1
    (the SI unit) for nuisance and linear coefficients, the present value for non-linear
    ones (time constants, periods), whose effect per SI unit can be tiny."""
    nonlinear = set(machine.nonlinear_parameters)
    out = np.ones(n_nuisance + len(free))
    for c, k in enumerate(free):
        if k in nonlinear and theta[k] != 0:
            out[n_nuisance + c] = abs(theta[k])
    return out


def _initialise_nonlinear(machine: Machine, obs: Observations, theta: np.ndarray, free: np.ndarray,
                          rtol: float = 1e-9, progress=None) -> np.ndarray:
    """Variable projection by grid search: for each free non-linear coefficient (time
    constant, period), try the candidates of its term's grid (and the prior value), fitting
    the identifiable linear coefficients and nuisance terms for each, and keep the best. The
    Gauss-Newton fit then refines all of them together. Every candidate's design is reduced
    to its triangular factor in one pass over chunks of points (see :func:`_reduce`)."""
    theta = theta.copy()
    nonlinear = [k for k in machine.nonlinear_parameters if k in set(free.tolist())]
    if not nonlinear:
        return theta
    linear = np.array([k for k in free if k not in set(nonlinear)], dtype=int)
    n_nu = obs.nuisance.shape[1]
    _, R = _reduce(machine, obs, theta, linear, np.zeros(n_nu), first_order=True)
    kept = analyse(R[:, :-1], [""] * (R.shape[1] - 1), protected=n_nu, rtol=rtol,
                   typical=_typical(machine, theta, linear, n_nu)).kept
    lin_cols = np.array([c - n_nu for c in kept if c >= n_nu], dtype=int)
    for step, k in enumerate(nonlinear):
        # the columns of the other terms hardly depend on this coefficient: computed once per chunk
        term = next(p for p in machine.term_spans() if p.start <= k < p.stop)
        own = np.array([i for i in range(term.start, term.stop) if i in set(linear[lin_cols].tolist())], dtype=int)
        others = np.array([i for i in linear[lin_cols] if i not in set(own.tolist())], dtype=int)
        grid = np.r_[theta[k], machine.search_grid(k, theta, n=obs.n_points, **obs.covariates)]
        factors = [np.zeros((0, n_nu + len(others) + len(own) + 1)) for _ in grid]
        for points, rows in _point_chunks(obs, len(others) + len(own)):
            cov = _take_covariates(obs.covariates, points)
            q, w, local, sigma = obs.q[points], obs.w[rows], obs.point[rows] - points[0], obs.sigma[rows, None]
            error = machine.volumetric_error(q, theta, **cov)
            _, A_other = _rows_of(w, local, error, machine.sensitivity(q, theta, parameters=others, **cov))
            for g, value in enumerate(grid):
                trial = theta.copy()
                trial[k] = value
                error = machine.volumetric_error(q, trial, **cov)
                pred, A_own = _rows_of(w, local, error, machine.sensitivity(q, trial, parameters=own, **cov))
                r = (obs.y[rows] - pred) / sigma[:, 0]
                block = np.hstack([obs.nuisance[rows] / sigma, A_other / sigma, A_own / sigma, r[:, None]])
                if not np.all(np.isfinite(block)):
                    _refuse_non_finite(obs, {"residuals or sensitivities": block})
                factors[g] = np.linalg.qr(np.vstack([factors[g], block]), mode="r")
        best, best_rss = theta.copy(), math.inf
        for value, R in zip(grid, factors):
            J, z = R[:, :-1], R[:, -1]
            scale, Js = _column_scale(J)  # linear coefficients only: SI sizes are typical
            delta = np.linalg.lstsq(Js, z, rcond=_rcond(len(obs.y), J.shape[1]))[0] / scale
            rss = float(np.sum((z - J @ delta) ** 2))
            if rss < best_rss:
                best_rss = rss
                best = theta.copy()
                best[k] = value
                best[others] += delta[n_nu:n_nu + len(others)]
                best[own] += delta[n_nu + len(others):]
        theta = best
        if progress:
            progress("non-linear start values", step + 1)
    return theta


def _poses(obs: Observations, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Pose index of every point (the same positions: several targets, or repeats) and the
    poses shuffled by ``seed``."""
    seed = _integer("seed", seed, 0)
    group = obs.poses()
    return group, np.random.default_rng(seed).permutation(int(group.max()) + 1 if group.size else 0)


def pose_folds(obs: Observations, folds: int, seed: int) -> list[np.ndarray] | None:
    """Groups of point indices for cross-validation, keeping the points at one pose in one group.

    A held-out pose must not be half in the fit.

    Parameters
    ----------
    obs : Observations
        The observations (poses: points with the same positions, to 1e-12).
    folds : int
        Number of groups.
    seed : int
        Seed of the shuffling of the poses.

    Returns
    -------
    list of ndarray of int, or None
        ``folds`` arrays of point indices; None when there are fewer than 2 x ``folds`` poses.

    Raises
    ------
    InputError
        If ``folds`` is not a whole number >= 1 or ``seed`` is negative.
    """
    folds = _integer("folds", folds, 1)
    group, order = _poses(obs, seed)
    if len(order) < 2 * folds:
        return None
    return [np.flatnonzero(np.isin(group, part)) for part in np.array_split(order, folds)]


def _holdout_split(obs: Observations, holdout: float, seed: int) -> tuple[list[np.ndarray], str]:
    """The points held out by a random split of the poses, and how; refuses a split that holds
    out every pose."""
    group, order = _poses(obs, seed)
    n_out = max(1, int(round(holdout * len(order))))
    if n_out >= len(order):
        raise InputError(f"holdout {holdout:g} of {len(order)} {'pose' if len(order) == 1 else 'poses'} holds out "
                         f"{n_out}: none is left to fit "
                         f"(give a smaller fraction, or data at more poses)", parameters=("holdout",))
    splits = [np.flatnonzero(np.isin(group, order[:n_out]))]
    how = (f"random split, {n_out} of {len(order)} poses ({splits[0].size} of {obs.n_points} points) "
           f"held out (seed {seed})")
    return splits, how


def _cross_validate(machine, obs, theta0, free, columns, convention, folds, holdout, seed,
                    max_iter, tol, progress):
    if holdout is not None:
        splits, how = _holdout_split(obs, holdout, seed)
    else:
        splits = pose_folds(obs, folds, seed)
        if splits is None:
            return None, f"too few poses for {folds}-fold cross-validation"
        how = f"{folds}-fold cross-validation over poses (seed {seed})"
    sq_pos, count = 0.0, 0
    for k, test in enumerate(splits):
        train = np.setdiff1d(np.arange(obs.n_points), test)
        fit_obs, test_obs = obs.subset(train), obs.subset(np.sort(test))
        theta, nuisance, *_ = _solve(machine, fit_obs, theta0, free, columns, convention, max_iter,
                                     tol)
        error = machine.volumetric_error(test_obs.q, theta, **test_obs.covariates)
        pred = np.einsum("rk,rk->r", test_obs.w, error[test_obs.point]) + test_obs.nuisance @ nuisance
        res = test_obs.y - pred
        pos = ~test_obs.angular
        per_point = point_squares(test_obs.point[pos], res[pos])
        sq_pos += per_point.sum()
        count += per_point.size
        if progress:
            progress("cross-validation", k + 1)
    return (float(np.sqrt(sq_pos / count) * UM_PER_M) if count else None), how
