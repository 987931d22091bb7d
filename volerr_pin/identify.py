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
from .ballbar import BallbarRun, ballbar_positions
from .identifiability import Analysis, analyse
from .tracker import TrackerMeasurements, tracker_observations
from .workspace import config_from_file
from .machine import Machine
from .measurements import PointMeasurements, Runs
from .spec import parse_component_name
from .units import UM_PER_M, URAD_PER_RAD

DIRECTION_INDEX = {d: i for i, d in enumerate("XYZABC")}


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
                            self.lines[keep])


def _take_covariates(cov: dict, idx) -> dict:
    out = {}
    for key, value in cov.items():
        out[key] = {k: v[idx] for k, v in value.items()} if isinstance(value, dict) else value[idx]
    return out


def build_observations(machine: Machine, data, *, sigma_um: float = 1.0, sigma_urad: float = 1.0,
                       run_axis: str | None = None, run_at: dict[str, float] | None = None
                       ) -> Observations:
    """Turn measurement objects into observations.

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
    data : iterable
        :class:`~volerr_pin.measurements.PointMeasurements`, :class:`~volerr_pin.measurements.Runs`,
        :class:`~volerr_pin.tracker.TrackerMeasurements` and
        :class:`~volerr_pin.ballbar.BallbarRun` objects.
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
        If a run's axis is unknown or not given, its target unit does not fit the axis kind,
        its positions leave the travel, a component run belongs to another axis, an object
        is of an unknown type, there are no observations, or a covariate the model reads is
        missing from some files.
    """
    q_list, cov_list, rows = [], [], []
    nuisance_names: list[str] = []
    nuisance_rows: list[tuple[int, int, float]] = []  # (row, column, value)
    n_points = 0
    for item in data:
        if isinstance(item, PointMeasurements):
            q_list.append(item.q)
            cov_list.append(item.covariates)
            for i in range(len(item.q)):
                for k in range(6):
                    if not np.isnan(item.values[i, k]):
                        w = np.zeros(6)
                        w[k] = 1.0
                        rows.append((n_points + i, w, item.values[i, k],
                                     (sigma_urad if k >= 3 else sigma_um) * 1e-6, k >= 3,
                                     item.source, item.lines[i]))
            n_points += len(item.q)
        elif isinstance(item, Runs):
            axis = item.axis or run_axis
            if axis is None:
                raise InputError(f"{item.source}: which axis moved? Give '# axis: X' in the file or run_axis",
                                 parameters=("run_axis",))
            if axis not in machine.axes:
                raise InputError(f"{item.source}: axis '{axis}' is not an axis of {machine.name} "
                                 f"({', '.join(machine.axes)})")
            j = machine.axes.index(axis)
            kind = machine.axis_kinds[j]
            if (item.target_unit == "mm") != (kind == "linear"):
                raise InputError(f"{item.source}: targets in {item.target_unit} but axis {axis} is {kind}")
            base = config_from_file(machine, {**item.at, **(run_at or {})}, f"{item.source}: '# at:'")
            q = np.tile(base, (len(item.target), 1))
            q[:, j] = item.target
            try:
                machine.check_q(q)
            except InputError as err:
                raise InputError(f"{item.source}: {err}") from None
            q_list.append(q)
            cov_list.append({"directions": np.where(np.arange(len(machine.axes)) == j,
                                                    item.direction[:, None], 1.0)})
            if item.component is None:
                nominal = machine.axis_jacobian(q, nominal=True)[:, :, j]
                w_all = nominal / np.linalg.norm(nominal, axis=1, keepdims=True)
                angular = kind == "rotary"
                label = "positioning"
            else:
                direction, _, owner = parse_component_name(item.component)
                if owner != axis:
                    raise InputError(f"{item.source}: {item.component} is an error of {owner}, not {axis}")
                w_all = np.zeros((len(q), 6))
                w_all[:, DIRECTION_INDEX[direction]] = 1.0
                angular = direction in "ABC"
                label = item.component
            straightness = (item.component is not None and not angular and kind == "linear"
                            and item.component[1] != axis)
            base_col = len(nuisance_names)
            tag = f"{label} run {item.source}"
            nuisance_names.append(f"offset[{tag}]")
            if straightness:
                nuisance_names.append(f"slope[{tag}]")
            lo, hi = machine.travel[j]
            u = (2 * q[:, j] - lo - hi) / (hi - lo)
            sigma = (sigma_urad if angular else sigma_um) * 1e-6
            for i in range(len(q)):
                row = len(rows)
                rows.append((n_points + i, w_all[i], item.value[i], sigma, angular, item.source,
                             item.lines[i]))
                nuisance_rows.append((row, base_col, 1.0))
                if straightness:
                    nuisance_rows.append((row, base_col + 1, u[i]))
            n_points += len(q)
        elif isinstance(item, TrackerMeasurements):
            obs_t = tracker_observations(machine, item)
            q_list.append(item.q)
            cov_list.append(item.covariates)
            tag = f"tracker {item.source}"
            base_col = len(nuisance_names)
            nuisance_names += [f"shift_{a}[{tag}]" for a in "xyz"] + [f"rotation_{a}[{tag}]" for a in "xyz"]
            for i in range(len(item.q)):
                for k in range(3):
                    row = len(rows)
                    rows.append((n_points + i, obs_t["w"][i, k], obs_t["deviation"][i, k], sigma_um * 1e-6, False,
                                 item.source, item.lines[i]))
                    for c in range(6):
                        if obs_t["nuisance"][i, k, c] != 0.0:
                            nuisance_rows.append((row, base_col + c, obs_t["nuisance"][i, k, c]))
            n_points += len(item.q)
        elif isinstance(item, BallbarRun):
            q, radial, directions = ballbar_positions(machine, item)
            q_list.append(q)
            cov_list.append({"directions": directions})
            tag = f"ballbar {item.source}"
            base_col = len(nuisance_names)
            nuisance_names += [f"centre_{item.plane[0]}[{tag}]", f"centre_{item.plane[1]}[{tag}]",
                               f"length[{tag}]"]
            for i in range(len(q)):
                row = len(rows)
                w = np.zeros(6)
                w[:3] = radial[i]
                rows.append((n_points + i, w, item.deviation[i], sigma_um * 1e-6, False, item.source,
                             item.lines[i]))
                for k, v in enumerate((math.cos(item.angle[i]), math.sin(item.angle[i]), 1.0)):
                    nuisance_rows.append((row, base_col + k, v))
            n_points += len(q)
        else:
            raise InputError(f"cannot use {type(item).__name__} as measurements")
    if not rows:
        raise InputError("no observations")
    q = np.vstack(q_list)
    covariates = _merge_covariates(cov_list, [len(x) for x in q_list], machine)
    nuisance = np.zeros((len(rows), len(nuisance_names)))
    for r, c, v in nuisance_rows:
        nuisance[r, c] = v
    return Observations(
        q, covariates, np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
        np.array([r[2] for r in rows]), np.array([r[3] for r in rows]),
        np.array([r[4] for r in rows], dtype=bool), nuisance, nuisance_names,
        [r[5] for r in rows], np.array([r[6] for r in rows]))


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
                          f"{machine.name}'s model does not read it, so it is not used", stacklevel=4)
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
            ``condition_number``, ``unidentifiable``, ``convention``, ``solver``,
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
                "uncertainty": None if math.isnan(self.uncertainty[k]) else float(self.uncertainty[k] / factor),
                "unit": unit, "status": status}
        return {
            "machine": m.name, "n_points": self.n_points, "n_observations": self.n_observations,
            "rank": sum(c >= len(self.nuisance) for c in self.analysis.kept), "n_parameters": int(len(self.free)),
            "condition_number": self.analysis.condition,
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
    pred = np.einsum("rk,rk->r", obs.w, error[obs.point])
    A = np.einsum("rk,rkp->rp", obs.w, S[obs.point])
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


def _solve(machine: Machine, obs: Observations, theta0: np.ndarray, free: np.ndarray,
           columns: np.ndarray | None, convention: str, max_iter: int, tol: float,
           step: Callable[[int], None] | None = None):
    """Gauss-Newton on [nuisance | free[columns]], damped (Levenberg-Marquardt, growing
    damping) when a full step does not lower the residual or would make a time constant or
    period non-positive;
    returns theta, nuisance, J, r, iterations, status: "converged" (the linearised model cannot
    lower the residual; a full Gauss-Newton step, or three damped ones running, lower the
    weighted RSS by less than 0.001 or 1e-10 of itself; or the step is below ``tol``),
    "stalled" (no step, however damped, lowers the residual although the linearised model
    says one should: the model is far from linear there, or badly conditioned) or "iteration limit"."""
    theta = theta0.copy()
    n_nu = obs.nuisance.shape[1]
    nuisance = np.zeros(n_nu)
    use = np.arange(len(free)) if columns is None else columns
    positive = np.array([k in set(machine.nonlinear_parameters) for k in free[use]], dtype=bool)
    sigma = obs.sigma
    it = 0
    rcond = 1e-9 if convention == "min-norm" else None
    status = "iteration limit"
    flat = 0
    for it in range(1, max_iter + 1):
        pred, A = predict_observations(machine, obs, theta, free)
        r = (obs.y - pred - obs.nuisance @ nuisance) / sigma
        J = np.hstack([obs.nuisance, A[:, use]]) / sigma[:, None]
        scale, Js = _column_scale(J, typical=_typical(machine, theta, free[use], n_nu))
        step_scaled = np.linalg.lstsq(Js, r, rcond=rcond)[0]
        delta = step_scaled / scale
        rss = float(r @ r)
        predicted = r - Js @ step_scaled
        gain = rss - float(predicted @ predicted)
        if gain <= 1e-12 * rss:
            status = "converged"  # the linearised model cannot lower the residual
            break
        # Gauss-Newton first; if its step does not lower the residual (far from linear, or
        # nearly singular directions that passed the rank test), Levenberg-Marquardt steps
        # with growing damping on the column-scaled problem, down to gradient-descent ones
        accepted = None
        for damping in (0.0, *(10.0 ** k for k in range(-6, 7))):
            if damping:
                augmented = np.vstack([Js, math.sqrt(damping) * np.eye(Js.shape[1])])
                step_scaled = np.linalg.lstsq(augmented, np.concatenate([r, np.zeros(Js.shape[1])]),
                                              rcond=None)[0]
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
    pred, A = predict_observations(machine, obs, theta, free)
    r = (obs.y - pred - obs.nuisance @ nuisance) / sigma
    J = np.hstack([obs.nuisance, A[:, use]]) / sigma[:, None]
    return theta, nuisance, J, r, it, status


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
        If ``convention`` or ``holdout`` is invalid, ``terms`` names an unknown component,
        there is nothing to fit, or the data are invalid (see :func:`build_observations`).
    """
    if convention not in ("prior", "min-norm"):
        raise InputError(f"convention must be 'prior' or 'min-norm', got {convention!r}")
    obs = data if isinstance(data, Observations) else build_observations(
        machine, data, sigma_um=sigma_um, sigma_urad=sigma_urad, run_axis=run_axis, run_at=run_at)
    if free is not None:
        free = np.unique(np.asarray(free, dtype=int))
    elif terms:
        unknown = sorted(set(terms) - set(machine.components))
        if unknown:
            raise InputError(f"terms: {', '.join(unknown)} not among the error terms of "
                             f"{machine.name} ({', '.join(machine.components)})", parameters=("terms",))
        free = np.array([k for k, n in enumerate(machine.parameter_names)
                         if n.split(".", 1)[0] in set(terms)], dtype=int)
    else:
        free = np.arange(len(machine.parameter_names))
    if free.size == 0 and obs.nuisance.shape[1] == 0:
        raise InputError(f"{machine.name} has no coefficients to fit")
    theta0 = (_initialise_nonlinear(machine, obs, machine.theta, free, rtol, progress) if initialise
              else machine.theta.copy())
    # identifiability of the first-order model: exact dependencies, untouched by second-order
    # differences that the errors' own size brings in
    pred, A = predict_observations(machine, obs, theta0, free, first_order=True)
    J0 = np.hstack([obs.nuisance, A]) / obs.sigma[:, None]
    names = obs.nuisance_names + [machine.parameter_names[k] for k in free]
    n_nu = obs.nuisance.shape[1]
    analysis = analyse(J0, names, protected=n_nu, rtol=rtol, what="these measurements",
                       typical=_typical(machine, theta0, free, n_nu))
    kept_theta = np.array([c - n_nu for c in analysis.kept if c >= n_nu], dtype=int)
    held = np.array(sorted(set(range(len(free))) - set(kept_theta.tolist())), dtype=int)
    columns = kept_theta if convention == "prior" else None
    tick = (lambda i: progress("fit", i)) if progress else None
    theta, nuisance, J, r, iterations, solver = _solve(machine, obs, theta0, free, columns, convention,
                                               max_iter, tol, tick)
    dof = len(r) - J.shape[1] if convention == "prior" else len(r) - analysis.rank
    residual_sigma = float(np.sqrt(r @ r / dof)) if dof > 0 else math.nan
    uncertainty = np.full(len(theta), np.nan)
    if convention == "prior" and dof > 0:
        scale, Js = _column_scale(J, typical=_typical(machine, theta, free[kept_theta], n_nu))
        cov = np.linalg.pinv(Js.T @ Js) / np.outer(scale, scale) * residual_sigma**2
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        uncertainty[free[kept_theta]] = std[n_nu:]
    residual_si = r * obs.sigma
    fitted_machine = machine.with_theta(theta)
    rms_fit = residual_rms(obs, residual_si)
    rms_fit_rot = residual_rms(obs, residual_si, angular=True)
    rms_holdout, how = None, "none"
    if holdout is not None or folds >= 2:
        rms_holdout, how = _cross_validate(machine, obs, theta0, free, columns, convention, folds,
                                           holdout, seed, max_iter, tol, progress)
    fitted_idx = free[kept_theta] if convention == "prior" else free
    held_idx = free[held] if convention == "prior" else np.array([], dtype=int)
    groups = [g for g in analysis.groups]
    return Identification(
        fitted_machine, machine, free, analysis, fitted_idx, held_idx, uncertainty,
        dict(zip(obs.nuisance_names, (float(v) for v in nuisance))), rms_fit or 0.0, rms_fit_rot,
        rms_holdout, how, obs.n_points, len(obs.y), iterations, convention, residual_sigma, groups,
        frozenset(n for c, n in enumerate(obs.nuisance_names)
                  if np.any(obs.angular[obs.nuisance[:, c] != 0]) or n.startswith("rotation_")), solver)


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
    Gauss-Newton fit then refines all of them together."""
    theta = theta.copy()
    nonlinear = [k for k in machine.nonlinear_parameters if k in set(free.tolist())]
    if not nonlinear:
        return theta
    linear = np.array([k for k in free if k not in set(nonlinear)], dtype=int)
    n_nu = obs.nuisance.shape[1]
    _, A = predict_observations(machine, obs, theta, linear, first_order=True)
    J = np.hstack([obs.nuisance, A]) / obs.sigma[:, None]
    kept = analyse(J, [""] * J.shape[1], protected=n_nu, rtol=rtol,
                   typical=_typical(machine, theta, linear, n_nu)).kept
    lin_cols = np.array([c - n_nu for c in kept if c >= n_nu], dtype=int)
    for step, k in enumerate(nonlinear):
        # the columns of the other terms hardly depend on this coefficient: compute them once
        term = next(p for p in machine.term_spans() if p.start <= k < p.stop)
        own = np.array([i for i in range(term.start, term.stop) if i in set(linear[lin_cols].tolist())], dtype=int)
        others = np.array([i for i in linear[lin_cols] if i not in set(own.tolist())], dtype=int)
        _, A_other = predict_observations(machine, obs, theta, others)
        grid = np.r_[theta[k], machine.search_grid(k, theta, n=obs.n_points, **obs.covariates)]
        best, best_rss = theta.copy(), math.inf
        for value in grid:
            trial = theta.copy()
            trial[k] = value
            pred, A_own = predict_observations(machine, obs, trial, own)
            r = (obs.y - pred) / obs.sigma
            J = np.hstack([obs.nuisance, A_other, A_own]) / obs.sigma[:, None]
            scale, Js = _column_scale(J)  # linear coefficients only: SI sizes are typical
            delta = np.linalg.lstsq(Js, r, rcond=None)[0] / scale
            rss = float(np.sum((r - J @ delta) ** 2))
            if rss < best_rss:
                best_rss = rss
                best = trial.copy()
                best[others] += delta[n_nu:n_nu + len(others)]
                best[own] += delta[n_nu + len(others):]
        theta = best
        if progress:
            progress("non-linear start values", step + 1)
    return theta


def _poses(obs: Observations, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Pose index of every point (the same positions: several targets, or repeats) and the
    poses shuffled by ``seed``."""
    _, group = np.unique(np.round(obs.q, 12), axis=0, return_inverse=True)
    group = group.ravel()
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
    """
    group, order = _poses(obs, seed)
    if len(order) < 2 * folds:
        return None
    return [np.flatnonzero(np.isin(group, part)) for part in np.array_split(order, folds)]


def _cross_validate(machine, obs, theta0, free, columns, convention, folds, holdout, seed,
                    max_iter, tol, progress):
    if holdout is not None:
        if not 0.0 < holdout < 1.0:
            raise InputError(f"holdout must be a fraction between 0 and 1, got {holdout}")
        group, order = _poses(obs, seed)
        n_out = max(1, int(round(holdout * len(order))))
        splits = [np.flatnonzero(np.isin(group, order[:n_out]))]
        how = (f"random split, {n_out} of {len(order)} poses ({splits[0].size} of {obs.n_points} points) "
               f"held out (seed {seed})")
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
