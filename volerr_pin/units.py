"""Engineering units of files and the CLI, converted once at the boundary to SI.

Keys in spec files carry their unit as a suffix (``values_um``, ``value_arcsec``,
``positions_mm``); the library works in SI (m, rad).
"""

from __future__ import annotations

import math

from .errors import SpecError

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


def scale(unit: str, quantity: str, where: str) -> float:
    """SI factor of ``unit`` for a ``quantity`` ("length" or "angle").

    Raises :class:`SpecError` naming ``where`` when the unit is unknown or of the
    wrong kind (an angle unit on a translational error, say).
    """
    table = LENGTH if quantity == "length" else ANGLE
    if unit in table:
        return table[unit]
    other = ANGLE if quantity == "length" else LENGTH
    if unit in other:
        raise SpecError(f"{where}: unit '{unit}' is an {'angle' if quantity == 'length' else 'length'} "
                        f"unit but this value is a {quantity} (use one of {', '.join(table)})")
    raise SpecError(f"{where}: unknown unit '{unit}' (use one of {', '.join(table)})")


def split_key(key: str) -> tuple[str, str | None]:
    """Split ``values_um`` into ``("values", "um")``; keys without a unit give ``None``."""
    stem, sep, unit = key.rpartition("_")
    if sep and unit in LENGTH or sep and unit in ANGLE:
        return stem, unit
    return key, None
