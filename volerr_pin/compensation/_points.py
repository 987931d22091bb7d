"""Point compensation: commanded positions that put the actual tool where the nominal one should be.

For desired NC positions ``q_d`` the target is the nominal tool pose at ``q_d``; the
compensated command ``q_c`` makes the *actual* pose match it.

- ``method="recursive"``: seed 002's scheme, ``Xc(n) = Xd - sum_{i<n} e(i)`` with
  ``e(i) = X_actual(Xc(i)) - Xd`` (eqs. 15-21), generalised to any machine by mapping the
  position error through the nominal axis Jacobian (the identity on a Cartesian machine,
  where it is exactly the paper's recursion). It corrects positions only.
- ``method="newton"``: Gauss-Newton on the exact axis Jacobian of the actual machine. On
  machines with rotary axes it also corrects the tool axis (position rows plus the tool-axis
  direction weighted by ``lever`` metres per radian), which is the pose compensation of a
  5-axis head. Points whose solution leaves the travel are reported as unreachable.

**Paths** (seed 002) are compensated by :class:`~volerr_pin.compensation.PathCompensator`,
built on these points (rapid moves at their end point; straight and helical moves split at
their largest residual until every point is within the tolerance).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..base import UM_PER_M, URAD_PER_RAD, InputError, integer as _integer, positive as _positive, require_memory
from ..model import (Covariates, Machine, Model, axis_jacobian, check_covariates, check_q, outside_travel,
                     tool_poses)

#: memory of one point compensated by :func:`compensate_points` (measured: 1.4-2.1 kB) [bytes]
COMPENSATION_BYTES = 2500

__all__ = ["MachineInputs", "PointCompensation", "compensate_checked", "compensate_points", "evaluate_compensation",
           "has_rotary", "solve_damped", "skew"]


class MachineInputs:
    """What the algorithms of :mod:`volerr_pin.model` take of a machine, taken from it once: its
    model, its coefficients and the covariates of its state, for any number of points.

    Loops that evaluate a machine in one state (the path compensation's solver, a controller's
    simulated tables) hold one and call the algorithms with it. The state is checked on first
    use (:func:`~volerr_pin.model.check_covariates` of one point, its refusals included) and
    its covariates are repeated for the points evaluated, the values the machine's own
    evaluations would give them.

    Parameters
    ----------
    machine : Machine
        The machine, in its state (:meth:`Machine.with_state`).

    Attributes
    ----------
    model : Model
        The machine's model.
    theta : ndarray, shape (P,)
        Its coefficients (SI; a copy, taken once).
    """

    __slots__ = ("model", "theta", "_state", "_one")

    def __init__(self, machine: Machine):
        self.model = machine.model
        self.theta = machine.theta
        self._state = machine.state
        self._one: Covariates | None = None

    def covariates(self, n: int, directions: np.ndarray | None = None) -> Covariates:
        """The covariates of ``n`` points in the machine's state.

        Parameters
        ----------
        n : int
            Number of points.
        directions : ndarray, shape (n, n_axes), optional
            The points' own motion directions (+1 or -1, made by the library), in place of the
            state's.

        Returns
        -------
        Covariates
            The state's values at every point.

        Raises
        ------
        InputError
            If the state cannot give what the model reads (a lagged temperature without ``t``).
        """
        if self._one is None:
            self._one = check_covariates(self.model, 1, None, self._state)
        cov = self._one.take(np.zeros(n, dtype=np.intp))
        return cov if directions is None else replace(cov, directions=directions)


@dataclass
class PointCompensation:
    """Result of :func:`compensate_points` (SI).

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        Compensated commands [m, rad].
    residual : ndarray, shape (N,)
        Position residual ``|p_actual(q) - p_nominal(q_d)|`` [m].
    axis_residual : ndarray, shape (N,)
        Tool-axis residual (sine of the angle between actual and desired tool axes) [rad]; 0
        where the tool axis is not corrected.
    before : ndarray, shape (N,)
        Position error without compensation [m].
    axis_before : ndarray, shape (N,)
        Tool-axis error without compensation [rad].
    iterations : ndarray of int, shape (N,)
        Iterations used.
    converged : ndarray of bool, shape (N,)
        Within tolerance, or at the least-squares optimum.
    reachable : ndarray of bool, shape (N,)
        The compensated command lies within the travel.
    within_tolerance : ndarray of bool, shape (N,)
        Residuals below the tolerances.
    history : list of ndarray
        Recursive scheme: the position residual vectors, shape (N, 3) [m], per step; empty
        for Newton.
    """

    q: np.ndarray
    residual: np.ndarray
    axis_residual: np.ndarray
    before: np.ndarray
    axis_before: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    reachable: np.ndarray
    within_tolerance: np.ndarray
    history: list = field(default_factory=list)


def has_rotary(machine: Machine) -> bool:
    """Whether a machine has a rotary axis (its tool axis can then be corrected).

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    bool
        True if any axis is rotary.
    """
    return any(k == "rotary" for k in machine.axis_kinds)


def compensate_points(machine: Machine, q_desired, *, method: str = "newton", tol_um: float = 0.01,
                      tol_urad: float = 0.1, max_iter: int = 30, orientation: bool | None = None,
                      lever: float = 0.1, **covariates) -> PointCompensation:
    """Compensated commands for the desired NC positions ``q_desired``, SI.

    The target is the nominal tool pose at ``q_desired``; the command makes the actual pose
    match it (see the module docstring for the two methods). Iterations stop when the position
    residual is below ``tol_um`` (and the tool-axis residual below ``tol_urad``), when the
    command stops moving (the least-squares optimum of a machine with fewer axes than error
    directions), or after ``max_iter``. Each iteration evaluates only the points still
    iterating.

    Parameters
    ----------
    machine : Machine
        The machine (its errors, and a state set by :meth:`Machine.with_state`).
    q_desired : array_like, shape (N, n_axes)
        Desired NC positions [m, rad], within the travel.
    method : "newton" or "recursive", default "newton"
        Gauss-Newton on the exact axis Jacobian, or seed 002's recursion (positions only).
    tol_um : float, default 0.01
        Position tolerance [um]: iterations stop below it.
    tol_urad : float, default 0.1
        Tool-axis tolerance [urad] (when the tool axis is corrected).
    max_iter : int, default 30
        Iteration limit.
    orientation : bool, optional
        Also correct the tool axis (default: when the machine has rotary axes; never with
        ``method="recursive"``).
    lever : float, default 0.1
        Weight of the tool-axis direction against the position [m per rad]; also the column
        scale of rotary axes.
    **covariates
        As for :meth:`Machine.volumetric_error` (None values are dropped).

    Returns
    -------
    PointCompensation
        The commands, residuals before and after, and per-point status.

    Raises
    ------
    InputError
        If ``method`` is unknown, ``tol_um``, ``tol_urad`` or ``lever`` is not a positive
        finite number, ``max_iter`` is not a whole number >= 0, ``q_desired`` or the
        covariates are invalid, or ``q_desired`` holds more points than the free memory can
        compensate at once.
    """
    if method not in ("newton", "recursive"):
        raise InputError(f"method must be 'newton' or 'recursive', got {method!r}", parameters=("method",))
    tol_um, tol_urad, lever = _positive("tol_um", tol_um), _positive("tol_urad", tol_urad), _positive("lever", lever)
    max_iter = _integer("max_iter", max_iter, 0)
    q_d = check_q(machine.model, q_desired, name="q_desired")
    require_memory(len(q_d) * COMPENSATION_BYTES, f"compensating {len(q_d):,} positions", ("q_desired",))
    cov = check_covariates(machine.model, len(q_d), {k: v for k, v in covariates.items() if v is not None},
                           machine.state)
    orientation = has_rotary(machine) if orientation is None else orientation
    return compensate_checked(machine.model, machine.theta, q_d, cov, method=method, tol_um=tol_um,
                              tol_urad=tol_urad, max_iter=max_iter, orientation=orientation, lever=lever)


def compensate_checked(model: Model, theta: np.ndarray, q_d: np.ndarray, cov: Covariates, *, method: str = "newton",
                       tol_um: float = 0.01, tol_urad: float = 0.1, max_iter: int = 30, orientation: bool = False,
                       lever: float = 0.1) -> PointCompensation:
    """:func:`compensate_points` of positions and covariates checked already, on the model's
    algorithms: for the library's own loops over positions it laid out.

    The iterations evaluate only the points still iterating, with their covariates sliced from
    ``cov`` (:meth:`Covariates.take <volerr_pin.model.Covariates.take>`), outside the travel
    too (a compensated command may leave it; the result says where).

    Parameters
    ----------
    model : Model
        The machine's model.
    theta : ndarray, shape (P,)
        Its coefficients (SI).
    q_d : ndarray, shape (N, n_axes)
        Desired NC positions [m, rad], checked (:func:`~volerr_pin.model.check_q`).
    cov : Covariates
        Their covariates, checked (:func:`~volerr_pin.model.check_covariates`).
    method : "newton" or "recursive", default "newton"
        As for :func:`compensate_points`.
    tol_um, tol_urad : float
        Tolerances [um, urad], as for :func:`compensate_points`.
    max_iter : int, default 30
        Iteration limit.
    orientation : bool, default False
        Also correct the tool axis (never with ``method="recursive"``).
    lever : float, default 0.1
        Weight of the tool-axis direction [m per rad], and the column scale of rotary axes.

    Returns
    -------
    PointCompensation
        The commands, residuals before and after, and per-point status.
    """
    if method == "recursive":
        orientation = False
    n = len(q_d)
    R_d, p_d = tool_poses(model, q_d, nominal=True)
    a_d = R_d[:, :, 2]
    R0, p0 = tool_poses(model, q_d, theta, cov)
    before = np.linalg.norm(p0 - p_d, axis=1)
    axis_before = np.linalg.norm(np.cross(R0[:, :, 2], a_d), axis=1)
    q = q_d.copy()
    iterations = np.zeros(n, dtype=int)
    res = before.copy()
    a_err = axis_before.copy() if orientation else np.zeros(n)
    within = (res < tol_um * 1e-6) & (a_err < tol_urad * 1e-6)
    stationary = np.zeros(n, dtype=bool)
    history = [p0 - p_d] if method == "recursive" else []
    nominal_J = None
    scale = np.where(np.array(model.axis_kinds) == "rotary", lever, 1.0)
    R, p = R0, p0
    active = np.flatnonzero(~within)
    for it in range(max_iter):
        if not len(active):
            break
        iterations[active] += 1
        e = p - p_d[active]
        cov_active = cov.take(active)
        if method == "recursive":
            if nominal_J is None:
                nominal_J = axis_jacobian(model, q_d, nominal=True)[:, :3, :]
            dq = solve_damped(nominal_J[active], e, scale, damping=1e-9)
        else:
            J = axis_jacobian(model, q[active], theta, cov_active)
            rows, rhs = [J[:, :3, :]], [e]
            if orientation:
                a = R[:, :, 2]
                # d a / d q = omega x a = -[a]x omega
                rows.append(-np.einsum("nij,njk->nik", skew(a), J[:, 3:, :]) * lever)
                rhs.append((a - a_d[active]) * lever)
            dq = solve_damped(np.concatenate(rows, axis=1), np.concatenate(rhs, axis=1), scale)
        q[active] -= dq
        # a machine with fewer axes than error directions (a 2-axis lathe) stops at the
        # least-squares optimum: the part of the error no axis can move is left
        stationary[active] = np.max(np.abs(dq) * scale, axis=1) < 1e-13
        R, p = tool_poses(model, q[active], theta, cov_active)
        if method == "recursive":
            step = history[-1].copy()  # points no longer iterating keep their residual
            step[active] = p - p_d[active]
            history.append(step)
        res[active] = np.linalg.norm(p - p_d[active], axis=1)
        if orientation:
            a_err[active] = np.linalg.norm(np.cross(R[:, :, 2], a_d[active]), axis=1)
        within[active] = (res[active] < tol_um * 1e-6) & (a_err[active] < tol_urad * 1e-6)
        keep = ~(within[active] | stationary[active])
        active, R, p = active[keep], R[keep], p[keep]
    done = within | stationary
    reachable = ~outside_travel(model, q).any(axis=1)
    return PointCompensation(q, res, a_err, before, axis_before, iterations, done, reachable, within, history)


def skew(a: np.ndarray) -> np.ndarray:
    """Cross-product matrices of many vectors.

    Parameters
    ----------
    a : ndarray, shape (N, 3)
        The vectors.

    Returns
    -------
    ndarray, shape (N, 3, 3)
        ``[a]x`` with ``[a]x b = a x b``.
    """
    S = np.zeros((len(a), 3, 3))
    S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -a[:, 2], a[:, 1], -a[:, 0]
    S[:, 1, 0], S[:, 2, 0], S[:, 2, 1] = a[:, 2], -a[:, 1], a[:, 0]
    return S


def solve_damped(J: np.ndarray, r: np.ndarray, scale: np.ndarray, damping: float = 0.05) -> np.ndarray:
    """Batched damped least squares ``J dq = r`` in scaled columns (``dq = x / scale``).

    The corrections sought are micrometres; near a singular pose (a rotary axis parallel to
    the tool axis) an undamped step would be huge. With damping ``lambda`` the scaled step
    in a direction of singular value ``s`` is ``s r / (s^2 + lambda^2)``, at most
    ``|r| / (2 lambda)``: well-conditioned directions converge as Newton, singular ones
    stay put (and the residual there is reported, not hidden).

    Parameters
    ----------
    J : ndarray, shape (N, m, n)
        Jacobians (rows: residual components; columns: axes).
    r : ndarray, shape (N, m)
        Residuals.
    scale : ndarray, shape (n,)
        Column scales (a rotary axis' radian counts as ``scale`` metres).
    damping : float, default 0.05
        Damping ``lambda`` in scaled units.

    Returns
    -------
    ndarray, shape (N, n)
        The steps.
    """
    Js = J / scale[None, None, :]
    JT = np.swapaxes(Js, 1, 2)
    A = JT @ Js + damping**2 * np.eye(J.shape[2])[None]
    x = np.linalg.solve(A, np.einsum("nij,nj->ni", JT, r)[..., None])[..., 0]
    return x / scale[None, :]


def evaluate_compensation(machine: Machine, q: np.ndarray, **covariates) -> dict:
    """Predicted tool position error over ``q`` without and with point compensation.

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (N, n_axes)
        Desired NC positions [m, rad].
    **covariates
        Passed to :func:`compensate_points` (covariates, or its keyword options).

    Returns
    -------
    dict
        ``points``, ``reachable``, ``max_before_um``, ``rms_before_um``, ``max_after_um``,
        ``rms_after_um`` (over the reachable points; None if there are none) [um],
        ``reduction_percent`` (100 (1 - RMS after / RMS before) over the reachable points;
        None when there are none or they have no error) and
        ``max_iterations``; on machines with rotary axes also the tool-axis error
        ``max_axis_before_urad``, ``rms_axis_before_urad``, ``max_axis_after_urad``,
        ``rms_axis_after_urad`` [urad] and ``not_within_tolerance`` (count).

    Raises
    ------
    InputError
        If ``q`` holds no points, or ``q`` or the covariates are invalid.
    """
    res = compensate_points(machine, q, **covariates)
    if len(res.q) == 0:
        raise InputError("q holds no points: there is nothing to compensate", parameters=("q",))
    before, after = res.before * UM_PER_M, res.residual * UM_PER_M
    ok = res.reachable
    out = {"points": int(len(q)), "reachable": int(ok.sum()),
           "max_before_um": float(before.max()), "rms_before_um": float(np.sqrt(np.mean(before**2))),
           "max_after_um": float(after[ok].max()) if ok.any() else None,
           "rms_after_um": float(np.sqrt(np.mean(after[ok] ** 2))) if ok.any() else None,
           "reduction_percent": float(100 * (1 - np.sqrt(np.mean(after[ok] ** 2)) / np.sqrt(np.mean(before[ok] ** 2))))
           if ok.any() and np.any(before[ok] > 0) else None,
           "max_iterations": int(res.iterations.max()) if len(q) else 0}
    if has_rotary(machine):
        axis_before = res.axis_before * URAD_PER_RAD
        out["max_axis_before_urad"] = float(axis_before.max())
        axis_after = (res.axis_residual * URAD_PER_RAD)[ok]
        out["rms_axis_before_urad"] = float(np.sqrt(np.mean(axis_before**2)))
        out["max_axis_after_urad"] = float(axis_after.max()) if ok.any() else None
        out["rms_axis_after_urad"] = float(np.sqrt(np.mean(axis_after**2))) if ok.any() else None
        out["not_within_tolerance"] = int((~res.within_tolerance).sum())
    return out
