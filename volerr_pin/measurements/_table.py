"""The table every measurement file is read as, and its metadata (the one shared reader).

A measurement file is comma-separated with a header row; ``#`` comment lines are allowed,
and header comments before the header row carry metadata: ``# axis: X``, ``# at: Y=200,
Z=150``, ``# plane: X, Y``, ``# radius: 100``, ``# centre: X=250, Y=200``, ``# convention:``,
``# tool:``. Every error names file, line and column.

Values beyond the plausibility limits of :data:`volerr_pin.base.PLAUSIBLE` (a deviation of
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

from ..base import PLAUSIBLE, InputError, describe_range, parse_axis_values, parse_number, read_text, shown

__all__ = ["DIRECTION_WORDS", "META_RE", "MeasurementError", "Table", "add_meta", "axis_values", "read_file",
           "read_table"]

#: a metadata line before the header row: ``# key: value``
META_RE = re.compile(r"^#\s*(axis|at|plane|radius|centre|center|convention|tool)\s*:\s*(.*)$", re.IGNORECASE)
#: words for an approach direction, as instruments and loggers write them
DIRECTION_WORDS = {**{w: "1" for w in ("+1", "1", "+", "fwd", "forward", "up", "pos", "positive")},
                   **{w: "-1" for w in ("-1", "-", "bwd", "backward", "back", "down", "neg", "negative")}}


class MeasurementError(InputError):
    """A measurement file is malformed (the message names file, line and column).

    A subclass of :class:`~volerr_pin.base.InputError`; constructed like it.
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
            A key of :data:`volerr_pin.base.PLAUSIBLE` ("error_length", "time", ...): values
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
            A key of :data:`volerr_pin.base.PLAUSIBLE`.
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


def read_file(path: Path) -> str:
    """The text of a measurement file, read once and checked.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    str
        Its content.

    Raises
    ------
    MeasurementError
        If it is not a regular file, is larger than the free memory allows, or is not UTF-8.
    """
    return read_text(path, MeasurementError, "measurement file")


def add_meta(meta: dict, meta_lines: dict, match: re.Match, number: int, path, header_line: int | None) -> None:
    """Keep one ``# key: value`` line; refuse it given twice (``centre`` and ``center`` are one
    key) or after the header row, where it would silently not count.

    Parameters
    ----------
    meta : dict of str to str
        The metadata so far (updated).
    meta_lines : dict of str to int
        The line of each key so far (updated).
    match : re.Match
        The line matched by :data:`META_RE`.
    number : int
        Its line number.
    path : str or Path
        The file, for messages.
    header_line : int or None
        The header row's line when the header has been read already, else None.

    Raises
    ------
    MeasurementError
        If the key was given before, or the line comes after the header row.
    """
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
    text = read_file(path) if text is None else text
    header, header_line, rows, lines, meta = None, 0, [], [], {}
    meta_lines: dict[str, int] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            match = META_RE.match(stripped)
            if match:
                add_meta(meta, meta_lines, match, number, path, header_line if header is not None else None)
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

