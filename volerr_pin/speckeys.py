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

from .errors import SpecError
from .units import scale, split_key

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


def numbers(value: Any, where: str, count: int | None = None) -> np.ndarray:
    """One number or a flat list of finite numbers as an array of shape ``(n,)``
    (``count`` numbers when given)."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SpecError(f"{where}: expected numbers, got {value!r}") from None
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1 or (count is not None and array.size != count):
        raise SpecError(f"{where}: expected a list of {count or 'some'} numbers, got {value!r}")
    if not np.all(np.isfinite(array)):
        raise SpecError(f"{where}: values must be finite, got {value!r}")
    return array


def number(value: Any, where: str) -> float:
    """One finite number."""
    return float(numbers(value, where, 1)[0])


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
              count: int | None = None) -> tuple[np.ndarray | None, str | None, float, str | None]:
        """``stem_<unit>`` of ``table`` as ``(SI values (n,), unit, SI per unit, key)``;
        ``quantity`` defaults to the component's, ``count`` fixes the number of values."""
        raw, key = find_key(table, stem, self.where, required)
        if key is None:
            return None, None, 1.0, None
        unit = unit_of(key, stem)
        factor = scale(unit, quantity or self.quantity, f"{self.where}.{key}")
        return numbers(raw, f"{self.where}.{key}", count) * factor, unit, factor, key
