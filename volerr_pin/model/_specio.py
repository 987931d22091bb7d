"""A machine's spec at the file boundary: written back as TOML (:func:`write_spec`, with a
``[provenance]`` table saying where its values came from; :func:`spec_document` is the
document), its present values checked against what a spec file holds (:func:`check_values`),
and Legendre terms fitted to its present component functions (:func:`legendre_terms`), for
typed edits of :class:`~volerr_pin.model.MachineSpec`.
"""

from __future__ import annotations

import datetime as _dt
import os
from pathlib import Path

import numpy as np
import tomli_w

from ..base import ANGLE, LENGTH, InputError, SpecError, same_file, write_text
from ._machine import Machine
from ._model import Model
from ._checks import plausible_theta
from ._spec import TermSpec, parse_component_name

#: the highest degree :func:`legendre_terms` fits
MAX_DEGREE = 20


__all__ = ["MAX_DEGREE", "add_terms", "check_values", "legendre_terms", "replace_terms", "spec_document", "write_spec"]


def check_values(machine: Machine | Model, theta: np.ndarray | None = None) -> None:
    """Check that a machine's present coefficient values are ones its spec can hold (within
    the plausibility limits a spec file is read with), so that a machine built from them - a
    changed model, a written spec - can be.

    Parameters
    ----------
    machine : Machine or Model
        The machine (its values are checked), or a model whose ``theta`` is checked.
    theta : ndarray, shape (P,), optional
        With a model: the values.

    Raises
    ------
    SpecError
        Naming the spec's source ("present values") and the first coefficient, its value and the
        limit that a spec would refuse.
    """
    model, values = (machine.model, machine.theta) if theta is None else (machine, theta)
    try:
        plausible_theta(model, values)
    except InputError as err:
        raise SpecError(f"{model.spec.source} (present values): {err}") from None


def _read(machine: Machine, tables: dict) -> dict[str, list[TermSpec]]:
    """``tables`` (component -> one term or a list of them: tables in the spec file's form, read
    here, or :class:`~volerr_pin.model.TermSpec`) as typed terms of the machine's spec."""
    if not isinstance(tables, dict):
        raise InputError(f"tables must map component names to term tables, got {type(tables).__name__}",
                         parameters=("tables",))
    spec = machine.spec

    def terms(name, given):
        items = [given] if isinstance(given, (dict, TermSpec)) else list(given)
        return [t if isinstance(t, TermSpec) else spec.term(name, t) for t in items]

    return {name: terms(name, given) for name, given in tables.items()}


def add_terms(machine: Machine, tables: dict) -> Machine:
    """A new machine with terms written as a spec file writes them added to its components:
    the tables are read at this boundary (:meth:`MachineSpec.term <volerr_pin.model.MachineSpec.term>`)
    and added as typed terms (:meth:`MachineSpec.with_terms <volerr_pin.model.MachineSpec.with_terms>`);
    every present coefficient keeps its value.

    Parameters
    ----------
    machine : Machine
        The machine.
    tables : dict of str to dict, TermSpec or list of them
        Component name -> one term or a list of them: a table as a spec file writes it, e.g.
        ``{"EXY": {"kind": "force_deflection", "force": "x", "compliance_um_per_N": [0.01]}}``,
        or a typed term.

    Returns
    -------
    Machine
        The new machine, in the same state.

    Raises
    ------
    SpecError
        If a component name or table is invalid (named as in a spec file).
    """
    spec = machine.spec
    for name, terms in _read(machine, tables).items():
        spec = spec.with_terms(name, *terms)
    return machine.with_spec(spec)


def replace_terms(machine: Machine, tables: dict) -> Machine:
    """A new machine whose components named in ``tables`` have the terms the tables give (added
    when the machine has none); the other components keep their present values.

    Parameters
    ----------
    machine : Machine
        The machine.
    tables : dict of str to dict, TermSpec or list of them
        Component name -> one term or a list of them (tables in the spec file's form, or typed
        terms).

    Returns
    -------
    Machine
        The new machine, in the same state.

    Raises
    ------
    SpecError
        If a component name or table is invalid (named as in a spec file).
    """
    spec = machine.spec
    for name, terms in _read(machine, tables).items():
        spec = spec.with_component(name, *terms)
    return machine.with_spec(spec)


def legendre_terms(machine: Machine, components, degree: int, start: int = 0) -> dict[str, TermSpec]:
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
    dict of str to TermSpec
        Component name -> its Legendre term (coefficients in um, or arcsec for an angular
        component), degree + 1 values, for ``machine.spec.with_component(name, term)``.

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
        tables[name] = machine.spec.term(name, {"kind": "legendre", f"coefficients_{unit}": [float(c) for c in full]})
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

