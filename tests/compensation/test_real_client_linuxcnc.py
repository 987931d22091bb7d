"""A real client reads what the product writes (issue 43): LinuxCNC's own interpreter, rs274
(Debian's ``linuxcnc-uspace``; ``.ci/run`` installs it where apt can), takes every compensated
program of the NC tests, and its canonical moves are the product's own reading of the output:
every end point, and every arc's centre and plane, to the 4 decimals rs274 prints (of mm, inch
or deg, in the units the program selects). And a headless LinuxCNC applies the joint tables the
product exports as the product simulates them."""

from __future__ import annotations

import re
import shutil
import subprocess
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.compensation.gcode import compensate_program, interpret, split_lines
from volerr_pin.compensation.gcode._expressions import Unfollowable
from volerr_pin.compensation.gcode._macros import expand

from test_gcode import (DWELL_AND_MOVE, FULL_CIRCLES, G90_1, LATHE_DIAMETER, LATHE_PROFILE, PROGRAM_500, PROGRAM_700,
                        PROGRAM_CGM, SUB)

RS274 = shutil.which("rs274")
pytestmark = [pytest.mark.slow, pytest.mark.skipif(
    RS274 is None, reason="LinuxCNC's interpreter rs274 is not installed (Debian's linuxcnc-uspace, as root: "
                          "apt-get install --no-install-recommends linuxcnc-uspace)")]

ROOT = Path(__file__).resolve().parents[2]
#: rs274 prints 4 decimals: a reading agrees when it rounds to the number printed
PRINTED = 0.5e-4 * (1 + 1e-6)
CANON_AXES = "XYZABC"
#: the canonical arc's words by plane: its two end coordinates, then the third axis
ARC_AXES = {"XY": ("X", "Y", "Z"), "XZ": ("Z", "X", "Y"), "YZ": ("Y", "Z", "X")}
SCALE = {"MM": 1.0, "INCHES": 25.4, "CM": 10.0}

