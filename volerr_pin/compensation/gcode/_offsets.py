"""Work offsets: their names, the G10 blocks that set them, and the tables controllers keep.

A work offset is where the program's zero lies in axis coordinates (G54 ... G59, LinuxCNC's
G59.1 - G59.3, FANUC's additional ``G54.1 Pn``, Haas's ``G154 Pn`` and G110 - G129). A program
that switches between them (several set-ups in one program) is read with each one's values:
from the program's own G10 L2 / L20 blocks, or from a table the user gives, in one of three
forms:

- a CSV file: a column ``offset`` (``G54``, ``G55``, ``G54.1 P3``, ``EXT`` for FANUC's external
  offset) and one column per axis with its unit (``X_mm``, ``Y_in``, ``A_deg``);
- LinuxCNC's parameter file (``linuxcnc.var``: parameter 5221 is G54's X, 5222 its Y ... in
  steps of 20 for G55 ... G59.3), in the machine's length unit, which must be said;
- a FANUC offset listing (``G10 L2 Pn X... Y...`` blocks, as a FANUC control punches its work
  offsets), in the control's length unit, which must be said.

Values are kept in SI (m, rad) per machine axis.
"""

from __future__ import annotations

import csv
import io
import stat
import math
import re
from pathlib import Path

import numpy as np

from ...base import INCH, MM
from ._lexer import GcodeError, check_words, mask_comments, parse_block

__all__ = ["LINUXCNC_P", "MOST_TABLE_BYTES", "offset_name", "read_work_offsets", "g10_target"]

#: the largest offsets file read [bytes] (a table of a few hundred offsets is a few kB)
MOST_TABLE_BYTES = 1 << 20
#: LinuxCNC's coordinate systems by their P number (G10 L2 P1 is G54 ...)
LINUXCNC_P = {1: "G54", 2: "G55", 3: "G56", 4: "G57", 5: "G58", 6: "G59", 7: "G59.1", 8: "G59.2", 9: "G59.3"}
#: LinuxCNC's parameter of the first axis (X) of G54; then Y ... W, R; each system 20 on
_VAR_FIRST, _VAR_STEP, _VAR_AXES = 5221, 20, "XYZABCUVW"
#: the most additional offsets (FANUC G54.1 P1 - P300, Haas G154 P1 - P99)
MOST_EXTENDED = 300


def offset_name(g: float, words: list[tuple[str, float]], extended: str = "G54.1") -> str:
    """The name of the work offset a G code selects (``"G55"``, ``"G54.1 P3"``, ``"G154 P2"``).

    Parameters
    ----------
    g : float
        The code (54 ... 59, 59.1 ... 59.3, 54.1, 154, 110 ... 129).
    words : list of (str, float)
        The block's words (the P of G54.1 / G154).
    extended : str
        The dialect's code of additional offsets (``"G54.1"`` or ``"G154"``).

    Returns
    -------
    str
        The name; Haas's G110 - G129 are ``G154 P1`` - ``G154 P20``.
    """
    if 110 <= g <= 129 and g == int(g):
        return f"G154 P{int(g) - 109}"
    if g in (54.1, 154):
        p = [v for letter, v in words if letter == "P"]
        return f"G{g:g} P{p[0]:g}" if p else f"G{g:g} P1"   # (FANUC: G54.1 alone is G54.1 P1)
    return f"G{g:g}"


def g10_target(l_value: float, p: float | None, dialect) -> str | None:
    """The work offset a G10 L2 / L20 block sets (``"current"`` for the one in force, ``"EXT"``
    for FANUC's external offset), or None if the dialect gives it no meaning the reader follows.

    Parameters
    ----------
    l_value : float
        The L word (2 or 20).
    p : float or None
        The P word.
    dialect : Dialect
        The program's dialect.

    Returns
    -------
    str or None
        The offset's name.
    """
    if p is None or p != int(p) or p < 0:
        return None
    p = int(p)
    if l_value == 20 and dialect.l20_extended:
        return f"{dialect.extended_offset} P{p}" if 1 <= p <= MOST_EXTENDED else None
    if p == 0:
        return {"current": "current", "external": "EXT"}.get(dialect.offset_p0)
    if dialect.linuxcnc_modes:
        return LINUXCNC_P.get(p)
    return f"G{53 + p}" if p <= 6 else None


_CSV_COLUMN = re.compile(r"^\s*([A-Za-z])[ _\[(]*(mm|in|inch|deg)[\])]*\s*$", re.IGNORECASE)
_UNITS = {"mm": MM, "in": INCH, "inch": INCH}


def _canonical(name: str, where: str) -> str:
    text = " ".join(name.upper().split())
    m = re.fullmatch(r"G(54|55|56|57|58|59|59\.[123]|5[0-9][0-9])|G(54\.1|154) ?P([0-9]{1,3})|G(1[12][0-9])|EXT", text)
    if not m:
        raise GcodeError(f"{where}: {name!r} is not a work offset (G54 ... G59, G59.1 ... G59.3, G54.1 Pn, G154 Pn, "
                         "G110 ... G129, SINUMERIK's G500 - G599, EXT)")
    if m.group(4):
        return offset_name(float(m.group(4)), [])
    if m.group(2):
        return f"G{m.group(2)} P{int(m.group(3))}"
    return text


