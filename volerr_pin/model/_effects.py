"""Effect terms: thermal drift and expansion, backlash, force deflection, periodic pitch.

Each is a :class:`~volerr_pin.model.Term` of a component error, driven by covariates (time
``t``, ``temperatures``, ``forces``, ``directions``) and, for some, the axis position. All
give exact derivatives with respect to their coefficients (including the non-linear ones:
time constants and periods) and to the axis position. Spec keys (units in the names) are
documented in ``docs/spec-format.md``.

Forms (value in the component's unit, SI inside):

- ``thermal_drift``, driver ``time``: ``sum_k a_k g(t; tau_k)`` with
  ``g = 1 - exp(-t / tau)`` for ``0 <= t <= t_stop`` (0 before t = 0) and
  ``g = (1 - exp(-t_stop / tau)) exp(-(t - t_stop) / tau)`` after a stop at ``t_stop``
  (cooling). Coefficients ``a1, tau1, a2, tau2, ...``.
- ``thermal_drift``, driver ``temperature``: ``sum_s k_s (T_s(t - lag) - T_ref,s)``;
  coefficients ``k_<sensor>``. A lag reads each sensor ``lag`` seconds earlier, from the
  points' own time series (linear interpolation; the first sample holds before it).
- ``thermal_expansion``, driver ``temperature``: ``alpha (T - T_ref) (q - q0)``, alpha in
  1/K (coefficient ``alpha``); driver ``time`` (Srivastava et al.): ``(q - q0) sum_k
  s_k (1 - exp(-t / tau_k))``, strains ``s_k``, coefficients ``s1, tau1, ...``.
- ``backlash``: ``(b / 2) d`` with the axis' approach direction ``d = +-1`` (0 when no
  directions are given: the mean of both); coefficient ``b``.
- ``force_deflection``: ``F_i sum_k c_k P_k(u)``, a compliance (Legendre in the axis
  position over its travel when more than one coefficient) times one force component;
  coefficients ``c0, c1, ...``. ``model = "beam"`` computes c0 from seed 004's
  simply-supported beam, ``b (L^2 - b^2)^1.5 / (9 sqrt(3) E I L)``; ``model = "torsion"``
  from ``32 e a / (G pi d^4)``.
- ``periodic_pitch``: ``sum_h s_h sin(2 pi h (q - q0) / p) + c_h cos(2 pi h (q - q0) / p)``;
  coefficients ``s1, c1, s2, c2, ..., period``.
  On a rotary axis ``q``, ``p`` and ``q0`` are angles (``period_deg = 360`` repeats once per
  revolution).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import legendre

from ..base import ANGLE, TIME, InputError, SpecError, scale, within
from ._speckeys import TermSite, find_key, number, numbers, stem_of, unit_of
from ._terms import MAX_COEFFICIENTS, Context, Covariates, Term


STATE_HINT = "; give it with the points, or hold the machine in a state (Machine.with_state)"
#: what STATE_HINT names, for interfaces that say it in their own words
STATE_API = ("Machine.with_state",)


def _need_t(ctx: Context, kind: str) -> np.ndarray:
    t = ctx.covariates.t
    if t is None:
        raise InputError(f"{ctx.component}: its {kind} term needs the covariate t (time, s){STATE_HINT}",
                         parameters=STATE_API)
    return t


def _need_temperature(ctx: Context, sensor: str, lag: float = 0.0) -> np.ndarray:
    key = sensor if lag == 0.0 else lagged_name(sensor, lag)
    temps = ctx.covariates.temperatures
    if key not in temps:
        known = ", ".join(k for k in temps if "@" not in k) or "none"
        raise InputError(f"{ctx.component}: this term needs the temperature of sensor '{sensor}' "
                         f"(given: {known}){STATE_HINT}", parameters=STATE_API)
    return temps[key]


def lagged_name(sensor: str, lag: float) -> str:
    """The covariate key of a sensor's temperature read ``lag`` seconds earlier: ``"T1@30s"``.

    Parameters
    ----------
    sensor : str
        The sensor's name.
    lag : float
        The lag [s].

    Returns
    -------
    str
        ``<sensor>@<lag>s``, the lag written with ``:g``.
    """
    return f"{sensor}@{lag:g}s"


def add_lagged_temperatures(cov: Covariates, requests) -> Covariates:
    """Covariates with ``sensor@<lag>s`` entries: each sensor read ``lag`` s earlier along
    the points' own time series (sorted by t; linear interpolation; before the first sample
    the first value holds) - the whole record (``history``) when the covariates carry it, else
    the points themselves. Points of different ``series`` (files) are different series: a lag
    never reaches from one file into another, whose clock may start at 0 again."""
    if not requests:
        return cov
    if cov.t is None:
        raise InputError("a temperature lag needs the covariate t (time, s)")
    series = np.zeros(cov.n) if cov.series is None else cov.series
    record = cov.history   # the whole record, when the points are a part of it
    rec_t = cov.t if record is None else record.t
    rec_series = series if record is None else record.series
    temps = dict(cov.temperatures)
    for sensor, lag in requests:
        if sensor not in cov.temperatures or (record is not None and sensor not in record.temperatures):
            raise InputError(f"a term reads sensor '{sensor}' {lag:g} s earlier, but no temperature "
                             f"'{sensor}' is given")
        rec_values = cov.temperatures[sensor] if record is None else record.temperatures[sensor]
        lagged = np.empty(cov.n)
        for s in np.unique(series):
            rows = np.flatnonzero(series == s)
            samples = np.flatnonzero(rec_series == s)
            order = samples[np.argsort(rec_t[samples], kind="stable")]
            lagged[rows] = np.interp(cov.t[rows] - lag, rec_t[order], rec_values[order])
        temps[lagged_name(sensor, lag)] = lagged
    return Covariates(cov.n, cov.t, temps, cov.forces, cov.directions, cov.series, cov.history)


def _saturation(t: np.ndarray, tau: float, stop: float | None):
    """g(t; tau) and dg/dtau for heating from t = 0 and cooling after ``stop``."""
    t = np.asarray(t, dtype=float)
    heat = np.clip(t, 0.0, None) if stop is None else np.clip(t, 0.0, stop)
    e = np.exp(-heat / tau)
    g = 1.0 - e
    dg = -e * heat / tau**2
    if stop is not None:
        after = t > stop
        if np.any(after):
            dt = t[after] - stop
            decay = np.exp(-dt / tau)
            g_stop, dg_stop = g[after], dg[after]
            g[after] = g_stop * decay
            dg[after] = dg_stop * decay + g_stop * decay * dt / tau**2
    return g, dg


def _tau_grid(cov: Covariates) -> np.ndarray:
    if cov.t is None or cov.t.size < 2:
        return np.array([])
    span = float(np.ptp(cov.t))
    if span <= 0:
        return np.array([])
    return np.geomspace(span / 300.0, 3.0 * span, 48)


@dataclass(frozen=True, eq=False)
class DriftTime(Term):
    """Thermal drift driven by time: ``sum_k a_k g(t; tau_k)``, heating from t = 0 and cooling
    after ``stop`` (the module's forms); coefficients ``a1, tau1, a2, tau2, ...``.

    Attributes
    ----------
    unit : str
        The display unit of the error in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.
    count : int
        Number of exponentials.
    stop : float or None
        The time heating stops and cooling starts [s]; None: no stop.
    time_unit : str
        The display unit of the time constants in the spec (``s``, ``min``, ``h``).

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``value``: the drift at the points' times ``t``.
    - ``jacobian``: derivatives of the drift with respect to the amplitudes and time constants.
    - ``search_grid``: candidate time constants: 48 values spaced geometrically from 1/300 to 3
      times the span of ``t``.
    - ``coefficient_units``: (SI per display unit, display unit) of each coefficient: the
      error's unit for the amplitudes, ``time_unit`` for the time constants.
    - ``coefficient_limits``: the plausibility limit of each coefficient, the time constants
      held positive ("time_constant").
    - ``to_spec``: the spec table: ``driver = "time"``, ``amplitudes_<unit>``,
      ``time_constants_<unit>`` and ``stop_<unit>`` when heating stops.
    - ``from_spec``: read a time-driven drift from its spec table.
    """

    unit: str
    unit_scale: float
    count: int
    stop: float | None
    time_unit: str
    kind = "thermal_drift"
    covariates = ("t",)

    @property
    def local_names(self):  # type: ignore[override]
        """Names of the coefficients: amplitude and time constant of each exponential, ``a1, tau1, ...``."""
        return tuple(n for k in range(1, self.count + 1) for n in (f"a{k}", f"tau{k}"))

    @property
    def nonlinear(self):  # type: ignore[override]
        """The time constants ``tau1, ...``, which the value is not linear in."""
        return tuple(f"tau{k}" for k in range(1, self.count + 1))

    def value(self, coefficients, ctx):
        t = _need_t(ctx, "thermal_drift")
        return sum(coefficients[2 * k] * _saturation(t, coefficients[2 * k + 1], self.stop)[0] for k in range(self.count))

    def jacobian(self, coefficients, ctx):
        t = _need_t(ctx, "thermal_drift")
        out = np.empty((ctx.n, 2 * self.count))
        for k in range(self.count):
            g, dg = _saturation(t, coefficients[2 * k + 1], self.stop)
            out[:, 2 * k] = g
            out[:, 2 * k + 1] = coefficients[2 * k] * dg
        return out

    def search_grid(self, name, coefficients, covariates):
        return _tau_grid(covariates)

    def coefficient_units(self):
        return [(self.unit_scale, self.unit), (TIME[self.time_unit], self.time_unit)] * self.count

    def coefficient_limits(self):
        return _with_time_constants(self)

    def to_spec(self, coefficients):
        table = {"kind": "thermal_drift", "driver": "time",
                 f"amplitudes_{self.unit}": [float(coefficients[2 * k] / self.unit_scale) for k in range(self.count)],
                 f"time_constants_{self.time_unit}": [float(coefficients[2 * k + 1] / TIME[self.time_unit])
                                                      for k in range(self.count)]}
        if self.stop is not None:
            table[f"stop_{self.time_unit}"] = float(self.stop / TIME[self.time_unit])
        return table

    keys = frozenset({"driver", "amplitudes", "time_constants", "stop"})

    @classmethod
    def from_spec(cls, table, site):
        amps, unit, factor, akey = site.value(table, "amplitudes")
        _count(amps.size, site, akey, "amplitudes")
        taus = _time_constants(table, site, amps.size)
        tunit = unit_of(find_key(table, "time_constants", site.where)[1], "time_constants")
        stop, _, _, skey = site.value(table, "stop", "time", required=False, count=1)
        if stop is not None and stop[0] < 0:
            raise SpecError(f"{site.where}.{skey}: heating stops at or after t = 0, got {table[skey]}")
        stop = None if stop is None else float(stop[0])
        return cls(unit, factor, amps.size, stop, tunit), np.ravel(np.column_stack([amps, taus]))


@dataclass(frozen=True, eq=False)
class DriftTemperature(Term):
    """Thermal drift driven by temperatures: ``sum_s k_s (T_s(t - lag) - T_ref,s)``;
    coefficients ``k_<sensor>`` [m/K or rad/K].

    Attributes
    ----------
    unit : str
        The display unit of the error in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.
    sensors : tuple of str
        The temperature sensors it reads.
    reference : tuple of float
        The reference temperature of each sensor [degC].
    lag : float
        How much earlier each sensor is read [s]; 0: at the points' own times.

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``lag_requests``: (sensor, lag) for each sensor when the term has a lag.
    - ``temperature_sensors``: the sensors the term reads.
    - ``coefficient_units``: (SI per display unit, display unit) of each coefficient: the
      error's unit per kelvin.
    - ``jacobian``: the temperature differences ``T_s(t - lag) - T_ref,s`` of the sensors.
    - ``value``: the drift, the temperature differences times the coefficients.
    - ``to_spec``: the spec table: ``driver = "temperature"``, ``sensors``,
      ``coefficients_<unit>_per_K``, ``reference_degC`` and ``lag_s`` when there is a lag.
    - ``from_spec``: read a temperature-driven drift from its spec table (reference 20 degC and
      no lag by default).
    """

    unit: str
    unit_scale: float
    sensors: tuple[str, ...]
    reference: tuple[float, ...]
    lag: float
    kind = "thermal_drift"
    covariates = ("temperatures",)

    @property
    def local_names(self):  # type: ignore[override]
        """Names of the coefficients, ``k_<sensor>`` for each sensor."""
        return tuple(f"k_{s}" for s in self.sensors)

    def lag_requests(self):
        return tuple((s, self.lag) for s in self.sensors) if self.lag else ()

    def temperature_sensors(self):
        return self.sensors

    def coefficient_units(self):
        return [(self.unit_scale, f"{self.unit}/K")] * self.size

    def jacobian(self, coefficients, ctx):
        return np.column_stack([_need_temperature(ctx, s, self.lag) - ref
                                for s, ref in zip(self.sensors, self.reference)])

    def value(self, coefficients, ctx):
        return self.jacobian(coefficients, ctx) @ coefficients

    def to_spec(self, coefficients):
        table = {"kind": "thermal_drift", "driver": "temperature", "sensors": list(self.sensors),
                 f"coefficients_{self.unit}_per_K": [float(v / self.unit_scale) for v in coefficients],
                 "reference_degC": list(self.reference)}
        if self.lag:
            table["lag_s"] = self.lag
        return table

    keys = frozenset({"driver", "sensors", "coefficients", "reference_degC", "lag_s"})

    @classmethod
    def from_spec(cls, table, site):
        where = site.where
        sensors = table.get("sensors")
        if not isinstance(sensors, list) or not sensors or not all(isinstance(s, str) and s for s in sensors):
            raise SpecError(f"{where}.sensors: expected a list of sensor names, got {sensors!r}")
        twice = sorted({s for s in sensors if sensors.count(s) > 1})
        if twice:
            raise SpecError(f"{where}.sensors: sensor '{twice[0]}' is listed twice")
        coef, unit, factor, _ = site.value(table, "coefficients", count=len(sensors), per="K")
        ref = _temperatures(table.get("reference_degC", 20.0), f"{where}.reference_degC")
        ref = np.broadcast_to(ref, (len(sensors),)) if ref.size == 1 else numbers(
            ref, f"{where}.reference_degC", len(sensors))
        lag = number(table.get("lag_s", 0.0), f"{where}.lag_s")
        if lag < 0:
            raise SpecError(f"{where}.lag_s: must be >= 0")
        within(np.array([lag]), "time", f"{where}.lag_s", "s", 1.0)
        return cls(unit, factor, tuple(sensors), tuple(float(r) for r in ref), lag), coef


@dataclass(frozen=True, eq=False)
class ExpansionTemperature(Term):
    """Thermal expansion of a linear axis driven by a temperature: ``alpha (T - T_ref) (q - q0)``;
    one coefficient ``alpha`` [1/K].

    Attributes
    ----------
    sensor : str
        The temperature sensor it reads.
    reference : float
        The reference temperature ``T_ref`` [degC].
    origin : float
        The axis position ``q0`` the expansion is measured from [m].

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``temperature_sensors``: the sensor the term reads.
    - ``coefficient_units``: (SI per display unit, display unit) of ``alpha``: ppm/K.
    - ``value``: the expansion ``alpha (T - T_ref) (q - q0)``.
    - ``jacobian``: the derivative with respect to ``alpha``, ``(T - T_ref) (q - q0)``.
    - ``position_slope``: the derivative with respect to the axis position, ``alpha (T -
      T_ref)``.
    - ``to_spec``: the spec table: ``driver = "temperature"``, ``sensor``,
      ``coefficient_ppm_per_K``, ``reference_degC`` and ``origin_mm``.
    - ``from_spec``: read a temperature-driven expansion from its spec table
      (``coefficient_per_K`` or ``coefficient_ppm_per_K``, within +-1 per K; reference 20 degC and
      origin 0 by default).
    """

    sensor: str
    reference: float
    origin: float
    kind = "thermal_expansion"
    axis_only = True
    linear_length_only = True
    covariates = ("temperatures",)

    local_names = ("alpha",)

    def temperature_sensors(self):
        return (self.sensor,)

    def coefficient_units(self):
        return [(1e-6, "ppm/K")]

    def _parts(self, ctx):
        return _need_temperature(ctx, self.sensor) - self.reference, ctx.position - self.origin

    def value(self, coefficients, ctx):
        dT, dq = self._parts(ctx)
        return coefficients[0] * dT * dq

    def jacobian(self, coefficients, ctx):
        dT, dq = self._parts(ctx)
        return (dT * dq)[:, None]

    def position_slope(self, coefficients, ctx):
        dT, _ = self._parts(ctx)
        return coefficients[0] * dT

    def to_spec(self, coefficients):
        return {"kind": "thermal_expansion", "driver": "temperature", "sensor": self.sensor,
                "coefficient_ppm_per_K": float(coefficients[0] * 1e6), "reference_degC": self.reference,
                "origin_mm": self.origin * 1e3}

    keys = frozenset({"driver", "sensor", "coefficient_per_K", "coefficient_ppm_per_K", "reference_degC",
                      "origin"})

    @classmethod
    def from_spec(cls, table, site):
        where = site.where
        sensor = table.get("sensor")
        if not isinstance(sensor, str) or not sensor:
            raise SpecError(f"{where}.sensor: expected a sensor name, got {sensor!r}")
        if ("coefficient_per_K" in table) == ("coefficient_ppm_per_K" in table):
            raise SpecError(f"{where}: give one of coefficient_per_K or coefficient_ppm_per_K")
        alpha = (number(table.get("coefficient_per_K", 0.0), f"{where}.coefficient_per_K")
                 + number(table.get("coefficient_ppm_per_K", 0.0), f"{where}.coefficient_ppm_per_K") * 1e-6)
        if abs(alpha) > 1.0:  # a strain of 1 per kelvin: a unit mistake, not a material
            key = "coefficient_per_K" if "coefficient_per_K" in table else "coefficient_ppm_per_K"
            raise SpecError(f"{where}.{key}: {table[key]} is implausible: an expansion coefficient lies "
                            "within +-1 per K (+-1e6 ppm/K)")
        reference = float(_temperatures(table.get("reference_degC", 20.0), f"{where}.reference_degC", 1)[0])
        return cls(sensor, reference, _origin(table, site)), np.array([alpha])


@dataclass(frozen=True, eq=False)
class ExpansionTime(Term):
    """Thermal expansion of a linear axis driven by time (Srivastava et al.):
    ``(q - q0) sum_k s_k (1 - exp(-t / tau_k))``; coefficients ``s1, tau1, s2, tau2, ...``.

    Attributes
    ----------
    count : int
        Number of exponentials.
    origin : float
        The axis position ``q0`` the expansion is measured from [m].
    time_unit : str
        The display unit of the time constants in the spec (``s``, ``min``, ``h``).

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``value``: the expansion, the strain at the points' times ``t`` times ``q - q0``.
    - ``jacobian``: derivatives of the expansion with respect to the strains and time constants.
    - ``position_slope``: the derivative with respect to the axis position: the strain at the
      points' times.
    - ``search_grid``: candidate time constants: 48 values spaced geometrically from 1/300 to 3
      times the span of ``t``.
    - ``coefficient_units``: (SI per display unit, display unit) of each coefficient: ppm for
      the strains, ``time_unit`` for the time constants.
    - ``coefficient_limits``: the plausibility limit of each coefficient, the time constants
      held positive ("time_constant").
    - ``to_spec``: the spec table: ``driver = "time"``, ``strains_ppm``,
      ``time_constants_<unit>`` and ``origin_mm``.
    - ``from_spec``: read a time-driven expansion from its spec table (strains within +-1e6
      ppm).
    """

    count: int
    origin: float
    time_unit: str
    kind = "thermal_expansion"
    axis_only = True
    linear_length_only = True
    covariates = ("t",)

    @property
    def local_names(self):  # type: ignore[override]
        """Names of the coefficients: strain and time constant of each exponential, ``s1, tau1, ...``."""
        return tuple(n for k in range(1, self.count + 1) for n in (f"s{k}", f"tau{k}"))

    @property
    def nonlinear(self):  # type: ignore[override]
        """The time constants ``tau1, ...``, which the value is not linear in."""
        return tuple(f"tau{k}" for k in range(1, self.count + 1))

    def _strain(self, c, ctx):
        t = _need_t(ctx, "thermal_expansion")
        strain = np.zeros(ctx.n)
        parts = []
        for k in range(self.count):
            g, dg = _saturation(t, c[2 * k + 1], None)
            strain += c[2 * k] * g
            parts.append((g, c[2 * k] * dg))
        return strain, parts

    def value(self, coefficients, ctx):
        return self._strain(coefficients, ctx)[0] * (ctx.position - self.origin)

    def jacobian(self, coefficients, ctx):
        _, parts = self._strain(coefficients, ctx)
        dq = ctx.position - self.origin
        return np.column_stack([col * dq for g, dg in parts for col in (g, dg)])

    def position_slope(self, coefficients, ctx):
        return self._strain(coefficients, ctx)[0]

    def search_grid(self, name, coefficients, covariates):
        return _tau_grid(covariates)

    def coefficient_units(self):
        return [(1e-6, "ppm"), (TIME[self.time_unit], self.time_unit)] * self.count

    def coefficient_limits(self):
        return _with_time_constants(self)

    def to_spec(self, coefficients):
        return {"kind": "thermal_expansion", "driver": "time",
                "strains_ppm": [float(coefficients[2 * k] * 1e6) for k in range(self.count)],
                f"time_constants_{self.time_unit}": [float(coefficients[2 * k + 1] / TIME[self.time_unit])
                                                     for k in range(self.count)],
                "origin_mm": self.origin * 1e3}

    keys = frozenset({"driver", "strains_ppm", "time_constants", "origin"})

    @classmethod
    def from_spec(cls, table, site):
        if "strains_ppm" not in table:
            raise SpecError(f"{site.where}: missing 'strains_ppm'")
        strains = numbers(table["strains_ppm"], f"{site.where}.strains_ppm")
        _count(strains.size, site, "strains_ppm", "strains")
        if np.any(np.abs(strains) > 1e6):
            raise SpecError(f"{site.where}.strains_ppm: a strain lies within +-1e6 ppm, got {table['strains_ppm']}")
        taus = _time_constants(table, site, strains.size)
        tunit = unit_of(find_key(table, "time_constants", site.where)[1], "time_constants")
        return (cls(strains.size, _origin(table, site), tunit),
                np.ravel(np.column_stack([strains * 1e-6, taus])))


@dataclass(frozen=True, eq=False)
class Backlash(Term):
    """Reversal error of an axis: ``(b / 2) d``, ``d`` the axis' approach direction (+1 or -1;
    0, the mean of both, when no directions are given); one coefficient ``b``.

    Attributes
    ----------
    unit : str
        The display unit of the error in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``value``: half the reversal, signed by the approach direction.
    - ``jacobian``: the derivative with respect to ``b``, ``d / 2``.
    - ``to_spec``: the spec table: ``reversal_<unit>``.
    - ``from_spec``: read a backlash from its spec table (``reversal_<unit>``, one number).
    """

    unit: str
    unit_scale: float
    kind = "backlash"
    axis_only = True
    covariates = ("directions",)
    local_names = ("b",)

    def _direction(self, ctx):
        d = ctx.covariates.directions
        if d is None or ctx.axis_index is None:
            return np.zeros(ctx.n)
        return d[:, ctx.axis_index]

    def value(self, coefficients, ctx):
        return 0.5 * coefficients[0] * self._direction(ctx)

    def jacobian(self, coefficients, ctx):
        return (0.5 * self._direction(ctx))[:, None]

    def to_spec(self, coefficients):
        return {"kind": "backlash", f"reversal_{self.unit}": float(coefficients[0] / self.unit_scale)}

    keys = frozenset({"reversal"})

    @classmethod
    def from_spec(cls, table, site):
        b, unit, factor, _ = site.value(table, "reversal", count=1)
        return cls(unit, factor), b


@dataclass(frozen=True, eq=False)
class ForceDeflection(Term):
    """Deflection under the process force: ``F_i sum_k c_k P_k(u)``, a compliance (Legendre in
    the axis position over its travel when ``degree`` > 0) times one force component;
    coefficients ``c0, c1, ...`` [m/N or rad/N].

    Attributes
    ----------
    unit : str
        The display unit of the error in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.
    force : int
        The force component it reads: 0, 1, 2 for x, y, z.
    degree : int
        Degree of the compliance's polynomial in the position (0: a constant compliance).
    travel : tuple of (float, float) or None
        The axis' travel (lower, upper) [m or rad] that u is normalised over (read only for
        degree > 0); may be None for degree 0.
    model : dict or None
        For a compliance computed from a structural model: ``{"compliance": c0 [SI], "keys":
        the model's spec keys}``, to write it back as read; None otherwise.

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``jacobian``: the force component times each Legendre polynomial of the position.
    - ``value``: the deflection, the compliance at the position times the force component.
    - ``position_slope``: the derivative with respect to the axis position: the compliance's
      slope times the force.
    - ``coefficient_units``: (SI per display unit, display unit) of each coefficient: the
      error's unit per newton.
    - ``to_spec``: the spec table: ``force`` and ``compliance_<unit>_per_N``, or the structural
      model's keys when the compliance is still the one the model gave.
    - ``from_spec``: read a force deflection from its spec table: a compliance, or ``model =
      "beam"`` or ``"torsion"`` with the model's dimensions (see the module's forms).
    """

    unit: str
    unit_scale: float
    force: int
    degree: int
    travel: tuple[float, float] | None
    model: dict | None = None
    kind = "force_deflection"
    covariates = ("forces",)

    @property
    def local_names(self):  # type: ignore[override]
        """Names of the coefficients, ``c0`` ... ``c<degree>``."""
        return tuple(f"c{k}" for k in range(self.degree + 1))

    def _force(self, ctx):
        F = ctx.covariates.forces
        if F is None:
            raise InputError(f"{ctx.component}: this term needs the covariate forces (N, 3) [N]{STATE_HINT}",
                             parameters=STATE_API)
        return F[:, self.force]

    def _basis(self, ctx):
        if self.degree == 0:
            return np.ones((ctx.n, 1)), np.zeros((ctx.n, 1))
        lo, hi = self.travel
        u = (2.0 * ctx.position - lo - hi) / (hi - lo)
        V = legendre.legvander(u, self.degree)
        dV = np.zeros_like(V)
        for k in range(1, self.degree + 1):
            e = np.zeros(k + 1)
            e[k] = 1.0
            dV[:, k] = legendre.legval(u, legendre.legder(e)) * 2.0 / (hi - lo)
        return V, dV

    def jacobian(self, coefficients, ctx):
        return self._basis(ctx)[0] * self._force(ctx)[:, None]

    def value(self, coefficients, ctx):
        return self.jacobian(coefficients, ctx) @ coefficients

    def position_slope(self, coefficients, ctx):
        return (self._basis(ctx)[1] @ coefficients) * self._force(ctx)

    def coefficient_units(self):
        return [(self.unit_scale, f"{self.unit}/N")] * self.size

    def to_spec(self, coefficients):
        table = {"kind": "force_deflection", "force": "xyz"[self.force],
                 f"compliance_{self.unit}_per_N": [float(v / self.unit_scale) for v in coefficients]}
        if self.model is not None and self.degree == 0 and math.isclose(
                coefficients[0], self.model["compliance"], rel_tol=1e-12):
            table = {"kind": "force_deflection", "force": "xyz"[self.force], **self.model["keys"]}
        return table

    keys = frozenset({"force", "compliance", "model", "E_GPa", "G_GPa", "d", "I_mm4", "L", "b", "e", "a"})

    @classmethod
    def from_spec(cls, table, site):
        where, quantity = site.where, site.quantity
        force = table.get("force")
        if not isinstance(force, str) or force not in ("x", "y", "z"):
            raise SpecError(f"{where}.force: must be 'x', 'y' or 'z', got {force!r}")
        model = table.get("model")
        used = {None: {"compliance"}, "beam": {"E_GPa", "L", "b", "d", "I_mm4"},
                "torsion": {"G_GPa", "d", "e", "a"}}.get(model, set())
        unused = sorted(k for k in table if stem_of(k) in cls.keys - used - {"force", "model"})
        if unused:
            named = f"the {model} model" if model else "a compliance (no model)"
            raise SpecError(f"{where}: {', '.join(unused)} not used by {named}")
        if model is not None:
            c0, keys = _structural_model(table, model, quantity, where)
            unit = "um" if quantity == "length" else "urad"
            return (cls(unit, scale(unit, quantity, where), "xyz".index(force), 0, None,
                        {"compliance": c0, "keys": keys}), np.array([c0]))
        comp, unit, factor, ckey = site.value(table, "compliance", per="N")
        _count(comp.size, site, ckey, "coefficients")
        if comp.size > 1 and (site.travel is None or not site.owner_is_axis):
            raise SpecError(f"{where}: a position-dependent compliance needs an axis with a travel")
        return cls(unit, factor, "xyz".index(force), comp.size - 1, site.travel), comp


@dataclass(frozen=True, eq=False)
class PeriodicPitch(Term):
    """Periodic error of an axis (a ballscrew's pitch, a rotary axis' once-per-revolution):
    ``sum_h s_h sin(2 pi h (q - q0) / p) + c_h cos(2 pi h (q - q0) / p)``; coefficients
    ``s1, c1, s2, c2, ..., period``, the period ``p`` non-linear.

    Attributes
    ----------
    unit : str
        The display unit of the error in the spec (``um``, ``arcsec``).
    unit_scale : float
        SI per display unit.
    harmonics : int
        Number of harmonics.
    origin : float
        The axis position ``q0`` the phase is measured from [m or rad].
    position_unit : str
        The display unit of the period and origin in the spec (``mm``, ``deg``).
    position_scale : float
        SI per ``position_unit``.

    Notes
    -----
    The methods of :class:`~volerr_pin.model.Term` (documented there) do here:

    - ``value``: the sum of the harmonics at the axis positions.
    - ``jacobian``: derivatives with respect to the sine and cosine amplitudes and the period.
    - ``position_slope``: the derivative with respect to the axis position.
    - ``search_grid``: candidate periods: 61 values evenly spaced from 0.7 to 1.3 times the
      current period.
    - ``coefficient_units``: (SI per display unit, display unit) of each coefficient: the
      error's unit for the amplitudes, ``position_unit`` for the period.
    - ``coefficient_limits``: the plausibility limit of each coefficient: an error for the
      amplitudes, "period_length" or "period_angle" for the period.
    - ``to_spec``: the spec table: ``period_<unit>``, ``sine_<unit>``, ``cosine_<unit>`` and
      ``origin_<unit>``.
    - ``from_spec``: read a periodic error from its spec table (a positive period, as many
      cosines as sines).
    """

    unit: str
    unit_scale: float
    harmonics: int
    origin: float
    position_unit: str
    position_scale: float
    kind = "periodic_pitch"
    axis_only = True

    @property
    def local_names(self):  # type: ignore[override]
        """Names of the coefficients: ``s1, c1, ..., s<H>, c<H>, period``."""
        return tuple(n for h in range(1, self.harmonics + 1) for n in (f"s{h}", f"c{h}")) + ("period",)

    nonlinear = ("period",)

    def _phase(self, c, ctx):
        p = c[-1]
        h = np.arange(1, self.harmonics + 1)
        return 2.0 * np.pi * np.outer(ctx.position - self.origin, h) / p, h, p

    def value(self, coefficients, ctx):
        phi, _, _ = self._phase(coefficients, ctx)
        return np.sin(phi) @ coefficients[0:-1:2] + np.cos(phi) @ coefficients[1:-1:2]

    def jacobian(self, coefficients, ctx):
        phi, h, p = self._phase(coefficients, ctx)
        out = np.empty((ctx.n, self.size))
        out[:, 0:-1:2] = np.sin(phi)
        out[:, 1:-1:2] = np.cos(phi)
        dphase = (np.cos(phi) * coefficients[0:-1:2] - np.sin(phi) * coefficients[1:-1:2])  # d value / d phi_h
        out[:, -1] = -(dphase * phi).sum(axis=1) / p
        return out

    def position_slope(self, coefficients, ctx):
        phi, h, p = self._phase(coefficients, ctx)
        return (np.cos(phi) * coefficients[0:-1:2] - np.sin(phi) * coefficients[1:-1:2]) @ (2.0 * np.pi * h / p)

    def search_grid(self, name, coefficients, covariates):
        return coefficients[-1] * np.linspace(0.7, 1.3, 61)

    def coefficient_units(self):
        return [(self.unit_scale, self.unit)] * (2 * self.harmonics) + [(self.position_scale, self.position_unit)]

    def coefficient_limits(self):
        quantity = "angle" if self.position_unit in ANGLE else "length"
        return super().coefficient_limits()[:-1] + [f"period_{quantity}"]

    def to_spec(self, coefficients):
        return {"kind": "periodic_pitch",
                f"period_{self.position_unit}": float(coefficients[-1] / self.position_scale),
                f"sine_{self.unit}": [float(v / self.unit_scale) for v in coefficients[0:-1:2]],
                f"cosine_{self.unit}": [float(v / self.unit_scale) for v in coefficients[1:-1:2]],
                f"origin_{self.position_unit}": float(self.origin / self.position_scale)}

    keys = frozenset({"period", "sine", "cosine", "origin"})

    @classmethod
    def from_spec(cls, table, site):
        position = site.position_quantity or "length"   # a rotary axis' period is an angle
        period, punit, pscale, pkey = site.value(table, "period", position, count=1)
        if period[0] <= 0:
            raise SpecError(f"{site.where}.{pkey}: the period must be positive")
        within(period, f"period_{position}", f"{site.where}.{pkey}", punit, pscale)
        sines, unit, factor, skey = site.value(table, "sine")
        _count(sines.size, site, skey, "harmonics")
        cosines, _, _, _ = site.value(table, "cosine", count=sines.size)
        coefs = np.r_[np.ravel(np.column_stack([sines, cosines])), period]
        return cls(unit, factor, sines.size, _origin(table, site, position), punit, pscale), coefs


def _count(count: int, site: TermSite, key: str, what: str) -> None:
    """Between 1 and :data:`~volerr_pin.model.MAX_COEFFICIENTS` values of a list key."""
    if not 1 <= count <= MAX_COEFFICIENTS:
        raise SpecError(f"{site.where}.{key}: {count} {what}; give 1 to {MAX_COEFFICIENTS}")


def _with_time_constants(term: Term) -> list[str]:
    """A term's limits with its time constants (``tau1`` ...) held positive, as a spec holds them."""
    return ["time_constant" if name.startswith("tau") else limit
            for name, limit in zip(term.local_names, Term.coefficient_limits(term))]


