"""Beckhoff TwinCAT CNC / ISG kernel: axis compensation lists and TF5280 Volumetric
Compensation.

Axis compensation lists (TF5200 "Axis compensation" and its parameter reference
P-COMP-xxxxx; TX1270 "Axis Compensation"), one list per axis, ``name value`` lines and
``#`` comments:

- leadscrew error compensation ``kw.ssfk.*`` (P-COMP-00017..00025): bilateral
  (``table[i].pos`` moving +, ``table[i].neg`` moving -), interpolation points
  ``table[i].setpoint`` (``interval 0``), ``unit 1``: lengths in 0.1 um, rotary in 0.0001 deg,
  integers. The values are **absolute position errors, actual minus set point** (the manual's
  example computes ``s_ist - s_soll``); the kernel subtracts them from the set-point. Linear
  between points, read at the set-point, end values held outside the table ("the value at the
  relevant end of the table is reused"); at most ``kw.ssfk.max_points`` entries (default 1500);
- cross compensation ``kw.crosscomp.*`` (P-COMP-00003..00007, P-COMP-00060): the slave
  axis' list names one master (``master_ax_nr``) whose command position the table reads;
  setpoints ascending (error 70245), at most 1000 values, valid for both directions;
- plane compensation ``kw.crosscomp2.*`` (P-COMP-00008..00016): the slave corrected over two
  masters on a square grid (``interval``, ``start_position_master1/2``,
  ``last_index_master1/2``, ``table[j][i].correction`` with j along master 2), linear between
  points, the margin values outside.

The manual calls the cross and plane values "relative compensation values" without saying
whether the kernel adds or subtracts them; we write them in the same sense as the leadscrew
table, as errors (actual minus set point), and say so in every file: check the sign with one
test move before relying on them. Values are refused beyond a signed 16-bit integer
(+-3.2767 mm), the range of the TX1270 lists (TF5200 lists take 32 bits).

Volumetric compensation: :mod:`volerr_pin.compensation.export`.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ...base import DEG, UM, InputError
from ...model import Machine
from ._isg_volumetric import CONFIG, model_of, quantise_model, read_volumetric, volumetric_files
from ._layouts import best_masters, check_count, cross_table, linear_xyz, nc_axes, own_table, plane_table
from ._protocol import Compensation, ControllerFormat
from ._tables import SetpointTables, Table, quantised
from ._zone import Zone

__all__ = ["ISG"]

#: position and value unit of the lists: 0.1 um (linear), 0.0001 deg (rotary)
UNITS = (0.1 * UM, 1e-4 * DEG)
VALUE_LIMIT = 32767
LIMITS = {"ssfk": 1499, "crosscomp": 1000, "crosscomp2": 2500}
#: ``kw.crosscomp2.max_points`` (P-COMP-00061), written fixed: the manual's default, 101 x 101. The
#: kernel reserves the table's memory at start-up and refuses another value on reloading the
#: lists ("can no longer be changed after start-up or after lists are reloaded", error 110640): a
#: re-export with another grid must load without a restart, so the value never follows the grid
PLANE_MAX_POINTS = 10201
LINE_RE = re.compile(r"^\s*(?P<key>[a-z_0-9.\[\]]+)\s+(?P<value>\S+)\s*$", re.IGNORECASE)


def list_name(machine: Machine, j: int) -> str:
    """The compensation list of axis ``j``: ``achskw_<axis>.lis``."""
    return f"achskw_{machine.axes[j]}.lis"


def _unit(machine: Machine, j: int) -> float:
    return UNITS[machine.axis_kinds[j] == "rotary"]


class ISG(ControllerFormat):
    """Beckhoff TwinCAT CNC / ISG kernel: axis compensation lists or TF5280 volumetric files.

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.export.ControllerFormat` (documented there)
    do here:

    - ``layout``: the tables of ``kind``: ``ssfk`` (bilateral per axis), ``crosscomp`` (plus
      each linear axis corrected over the one other linear axis that explains most of its error),
      ``crosscomp2`` (plus each linear axis corrected over the plane of the other two) or
      ``volumetric`` (the TF5280 model).
    - ``quantise``: values rounded to 0.1 um / 0.0001 deg (the model's to the CSV digits).
    - ``files``: one list per axis (``achskw_<axis>.lis``), or the three TF5280 files.
    - ``read``: tables or model from the files, checked by the kernel's rules.
    """

    name = "isg"
    title = "Beckhoff TwinCAT CNC / ISG kernel"
    kinds = ("ssfk", "crosscomp", "crosscomp2", "volumetric")
    convention = ("axis lists hold errors (actual minus set point) in 0.1 um / 0.0001 deg, subtracted by the kernel; "
                  "TF5280 files hold ISO 230-1 error parameters in mm and rad, from which the kernel computes its "
                  "correction")
    manual = ("Beckhoff TF5200 TwinCAT 3 CNC Axis compensation (leadscrew, cross and plane compensation; "
              "P-COMP-00003..00025, P-COMP-00059..00061); TF5280 Volumetric Compensation (General configuration, "
              "ISG CSV format, Units of measure, List of parameters supported); TF5200 P-VOLC-00001..00014")
    default_nodes = {"ssfk": 41, "crosscomp": 41, "crosscomp2": 17, "volumetric": 41}

    def layout(self, machine: Machine, zone: Zone, kind: str, nodes: int | None) -> Compensation:
        count = self.default_nodes[kind] if nodes is None else int(nodes)
        if kind == "volumetric":
            return model_of(machine, zone, count)
        nc_axes(machine, self.title)
        tables: list[Table] = []
        notes: list[str] = []
        check_count(count, 2, LIMITS["ssfk"], "a leadscrew table (kw.ssfk)")
        for j in range(len(machine.axes)):
            tables.append(own_table(machine, zone, j, count, UNITS, directional=True))
        lin = linear_xyz(machine)
        if kind == "crosscomp":
            check_count(count, 2, LIMITS["crosscomp"], "a cross compensation table (kw.crosscomp)")
            for slave, master in best_masters(machine, zone, lin, lin).items():
                tables.append(cross_table(machine, zone, slave, master, count, UNITS))
                notes.append(f"{machine.axes[slave]} corrected over {machine.axes[master]} (one master per slave)")
        elif kind == "crosscomp2" and len(lin) == 3:
            for slave in lin:
                masters = tuple(m for m in lin if m != slave)
                table = plane_table(machine, zone, slave, masters, count, UNITS[0])
                if table.values.size > LIMITS["crosscomp2"]:
                    raise InputError(f"nodes: a plane table of {table.values.size} points exceeds the "
                                     f"{LIMITS['crosscomp2']} this export keeps to", parameters=("nodes",))
                tables.append(table)
        tables.sort(key=lambda t: t.output)              # list by list, as read back
        return SetpointTables(tuple(tables), len(machine.axes), tuple(notes), kind=kind)

    def quantise(self, compensation: Compensation, machine: Machine) -> Compensation:
        if compensation.kind == "volumetric":
            return quantise_model(compensation)
        out = []
        for t in compensation.tables:
            unit = _unit(machine, t.output)
            values = quantised(t.values, unit)
            if np.abs(values).max(initial=0.0) > VALUE_LIMIT * unit:
                raise InputError(f"{list_name(machine, t.output)}: table {t.label} needs "
                                 f"{np.abs(values).max() / unit:.0f} units, beyond the lists' {VALUE_LIMIT}")
            out.append(t.with_values(values))
        return SetpointTables(tuple(out), compensation.n_axes, compensation.notes, kind=compensation.kind)

    def files(self, compensation: Compensation, machine: Machine) -> dict[str, str]:
        if compensation.kind == "volumetric":
            return volumetric_files(compensation, machine)
        lists: dict[int, list[str]] = {}
        for t in compensation.tables:
            body = lists.setdefault(t.output, self._head(machine, t.output))
            unit = _unit(machine, t.output)
            if t.directional:
                body += self._ssfk(machine, t, unit)
            elif len(t.inputs) == 1:
                body += self._cross(machine, t, unit)
            else:
                body += self._plane(machine, t, unit)
        return {list_name(machine, j): "\n".join(lines) + "\n" for j, lines in sorted(lists.items())}

    @staticmethod
    def _head(machine: Machine, j: int) -> list[str]:
        return [f"# volerr_pin: axis compensation list of axis {machine.axes[j]} ({machine.name})",
                "# values are position ERRORS (actual minus set point) in 0.1 um (linear) or 0.0001 deg (rotary);",
                "# the kernel subtracts them. Leadscrew (kw.ssfk) needs lr_param.ssfk 1, cross compensation",
                "# lr_param.crosscomp 1, plane compensation lr_param.crosscomp2 1 in the axis parameter list.",
                f"kopf.achs_nr {j + 1}", f"kopf.log_achs_name {machine.axes[j]}"]

    @staticmethod
    def _ssfk(machine: Machine, t: Table, unit: float) -> list[str]:
        ints = np.rint(t.nodes[0] / UNITS[machine.axis_kinds[t.inputs[0]] == "rotary"]).astype(int)
        errors = np.rint(-t.values / unit).astype(int)
        lines = ["# leadscrew error compensation, bilateral: pos while moving +, neg while moving -",
                 "kw.ssfk.unit 1", "kw.ssfk.interval 0", f"kw.ssfk.kw_startpos {ints[0]}",
                 f"kw.ssfk.kw_nr_max {len(ints)}", "kw.ssfk.bilateral 1", "kw.ssfk.modulo 0"]
        lines += [f"kw.ssfk.table[{i}].setpoint {v}" for i, v in enumerate(ints)]
        lines += [f"kw.ssfk.table[{i}].pos {v}" for i, v in enumerate(errors[0])]
        lines += [f"kw.ssfk.table[{i}].neg {v}" for i, v in enumerate(errors[1])]
        return lines

    @staticmethod
    def _cross(machine: Machine, t: Table, unit: float) -> list[str]:
        m = t.inputs[0]
        ints = np.rint(t.nodes[0] / UNITS[machine.axis_kinds[m] == "rotary"]).astype(int)
        errors = np.rint(-t.values / unit).astype(int)
        lines = [f"# cross compensation: {machine.axes[t.output]} over the command position of {machine.axes[m]}",
                 "kw.crosscomp.unit 1", f"kw.crosscomp.last_index {len(ints) - 1}",
                 f"kw.crosscomp.master_ax_nr {m + 1}"]
        lines += [f"kw.crosscomp.table[{i}].setpoint {v}" for i, v in enumerate(ints)]
        lines += [f"kw.crosscomp.table[{i}].correction {v}" for i, v in enumerate(errors)]
        return lines

    @staticmethod
    def _plane(machine: Machine, t: Table, unit: float) -> list[str]:
        (m1, m2), (g1, g2) = t.inputs, t.nodes
        spacing = int(round((g1[1] - g1[0]) / UNITS[0]))
        errors = np.rint(-t.values / unit).astype(int)
        lines = [f"# plane compensation: {machine.axes[t.output]} over {machine.axes[m1]} (master 1) and "
                 f"{machine.axes[m2]} (master 2); table[j][i]: j along master 2",
                 "# max_points: the manual's default, the same in every export (fixed at start-up, error 110640)",
                 "kw.crosscomp2.unit 1", f"kw.crosscomp2.max_points {PLANE_MAX_POINTS}",
                 f"kw.crosscomp2.interval {spacing}",
                 f"kw.crosscomp2.last_index_master1 {len(g1) - 1}", f"kw.crosscomp2.last_index_master2 {len(g2) - 1}",
                 f"kw.crosscomp2.start_position_master1 {int(round(g1[0] / UNITS[0]))}",
                 f"kw.crosscomp2.start_position_master2 {int(round(g2[0] / UNITS[0]))}",
                 f"kw.crosscomp2.master1_ax_nr {m1 + 1}", f"kw.crosscomp2.master2_ax_nr {m2 + 1}"]
        lines += [f"kw.crosscomp2.table[{j}][{i}].correction {errors[i, j]}"
                  for j in range(len(g2)) for i in range(len(g1))]
        return lines

    # ------------------------------------------------------------------ reading
    def read(self, texts: Mapping[str, str], machine: Machine) -> Compensation:
        if CONFIG in texts:
            return read_volumetric(texts, machine)
        tables, kinds = [], set()
        for j in range(len(machine.axes)):
            name = list_name(machine, j)
            if name in texts:
                found = self._read_list(name, texts[name], machine, j)
                tables += found
                kinds.update("ssfk" if t.directional else "crosscomp" if len(t.inputs) == 1 else "crosscomp2"
                             for t in found)
        kind = "crosscomp2" if "crosscomp2" in kinds else "crosscomp" if "crosscomp" in kinds else "ssfk"
        return SetpointTables(tuple(tables), len(machine.axes), kind=kind)

    def _read_list(self, name: str, text: str, machine: Machine, j: int) -> list[Table]:
        entries: dict[str, tuple[int, str]] = {}
        for number, line in enumerate(text.splitlines(), 1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            m = LINE_RE.match(line)
            if m is None:
                raise InputError(f"{name}:{number}: not a 'name value' line")
            if m["key"] in entries:
                raise InputError(f"{name}:{number}: {m['key']} given twice")
            entries[m["key"]] = (number, m["value"])

        def integer(key: str) -> int:
            if key not in entries:
                raise InputError(f"{name}: {key} missing")
            number, value = entries.pop(key)
            if not re.fullmatch(r"[+-]?\d+", value):
                raise InputError(f"{name}:{number}: {key} must be an integer, got {value!r}")
            return int(value)

        def text_value(key: str) -> str:
            if key not in entries:
                raise InputError(f"{name}: {key} missing")
            return entries.pop(key)[1]

        if integer("kopf.achs_nr") != j + 1 or text_value("kopf.log_achs_name") != machine.axes[j]:
            raise InputError(f"{name}: kopf.achs_nr / kopf.log_achs_name do not name axis {machine.axes[j]} ({j + 1})")
        unit = _unit(machine, j)
        tables = []
        if "kw.ssfk.kw_nr_max" in entries:
            for key, want in (("kw.ssfk.unit", 1), ("kw.ssfk.interval", 0), ("kw.ssfk.bilateral", 1),
                              ("kw.ssfk.modulo", 0)):
                if integer(key) != want:
                    raise InputError(f"{name}: {key} must be {want}")
            n = integer("kw.ssfk.kw_nr_max")
            if not 2 <= n <= LIMITS["ssfk"]:
                raise InputError(f"{name}: kw.ssfk.kw_nr_max {n} outside 2..{LIMITS['ssfk']}")
            start = integer("kw.ssfk.kw_startpos")
            setpoints = self._ascending(name, [integer(f"kw.ssfk.table[{i}].setpoint") for i in range(n)])
            if setpoints[0] != start:
                raise InputError(f"{name}: kw.ssfk.kw_startpos {start} is not the first setpoint {setpoints[0]}")
            pos = [self._value(name, integer(f"kw.ssfk.table[{i}].pos")) for i in range(n)]
            neg = [self._value(name, integer(f"kw.ssfk.table[{i}].neg")) for i in range(n)]
            grid = np.array(setpoints) * _unit(machine, j)
            tables.append(Table(j, (j,), (grid,), -np.array([pos, neg]) * unit, directional=True,
                                label=f"{machine.axes[j]}({machine.axes[j]})"))
        if "kw.crosscomp.last_index" in entries:
            if integer("kw.crosscomp.unit") != 1:
                raise InputError(f"{name}: kw.crosscomp.unit must be 1")
            n = integer("kw.crosscomp.last_index") + 1
            if not 2 <= n <= LIMITS["crosscomp"]:
                raise InputError(f"{name}: kw.crosscomp.last_index {n - 1} outside 1..{LIMITS['crosscomp'] - 1}")
            m = integer("kw.crosscomp.master_ax_nr") - 1
            if not 0 <= m < len(machine.axes) or m == j:
                raise InputError(f"{name}: kw.crosscomp.master_ax_nr {m + 1} is not another axis")
            setpoints = self._ascending(name, [integer(f"kw.crosscomp.table[{i}].setpoint") for i in range(n)])
            values = [self._value(name, integer(f"kw.crosscomp.table[{i}].correction")) for i in range(n)]
            tables.append(Table(j, (m,), (np.array(setpoints) * _unit(machine, m),), -np.array(values) * unit,
                                label=f"{machine.axes[j]}({machine.axes[m]})"))
        if "kw.crosscomp2.interval" in entries:
            if integer("kw.crosscomp2.unit") != 1:
                raise InputError(f"{name}: kw.crosscomp2.unit must be 1")
            spacing = integer("kw.crosscomp2.interval")
            n1, n2 = integer("kw.crosscomp2.last_index_master1") + 1, integer("kw.crosscomp2.last_index_master2") + 1
            if spacing <= 0 or n1 < 2 or n2 < 2 or n1 * n2 > integer("kw.crosscomp2.max_points"):
                raise InputError(f"{name}: plane table of {n1} x {n2} points, interval {spacing}: not a valid grid")
            s1, s2 = integer("kw.crosscomp2.start_position_master1"), integer("kw.crosscomp2.start_position_master2")
            m1, m2 = integer("kw.crosscomp2.master1_ax_nr") - 1, integer("kw.crosscomp2.master2_ax_nr") - 1
            values = np.array([[self._value(name, integer(f"kw.crosscomp2.table[{b}][{a}].correction"))
                                for b in range(n2)] for a in range(n1)])
            grids = ((s1 + spacing * np.arange(n1)) * UNITS[0], (s2 + spacing * np.arange(n2)) * UNITS[0])
            tables.append(Table(j, (m1, m2), grids, -values * unit,
                                label=f"{machine.axes[j]}({machine.axes[m1]},{machine.axes[m2]})"))
        if entries:
            key, (number, _) = next(iter(entries.items()))
            raise InputError(f"{name}:{number}: unknown or unused entry {key}")
        return tables

    @staticmethod
    def _ascending(name: str, values: list[int]) -> list[int]:
        for i in range(1, len(values)):
            if values[i] <= values[i - 1]:
                raise InputError(f"{name}: setpoint {i} ({values[i]}) does not ascend (kernel error 70245)")
        return values

    @staticmethod
    def _value(name: str, value: int) -> int:
        if abs(value) > VALUE_LIMIT:
            raise InputError(f"{name}: value {value} beyond +-{VALUE_LIMIT}")
        return value
