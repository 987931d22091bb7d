"""Changing a machine's error terms and writing its spec back to TOML.

:func:`replace_terms` gives a machine new terms for some components (for instance a
Legendre polynomial of another degree before an identification); :func:`write_spec` writes
the machine with its current coefficient values as a spec that :func:`load_machine` reads,
with a ``[provenance]`` table saying where the values came from.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import os
from pathlib import Path

import numpy as np
import tomli_w

from ..base.errors import InputError
from .machine import Machine
from ..base.safeio import same_file, write_text
from .spec import axis_travel, parse_component_name, parse_components
from ..base.units import ANGLE, LENGTH

#: the highest degree :func:`legendre_terms` fits
MAX_DEGREE = 20


def _owners(machine: Machine) -> dict:
    spec = machine.spec
    owners = {}
    for axis, kind in zip(spec.axes, machine.axis_kinds):
        owners[axis.name] = ("length" if kind == "linear" else "angle",
                             axis_travel(machine.urdf, axis))
    for body in spec.bodies:
        owners[body.name] = (None, None)
    return owners


def _rebuilt(machine: Machine, spec, theta_of) -> Machine:
    """A machine of ``spec`` on the same URDF, with coefficients ``theta_of(fresh)`` and the
    state ``machine`` is held in."""
    fresh = machine._edited(spec)
    fresh = fresh.with_theta(theta_of(fresh))
    return fresh.with_state(**machine.state) if machine.state else fresh


def replace_terms(machine: Machine, tables: dict[str, dict | list[dict]]) -> Machine:
    """A new machine whose components ``tables`` replace or add to the spec's.

    Other components are unchanged and keep their current values; the components in
    ``tables`` take the values the tables give.

    Parameters
    ----------
    machine : Machine
        The machine.
    tables : dict of str to dict or list of dict
        Component name -> one term table or a list of them, in the spec's TOML form (keys
        with their unit suffixes).

    Returns
    -------
    Machine
        The new machine, in the same state (:attr:`Machine.state`).

    Raises
    ------
    SpecError
        If a component name or term table is invalid (named in the message as the spec's
        source with "(replaced terms)").
    """
    new = {c.name: c for c in _parsed(machine, tables)}
    components = [new.pop(c.name, c) for c in machine.spec.components] + list(new.values())
    # keep the current values of untouched components
    old_values = dict(zip(machine.parameter_names, machine.theta))
    spec = dataclasses.replace(machine.spec, components=tuple(components))
    return _rebuilt(machine, spec, lambda fresh: np.array(
        [old_values.get(n, v) if n.split(".", 1)[0] not in tables else v
         for n, v in zip(fresh.parameter_names, fresh.theta)]))


__all__ = ["add_terms", "check_values", "legendre_terms", "remove_components", "replace_terms", "spec_document",
           "term_tables", "with_axis_errors", "write_spec"]


def _parsed(machine: Machine, tables: dict[str, dict | list[dict]], what: str = "replaced terms") -> list:
    """The components of ``tables`` (spec TOML form) as the machine's spec parses them; an error
    names the spec's source and ``what`` the tables are."""
    raw = {name: (t if isinstance(t, dict) else {"terms": list(t)}) for name, t in tables.items()}
    return list(parse_components(raw, f"{machine.spec.source} ({what})", _owners(machine)))


def check_values(machine: Machine) -> None:
    """Check that the machine's present coefficient values are ones its spec can hold (within
    the plausibility limits a spec file is read with), so that a machine built from them - a
    changed model, a written spec - can be.

    Parameters
    ----------
    machine : Machine
        The machine.

    Raises
    ------
    SpecError
        Naming the spec's source ("present values") and the first component, term and value
        that a spec would refuse.
    """
    _parsed(machine, term_tables(machine), "present values")


