"""The value checks of what a user gives a model, in O(N), made once where the input enters
(readers, the command line, :class:`~volerr_pin.model.Machine`), never in the algorithms' loops:
NC positions (shape, finite, within the travel unless extrapolation is asked for),
coefficients, the coefficients a derivative is taken by, a machine's state, and the
covariates of points (converted, filled in from the state, lagged temperatures added).

:func:`check_inputs` checks positions, coefficients and covariates at once and returns what
the algorithms (:mod:`volerr_pin.model`) take; the other functions are its parts.
"""

from __future__ import annotations

import numpy as np

from typing import Mapping

from ..base import InputError, real_array, require_memory
from ._effects import add_lagged_temperatures
from ._model import Model
from ._terms import Covariates, TemperatureHistory

#: evaluations below this many bytes are not sized against the free memory
SMALL_REQUEST = 64 * 2**20

__all__ = ["COVARIATES", "check_covariates", "check_inputs", "check_parameters", "check_q", "check_theta",
           "merge_state", "outside_travel", "plausible_theta", "theta_bounds"]

#: the covariates a machine can read
COVARIATES = ("t", "temperatures", "forces", "directions", "series", "history")


def outside_travel(model: Model, q: np.ndarray) -> np.ndarray:
    """Where positions leave the travel by more than rounding.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad] (not converted or checked).

    Returns
    -------
    ndarray of bool, shape (N, n_axes)
        True where ``q`` is below the lower or above the upper travel by more than 1e-9 of the
        span (at least 1e-9 m or rad).
    """
    span = model.travel[:, 1] - model.travel[:, 0]
    tol = 1e-9 * np.where(np.isfinite(span), np.maximum(span, 1.0), 1.0)
    return (q < model.travel[:, 0] - tol) | (q > model.travel[:, 1] + tol)


def check_theta(model: Model, theta, limits: bool = False) -> np.ndarray:
    """Coefficients as a new float array, checked.

    Parameters
    ----------
    model : Model
        The model.
    theta : array_like, shape (P,)
        Coefficients in the SI unit of each (order of ``model.names``).
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
    if theta.shape != (len(model.names),):
        raise InputError(f"theta has shape {theta.shape}; expected ({len(model.names)},) "
                         f"for the parameters of {model.spec.name}")
    bad = np.flatnonzero(~np.isfinite(theta))
    if bad.size:
        raise InputError(f"theta[{bad[0]}] ({model.names[bad[0]]}) is {theta[bad[0]]}")
    return plausible_theta(model, theta) if limits else theta


def theta_bounds(model: Model) -> np.ndarray:
    """Lowest and highest plausible SI value of each coefficient, by the spec's rules.

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    ndarray, shape (P, 2)
        The bounds (an error within 1 m or 1 rad, a time constant within 1e10 s, a period
        from a micrometre to 1 km), in the order of ``parameter_names``; read-only.
    """
    cached = model.__dict__.get("_theta_bounds")   # the model is frozen: computed once, kept aside
    if cached is None:
        bounds = {name: b for comp in model.spec.components for tspec in comp.terms
                  for name, b in zip(tspec.names(comp.name), tspec.term.coefficient_bounds())}
        cached = np.array([bounds[n] for n in model.names]).reshape(-1, 2)
        cached.flags.writeable = False
        model.__dict__["_theta_bounds"] = cached
    return cached


def plausible_theta(model: Model, theta: np.ndarray) -> np.ndarray:
    """``theta`` (checked by :func:`check_theta`), refused beyond :func:`theta_bounds`.

    Parameters
    ----------
    model : Model
        The model.
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
    low, high = theta_bounds(model).T
    bad = np.flatnonzero((theta < low) | (theta > high))
    if bad.size:
        k = int(bad[0])
        name = model.names[k]
        units = {n: u for comp in model.spec.components for tspec in comp.terms
                 for n, u in zip(tspec.names(comp.name), tspec.term.coefficient_units())}
        factor, unit = units[name]
        raise InputError(f"theta[{k}] ({name}) = {theta[k] / factor:.10g} {unit} is implausible: "
                         f"the spec's limit is {low[k] / factor:.10g} .. {high[k] / factor:.10g} {unit}")
    return theta


