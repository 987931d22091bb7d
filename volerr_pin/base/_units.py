"""Engineering units of files and the command line, converted once at the boundary to SI.

The library works in SI (m, rad, s, N, degC). People and files speak engineering units:
axis positions in mm (linear axes) and deg (rotary axes), errors in um and arcsec, keys of
spec files with their unit as a suffix (``values_um``, ``value_arcsec``, ``positions_mm``).
This module owns every factor between the two and the parsing of unit suffixes and of
``AXIS=VALUE`` lists; other modules import the factors from here instead of recomputing them.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence

import numpy as np

from ._errors import InputError, SpecError

#: length units -> metres
LENGTH = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9}
#: angle units -> radians
ANGLE = {
    "rad": 1.0,
    "mrad": 1e-3,
    "urad": 1e-6,
    "deg": math.pi / 180.0,
    "arcsec": math.pi / (180.0 * 3600.0),
}
#: time units -> seconds
TIME = {"s": 1.0, "min": 60.0, "h": 3600.0}
#: units of each quantity a key suffix may name
QUANTITIES = {"length": LENGTH, "angle": ANGLE, "time": TIME, "temperature": {"degC": 1.0},
              "force": {"N": 1.0}}
#: temperature units a measurement column may name -> (scale, offset): degC = scale * value + offset
TEMPERATURE = {"degC": (1.0, 0.0), "K": (1.0, -273.15), "degF": (5.0 / 9.0, -160.0 / 9.0)}
#: suffixes that read like a temperature unit but are none of :data:`TEMPERATURE` (compared in
#: lower case): a column ending so is refused rather than read as a sensor of that name
TEMPERATURE_LIKE = frozenset({"c", "f", "r", "k", "deg", "degc", "degf", "degk", "degr", "ra", "celsius",
                              "centigrade", "fahrenheit", "kelvin", "rankine", "°c", "°f", "°", "oc", "of"})

MM = LENGTH["mm"]
UM = LENGTH["um"]
DEG = ANGLE["deg"]
ARCSEC = ANGLE["arcsec"]
URAD = ANGLE["urad"]
#: um per metre, for reports
UM_PER_M = 1.0 / UM
#: urad per radian, for reports
URAD_PER_RAD = 1.0 / URAD
#: arcsec per radian, for reports
ARCSEC_PER_RAD = 1.0 / ARCSEC
#: one inch in metres (NC programs in G20)
INCH = 25.4e-3

#: engineering unit of an axis position, by axis kind
AXIS_UNIT = {"linear": "mm", "rotary": "deg"}

#: Plausibility limits of what files give, SI, as (lowest, highest). A value beyond them is a
#: mistake (a wrong unit, a corrupted cell, an overflowing fit), never a measurement, so the
#: readers refuse it instead of carrying it into a fit. docs/measurements.md lists them.
PLAUSIBLE = {
    "error_length": (-1.0, 1.0),                  # a deviation or error of more than 1 m
    "error_angle": (-1.0, 1.0),                   # an angular error of more than 1 rad (57 deg)
    "position_length": (-1e3, 1e3),               # positions and coordinates beyond 1 km
    "position_angle": (-1e7 * DEG, 1e7 * DEG),    # rotary positions beyond 10 million deg
    "time": (-1e10, 1e10),                        # 317 years (Unix time in s is 1.7e9)
    "time_constant": (1e-9, 1e10),                # a time constant is positive; below a nanosecond a unit mistake
    "temperature": (-273.15, 1000.0),             # degC: below absolute zero, or melting
    "force": (-1e7, 1e7),                         # N: 10 MN
    "reading": (-1e15, 1e15),                     # a series value of unknown unit (epoch ms pass)
    "period_length": (1e-6, 1e3),                 # a period of a micrometre is a unit mistake, not a screw
    "period_angle": (ANGLE["arcsec"], 1e7 * DEG),  # an angular period below an arc second
    "feed": (1e-6 / 60.0, 1e3 / 60.0),            # m/s: 0.001 mm/min to 1000 m/min (ten times any machine's)
}
#: what each limit is of, for messages
PLAUSIBLE_WHAT = {"error_length": "a deviation", "error_angle": "an angular deviation",
                  "position_length": "a position", "position_angle": "a rotary position",
                  "time": "a time", "time_constant": "a time constant", "temperature": "a temperature", "force": "a force",
                  "reading": "a reading in any unit", "period_length": "a period",
                  "period_angle": "an angular period", "feed": "a feed rate"}

#: a decimal number as files write it: digits, an optional point and exponent; no NaN or
#: inf spellings, underscores, hex or non-ASCII digits (all of which float() would take)
NUMBER = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"  # ASCII digits; no backtracking
NUMBER_RE = re.compile(NUMBER)


def parse_number(text: str) -> float:
    """A finite decimal number written as text (surrounding blanks ignored).

    Parameters
    ----------
    text : str
        The text, e.g. ``"-1.5e-3"``.

    Returns
    -------
    float
        Its value.

    Raises
    ------
    ValueError
        With the reason as its message: ``"is not a number"`` (also for ``1_000``, ``0x10``
        and non-ASCII digits) or ``"is not a finite number"`` (``nan``, ``inf`` and values
        that overflow, such as ``1e999``).
    """
    text = text.strip()
    if not NUMBER_RE.fullmatch(text):
        try:
            special = float(text)
        except ValueError:
            special = 0.0
        raise ValueError("is not a finite number" if not math.isfinite(special) else "is not a number")
    value = float(text)
    if not math.isfinite(value):
        raise ValueError("is not a finite number")
    return value


def shown(value: float) -> str:
    """A value for a message: enough digits to tell it from a limit (``-1000001``, ``1e+300``).

    Parameters
    ----------
    value : float
        The value.

    Returns
    -------
    str
        The value with up to 10 significant digits (``:.10g``).
    """
    return f"{value:.10g}"


def plausible_range(kind: str, unit_scale: float = 1.0) -> tuple[float, float]:
    """The plausibility limits of :data:`PLAUSIBLE` in a file unit.

    Parameters
    ----------
    kind : str
        A key of :data:`PLAUSIBLE`.
    unit_scale : float, default 1.0
        SI value of one file unit (1e-6 for um); temperatures are in degC and take 1.

    Returns
    -------
    (float, float)
        Lowest and highest plausible value, in the file unit.
    """
    low, high = PLAUSIBLE[kind]
    return low / unit_scale, high / unit_scale


def describe_range(kind: str, unit: str, unit_scale: float = 1.0) -> str:
    """The plausibility limits of ``kind`` in words for a message, e.g. ``"|value| <= 1e+06 um"``.

    Parameters
    ----------
    kind : str
        A key of :data:`PLAUSIBLE`.
    unit : str
        The file unit's name.
    unit_scale : float, default 1.0
        SI value of one file unit.

    Returns
    -------
    str
        The range, in the file unit.
    """
    low, high = plausible_range(kind, unit_scale)
    if low == -high:
        return f"{PLAUSIBLE_WHAT[kind]} lies within +-{high:g} {unit}".rstrip()
    return f"{PLAUSIBLE_WHAT[kind]} lies within {low:g} .. {high:g} {unit}".rstrip()


def within(values, limit: str, where: str, unit: str, unit_scale: float = 1.0, *,
           error: type[Exception] = SpecError, parameters: tuple[str, ...] = ()) -> np.ndarray:
    """SI values refused unless they lie within the plausibility limit ``limit``: the one check
    every reader (specs, URDFs, options, reports) holds its values to.

    Parameters
    ----------
    values : array_like
        The values, SI.
    limit : str
        A key of :data:`PLAUSIBLE`.
    where : str
        What the values are (a file and key, an option), the start of the message.
    unit : str
        The unit the values were given in, for the message.
    unit_scale : float, default 1.0
        SI value of one such unit.
    error : type, default SpecError
        Exception class raised, constructed with the message (and ``parameters``).
    parameters : tuple of str, optional
        The parameters the values come from, for a :class:`~volerr_pin.base.VolerrError`.

    Returns
    -------
    ndarray
        The values as floats.

    Raises
    ------
    SpecError
        (or ``error``) Naming ``where``, the first value beyond the limit (or not a number) in
        ``unit`` and the limit.
    """
    array = np.asarray(values, dtype=float)
    low, high = PLAUSIBLE[limit]
    bad = np.flatnonzero(~((array >= low) & (array <= high)))
    if bad.size:
        value = array.ravel()[bad[0]] / unit_scale
        message = (f"{where}: {shown(value)} {unit} is {'not a number' if math.isnan(value) else 'implausible'}: "
                   f"{describe_range(limit, unit, unit_scale)}")
        raise error(message, parameters=parameters) if parameters else error(message)
    return array


def scale(unit: str, quantity: str, where: str) -> float:
    """SI factor of a unit.

    Parameters
    ----------
    unit : str
        Unit name, e.g. ``"um"``, ``"arcsec"`` or ``"min"``.
    quantity : {"length", "angle", "time"}
        What the value measures.
    where : str
        Names the value (file, key) in the error message.

    Returns
    -------
    float
        SI value (m, rad or s) of one ``unit``.

    Raises
    ------
    SpecError
        When the unit is unknown or of the wrong kind (an angle unit on a translational
        error, say).
    """
    table = QUANTITIES[quantity]
    if not isinstance(unit, str):
        raise SpecError(f"{where}: expected a unit name such as {next(iter(table))!r}, got {unit!r}")
    if unit in table:
        return table[unit]
    for other, units in QUANTITIES.items():
        if unit in units:
            article = "an" if other[0] in "aeiou" else "a"
            raise SpecError(f"{where}: unit '{unit}' is {article} {other} unit but this value is a {quantity} "
                            f"(use one of {', '.join(table)})")
    raise SpecError(f"{where}: unknown unit '{unit}' (use one of {', '.join(table)})")


def split_key(key: str, quantities: Sequence[str] = ("length", "angle"), per: Sequence[str] = ()
              ) -> tuple[str, str | None]:
    """Split a unit-suffixed key into its stem and unit.

    Parameters
    ----------
    key : str
        A key such as ``"values_um"``, ``"t_s"`` or ``"coefficients_um_per_K"``.
    quantities : sequence of str
        Which units count as a suffix: names of :data:`QUANTITIES` (default length and angle).
    per : sequence of str
        Denominators of rate units, e.g. ``("K", "N")``: ``values_um_per_K`` gives
        ``("values", "um_per_K")`` when the numerator is a length or angle unit.

    Returns
    -------
    (str, str or None)
        The stem and the unit; keys without a known unit give ``(key, None)``.
    """
    for denominator in per:
        tail = f"_per_{denominator}"
        if key.endswith(tail):
            stem, unit = split_key(key[: -len(tail)], ("length", "angle"))
            if unit is not None:
                return stem, f"{unit}{tail}"
    stem, sep, unit = key.rpartition("_")
    if sep and any(unit in QUANTITIES[q] for q in quantities):
        return stem, unit
    return key, None


def axis_scale(kind: str) -> float:
    """SI value (m or rad) of one engineering unit of an axis of ``kind``: mm for
    ``"linear"``, deg for ``"rotary"``.

    Parameters
    ----------
    kind : str
        The axis kind, ``"linear"`` or ``"rotary"`` (any other kind counts as rotary).

    Returns
    -------
    float
        1e-3 (m per mm) or pi / 180 (rad per deg).
    """
    return MM if kind == "linear" else DEG


def axis_scales(kinds: Iterable[str]) -> np.ndarray:
    """:func:`axis_scale` of each axis kind, shape ``(n_axes,)``.

    Parameters
    ----------
    kinds : iterable of str
        The axes' kinds, ``"linear"`` or ``"rotary"``.

    Returns
    -------
    ndarray, shape (n_axes,)
        SI value of one engineering unit of each axis (m per mm, rad per deg).
    """
    return np.array([axis_scale(k) for k in kinds])


def parse_axis_values(items: str | Iterable[str], where: str, axes: Sequence[str] | None = None,
                      error: type[InputError] = InputError) -> dict[str, float]:
    """Parse ``AXIS=VALUE`` items as the command line and file headers give them.

    Parameters
    ----------
    items : str or iterable of str
        ``["X=100", "C=90"]``, or one string ``"X=100, C=90"`` split at commas and blanks.
    where : str
        Names the source (a command-line option, a file header) in error messages.
    axes : sequence of str, optional
        Axis names allowed; without it any name is taken (checked later by the caller).
    error : type
        Exception class raised for bad items (an :class:`InputError` subclass).

    Returns
    -------
    dict
        Axis name -> value in the units given (mm / deg by convention), in the order given.

    Raises
    ------
    InputError
        (``error``) If an item is not ``AXIS=VALUE`` with a finite number, names an axis
        not in ``axes``, or names an axis given before.
    """
    if isinstance(items, str):
        items = [s for s in re.split(r"[,\s]+", items.strip()) if s]
    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise error(f"{where}: '{item}' is not AXIS=VALUE")
        try:
            value = parse_number(text)
        except ValueError as err:
            raise error(f"{where}: '{item}' is not AXIS=VALUE: '{text}' {err}") from None
        if axes is not None and name not in axes:
            raise error(f"{where}: '{item}' names no axis (axes: {', '.join(axes)})")
        if name in out:
            raise error(f"{where}: axis {name} is given twice")
        out[name] = value
    return out


def axis_values_to_si(names: Sequence[str], kinds: Sequence[str], values: dict[str, float],
                      where: str, machine_name: str = "the machine") -> dict[str, float]:
    """Axis positions in engineering units (mm / deg) -> SI (m / rad), by axis name.

    Parameters
    ----------
    names, kinds : sequence of str
        The machine's axis names and kinds (``"linear"`` / ``"rotary"``).
    values : dict
        Axis name -> position in mm or deg.
    where : str
        Names the source in the error raised for a name that is not an axis.
    machine_name : str
        Names the machine in that error.

    Returns
    -------
    dict
        Axis name -> position in m or rad, in the order of ``values``.

    Raises
    ------
    InputError
        If ``values`` names something that is not an axis, or a position beyond what one may be
        (:data:`PLAUSIBLE`).
    """
    out = {}
    for name, value in values.items():
        if name not in names:
            raise InputError(f"{where} names '{name}', not an axis of {machine_name}")
        kind = kinds[list(names).index(name)]
        out[name] = value * axis_scale(kind)
        unit = "deg" if kind == "rotary" else "mm"
        within([out[name]], f"position_{'angle' if kind == 'rotary' else 'length'}", f"{where} {name}", unit,
               axis_scale(kind), error=InputError)
    return out
