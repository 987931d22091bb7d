"""The checks every evaluation of a machine makes of its inputs: NC positions (shape, finite,
within the travel unless extrapolation is asked for), coefficients and the coefficients a
derivative is taken by (the covariates are :mod:`volerr_pin.model.state`'s).

Each function takes the assembled model (:class:`~volerr_pin.model.assembly.Assembly`) first;
:class:`~volerr_pin.model.machine.Machine` checks its inputs with them once, then calls the model
core (:mod:`volerr_pin.model.evaluate`).
"""

from __future__ import annotations

import numpy as np

from .assembly import Assembly
from ..base.checks import real_array
from ..base.errors import InputError
from ..base.safeio import require_memory

#: evaluations below this many bytes are not sized against the free memory
SMALL_REQUEST = 64 * 2**20

__all__ = ["check_parameters", "check_q", "check_theta", "outside_travel", "plausible_theta", "theta_bounds"]


def outside_travel(asm: Assembly, q: np.ndarray) -> np.ndarray:
    """Where positions leave the travel by more than rounding.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad] (not converted or checked).

    Returns
    -------
    ndarray of bool, shape (N, n_axes)
        True where ``q`` is below the lower or above the upper travel by more than 1e-9 of the
        span (at least 1e-9 m or rad).
    """
    span = asm.travel[:, 1] - asm.travel[:, 0]
    tol = 1e-9 * np.where(np.isfinite(span), np.maximum(span, 1.0), 1.0)
    return (q < asm.travel[:, 0] - tol) | (q > asm.travel[:, 1] + tol)


def check_theta(asm: Assembly, theta, limits: bool = False) -> np.ndarray:
    """Coefficients as a new float array, checked.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    theta : array_like, shape (P,)
        Coefficients in the SI unit of each (order of ``asm.names``).
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
    theta = real_array(theta, "theta", "theta")
    if theta.shape != (len(asm.names),):
        raise InputError(f"theta has shape {theta.shape}; expected ({len(asm.names)},) "
                         f"for the parameters of {asm.spec.name}")
    bad = np.flatnonzero(~np.isfinite(theta))
    if bad.size:
        raise InputError(f"theta[{bad[0]}] ({asm.names[bad[0]]}) is {theta[bad[0]]}")
    return plausible_theta(asm, theta) if limits else theta


def theta_bounds(asm: Assembly) -> np.ndarray:
    """Lowest and highest plausible SI value of each coefficient, by the spec's rules.

    Parameters
    ----------
    asm : Assembly
        The assembled model.

    Returns
    -------
    ndarray, shape (P, 2)
        The bounds (an error within 1 m or 1 rad, a time constant within 1e10 s, a period
        from a micrometre to 1 km), in the order of ``parameter_names``; read-only.
    """
    cached = asm.__dict__.get("_theta_bounds")   # the assembly is frozen: computed once, kept aside
    if cached is None:
        bounds = {name: b for comp in asm.spec.components for tspec in comp.terms
                  for name, b in zip(tspec.names(comp.name), tspec.term.coefficient_bounds())}
        cached = np.array([bounds[n] for n in asm.names]).reshape(-1, 2)
        cached.flags.writeable = False
        asm.__dict__["_theta_bounds"] = cached
    return cached


def plausible_theta(asm: Assembly, theta: np.ndarray) -> np.ndarray:
    """``theta`` (checked by :func:`check_theta`), refused beyond :func:`theta_bounds`.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
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
    low, high = theta_bounds(asm).T
    bad = np.flatnonzero((theta < low) | (theta > high))
    if bad.size:
        k = int(bad[0])
        name = asm.names[k]
        units = {n: u for comp in asm.spec.components for tspec in comp.terms
                 for n, u in zip(tspec.names(comp.name), tspec.term.coefficient_units())}
        factor, unit = units[name]
        raise InputError(f"theta[{k}] ({name}) = {theta[k] / factor:.10g} {unit} is implausible: "
                         f"the spec's limit is {low[k] / factor:.10g} .. {high[k] / factor:.10g} {unit}")
    return theta


def check_q(asm: Assembly, q, extrapolate: bool = False, columns: int = 0, name: str = "q") -> np.ndarray:
    """Convert ``q`` to a float array of NC positions and check it.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
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
        per_point = 8 * (64 + len(asm.names) + 8 * columns + 2 * len(asm.axes))
        if shape[0] * per_point > SMALL_REQUEST:   # the fits' many small calls read no /proc/meminfo
            require_memory(shape[0] * per_point, f"evaluating {shape[0]:,} positions {name}")
    q = real_array(q, f"{name} (shape (N, {len(asm.axes)}))", name)
    if q.ndim == 1 and q.shape[0] == len(asm.axes):
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != len(asm.axes):
        raise InputError(f"{name} has shape {q.shape}; expected (N, {len(asm.axes)}) with columns "
                         f"{', '.join(asm.axes)}")
    bad = np.argwhere(~np.isfinite(q))
    if bad.size:
        i, j = bad[0]
        raise InputError(f"{name}[{i}, {j}] (axis {asm.axes[j]}) is {q[i, j]}")
    if not extrapolate:
        outside = outside_travel(asm, q)
        if outside.any():
            i, j = np.argwhere(outside)[0]
            unit = "m" if asm.axis_kinds[j] == "linear" else "rad"
            raise InputError(
                f"{name}[{i}, {j}] = {q[i, j]:.6g} {unit} is outside the travel of axis {asm.axes[j]} "
                f"[{asm.travel[j, 0]:.6g}, {asm.travel[j, 1]:.6g}] {unit} "
                f"({int(outside.sum())} value(s) outside); pass extrapolate=True to evaluate there")
    return q


def check_parameters(asm: Assembly, parameters) -> np.ndarray:
    """Indices of ``theta`` (all when None), checked: negative indices would wrap.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    parameters : array_like of int or None
        Indices of coefficients.

    Returns
    -------
    ndarray of int, shape (P',)
        The indices.

    Raises
    ------
    InputError
        Naming ``parameters``, for values that are not indices of ``theta``.
    """
    count = len(asm.names)
    if parameters is None:
        return np.arange(count)
    raw = np.atleast_1d(np.asarray(parameters, dtype=object))
    if raw.ndim != 1 or not all(isinstance(p, (int, np.integer)) and not isinstance(p, bool)
                                and 0 <= p < count for p in raw):
        bad = next((p for p in raw.ravel() if not (isinstance(p, (int, np.integer)) and not isinstance(p, bool)
                                                  and 0 <= p < count)), raw)
        raise InputError(f"parameters must be indices of theta, 0 to {count - 1}, got {bad!r} (an index of "
                         "a name is parameter_names.index(name))", parameters=("parameters",))
    return raw.astype(int)
