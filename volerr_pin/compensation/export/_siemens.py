"""SINUMERIK 840D sl interpolatory compensation, as .INI part programs (Function Manual
"Extended Functions", K3 Compensation, section "Interpolatory compensation": "Measuring system
error compensation (MSEC)", "Compensation of sag and angularity errors", examples; edition
03/2013, 6FC5397-1BP40-3BA1).

- LEC (``%_N_AX_EEC_INI``): ``$AA_ENC_COMP[0,N,AXi]`` compensation values at interpolation
  points N, ``$AA_ENC_COMP_STEP``, ``_MIN``, ``_MAX`` (mm or deg), ``_IS_MODULO 0``; one table
  per machine axis, both directions alike. "A positive compensation value causes the
  corresponding machine axis to move in the negative direction": **the values are errors**
  (actual minus nominal). The first and last values "remain active over the entire
  traversing range". Points per axis: MD38000 ``$MA_MM_ENC_COMP_MAX_POINTS`` must be at least
  the table's.
- CEC (``%_N_NC_CEC_INI``): ``$AN_CEC[t,N]``, ``_INPUT_AXIS[t]`` (the base axis whose
  *programmed set-point* is read), ``_OUTPUT_AXIS[t]``, ``_STEP``, ``_MIN``, ``_MAX``,
  ``_DIRECTION[t]`` (0 both, 1 only while the base axis moves +, -1 only while it moves -),
  ``_MULT_BY_TABLE 0``, ``_IS_MODULO 0``. Direction-dependent compensation is two tables of one
  axis with ``_DIRECTION`` 1 and -1. The manual states the sign only for MSEC; CEC values are
  written in the same sense (errors), as parts of the same interpolatory compensation: check
  with one test move. Table sizes are machine data (MD18342 ``$MN_MM_CEC_MAX_POINTS[t]``); we
  keep within the 828D's fixed eight tables of 200 points (K3, example of direction-dependent
  tables) so the files load on either, unless told otherwise.

Machine axes are named ``AX1``, ``AX2``, ... in the machine's axis order. Positions and values
go through the control's internal resolution (MD10200 ``INT_INCR_PER_MM``, MD10210
``INT_INCR_PER_DEG``; default 1000 per mm and per degree): values are rounded to it, and the
node spacing is a whole number of increments.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ...base import DEG, MM, InputError
from ...model import Machine
from ._layouts import check_count, cross_table, explained_scores, fixed, linear_xyz, nc_axes, own_table
from ._protocol import ControllerFormat
from ._tables import SetpointTables, Table, quantised
from ._zone import Zone

__all__ = ["Siemens840D"]

LEC_FILE, CEC_FILE = "AX_EEC.INI", "NC_CEC.INI"
ASSIGN_RE = re.compile(r"^\s*\$(?P<name>A[AN]_[A-Z_]+)\[(?P<index>[^\]]*)\]\s*=\s*(?P<value>[^;\s]+)\s*(;.*)?$")


class Siemens840D(ControllerFormat):
    """SINUMERIK 840D sl: LEC tables per axis, CEC sag / angularity and direction tables.

    Parameters
    ----------
    increments_per_mm : int, default 1000
        MD10200 ``$MN_INT_INCR_PER_MM``: values and node positions of linear axes are whole
        multiples of 1 / this mm.
    increments_per_deg : int, default 1000
        MD10210 ``$MN_INT_INCR_PER_DEG``, likewise for rotary axes.
    max_points : int, default 200
        Points per CEC table (MD18342); LEC tables take up to 1000 (MD38000).
    max_tables : int, default 8
        CEC tables in all.

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.export.ControllerFormat` (documented there)
    do here:

    - ``layout``: LEC tables for every axis; with ``cec`` also the linear axes corrected over
      each other (the pairs that explain most of the error first, up to the table limit) and, on a
      machine with direction-dependent errors, a pair of one-way tables per axis.
    - ``quantise``: values rounded to the internal resolution.
    - ``files``: ``AX_EEC.INI`` (LEC) and, with CEC tables, ``NC_CEC.INI``.
    - ``read``: the tables the .INI programs assign, checked as the control checks them.
    """

    name = "siemens-840d"
    title = "SINUMERIK 840D sl interpolatory compensation (LEC, CEC)"
    kinds = ("lec", "cec")
    convention = ("values are errors (actual minus nominal; a positive value moves the axis negative), mm or deg, "
                  "rounded to the control's internal resolution")
    manual = ("SINUMERIK 840D sl Function Manual Extended Functions, K3 Compensation: Interpolatory compensation "
              "(MSEC, sag and angularity compensation, direction-dependent tables, examples)")
    default_nodes = 41
    lec_points = 1000

    def __init__(self, increments_per_mm: int = 1000, increments_per_deg: int = 1000, max_points: int = 200,
                 max_tables: int = 8):
        self.units = (MM / increments_per_mm, DEG / increments_per_deg)
        self.decimals = (len(str(increments_per_mm)) - 1, len(str(increments_per_deg)) - 1)
        self.max_points, self.max_tables = int(max_points), int(max_tables)

    def _unit(self, machine: Machine, j: int) -> float:
        return self.units[machine.axis_kinds[j] == "rotary"]

    def layout(self, machine: Machine, zone: Zone, kind: str, nodes: int | None) -> SetpointTables:
        nc_axes(machine, self.title)
        count = self.default_nodes if nodes is None else int(nodes)
        check_count(count, 2, self.lec_points, "a LEC table (MD38000)")
        tables = [own_table(machine, zone, j, count, self.units) for j in range(len(machine.axes))]
        notes = []
        if kind == "cec":
            check_count(count, 2, self.max_points, "a CEC table (MD18342)")
            cec = []
            if "directions" in machine.covariates_used:
                for j in range(len(machine.axes)):
                    cec += [own_table(machine, zone, j, count, self.units, only=+1),
                            own_table(machine, zone, j, count, self.units, only=-1)]
            lin = linear_xyz(machine)
            scores = explained_scores(machine, zone, lin, lin)
            ranked = sorted(((score, s, m) for (s, m), score in scores.items()), reverse=True)
            for _, s, m in ranked:
                if len(cec) < self.max_tables:
                    cec.append(cross_table(machine, zone, s, m, count, self.units))
                else:
                    notes.append(f"no room for {machine.axes[s]}({machine.axes[m]}) within "
                                 f"{self.max_tables} CEC tables")
            tables += cec[:self.max_tables]
        return SetpointTables(tuple(tables), len(machine.axes), tuple(notes), kind=kind)

    def quantise(self, compensation: SetpointTables, machine: Machine) -> SetpointTables:
        out = [t.with_values(quantised(t.values, self._unit(machine, t.output))) for t in compensation.tables]
        return SetpointTables(tuple(out), compensation.n_axes, compensation.notes, kind=compensation.kind)

    def _number(self, value: float, machine: Machine, j: int) -> str:
        unit = self._unit(machine, j)
        decimals = self.decimals[machine.axis_kinds[j] == "rotary"]
        scale = MM if machine.axis_kinds[j] == "linear" else DEG
        return fixed(round(value / unit) * unit / scale, decimals)

    def files(self, compensation: SetpointTables, machine: Machine) -> dict[str, str]:
        lec = ["%_N_AX_EEC_INI", "CHANDATA(1)",
               f"; volerr_pin: leadscrew error compensation (LEC) of {machine.name}; values are ERRORS, mm or deg:",
               "; a positive value moves the axis negative. Machine axis AXn is the machine's n-th axis:",
               "; " + ", ".join(f"AX{j + 1} = {a}" for j, a in enumerate(machine.axes))]
        cec = ["%_N_NC_CEC_INI", "CHANDATA(1)",
               f"; volerr_pin: sag / angularity and direction-dependent compensation (CEC) of {machine.name};",
               "; values are ERRORS in the sense of LEC (mm or deg), read at the base axis' set-point"]
        t_index = 0
        for t in compensation.tables:
            j, m = t.output, t.inputs[0]
            grid = t.nodes[0]
            step = self._number(grid[1] - grid[0], machine, m)
            if len(t.inputs) == 1 and m == j and not t.only:
                ax = f"AX{j + 1}"
                lec += [f"$AA_ENC_COMP[0,{i},{ax}]={self._number(-v, machine, j)}" for i, v in enumerate(t.values)]
                lec += [f"$AA_ENC_COMP_STEP[0,{ax}]={step}",
                        f"$AA_ENC_COMP_MIN[0,{ax}]={self._number(grid[0], machine, m)}",
                        f"$AA_ENC_COMP_MAX[0,{ax}]={self._number(grid[-1], machine, m)}",
                        f"$AA_ENC_COMP_IS_MODULO[0,{ax}]=0"]
                continue
            cec.append(f"; table {t_index}: {t.label}")
            cec += [f"$AN_CEC[{t_index},{i}]={self._number(-v, machine, j)}" for i, v in enumerate(t.values)]
            cec += [f"$AN_CEC_INPUT_AXIS[{t_index}]=(AX{m + 1})", f"$AN_CEC_OUTPUT_AXIS[{t_index}]=(AX{j + 1})",
                    f"$AN_CEC_STEP[{t_index}]={step}", f"$AN_CEC_MIN[{t_index}]={self._number(grid[0], machine, m)}",
                    f"$AN_CEC_MAX[{t_index}]={self._number(grid[-1], machine, m)}",
                    f"$AN_CEC_DIRECTION[{t_index}]={t.only}", f"$AN_CEC_MULT_BY_TABLE[{t_index}]=0",
                    f"$AN_CEC_IS_MODULO[{t_index}]=0"]
            t_index += 1
        out = {LEC_FILE: "\n".join(lec + ["M17"]) + "\n"}
        if t_index:
            cec.insert(4, "; MD18342 $MN_MM_CEC_MAX_POINTS[t] must be at least: "
                       + ", ".join(f"[{k}] {len(t.nodes[0])}" for k, t in enumerate(
                           [t for t in compensation.tables if t.only or t.inputs[0] != t.output])))
            out[CEC_FILE] = "\n".join(cec + ["M17"]) + "\n"
        return out

    # ------------------------------------------------------------------ reading
    def read(self, texts: Mapping[str, str], machine: Machine) -> SetpointTables:
        if LEC_FILE not in texts:
            raise InputError(f"{LEC_FILE}: missing")
        lec = self._assignments(LEC_FILE, texts[LEC_FILE], "%_N_AX_EEC_INI")
        tables = []
        for j, axis in enumerate(machine.axes):
            ax = f"AX{j + 1}"
            values = self._series(LEC_FILE, lec, "AA_ENC_COMP", lambda i: f"0,{i},{ax}", self.lec_points)
            grid = self._grid(LEC_FILE, lec, "AA_ENC_COMP", f"0,{ax}", len(values), machine, j)
            if lec.pop(("AA_ENC_COMP_IS_MODULO", f"0,{ax}"), None) != "0":
                raise InputError(f"{LEC_FILE}: $AA_ENC_COMP_IS_MODULO[0,{ax}] must be 0")
            scale = MM if machine.axis_kinds[j] == "linear" else DEG
            tables.append(Table(j, (j,), (grid,), -np.array(values) * scale, label=f"{axis}({axis})"))
        self._nothing_left(LEC_FILE, lec)
        kind = "lec"
        if CEC_FILE in texts:
            kind = "cec"
            cec = self._assignments(CEC_FILE, texts[CEC_FILE], "%_N_NC_CEC_INI")
            t = 0
            while ("AN_CEC", f"{t},0") in cec:
                if t >= self.max_tables:
                    raise InputError(f"{CEC_FILE}: more than {self.max_tables} CEC tables")
                values = self._series(CEC_FILE, cec, "AN_CEC", lambda i: f"{t},{i}", self.max_points)
                m = self._axis(CEC_FILE, cec.pop(("AN_CEC_INPUT_AXIS", str(t)), None), machine)
                j = self._axis(CEC_FILE, cec.pop(("AN_CEC_OUTPUT_AXIS", str(t)), None), machine)
                grid = self._grid(CEC_FILE, cec, "AN_CEC", str(t), len(values), machine, m)
                only = cec.pop(("AN_CEC_DIRECTION", str(t)), None)
                if only not in ("0", "1", "-1"):
                    raise InputError(f"{CEC_FILE}: $AN_CEC_DIRECTION[{t}] must be 0, 1 or -1, got {only!r}")
                for key in ("AN_CEC_MULT_BY_TABLE", "AN_CEC_IS_MODULO"):
                    if cec.pop((key, str(t)), None) != "0":
                        raise InputError(f"{CEC_FILE}: ${key}[{t}] must be 0")
                scale = MM if machine.axis_kinds[j] == "linear" else DEG
                suffix = {"1": " +", "-1": " -"}.get(only, "")
                tables.append(Table(j, (m,), (grid,), -np.array(values) * scale, only=int(only),
                                    label=f"{machine.axes[j]}({machine.axes[m]}){suffix}"))
                t += 1
            self._nothing_left(CEC_FILE, cec)
        return SetpointTables(tuple(tables), len(machine.axes), kind=kind)

    @staticmethod
    def _assignments(name: str, text: str, head: str) -> dict[tuple[str, str], str]:
        lines = text.splitlines()
        if not lines or lines[0].strip() != head or "CHANDATA(1)" not in (s.strip() for s in lines[:3]):
            raise InputError(f"{name}:1: expected '{head}' and CHANDATA(1)")
        if lines[-1].strip() != "M17":
            raise InputError(f"{name}:{len(lines)}: the program must end with M17")
        out: dict[tuple[str, str], str] = {}
        for number, line in enumerate(lines[1:-1], 2):
            if not line.strip() or line.lstrip().startswith(";") or line.strip() == "CHANDATA(1)":
                continue
            m = ASSIGN_RE.match(line)
            if m is None:
                raise InputError(f"{name}:{number}: not an assignment of a compensation variable")
            key = (m["name"], m["index"].replace(" ", ""))
            if key in out:
                raise InputError(f"{name}:{number}: ${key[0]}[{key[1]}] assigned twice")
            out[key] = m["value"]
        return out

    @staticmethod
    def _float(name: str, key: tuple[str, str], text: str | None) -> float:
        if text is None:
            raise InputError(f"{name}: ${key[0]}[{key[1]}] missing")
        if not re.fullmatch(r"[+-]?(?:\d+\.?\d*|\.\d+)", text):
            raise InputError(f"{name}: ${key[0]}[{key[1]}] = {text!r} is not a number")
        return float(text)

    def _series(self, name, table, variable, index, limit) -> list[float]:
        values = []
        while (variable, index(len(values))) in table:
            key = (variable, index(len(values)))
            values.append(self._float(name, key, table.pop(key)))
        if not 2 <= len(values) <= limit:
            raise InputError(f"{name}: ${variable}: {len(values)} points, outside 2..{limit}")
        return values

    def _grid(self, name, table, variable, index, count, machine, j) -> np.ndarray:
        step, lo, hi = (self._float(name, (f"{variable}_{k}", index), table.pop((f"{variable}_{k}", index), None))
                        for k in ("STEP", "MIN", "MAX"))
        scale = MM if machine.axis_kinds[j] == "linear" else DEG
        unit = self._unit(machine, j) / scale
        if step <= 0 or abs(lo + step * (count - 1) - hi) > unit / 2:
            raise InputError(f"{name}: ${variable}[{index}]: MIN {lo:g} + {count - 1} x STEP {step:g} "
                             f"is not MAX {hi:g}")
        return (lo + step * np.arange(count)) * scale

    @staticmethod
    def _axis(name: str, text: str | None, machine: Machine) -> int:
        m = re.fullmatch(r"\(AX(\d+)\)", text or "")
        if m is None or not 1 <= int(m[1]) <= len(machine.axes):
            raise InputError(f"{name}: axis {text!r} is not (AXn) of a machine axis")
        return int(m[1]) - 1

    @staticmethod
    def _nothing_left(name: str, table: dict) -> None:
        if table:
            key = next(iter(table))
            raise InputError(f"{name}: unknown or unused assignment ${key[0]}[{key[1]}]")
