"""How uncertain an error map, or the residual of a compensation, is: linear propagation
and Monte Carlo side by side (GUM and its Supplement 1).

For coefficients with estimate ``theta`` and covariance ``Sigma`` (:mod:`._covariance`), at
every point the position error ``f = e(q, theta)[:3]`` (plus a fixed offset for a
compensation's residual) has

- **linear** standard uncertainties ``u^2(f) = diag(S Sigma S^T)`` with the exact
  sensitivities ``S = d f / d theta`` at the estimate; the norm ``|f|`` through its direction
  ``n = f / |f|`` (``u^2 = n^T S Sigma S^T n``; where ``f = 0`` the norm has no derivative and
  ``sqrt(trace)`` is given); the largest ``|f|`` over the points through the gradient at the
  worst point, and the RMS over points through ``sum_i f_i^T S_i / (N RMS)``; 95 % intervals
  ``y +- 1.96 u``. A norm has no derivative at zero (GUM 5.1.2; Supplement 1, 5.8): where the
  vector behind a summary is within 1.96 of its own largest standard deviation of zero
  (``|f_worst| < 1.96 sqrt(lambda_max(C_worst))`` for the max; for the RMS the same of the
  stacked errors of all points), the linear interval is not applicable and only the Monte
  Carlo result is given (the compensated residual of an exact compensation is such a case);
- **Monte Carlo** (GUM S1): ``theta`` drawn from ``N(theta, Sigma)``, the exact kinematics
  evaluated for every draw; per point the mean and standard deviation over all draws and
  the 2.5 / 97.5 % quantiles over the first ``interval_samples`` draws; for the max and RMS
  over the points their mean, standard deviation and 2.5 / 97.5 % quantiles over all draws.

**Where they disagree.** A component's linear uncertainty is exact when the error is linear
in the coefficients. The model's kinematics is not: an angular error ``phi`` about an axis
at distance ``r`` moves the point by ``r (cos phi - 1)`` towards the axis and
``r sin phi`` across it, so Monte Carlo finds a mean shifted by ``-r sigma^2 / 2`` that the
linear propagation (mean = the estimate) cannot see, and a spread along the radius of about
``r sigma^2 / sqrt(2)`` where the linear one is 0. With errors of micrometres and arcseconds
the difference is below 1e-10 m; with large angular (rotary-axis) uncertainties it is not.
Non-linear terms (time constants, periods) and the summaries themselves are the other
source: ``|f|``, its max and its RMS are non-linear functions of ``f`` even when ``f`` is
linear, so near a zero of the error, or where several points compete for the worst one,
the Monte Carlo mean lies above the estimate (the expected maximum exceeds the maximum of
the expectations) and the intervals are skewed.

The comparison follows GUM S1 section 8: the linear interval ``y +- U`` and the Monte Carlo
interval agree when both endpoints differ by at most ``delta`` (half a unit in the second
significant digit of ``u``) or, when the sampling error of the Monte Carlo endpoint is
larger, by at most ``z`` of its standard errors (``z`` for a family-wise 0.1 % false alarm
rate over the tests made). Per point, the mean and the standard deviation of ``fx, fy, fz``
are compared the same way (standard errors ``u / sqrt(n)`` and ``u / sqrt(2 (n - 1))``).

**Compensation.** A compensation maps desired positions to commands. It is computed once
from the estimate; the machine the commands are sent to is the uncertain one, so the
residual at a desired position ``q`` is ``e(q_c, theta) + p_nom(q_c) - p_nom(q)``: zero at the
estimate for an exact point compensation, with the uncertainty of the error at ``q_c``.
:func:`point_compensation` is ``compensate.compensate_points`` on the estimate;
:func:`table_compensation` is a controller's tables, exported from the estimate and applied as
the controller applies them; any other is a callable with the same signature.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.special import ndtri

from ..base import UM_PER_M, InputError, require_memory
from ..model import Machine, check_covariates, check_parameters, check_q, sensitivity, to_engineering, tool_poses
from ._covariance import Covariance
from ._engine import Engine, InProcess
from ._montecarlo import (QUANTILE_TASK_BYTES, MonteCarlo, NormalSource, Points, make_points, point_quantiles,
                         run_monte_carlo)

__all__ = ["FieldUncertainty", "Linear", "Scalar", "UncertaintyStudy", "check_arguments", "compensated_points",
           "compare_scalar", "linear_propagation", "numerical_tolerance", "point_compensation", "study_uncertainty",
           "table_compensation", "z_family"]

#: coverage probability of the intervals and the normal coverage factor of the linear ones
COVERAGE = 0.95
K95 = float(ndtri(0.975))
#: family-wise false-alarm probability of the agreement tests
FAMILY_ALPHA = 1e-3


def z_family(tests: int, alpha: float = FAMILY_ALPHA) -> float:
    """Two-sided normal threshold for ``tests`` tests at a family-wise false-alarm rate ``alpha`` (Bonferroni).

    Parameters
    ----------
    tests : int
        Number of tests.
    alpha : float, default FAMILY_ALPHA
        Family-wise probability of a false alarm.

    Returns
    -------
    float
        ``ndtri(1 - alpha / (2 tests))``.
    """
    return float(ndtri(1.0 - alpha / (2.0 * max(1, tests))))


def numerical_tolerance(u: np.ndarray | float, digits: int = 2) -> np.ndarray:
    """GUM S1 7.9.2: half a unit in the last of ``digits`` significant digits of ``u``.

    Parameters
    ----------
    u : array_like
        Standard uncertainties (> 0; 0 gives 0).
    digits : int, default 2
        Significant digits.

    Returns
    -------
    ndarray
        ``0.5 * 10**(floor(log10 u) - digits + 1)``, same shape.
    """
    u = np.asarray(u, dtype=float)
    with np.errstate(divide="ignore"):
        exponent = np.floor(np.log10(np.where(u > 0, u, 1.0))) - digits + 1
    return np.where(u > 0, 0.5 * 10.0**exponent, 0.0)


def quantile_se(sorted_values: np.ndarray, p: float) -> float:
    """Standard error of the ``p`` sample quantile, from the order statistics that bracket it
    (distribution-free 95 % interval of the quantile / (2 x 1.96)).

    Parameters
    ----------
    sorted_values : ndarray, shape (n,)
        The sample, sorted.
    p : float
        Probability.

    Returns
    -------
    float
        The standard error, in the unit of the values.
    """
    n = len(sorted_values)
    half = K95 * math.sqrt(n * p * (1 - p))
    lo = int(max(0, math.floor(n * p - half)))
    hi = int(min(n - 1, math.ceil(n * p + half)))
    return float(sorted_values[hi] - sorted_values[lo]) / (2 * K95)


@dataclass(frozen=True)
class Scalar:
    """A summary (max or RMS over the points) by both methods (SI).

    Attributes
    ----------
    value : float
        At the estimate [m].
    linear_u : float
        Linear standard uncertainty [m].
    mc_mean, mc_std : float
        Monte Carlo mean and standard deviation [m].
    mc_low, mc_high : float
        Monte Carlo 2.5 % and 97.5 % quantiles [m].
    se_low, se_high : float
        Their standard errors [m].
    tolerance_low, tolerance_high : float
        What an endpoint may differ by and still agree [m].
    agree : bool or None
        Both endpoints of the linear interval within tolerance of the Monte Carlo ones; None
        where the linear interval is not applicable.
    applicable : bool
        The linear propagation applies: the vector behind the norm is farther from zero than
        1.96 of its largest standard deviation (``scale``).
    mc_upper : float
        Monte Carlo 95 % quantile, a one-sided 95 % upper bound [m].
    delta : float
        The numerical tolerance of the comparison (GUM S1 7.9.2: half a unit in the second
        significant digit of u) [m].
    draws : int
        The Monte Carlo draws.
    """

    value: float
    linear_u: float
    mc_mean: float
    mc_std: float
    mc_low: float
    mc_high: float
    se_low: float
    se_high: float
    tolerance_low: float
    tolerance_high: float
    agree: bool | None
    applicable: bool = True
    mc_upper: float = math.nan
    delta: float = 0.0
    draws: int = 0

    @property
    def draws_needed(self) -> int:
        """The draws at which both endpoints' sampling errors (times the test's ``z``) fall
        within ``delta``, so that the comparison resolves the numerical tolerance itself (GUM S1
        7.9); ``draws`` when they already do (int)."""
        if self.delta <= 0 or self.draws <= 0:
            return self.draws
        worst = max(self.tolerance_low, self.tolerance_high) / self.delta
        return max(self.draws, int(math.ceil(self.draws * worst**2)))

    @property
    def linear_low(self) -> float:
        """Lower end of the linear 95 % interval [m] (float)."""
        return self.value - K95 * self.linear_u

    @property
    def linear_high(self) -> float:
        """Upper end of the linear 95 % interval [m] (float)."""
        return self.value + K95 * self.linear_u

    def to_dict(self) -> dict:
        """The report fields, in um.

        Returns
        -------
        dict
            ``value``, ``linear`` {``applicable``, ``u``, ``low``, ``high`` (null where not
            applicable)}, ``monte_carlo`` {``mean``, ``u``, ``low``, ``high``, ``upper``},
            ``difference_low``, ``difference_high`` (null where not applicable),
            ``tolerance_low``, ``tolerance_high``, ``delta``, ``draws_needed``, ``agree``.
        """
        f = UM_PER_M
        on = self.applicable
        return {"value": self.value * f,
                "linear": {"applicable": on, "u": self.linear_u * f if on else None,
                           "low": self.linear_low * f if on else None, "high": self.linear_high * f if on else None},
                "monte_carlo": {"mean": self.mc_mean * f, "u": self.mc_std * f, "low": self.mc_low * f,
                                "high": self.mc_high * f, "upper": self.mc_upper * f},
                "difference_low": abs(self.linear_low - self.mc_low) * f if on else None,
                "difference_high": abs(self.linear_high - self.mc_high) * f if on else None,
                "tolerance_low": self.tolerance_low * f, "tolerance_high": self.tolerance_high * f,
                "delta": self.delta * f, "draws_needed": self.draws_needed,
                "agree": self.agree}


def compare_scalar(value: float, linear_u: float, draws: np.ndarray, z: float, scale: float = 0.0) -> Scalar:
    """Linear and Monte Carlo results of one summary side by side (GUM S1 section 8).

    Parameters
    ----------
    value : float
        The summary at the estimate [m].
    linear_u : float
        Its linear standard uncertainty [m].
    draws : ndarray, shape (n,)
        Its Monte Carlo values [m].
    z : float
        Standard errors an endpoint may differ by (see :func:`z_family`).
    scale : float, default 0
        The largest standard deviation of the vector behind the norm [m]: the linear interval
        applies where ``value >= 1.96 scale``.

    Returns
    -------
    Scalar
        Both results and whether they agree (None where the linear interval does not apply).
    """
    x = np.sort(np.asarray(draws, dtype=float))
    lo, hi = (float(v) for v in np.quantile(x, [(1 - COVERAGE) / 2, (1 + COVERAGE) / 2]))
    se_lo, se_hi = quantile_se(x, (1 - COVERAGE) / 2), quantile_se(x, (1 + COVERAGE) / 2)
    mc_std = float(x.std(ddof=1)) if len(x) > 1 else 0.0
    delta = float(numerical_tolerance(max(linear_u, mc_std)))
    tol_lo, tol_hi = max(delta, z * se_lo), max(delta, z * se_hi)
    applicable = bool(value >= K95 * scale)
    agree = (bool((abs(value - K95 * linear_u - lo) <= tol_lo) and (abs(value + K95 * linear_u - hi) <= tol_hi))
             if applicable else None)
    upper = float(np.quantile(x, COVERAGE)) if len(x) else math.nan
    return Scalar(float(value), float(linear_u), float(x.mean()), mc_std, lo, hi, se_lo, se_hi, tol_lo, tol_hi,
                  agree, applicable, upper, delta, len(x))


@dataclass(frozen=True)
class Linear:
    """Linear propagation over a set of points (SI).

    Attributes
    ----------
    u : ndarray, shape (N, 4)
        Standard uncertainties of ``fx, fy, fz, |f|`` [m].
    max_u : float
        Of the largest ``|f|`` over the points [m].
    rms_u : float
        Of the RMS of ``|f|`` over the points [m].
    worst : int
        The point of the largest ``|f|`` at the estimate.
    max_scale, rms_scale : float
        The largest standard deviation of the vector behind each summary [m]: the worst
        point's ``f``, and the stacked ``f`` of all points over ``sqrt(N)`` (where the summary is
        within 1.96 of it of zero, its linear interval does not apply).
    """

    u: np.ndarray
    max_u: float
    rms_u: float
    worst: int
    max_scale: float = 0.0
    rms_scale: float = 0.0


def linear_propagation(machine: Machine, covariance: Covariance, points: Points, block: int = 2048) -> Linear:
    """``u^2 = diag(S Sigma S^T)`` at every point, and of the max and RMS over them.

    Parameters
    ----------
    machine : Machine
        The machine at the estimate.
    covariance : Covariance
        The uncertain coefficients and their covariance.
    points : Points
        Where (their ``reference`` is the estimate's ``fx, fy, fz, |f|``).
    block : int, default 2048
        Points per sensitivity evaluation (memory: block x 3 x p doubles).

    Returns
    -------
    Linear
        Per point and summary standard uncertainties.

    Raises
    ------
    InputError
        If ``covariance.indices`` are not indices of the machine's coefficients.
    """
    model, theta = machine.model, machine.theta
    columns = check_parameters(model, covariance.indices)
    cov = check_covariates(model, points.n, None, machine.state)
    Sigma = covariance.matrix
    f = points.reference[:, :3]
    norm = points.reference[:, 3]
    u = np.empty((points.n, 4))
    worst = int(np.argmax(norm))
    g_rms = np.zeros(len(covariance.indices))
    g_max = np.zeros(len(covariance.indices))
    gram = np.zeros((len(covariance.indices),) * 2)   # sum of S_i^T S_i: the stacked errors' covariance
    max_scale = 0.0
    for start in range(0, points.n, block):
        rows = slice(start, min(start + block, points.n))
        S = sensitivity(model, points.q[rows], theta, cov.take(rows), columns=columns)[:, :3, :]
        C = np.einsum("nip,pq,njq->nij", S, Sigma, S)
        u[rows, :3] = np.sqrt(np.clip(np.einsum("nii->ni", C), 0.0, None))
        nb = norm[rows]
        direction = np.divide(f[rows], nb[:, None], out=np.zeros_like(f[rows]), where=nb[:, None] > 0)
        along = np.einsum("ni,nij,nj->n", direction, C, direction)
        u[rows, 3] = np.sqrt(np.clip(np.where(nb > 0, along, np.einsum("nii->n", C)), 0.0, None))
        g_rms += np.einsum("ni,nip->p", f[rows], S)
        gram += np.einsum("nip,niq->pq", S, S)
        if rows.start <= worst < rows.stop:
            k = worst - rows.start
            g_max = direction[k] @ S[k] if nb[k] > 0 else np.zeros(len(covariance.indices))
            max_scale = math.sqrt(max(0.0, float(np.linalg.eigvalsh((C[k] + C[k].T) / 2)[-1])))
    rms = math.sqrt(float(np.mean(norm**2)))
    g_rms = g_rms / (points.n * rms) if rms > 0 else np.zeros_like(g_rms)
    # the stacked errors' covariance S Sigma S^T shares its non-zero eigenvalues with L^T (sum S^T S) L
    root = covariance.factor()[covariance.indices]
    top = float(np.linalg.eigvalsh(root.T @ gram @ root)[-1]) if root.size else 0.0
    return Linear(u, math.sqrt(max(0.0, float(g_max @ Sigma @ g_max))),
                  math.sqrt(max(0.0, float(g_rms @ Sigma @ g_rms))), worst, max_scale,
                  math.sqrt(max(0.0, top) / points.n))


@dataclass(frozen=True)
class FieldUncertainty:
    """Both methods at every point of one field (the error map, or a compensation's residual), SI.

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        The desired NC positions [m, rad].
    estimate : ndarray, shape (N, 4)
        ``fx, fy, fz, |f|`` at the estimate [m].
    linear : Linear
        Linear propagation.
    mc_mean, mc_std : ndarray, shape (N, 4)
        Monte Carlo mean and standard deviation [m].
    interval : ndarray, shape (N, 4, 2)
        Monte Carlo 2.5 % and 97.5 % quantiles [m], over ``interval_samples`` draws.
    interval_samples : int
        Draws behind ``interval``.
    max : Scalar
        The largest ``|f|`` over the points.
    rms : Scalar
        The RMS of ``|f|`` over the points.
    disagree : ndarray of bool, shape (N,)
        Points where the mean or standard deviation of ``fx``, ``fy`` or ``fz`` differ beyond
        the tolerance.
    excess : ndarray, shape (N,)
        The largest difference over its tolerance at each point (above 1 where ``disagree``).
    max_draws : ndarray, shape (samples,), or None
        The largest ``|f|`` over the points in every Monte Carlo draw [m] (for pictures).
    """

    q: np.ndarray
    estimate: np.ndarray
    linear: Linear
    mc_mean: np.ndarray
    mc_std: np.ndarray
    interval: np.ndarray
    interval_samples: int
    max: Scalar
    rms: Scalar
    disagree: np.ndarray
    excess: np.ndarray
    max_draws: np.ndarray | None = None

    @property
    def u_position(self) -> np.ndarray:
        """Monte Carlo standard uncertainty of the position, ``sqrt(u_x^2 + u_y^2 + u_z^2)``, shape (N,) [m]."""
        return np.sqrt(np.sum(self.mc_std[:, :3] ** 2, axis=1))

    @property
    def linear_u_position(self) -> np.ndarray:
        """The same from the linear propagation, shape (N,) [m]."""
        return np.sqrt(np.sum(self.linear.u[:, :3] ** 2, axis=1))

    def to_dict(self, machine: Machine) -> dict:
        """The report fields, in um (positions in mm / deg).

        Parameters
        ----------
        machine : Machine
            The machine (its axis units).

        Returns
        -------
        dict
            ``points``, ``max_error_um`` and ``rms_error_um`` (:meth:`Scalar.to_dict`),
            ``u_position_um`` {``linear_max``, ``linear_rms``, ``monte_carlo_max``,
            ``monte_carlo_rms``}, ``points_disagreeing``, ``agree`` (every point, and every
            summary whose linear interval applies) and ``worst_disagreement``
            (null when every point agrees; else ``q``, ``linear_u_um``, ``monte_carlo_u_um``,
            ``bias_um``).
        """
        f = UM_PER_M
        lin, mc = self.linear_u_position, self.u_position
        worst = None
        if self.disagree.any():
            i = int(np.argmax(self.excess))
            worst = {"q": to_engineering(machine, self.q[i]).tolist(), "linear_u_um": float(lin[i] * f),
                     "monte_carlo_u_um": float(mc[i] * f),
                     "bias_um": float(np.linalg.norm(self.mc_mean[i, :3] - self.estimate[i, :3]) * f)}
        return {"points": int(len(self.q)), "max_error_um": self.max.to_dict(), "rms_error_um": self.rms.to_dict(),
                "u_position_um": {"linear_max": float(lin.max() * f),
                                  "linear_rms": float(np.sqrt(np.mean(lin**2)) * f),
                                  "monte_carlo_max": float(mc.max() * f),
                                  "monte_carlo_rms": float(np.sqrt(np.mean(mc**2)) * f)},
                "points_disagreeing": int(self.disagree.sum()),
                "agree": bool(all(s.agree for s in (self.max, self.rms) if s.applicable)
                              and not self.disagree.any()),
                "worst_disagreement": worst}

    def table(self, machine: Machine) -> tuple[list[str], np.ndarray]:
        """Every point's numbers as a table (positions in mm / deg, errors in um).

        Parameters
        ----------
        machine : Machine
            The machine (axis names and units).

        Returns
        -------
        header : list of str
            Column names.
        rows : ndarray, shape (N, columns)
            The values.
        """
        units = ["mm" if k == "linear" else "deg" for k in machine.axis_kinds]
        header = [f"{a.lower()}_{u}" for a, u in zip(machine.axes, units)]
        cols = [to_engineering(machine, self.q)]
        for name, k in (("dx", 0), ("dy", 1), ("dz", 2), ("norm", 3)):
            header += [f"{name}_um", f"{name}_u_linear_um", f"{name}_mean_um", f"{name}_u_um", f"{name}_low_um",
                       f"{name}_high_um"]
            cols.append(np.column_stack([self.estimate[:, k], self.linear.u[:, k], self.mc_mean[:, k],
                                         self.mc_std[:, k], self.interval[:, k, 0], self.interval[:, k, 1]]) * UM_PER_M)
        header.append("disagree")
        cols.append(self.disagree[:, None].astype(float))
        return header, np.hstack(cols)


def _field(machine: Machine, covariance: Covariance, points: Points, q_desired: np.ndarray, source, samples: int,
           interval_samples: int, engine: Engine, progress, stage: str) -> FieldUncertainty:
    linear = linear_propagation(machine, covariance, points)
    report = (lambda done, total: progress(f"{stage}: Monte Carlo", done, total)) if progress else None
    mc: MonteCarlo = run_monte_carlo(machine, source, points, samples, engine=engine, progress=report)
    report = (lambda done, total: progress(f"{stage}: intervals", done, total)) if progress else None
    interval = point_quantiles(machine, source, points, interval_samples, engine=engine, progress=report)
    z = z_family(4)
    est = points.reference
    rms_value = math.sqrt(float(np.mean(est[:, 3] ** 2)))
    mx = compare_scalar(float(est[:, 3].max()), linear.max_u, mc.max, z, linear.max_scale)
    rms = compare_scalar(rms_value, linear.rms_u, mc.rms, z, linear.rms_scale)
    n = samples
    std = mc.std[:, :3]
    u_lin = linear.u[:, :3]
    floor = 1e-9 * max(float(std.max()), float(u_lin.max()), 1e-300)
    delta = np.maximum(numerical_tolerance(np.maximum(u_lin, std)), floor)
    zp = z_family(6 * points.n)
    tol_mean = np.maximum(delta, zp * std / math.sqrt(n))
    tol_std = np.maximum(delta, zp * std / math.sqrt(2 * (n - 1)))
    excess = np.maximum(np.abs(mc.mean[:, :3] - est[:, :3]) / tol_mean, np.abs(std - u_lin) / tol_std).max(axis=1)
    return FieldUncertainty(q_desired, est, linear, mc.mean, mc.std, interval, interval_samples, mx, rms,
                            excess > 1.0, excess, np.asarray(mc.max, dtype=float))


def point_compensation(machine: Machine, **options) -> Callable[[np.ndarray], np.ndarray]:
    """Exact point compensation computed on ``machine`` (the estimate), as a command map.

    Parameters
    ----------
    machine : Machine
        The machine at the estimate.
    **options
        Passed to :func:`volerr_pin.compensation.compensate_points` (``method``, ``tol_um``, ...).

    Returns
    -------
    callable
        ``command(q_desired) -> q_commanded``, both (N, n_axes) [m, rad].
    """
    from ..compensation import compensate_points

    def command(q_desired: np.ndarray) -> np.ndarray:
        return compensate_points(machine, q_desired, **options).q

    return command


def table_compensation(machine: Machine, controller: str, **options) -> Callable[[np.ndarray], np.ndarray]:
    """A controller's compensation tables exported from ``machine`` (the estimate), as the
    command map the controller makes of them.

    The tables are laid out, fitted, rounded to the format, written and read back by the
    controller's rules (:func:`volerr_pin.compensation.export.export_tables`); the map adds the corrections
    the controller reads from them to the desired positions, with the tool at the machine's
    tool point and the approach directions of the machine's state. So the residual of the
    study holds what the tables cannot represent (their interpolation, their rounding) beside
    the uncertainty of the machine.

    Parameters
    ----------
    machine : Machine
        The machine at the estimate (its state included).
    controller : str
        ``linuxcnc``, ``isg``, ``siemens-840d``, ``heidenhain`` or ``fanuc``.
    **options
        Passed to :func:`volerr_pin.compensation.export.export_tables` (``zone``, ``kind``, ``nodes``,
        ``points``, ``seed``).

    Returns
    -------
    callable
        ``command(q_desired) -> q_commanded``, both (N, n_axes) [m, rad]; its ``__name__`` is
        the controller's and its ``export`` the :class:`~volerr_pin.compensation.export.ExportResult`.

    Raises
    ------
    InputError
        For an unknown controller, or a machine with direction-dependent terms (backlash) whose
        state gives no approach directions: a controller applies those tables by the direction
        each axis moved, and the model without directions holds the axes midway.
    SpecError
        For a machine the controller cannot compensate this way.
    """
    from ..compensation.export import controller_format, export_tables

    fmt = controller_format(controller)
    directions = machine.state.get("directions")
    if directions is None and "directions" in machine.covariates_used:
        raise InputError(f"compensation: {fmt.name} applies its tables by the direction each axis moved, and "
                         "the model has direction-dependent terms: give the direction each axis approaches from "
                         "in Machine.with_state (directions=+1 or -1 per axis)", parameters=("Machine.with_state",))
    result = export_tables(machine, fmt, **options)
    table = result.compensation
    approach = np.ones(len(machine.axes)) if directions is None else np.asarray(directions, dtype=float)

    def command(q_desired: np.ndarray) -> np.ndarray:
        q_desired = np.asarray(q_desired, dtype=float)
        d = np.broadcast_to(approach, q_desired.shape)
        return q_desired + table.correction(q_desired, d, np.zeros(len(q_desired)))

    command.__name__ = fmt.name
    command.export = result
    return command


def compensated_points(machine: Machine, q_desired: np.ndarray, command: Callable[[np.ndarray], np.ndarray]
                       ) -> Points:
    """The points at which a compensation's residual is evaluated.

    Parameters
    ----------
    machine : Machine
        The machine at the estimate.
    q_desired : ndarray, shape (N, n_axes)
        Desired NC positions [m, rad].
    command : callable
        The compensation: desired positions -> commanded positions, (N, n_axes) [m, rad].

    Returns
    -------
    Points
        At the commands, with offset ``p_nom(q_c) - p_nom(q_desired)`` so that ``f`` is the
        residual of the actual tool point against the desired nominal one.

    Raises
    ------
    InputError
        If ``q_desired`` is invalid, or the compensation returns another shape or values that
        are not finite.
    """
    return _compensated_points(machine, check_q(machine.model, q_desired, name="q_desired"), command)


def _compensated_points(machine: Machine, q_desired: np.ndarray, command: Callable[[np.ndarray], np.ndarray]
                        ) -> Points:
    """:func:`compensated_points` at checked desired positions."""
    q_c = np.asarray(command(q_desired), dtype=float)
    if q_c.shape != q_desired.shape or not np.isfinite(q_c).all():
        raise InputError(f"compensation: expected finite commands of shape {q_desired.shape}, got shape "
                         f"{q_c.shape}", parameters=("compensation",))
    _, p_c = tool_poses(machine.model, q_c, nominal=True)   # commands may leave the travel at its ends
    _, p_d = tool_poses(machine.model, q_desired, nominal=True)
    return make_points(machine, q_c, offset=p_c - p_d, extrapolate=True)


@dataclass(frozen=True)
class UncertaintyStudy:
    """Result of :func:`study_uncertainty`.

    Attributes
    ----------
    machine : Machine
        The machine at the estimate.
    covariance : Covariance
        What was propagated.
    samples : int
        Monte Carlo draws.
    seed : int
        Their seed.
    workers : int
        Worker processes that ran them.
    map : FieldUncertainty
        The volumetric error over the points.
    compensated : FieldUncertainty or None
        The residual after the compensation, at the same desired points.
    compensation : str
        Which compensation ("none", "point", or a given name).
    """

    machine: Machine
    covariance: Covariance
    samples: int
    seed: int
    workers: int
    map: FieldUncertainty
    compensated: FieldUncertainty | None
    compensation: str

    def to_dict(self) -> dict:
        """The JSON report (docs/reports.md).

        Returns
        -------
        dict
            ``machine``, ``source``, ``samples``, ``seed``, ``workers``, ``coverage``,
            ``interval_samples``, ``parameters`` (how many are uncertain), ``not_propagated``,
            ``map`` and ``compensation`` (:meth:`FieldUncertainty.to_dict`, or null) and
            ``compensation_method``.
        """
        return {"machine": self.machine.name, "source": self.covariance.source, "samples": self.samples,
                "seed": self.seed, "workers": self.workers, "coverage": COVERAGE,
                "interval_samples": self.map.interval_samples, "n_parameters": int(len(self.covariance.indices)),
                "not_propagated": list(self.covariance.not_propagated),
                "map": self.map.to_dict(self.machine),
                "compensation_method": self.compensation,
                "compensation": None if self.compensated is None else self.compensated.to_dict(self.machine)}


def check_arguments(samples, seed, interval_samples=None) -> tuple[int, int, int]:
    """Check the size and seed of an uncertainty study before any work.

    Parameters
    ----------
    samples : int
        Monte Carlo draws (>= 2).
    seed : int
        Seed (>= 0).
    interval_samples : int, optional
        Draws behind the per-point intervals (2 to ``samples``; default ``min(samples, 1000)``).

    Returns
    -------
    tuple of int
        ``samples``, ``seed``, ``interval_samples``.

    Raises
    ------
    InputError
        Naming the parameter that is out of range or not a whole number.
    """
    if isinstance(samples, bool) or not float(samples).is_integer() or samples < 2:
        raise InputError(f"samples must be a whole number >= 2, got {samples!r}", parameters=("samples",))
    samples = int(samples)
    if isinstance(seed, bool) or int(seed) != seed or seed < 0:
        raise InputError(f"seed must be a non-negative whole number, got {seed!r}", parameters=("seed",))
    interval_samples = min(samples, 1000) if interval_samples is None else interval_samples
    if isinstance(interval_samples, bool) or int(interval_samples) != interval_samples or \
            not 2 <= interval_samples <= samples:
        raise InputError(f"interval_samples must be a whole number from 2 to samples ({samples}), got "
                         f"{interval_samples!r}", parameters=("interval_samples", "samples"))
    if interval_samples * 32 > QUANTILE_TASK_BYTES:
        raise InputError(f"interval_samples: {interval_samples:,} draws at one point need more than "
                         f"{QUANTILE_TASK_BYTES >> 20} MB; the per-point intervals take at most "
                         f"{QUANTILE_TASK_BYTES // 32:,}", parameters=("interval_samples",))
    require_memory(samples * 24.0, f"a study of {samples:,} draws", ("samples",))
    return samples, int(seed), int(interval_samples)


def study_uncertainty(covariance: Covariance, q: np.ndarray, *, samples: int = 2000, seed: int = 0,
                      interval_samples: int | None = None, compensation: Callable | str | None = None,
                      engine: Engine | None = None, progress=None) -> UncertaintyStudy:
    """Linear and Monte Carlo uncertainty of the error map at ``q`` (and of a compensation's residual).

    Parameters
    ----------
    covariance : Covariance
        The estimate (its machine) and the covariance of its uncertain coefficients.
    q : ndarray, shape (N, n_axes)
        Desired NC positions [m, rad].
    samples : int, default 2000
        Monte Carlo draws.
    seed : int, default 0
        Seed of the draws (chunk ``k`` draws from ``SeedSequence(seed, spawn_key=(k,))``).
    interval_samples : int, optional
        Draws behind the per-point intervals (default ``min(samples, 1000)``).
    compensation : callable, str or None
        None: the map only. "point": exact point compensation on the estimate
        (:func:`point_compensation`). A controller's name (``linuxcnc``, ``isg``,
        ``siemens-840d``, ``heidenhain``, ``fanuc``): its tables exported from the estimate, as
        the controller applies them (:func:`table_compensation`, default layout over the whole
        travel). A callable ``q_desired -> q_commanded``: any other.
    engine : Engine, optional
        Where the Monte Carlo runs (default in this process).
    progress : callable(stage, done, total), optional
        Called as tasks finish.

    Returns
    -------
    UncertaintyStudy
        Both methods, side by side, for the map and the residual.

    Raises
    ------
    InputError
        If ``samples`` or ``interval_samples`` is not a whole number >= 2 (``interval_samples``
        at most ``samples``), ``seed`` is negative, ``q`` is invalid, or ``compensation`` is a
        name other than those above (and as :func:`table_compensation` raises).
    """
    machine = covariance.machine
    samples, seed, interval_samples = check_arguments(samples, seed, interval_samples)
    engine = engine or InProcess()
    points = make_points(machine, q)   # q checked here, once
    q = points.q
    source = NormalSource(machine.theta, covariance.factor(), int(seed))
    field = _field(machine, covariance, points, q, source, samples, int(interval_samples), engine, progress, "map")
    residual, name = None, "none"
    if compensation is not None:
        name = compensation if isinstance(compensation, str) else getattr(compensation, "__name__", "given")
        if compensation == "point":
            compensation = point_compensation(machine)
        elif isinstance(compensation, str):
            from ..compensation.export import CONTROLLERS

            if compensation not in CONTROLLERS:
                raise InputError(f"compensation must be 'point', a controller ({', '.join(CONTROLLERS)}) or a "
                                 f"callable, got {compensation!r}", parameters=("compensation",))
            compensation = table_compensation(machine, compensation)
        cpoints = _compensated_points(machine, q, compensation)
        residual = _field(machine, covariance, cpoints, q, source, samples, int(interval_samples), engine, progress,
                          "compensation")
    return UncertaintyStudy(machine, covariance, samples, int(seed), engine.workers, field, residual, name)
