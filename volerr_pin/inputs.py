"""The checks every evaluation of a machine makes of its inputs: NC positions (shape, finite,
within the travel unless extrapolation is asked for), coefficients and covariates.

Each function takes the machine first and is also its method (``m.check_q(q)`` is
``check_q(m, q)``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .checks import real_array
from .errors import InputError
from .terms import Covariates

if TYPE_CHECKING:  # the machine imports this module; its type is only named here
    from .machine import Machine

__all__ = ["check_inputs", "check_q", "check_theta", "outside_travel"]


def outside_travel(machine: "Machine", q: np.ndarray) -> np.ndarray:
    """Where positions leave the travel by more than rounding.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad] (not converted or checked).

    Returns
    -------
    ndarray of bool, shape (N, n_axes)
        True where ``q`` is below the lower or above the upper travel by more than 1e-9 of the
        span (at least 1e-9 m or rad).
    """
    span = machine.assembly.travel[:, 1] - machine.assembly.travel[:, 0]
    tol = 1e-9 * np.where(np.isfinite(span), np.maximum(span, 1.0), 1.0)
    return (q < machine.assembly.travel[:, 0] - tol) | (q > machine.assembly.travel[:, 1] + tol)


def check_theta(machine: "Machine", theta) -> np.ndarray:
    """Coefficients as a new float array, checked; the machine's own when not given.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    theta : array_like, shape (P,) or None
        Coefficients in the SI unit of each (order of ``parameter_names``).

    Returns
    -------
    ndarray, shape (P,)
        The coefficients.

    Raises
    ------
    InputError
        If ``theta`` does not have shape (P,) or holds a value that is not finite.
    """
    if theta is None:
        return machine.theta
    theta = real_array(theta, "theta", "theta")
    if theta.shape != (len(machine.assembly.names),):
        raise InputError(f"theta has shape {theta.shape}; expected ({len(machine.assembly.names)},) "
                         f"for the parameters of {machine.name}")
    bad = np.flatnonzero(~np.isfinite(theta))
    if bad.size:
        raise InputError(f"theta[{bad[0]}] ({machine.assembly.names[bad[0]]}) is {theta[bad[0]]}")
    return theta


def check_q(machine: "Machine", q, extrapolate: bool = False) -> np.ndarray:
    """Convert ``q`` to a float array of NC positions and check it.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad]; a single point becomes one row.
    extrapolate : bool, default False
        Allow positions outside the travel.

    Returns
    -------
    ndarray, shape (N, n_axes)
        The positions as a new float array [m, rad].

    Raises
    ------
    InputError
        If ``q`` is not real numbers, has the wrong shape, holds a value that is not finite, or
        (unless ``extrapolate``) leaves the travel (see :func:`outside_travel`).
    """
    q = real_array(q, f"q (shape (N, {len(machine.axes)}))", "q")
    if q.ndim == 1 and q.shape[0] == len(machine.axes):
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != len(machine.axes):
        raise InputError(f"q has shape {q.shape}; expected (N, {len(machine.axes)}) with columns "
                         f"{', '.join(machine.axes)}")
    bad = np.argwhere(~np.isfinite(q))
    if bad.size:
        i, j = bad[0]
        raise InputError(f"q[{i}, {j}] (axis {machine.axes[j]}) is {q[i, j]}")
    if not extrapolate:
        outside = machine.outside_travel(q)
        if outside.any():
            i, j = np.argwhere(outside)[0]
            unit = "m" if machine.axis_kinds[j] == "linear" else "rad"
            raise InputError(
                f"q[{i}, {j}] = {q[i, j]:.6g} {unit} is outside the travel of axis {machine.axes[j]} "
                f"[{machine.assembly.travel[j, 0]:.6g}, {machine.assembly.travel[j, 1]:.6g}] {unit} "
                f"({int(outside.sum())} value(s) outside); pass extrapolate=True to evaluate there")
    return q


def check_inputs(machine: "Machine", q, theta=None, *, extrapolate: bool = False, **covariates
                 ) -> tuple[np.ndarray, np.ndarray, Covariates]:
    """Check positions, coefficients and covariates at once, as every evaluation does.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad].
    theta : array_like, shape (P,), optional
        Coefficients (SI); defaults to the machine's.
    extrapolate : bool, default False
        Allow positions outside the travel.
    **covariates
        As for :meth:`~volerr_pin.machine.Machine.volumetric_error`.

    Returns
    -------
    q : ndarray, shape (N, n_axes)
        The positions (see :func:`check_q`).
    theta : ndarray, shape (P,)
        The coefficients (the machine's own array when not given: not to be modified).
    covariates : Covariates
        The covariates (see :func:`~volerr_pin.state.check_covariates`).

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    q = machine.check_q(q, extrapolate)
    return q, check_theta(machine, theta), machine.check_covariates(q.shape[0], covariates)
