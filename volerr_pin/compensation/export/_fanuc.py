"""FANUC pitch error compensation, bidirectional, as a parameter file (Series 0i-PB Parameter
Manual B-63980EN/01, parameters 3620-3627 "pitch error compensation" with its examples;
Series 16i/18i-MA/TA technical report A-77810E "Bidirectional pitch error compensation":
3605#0, 3620-3627; Series 15i Parameter Manual B-63330EN/03, 3 "Inputting and outputting
parameters": the file format).

What the CNC does, as this product reads those documents:

- Compensation points lie every ``interval`` (3624, detection units) from the reference
  position (machine coordinate 0; 3620 is its point number). Each point's value is the
  *increment* of the compensation over the section ending at that point, in detection units
  times the magnification (3623); the CNC outputs it when the axis passes the point, so the
  compensation is a step function of the position: constant from one point to the next,
  zero at the reference position (where the pulses are counted from), held beyond the last
  points. **Values are corrections** (the pulses the CNC adds), not errors.
- Bidirectional (3605#0 = 1): the points 3621..3622 apply while moving +, the points from
  3626 on (as many) while moving -; 3627 is the absolute compensation at the reference
  position in the negative direction (the reference return taken as positive).
- Per point -127..+127 (times 3623, 1..100); at most 128 points per axis and direction, 1024
  in all (point numbers 0-1023).

File: ``%`` and a comment line (the CNC skips the text between the first ``%`` and the end
of its line), axis-type parameters ``N03620A1P..A2P..``, pitch data ``N1nnnnP..`` (10000 +
point number), ``%``. Bit 0 of 3605 is not written (the other bits of that parameter belong to
the machine): set it by hand on the axes named in the comment. Detection unit: 0.001 mm and
0.001 deg (increment system IS-B) unless told otherwise.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

import numpy as np

from ...base import DEG, MM, InputError
from ...model import Machine
from ._layouts import nc_axes
from ._protocol import ControllerFormat
from ._tables import SetpointTables, Table, quantised
from ._zone import Zone

__all__ = ["Fanuc"]

FILE = "PITCH.TXT"
PARAMS = (3620, 3621, 3622, 3623, 3624, 3626, 3627)
LINE_RE = re.compile(r"^N(?P<number>\d{5})(?P<rest>(?:A\d+P[+-]?\d+)+|P[+-]?\d+)$")


class Fanuc(ControllerFormat):
    """FANUC bidirectional pitch error compensation (parameters 3620-3627 and pitch data).

    Parameters
    ----------
    detection_unit_mm : float, default 0.001
        Detection unit of linear axes [mm] (IS-B; IS-C is 0.0001).
    detection_unit_deg : float, default 0.001
        Detection unit of rotary axes [deg].
    points_per_axis : int, default 128
        Points per axis and direction.
    total_points : int, default 1024
        Point numbers available for all axes.

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.export.ControllerFormat` (documented there)
    do here:

    - ``layout``: a bidirectional step table per axis: points every whole number of detection
      units from machine 0 (the reference position) across the zone, the positive direction's
      value at the reference fixed at zero.
    - ``quantise``: absolute corrections rounded to detection unit x magnification (the smallest
      magnification whose increments fit).
    - ``files``: ``PITCH.TXT``: parameters 3620-3627 and the pitch data.
    - ``read``: the tables the parameter file sets, by the CNC's rules.
    """

    name = "fanuc"
    title = "FANUC pitch error compensation (bidirectional, parameters 3620-3627)"
    kinds = ("pitch",)
    convention = ("values are increments of the correction per section, detection units x magnification; "
                  "the compensation steps at each point and is zero at the reference position (machine 0)")
    manual = ("FANUC Series 0i-PB Parameter Manual B-63980EN/01 (3620-3627, examples); technical report A-77810E "
              "Bidirectional pitch error compensation (3605#0, 3626, 3627); Series 15i Parameter Manual "
              "B-63330EN/03 section 3 (parameter file format)")
    default_nodes = 41
    value_limit = 127

    def __init__(self, detection_unit_mm: float = 0.001, detection_unit_deg: float = 0.001,
                 points_per_axis: int = 128, total_points: int = 1024):
        self.units = (detection_unit_mm * MM, detection_unit_deg * DEG)
        self.points_per_axis, self.total_points = int(points_per_axis), int(total_points)

    def _unit(self, machine: Machine, j: int) -> float:
        return self.units[machine.axis_kinds[j] == "rotary"]

    def layout(self, machine: Machine, zone: Zone, kind: str, nodes: int | None) -> SetpointTables:
        nc_axes(machine, self.title)
        count = self.default_nodes if nodes is None else int(nodes)
        if count < 2:
            raise InputError(f"nodes: a pitch error table needs at least 2 points, got {count}", parameters=("nodes",))
        tables, used = [], 0
        for j, axis in enumerate(machine.axes):
            unit = self._unit(machine, j)
            lo, hi = zone.ranges[j]
            if hi <= lo:
                lo, hi = lo - 500 * unit, lo + 500 * unit
            interval = max(math.ceil((hi - lo) / (count - 1) / unit - 1e-9), 1)
            k_lo = min(math.floor(lo / (interval * unit) + 1e-9), 0)
            k_hi = max(math.ceil(hi / (interval * unit) - 1e-9), 0)
            grid = np.arange(k_lo, k_hi + 1) * interval * unit
            if len(grid) > self.points_per_axis:
                raise InputError(f"nodes: axis {axis} needs {len(grid)} pitch error points (from machine 0 across the "
                                 f"zone); the CNC holds {self.points_per_axis} per axis and direction",
                                 parameters=("nodes",))
            used += 2 * len(grid)
            free = np.ones((2, len(grid)), dtype=bool)
            free[0, -k_lo] = False                                     # zero at the reference position, moving +
            tables.append(Table(j, (j,), (grid,), np.zeros((2, len(grid))), directional=True, step=True, free=free,
                                tied="directions" not in machine.covariates_used, label=f"{axis}({axis})"))
        if used > self.total_points:
            raise InputError(f"nodes: {used} pitch error points in all; the CNC holds {self.total_points}",
                             parameters=("nodes",))
        rotary = [a for a, k in zip(machine.axes, machine.axis_kinds) if k == "rotary"]
        notes = [f"rotary axes {', '.join(rotary)}: their points are numbered as a linear-type axis' are; set them up "
                 "as linear-type axes for pitch error compensation (the 0i manual's rotary-type form, whose farthest "
                 "negative point is the reference position's own number, is not written)"] if rotary else []
        return SetpointTables(tuple(tables), len(machine.axes), notes, kind="pitch")

    def _magnification(self, values: np.ndarray, unit: float) -> int:
        """Smallest magnification (1..100) at which every increment fits +-127."""
        for mag in range(1, 101):
            steps = np.diff(quantised(values, unit * mag), axis=-1) / (unit * mag)
            if np.abs(steps).max(initial=0.0) <= self.value_limit + 1e-9:
                return mag
        raise InputError(f"a pitch error increment beyond {self.value_limit} x 100 detection units")

    def quantise(self, compensation: SetpointTables, machine: Machine) -> SetpointTables:
        out = []
        for t in compensation.tables:
            unit = self._unit(machine, t.output)
            mag = self._magnification(t.values, unit)
            out.append(t.with_values(quantised(t.values, unit * mag)))
        return SetpointTables(tuple(out), compensation.n_axes, compensation.notes, kind=compensation.kind)

    def files(self, compensation: SetpointTables, machine: Machine) -> dict[str, str]:
        params = {p: [] for p in PARAMS}
        data = []
        base = 0
        for t in compensation.tables:
            j = t.output
            unit = self._unit(machine, j)
            mag = self._magnification(t.values, unit)
            grid = t.nodes[0]
            n = len(grid)
            interval = int(round((grid[1] - grid[0]) / unit))
            ref = int(round(-grid[0] / (interval * unit)))
            counts = np.rint(t.values / (unit * mag)).astype(int)          # absolute, in units x mag
            for offset, row in ((0, counts[0]), (n, counts[1])):
                increments = np.concatenate([[0], np.diff(row)])
                data += [(base + offset + i, int(v)) for i, v in enumerate(increments)]
            for p, v in zip(PARAMS, (base + ref, base, base + n - 1, mag, interval, base + n, int(counts[1, ref]))):
                params[p].append(f"A{j + 1}P{v}")
            base += 2 * n
        axes = " ".join(machine.axes)
        lines = [f"%(volerr_pin: bidirectional pitch error compensation of {machine.name}; values are corrections; "
                 f"set bit 0 BDP of parameter 3605 on axes {axes}; reference position at machine 0)"]
        lines += [f"N{p:05d}" + "".join(words) for p, words in params.items()]
        lines += [f"N{10000 + number:05d}P{value}" for number, value in data]
        lines.append("%")
        return {FILE: "\n".join(lines) + "\n"}

    def read(self, texts: Mapping[str, str], machine: Machine) -> SetpointTables:
        if FILE not in texts:
            raise InputError(f"{FILE}: missing")
        lines = texts[FILE].splitlines()
        if not lines or not lines[0].startswith("%") or lines[-1].strip() != "%":
            raise InputError(f"{FILE}: must begin and end with %")
        params: dict[int, dict[int, int]] = {}
        data: dict[int, int] = {}
        for number, line in enumerate(lines[1:-1], 2):
            m = LINE_RE.match(line.strip())
            if m is None:
                raise InputError(f"{FILE}:{number}: not a parameter line N.....A.P. or N1....P.")
            key = int(m["number"])
            if key >= 10000:
                if key - 10000 >= self.total_points or key - 10000 in data:
                    raise InputError(f"{FILE}:{number}: pitch point {key - 10000} out of range or given twice")
                value = int(m["rest"][1:])
                if abs(value) > self.value_limit:
                    raise InputError(f"{FILE}:{number}: pitch value {value} beyond +-{self.value_limit}")
                data[key - 10000] = value
            elif key in PARAMS:
                params[key] = {int(a): int(v) for a, v in re.findall(r"A(\d+)P([+-]?\d+)", m["rest"])}
            else:
                raise InputError(f"{FILE}:{number}: parameter {key} is not one this file sets")
        tables = []
        for j, axis in enumerate(machine.axes):
            try:
                ref, lo, hi, mag, interval, neg, at_ref = (params[p][j + 1] for p in PARAMS)
            except KeyError:
                raise InputError(f"{FILE}: parameters 3620-3627 incomplete for axis {axis} (A{j + 1})") from None
            n = hi - lo + 1
            if not (lo <= ref <= hi and 1 <= mag <= 100 and interval > 0 and 2 <= n <= self.points_per_axis):
                raise InputError(f"{FILE}: axis {axis}: 3620 {ref}, 3621 {lo}, 3622 {hi}, 3623 {mag}, 3624 {interval} "
                                 "do not describe a table")
            unit = self._unit(machine, j)
            rows = []
            for first, start in ((lo, 0), (neg, at_ref)):
                missing = [k for k in range(first, first + n) if k not in data]
                if missing:
                    raise InputError(f"{FILE}: axis {axis}: pitch point {missing[0]} missing")
                steps = np.array([data[k] for k in range(first, first + n)])
                if steps[0] != 0:
                    raise InputError(f"{FILE}: axis {axis}: point {first} (below the table) must be 0")
                absolute = np.cumsum(steps)
                rows.append((absolute - absolute[ref - lo] + start) * unit * mag)
            grid = (np.arange(n) - (ref - lo)) * interval * unit
            free = np.ones((2, n), dtype=bool)
            free[0, ref - lo] = False
            tables.append(Table(j, (j,), (grid,), np.array(rows), directional=True, step=True, free=free,
                                label=f"{axis}({axis})"))
        return SetpointTables(tuple(tables), len(machine.axes), kind="pitch")
