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

from .errors import InputError, SpecError

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
    ``"linear"``, deg for ``"rotary"``."""
    return MM if kind == "linear" else DEG


def axis_scales(kinds: Iterable[str]) -> np.ndarray:
    """:func:`axis_scale` of each axis kind, shape ``(n_axes,)``."""
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
    """
    if isinstance(items, str):
        items = [s for s in re.split(r"[,\s]+", items.strip()) if s]
    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        try:
            value = float(text)
        except ValueError:
            sep = ""
        if not sep or not name:
            raise error(f"{where}: '{item}' is not AXIS=VALUE")
        if axes is not None and name not in axes:
            raise error(f"{where}: '{item}' names no axis (axes: {', '.join(axes)})")
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
    """
    out = {}
    for name, value in values.items():
        if name not in names:
            raise InputError(f"{where} names '{name}', not an axis of {machine_name}")
        out[name] = value * axis_scale(kinds[list(names).index(name)])
    return out