def check_q(model: Model, q, extrapolate: bool = False, columns: int = 0, name: str = "q") -> np.ndarray:
    """Convert ``q`` to a float array of NC positions and check it.

    Parameters
    ----------
    model : Model
        The model.
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
        per_point = 8 * (64 + len(model.names) + 8 * columns + 2 * len(model.axes))
        if shape[0] * per_point > SMALL_REQUEST:   # the fits' many small calls read no /proc/meminfo
            require_memory(shape[0] * per_point, f"evaluating {shape[0]:,} positions {name}")
    q = real_array(q, f"{name} (shape (N, {len(model.axes)}))", name)
    if q.ndim == 1 and q.shape[0] == len(model.axes):
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != len(model.axes):
        raise InputError(f"{name} has shape {q.shape}; expected (N, {len(model.axes)}) with columns "
                         f"{', '.join(model.axes)}")
    bad = np.argwhere(~np.isfinite(q))
    if bad.size:
        i, j = bad[0]
        raise InputError(f"{name}[{i}, {j}] (axis {model.axes[j]}) is {q[i, j]}")
    if not extrapolate:
        outside = outside_travel(model, q)
        if outside.any():
            i, j = np.argwhere(outside)[0]
            unit = "m" if model.axis_kinds[j] == "linear" else "rad"
            raise InputError(
                f"{name}[{i}, {j}] = {q[i, j]:.6g} {unit} is outside the travel of axis {model.axes[j]} "
                f"[{model.travel[j, 0]:.6g}, {model.travel[j, 1]:.6g}] {unit} "
                f"({int(outside.sum())} value(s) outside); pass extrapolate=True to evaluate there")
    return q


def check_parameters(model: Model, parameters) -> np.ndarray:
    """Indices of ``theta`` (all when None), checked: negative indices would wrap.

    Parameters
    ----------
    model : Model
        The model.
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
    count = len(model.names)
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


def merge_state(state: Mapping, axes: tuple[str, ...], t=None, temperatures: Mapping | None = None, forces=None,
                directions=None) -> dict:
    """A state with new values, checked: temperatures merged by sensor, the others replaced.

    Parameters
    ----------
    state : mapping
        The state so far (see :attr:`~volerr_pin.model.Machine.state`).
    axes : tuple of str
        The machine's axes (the length of ``directions``).
    t : float, optional
        Time [s].
    temperatures : mapping of str to float, optional
        Temperature by sensor name [degC]. An empty mapping changes nothing.
    forces : array_like, shape (3,), optional
        Process force Fx, Fy, Fz [N].
    directions : array_like, shape (n_axes,), optional
        Approach direction of each axis, +1 or -1.

    Returns
    -------
    dict
        The new state: ``t`` (float), ``temperatures`` ({sensor: float}), ``forces`` (ndarray,
        shape (3,)), ``directions`` (ndarray, shape (n_axes,)), those given so far.

    Raises
    ------
    InputError
        If a value is not a real number, ``forces`` is not three values, ``directions`` not
        n_axes values of +1 or -1, or a value of the state is not finite.
    """
    state = dict(state)
    if t is not None:
        value = real_array(t, "t", "t")
        if value.shape != ():
            raise InputError(f"t must be one time in s, got shape {value.shape}", parameters=("t",))
        state["t"] = float(value)
    if temperatures:
        if not isinstance(temperatures, Mapping):
            raise InputError("temperatures must map sensor names to degC", parameters=("temperatures",))
        given = {}
        for k, v in temperatures.items():
            value = real_array(v, f"temperatures[{k!r}]", "temperatures")
            if value.shape != ():
                raise InputError(f"temperatures[{k!r}] must be one value in degC, got shape {value.shape}",
                                 parameters=("temperatures",))
            given[str(k)] = float(value)
        state["temperatures"] = {**state.get("temperatures", {}), **given}
    if forces is not None:
        f = real_array(forces, "forces", "forces")
        if f.shape != (3,):
            raise InputError(f"forces must be three values (Fx, Fy, Fz in N), got shape {f.shape}")
        state["forces"] = f
    if directions is not None:
        d = real_array(directions, "directions", "directions")
        if d.shape != (len(axes),) or not np.all(np.isin(d, (-1.0, 1.0))):
            raise InputError(f"directions must be {len(axes)} values of +1 or -1 "
                             f"(axes {', '.join(axes)})")
        state["directions"] = d
    for key, value in state.items():
        values = value.values() if isinstance(value, dict) else np.atleast_1d(value)
        if not np.all(np.isfinite(list(values))):
            raise InputError(f"state '{key}' is not finite")
    return state


def _with_state(state: Mapping, n: int, covariates: Mapping) -> dict:
    """The covariates of ``n`` points with the state's values (:func:`merge_state`) repeated
    for every point where the call gives none (temperatures sensor by sensor)."""
    if not state:
        return dict(covariates)
    out = dict(covariates)
    if out.get("t") is None and "t" in state:
        out["t"] = np.full(n, state["t"])
    if "temperatures" in state:
        given = dict(out.get("temperatures") or {})
        for sensor, value in state["temperatures"].items():
            given.setdefault(sensor, np.full(n, value))
        out["temperatures"] = given
    if out.get("forces") is None and "forces" in state:
        out["forces"] = np.tile(state["forces"], (n, 1))
    if out.get("directions") is None and "directions" in state:
        out["directions"] = np.tile(state["directions"], (n, 1))
    return out


