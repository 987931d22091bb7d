"""A real client reads what the product writes (issue 43): LinuxCNC's own interpreter, rs274
(Debian's ``linuxcnc-uspace``; ``.ci/run`` installs it where apt can), takes every compensated
program of the NC tests, and its canonical moves are the product's own reading of the output:
every end point, and every arc's centre and plane, to the 4 decimals rs274 prints (of mm, inch
or deg, in the units the program selects)."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.gcode import compensate_program, interpret

from test_gcode import FULL_CIRCLES, G90_1, LATHE_DIAMETER, LATHE_PROFILE, PROGRAM_500, PROGRAM_700, PROGRAM_CGM, SUB

RS274 = shutil.which("rs274")
pytestmark = [pytest.mark.slow, pytest.mark.skipif(
    RS274 is None, reason="LinuxCNC's interpreter rs274 is not installed (Debian's linuxcnc-uspace, as root: "
                          "apt-get install --no-install-recommends linuxcnc-uspace)")]

ROOT = Path(__file__).resolve().parents[1]
#: rs274 prints 4 decimals: a reading agrees when it rounds to the number printed
PRINTED = 0.5e-4 * (1 + 1e-6)
CANON_AXES = "XYZABC"
#: the canonical arc's words by plane: its two end coordinates, then the third axis
ARC_AXES = {"XY": ("X", "Y", "Z"), "XZ": ("Z", "X", "Y"), "YZ": ("Y", "Z", "X")}
SCALE = {"MM": 1.0, "INCHES": 25.4, "CM": 10.0}

M72 = "G0 X10 Y10 Z50 F100\nM70\nG91\nG1 X5\nM72\nG1 X100 Y20\nG0 Z60\nM30\n"
PROGRAMS = [
    ("vmc500", PROGRAM_500), ("vmc500", G90_1), ("vmc500", M72), ("vmc500", SUB), ("vmc500", FULL_CIRCLES),
    ("vmc500", "G64 P0.01 Q0.001\nG0 X100 Y100 Z50\nG1 X200 F100\nG2 X300 Y100 R50\nM30\n"),
    ("vmc700", PROGRAM_700), ("vmc700", (ROOT / "examples" / "data" / "part.nc").read_text()),
    ("cgm4000", PROGRAM_CGM), ("lathe_2axis", LATHE_PROFILE), ("lathe_2axis", LATHE_DIAMETER),
]


def canonical_moves(text: str) -> list[dict]:
    """The motions of rs274's canonical output, in mm and deg: kind, end per axis letter, and an
    arc's plane and centre."""
    units, plane, out = 1.0, "XY", []
    for line in text.splitlines():
        call = re.search(r"([A-Z_]+)\((.*)\)\s*$", line)
        if not call:
            continue
        name, args = call.groups()
        if name == "USE_LENGTH_UNITS":
            units = SCALE[args.split("_")[-1]]
        elif name == "SELECT_PLANE":
            plane = args.split("_")[-1]
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            v = [float(a) for a in args.split(",")]
            if name == "ARC_FEED":
                first, second, third = ARC_AXES[plane]
                end = {first: v[0], second: v[1], third: v[5], "A": v[6], "B": v[7], "C": v[8]}
                centre = {first: v[2], second: v[3]}
                out.append({"kind": "arc", "end": end, "centre": centre, "plane": (first, second), "units": units})
            else:
                out.append({"kind": name, "end": dict(zip(CANON_AXES, v[:6])), "units": units})
    return out


def _agrees(mine_mm: float, printed: float, scale: float) -> bool:
    """A reading in mm or deg agrees with a printed number in the program's units (``scale``
    mm per unit; 1 for degrees) when it rounds to it."""
    return abs(mine_mm / scale - printed) <= PRINTED


@pytest.mark.parametrize("name, program", PROGRAMS, ids=[f"{n}-{k}" for k, (n, _) in enumerate(PROGRAMS)])
def test_linuxcnc_reads_the_compensated_program_as_the_product_does(machines, tmp_path, name, program):
    m = machines[name]
    out, _ = compensate_program(m, program, tol_um=1.0, pass_through=True)
    path = tmp_path / "out.ngc"
    path.write_text(out if out.rstrip().endswith(("M30", "M2", "%")) else out + "M30\n")
    run = subprocess.run([RS274, "-g", str(path), str(tmp_path / "out.canon")], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    canon = canonical_moves((tmp_path / "out.canon").read_text())
    mine = interpret(m, path.read_text())
    assert len(canon) == len(mine), (len(canon), len(mine))
    kinds = {a: k for a, k in zip(m.axes, m.axis_kinds)}
    for c, s in zip(canon, mine):
        for j, axis in enumerate(m.axes):
            scale = c["units"] if kinds[axis] == "linear" else 1.0
            value = s.end[j] * (1e3 if kinds[axis] == "linear" else 180 / np.pi)
            assert _agrees(value, c["end"][axis], scale), (s.line, axis, value, c["end"][axis])
        assert (c["kind"] == "arc") == (s.kind == "arc"), s.line
        if s.kind == "arc":
            i, j = (m.axes.index(a) for a in c["plane"])
            assert s.arc.plane[:2] == (i, j), (s.line, s.arc.plane, c["plane"])
            for axis, value in zip(c["plane"], s.arc.center):
                assert _agrees(value * 1e3, c["centre"][axis], c["units"]), (s.line, axis, value, c["centre"])
