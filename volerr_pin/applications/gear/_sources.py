"""Deviations per error source: each component of the machine alone and all together, the
unit-error study (each error of an axis alone at 1 mm or 1 deg), and contribution degrees
(after the gear-rolling study, seed 004 in the docs' references)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...base import DEG, MM, InputError
from ...model import Machine, parse_component_name
from ._flanks import FlankDeviations, each_flanks
from ._geometry import FLANKS, REFERENCE_GEAR, GearPair

__all__ = ["SourceDeviations", "contribution_degrees", "deviations_by_source", "unit_error_study"]


@dataclass(frozen=True)
class SourceDeviations:
    """The gear deviations one error source causes on its own.

    Attributes
    ----------
    source : str
        The component name (e.g. ``"ECA"``), or ``"all"`` for every source together.
    label : str
        What the source is, in seed 004's words where it has them (e.g. ``"ez(A)"``).
    value : str
        The magnitude of the source: "spec" (the machine's own terms) or a unit value ("1 mm").
    group : str
        The sources a contribution degree is taken over: "sources" (every single source of a
        machine), "all" (the row of all sources together) or, in a unit-error study, the axis
        and the kind of error ("A translations", "A rotations").
    deviations : FlankDeviations
        The deviations it causes.
    """

    source: str
    label: str
    value: str
    group: str
    deviations: FlankDeviations

    def to_dict(self, flank: str | None = None) -> dict:
        """Report row: ``source``, ``label``, ``value`` and the deviations in micrometres.

        Parameters
        ----------
        flank : str, optional
            "right" or "left": that flank's deviations as top-level fields; default both,
            under ``flanks``.

        Returns
        -------
        dict
            The row.
        """
        row = {"source": self.source, "label": self.label, "value": self.value}
        per_flank = self.deviations.to_dict()
        if flank is None:
            row["flanks"] = per_flank
        else:
            row.update(per_flank[flank])
        return row


def _label(name: str) -> str:
    """Seed 004's name of a component error: EXA -> dx(A), ECB -> ez(B); location errors
    (EC0Y) as they are."""
    direction, location, owner = parse_component_name(name)
    if location:
        return name
    kind = "d" if direction in "XYZ" else "e"
    return f"{kind}{'xyzxyz'['XYZABC'.index(direction)]}({owner})"


def deviations_by_source(machine: Machine, gear: GearPair = REFERENCE_GEAR, *, components=None,
                         **options) -> list[SourceDeviations]:
    """The gear deviations of each error source of the machine alone, and of all together.

    Parameters
    ----------
    machine : Machine
        The rolling machine with its present errors.
    gear : GearPair, default :data:`REFERENCE_GEAR`
        The gear.
    components : iterable of str, optional
        Component names to report (default every component with terms).
    **options
        Passed to :func:`flank_deviations` (``spindles``, ``at``, point counts, covariates).

    Returns
    -------
    list of SourceDeviations
        One per component in the machine's order, then ``"all"``.

    Raises
    ------
    InputError
        If a component name is unknown, or as :func:`flank_deviations`.
    """
    present = list(machine.components)          # the components that have terms
    names = present if components is None else list(components)
    unknown = [n for n in names if n not in present]
    if unknown:
        raise InputError(f"components {', '.join(unknown)} have no terms in {machine.name} "
                         f"(those with terms: {', '.join(present)})", parameters=("components",))
    machines = [machine.with_spec(machine.spec.without(*(c for c in present if c != name))) for name in names]
    flanks = each_flanks(machines + [machine], gear, options)
    out = [SourceDeviations(name, _label(name), "spec", "sources", f) for name, f in zip(names, flanks)]
    out.append(SourceDeviations("all", "all sources", "spec", "all", flanks[-1]))
    return out


def unit_error_study(machine: Machine, gear: GearPair = REFERENCE_GEAR, *, axes: Sequence[str] = ("A", "B"),
                     translation: float = 1 * MM, rotation: float = 1 * DEG,
                     **options) -> list[SourceDeviations]:
    """Seed 004's study: each of the six errors of each axis alone, at a unit value.

    Every other error of the machine is removed; the error under study is a constant
    ``translation`` (dx, dy, dz) or ``rotation`` (ex, ey, ez), acting as the machine's spec
    places the axis' errors (fixed or moving frame, reference point).

    Parameters
    ----------
    machine : Machine
        The rolling machine.
    gear : GearPair, default :data:`REFERENCE_GEAR`
        The gear.
    axes : sequence of str, default ("A", "B")
        The axes whose errors are studied.
    translation : float, default 1 mm
        Value of each translational error [m].
    rotation : float, default 1 deg
        Value of each angular error [rad].
    **options
        Passed to :func:`flank_deviations`.

    Returns
    -------
    list of SourceDeviations
        Per axis, dx, dy, dz, ex, ey, ez (components ``EX<axis>`` .. ``EC<axis>``).

    Raises
    ------
    InputError
        If an axis is unknown, a unit value is not positive, or as :func:`flank_deviations`.
    """
    for name, value, unit, factor in (("translation", translation, "mm", MM), ("rotation", rotation, "deg", DEG)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be positive, got {value / factor:g} {unit}", parameters=(name,))
    for axis in axes:
        if axis not in machine.axes:
            raise InputError(f"axis {axis!r} is not an axis of {machine.name} (axes: {', '.join(machine.axes)})",
                             parameters=("axes",))
    bare = machine.with_spec(machine.spec.without(*machine.components))
    studied = []
    for axis in axes:
        for direction in "XYZABC":
            name = f"E{direction}{axis}"
            if direction in "XYZ":
                table, value = {"kind": "constant", "value_mm": translation / MM}, f"{translation / MM:g} mm"
            else:
                table, value = {"kind": "constant", "value_deg": rotation / DEG}, f"{rotation / DEG:g} deg"
            group = f"{axis} {'translations' if direction in 'XYZ' else 'rotations'}"
            studied.append((name, value, group, bare.with_spec(bare.spec.with_component(name, bare.spec.term(name, table)))))
    flanks = each_flanks([one for *_, one in studied], gear, options)
    return [SourceDeviations(name, _label(name), value, group, f)
            for (name, value, group, _), f in zip(studied, flanks)]


def contribution_degrees(rows: Sequence[SourceDeviations], flank: str = "right") -> list[dict]:
    """Seed 004's contribution degree of each source within its group.

    ``s_i = |S_i| / sum_j |S_j|`` over the rows of the same :attr:`SourceDeviations.group`
    (seed 004's Tables 3 and 5 take the three translations or the three rotations of one
    axis), for seed 004's three deviations ``profile``, ``helix`` and ``pitch``.

    Parameters
    ----------
    rows : sequence of SourceDeviations
        The sources.
    flank : str, default "right"
        The flank whose deviations are compared.

    Returns
    -------
    list of dict
        Per row, ``{"profile": s, "helix": s, "pitch": s}`` (fractions; None for the "all"
        row and where every source of the group gives 0).

    Raises
    ------
    InputError
        If ``flank`` is not "right" or "left".
    """
    if flank not in FLANKS:
        raise InputError(f"flank must be 'right' or 'left', got {flank!r}", parameters=("flank",))
    keys = ("profile", "helix", "pitch")
    totals: dict = {}
    for row in rows:
        for key in keys:
            totals[row.group, key] = totals.get((row.group, key), 0.0) + abs(row.deviations.values[flank][key])
    out = []
    for row in rows:
        shares = {}
        for key in keys:
            total = totals[row.group, key]
            shares[key] = (None if row.group == "all" or total == 0.0
                           else abs(row.deviations.values[flank][key]) / total)
        out.append(shares)
    return out