def with_axis_errors(machine: Machine, axes: dict[str, dict]) -> Machine:
    """A new machine whose axes place their component errors differently.

    Parameters
    ----------
    machine : Machine
        The machine.
    axes : dict of str to dict
        Axis name -> ``{"frame": "moving" or "fixed", "reference": (x, y, z)}`` (either key
        may be left out): the frame the axis' errors act in ("moving": after the joint, turning
        with a rotary axis; "fixed": before it) and the point of that frame about which its
        angular errors act [m].

    Returns
    -------
    Machine
        The new machine with the same terms, coefficient values and state.

    Raises
    ------
    InputError
        If an axis is unknown, a key is not "frame" or "reference", the frame is neither
        "moving" nor "fixed", or the reference point is not three finite numbers.
    """
    spec = machine.spec
    names = [a.name for a in spec.axes]
    changed = []
    for axis in spec.axes:
        if axis.name not in axes:
            changed.append(axis)
            continue
        change = axes[axis.name]
        if not isinstance(change, dict):
            raise InputError(f"axes[{axis.name!r}] must be a dict with 'frame' and/or 'reference', got {change!r}",
                             parameters=("axes",))
        extra = sorted(set(change) - {"frame", "reference"})
        if extra:
            raise InputError(f"axes[{axis.name!r}]: unknown keys {', '.join(extra)} (use frame, reference)",
                             parameters=("axes",))
        frame = change.get("frame", axis.frame)
        if frame not in ("moving", "fixed"):
            raise InputError(f"axes[{axis.name!r}]: frame must be 'moving' or 'fixed', got {frame!r}",
                             parameters=("axes",))
        try:
            reference = np.asarray(change.get("reference", axis.reference), dtype=float)
        except (TypeError, ValueError):
            reference = np.full(1, np.nan)
        if reference.shape != (3,) or not np.isfinite(reference).all():
            raise InputError(f"axes[{axis.name!r}]: reference must be three finite numbers [m], got "
                             f"{change.get('reference')!r}", parameters=("axes",))
        changed.append(dataclasses.replace(axis, frame=frame, reference=tuple(float(v) for v in reference)))
    unknown = sorted(set(axes) - set(names))
    if unknown:
        raise InputError(f"{', '.join(unknown)} not among the axes of {machine.name} ({', '.join(names)})",
                         parameters=("axes",))
    return _rebuilt(machine, dataclasses.replace(spec, axes=tuple(changed)), lambda fresh: machine.theta)


def remove_components(machine: Machine, names) -> Machine:
    """A new machine without the components ``names`` (their error joints stay, at zero).

    Parameters
    ----------
    machine : Machine
        The machine.
    names : iterable of str
        Component names.

    Returns
    -------
    Machine
        The new machine; the other coefficients keep their current values, the state stays.

    Raises
    ------
    InputError
        If a name is not among the machine's components.
    """
    names = set(names)
    unknown = sorted(names - set(machine.components))
    if unknown:
        raise InputError(f"{', '.join(unknown)} not among the components of {machine.name}")
    values = dict(zip(machine.parameter_names, machine.theta))
    spec = dataclasses.replace(machine.spec, components=tuple(
        c for c in machine.spec.components if c.name not in names))
    return _rebuilt(machine, spec, lambda fresh: np.array([values[n] for n in fresh.parameter_names]))


def add_terms(machine: Machine, tables: dict[str, dict | list[dict]]) -> Machine:
    """A new machine with extra terms.

    ``tables`` maps a component name to one term table or a list of them (spec TOML form),
    added to that component's present terms (a new component if it has none). Every
    coefficient keeps its present value.

    Parameters
    ----------
    machine : Machine
        The machine.
    tables : dict of str to dict or list of dict
        Component name -> extra term table(s).

    Returns
    -------
    Machine
        The new machine.

    Raises
    ------
    SpecError
        If a component name or term table is invalid.
    """
    current = term_tables(machine)
    merged = {}
    for name, extra in tables.items():
        extra = [extra] if isinstance(extra, dict) else list(extra)
        merged[name] = current.get(name, []) + extra
    return replace_terms(machine, merged)


def term_tables(machine: Machine) -> dict[str, list[dict]]:
    """Component name -> the list of its term tables (spec TOML form, current values).

    As :func:`replace_terms` and :func:`add_terms` take them.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    dict of str to list of dict
        The term tables of every component that has terms.
    """
    return {name: list(t["terms"]) if "terms" in t else [t]
            for name, t in spec_document(machine)["errors"].items()}


def legendre_terms(machine: Machine, components, degree: int, start: int = 0) -> dict:
    """Legendre tables of ``degree`` for ``components``, fitted to the current component functions.

    Their coefficients reproduce the current component functions as closely as the degree
    allows (least squares at 201 points over the travel, other axes at mid travel), so a refit
    starts from the machine's present state. A component without terms starts at zero.

    Parameters
    ----------
    machine : Machine
        The machine.
    components : iterable of str
        Component errors of axes (not location errors).
    degree : int
        Highest Legendre degree, 0 to :data:`MAX_DEGREE`.
    start : int, default 0
        Lowest degree fitted; the coefficients below it are 0.

    Returns
    -------
    dict of str to dict
        Component name -> ``{"kind": "legendre", "coefficients_um": [...]}`` (or
        ``coefficients_arcsec`` for an angular component), degree + 1 values.

    Raises
    ------
    InputError
        If ``degree`` is negative or above :data:`MAX_DEGREE`, or a component is not a
        component error of an axis.
    """
    if not 0 <= degree <= MAX_DEGREE:
        raise InputError(f"degree must be 0 to {MAX_DEGREE}, got {degree} (a polynomial of higher degree over the "
                         "travel follows the noise, not the geometry; a table term holds finer detail)",
                         parameters=("degree",))
    travel = machine.travel
    grid = np.tile(machine.mid_travel, (201, 1))
    tables = {}
    for name in components:
        direction, location, owner = parse_component_name(name)
        if owner not in machine.axes or location:
            raise InputError(f"degree applies to component errors of axes; {name} is not one",
                             parameters=("degree",))
        j = machine.axes.index(owner)
        q = grid.copy()
        q[:, j] = np.linspace(*travel[j], 201)
        values = (machine.component_values(q)[:, machine.components.index(name)]
                  if name in machine.components else np.zeros(201))
        u = np.linspace(-1.0, 1.0, 201)
        V = np.polynomial.legendre.legvander(u, degree)[:, start:]
        coef = np.linalg.lstsq(V, values, rcond=None)[0] if V.shape[1] else np.zeros(0)
        unit, scale = ("um", LENGTH["um"]) if direction in "XYZ" else ("arcsec", ANGLE["arcsec"])
        full = np.r_[np.zeros(start), coef] / scale
        tables[name] = {"kind": "legendre", f"coefficients_{unit}": [float(c) for c in full]}
    return tables