def check_covariates(model: Model, n: int, covariates: Mapping | None = None, state: Mapping | None = None) -> Covariates:
    """The covariates of ``n`` points as the algorithms take them, checked: converted, the ones
    not given filled in from ``state``, and the lagged temperatures that terms read
    (``sensor@<lag>s``) added.

    Parameters
    ----------
    model : Model
        The model: its axes name the columns of ``directions``, its terms the lagged
        temperatures to add.
    n : int
        Number of points.
    covariates : mapping, optional
        ``t`` (n,) [s], ``temperatures`` {sensor: (n,)} [degC], ``forces`` (n, 3) [N],
        ``directions`` (n, n_axes) of +1/-1, ``series`` (n,) whole numbers naming the time
        series each point belongs to (the file it came from: a lagged temperature is read
        along its own series only), ``history`` the whole temperature record the points are
        part of (:class:`~volerr_pin.model.TemperatureHistory`); missing or None entries are
        not given.
    state : mapping, optional
        A machine's state (:func:`merge_state`): the covariates not given.

    Returns
    -------
    Covariates
        The checked covariates as float arrays (SI).

    Raises
    ------
    InputError
        For an unknown covariate, a value that is not numeric, has the wrong shape or is not
        finite, a sensor name containing '@' (reserved for lags), directions other than +1 /
        -1, or a lagged temperature without ``t``.
    """
    axes = model.axes
    known = set(COVARIATES)
    covariates = _with_state(state or {}, n, covariates or {})
    unknown = sorted(set(covariates) - known)
    if unknown:
        raise InputError(f"unknown covariate(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")

    def vector(name, value, shape):
        array = real_array(value, f"covariate '{name}'", name.split("[")[0])
        if array.shape != shape:
            raise InputError(f"covariate '{name}' has shape {array.shape}; expected {shape}")
        bad = np.argwhere(~np.isfinite(array))
        if bad.size:
            raise InputError(f"covariate '{name}'[{', '.join(map(str, bad[0]))}] is not finite")
        return array

    t = covariates.get("t")
    t = None if t is None else vector("t", t, (n,))
    temps = {}
    for sensor, values in dict(covariates.get("temperatures") or {}).items():
        if "@" in str(sensor):
            raise InputError(f"temperature sensor name {sensor!r}: '@' is reserved for lags")
        temps[str(sensor)] = vector(f"temperatures[{sensor!r}]", values, (n,))
    forces = covariates.get("forces")
    forces = None if forces is None else vector("forces", forces, (n, 3))
    directions = covariates.get("directions")
    if directions is not None:
        directions = vector("directions", directions, (n, len(axes)))
        if not np.all(np.isin(directions, (-1.0, 1.0))):
            raise InputError("covariate 'directions' must hold only +1 and -1")
    series = covariates.get("series")
    if series is not None:
        series = vector("series", series, (n,))
        if not np.all(series == np.round(series)):
            raise InputError("covariate 'series' must hold whole numbers (one per time series)")
    history = covariates.get("history")
    if history is not None and not isinstance(history, TemperatureHistory):
        raise InputError(f"covariate 'history' must be a TemperatureHistory, got {type(history).__name__}")
    return add_lagged_temperatures(Covariates(n, t, temps, forces, directions, series, history),
                                   model.lags)


def check_inputs(model: Model, q, theta=None, covariates: Mapping | None = None, *, state: Mapping | None = None,
                 extrapolate: bool = False, columns: int = 0, name: str = "q"
                 ) -> tuple[np.ndarray, np.ndarray, Covariates]:
    """Positions, coefficients and covariates a user gives, checked at once: what the
    algorithms of :mod:`volerr_pin.model` take.

    Parameters
    ----------
    model : Model
        The model.
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad]; a single point becomes one row.
    theta : array_like, shape (P,), optional
        Coefficients (SI); default the spec's (``model.theta``).
    covariates : mapping, optional
        The points' covariates (see :func:`check_covariates`).
    state : mapping, optional
        A machine's state: the covariates not given.
    extrapolate : bool, default False
        Allow positions outside the travel.
    columns : int, default 0
        Columns of a sensitivity the evaluation returns per point (see :func:`check_q`).
    name : str, default "q"
        The caller's name of the positions, for messages.

    Returns
    -------
    q : ndarray, shape (N, n_axes)
        The positions, a new float array.
    theta : ndarray, shape (P,)
        The coefficients (``model.theta`` itself when not given: not to be modified).
    cov : Covariates
        The covariates.

    Raises
    ------
    InputError
        For invalid ``q`` (see :func:`check_q`), ``theta`` (see :func:`check_theta`) or
        covariates (see :func:`check_covariates`).
    """
    q = check_q(model, q, extrapolate, columns, name)
    theta = model.theta if theta is None else check_theta(model, theta)
    return q, theta, check_covariates(model, q.shape[0], covariates, state)
