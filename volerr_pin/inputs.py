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
from .safeio import require_memory
from .terms import Covariates

#: evaluations below this many bytes are not sized against the free memory
SMALL_REQUEST = 64 * 2**20

if TYPE_CHECKING:  # the machine imports this module; its type is only named here
    from .machine import Machine

__all__ = ["check_inputs", "check_q", "check_theta", "outside_travel", "plausible_theta", "theta_bounds"]


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


def check_theta(machine: "Machine", theta, limits: bool = False) -> np.ndarray:
    """Coefficients as a new float array, checked; the machine's own when not given.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    theta : array_like, shape (P,) or None
        Coefficients in the SI unit of each (order of ``parameter_names``).
    limits : bool, default False
        Also refuse values beyond the limits a spec would (:func:`plausible_theta`).

    Returns
    -------
    ndarray, shape (P,)
        The coefficients.

    Raises
    ------
    InputError
        If ``theta`` does not have shape (P,) or holds a value that is not finite (or, with
        ``limits``, one beyond its plausibility limits).
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
    return plausible_theta(machine, theta) if limits else theta


def theta_bounds(machine: "Machine") -> np.ndarray:
    """Lowest and highest plausible SI value of each coefficient, by the spec's rules.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    ndarray, shape (P, 2)
        The bounds (an error within 1 m or 1 rad, a time constant within 1e10 s, a period
        from a micrometre to 1 km), in the order of ``parameter_names``; read-only.
    """
    cached = machine.__dict__.get("_theta_bounds")
    if cached is None:
        bounds = {name: b for comp in machine.spec.components for tspec in comp.terms
                  for name, b in zip(tspec.names(comp.name), tspec.term.coefficient_bounds())}
        cached = np.array([bounds[n] for n in machine.parameter_names]).reshape(-1, 2)
        cached.flags.writeable = False
        machine.__dict__["_theta_bounds"] = cached
    return cached


def plausible_theta(machine: "Machine", theta: np.ndarray) -> np.ndarray:
    """``theta`` (checked by :func:`check_theta`), refused beyond :func:`theta_bounds`.

    Parameters
    ----------
    machine : Machine
        The machine.
    theta : ndarray, shape (P,)
        Coefficients, SI.

    Returns
    -------
    ndarray, shape (P,)
        ``theta``.

    Raises
    ------
    InputError
        Naming the first coefficient beyond its bounds, in its display unit.
    """
    low, high = theta_bounds(machine).T
    bad = np.flatnonzero((theta < low) | (theta > high))
    if bad.size:
        k = int(bad[0])
        name = machine.parameter_names[k]
        units = {n: u for comp in machine.spec.components for tspec in comp.terms
                 for n, u in zip(tspec.names(comp.name), tspec.term.coefficient_units())}
        factor, unit = units[name]
        raise InputError(f"theta[{k}] ({name}) = {theta[k] / factor:.10g} {unit} is implausible: "
                         f"the spec's limit is {low[k] / factor:.10g} .. {high[k] / factor:.10g} {unit}")
    return theta


def check_q(machine: "Machine", q, extrapolate: bool = False, columns: int = 0, name: str = "q") -> np.ndarray:
    """Convert ``q`` to a float array of NC positions and check it.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad]; a single point becomes one row.
    extrapolate : bool, default False
        Allow positions outside the travel.
    columns : int, default 0
        Columns of a sensitivity the evaluation returns per point (0 for errors alone): with
        the number of points, what the evaluation will hold, checked against the free memory
        before ``q`` is copied (a broadcast view of a billion points takes one row of memory).
    name : str, default "q"
        The caller's name of the positions (``q_desired``), so that a refusal names what the
        caller was given.

    Returns
    -------
    ndarray, shape (N, n_axes)
        The positions as a new float array [m, rad].

    Raises
    ------
    InputError
        If ``q`` is not real numbers, has the wrong shape, holds a value that is not finite, or
        (unless ``extrapolate``) leaves the travel (see :func:`outside_travel`), or more
        points than the free memory can evaluate at once.
    """
    shape = q.shape if isinstance(q, np.ndarray) else ()   # a list is already in memory
    if len(shape) == 2:
        # measured peaks: about 8 x (64 + P) bytes a point for errors, 8 x 8 per sensitivity column
        per_point = 8 * (64 + len(machine.assembly.names) + 8 * columns + 2 * len(machine.axes))
        if shape[0] * per_point > SMALL_REQUEST:   # the fits' many small calls read no /proc/meminfo
            require_memory(shape[0] * per_point, f"evaluating {shape[0]:,} positions {name}")
    q = real_array(q, f"{name} (shape (N, {len(machine.axes)}))", name)
    if q.ndim == 1 and q.shape[0] == len(machine.axes):
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != len(machine.axes):
        raise InputError(f"{name} has shape {q.shape}; expected (N, {len(machine.axes)}) with columns "
                         f"{', '.join(machine.axes)}")
    bad = np.argwhere(~np.isfinite(q))
    if bad.size:
        i, j = bad[0]
        raise InputError(f"{name}[{i}, {j}] (axis {machine.axes[j]}) is {q[i, j]}")
    if not extrapolate:
        outside = machine.outside_travel(q)
        if outside.any():
            i, j = np.argwhere(outside)[0]
            unit = "m" if machine.axis_kinds[j] == "linear" else "rad"
            raise InputError(
                f"{name}[{i}, {j}] = {q[i, j]:.6g} {unit} is outside the travel of axis {machine.axes[j]} "
                f"[{machine.assembly.travel[j, 0]:.6g}, {machine.assembly.travel[j, 1]:.6g}] {unit} "
                f"({int(outside.sum())} value(s) outside); pass extrapolate=True to evaluate there")
    return q


def check_inputs(machine: "Machine", q, theta=None, *, extrapolate: bool = False, columns: int = 0, **covariates
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
    columns : int, default 0
        Columns of a sensitivity the evaluation returns per point (0 for errors alone): with
        the number of points, what the evaluation will hold, checked against the free memory
        before ``q`` is copied (a broadcast view of a billion points is one row in memory).
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
        For invalid ``q``, ``theta`` or covariates, or more points than the free memory can
        evaluate at once (see :func:`check_q`).
    """
    q = machine.check_q(q, extrapolate, columns)
    return q, check_theta(machine, theta), machine.check_covariates(q.shape[0], covariates)