def spec_document(machine: Machine, out: Path | None = None, provenance: dict | None = None) -> dict:
    """The machine (with its current coefficient values) as a spec document (a dict).

    Parameters
    ----------
    machine : Machine
        The machine.
    out : Path, optional
        Where the document will be written: the URDF path is made relative to its folder
        (default: the current directory).
    provenance : dict, optional
        Recorded as the ``[provenance]`` table.

    Returns
    -------
    dict
        The TOML document: ``format``, ``machine``, ``axes``, ``bodies`` (if any), ``errors``
        (coefficients in the spec's units, reference points in mm) and ``provenance``.
    """
    spec = machine.spec
    base = Path(out).resolve().parent if out is not None else Path.cwd()
    if isinstance(spec.urdf_ref, dict):
        urdf = dict(spec.urdf_ref)
    else:
        urdf = os.path.relpath(spec.urdf, base)
    document: dict = {"format": 1, "machine": {
        "name": spec.name, "urdf": urdf, "tool_frame": spec.tool_frame,
        "workpiece_frame": spec.workpiece_frame}}
    if spec.description:
        document["machine"]["description"] = spec.description
    if spec.reference:
        document["machine"]["source"] = spec.reference
    axes = {}
    for axis, kind in zip(spec.axes, machine.axis_kinds):
        table = {"joint": axis.joint}
        if axis.sign != 1:
            table["sign"] = int(axis.sign)
        default_frame = "moving" if kind == "linear" else "fixed"
        if axis.frame != default_frame:
            table["errors_frame"] = axis.frame
        if any(axis.reference):
            table["reference_point_mm"] = [round(float(v * 1e3), 9) for v in axis.reference]
        axes[axis.name] = table
    document["axes"] = axes
    if spec.bodies:
        document["bodies"] = {b.name: ({"joint": b.joint} | (
            {"reference_point_mm": [round(float(v * 1e3), 9) for v in b.reference]} if any(b.reference) else {}))
            for b in spec.bodies}
    theta = dict(zip(machine.parameter_names, machine.theta))
    errors = {}
    for comp in spec.components:
        tables = []
        for tspec in comp.terms:
            values = np.array([theta[n] for n in tspec.names(comp.name)])
            table = tspec.term.to_spec(values)
            if tspec.prefix:
                table["prefix"] = tspec.prefix
            tables.append(table)
        errors[comp.name] = tables[0] if len(tables) == 1 else {"terms": tables}
    document["errors"] = errors
    if provenance:
        document["provenance"] = provenance
    return document


def write_spec(machine: Machine, out: str | Path, provenance: dict | None = None, *, backup: bool = True) -> Path:
    """Write the machine's spec with its current values to ``out`` (TOML).

    ``provenance`` (data files, RMS, ...) is recorded with the date of writing and the spec the
    machine was derived from; None values are dropped (TOML has no null). The file is written
    to a temporary file beside ``out`` and renamed over it only when complete; a spec it
    replaces is kept as ``<stem>.bak.toml`` (``.bak2.toml`` ... when that is taken).

    Parameters
    ----------
    machine : Machine
        The machine.
    out : str or Path
        The TOML file to write.
    provenance : dict, optional
        Extra entries of the ``[provenance]`` table.
    backup : bool, default True
        Keep a spec that ``out`` replaces as a numbered backup beside it.

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    InputError
        If ``out`` is the machine's own spec or URDF.
    """
    out = Path(out)
    for source in (machine.spec.source, machine.spec.urdf):
        if same_file(out, source):
            raise InputError(f"out: {out} is the machine's own {'spec' if source == machine.spec.source else 'URDF'}; "
                             "write the new spec elsewhere", parameters=("out",))
    record = {"written": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
              "derived_from": str(machine.spec.source)}
    record.update(provenance or {})
    document = spec_document(machine, out, _clean(record))
    header = (f"# volerr_pin error specification for {machine.name}, written by volerr_pin "
              f"from {machine.spec.source}\n")
    return write_text(out, header + tomli_w.dumps(document), backup=backup)


def _clean(value):
    """TOML has no null: drop None, turn numpy scalars into Python numbers."""
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value if v is not None]
    if isinstance(value, np.generic):
        return value.item()
    return value

