"""LinuxCNC joint compensation files (``COMP_FILE_TYPE = 1``) and the INI lines that load them.

What LinuxCNC does (its source: ``src/emc/motion/usrmotintf.cc`` ``usrmotLoadComp``,
``src/emc/motion/command.c`` ``EMCMOT_SET_JOINT_COMP``, ``src/emc/motion/control.c``
``compute_screw_comp``; the INI keys in the Integrator's Manual, "INI Configuration",
section [JOINT_n]):

- The file is read line by line; each line must hold three numbers (``sscanf("%lf %lf
  %lf")``): nominal position, forward trim, reverse trim, in machine units. Reading stops
  without a word at the first line that does not: a header or a comment would silently cut
  the table, so the files hold nothing else.
- Type 1 trims are added to the joint's commanded position (``motor_pos_cmd = pos_cmd +
  backlash_filt``); type 0 files would hold actual positions instead (trim = nominal -
  actual). We write type 1: **each trim is the correction added to the commanded position**.
- At most 256 entries (``EMCMOT_COMP_SIZE``), nominal positions strictly increasing
  (an entry that does not increase is refused with "compensation values must increase").
- Between entries the trims are interpolated linearly, read at the commanded position; below
  the first and above the last entry the end trims hold (the table's sentinels at -/+
  DBL_MAX have zero slope).
- The forward trim applies while the commanded velocity is positive, the reverse trim while
  negative, and at standstill the last one stays: reversal (backlash) goes into the two
  columns. (The change is ramped over a few servo periods; the simulation takes the settled
  value.)

Machine units are taken as mm and degrees (``[TRAJ] LINEAR_UNITS = mm``, ``ANGULAR_UNITS =
degree``), which the INI fragment says in a comment; values are written to 1e-6 of a unit.
Joint n is the machine's n-th axis (trivial kinematics).
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Mapping

import numpy as np

from ...base import InputError, axis_scale
from ...model import Machine
from ._protocol import ControllerFormat
from ._tables import SetpointTables, Table, quantised
from ._layouts import fixed, own_table
from ._zone import Zone

__all__ = ["LinuxCNC"]

#: how LinuxCNC applies the tables where it differs from the settled correction the residuals are
#: simulated with (both seen in a headless LinuxCNC 2.9 with a 1 ms servo period): said in the
#: report and the INI fragment, with what avoids them
APPLIED = (
    "LinuxCNC applies a joint's trim only once the joint moves: a joint not moved since homing gets no "
    "correction (on cgm4000, B at 0 deg held -1.984 mdeg in its table and 0 applied). Move every joint "
    "after homing, before the compensated program runs.",
    "LinuxCNC takes a trim in through a filter limited by the joint's MAX_ACCELERATION, which from "
    "standstill never completes a step between 0.25 and 0.5 x MAX_ACCELERATION x (servo period)^2 "
    "(at 3000 units/s^2 and 1 ms: 0.75 to 1.5 um, or mdeg, left over; 1.05-1.38 um on Z and 1.0 mdeg on A "
    "were seen). Where that band matters, a shorter servo period narrows it with its square.",
)
#: EMCMOT_COMP_SIZE: entries a joint's table may hold
MAX_ENTRIES = 256
#: decimals written (of mm or deg)
DECIMALS = 6
INI_NAME = "compensation.ini"
SECTION_RE = re.compile(r"^\s*\[(?P<name>[^\]]+)\]\s*$")
KEY_RE = re.compile(r"^\s*(?P<key>[A-Z_0-9]+)\s*=\s*(?P<value>.*?)\s*$")
NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
LINE_RE = re.compile(rf"^\s*({NUMBER})\s+({NUMBER})\s+({NUMBER})\s*$")


def comp_file_name(machine: Machine, j: int) -> str:
    """The comp file of joint ``j``: ``joint<j>_<axis>.comp``."""
    return f"joint{j}_{machine.axes[j]}.comp"


class LinuxCNC(ControllerFormat):
    """LinuxCNC joint compensation (type 1: nominal, forward trim, reverse trim).

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.export.ControllerFormat` (documented there)
    do here:

    - ``layout``: one bidirectional table per joint over its zone range.
    - ``quantise``: trims rounded to 1e-6 mm or deg (what the files hold).
    - ``files``: one comp file per joint and the INI fragment that loads them.
    - ``read``: the tables the INI fragment and comp files give, read by LinuxCNC's rules.
    """

    name = "linuxcnc"
    title = "LinuxCNC joint compensation (COMP_FILE_TYPE = 1)"
    kinds = ("joint",)
    convention = ("trims are corrections added to the commanded joint position (type 1), mm or deg; "
                  "forward trim while moving +, reverse trim while moving -")
    manual = ("LinuxCNC Integrator's Manual, INI Configuration, [JOINT_n] COMP_FILE / COMP_FILE_TYPE; "
              "source usrmotintf.cc (usrmotLoadComp), command.c (EMCMOT_SET_JOINT_COMP), control.c "
              "(compute_screw_comp)")
    default_nodes = 41

    def layout(self, machine: Machine, zone: Zone, kind: str, nodes: int | None) -> SetpointTables:
        count = self.default_nodes if nodes is None else int(nodes)
        if not 2 <= count <= MAX_ENTRIES:
            raise InputError(f"nodes: LinuxCNC holds 2 to {MAX_ENTRIES} entries per joint, got {count}",
                             parameters=("nodes",))
        step = (10.0 ** -DECIMALS * axis_scale("linear"), 10.0 ** -DECIMALS * axis_scale("rotary"))
        tables = [own_table(machine, zone, j, count, step, directional=True) for j in range(len(machine.axes))]
        return SetpointTables(tuple(tables), len(machine.axes), list(APPLIED), kind="joint")

    def quantise(self, compensation: SetpointTables, machine: Machine) -> SetpointTables:
        out = [t.with_values(quantised(t.values, 10.0 ** -DECIMALS * axis_scale(machine.axis_kinds[t.output])))
               for t in compensation.tables]
        return SetpointTables(tuple(out), compensation.n_axes, compensation.notes, kind="joint")

    def files(self, compensation: SetpointTables, machine: Machine) -> dict[str, str]:
        out = {}
        ini = [f"# volerr_pin: joint compensation for {machine.name}, one comp file per joint.",
               "# COMP_FILE_TYPE 1: nominal position, forward trim, reverse trim; each trim is the correction",
               "# LinuxCNC adds to the commanded joint position (forward while moving +, reverse while moving -).",
               "# Machine units: [TRAJ] LINEAR_UNITS = mm, ANGULAR_UNITS = degree. Joint n is axis n:",
               "# " + ", ".join(f"joint {j} = {a}" for j, a in enumerate(machine.axes)) + ".",
               "# Copy these keys into the [JOINT_n] sections of the machine's INI file, with the comp files",
               "# beside it (COMP_FILE names are relative to this folder). BACKLASH is not used with COMP_FILE.",
               *(f"# {line}" for note in APPLIED for line in textwrap.wrap(note, 96))]
        for t in compensation.tables:
            j = t.output
            unit = axis_scale(machine.axis_kinds[j])
            rows = [" ".join(fixed(v / unit, DECIMALS) for v in row) for row in zip(t.nodes[0], *t.values)]
            name = comp_file_name(machine, j)
            out[name] = "\n".join(rows) + "\n"
            ini += ["", f"[JOINT_{j}]", "COMP_FILE_TYPE = 1", f"COMP_FILE = {name}"]
        out[INI_NAME] = "\n".join(ini) + "\n"
        return out

    def read(self, texts: Mapping[str, str], machine: Machine) -> SetpointTables:
        if INI_NAME not in texts:
            raise InputError(f"{INI_NAME}: missing")
        sections: dict[str, dict[str, str]] = {}
        current = None
        for number, line in enumerate(texts[INI_NAME].splitlines(), 1):
            if not line.strip() or line.lstrip().startswith(("#", ";")):
                continue
            m = SECTION_RE.match(line)
            if m:
                current = sections.setdefault(m["name"], {})
                continue
            m = KEY_RE.match(line)
            if m is None or current is None:
                raise InputError(f"{INI_NAME}:{number}: not a section or KEY = VALUE line")
            current[m["key"]] = m["value"]
        tables = []
        for j, axis in enumerate(machine.axes):
            section = sections.get(f"JOINT_{j}")
            if section is None:
                raise InputError(f"{INI_NAME}: no [JOINT_{j}] section (axis {axis})")
            if section.get("COMP_FILE_TYPE") != "1":
                raise InputError(f"{INI_NAME}: [JOINT_{j}] COMP_FILE_TYPE must be 1, "
                                 f"got {section.get('COMP_FILE_TYPE')!r}")
            name = section.get("COMP_FILE")
            if name not in texts:
                raise InputError(f"{INI_NAME}: [JOINT_{j}] COMP_FILE {name!r} is not among the files")
            nominal, fwd, rev = self._entries(name, texts[name])
            unit = axis_scale(machine.axis_kinds[j])
            tables.append(Table(j, (j,), (np.array(nominal) * unit,), np.array([fwd, rev]) * unit,
                                directional=True, label=f"{axis}({axis})"))
        return SetpointTables(tuple(tables), len(machine.axes), kind="joint")

    @staticmethod
    def _entries(name: str, text: str) -> tuple[list, list, list]:
        nominal, fwd, rev = [], [], []
        for number, line in enumerate(text.splitlines(), 1):
            m = LINE_RE.match(line)
            if m is None:
                raise InputError(f"{name}:{number}: not three numbers; LinuxCNC stops reading the table here")
            x, f, r = (float(g) for g in m.groups())
            if nominal and x <= nominal[-1]:
                raise InputError(f"{name}:{number}: nominal position {x:g} does not increase "
                                 "(LinuxCNC: compensation values must increase)")
            nominal.append(x)
            fwd.append(f)
            rev.append(r)
        if len(nominal) > MAX_ENTRIES:
            raise InputError(f"{name}: {len(nominal)} entries; LinuxCNC takes at most {MAX_ENTRIES}")
        if len(nominal) < 2:
            raise InputError(f"{name}: {len(nominal)} entries; a table needs at least 2")
        return nominal, fwd, rev