M72 = "G0 X10 Y10 Z50 F100\nM70\nG91\nG1 X5\nM72\nG1 X100 Y20\nG0 Z60\nM30\n"
#: every operator, function, parameter kind and O-word the product follows, and polar words:
#: LinuxCNC must read the program itself as the product does (the expansion's rules), and the
#: compensated program as run too
MACROS = """G21 G90 G17
#<_base> = 150
#1 = [2 ** 3 ** 2 / 64 + 7 MOD 3 - -7 MOD 3]
#2 = [1 LT 2 AND 3 GT 4 OR 1 EQ 1.0000001 XOR 0]
#<r> = [SQRT[16] * 10 + ABS[-5] + FIX[-1.5] + FUP[-1.5] + ROUND[2.5] + EXP[0] + LN[1]]
G0 X#<_base> Y[#<_base> + #1] Z[200 + #2]
G1 X[#<_base> + #<r> * COS[30]] Y[#<_base> + #<r> * SIN[30]] F500
G1 X[#<_base> + 50 * TAN[45]] Y[#<_base> + ATAN[1]/[-1]] Z[200 + ASIN[0.5] + ACOS[0.5]]
o100 sub
  #<n> = #1
  o101 while [#<n> GT 0]
    G91 G1 X[#2 / #1] Y1 Z-1
    #<n> = [#<n> - 1]
    o102 if [#<n> EQ 2]
      G91 G1 Y2
    o102 elseif [#<n> EQ 1]
      G90 G1 Z190
    o102 else
      G90
    o102 endif
  o101 endwhile
  G90
  o100 return [#<n> + 10]
o100 endsub
o100 call [4] [20]
G0 Z[190 + #<_value>]
o103 repeat [3]
  G91 G2 X10 Y0 I5 J0 Z-1
o103 endrepeat
o104 do
  G90 G0 Z#<_base>
o104 while [0]
G90 G0 X0 Y0
G0 X150 Y150
G1 @250 F300
^40
G91 @-20 ^5
G90 G3 ^60 I[-230 * COS[45]] J[-230 * SIN[45]]
G90 G0 X200 Y200
M30
"""
PROGRAMS = [
    ("vmc500", PROGRAM_500), ("vmc500", G90_1), ("vmc500", M72), ("vmc500", SUB), ("vmc500", FULL_CIRCLES),
    ("vmc500", "G64 P0.01 Q0.001\nG0 X100 Y100 Z50\nG1 X200 F100\nG2 X300 Y100 R50\nM30\n"),
    ("vmc500", DWELL_AND_MOVE), ("vmc500", MACROS),
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
    reads_as_the_product_does(m, path, tmp_path / "out.canon")


@pytest.mark.parametrize("name, program", PROGRAMS, ids=[f"{n}-{k}" for k, (n, _) in enumerate(PROGRAMS)])
def test_pygcode_finds_no_word_or_comment_lost(machines, name, program):
    """pygcode (PyPI), a G-code reader of its own, reads the program and the compensated one:
    every comment, and every word but the coordinates (whose numbers change) and the motion
    codes of the pieces a split move adds, is in both, as often. A program whose parameters
    and loops are followed is compared as run (its O-word lines are meant to go)."""
    pygcode = pytest.importorskip("pygcode", reason="pygcode (PyPI) is not installed: pip install -e .[test]")
    m = machines[name]
    out, _ = compensate_program(m, program, tol_um=1.0, pass_through=True)
    try:
        expansion = expand(split_lines(program))
    except Unfollowable:   # read as written
        expansion = None
    reference = program if expansion is None else "".join(body + end for body, end in expansion.lines)

    def words(text: str) -> tuple[list[str], Counter]:
        comments, kept = [], Counter()
        for number, raw in enumerate(text.splitlines(), start=1):
            try:
                line = pygcode.Line(raw)
            except Exception as err:   # pygcode reads no parameters or expressions
                pytest.skip(f"pygcode cannot read line {number} ({raw!r}): {err}")
            if line.comment:
                comments.append(str(line.comment))
            kept.update(str(w) for w in line.block.words
                        if not (w.letter in m.axes or w.letter in "IJKR" or (w.letter == "G" and w.value in (0, 1, 2, 3))))
        return comments, kept

    assert words(out) == words(reference)


def test_linuxcnc_reads_parameters_expressions_loops_and_polar_words_as_the_product_does(machines, tmp_path):
    """The expansion's rules against LinuxCNC's own interpreter, on the program as written."""
    path = tmp_path / "in.ngc"
    path.write_text(MACROS)
    reads_as_the_product_does(machines["vmc500"], path, tmp_path / "in.canon")


def _random_expression(rng, depth: int = 0) -> str:
    """A random rs274ngc expression that is defined everywhere (no division by zero, no root of
    a negative ...), over the parameters #1, #2 and #<p>."""
    if depth > 3 or rng.random() < 0.3:
        return rng.choice(["#1", "#2", "#<p>", f"{rng.uniform(-50, 50):.4f}", str(rng.integers(-9, 10))])
    a, b = _random_expression(rng, depth + 1), _random_expression(rng, depth + 1)
    return str(rng.choice([
        f"[{a} + {b}]", f"[{a} - {b}]", f"[{a} * {b}]", f"[{a} / [ABS[{b}] + 1]]", f"[{a} MOD [ABS[{b}] + 1]]",
        f"[ABS[{a}] ** [ABS[{b}] MOD 3]]", f"[{a} GT {b}]", f"[{a} EQ {b}]", f"[{a} LT {b} OR {b} LT 0]",
        f"[{a} NE {b} AND {a} GT 0]", f"[{a} XOR {b}]", f"SIN[{a}]", f"COS[{a}]", f"ATAN[{a}]/[{b}]",
        f"SQRT[ABS[{a}]]", f"LN[ABS[{a}] + 1]", f"EXP[[{a}] MOD 3]", f"FIX[{a}]", f"FUP[{a}]", f"ROUND[{a}]",
        f"ABS[{a}]", f"ASIN[SIN[{a}]]", f"ACOS[COS[{a}]]", f"-{a}", f"[{a} + 2 * {b} ** 2 - {a} / 4]"]))


def test_linuxcnc_computes_random_expressions_as_the_product_does(machines, tmp_path):
    """300 random expressions (every operator and function, nested, over parameters set along
    the way), each an X word: rs274 and the product give the same number."""
    rng = np.random.default_rng(43)
    lines = ["G21 G90 G17", "#1 = 3.25", "#2 = -7", "#<p> = 12.5", "G0 X0 Y100 Z100"]
    def short() -> str:   # rs274 reads lines of at most 255 characters
        while len(text := _random_expression(rng)) > 200:
            pass
        return text

    for k in range(300):
        lines.append(f"G1 X[ABS[{short()}] MOD 400] F1000")
        if k % 10 == 0:   # parameters change along the way
            lines.append(f"#{1 + k % 2} = [[{short()}] MOD 100]")
    path = tmp_path / "random.ngc"
    path.write_text("\n".join(lines + ["M30"]) + "\n")
    reads_as_the_product_does(machines["vmc500"], path, tmp_path / "random.canon")


def reads_as_the_product_does(m, path: Path, canon_path: Path) -> None:
    """rs274 accepts the program at ``path``, and its canonical moves are the product's reading
    of it, move by move, to the digits rs274 prints."""
    run = subprocess.run([RS274, "-g", str(path), str(canon_path)], capture_output=True, text=True, timeout=120,
                         cwd=path.parent)
    assert run.returncode == 0, run.stdout + run.stderr
    canon = canonical_moves(canon_path.read_text())
    mine = interpret(m, path.read_text())
    if len(canon) != len(mine):   # a block of G0 alone is a traverse to where the tool stands for rs274
        canon = [c for k, c in enumerate(canon) if c["kind"] == "arc" or k == 0 or c["end"] != canon[k - 1]["end"]]
        mine = [s for s in mine if s.kind == "arc" or not np.array_equal(s.start, s.end)]
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


# ---------------------------------------------------------------- the joint tables, applied
LINUXCNC = shutil.which("linuxcnc")
#: the user LinuxCNC runs as when the tests run as root (it refuses root); .ci/run creates it
SIM_USER = "volerr-lcnc"

DRIVER = '''#!/usr/bin/python3
# A display for a headless LinuxCNC: homes, moves by MDI and reads each joint's commanded and
# motor position through a HAL component of its own (full precision), then writes them out.
import json, subprocess, time, hal, linuxcnc
MOVES, JOINTS, OUT = {moves!r}, {joints}, {out!r}
c, s = linuxcnc.command(), linuxcnc.stat()
rows, error = [], None
try:
    h = hal.component("probe")
    for j in range(JOINTS):
        h.newpin("m%d" % j, hal.HAL_FLOAT, hal.HAL_IN)
        h.newpin("c%d" % j, hal.HAL_FLOAT, hal.HAL_IN)
    h.ready()
    for j in range(JOINTS):
        subprocess.run(["halcmd", "net", "j%d" % j, "probe.m%d" % j], check=True)
        subprocess.run(["halcmd", "net", "c%d" % j, "joint.%d.pos-cmd" % j, "probe.c%d" % j], check=True)
    for state in (linuxcnc.STATE_ESTOP_RESET, linuxcnc.STATE_ON):
        c.state(state)
        c.wait_complete()
    c.mode(linuxcnc.MODE_MANUAL)
    c.wait_complete()
    c.teleop_enable(0)
    c.wait_complete()
    c.home(-1)
    c.wait_complete()
    start = time.time()
    while time.time() - start < 30:
        s.poll()
        if all(s.homed[:JOINTS]):
            break
        time.sleep(0.05)
    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete()
    for move in MOVES:
        c.mdi(move)
        c.wait_complete(120)
        time.sleep(0.3)   # the trims settle through their filter
        rows.append({{"cmd": [h["c%d" % j] for j in range(JOINTS)], "motor": [h["m%d" % j] for j in range(JOINTS)]}})
except Exception as e:
    error = repr(e)
with open(OUT, "w") as f:
    json.dump({{"rows": rows, "error": error}}, f)
c.state(linuxcnc.STATE_OFF)
'''


def _ini(machine, comp: dict[int, str], driver: Path, folder: Path) -> str:
    """A headless LinuxCNC with trivial kinematics, a 1 ms servo period and loopback joints."""
    letters = "".join(machine.axes)
    lines = ["[EMC]", "MACHINE = volerr_sim", "VERSION = 1.1", "[DISPLAY]", f"DISPLAY = {driver}",
             "[TASK]", "TASK = milltask", "CYCLE_TIME = 0.001", "[RS274NGC]", f"PARAMETER_FILE = {folder / 'sim.var'}",
             "[EMCMOT]", "EMCMOT = motmod", "COMM_TIMEOUT = 1.0", "SERVO_PERIOD = 1000000",
             "[HAL]", f"HALFILE = {folder / 'sim.hal'}", "[TRAJ]", f"COORDINATES = {letters}", "LINEAR_UNITS = mm",
             "ANGULAR_UNITS = degree", "DEFAULT_LINEAR_VELOCITY = 50", "MAX_LINEAR_VELOCITY = 400",
             "[EMCIO]", "EMCIO = io", "CYCLE_TIME = 0.100", f"TOOL_TABLE = {folder / 'tool.tbl'}",
             "[KINS]", "KINEMATICS = trivkins", f"JOINTS = {len(machine.axes)}"]
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        lo, hi = machine.travel[j] * (1e3 if kind == "linear" else 180 / np.pi)
        limits = [f"MIN_LIMIT = {lo - 1:g}", f"MAX_LIMIT = {hi + 1:g}", "MAX_VELOCITY = 400", "MAX_ACCELERATION = 3000"]
        lines += [f"[AXIS_{axis}]", *limits, f"[JOINT_{j}]", f"TYPE = {'LINEAR' if kind == 'linear' else 'ANGULAR'}",
                  "HOME = 0", "HOME_SEQUENCE = 0", *limits, "COMP_FILE_TYPE = 1", f"COMP_FILE = {comp[j]}"]
    return "\n".join(lines) + "\n"


def _hal(n: int) -> str:
    return "\n".join(["loadrt [KINS]KINEMATICS",
                      "loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS",
                      "addf motion-command-handler servo-thread", "addf motion-controller servo-thread",
                      *(f"net j{j} joint.{j}.motor-pos-cmd => joint.{j}.motor-pos-fb" for j in range(n)),
                      "net estop-loop iocontrol.0.user-enable-out => iocontrol.0.emc-enable-in"]) + "\n"


@pytest.mark.skipif(LINUXCNC is None, reason="LinuxCNC is not installed (Debian's linuxcnc-uspace)")
@pytest.mark.parametrize("name, seed", [("vmc500", 0), ("cgm4000", 1)])
def test_linuxcnc_applies_the_exported_joint_tables_as_simulated(name, seed):
    """A headless LinuxCNC (trivial kinematics, 1 ms servo period, loopback joints, a display of
    the test's own that homes and moves by MDI) loads the joint tables the product exports; what
    it adds to each joint's command (motor position less commanded position) is the correction
    the product's simulation applies there, direction by direction."""
    import json
    import os
    import pwd
    import tempfile

    from volerr_pin.compensation.export import export_tables

    if os.geteuid() == 0:
        try:
            pwd.getpwnam(SIM_USER)
        except KeyError:
            pytest.skip(f"LinuxCNC refuses to run as root and the user {SIM_USER} does not exist (.ci/run creates it)")
    machine = vp.load_machine(name)
    folder = Path(tempfile.mkdtemp(prefix="volerr-lcnc-", dir="/tmp"))
    try:
        os.chmod(folder, 0o777)
        result = export_tables(machine, "linuxcnc", folder / "comp", points=512)
        rng = np.random.default_rng(seed)
        lo, hi = machine.travel[:, 0], machine.travel[:, 1]
        scale = np.where(np.array(machine.axis_kinds) == "linear", 1e3, 180 / np.pi)
        q = lo + (0.1 + 0.8 * rng.random((8, len(machine.axes)))) * (hi - lo)   # inside the soft limits
        q = np.round(q * scale, 4) / scale   # as the MDI words give them
        moves = ["G1 " + " ".join(f"{a}{v:.4f}" for a, v in zip(machine.axes, row)) + " F20000" for row in q * scale]
        comp = {j: str(folder / "comp" / f"joint{j}_{a}.comp") for j, a in enumerate(machine.axes)}
        driver = folder / "driver.py"
        driver.write_text(DRIVER.format(moves=moves, joints=len(machine.axes), out=str(folder / "result.json")))
        (folder / "sim.ini").write_text(_ini(machine, comp, driver, folder))
        (folder / "sim.hal").write_text(_hal(len(machine.axes)))
        for empty in ("sim.var", "tool.tbl"):
            (folder / empty).write_text("")
        for path in [folder, *folder.rglob("*")]:
            os.chmod(path, 0o777)
        command = [LINUXCNC, str(folder / "sim.ini")]
        if os.geteuid() == 0:   # (LinuxCNC writes its logs into HOME: the folder's)
            command = ["runuser", "-u", SIM_USER, "--", "env", f"HOME={folder}", *command]
        run = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=folder)
        assert (folder / "result.json").exists(), run.stdout[-2000:] + run.stderr[-2000:]
        report = json.loads((folder / "result.json").read_text())
        assert report["error"] is None and len(report["rows"]) == len(q), report
        commanded = np.array([row["cmd"] for row in report["rows"]]) / scale
        applied = (np.array([row["motor"] for row in report["rows"]]) - np.array([row["cmd"] for row in report["rows"]]))
        np.testing.assert_allclose(commanded, q, atol=1e-9)
        # the direction each joint moved into each point (every joint moved from home first)
        previous = np.vstack([np.zeros(len(machine.axes)), q[:-1]])
        directions = np.where(q >= previous, 1.0, -1.0)
        expected = result.compensation.correction(q, directions, np.zeros(len(q))) * scale
        np.testing.assert_allclose(applied, expected, rtol=0, atol=1e-6)   # mm / deg
        assert np.abs(expected).max() > 1e-4   # the tables do correct
    finally:
        shutil.rmtree(folder, ignore_errors=True)