def read_work_offsets(path, axes: list[str], kinds: list[str], unit: str | None = None) -> dict[str, np.ndarray]:
    """Read a work-offset table (CSV, LinuxCNC parameter file or FANUC listing; see the module).

    Parameters
    ----------
    path : str or Path
        The file (at most :data:`MOST_TABLE_BYTES`).
    axes : list of str
        The machine's axes.
    kinds : list of str
        Their kinds (``"linear"``, ``"rotary"``).
    unit : str, optional
        ``"mm"`` or ``"inch"``: the length unit of a LinuxCNC parameter file or a FANUC listing
        (a CSV says its units in its header).

    Returns
    -------
    dict of str to numpy.ndarray
        Each offset's values [m, rad] per machine axis (``"EXT"``: FANUC's external offset).

    Raises
    ------
    GcodeError
        Naming the file and line: a file too large or not text, a row without a value for an
        axis of the machine, a value that is not a finite number, an unknown offset, an offset
        given twice, a missing ``unit`` where the file does not say it.
    """
    path = Path(path)
    where = str(path)
    try:
        info = path.stat()
    except OSError as err:
        raise GcodeError(f"{where}: cannot read the work-offset table: {err.strerror}",
                         parameters=("work_offsets",)) from None
    if not stat.S_ISREG(info.st_mode):
        raise GcodeError(f"{where}: not a regular file (a folder, device, pipe or socket); give a work-offset table",
                         parameters=("work_offsets",))
    size = info.st_size
    if size > MOST_TABLE_BYTES:
        raise GcodeError(f"{where}: {size:,} bytes, more than a work-offset table holds (at most "
                         f"{MOST_TABLE_BYTES:,})", parameters=("work_offsets",))
    try:
        text = path.read_bytes().decode("utf-8").removeprefix("\ufeff")   # (a byte order mark, as Excel writes)
    except UnicodeDecodeError as err:
        raise GcodeError(f"{where}: not UTF-8 text (byte {err.start})", parameters=("work_offsets",)) from None
    if unit is not None and unit not in ("mm", "inch"):
        raise GcodeError(f"work_offsets_unit must be 'mm' or 'inch', got {unit!r}", parameters=("work_offsets_unit",))
    lines = text.splitlines()
    content = [ln for ln in lines if ln.strip()]
    if not content:
        raise GcodeError(f"{where}: no work offsets in the file", parameters=("work_offsets",))
    if "," in content[0]:
        return _read_csv(text, where, axes, kinds)
    if all(re.fullmatch(r"\s*[0-9]+\s+\S+\s*", ln) for ln in content):
        return _read_var(lines, where, axes, kinds, _unit(unit, where, "a LinuxCNC parameter file"))
    return _read_fanuc(lines, where, axes, kinds, _unit(unit, where, "a FANUC offset listing"))


def _unit(unit: str | None, where: str, what: str) -> float:
    if unit is None:
        raise GcodeError(f"{where}: {what} does not say its length unit; give it (work_offsets_unit 'mm' or 'inch', "
                         "the controller's setting)", parameters=("work_offsets_unit",))
    return _UNITS[unit]


def _value(text: str, where: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v) or not re.fullmatch(r"\s*[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\s*", text):
        raise GcodeError(f"{where}: {text.strip()!r} is not a finite number", parameters=("work_offsets",))
    return v


def _put(table: dict, name: str, values: np.ndarray, where: str) -> None:
    if name in table:
        raise GcodeError(f"{where}: {name} is given twice", parameters=("work_offsets",))
    table[name] = values


