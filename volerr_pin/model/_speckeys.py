"""Reading the keys of a spec table: unit-suffixed values, lists of numbers, unknown keys.

One set of rules for every table of a spec (machine, axes, bodies, every kind of error
term), so every term reads ``amplitudes_um``, ``time_constants_min`` or
``coefficients_um_per_K`` the same way and says the same thing when a key is wrong.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base import SpecError, scale, split_key, within

#: a plain name: components, prefixes, joints, bodies
NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
#: keys whose suffix is part of the name, not a unit to choose (``E_GPa``, ``lag_s``)
EXACT_KEYS = ("E_GPa", "G_GPa", "I_mm4", "reference_degC", "lag_s", "strains_ppm",
              "coefficient_per_K", "coefficient_ppm_per_K")


def stem_of(key: str) -> str:
    """A key without its unit suffix: ``coefficients_um_per_K`` -> ``coefficients``,
    ``time_constants_min`` -> ``time_constants``; :data:`EXACT_KEYS` stay whole."""
    if key in EXACT_KEYS:
        return key
    return split_key(key, ("length", "angle", "time"), per=("K", "N"))[0]


def check_keys(table: dict, allowed: set[str] | frozenset[str], where: str, what: str = "") -> None:
    """Raise a :class:`SpecError` naming every key of ``table`` whose stem is not ``allowed``
    (``what`` says for which kind of table, e.g. " for backlash")."""
    unknown = sorted(k for k in table if stem_of(k) not in allowed)
    if unknown:
        raise SpecError(f"{where}: unknown key(s) {', '.join(unknown)}{what} "
                        f"(allowed: {', '.join(sorted(allowed))})")


def find_key(table: dict, stem: str, where: str, required: bool = True, example: str = "um"
             ) -> tuple[Any, str | None]:
    """The value of ``stem`` with its unit suffix and the key it was found under.

    Returns ``(None, None)`` when the key is absent and not ``required``; raises a
    :class:`SpecError` when it is given twice, without a unit (``example`` is the unit the
    message suggests), or missing.
    """
    if stem in EXACT_KEYS:
        hits = [k for k in table if k == stem]
    else:
        hits = [k for k in table if k != stem and stem_of(k) == stem]
    if len(hits) > 1:
        raise SpecError(f"{where}: both {hits[0]} and {hits[1]} given")
    if hits and stem in table and stem not in EXACT_KEYS:
        raise SpecError(f"{where}: both {hits[0]} and {stem} given; give the value once, with its unit")
    if not hits:
        if stem in table:
            raise SpecError(f"{where}: key '{stem}' needs a unit suffix, e.g. '{stem}_{example}'")
        if required:
            raise SpecError(f"{where}: missing '{stem}_<unit>'")
        return None, None
    return table[hits[0]], hits[0]


def unit_of(key: str, stem: str) -> str:
    """The unit of ``key`` found for ``stem``, without a rate's denominator
    (``coefficients_um_per_K`` -> ``um``)."""
    return key[len(stem) + 1:].split("_per_")[0]


def _is_number(value: Any) -> bool:
    """An int or float as TOML gives them (a bool is an int to Python, but not a number here)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def numbers(value: Any, where: str, count: int | None = None) -> np.ndarray:
    """One number or a flat list of finite numbers as an array of shape ``(n,)``
    (``count`` numbers when given). Strings (``"500"``) and booleans (``true``) are refused,
    naming ``where`` (file, table and key)."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "iuf":
        items = list(value.ravel()) if value.ndim <= 1 else [value]
    else:
        items = list(value) if isinstance(value, (list, tuple)) else [value]
    for item in items:
        if isinstance(item, (list, tuple, np.ndarray)):
            raise SpecError(f"{where}: expected a flat list of {count or 'some'} numbers, got {_shown(value)}")
        if not _is_number(item):
            kind = {str: "a string", bool: "a boolean"}.get(type(item), type(item).__name__)
            if isinstance(item, dict):
                kind = "a table"
            raise SpecError(f"{where}: expected a number, got {kind} {_shown(item)}"
                            + (" (write it without quotes)" if isinstance(item, str) else ""))
    array = np.array(items, dtype=float)
    if count is not None and array.size != count:
        raise SpecError(f"{where}: expected {'one number' if count == 1 else f'a list of {count} numbers'}, "
                        f"got {_shown(value)}")
    if not np.all(np.isfinite(array)):
        raise SpecError(f"{where}: values must be finite, got {_shown(value)}")
    return array


def number(value: Any, where: str) -> float:
    """One finite number (not a string, a boolean or a list)."""
    if isinstance(value, (list, tuple)):
        raise SpecError(f"{where}: expected one number, got a list {_shown(value)}")
    return float(numbers(value, where, 1)[0])


def text(table: dict, key: str, where: str, default: str | None = None) -> str:
    """The string ``table[key]`` (``default`` when absent; required when ``default`` is None).

    Raises a :class:`SpecError` naming ``where`` and the key when the value is not a string
    (``joint = 5``, ``tool_frame = ["tool"]``) or when a required key is missing.
    """
    if key not in table:
        if default is None:
            raise SpecError(f"{where}: missing '{key}'")
        return default
    value = table[key]
    if not isinstance(value, str):
        raise SpecError(f"{where}.{key}: expected a string (in quotes), got {_shown(value)}")
    return value


@dataclass(frozen=True)
class TermSite:
    """Where a term is read and what it is an error of.

    Attributes
    ----------
    where : str
        File and table path for messages, e.g. ``"vmc500.toml: errors.EXX.terms[0]"``.
    quantity : {"length", "angle"}
        What the component error measures.
    position_quantity : {"length", "angle"} or None
        What the owner's axis position measures; None for a body without an axis.
    travel : (float, float) or None
        The axis travel in SI (m or rad).
    owner_is_axis : bool
        Whether the component is an error of an axis (not of a body or a location).
    """

    where: str
    quantity: str
    position_quantity: str | None
    travel: tuple[float, float] | None
    owner_is_axis: bool

    def value(self, table: dict, stem: str, quantity: str | None = None, required: bool = True,
              count: int | None = None, per: str | None = None
              ) -> tuple[np.ndarray | None, str | None, float, str | None]:
        """``stem_<unit>`` of ``table`` as ``(SI values (n,), unit, SI per unit, key)``.

        ``quantity`` defaults to the component's (then the values are errors, or error rates
        with ``per``: ``"K"`` for ``coefficients_um_per_K``, ``"N"`` for ``compliance_um_per_N``);
        ``count`` fixes the number of values. Values beyond the plausibility limits of
        :data:`volerr_pin.base.PLAUSIBLE` (an error of more than 1 m or 1 rad, a position
        beyond 1 km) are refused, naming the key.
        """
        what = quantity or self.quantity
        example = {"length": "mm" if quantity else "um", "angle": "deg" if quantity else "arcsec",
                   "time": "s"}.get(what, "um")
        raw, key = find_key(table, stem, self.where, required, example=example + (f"_per_{per}" if per else ""))
        if key is None:
            return None, None, 1.0, None
        suffix = key[len(stem) + 1:]
        unit, _, rate = suffix.partition("_per_")
        if rate != (per or ""):
            wanted = f"{stem}_{example}_per_{per}" if per else f"{stem}_{example}"
            raise SpecError(f"{self.where}.{key}: unit '{suffix}' does not fit; write it as e.g. {wanted}")
        factor = scale(unit, what, f"{self.where}.{key}")
        values = numbers(raw, f"{self.where}.{key}", count) * factor
        limit = f"error_{what}" if quantity is None else ("time" if what == "time" else f"position_{what}")
        within(values, limit, f"{self.where}.{key}", suffix.replace("_per_", "/"), factor)
        return values, unit, factor, key
