"""A machine's state and the covariates of its points: time [s], temperatures by sensor [degC],
process forces [N] and approach directions (+1/-1 per axis).

A state (:meth:`Machine.with_state`) holds one value of each for every point a call does not
give them for; :func:`check_covariates` converts and checks what a call gives, fills in the
state, and adds the lagged temperatures the terms read.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from .assembly import Assembly
from ..base.checks import real_array
from .effects import add_lagged_temperatures
from ..base.errors import InputError
from .terms import Covariates, TemperatureHistory

__all__ = ["COVARIATES", "check_covariates", "merge_state", "with_state_defaults"]

#: the covariates a machine can read
COVARIATES = ("t", "temperatures", "forces", "directions", "series", "history")


def merge_state(state: Mapping, axes: tuple[str, ...], t=None, temperatures: Mapping | None = None, forces=None,
                directions=None) -> dict:
    """A state with new values, checked: temperatures merged by sensor, the others replaced.

    Parameters
    ----------
    state : mapping
        The state so far (see :attr:`Machine.state`).
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


def with_state_defaults(state: Mapping, n: int, covariates: Mapping) -> dict:
    """The covariates of ``n`` points with the state's values where a call gives none.

    Parameters
    ----------
    state : mapping
        The machine's state (see :func:`merge_state`).
    n : int
        Number of points.
    covariates : mapping
        What the call gives.

    Returns
    -------
    dict
        The covariates, each of the state's values repeated for every point where the call
        gives none (temperatures sensor by sensor).
    """
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


def check_covariates(asm: Assembly, state: Mapping, n: int, covariates: Mapping) -> Covariates:
    """Check keyword covariates (t, temperatures, forces, directions; see
    :meth:`~volerr_pin.model.machine.Machine.volumetric_error`).

    Covariates not given are filled in from the state set by
    :meth:`~volerr_pin.model.machine.Machine.with_state`, and the lagged temperatures that terms read
    (``sensor@<lag>s``) are added.

    Parameters
    ----------
    asm : Assembly
        The assembled model: its axes name the columns of ``directions``, its terms the lagged
        temperatures to add.
    state : mapping
        The machine's state (:func:`merge_state`): the covariates not given.
    n : int
        Number of points.
    covariates : mapping
        ``t`` (n,) [s], ``temperatures`` {sensor: (n,)} [degC], ``forces`` (n, 3) [N],
        ``directions`` (n, n_axes) of +1/-1, ``series`` (n,) whole numbers naming the time
        series each point belongs to (the file it came from: a lagged temperature is read
        along its own series only), ``history`` the whole temperature record the points are
        part of (:class:`~volerr_pin.model.terms.TemperatureHistory`); missing or None entries are
        not given.

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
    axes = asm.axes
    known = set(COVARIATES)
    covariates = with_state_defaults(state, n, covariates)
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
                                   asm.lags)