def _time_constants(table: dict, site: TermSite, count: int) -> np.ndarray:
    """``time_constants_<unit>``: ``count`` positive times, s."""
    taus, _, _, key = site.value(table, "time_constants", "time", count=count)
    if np.any(taus <= 0):
        raise SpecError(f"{site.where}.{key}: time constants must be positive, got {table[key]}")
    return taus


def _temperatures(value, where: str, count: int | None = None) -> np.ndarray:
    """Temperatures [degC] within the plausibility limits."""
    temps = numbers(value, where, count)
    within(temps, "temperature", where, "degC", 1.0)
    return temps


def _origin(table: dict, site: TermSite, quantity: str = "length") -> float:
    """The axis position ``q0`` an effect is measured from (``origin_<unit>``, default 0), m
    (``quantity`` "angle": rad)."""
    origin, _, _, _ = site.value(table, "origin", quantity, required=False, count=1)
    return 0.0 if origin is None else float(origin[0])


#: effect kinds by (kind, driver); driver None for kinds without one
EFFECTS = {("thermal_drift", "time"): DriftTime, ("thermal_drift", "temperature"): DriftTemperature,
           ("thermal_expansion", "temperature"): ExpansionTemperature, ("thermal_expansion", "time"): ExpansionTime,
           ("backlash", None): Backlash, ("force_deflection", None): ForceDeflection,
           ("periodic_pitch", None): PeriodicPitch}


