"""The measure paths are compensated in, and the batch solver of their compensated points.

:class:`PoseMetric` compares the actual tool at commanded axis positions with the nominal
tool at desired ones: the position distance and, on machines with rotary axes, the tool-axis
angle times ``lever`` (metres per radian), the larger of the two.

:class:`PointSolver` finds compensated commands for many desired points at once, with few
evaluations of the model: Gauss-Newton steps on the *nominal* axis Jacobian (which the
errors change by parts in 1e5, so each step shrinks the residual by about that factor; the
Jacobian is computed once when it is the same everywhere, as on a Cartesian machine), then
steps on the actual Jacobian for the few points that do not converge so (singular poses).
Only the points still iterating are evaluated. It finds what
:func:`~volerr_pin.compensation.compensate_points` finds, in about a third of the
evaluations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import Machine, axis_jacobian, tool_poses
from ._points import MachineInputs, skew, solve_damped

__all__ = ["PointSolver", "PoseMetric", "SolvedPoints"]


class PoseMetric:
    """Poses of the tool and the residual measure of compensation (SI).

    Parameters
    ----------
    machine : Machine
        The machine, in the state compensated for.
    lever : float
        Weight of the tool-axis angle against the position [m per rad].
    orientation : bool
        Whether the tool axis counts (machines with rotary axes).

    Attributes
    ----------
    machine : Machine
        The machine.
    inputs : MachineInputs
        Its model, coefficients and state, as the algorithms take them.
    lever : float
        [m per rad].
    orientation : bool
        As given.
    scale : ndarray, shape (n_axes,)
        Column scale of each axis: 1 for linear axes, ``lever`` for rotary ones [m per unit].
    """

    def __init__(self, machine: Machine, lever: float, orientation: bool):
        self.machine = machine
        self.inputs = MachineInputs(machine)
        self.lever = float(lever)
        self.orientation = bool(orientation)
        self.scale = np.where(np.array(machine.axis_kinds) == "rotary", self.lever, 1.0)

    def actual(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool axis and tool point of the actual machine at commands ``q``.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded axis positions [m, rad] (outside the travel allowed).

        Returns
        -------
        a : ndarray, shape (N, 3)
            Tool axes (unit vectors, workpiece frame).
        p : ndarray, shape (N, 3)
            Tool points [m].
        """
        inputs = self.inputs
        R, p = tool_poses(inputs.model, q, inputs.theta, inputs.covariates(len(q)))
        return np.ascontiguousarray(R[:, :, 2]), p

    def nominal(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool axis and tool point of the nominal machine at ``q`` (see :meth:`actual`).

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Axis positions [m, rad].

        Returns
        -------
        a : ndarray, shape (N, 3)
            Tool axes.
        p : ndarray, shape (N, 3)
            Tool points [m].
        """
        R, p = tool_poses(self.inputs.model, q, nominal=True)
        return np.ascontiguousarray(R[:, :, 2]), p

    def jacobian(self, q: np.ndarray, nominal: bool = False) -> np.ndarray:
        """Axis Jacobians of the actual (or nominal) machine at commands ``q``.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            Commanded axis positions [m, rad] (outside the travel allowed).
        nominal : bool, default False
            The nominal machine.

        Returns
        -------
        ndarray, shape (N, 6, n_axes)
            As :func:`~volerr_pin.model.axis_jacobian` gives them.
        """
        inputs = self.inputs
        if nominal:
            return axis_jacobian(inputs.model, q, nominal=True)
        return axis_jacobian(inputs.model, q, inputs.theta, inputs.covariates(len(q)))

    def residual(self, a: np.ndarray, p: np.ndarray, a_d: np.ndarray, p_d: np.ndarray) -> np.ndarray:
        """The residual of actual poses against desired ones.

        Parameters
        ----------
        a, p : ndarray, shape (N, 3)
            Actual tool axes and points [m].
        a_d, p_d : ndarray, shape (N, 3)
            Desired (nominal) tool axes and points [m].

        Returns
        -------
        ndarray, shape (N,)
            ``|p - p_d|``, or its maximum with ``lever |a x a_d|`` when the tool axis counts [m].
        """
        d = p - p_d
        res = np.sqrt(np.einsum("ij,ij->i", d, d))
        if self.orientation:
            c = np.cross(a, a_d)
            res = np.maximum(res, self.lever * np.sqrt(np.einsum("ij,ij->i", c, c)))
        return res

    def difference(self, a: np.ndarray, p: np.ndarray, a_d: np.ndarray, p_d: np.ndarray) -> np.ndarray:
        """The residual as a vector: ``p - p_d`` and ``lever (a - a_d)`` (zero without orientation).

        Parameters
        ----------
        a, p, a_d, p_d : ndarray, shape (N, 3)
            As for :meth:`residual`.

        Returns
        -------
        ndarray, shape (N, 6)
            [m].
        """
        axis = self.lever * (a - a_d) if self.orientation else np.zeros_like(a)
        return np.concatenate([p - p_d, axis], axis=1)


@dataclass
class SolvedPoints:
    """Compensated commands of many desired points (SI).

    Attributes
    ----------
    c : ndarray, shape (N, n_axes)
        Compensated commands [m, rad].
    residual : ndarray, shape (N,)
        Residual at the commands (:meth:`PoseMetric.residual`) [m].
    before : ndarray, shape (N,)
        Residual at the desired points run uncompensated [m].
    a_d, p_d : ndarray, shape (N, 3)
        Nominal tool axes and points at the desired points (the targets).
    """

    c: np.ndarray
    residual: np.ndarray
    before: np.ndarray
    a_d: np.ndarray
    p_d: np.ndarray


class PointSolver:
    """Compensated commands for many desired points (see the module docstring).

    Parameters
    ----------
    metric : PoseMetric
        Poses and residual measure.
    method : "newton" or "recursive"
        ``"recursive"``: seed 002's recursion (nominal Jacobian only, positions only, as
        :func:`~volerr_pin.compensation.compensate_points`); ``"newton"``: nominal
        Jacobian steps, then actual-Jacobian steps for points that do not converge.
    tol : float
        Position tolerance of a point [m].
    tol_axis : float
        Tool-axis tolerance of a point [rad].
    max_iter : int, default 30
        Iteration limit.

    Attributes
    ----------
    metric : PoseMetric
        As given.
    method : str
        As given.
    tol, tol_axis : float
        As given.
    max_iter : int
        As given.
    """

    #: nominal-Jacobian steps before a point not yet converged gets actual-Jacobian steps
    NOMINAL_STEPS = 3

    def __init__(self, metric: PoseMetric, method: str, tol: float, tol_axis: float, max_iter: int = 30):
        self.metric = metric
        self.method = method
        self.tol = float(tol)
        self.tol_axis = float(tol_axis)
        self.max_iter = int(max_iter)
        self.orientation = metric.orientation and method != "recursive"
        self.damping = 0.05 if self.orientation else 1e-6
        #: residual rows of the nominal Jacobian when it is the same at every pose, else None
        self.constant_rows: np.ndarray | None = None
        #: their damped pseudo-inverse, shape (n_axes, 3) (``step = r @ constant.T``), else None
        self.constant = self._constant_jacobian()

    # Jacobians ------------------------------------------------------------------------
    def rows(self, J: np.ndarray, a: np.ndarray | None) -> np.ndarray:
        """Residual rows of axis Jacobians: position, and ``lever d a / d q`` with orientation.

        Parameters
        ----------
        J : ndarray, shape (N, 6, n_axes)
            Axis Jacobians (:meth:`PoseMetric.jacobian`).
        a : ndarray, shape (N, 3) or None
            Tool axes (needed with orientation).

        Returns
        -------
        ndarray, shape (N, 3 or 6, n_axes)
            The rows of :meth:`PoseMetric.difference` they move (the first three without
            orientation).
        """
        if not self.orientation:
            return J[:, :3, :]
        turn = -np.einsum("nij,njk->nik", skew(a), J[:, 3:, :]) * self.metric.lever
        return np.concatenate([J[:, :3, :], turn], axis=1)

    def _constant_jacobian(self) -> np.ndarray | None:
        """The damped pseudo-inverse of the nominal Jacobian when it is the same at every pose
        (every axis linear: the tool moves along fixed directions), else None."""
        machine = self.metric.machine
        if self.orientation or any(k != "linear" for k in machine.axis_kinds):
            return None
        rng = np.random.default_rng(1)
        travel = machine.travel
        q = travel[:, 0] + rng.random((8, len(machine.axes))) * (travel[:, 1] - travel[:, 0])
        J = self.metric.jacobian(q, nominal=True)[:, :3, :]
        if np.max(np.abs(J - J[0])) > 1e-12:
            return None
        self.constant_rows = J[0]
        Js = J[0] / self.metric.scale[None, :]
        inverse = np.linalg.solve(Js.T @ Js + self.damping**2 * np.eye(Js.shape[1]), Js.T)
        return inverse / self.metric.scale[:, None]

    def _nominal_step(self, q: np.ndarray, a: np.ndarray, r: np.ndarray) -> np.ndarray:
        if self.constant is not None:
            return r @ self.constant.T
        J = self.metric.jacobian(q, nominal=True)
        return solve_damped(self.rows(J, a), r, self.metric.scale, self.damping)

    def _actual_step(self, q: np.ndarray, a: np.ndarray, r: np.ndarray) -> np.ndarray:
        J = self.metric.jacobian(q)
        return solve_damped(self.rows(J, a), r, self.metric.scale, self.damping)

    # solving --------------------------------------------------------------------------
    def _vector(self, a, p, a_d, p_d) -> np.ndarray:
        if self.orientation:
            return np.concatenate([p - p_d, self.metric.lever * (a - a_d)], axis=1)
        return p - p_d

    def _within(self, a, p, a_d, p_d) -> tuple[np.ndarray, np.ndarray]:
        d = p - p_d
        pos = np.sqrt(np.einsum("ij,ij->i", d, d))
        ok = pos < self.tol
        if self.orientation:
            c = np.cross(a, a_d)
            ok &= np.sqrt(np.einsum("ij,ij->i", c, c)) < self.tol_axis
        return ok, pos

    def solve(self, q_d: np.ndarray, a_d: np.ndarray | None = None, p_d: np.ndarray | None = None) -> SolvedPoints:
        """Compensated commands for desired axis positions.

        Parameters
        ----------
        q_d : ndarray, shape (N, n_axes)
            Desired axis positions [m, rad].
        a_d, p_d : ndarray, shape (N, 3), optional
            Nominal tool axes and points at ``q_d``, when known already.

        Returns
        -------
        SolvedPoints
            Commands, residuals before and after, targets.
        """
        metric = self.metric
        q_d = np.asarray(q_d, dtype=float)
        n = len(q_d)
        if a_d is None or p_d is None:
            a_d, p_d = metric.nominal(q_d)
        if n == 0:
            empty = np.zeros(0)
            return SolvedPoints(q_d.copy(), empty, empty.copy(), a_d, p_d)
        a, p = metric.actual(q_d)
        before = metric.residual(a, p, a_d, p_d)
        residual = before.copy()  # at the current command of every point
        c = q_d.copy()
        ok, _ = self._within(a, p, a_d, p_d)
        active = np.flatnonzero(~ok)
        a, p = a[active], p[active]
        for it in range(self.max_iter):
            if not len(active):
                break
            r = self._vector(a, p, a_d[active], p_d[active])
            if it < self.NOMINAL_STEPS or self.method == "recursive":
                step = self._nominal_step(c[active], a, r)
            else:
                step = self._actual_step(c[active], a, r)
            c[active] -= step
            still = np.max(np.abs(step) * metric.scale, axis=1) >= 1e-13  # else: the least-squares optimum
            a, p = metric.actual(c[active])
            residual[active] = metric.residual(a, p, a_d[active], p_d[active])
            ok, _ = self._within(a, p, a_d[active], p_d[active])
            keep = ~ok & still
            active, a, p = active[keep], a[keep], p[keep]
        return SolvedPoints(c, residual, before, a_d, p_d)
