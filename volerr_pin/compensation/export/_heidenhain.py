"""HEIDENHAIN TNC nonlinear axis error compensation: ``.COM`` compensation-value tables and the
``.CMA`` assignment table (TNC 407/415/425 Technical Manual, "Non-linear axis error
compensation" and module 9095; MANUALplus 620 Technical Manual 6.10.3 "Nonlinear axis error
compensation": entering compensation values, assigning the tables to the axes).

- A ``.COM`` table holds compensation points (``AXISPOS``, mm or deg from the machine datum)
  of the axis it depends on, a column of values for each axis it compensates (named by the
  axis) and, optionally, ``BACKLASH``: the values measured in the negative direction of
  traverse. We give the ``BACKLASH`` column to the table's own axis (pitch error, moving -);
  the other columns apply in both directions.
- The ``.CMA`` table has a column per axis; an entry names the ``.COM`` table that depends on
  that axis ("[axis in column from .com] = F(axis in column from .cma)"); ``*`` in ``ACTIVE``
  activates the line. One table per axis and line.
- At most 256 entries per ``.COM`` table (module 9095, error 3); linear interpolation between
  points, read at the nominal position; we take the end values as held outside the table
  (the manuals found do not say; our tables span the zone).
- The sign: the TNC's axis error compensation takes the error, positive when the travel is
  too long (TNC 407 Technical Manual, "Linear axis-error compensation", MP720); the nonlinear
  tables enter the measured error curve the same way. **Values are errors** (actual minus
  nominal); the control subtracts them.

Values and positions are written to 0.0001 mm / 0.0001 deg, TNC table style (``BEGIN``
line, header, fixed columns, ``[END]``).
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ...base import DEG, MM, InputError
from ...model import Machine
from ._layouts import check_count, cross_table, fixed, linear_xyz, nc_axes, own_table
from ._protocol import ControllerFormat
from ._tables import SetpointTables, Table, quantised
from ._zone import Zone

__all__ = ["Heidenhain"]

CMA = "CONFIG.CMA"
MAX_ENTRIES = 256
DECIMALS = 4
UNITS = (1e-4 * MM, 1e-4 * DEG)


def com_name(axis: str) -> str:
    """The table that depends on ``axis``: ``<axis>.COM``."""
    return f"{axis}.COM"


#: which TNC generation the files are for (said in every report)
GENERATION = ("the .COM tables are in the AXISPOS column layout of the later controls (as the MANUALplus 620 "
              "manual enters them): the TNC 407/415/425 manual describes compensation points from a datum at a "
              "power-of-two spacing instead, which these files do not write")


class Heidenhain(ControllerFormat):
    """HEIDENHAIN TNC nonlinear axis error compensation (.COM tables, .CMA assignment).

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.export.ControllerFormat` (documented there)
    do here:

    - ``layout``: one table per axis with its own column and ``BACKLASH``; with ``cross`` also
      the other linear axes' columns in each linear axis' table.
    - ``quantise``: values rounded to 0.0001 mm / deg.
    - ``files``: ``<axis>.COM`` per axis and ``CONFIG.CMA``.
    - ``read``: the tables the active ``.CMA`` line assigns, read from their ``.COM`` files.
    """

    name = "heidenhain"
    title = "HEIDENHAIN TNC nonlinear axis error compensation (.COM / .CMA)"
    kinds = ("axis", "cross")
    convention = ("values are errors (actual minus nominal, positive when the travel is too long), mm or deg; "
                  "BACKLASH holds the table's own axis moving in the negative direction")
    manual = ("HEIDENHAIN TNC 407/415/425 Technical Manual: linear and non-linear axis-error compensation (MP720, "
              "MP730, .CMA/.COM, module 9095); MANUALplus 620 Technical Manual 6.10.3 Nonlinear axis error "
              "compensation")
    default_nodes = 41

    def layout(self, machine: Machine, zone: Zone, kind: str, nodes: int | None) -> SetpointTables:
        nc_axes(machine, self.title)
        count = check_count(self.default_nodes if nodes is None else int(nodes), 2, MAX_ENTRIES, "a .COM table")
        lin = linear_xyz(machine)
        tables = []
        for m in range(len(machine.axes)):
            tables.append(own_table(machine, zone, m, count, UNITS, directional=True))
            if kind == "cross" and m in lin:
                tables += [cross_table(machine, zone, s, m, count, UNITS) for s in lin if s != m]
        notes = [GENERATION]
        rotary = [a for a, k in zip(machine.axes, machine.axis_kinds) if k == "rotary"]
        if rotary:
            notes.append(f"rotary axes {', '.join(rotary)}: their entries follow the zone's angles (may be below 0 or "
                         "beyond 360 deg); the TNC 407/415/425 accepts rotary entries from 0 to 360 deg only")
        return SetpointTables(tuple(tables), len(machine.axes), notes, kind=kind)

    def quantise(self, compensation: SetpointTables, machine: Machine) -> SetpointTables:
        out = [t.with_values(quantised(t.values, UNITS[machine.axis_kinds[t.output] == "rotary"]))
               for t in compensation.tables]
        return SetpointTables(tuple(out), compensation.n_axes, compensation.notes, kind=compensation.kind)

    def files(self, compensation: SetpointTables, machine: Machine) -> dict[str, str]:
        groups: dict[int, list[Table]] = {}
        for t in compensation.tables:
            groups.setdefault(t.inputs[0], []).append(t)
        out = {}
        for m, group in groups.items():
            axis = machine.axes[m]
            columns = [machine.axes[t.output] for t in group]
            scale = lambda j: MM if machine.axis_kinds[j] == "linear" else DEG  # noqa: E731
            head = f"{'NR':>6}{'AXISPOS':>14}" + "".join(f"{c:>14}" for c in columns) + f"{'BACKLASH':>14}"
            rows = [f"BEGIN {com_name(axis)} MM", head]
            for i, x in enumerate(group[0].nodes[0]):
                cells = [fixed(x / scale(m), DECIMALS, plus=True)]
                for t in group:
                    v = t.values[0, i] if t.directional else t.values[i]
                    cells.append(fixed(-v / scale(t.output), DECIMALS, plus=True))
                cells.append(fixed(-group[0].values[1, i] / scale(m), DECIMALS, plus=True))
                rows.append(f"{i:>6}" + "".join(f"{c:>14}" for c in cells))
            rows.append("[END]")
            out[com_name(axis)] = "\n".join(rows) + "\n"
        axes = list(machine.axes)
        cma = [f"BEGIN {CMA}", f"{'NR':>6}" + "".join(f"{a:>10}" for a in axes) + f"{'ACTIVE':>8}",
               f"{0:>6}" + "".join(f"{com_name(a) if j in groups else '':>10}" for j, a in enumerate(axes))
               + f"{'*':>8}",
               "[END]"]
        out[CMA] = "\n".join(cma) + "\n"
        return out

    def read(self, texts: Mapping[str, str], machine: Machine) -> SetpointTables:
        if CMA not in texts:
            raise InputError(f"{CMA}: missing")
        header, rows = self._table(CMA, texts[CMA])
        active = [r for r in rows if r.get("ACTIVE") == "*"]
        if len(active) != 1:
            raise InputError(f"{CMA}: {len(active)} active lines; exactly one must be marked * in ACTIVE")
        unknown = [c for c in header if c not in machine.axes and c not in ("NR", "ACTIVE")]
        if unknown:
            raise InputError(f"{CMA}: column {unknown[0]} is not an axis of {machine.name}")
        tables, kinds = [], set()
        for m, axis in enumerate(machine.axes):
            name = active[0].get(axis, "")
            if not name:
                continue
            if name not in texts:
                raise InputError(f"{CMA}: table {name} of axis {axis} is not among the files")
            cols, entries = self._table(name, texts[name])
            if cols[:2] != ["NR", "AXISPOS"] or cols[-1] != "BACKLASH" or cols[2] != axis:
                raise InputError(f"{name}: columns must be NR, AXISPOS, {axis}, ..., BACKLASH")
            if not 2 <= len(entries) <= MAX_ENTRIES:
                raise InputError(f"{name}: {len(entries)} entries, outside 2..{MAX_ENTRIES}")
            number = lambda row, col: self._number(name, row, col)  # noqa: E731
            scale = lambda j: MM if machine.axis_kinds[j] == "linear" else DEG  # noqa: E731
            grid = np.array([number(r, "AXISPOS") for r in entries]) * scale(m)
            if np.any(np.diff(grid) <= 0):
                raise InputError(f"{name}: AXISPOS does not increase")
            for col in cols[2:-1]:
                if col not in machine.axes:
                    raise InputError(f"{name}: column {col} is not an axis of {machine.name}")
                j = machine.axes.index(col)
                values = -np.array([number(r, col) for r in entries]) * scale(j)
                if j == m:
                    back = -np.array([number(r, "BACKLASH") for r in entries]) * scale(j)
                    tables.append(Table(j, (m,), (grid,), np.stack([values, back]), directional=True,
                                        label=f"{col}({axis})"))
                else:
                    kinds.add("cross")
                    tables.append(Table(j, (m,), (grid,), values, label=f"{col}({axis})"))
        return SetpointTables(tuple(tables), len(machine.axes), kind="cross" if kinds else "axis")

    @staticmethod
    def _table(name: str, text: str) -> tuple[list[str], list[dict[str, str]]]:
        """Header and rows of a TNC table; cells are read by the header's column positions
        (right-aligned columns end where their title ends), so an empty cell stays empty."""
        lines = [line for line in text.splitlines() if line.strip()]
        if len(lines) < 3 or not re.fullmatch(rf"BEGIN\s+{re.escape(name)}(\s+MM)?", lines[0].strip()) \
                or lines[-1].strip() != "[END]":
            raise InputError(f"{name}:1: expected 'BEGIN {name}', a header, rows and '[END]'")
        header = lines[1].split()
        ends = [m.end() for m in re.finditer(r"\S+", lines[1])]
        starts = [0] + ends[:-1]
        rows = []
        for number, line in enumerate(lines[2:-1], 3):
            if len(line.rstrip()) > ends[-1]:
                raise InputError(f"{name}:{number}: cells beyond the last column")
            cells = [line[a:b].strip() for a, b in zip(starts, ends)]
            if cells[0] != str(len(rows)):
                raise InputError(f"{name}:{number}: NR {cells[0]!r} out of sequence")
            rows.append(dict(zip(header, cells)) | {"_line": str(number)})
        return header, rows

    @staticmethod
    def _number(name: str, row: dict[str, str], column: str) -> float:
        text = row[column]
        if not re.fullmatch(r"[+-]?(?:\d+\.?\d*|\.\d+)", text):
            raise InputError(f"{name}:{row['_line']}: {column} {text!r} is not a number")
        return float(text)
