"""How a controller's compensation plays out on the machine.

The controller reads the commanded positions ``q``, adds its corrections ``c(q, direction)``
to the set-points, and the axes go to ``q + c``; the tool point then sits where the model
puts it at ``q + c`` (every error of the machine, in the direction each axis moved), and
the residual is that position minus the nominal tool point at ``q``, in the workpiece frame:

    r = p_actual(q + c) - p_nominal(q),

for the tool point ``L`` beyond the machine's tool point along the tool axis. Exact point
compensation (:func:`exact_setpoints`) solves ``r = 0`` for the set-points directly; it is
what no table can beat.

The positions evaluated here are the library's own (a zone's samples, their set-points), so
the model's algorithms evaluate them as they are; loops take the machine's inputs once
(:class:`~volerr_pin.compensation.MachineInputs`), and every function here takes
either.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...model import Machine, axis_jacobian, tool_poses
from ...base import UM_PER_M
from .._points import MachineInputs
from ._protocol import Compensation
from ._zone import Points

__all__ = ["Residuals", "exact_setpoints", "residuals", "summary", "tip_jacobian", "tool_tips"]

#: lever that scales rotary axes against linear ones in the exact solve [m per rad]
LEVER = 0.1


def _inputs(machine: Machine | MachineInputs) -> MachineInputs:
    """The machine's inputs (taken here, or given)."""
    return machine if isinstance(machine, MachineInputs) else MachineInputs(machine)


def tool_tips(machine: Machine | MachineInputs, q: np.ndarray, points: Points, nominal: bool = False) -> np.ndarray:
    """Tool points in the workpiece frame, ``L`` beyond the machine's tool point along the tool
    axis.

    Parameters
    ----------
    machine : Machine or MachineInputs
        The machine, or its inputs taken once.
    q : ndarray, shape (N, n_axes)
        Axis positions [m, rad] (set-points; may leave the travel by the corrections).
    points : Points
        Supplies the motion directions (for direction-dependent errors) and tool extensions.
    nominal : bool, default False
        The nominal machine instead of the actual one.

    Returns
    -------
    ndarray, shape (N, 3)
        Tool points [m].
    """
    inputs = _inputs(machine)
    if nominal:
        R, p = tool_poses(inputs.model, q, nominal=True)
    else:
        R, p = tool_poses(inputs.model, q, inputs.theta, inputs.covariates(len(q), points.directions))
    return p - points.tool[:, None] * R[:, :, 2]


def tip_jacobian(machine: Machine | MachineInputs, q: np.ndarray, points: Points) -> np.ndarray:
    """d (actual tool point) / d (axis positions), with the errors' position slopes.

    Parameters
    ----------
    machine : Machine or MachineInputs
        The machine, or its inputs taken once.
    q : ndarray, shape (N, n_axes)
        Axis positions [m, rad].
    points : Points
        Directions and tool extensions.

    Returns
    -------
    ndarray, shape (N, 3, n_axes)
        [m per m or rad].
    """
    inputs = _inputs(machine)
    cov = inputs.covariates(len(q), points.directions)
    J = axis_jacobian(inputs.model, q, inputs.theta, cov)
    R, _ = tool_poses(inputs.model, q, inputs.theta, cov)
    arm = -points.tool[:, None] * R[:, :, 2]                       # tip - tool point, workpiece axes
    # v_tip = v + w x arm = v - arm x w
    skew = np.zeros((len(q), 3, 3))
    skew[:, 0, 1], skew[:, 0, 2] = -arm[:, 2], arm[:, 1]
    skew[:, 1, 0], skew[:, 1, 2] = arm[:, 2], -arm[:, 0]
    skew[:, 2, 0], skew[:, 2, 1] = -arm[:, 1], arm[:, 0]
    return J[:, :3] - skew @ J[:, 3:]


def residuals(machine: Machine | MachineInputs, compensation: Compensation | None, points: Points) -> np.ndarray:
    """Position error of the tool point left when the controller applies ``compensation``.

    Parameters
    ----------
    machine : Machine or MachineInputs
        The machine, or its inputs taken once.
    compensation : Compensation or None
        What the controller adds to the set-points; None: nothing (the uncompensated error).
    points : Points
        Commanded positions in the order visited, directions, tools.

    Returns
    -------
    ndarray, shape (N, 3)
        Actual minus nominal tool point [m], workpiece frame.
    """
    inputs = _inputs(machine)
    target = tool_tips(inputs, points.q, points, nominal=True)
    setpoints = points.q if compensation is None else points.q + compensation.correction(
        points.q, points.directions, points.tool)
    return tool_tips(inputs, setpoints, points) - target


def exact_setpoints(machine: Machine | MachineInputs, points: Points, tol: float = 1e-11,
                    max_iter: int = 20) -> np.ndarray:
    """Set-points that put the actual tool point exactly on the nominal one at every point
    (Gauss-Newton on the exact tool-point Jacobian; least change, rotary axes weighted by a
    0.1 m lever, where the machine has more axes than three).

    Parameters
    ----------
    machine : Machine or MachineInputs
        The machine, or its inputs taken once.
    points : Points
        Commanded positions, directions, tools.
    tol : float, default 1e-11
        Stop when every residual is below this [m].
    max_iter : int, default 20
        Iteration limit.

    Returns
    -------
    ndarray, shape (N, n_axes)
        Set-points [m, rad].
    """
    inputs = _inputs(machine)
    scale = np.array([1.0 if k == "linear" else 1.0 / LEVER for k in inputs.model.axis_kinds])
    target = tool_tips(inputs, points.q, points, nominal=True)
    q = points.q.copy()
    for _ in range(max_iter):
        r = tool_tips(inputs, q, points) - target
        if np.abs(r).max() < tol:
            break
        J = tip_jacobian(inputs, q, points) * (1.0 / scale)
        step = np.einsum("nij,nj->ni", np.linalg.pinv(J), r)
        q = q - step / scale
    return q


@dataclass(frozen=True)
class Residuals:
    """Summary of tool-point position errors over points.

    Attributes
    ----------
    max_um : float
        Largest Euclidean norm of the position error [um].
    rms_um : float
        Root mean square of the norms [um].
    """

    max_um: float
    rms_um: float


def summary(r: np.ndarray) -> Residuals:
    """Largest and RMS Euclidean norm of position errors.

    Parameters
    ----------
    r : ndarray, shape (N, 3)
        Position errors [m].

    Returns
    -------
    Residuals
        In um.
    """
    norm = np.linalg.norm(r, axis=1) * UM_PER_M
    return Residuals(float(norm.max()), float(np.sqrt(np.mean(norm**2))))
