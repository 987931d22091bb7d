"""Readers for measurement files, with strict validation (file, line and column in every error).

Three kinds, told apart by their header (comma-separated, ``#`` comment lines allowed):

- **point measurements**: ``x,y,z[,a,b,c],dx,dy,dz[,rx,ry,rz]`` plus optional covariates
  ``t,T_<sensor>...,Fx,Fy,Fz,dir_<axis>...``; positions in mm / deg (commanded NC
  positions, one column per machine axis, lower-case axis names), deviations in um and
  urad (measured tool point minus commanded, relative to the workpiece), ``t`` in s,
  ``T_*`` in degC, ``F*`` in N, ``dir_*`` +1/-1. Columns may carry their unit
  (``x_mm``, ``dx_um``, ``rx_urad``); an empty deviation cell means "not measured".
- **positioning runs** (ISO 230-2): ``target_mm,cycle,direction,deviation_um`` (rotary
  axes ``target_deg``, ``deviation_arcsec``); ``direction`` +1 or -1.
- **component runs** (interferometer straightness / angular exports):
  ``target_mm,cycle,direction,EYX_um`` or ``...,EBX_arcsec``: the value column names the
  measured component and its unit.

Runs may say which axis moved and where the other axes stood in header comments:
``# axis: X`` and ``# at: Y=200, Z=150`` (mm / deg).

Values beyond the plausibility limits of :data:`volerr_pin.units.PLAUSIBLE` (a deviation of
more than 1 m, a position beyond 1 km, a temperature below absolute zero...) are refused,
naming file, line and column: they are mistakes, not measurements (docs/measurements.md).
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError
from .safeio import read_text
from .spec import parse_component_name
from .units import (ANGLE, AXIS_UNIT, DEG, LENGTH, MM, PLAUSIBLE, axis_scale, describe_range,
                    parse_axis_values, parse_number, shown, split_key)

DEVIATIONS = ("dx", "dy", "dz", "rx", "ry", "rz")
DEVIATION_UNITS = {"dx": "um", "dy": "um", "dz": "um", "rx": "urad", "ry": "urad", "rz": "urad"}
#: largest cycle number of a run (cycles count from 0 or 1)
MAX_CYCLE = 1_000_000
META_RE = re.compile(r"^#\s*(axis|at|plane|radius|centre|center|convention|tool)\s*:\s*(.*)$", re.IGNORECASE)


class MeasurementError(InputError):
    """A measurement file is malformed (the message names file, line and column).

    A subclass of :class:`~volerr_pin.errors.InputError`; constructed like it.
    """


@dataclass
class Table:
    """A CSV table as read: header, rows with their line numbers, header-comment metadata.

    Attributes
    ----------
    path : str
        The file.
    header : list of str
        Column names, stripped.
    header_line : int
        File line of the header (0 for a table built from ``KEY=VALUE`` lines).
    rows : list of list of str
        Data rows as text, one cell per column.
    lines : list of int
        File line of each row.
    meta : dict of str to str
        Header comments before the header row (``# axis:``, ``# at:``, ``# plane:``,
        ``# radius:``, ``# centre:``, ``# convention:``, ``# tool:``), keys lower-case; a
        converted run layout adds ``unused``.
    converted : bool, default False
        Whether the table was converted from another layout (wide or ``KEY=VALUE`` runs):
        its columns are not the file's, so messages name the line only.
    """

    path: str
    header: list[str]
    header_line: int
    rows: list[list[str]]
    lines: list[int]
    meta: dict[str, str] = field(default_factory=dict)
    converted: bool = False

    def where(self, row: int, col: int) -> str:
        """Where a cell is, for messages.

        Parameters
        ----------
        row : int
            Row index (0-based, into :attr:`rows`).
        col : int
            Column index (0-based).

        Returns
        -------
        str
            ``path:line:column`` with the file line and the 1-based column (``path:line`` for
            a converted table).
        """
        if self.converted:
            return f"{self.path}:{self.lines[row]}"
        return f"{self.path}:{self.lines[row]}:{col + 1}"

    def number(self, row: int, col: int, allow_empty: bool = False) -> float:
        """A cell as a finite float.

        Parameters
        ----------
        row : int
            Row index (0-based).
        col : int
            Column index (0-based).
        allow_empty : bool, default False
            An empty cell gives NaN instead of an error.

        Returns
        -------
        float
            The value, in the file's unit.

        Raises
        ------
        MeasurementError
            If the cell is not a decimal number (``nan``, ``inf``, ``1_000``, hex and
            non-ASCII digits are refused) or overflows.
        """
        text = self.rows[row][col].strip()
        if text == "" and allow_empty:
            return math.nan
        try:
            return parse_number(text)
        except ValueError as err:
            shown = text if text.isprintable() else repr(text)
            raise MeasurementError(f"{self.where(row, col)}: column '{self.header[col]}': "
                                   f"'{shown}' {err}") from None

    def column(self, col: int, allow_empty: bool = False, *, limit: str | None = None, unit: str = "",
               unit_scale: float = 1.0) -> np.ndarray:
        """A column as finite floats (see :meth:`number`), within a plausibility limit.

        Parameters
        ----------
        col : int
            Column index (0-based).
        allow_empty : bool, default False
            Empty cells give NaN instead of an error.
        limit : str, optional
            A key of :data:`volerr_pin.units.PLAUSIBLE` ("error_length", "time", ...): values
            beyond it are refused.
        unit : str, optional
            The column's unit, for the message.
        unit_scale : float, default 1.0
            SI value of one unit of the column (1e-6 for um; 1 for degC).

        Returns
        -------
        ndarray, shape (n_rows,)
            The values, in the file's unit.

        Raises
        ------
        MeasurementError
            If a cell is not a number or not finite, or lies beyond ``limit``.
        """
        # Fast path: float() takes exactly the numbers parse_number takes, once the text is
        # ASCII without underscores and the values are finite; any other column is read cell
        # by cell, which names the first bad cell.
        texts = [row[col] for row in self.rows]
        joined = "".join(texts)
        values = None
        if joined.isascii() and "_" not in joined:
            try:
                values = np.array([float(t) if (t.strip() or not allow_empty) else math.nan for t in texts])
            except ValueError:
                values = None
            if values is not None and not np.all(np.isfinite(values) | np.array([not t.strip() for t in texts])):
                values = None
        if values is None:
            values = np.array([self.number(i, col, allow_empty) for i in range(len(self.rows))])
        if limit is not None:
            self.check_plausible(col, values, limit, unit, unit_scale)
        return values

    def check_plausible(self, col: int, values: np.ndarray, limit: str, unit: str, unit_scale: float = 1.0
                        ) -> None:
        """Refuse values of a column beyond a plausibility limit, naming the first such cell.

        Parameters
        ----------
        col : int
            Column index (0-based) the values come from.
        values : ndarray, shape (n_rows,)
            The values in the column's unit (NaN: not measured, passes).
        limit : str
            A key of :data:`volerr_pin.units.PLAUSIBLE`.
        unit : str
            The unit of the values, for the message.
        unit_scale : float, default 1.0
            SI value of one unit.

        Raises
        ------
        MeasurementError
            Naming file, line, column, the value and the limit.
        """
        low, high = PLAUSIBLE[limit]
        si = values * unit_scale
        bad = np.flatnonzero((si < low) | (si > high))
        if bad.size:
            r = int(bad[0])
            raise MeasurementError(f"{self.where(r, col)}: column '{self.header[col]}': {shown(values[r])} {unit} "
                                   f"is implausible: {describe_range(limit, unit, unit_scale)} "
                                   "(docs/measurements.md)".replace("  ", " "))


def _read_text(path: Path) -> str:
    return read_text(path, MeasurementError, "measurement file")


def _add_meta(meta: dict, meta_lines: dict, match: re.Match, number: int, path, header_line: int | None) -> None:
    """Keep one ``# key: value`` line; refuse it given twice (``centre`` and ``center`` are one
    key) or after the header row, where it would silently not count."""
    key = match.group(1).lower()
    if header_line is not None:
        raise MeasurementError(f"{path}:{number}: '# {match.group(1)}:' comes after the header row "
                               f"(line {header_line}); metadata lines go before it")
    same = {"centre": "center", "center": "centre"}.get(key)
    for k in (key, same):
        if k in meta_lines:
            raise MeasurementError(f"{path}:{number}: '# {match.group(1)}:' is given twice "
                                   f"(first on line {meta_lines[k]})")
    meta[key] = match.group(2).strip()
    meta_lines[key] = number


def read_table(path: str | Path | Table, text: str | None = None) -> Table:
    """Read a comma-separated file with ``#`` comments; every data row must match the header.

    A :class:`Table` already read is returned as it is (readers take either).

    Parameters
    ----------
    path : str, Path or Table
        The file (UTF-8; a byte-order mark is tolerated).
    text : str, optional
        The file's content when the caller has read it already.

    Returns
    -------
    Table
        The header, the data rows and the header-comment metadata.

    Raises
    ------
    MeasurementError
        If the file cannot be read (not a regular file, larger than the memory allows, not
        UTF-8), a column name is duplicated or empty, a metadata line (``# axis:``,
        ``# plane:``...) is given twice or after the header row, a row has another number of
        cells than the header, or there is no header or no data row.
    """
    if isinstance(path, Table):
        return path
    path = Path(path)
    text = _read_text(path) if text is None else text
    header, header_line, rows, lines, meta = None, 0, [], [], {}
    meta_lines: dict[str, int] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            match = META_RE.match(stripped)
            if match:
                _add_meta(meta, meta_lines, match, number, path, header_line if header is not None else None)
            continue
        try:
            cells = next(csv.reader([line], strict=True))
        except csv.Error as err:  # an unclosed quote, a cell beyond the csv module's size limit
            raise MeasurementError(f"{path}:{number}: not a comma-separated row ({err})") from None
        if header is None:
            header = [c.strip() for c in cells]
            header_line = number
            seen: dict[str, int] = {}
            for col, name in enumerate(header):
                if name in seen:
                    raise MeasurementError(f"{path}:{number}:{col + 1}: duplicate column '{name}'")
                seen[name] = col
            if "" in header:
                raise MeasurementError(f"{path}:{number}:{header.index('') + 1}: empty column name")
            continue
        if len(cells) != len(header):
            raise MeasurementError(f"{path}:{number}:{min(len(cells), len(header)) + 1}: "
                                   f"{len(cells)} values but the header has {len(header)} columns")
        rows.append(cells)
        lines.append(number)
    if header is None:
        raise MeasurementError(f"{path}: no header row")
    if not rows:
        raise MeasurementError(f"{path}:{header_line}: no data rows after the header")
    return Table(str(path), header, header_line, rows, lines, meta)


@dataclass(frozen=True)
class PointMeasurements:
    """Point measurements in SI.

    ``q`` (N, n_axes) commanded positions [m, rad]; ``values`` (N, 6) deviations dx, dy, dz [m],
    rx, ry, rz [rad] with NaN where not measured; ``covariates`` keyword arrays for the
    model; ``lines`` the file line of each row; ``unused`` columns present but not used.

    Attributes
    ----------
    source : str
        The file (or a label for simulated data).
    q : ndarray, shape (N, n_axes)
        Commanded NC positions [m, rad].
    values : ndarray, shape (N, 6)
        Deviations dx, dy, dz [m], rx, ry, rz [rad]; NaN where not measured.
    covariates : dict
        Keyword covariates for :meth:`Machine.volumetric_error`: ``t`` (N,) [s],
        ``temperatures`` {sensor: (N,)} [degC], ``forces`` (N, 3) [N], ``directions``
        (N, n_axes) of +1/-1; only those present.
    lines : ndarray of int, shape (N,)
        File line of each row.
    unused : tuple of str
        Columns present but not used.
    """

    source: str
    q: np.ndarray
    values: np.ndarray
    covariates: dict
    lines: np.ndarray
    unused: tuple[str, ...] = ()

    @property
    def measured(self) -> np.ndarray:
        """Where a deviation was measured: ndarray of bool, shape (N, 6)."""
        return ~np.isnan(self.values)


def read_points(path: str | Path | Table, machine) -> PointMeasurements:
    """Read a point-measurement file for ``machine`` (positions checked against its travel).

    See the module docstring for the columns and their units.

    Parameters
    ----------
    path : str, Path or Table
        The file, or a table read already.
    machine : Machine
        The machine (its axes name the position columns).

    Returns
    -------
    PointMeasurements
        The measurements in SI.

    Raises
    ------
    MeasurementError
        If the table is malformed, a column's unit is not the file unit or a column is given
        twice under two spellings, a position column is missing or outside the travel, a
        covariate column is invalid, there is no deviation column, a row has no measured
        deviation, or a value lies beyond its plausibility limit (docs/measurements.md).
    """
    table = read_table(path)
    columns = header_columns(table, machine)
    q, covariates, used = positions_and_covariates(table, columns, machine)
    values = np.full((len(table.rows), 6), np.nan)
    present = [k for k, name in enumerate(DEVIATIONS) if name in columns]
    if not present:
        raise MeasurementError(f"{table.path}:{table.header_line}: no deviation column "
                               "(dx, dy, dz [um] or rx, ry, rz [urad])")
    for k in present:
        col = columns[DEVIATIONS[k]]
        used.add(col)
        limit = "error_length" if k < 3 else "error_angle"
        values[:, k] = table.column(col, allow_empty=True, limit=limit, unit=DEVIATION_UNITS[DEVIATIONS[k]],
                                    unit_scale=1e-6) * 1e-6  # um and urad
    empty = np.flatnonzero(np.all(np.isnan(values), axis=1))
    if empty.size:
        raise MeasurementError(f"{table.path}:{table.lines[empty[0]]}: row has no measured deviation")
    unused = tuple(table.header[c] for c in range(len(table.header)) if c not in used)
    return PointMeasurements(table.path, q, values, covariates, np.array(table.lines), unused)


def header_columns(table: Table, machine) -> dict[str, int]:
    """Column stem -> index, with the units in the names checked against the file units.

    Parameters
    ----------
    table : Table
        The table.
    machine : Machine
        The machine (its axes name the position columns and their units).

    Returns
    -------
    dict of str to int
        Column name without its unit suffix -> column index (0-based).

    Raises
    ------
    MeasurementError
        If a column carries a unit other than the file unit of that column (mm / deg for
        positions, um / urad for deviations, s, degC, N, mm for tracker coordinates), or one
        column is given twice under two spellings (``dx`` and ``dx_um``).
    """
    columns: dict[str, int] = {}
    for col, name in enumerate(table.header):
        stem, unit = split_key(name, ("length", "angle", "time", "temperature", "force"))
        if stem in columns:
            first = table.header[columns[stem]]
            raise MeasurementError(f"{table.path}:{table.header_line}:{col + 1}: columns '{first}' "
                                   f"(column {columns[stem] + 1}) and '{name}' are both {stem}; keep one")
        columns[stem] = col
        expected = _expected_unit(stem, machine)
        if unit is not None and expected is not None and unit != expected:
            raise MeasurementError(f"{table.path}:{table.header_line}:{col + 1}: column '{name}': "
                                   f"unit '{unit}' is not the file unit '{expected}' of {stem}")
    return columns


def positions_and_covariates(table: Table, columns: dict[str, int], machine) -> tuple[np.ndarray, dict, set]:
    """NC positions (SI, checked against the travel), covariates, and the columns used.

    Parameters
    ----------
    table : Table
        The table.
    columns : dict of str to int
        Column stem -> index, from :func:`header_columns`.
    machine : Machine
        The machine.

    Returns
    -------
    q : ndarray, shape (n_rows, n_axes)
        NC positions [m, rad] (the file gives mm / deg).
    covariates : dict
        ``t`` [s], ``temperatures`` {sensor: values} [degC], ``forces`` (n_rows, 3) [N] and
        ``directions`` (n_rows, n_axes) of +1/-1 (+1 for axes without a column), those the
        file gives.
    used : set of int
        Indices of the columns read.

    Raises
    ------
    MeasurementError
        If a position column is missing or leaves the travel, a value is not a finite number
        or lies beyond its plausibility limit, only some of Fx, Fy, Fz are given, or a
        direction is not +1 or -1.
    """
    used = set()
    q = np.empty((len(table.rows), len(machine.axes)))
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        key = axis.lower()
        if key not in columns:
            raise MeasurementError(f"{table.path}:{table.header_line}: missing position column "
                                   f"'{key}' for axis {axis} ({AXIS_UNIT[kind]})")
        col = columns[key]
        used.add(col)
        factor = axis_scale(kind)
        q[:, j] = table.column(col, limit=f"position_{'length' if kind == 'linear' else 'angle'}",
                               unit=AXIS_UNIT[kind], unit_scale=factor) * factor
        lo, hi = machine.travel[j]
        bad = np.flatnonzero((q[:, j] < lo - 1e-9 * max(1.0, hi - lo)) | (q[:, j] > hi + 1e-9 * max(1.0, hi - lo)))
        if bad.size:
            shown, unit = 1.0 / factor, AXIS_UNIT[kind]
            raise MeasurementError(f"{table.where(bad[0], col)}: {key} = {q[bad[0], j] * shown:g} {unit} is "
                                   f"outside the travel of {axis} [{lo * shown:g}, {hi * shown:g}] {unit}")
    covariates: dict = {}
    if "t" in columns:
        covariates["t"] = table.column(columns["t"], limit="time", unit="s")
        used.add(columns["t"])
    temps = {}
    for name, col in columns.items():
        if name.startswith("T_") and len(name) > 2:
            temps[name[2:]] = table.column(col, limit="temperature", unit="degC")
            used.add(col)
    if temps:
        covariates["temperatures"] = temps
    force_cols = [columns.get(f"F{c}") for c in "xyz"]
    if any(c is not None for c in force_cols):
        missing = [f"F{c}" for c, col in zip("xyz", force_cols) if col is None]
        if missing:
            raise MeasurementError(f"{table.path}:{table.header_line}: force columns need all of "
                                   f"Fx, Fy, Fz (missing {', '.join(missing)})")
        covariates["forces"] = np.column_stack([table.column(c, limit="force", unit="N") for c in force_cols])
        used.update(force_cols)
    dir_cols = [columns.get(f"dir_{a.lower()}") for a in machine.axes]
    if any(c is not None for c in dir_cols):
        directions = np.ones((len(table.rows), len(machine.axes)))
        for j, col in enumerate(dir_cols):
            if col is None:
                continue
            used.add(col)
            directions[:, j] = table.column(col)
            bad = np.flatnonzero(~np.isin(directions[:, j], (-1.0, 1.0)))
            if bad.size:
                raise MeasurementError(f"{table.where(bad[0], col)}: column '{table.header[col]}': "
                                       f"direction must be +1 or -1, got {table.rows[bad[0]][col].strip()}")
        covariates["directions"] = directions
    return q, covariates, used


def _expected_unit(stem: str, machine) -> str | None:
    if stem in DEVIATION_UNITS:
        return DEVIATION_UNITS[stem]
    for axis, kind in zip(machine.axes, machine.axis_kinds):
        if stem == axis.lower():
            return AXIS_UNIT[kind]
    if stem == "t":
        return "s"
    if stem.startswith("T_"):
        return "degC"
    if stem in ("Fx", "Fy", "Fz"):
        return "N"
    if stem in ("tx", "ty", "tz", "ox", "oy", "oz"):  # tracker coordinates, target offsets
        return "mm"
    return None


@dataclass(frozen=True)
class Runs:
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


DIRECTION_WORDS = {**{w: "1" for w in ("+1", "1", "+", "fwd", "forward", "up", "pos", "positive")},
                   **{w: "-1" for w in ("-1", "-", "bwd", "backward", "back", "down", "neg", "negative")}}
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
                _add_meta(meta, meta_lines, match, number, path, None)
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


def run_table(path: str | Path | Table) -> Table:
    """A run file in any accepted layout as the long table ``target_*,cycle,direction,value``.

    Long CSV, wide CSV (one column per cycle) or ``KEY=VALUE`` lines (``.dat``). Any other
    file comes back as read.

    Parameters
    ----------
    path : str, Path or Table
        The file, or a table read already.

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
        text = _read_text(path)
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
    :func:`volerr_pin.iso230.evaluate` groups them, to 1e-9 of their unit."""
    first: dict[tuple[float, int, int], int] = {}
    for r, key in enumerate(zip(np.round(target, 9).tolist(), cycle.astype(int).tolist(),
                                direction.astype(int).tolist())):
        if key in first:
            raise MeasurementError(
                f"{table.path}:{table.lines[r]}: target {key[0]:g} {unit}, cycle {key[1]}, direction "
                f"{key[2]:+d} is given twice (first on line {table.lines[first[key]]}); one approach per "
                "target, cycle and direction")
        first[key] = r


def axis_values(table: Table, key: str) -> dict[str, float]:
    """Axis positions of a header line, e.g. ``# at: Y=200, Z=150`` -> {"Y": 200.0, "Z": 150.0}.

    Parameters
    ----------
    table : Table
        The table.
    key : str
        The header key: "at", "centre", ...

    Returns
    -------
    dict of str to float
        Axis name -> position in file units (mm / deg); {} without the line.

    Raises
    ------
    MeasurementError
        If the line is not a list of ``AXIS=VALUE`` items.
    """
    text = table.meta.get(key)
    if not text:
        return {}
    return parse_axis_values(text, f"{table.path}: header '# {key}: {text}'", error=MeasurementError)


def read_any(path: str | Path, machine=None, axis: str | None = None):
    """Read a file of any kind, telling them apart by the header (the file is read once).

    Parameters
    ----------
    path : str or Path
        The file.
    machine : Machine, optional
        The machine; needed for point measurements and tracker files.
    axis : str, optional
        Moving axis of a run file (see :func:`read_runs`).

    Returns
    -------
    Runs, BallbarRun, TrackerMeasurements or PointMeasurements
        A run file, a ballbar file, a tracker file (only with ``machine``), or else point
        measurements.

    Raises
    ------
    MeasurementError
        If the file is malformed, or point measurements are read without ``machine``.
    """
    table = run_table(path)
    if is_run_file(table.header):
        return read_runs(table, axis)
    from .ballbar import is_ballbar_file, read_ballbar
    from .tracker import is_tracker_file, read_tracker

    if is_ballbar_file(table.header):
        return read_ballbar(table)
    if machine is not None and is_tracker_file(table.header):
        return read_tracker(table, machine)
    if machine is None:
        raise MeasurementError(f"{path}: point measurements need the machine (its axes and travels)")
    return read_points(table, machine)
