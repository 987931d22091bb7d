"""Tolerance files: how large each component error may be, how it is distributed, what
tightening it costs.

The format is that of the tolerance files of ``volerr rank`` (``COMPONENT_um = 5``,
``COMPONENT_arcsec = 2``, ``default_um``, ``default_arcsec``), read the same way, with
three optional additions for the tolerance studies::

    distribution = "uniform"      # every entry's default: "uniform" (within +-value) or
                                  # "normal" (value = standard deviation)
    EXX_um = 5                    # as for rank
    EBX_arcsec = { value = 2, distribution = "normal", cost = 3 }
    default_um = 1
    default_arcsec = 1

``cost`` is the relative cost weight ``w`` of the component in the reciprocal cost model
(``w * t0 / t``: holding a tolerance at half its value costs twice as much); default 1.
A file without the additions means what it means to ``rank``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..base import ARCSEC, UM, SpecError, split_key
from ..model import Machine, parse_component_name, read_toml
from ..fit import tolerance_key
from ._distributions import DISTRIBUTIONS, Distribution, distribution

__all__ = ["Tolerance", "Tolerances", "read_tolerance_file", "tolerances_toml"]

ENTRY_KEYS = {"value", "distribution", "cost"}


@dataclass(frozen=True)
class Tolerance:
    """The tolerance of one component error.

    Attributes
    ----------
    component : str
        Component name (``EXX``, ``EC0Y``).
    value : float
        Tolerance [m or rad]: the bound of a uniform, the standard deviation of a normal.
    distribution : Distribution
        How the error is drawn within it.
    cost : float
        Cost weight (dimensionless, > 0).
    angular : bool
        True for an angle (shown in arcsec), False for a length (shown in um).
    """

    component: str
    value: float
    distribution: Distribution
    cost: float
    angular: bool

    @property
    def unit(self) -> str:
        """The display unit: ``"arcsec"`` or ``"um"`` (str)."""
        return "arcsec" if self.angular else "um"

    @property
    def factor(self) -> float:
        """SI value of one display unit (float)."""
        return ARCSEC if self.angular else UM

    @property
    def std(self) -> float:
        """Standard deviation of the drawn error [m or rad] (float)."""
        return self.value * self.distribution.std


@dataclass(frozen=True)
class Tolerances:
    """Every component's tolerance, in the machine's component order.

    Attributes
    ----------
    source : str
        Where they come from (the file).
    entries : tuple of Tolerance
        One per component of the machine.
    """

    source: str
    entries: tuple[Tolerance, ...]

    @property
    def components(self) -> tuple[str, ...]:
        """Component names, in order (tuple of str)."""
        return tuple(e.component for e in self.entries)

    @property
    def values(self) -> np.ndarray:
        """Tolerances [m or rad], shape (n_components,)."""
        return np.array([e.value for e in self.entries])

    @property
    def costs(self) -> np.ndarray:
        """Cost weights, shape (n_components,)."""
        return np.array([e.cost for e in self.entries])

    def with_values(self, values, source: str | None = None) -> "Tolerances":
        """The same entries with other tolerance values.

        Parameters
        ----------
        values : array_like, shape (n_components,)
            New tolerances [m or rad].
        source : str, optional
            Where they come from (default: unchanged).

        Returns
        -------
        Tolerances
            The new set.
        """
        values = np.asarray(values, dtype=float)
        return Tolerances(self.source if source is None else source,
                          tuple(replace(e, value=float(v)) for e, v in zip(self.entries, values)))

    def to_dict(self) -> list[dict]:
        """The entries for reports.

        Returns
        -------
        list of dict
            ``component``, ``tolerance`` (in ``unit``), ``unit`` (``um`` or ``arcsec``),
            ``distribution`` and ``cost``, per component.
        """
        return [{"component": e.component, "tolerance": e.value / e.factor, "unit": e.unit,
                 "distribution": e.distribution.name, "cost": e.cost} for e in self.entries]


def _number(value, where: str, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0 \
            or (positive and value == 0):
        raise SpecError(f"{where}: expected a {'positive' if positive else 'non-negative'} number, got {value!r}")
    return float(value)


def read_tolerance_file(path: str | Path, machine: Machine) -> Tolerances:
    """Read a tolerance file (see the module docstring) for ``machine``.

    Parameters
    ----------
    path : str or Path
        The TOML file.
    machine : Machine
        The machine whose components need tolerances.

    Returns
    -------
    Tolerances
        One entry per component of ``machine``, in its order, SI.

    Raises
    ------
    SpecError
        Naming the file and the key, when a key names no component of the machine, has no
        unit or one of the wrong kind, a component (or a default) is given under two keys
        (``EXX_um`` and ``EXX_mm``), a value is not a non-negative number (a cost not a
        positive one) or lies beyond a spec's plausibility limits (an error of 1 m or 1 rad),
        a distribution is unknown, an entry table has other keys, or a component has no
        tolerance and no default covers it.
    """
    path = Path(path)
    data = read_toml(path)
    default_dist = DISTRIBUTIONS["uniform"]
    if "distribution" in data:
        default_dist = _dist(data.pop("distribution"), f"{path}: distribution")
    defaults: dict[str, float] = {}
    given: dict[str, tuple[float, object, float]] = {}
    seen: dict[tuple[str, str], str] = {}   # (stem, quantity) -> the key it was given under
    for key, raw in data.items():
        where = f"{path}: {key}"
        dist, cost = None, 1.0
        if isinstance(raw, dict):
            extra = sorted(set(raw) - ENTRY_KEYS)
            if extra:
                raise SpecError(f"{where}: unknown key {extra[0]!r} (an entry takes {', '.join(sorted(ENTRY_KEYS))})")
            if "value" not in raw:
                raise SpecError(f"{where}: an entry table needs a value")
            if "distribution" in raw:
                dist = _dist(raw["distribution"], f"{where}.distribution")
            if "cost" in raw:
                cost = _number(raw["cost"], f"{where}.cost", positive=True)
            if split_key(key)[0] == "default":
                raise SpecError(f"{where}: a default takes a number only")
            raw = raw["value"]
        stem, quantity, value = tolerance_key(key, raw, machine, seen, path)
        if stem == "default":
            defaults[quantity] = value
        else:
            given[stem] = (value, dist, cost)
    entries, missing = [], []
    for name in machine.components:
        angular = parse_component_name(name)[0] not in "XYZ"
        if name in given:
            value, dist, cost = given[name]
        elif ("angle" if angular else "length") in defaults:
            value, dist, cost = defaults["angle" if angular else "length"], None, 1.0
        else:
            missing.append(name)
            continue
        entries.append(Tolerance(name, value, dist or default_dist, cost, angular))
    if missing:
        raise SpecError(f"{path}: no tolerance for {', '.join(missing)} (give them, or default_um / default_arcsec)")
    return Tolerances(str(path), tuple(entries))


def _dist(name, where: str) -> Distribution:
    try:
        return distribution(name, where)
    except Exception as err:
        raise SpecError(str(err)) from None


def tolerances_toml(tolerances: Tolerances, header: str = "") -> str:
    """A tolerance file holding ``tolerances`` (read back by :func:`read_tolerance_file`).

    Parameters
    ----------
    tolerances : Tolerances
        The tolerances.
    header : str, optional
        Comment lines to put first (without the ``#``).

    Returns
    -------
    str
        TOML text: one entry table per component, values to 6 significant digits.
    """
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    for e in tolerances.entries:
        lines.append(f'{e.component}_{e.unit} = {{ value = {float(f"{e.value / e.factor:.6g}")!r}, '
                     f'distribution = "{e.distribution.name}", cost = {e.cost!r} }}')
    return "\n".join(lines) + "\n"