def _structural_model(table, model, quantity, where):
    """Compliance [m/N or rad/N] from seed 004's beam and torsion formulas."""
    def length(key):
        value, k = find_key(table, key, where, example="mm")
        return number(value, f"{where}.{k}") * scale(unit_of(k, key), "length", f"{where}.{k}")

    def modulus(key):
        if key not in table:
            raise SpecError(f"{where}: the {model} model needs {key}")
        return number(table[key], f"{where}.{key}") * 1e9

    keys = {"model": model}
    if model == "beam":
        if quantity != "length":
            raise SpecError(f"{where}: the beam model gives a deflection (a length error)")
        E = modulus("E_GPa")
        L, b = length("L"), length("b")
        if "I_mm4" in table:
            if any(stem_of(k) == "d" for k in table):
                raise SpecError(f"{where}: give either I_mm4 or the diameter d, not both")
            I = number(table["I_mm4"], f"{where}.I_mm4") * 1e-12
            keys["I_mm4"] = table["I_mm4"]
        else:
            d = length("d")
            I = math.pi * d**4 / 64.0
            keys.update({k: table[k] for k in table if stem_of(k) == "d"})
        if not (E > 0 and L > 0 and 0 < b < L and I > 0):
            raise SpecError(f"{where}: beam model needs E_GPa > 0, L > b > 0 and a positive I or d")
        keys.update({k: table[k] for k in table if stem_of(k) in ("L", "b")} | {"E_GPa": table["E_GPa"]})
        return b * (L**2 - b**2) ** 1.5 / (9.0 * math.sqrt(3.0) * E * I * L), keys
    if model == "torsion":
        if quantity != "angle":
            raise SpecError(f"{where}: the torsion model gives an angle (an angular error)")
        G = modulus("G_GPa")
        d, e, a = length("d"), length("e"), length("a")
        if not (G > 0 and d > 0):
            raise SpecError(f"{where}: torsion model needs G_GPa > 0 and d > 0")
        keys.update({k: table[k] for k in table if stem_of(k) in ("d", "e", "a")} | {"G_GPa": table["G_GPa"]})
        return 32.0 * e * a / (G * math.pi * d**4), keys
    raise SpecError(f"{where}.model: must be 'beam' or 'torsion', got {model!r}")
