"""Axis runs: positioning (ISO 230-2) and component runs along one axis, in every layout
instruments and loggers write.

- **positioning runs**: ``target_mm,cycle,direction,deviation_um`` (rotary axes
  ``target_deg``, ``deviation_arcsec``); ``direction`` +1 or -1.
- **component runs** (interferometer straightness / angular exports):
  ``target_mm,cycle,direction,EYX_um`` or ``...,EBX_arcsec``: the value column names the
  measured component and its unit.
- the same runs laid out one row per target and direction with one column per cycle (wide),
  or as ``KEY=VALUE`` lines (``UNIT=mm``, ``TGT_DATA[i]``, ``REF_DATA_FWD[i,c]``): converted
  to the long layout by :func:`run_table`.

Runs may say which axis moved and where the other axes stood in header comments:
``# axis: X`` and ``# at: Y=200, Z=150`` (mm / deg).

As observations, the moving axis stands at each target, the other axes at ``# at:`` (or mid
travel, rotary axes at 0). A positioning run observes the error along the axis' own motion; a
component run the component's direction. Every run file gets an offset (the instrument zero)
as a nuisance term; straightness runs also a slope (the reference line's alignment).
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base import (ANGLE, DEG, LENGTH, MM, PLAUSIBLE, InputError, axis_scale, axis_values_to_si, describe_range,
                    parse_number, shown)
from ..model import axis_jacobian, check_q, default_config, parse_component_name
from ._protocol import Measurement, MeasurementKind, NuisanceTerm, ObservationBlock, ObservationOptions
from ._table import (DIRECTION_WORDS, META_RE, MeasurementError, Table, add_meta, axis_values, read_file,
                    read_table)

__all__ = ["KIND", "MAX_CYCLE", "Runs", "is_run_file", "read_runs", "run_table"]

#: largest cycle number of a run (cycles count from 0 or 1)
MAX_CYCLE = 1_000_000
#: index of each error direction in the error's six components
DIRECTION_INDEX = {d: i for i, d in enumerate("XYZABC")}


@dataclass(frozen=True)
class Runs(Measurement):
    """A positioning or component run along one axis.

    ``target`` (N,) [m or rad]; ``cycle`` (N,) int; ``direction`` (N,) +1/-1; ``value`` (N,)
    in SI; ``file_value``/``unit`` as in the file; ``component`` the measured component
    ("EYX", "EBX"), or None for a positioning run (the error along the axis' own motion);
    ``axis`` the moving axis if known; ``at`` other axes' positions from the header, in file
    units (mm / deg), by axis name.

    Attributes
    ----------
    source : str
        The file.
    target : ndarray, shape (N,)
        Target positions [m or rad].
    cycle : ndarray of int, shape (N,)
        Cycle numbers.
    direction : ndarray of int, shape (N,)
        Approach directions, +1 or -1.
    value : ndarray, shape (N,)
        Measured deviations [m or rad].
    file_target : ndarray, shape (N,)
        Targets as in the file [mm or deg].
    file_value : ndarray, shape (N,)
        Values as in the file [``unit``].
    target_unit : str
        "mm" or "deg".
    unit : str
        Unit of the values in the file (um, mm, nm, arcsec, urad, mrad or deg).
    component : str or None
        The measured component ("EYX", "EBX"), None for a positioning run.
    axis : str or None
        The moving axis, if known.
    at : dict of str to float
        Other axes' positions from the header [mm, deg], by axis name.
    lines : ndarray of int, shape (N,)
        File line of each row.
    unused : tuple of str
        Columns (or keys) present but not used.

    Notes
    -----
    The methods of :class:`~volerr_pin.measurements.Measurement` (documented there) do here:

    - ``observations``: the run as observations: one row per approach, an offset (and for a
      straightness run a slope) as nuisance terms (see the module docstring).
    """

    source: str
    target: np.ndarray
    cycle: np.ndarray
    direction: np.ndarray
    value: np.ndarray
    file_target: np.ndarray
    file_value: np.ndarray
    target_unit: str
    unit: str
    component: str | None
    axis: str | None
    at: dict
    lines: np.ndarray
    unused: tuple[str, ...] = ()


    def observations(self, machine, options: ObservationOptions) -> ObservationBlock:
        axis = self.axis or options.axis
        if axis is None:
            raise InputError(f"{self.source}: which axis moved? Give '# axis: X' in the file or run_axis",
                             parameters=("run_axis",))
        if axis not in machine.axes:
            raise InputError(f"{self.source}: axis '{axis}' is not an axis of {machine.name} "
                             f"({', '.join(machine.axes)})")
        j = machine.axes.index(axis)
        kind = machine.axis_kinds[j]
        if (self.target_unit == "mm") != (kind == "linear"):
            raise InputError(f"{self.source}: targets in {self.target_unit} but axis {axis} is {kind}")
        at = axis_values_to_si(machine.axes, machine.axis_kinds, self.at, f"{self.source}: '# at:'", machine.name)
        base = default_config(machine, {**at, **(options.at or {})})
        q = np.tile(base, (len(self.target), 1))
        q[:, j] = self.target
        try:
            q = check_q(machine.model, q)
        except InputError as err:
            raise InputError(f"{self.source}: {err}") from None
        covariates = {"directions": np.where(np.arange(len(machine.axes)) == j, self.direction[:, None], 1.0)}
        if self.component is None:
            nominal = axis_jacobian(machine.model, q, nominal=True)[:, :, j]
            w = nominal / np.linalg.norm(nominal, axis=1, keepdims=True)
            angular = kind == "rotary"
            label = "positioning"
        else:
            direction, _, owner = parse_component_name(self.component)
            if owner != axis:
                raise InputError(f"{self.source}: {self.component} is an error of {owner}, not {axis}")
            w = np.zeros((len(q), 6))
            w[:, DIRECTION_INDEX[direction]] = 1.0
            angular = direction in "ABC"
            label = self.component
        straightness = (self.component is not None and not angular and kind == "linear"
                        and self.component[1] != axis)
        tag = f"{label} run {self.source}"
        n = len(q)
        terms = [NuisanceTerm(f"offset[{tag}]", bool(angular))]
        design = [np.ones(n)]
        if straightness:
            lo, hi = machine.travel[j]
            terms.append(NuisanceTerm(f"slope[{tag}]", False))
            design.append((2 * q[:, j] - lo - hi) / (hi - lo))
        sigma = (options.sigma_urad if angular else options.sigma_um) * 1e-6
        return ObservationBlock(self.source, q, covariates, np.arange(n), w, np.asarray(self.value, dtype=float),
                                np.full(n, sigma), np.full(n, angular), np.asarray(self.lines),
                                np.column_stack(design), tuple(terms))


RUN_VALUE_RE = re.compile(r"^(deviation|E[XYZABC]0?_?[A-Za-z][A-Za-z0-9_]*)_(um|mm|nm|arcsec|urad|mrad|deg)$")


def is_run_file(header: list[str]) -> bool:
    """Whether a header is that of a run file.

    Parameters
    ----------
    header : list of str
        Column names.

    Returns
    -------
    bool
        True if a column starts with ``target_``.
    """
    return any(h.startswith("target_") for h in header)


WIDE_CYCLE_RE = re.compile(r"^(?:(?P<stem>[A-Za-z][A-Za-z0-9]*)_)?(?:c|cycle_?)(?P<n>\d+)(?:_(?P<unit>[A-Za-z]+))?$")
KEY_VALUE_RE = re.compile(r"^(?P<key>[A-Za-z_][A-Za-z0-9_]*)(?:\[(?P<index>[^\]]*)\])?\s*=\s*(?P<value>.*)$")


def _deviation(actual: str, target: str, scale: float) -> str:
    """``actual - target`` of two numbers as written, times ``scale``, as text."""
    return repr((float(actual) - float(target)) * scale)


def _deviation_column(target_unit: str) -> tuple[str, float]:
    """Long-layout deviation column for positions given in the target's unit."""
    return ("deviation_um", 1e3) if target_unit == "mm" else ("deviation_arcsec", 3600.0)


def _wide_run_table(table: Table) -> Table | None:
    """A run laid out one row per target and direction, one column per cycle
    (``direction,i,target_mm,ref_c1,...,ref_c5``) as a long table; None if it is not one.

    Cycle columns hold the measured positions in the target's unit, or deviations when the
    column names a unit (``dev_c1_um``). Directions may be words (fwd/bwd, up/down, ...)."""
    header = table.header
    if any(h in ("cycle", "run") for h in header):
        return None
    targets = [c for c, h in enumerate(header) if h in ("target_mm", "target_deg")]
    cycles = [(c, WIDE_CYCLE_RE.match(h)) for c, h in enumerate(header)]
    cycles = [(c, m) for c, m in cycles if m]
    directions = [c for c, h in enumerate(header) if h.lower() in ("direction", "dir")]
    if len(targets) == 1 and cycles and len(directions) > 1:
        raise MeasurementError(f"{table.path}:{table.header_line}:{directions[1] + 1}: columns "
                               f"'{header[directions[0]]}' and '{header[directions[1]]}' are both the direction")
    if len(targets) != 1 or not cycles or len(directions) != 1:
        return None
    tcol, dcol = targets[0], directions[0]
    target_unit = header[tcol].split("_", 1)[1]
    seen: dict[int, int] = {}
    for c, m in cycles:
        n = int(m.group("n"))
        if n in seen:
            raise MeasurementError(f"{table.path}:{table.header_line}:{c + 1}: columns '{header[seen[n]]}' and "
                                   f"'{header[c]}' are both cycle {n}")
        seen[n] = c
    units = {m.group("unit") for _, m in cycles}
    if len(units) != 1:
        raise MeasurementError(f"{table.path}:{table.header_line}: cycle columns must all give positions "
                               f"(no unit) or all deviations in one unit, got {', '.join(h for h in header)}")
    unit = units.pop()
    if unit is None:
        value_name, scale = _deviation_column(target_unit)
    else:
        if unit not in LENGTH and unit not in ANGLE:
            raise MeasurementError(f"{table.path}:{table.header_line}: unknown unit '{unit}' in the cycle columns")
        value_name, scale = f"deviation_{unit}", None
    kind = "position_length" if target_unit == "mm" else "position_angle"
    target_scale = MM if target_unit == "mm" else DEG
    # deviations in the unit of the long layout: um / arcsec from positions, else as given
    dev_unit = value_name.split("_", 1)[1]
    dev_scale = LENGTH[dev_unit] if dev_unit in LENGTH else ANGLE[dev_unit]
    dev_kind = "error_length" if dev_unit in LENGTH else "error_angle"
    rows, lines = [], []
    for r, (cells, line) in enumerate(zip(table.rows, table.lines)):
        word = cells[dcol].strip().lower()
        if word not in DIRECTION_WORDS:
            raise MeasurementError(f"{table.where(r, dcol)}: column '{header[dcol]}': '{cells[dcol].strip()}' is "
                                   "not a direction (+1/-1, fwd/bwd, forward/backward, up/down, pos/neg)")
        target = str(table.number(r, tcol))
        _check_cell(table, r, tcol, float(target), kind, target_unit, target_scale)
        for c, m in cycles:
            if cells[c].strip() == "":
                continue  # a cycle not measured at this target
            value = table.number(r, c)
            if scale is None:
                _check_cell(table, r, c, value, dev_kind, dev_unit, dev_scale)
                deviation = repr(value)
            else:
                _check_cell(table, r, c, value, kind, target_unit, target_scale)
                deviation = _deviation(str(value), target, scale)
                _check_cell(table, r, c, float(deviation), dev_kind, dev_unit, dev_scale,
                            f"the deviation {shown(float(deviation))} {dev_unit} (measured minus target)")
            rows.append([target, str(int(m.group("n"))), DIRECTION_WORDS[word], deviation])
            lines.append(line)
    used = {tcol, dcol, *(c for c, _ in cycles)}
    meta = dict(table.meta)
    meta["unused"] = ",".join(h for c, h in enumerate(header) if c not in used)
    return Table(table.path, [header[tcol], "cycle", "direction", value_name], table.header_line, rows, lines, meta,
                 converted=True)


def _check_cell(table: Table, row: int, col: int, value: float, limit: str, unit: str, unit_scale: float,
                what: str | None = None) -> None:
    """Refuse a cell's value, or a value derived from it (``what``: a deviation from a measured
    position), beyond the plausibility limit ``limit``."""
    low, high = PLAUSIBLE[limit]
    if not low <= value * unit_scale <= high:
        raise MeasurementError(f"{table.where(row, col)}: column '{table.header[col]}': "
                               f"{what or f'{shown(value)} {unit}'} is implausible: "
                               f"{describe_range(limit, unit, unit_scale)} (docs/measurements.md)")


def _key_value_run_table(path: Path, text: str) -> Table:
    """An ``.dat`` run of ``KEY=VALUE`` lines (``UNIT=mm``, ``TGT_DATA[i]``, ``REF_DATA_FWD[i,c]``,
    ``REF_DATA_BWD[i,c]``: measured positions per target i and cycle c) as a long table."""
    values: dict[str, tuple[str, int]] = {}
    indexed: dict[str, dict[tuple[int, ...], tuple[str, int]]] = {}
    meta: dict[str, str] = {}
    meta_lines: dict[str, int] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            match = META_RE.match(stripped)
            if match:
                add_meta(meta, meta_lines, match, number, path, None)
            continue
        match = KEY_VALUE_RE.match(stripped)
        if not match:
            raise MeasurementError(f"{path}:{number}: expected KEY=VALUE or KEY[i,j]=VALUE, got '{stripped[:40]}'")
        key, index, value = match.group("key").upper(), match.group("index"), match.group("value").strip()
        if index is None:
            if key in values:
                raise MeasurementError(f"{path}:{number}: {key} given twice (first on line {values[key][1]})")
            values[key] = (value, number)
            continue
        try:
            idx = tuple(int(i) for i in index.split(","))
        except ValueError:
            raise MeasurementError(f"{path}:{number}: index [{index}] is not integers") from None
        if idx in indexed.setdefault(key, {}):
            raise MeasurementError(f"{path}:{number}: {key}[{index}] given twice "
                                   f"(first on line {indexed[key][idx][1]})")
        indexed[key][idx] = (value, number)

    def number_of(value: str, line: int, what: str) -> float:
        try:
            return parse_number(value)
        except ValueError as err:
            raise MeasurementError(f"{path}:{line}: {what}: '{value}' {err}") from None

    def plausible(x: float, line: int, what: str, limit: str, unit: str, unit_scale: float) -> None:
        low, high = PLAUSIBLE[limit]
        if not low <= x * unit_scale <= high:
            raise MeasurementError(f"{path}:{line}: {what} is implausible: {describe_range(limit, unit, unit_scale)} "
                                   "(docs/measurements.md)")

    if "UNIT" not in values:
        raise MeasurementError(f"{path}: no UNIT= line (mm or deg)")
    unit = values["UNIT"][0].strip().lower()
    if unit not in ("mm", "deg"):
        raise MeasurementError(f"{path}:{values['UNIT'][1]}: UNIT={unit}: expected mm or deg")
    targets = indexed.get("TGT_DATA", {})
    if not targets:
        raise MeasurementError(f"{path}: no TGT_DATA[i]= lines (the target positions)")
    for idx, (_, line) in targets.items():
        if len(idx) != 1:
            raise MeasurementError(f"{path}:{line}: TGT_DATA needs one index [target]")
    if not any(k in indexed for k in ("REF_DATA_FWD", "REF_DATA_BWD")):
        raise MeasurementError(f"{path}: no REF_DATA_FWD[i,c]= or REF_DATA_BWD[i,c]= lines (the measured positions)")
    value_name, scale = _deviation_column(unit)
    position = ("position_length", MM) if unit == "mm" else ("position_angle", DEG)
    dev_unit = value_name.split("_", 1)[1]
    deviation = ("error_length", LENGTH[dev_unit]) if unit == "mm" else ("error_angle", ANGLE[dev_unit])
    rows, lines = [], []
    for key, direction in (("REF_DATA_FWD", "1"), ("REF_DATA_BWD", "-1")):
        for idx, (value, line) in sorted(indexed.get(key, {}).items()):
            if len(idx) != 2:
                raise MeasurementError(f"{path}:{line}: {key} needs two indices [target, cycle]")
            if (idx[0],) not in targets:
                raise MeasurementError(f"{path}:{line}: {key}[{idx[0]},{idx[1]}]: no TGT_DATA[{idx[0]}]")
            target_text, target_line = targets[(idx[0],)]
            name = f"{key}[{idx[0]},{idx[1]}]"
            target = number_of(target_text, target_line, f"TGT_DATA[{idx[0]}]")
            plausible(target, target_line, f"TGT_DATA[{idx[0]}] = {shown(target)} {unit}", position[0], unit, position[1])
            measured = number_of(value, line, name)
            plausible(measured, line, f"{name} = {shown(measured)} {unit}", position[0], unit, position[1])
            dev = _deviation(repr(measured), repr(target), scale)
            plausible(float(dev), line, f"{name}: the deviation {shown(float(dev))} {dev_unit}", deviation[0], dev_unit,
                      deviation[1])
            rows.append([repr(target), str(idx[1]), direction, dev])
            lines.append(line)
    for key, what in (("CYCLES", {r[1] for r in rows}), ("POSITIONS", {r[0] for r in rows})):
        if key in values:
            count = number_of(*values[key], key)
            if count != round(count) or int(count) != len(what):
                raise MeasurementError(f"{path}:{values[key][1]}: {key}={values[key][0]} but the data hold {len(what)}")
    known = {"UNIT", "CYCLES", "POSITIONS", "TGT_DATA", "REF_DATA_FWD", "REF_DATA_BWD"}
    meta["unused"] = ",".join(sorted((set(values) | set(indexed)) - known))
    return Table(str(path), [f"target_{unit}", "cycle", "direction", value_name], 0, rows, lines, meta,
                 converted=True)


def run_table(path: str | Path | Table, text: str | None = None) -> Table:
    """A run file in any accepted layout as the long table ``target_*,cycle,direction,value``.

    Long CSV, wide CSV (one column per cycle) or ``KEY=VALUE`` lines (``.dat``). Any other
    file comes back as read.

    Parameters
    ----------
    path : str, Path or Table
        The file, or a table read already.
    text : str, optional
        The file's content when the caller has read it already.

    Returns
    -------
    Table
        The long table (a wide or ``KEY=VALUE`` layout converted: deviations from measured
        positions in um or arcsec), or the file as read.

    Raises
    ------
    MeasurementError
        If the file cannot be read or a run layout is malformed.
    """
    if isinstance(path, Table):
        table = path
    else:
        path = Path(path)
        text = read_file(path) if text is None else text
        first = next((l.strip() for l in text.splitlines() if l.strip() and not l.strip().startswith("#")), "")
        if KEY_VALUE_RE.match(first) and "," not in first:
            return _key_value_run_table(path, text)
        table = read_table(path, text)
    return _wide_run_table(table) or table


def read_runs(path: str | Path | Table, axis: str | None = None) -> Runs:
    """Read a positioning (ISO 230-2) or component run; ``axis`` overrides ``# axis:``.

    Layouts: long CSV ``target_mm,cycle,direction,deviation_um`` (or a component column such
    as ``EYX_um``), wide CSV with one column per cycle, and ``KEY=VALUE`` files (see
    :func:`run_table` and docs/measurements.md).

    Parameters
    ----------
    path : str, Path or Table
        The file, or a table read already.
    axis : str, optional
        The moving axis (a component run's own axis is that of its component).

    Returns
    -------
    Runs
        The run, values in SI and as in the file.

    Raises
    ------
    MeasurementError
        If the table is malformed, the target, cycle, direction or value column is missing or
        ambiguous, the component is unknown or belongs to another axis than ``axis``, the
        value's unit does not fit the target or component, ``axis`` contradicts the file's
        ``# axis:``, ``# at:`` names the moving axis, a direction is not +1 / -1, a cycle
        number is not an integer from 0 to :data:`MAX_CYCLE`, one target, cycle and
        direction is given twice (naming both lines), or a target or value lies beyond its
        plausibility limit.
    """
    table = run_table(path)
    header = table.header
    target_cols = [c for c, h in enumerate(header) if h in ("target_mm", "target_deg")]
    if len(target_cols) != 1:
        raise MeasurementError(f"{table.path}:{table.header_line}: a run needs exactly one of the "
                               "columns target_mm (linear axis) or target_deg (rotary axis)")
    tcol = target_cols[0]
    target_unit = header[tcol].split("_", 1)[1]
    needed = {}
    for name in ("cycle", "direction"):
        alternatives = [name] + (["run"] if name == "cycle" else [])
        found = [c for c, h in enumerate(header) if h in alternatives]
        if not found:
            raise MeasurementError(f"{table.path}:{table.header_line}: missing column '{name}'")
        if len(found) > 1:
            raise MeasurementError(f"{table.path}:{table.header_line}:{found[1] + 1}: columns "
                                   f"'{header[found[0]]}' and '{header[found[1]]}' are both the {name}; keep one")
        needed[name] = found[0]
    value_cols = [(c, RUN_VALUE_RE.match(h)) for c, h in enumerate(header) if RUN_VALUE_RE.match(h)]
    if len(value_cols) != 1:
        raise MeasurementError(
            f"{table.path}:{table.header_line}: a run needs exactly one value column: "
            "deviation_um / deviation_arcsec (positioning) or a component with its unit such as "
            "EYX_um or EBX_arcsec")
    vcol, match = value_cols[0]
    quantity, unit = match.group(1), match.group(2)
    own = table.meta.get("axis")
    if axis is not None and own is not None and axis != own:
        raise MeasurementError(f"axis {axis} is not the run's own: {table.path} says '# axis: {own}'",
                               parameters=("axis",))
    axis = axis or own
    component = None  # positioning: the error along the axis' own motion
    if quantity != "deviation":
        component = quantity
        try:
            _, _, owner = parse_component_name(quantity)
        except ValueError:
            raise MeasurementError(f"{table.path}:{table.header_line}:{vcol + 1}: '{quantity}' is not "
                                   "a component name") from None
        if axis is not None and axis != owner:
            raise MeasurementError(f"{table.path}:{table.header_line}:{vcol + 1}: column '{header[vcol]}' "
                                   f"belongs to axis {owner}, but the run is along {axis}")
        axis = owner
    angular = unit in ANGLE
    target_linear = target_unit == "mm"
    value_scale = ANGLE[unit] if angular else LENGTH[unit]
    if quantity == "deviation" and angular == target_linear:
        raise MeasurementError(f"{table.path}:{table.header_line}:{vcol + 1}: a positioning run on a "
                               f"{'linear' if target_linear else 'rotary'} axis gives its deviation in "
                               f"{'um' if target_linear else 'arcsec'}, not {unit}")
    if quantity != "deviation":
        direction_letter = quantity[1]
        if (direction_letter in "ABC") != angular:
            raise MeasurementError(f"{table.path}:{table.header_line}:{vcol + 1}: {quantity} is "
                                   f"{'an angle' if direction_letter in 'ABC' else 'a length'}; unit "
                                   f"'{unit}' does not fit")
    target_scale = axis_scale("linear" if target_linear else "rotary")
    file_target = table.column(tcol, limit="position_length" if target_linear else "position_angle",
                               unit=target_unit, unit_scale=target_scale)
    file_value = table.column(vcol, limit="error_angle" if angular else "error_length", unit=unit,
                              unit_scale=value_scale)
    cycle = table.column(needed["cycle"])
    direction = table.column(needed["direction"])
    for k, (values, name) in enumerate(((cycle, "cycle"), (direction, "direction"))):
        col = needed[name]
        if name == "direction":
            bad = np.flatnonzero(~np.isin(values, (-1.0, 1.0)))
            if bad.size:
                raise MeasurementError(f"{table.where(bad[0], col)}: column 'direction': must be +1 or -1, "
                                       f"got {table.rows[bad[0]][col].strip()}")
        else:
            bad = np.flatnonzero((values != np.round(values)) | (values < 0) | (values > MAX_CYCLE))
            if bad.size:
                raise MeasurementError(f"{table.where(bad[0], col)}: column '{header[col]}': cycle numbers "
                                       f"are integers from 0 to {MAX_CYCLE:,}, got {table.rows[bad[0]][col].strip()}")
    _refuse_repeated_approaches(table, file_target, cycle, direction, target_unit)
    at = axis_values(table, "at")
    if axis is not None and axis in at:
        raise MeasurementError(f"{table.path}: header '# at: {table.meta['at']}' gives {axis}={at[axis]:g}, but "
                               f"{axis} is the axis that moves in this run; '# at:' gives the other axes")
    used = {tcol, vcol, needed["cycle"], needed["direction"]}
    unused = tuple(h for c, h in enumerate(header) if c not in used)
    unused += tuple(h for h in table.meta.get("unused", "").split(",") if h)
    return Runs(table.path, file_target * target_scale, cycle.astype(int), direction.astype(int),
                file_value * value_scale, file_target, file_value, target_unit, unit, component, axis,
                at, np.array(table.lines), unused)


def _refuse_repeated_approaches(table: Table, target: np.ndarray, cycle: np.ndarray, direction: np.ndarray,
                                unit: str) -> None:
    """One approach per target, cycle and direction: a repeated row would count as one more
    approach (a sixth of five) and change every statistic. Targets are compared as
    :func:`volerr_pin.applications.iso230.evaluate` groups them, to 1e-9 of their unit."""
    first: dict[tuple[float, int, int], int] = {}
    for r, key in enumerate(zip(np.round(target, 9).tolist(), cycle.astype(int).tolist(),
                                direction.astype(int).tolist())):
        if key in first:
            raise MeasurementError(
                f"{table.path}:{table.lines[r]}: target {key[0]:g} {unit}, cycle {key[1]}, direction "
                f"{key[2]:+d} is given twice (first on line {table.lines[first[key]]}); one approach per "
                "target, cycle and direction")
        first[key] = r



def _other_layout(path: Path, text: str) -> Table | None:
    """A run file in the wide or KEY=VALUE layout as the long table; None for any other file
    (told apart by its first line, so that other files are parsed once, by the caller)."""
    first = next((l.strip() for l in text.splitlines() if l.strip() and not l.strip().startswith("#")), "")
    if KEY_VALUE_RE.match(first) and "," not in first:
        return _key_value_run_table(path, text)
    try:
        header = [c.strip() for c in next(csv.reader([first], strict=True))] if first else []
    except csv.Error:
        return None  # the table reader names the line
    targets = [h for h in header if h in ("target_mm", "target_deg")]
    directions = [h for h in header if h.lower() in ("direction", "dir")]
    if (len(targets) == 1 and directions and any(WIDE_CYCLE_RE.match(h) for h in header)
            and not any(h in ("cycle", "run") for h in header)):
        return _wide_run_table(read_table(path, text))
    return None

#: positioning and component runs, in the long, wide and KEY=VALUE layouts
KIND = MeasurementKind("runs", "runs", False, recognises=is_run_file,
                       read=lambda table, machine=None, axis=None: read_runs(table, axis),
                       layout=_other_layout)