def _read_csv(text: str, where: str, axes, kinds) -> dict[str, np.ndarray]:
    rows = list(csv.reader(io.StringIO(text)))
    header = [h.strip() for h in rows[0]]
    if not header or header[0].lower() != "offset":
        raise GcodeError(f"{where}:1: the first column must be 'offset' (then one per axis with its unit: X_mm, "
                         "A_deg ...)", parameters=("work_offsets",))
    columns: dict[str, tuple[int, float]] = {}
    for c, h in enumerate(header[1:], start=1):
        m = _CSV_COLUMN.match(h)
        if not m or m.group(1).upper() not in axes:
            raise GcodeError(f"{where}:1:{c + 1}: column {h!r} is not an axis of the machine ({', '.join(axes)}) with "
                             "its unit (X_mm, X_in, A_deg)", parameters=("work_offsets",))
        axis, u = m.group(1).upper(), m.group(2).lower()
        j = axes.index(axis)
        if (kinds[j] == "rotary") != (u == "deg"):
            raise GcodeError(f"{where}:1:{c + 1}: axis {axis} is {kinds[j]}: its unit is "
                             f"{'deg' if kinds[j] == 'rotary' else 'mm or in'}, not {u}", parameters=("work_offsets",))
        if axis in columns:
            raise GcodeError(f"{where}:1:{c + 1}: axis {axis} has two columns", parameters=("work_offsets",))
        columns[axis] = (c, math.pi / 180 if u == "deg" else _UNITS[u])
    missing = [a for a in axes if a not in columns]
    if missing:
        raise GcodeError(f"{where}:1: no column for axis {', '.join(missing)} (every axis of the machine has one)",
                         parameters=("work_offsets",))
    table: dict[str, np.ndarray] = {}
    for k, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise GcodeError(f"{where}:{k}: {len(row)} fields, the header has {len(header)}",
                             parameters=("work_offsets",))
        name = _canonical(row[0], f"{where}:{k}:1")
        values = np.array([_value(row[columns[a][0]], f"{where}:{k}:{columns[a][0] + 1}") * columns[a][1]
                           for a in axes])
        _put(table, name, values, f"{where}:{k}")
    return table


def _read_var(lines, where: str, axes, kinds, length: float) -> dict[str, np.ndarray]:
    params: dict[int, float] = {}
    for k, ln in enumerate(lines, start=1):
        if ln.strip():
            number, value = ln.split()
            params[int(number)] = _value(value, f"{where}:{k}")
    table: dict[str, np.ndarray] = {}
    for p, name in LINUXCNC_P.items():
        first = _VAR_FIRST + (p - 1) * _VAR_STEP
        numbers = [first + _VAR_AXES.index(a) for a in axes]
        if not any(n in params for n in numbers):
            continue
        absent = [a for a, n in zip(axes, numbers) if n not in params]
        if absent:
            raise GcodeError(f"{where}: {name}'s axis {', '.join(absent)} (parameter "
                             f"{', '.join(str(first + _VAR_AXES.index(a)) for a in absent)}) is not in the file",
                             parameters=("work_offsets",))
        rotation = params.get(first + len(_VAR_AXES), 0.0)
        if rotation:
            raise GcodeError(f"{where}: {name} is rotated by {rotation:g} deg (parameter {first + len(_VAR_AXES)}), "
                             "which the reader does not follow", parameters=("work_offsets",))
        table[name] = np.array([params[n] * (math.pi / 180 if kind == "rotary" else length)
                                for n, kind in zip(numbers, kinds)])
    if not table:
        raise GcodeError(f"{where}: no work offset parameters (5221 ... 5389) in the file", parameters=("work_offsets",))
    return table


def _read_fanuc(lines, where: str, axes, kinds, length: float) -> dict[str, np.ndarray]:
    from ._dialect import DIALECTS, check_points

    fanuc = DIALECTS["fanuc"]
    table: dict[str, np.ndarray] = {}
    for k, ln in enumerate(lines, start=1):
        code = mask_comments(ln, k, where)
        stripped = code.strip()
        if not stripped or stripped.startswith("%") or re.fullmatch(r"[O:][0-9]+", stripped):
            continue
        block = parse_block(ln, k, where, code)
        check_words(block, where)
        check_points(fanuc, block.words, "".join(axes), f"{where}:{k}")
        if any(w.letter == "G" and w.value == 91 for w in block.words):
            raise GcodeError(f"{where}:{k}: G91: a listing's offsets are absolute values; an increment is not read",
                             parameters=("work_offsets",))
        words = [(w.letter, w.value) for w in block.words if w.letter != "N"]
        ls = [v for letter, v in words if letter == "L"]
        ps = [v for letter, v in words if letter == "P"]
        if ("G", 10) not in words or not ls or ls[0] not in (2, 20):
            raise GcodeError(f"{where}:{k}: {stripped!r} is not a work offset (G10 L2 Pn or G10 L20 Pn with axis "
                             "words)", parameters=("work_offsets",))
        name = g10_target(ls[0], ps[0] if ps else None, fanuc)
        if name is None:
            raise GcodeError(f"{where}:{k}: G10 L{ls[0]:g} with P {ps[0] if ps else 'missing'} names no work offset",
                             parameters=("work_offsets",))
        values = {letter: v for letter, v in words if letter in axes}
        stray = [letter for letter, _ in words if letter not in axes and letter not in "GLP"]
        if stray:
            raise GcodeError(f"{where}:{k}: {stray[0]} is not an axis of the machine ({', '.join(axes)})",
                             parameters=("work_offsets",))
        absent = [a for a in axes if a not in values]
        if absent:
            raise GcodeError(f"{where}:{k}: {name} gives no value for axis {', '.join(absent)}",
                             parameters=("work_offsets",))
        _put(table, name, np.array([values[a] * (math.pi / 180 if kind == "rotary" else length)
                                    for a, kind in zip(axes, kinds)]), f"{where}:{k}")
    return table
