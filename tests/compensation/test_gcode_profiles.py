"""Issue 43: LinuxCNC's lathe cycles (G70 - G72) compensated through their profiles.

The controller derives every pass of a cycle from its profile (a subroutine named by Q), so the
profile as run is written as a new subroutine before the cycle and compensated as the path the
cycle follows. These tests hold that to an independent computation: the same path compensated
as ordinary moves. The real-client suite runs the outputs through LinuxCNC's interpreter.
"""

from __future__ import annotations

import re
import subprocess

import pytest

from volerr_pin.compensation.gcode import compensate_program, split_lines
from volerr_pin.compensation.gcode._state import ModalState
from volerr_pin.compensation.gcode._profiles import Profiles
from volerr_pin.compensation.gcode._macros import expand

import numpy as np

from test_real_client_corpus import _moves, _wide, follows
from test_real_client_linuxcnc import RS274

PROFILE = "G0 X40 Z-10\nG1 Z-20 F100\nG2 X50 Z-30 R10\nG1 Z-60\nX60\nG2 X70 Z-70 I10 K0\n"
CASES = [
    ("G18 G21 G90 F100\nG0 X80 Z-5", "G71 Q100 X80 Z-5 D0.5 I1 R0.3", "G0 X80 Z-5"),     # start given
    ("G18 G21 G90 F100\nG0 X90 Z-2", "G71 Q100 D0.5", "G0 X90 Z-2"),                        # where the tool is
    ("G18 G21 G90 F100\nG0 X80 Z-5", "G91 G71 Q100 X10 Z2", None),                          # incremental start
    ("G18 G21 G90 G7 F100\nG0 X160 Z-5", "G70 Q100 X160 Z-5", "G0 X160 Z-5"),               # diameters
]
#: the profile in diameters, and incremental from X90 Z-3
DIAMETERS = "G0 X80 Z-10\nG1 Z-20 F100\nG2 X100 Z-30 R10\nG1 Z-60\nX120\nG2 X140 Z-70 I10 K0\n"
INCREMENTAL = "G0 X-50 Z-7\nG1 Z-10 F100\nG2 X10 Z-10 R10\nG1 Z-30\nX10\nG2 X10 Z-10 I10 K0\n"


def profile_of(head: str, cycle: str) -> str:
    return DIAMETERS if "G7" in head else INCREMENTAL if "G91" in cycle else PROFILE


def cycle_program(head: str, cycle: str, profile: str = PROFILE) -> str:
    return f"{head}\no100 sub\n{profile}o100 endsub\n{cycle}\nM30\n"


def numbers(lines: list[str]) -> list[tuple[str, float]]:
    return [(m.group(1), float(m.group(2))) for line in lines for m in re.finditer(r"([XZIKR])(-?[0-9.]+)", line)]


def body_of(out: str, name: str) -> list[str]:
    lines = out.splitlines()
    return lines[lines.index(f"o{name} sub") + 1:lines.index(f"o{name} endsub")]


@pytest.mark.parametrize("head, cycle, start", CASES)
def test_a_profile_is_compensated_as_the_path_the_cycle_follows(machines, head, cycle, start):
    """The profile's compensated numbers are those of the same path (G0 cut as G1) compensated as
    ordinary moves from the cycle's start point, in the cycle's modes."""
    m = machines["lathe_2axis"]
    profile = profile_of(head, cycle)
    if start is None:
        start = "G0 X90 Z-3\nG91"
    out, report = compensate_program(m, cycle_program(head, cycle, profile), tol_um=1.0)
    assert report.expanded["profiles"] == 1 and report.moves_kept == 0
    assert report.moves == 1 + 6   # the program's G0, and the profile's six moves
    assert body_of(out, "100") == profile.splitlines()   # the definition stays as written; the cycle names o101
    lines = out.splitlines()
    assert re.sub(r"Q101", "Q100", lines[lines.index("o101 endsub") + 1]) == cycle
    plain = head.split("\n")[0] + "\n" + start + "\n" + profile.replace("G0", "G1") + "M30\n"
    alike, _ = compensate_program(m, plain, tol_um=1.0)
    expected = alike.splitlines()[len(start.split("\n")) + 1:-1]
    assert numbers(body_of(out, "101")) == numbers(expected)   # as written, to the last digit
    assert numbers(body_of(out, "101")) != numbers(profile.splitlines())   # and it was compensated
    assert any(re.match(r"line \d+: G7[01] \(lathe (roughing|finishing) cycle\) kept as written: it cuts along its "
                        r"profile, compensated as subroutine o101 written before it", w) for w in report.warnings)


def test_each_cycle_runs_its_profile_with_the_values_of_its_time(machines):
    """A profile reading a global is run at each cycle with the value then; the original
    subroutine, which the cycles no longer name, stays as written, and the modes after a profile are the
    program's (the profile's G2 does not carry: the next block's Z move is a line)."""
    program = ("G18 G21 G90\nG0 X80 Z-5\n#<_d> = 0\no7 sub\nG1 X40 Z[-10 - #<_d>]\nG1 Z[-20 - #<_d>]\n"
               "G2 X60 Z[-30 - #<_d>] R15\no7 endsub\nG71 Q7 X80 Z-5 D0.5\n#<_d> = 10\n"
               "G71 Q7 X80 Z-5 D0.5\nG0 X80 Z-5\nZ-3\nM30\n")
    out, report = compensate_program(machines["lathe_2axis"], program, tol_um=1.0)
    assert report.expanded["profiles"] == 2 and body_of(out, "7") == program.splitlines()[4:7]
    z8 = [v for a, v in numbers(body_of(out, "8")) if a == "Z"]
    z9 = [v for a, v in numbers(body_of(out, "9")) if a == "Z"]
    assert z8[-1] == pytest.approx(-30, abs=0.05) and z9[-1] == pytest.approx(-40, abs=0.05)
    assert "G71 Q8 X80 Z-5 D0.5" in out and "G71 Q9 X80 Z-5 D0.5" in out
    assert re.fullmatch(r"Z-2\.99[0-9]* X79\.99[0-9]*", out.splitlines()[-2]) and report.moves_kept == 0


@pytest.mark.parametrize("profile, why", [
    ("G1 X40 Z290 A2\nG1 Z280\n", "a fillet"),                 # A: a fillet LinuxCNC inserts
    ("G1 X40 Z290\nG1 W-10\n", "an incremental Z word"),        # U / W
    ("G1 X40 Z290\nG90 G1 Z280\n", "a G code the cycle ignores"),
    ("X40 Z290\nG1 Z280\n", "a move before any motion code"),
    ("G1 X40 Y5 Z290\nG1 Z280\n", "a Y word"),
])
def test_a_profile_the_cycle_reads_otherwise_keeps_the_cycle_as_written(machines, profile, why):
    program = cycle_program("G18 G21 G90 F100\nG0 X80 Y100 Z300", "G71 Q100 X80 Z300 D0.5", profile)
    out, report = compensate_program(machines["vmc500"], program, tol_um=1.0)
    assert "o100 sub" in out and "G71 Q100 X80 Z300 D0.5" in out and "o101" not in out, why
    assert report.expanded is None or report.expanded["profiles"] == 0
    assert report.moves_kept == 1 and any("G71 (lathe roughing cycle) kept unchanged" in w for w in report.warnings)


def test_a_compensated_profile_linuxcnc_would_refuse_is_written_as_it_runs(tmp_path):
    """G72 needs its profile monotonic in X (each block within 1e-3 mm): a long block along Z may
    turn back once compensated. It is then written as it runs, uncompensated, and said."""
    state = ModalState(position=np.zeros(2), known=np.ones(2, dtype=bool))
    lines = ["G1 X200 Z0\n", "G1 X200.0019 Z-300\n", "G1 X100 Z-350\n", "o101 endsub\n"]
    why = Profiles.refusal(lines, "G72 Q101 X300 Z10", state)
    assert why == ("it would turn back by 0.0019 mm in X, and G72 needs it monotonic in X (LinuxCNC refuses it)")
    assert Profiles.refusal(lines, "G71 Q101 X300 Z10", state) is None        # monotonic in Z
    assert Profiles.refusal(lines, "G70 Q101 X300 Z10", state) is None        # in Z or X
    lines[1] = "G1 X200.0009 Z-300\n"                                           # within 1e-3 mm
    assert Profiles.refusal(lines, "G72 Q101 X300 Z10", state) is None
    state.diameter, lines[1] = True, "G1 X200.0019 Z-300\n"                     # 1e-3 of a radius
    assert Profiles.refusal(lines, "G72 Q101 X300 Z10", state) is None
    # in a program: vmc500's errors, extended to travels of 2 m, turn X back along a 300 mm block
    # along Z by 1.9 um
    m = _wide(tmp_path / "wide")
    profile = ["G1 X200 Z0", "G1 Z-300", "G1 X100 Z-350", "G1 Z-400"]
    program = cycle_program("G18 G21 G90\nG0 X300 Y0 Z10", "G72 Q100 X300 Z10 D0.5 I5 R0.3",
                            "".join(f"{line}\n" for line in profile))
    out, report = compensate_program(m, program, tol_um=1.0)
    assert body_of(out, "101") == profile and "G72 Q101 X300 Z10 D0.5 I5 R0.3" in out
    assert report.moves == 1 and report.moves_kept == 1   # the G0; the cycle, kept
    assert report.expanded["profiles"] == 0
    assert any(re.fullmatch(r"line 9: a lathe cycle's profile written as it runs, uncompensated: it would turn back "
                            r"by 0\.00\d+ mm in X, and G72 needs it monotonic in X \(LinuxCNC refuses it\)", w)
               for w in report.warnings), report.warnings


def test_the_expansion_writes_the_profile_before_its_cycle():
    expansion = expand(split_lines(cycle_program("G18 G21\nG0 X80 Z-5", "G71 Q100 X80 Z-5 (rough) D0.5")))
    bodies = [body for body, _ in expansion.lines]
    assert bodies[2:10] == ["o100 sub", *PROFILE.splitlines(), "o100 endsub"]   # as written
    assert bodies[10:19] == ["o101 sub", *PROFILE.splitlines(), "o101 endsub", "G71 Q101 X80 Z-5 (rough) D0.5"]
    assert expansion.profiles == {"101": "G71 Q101 X80 Z-5 (rough) D0.5"}
    assert list(expansion.origin[10:19]) == [11, 4, 5, 6, 7, 8, 9, 11, 11]


@pytest.mark.slow
@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 (Debian's linuxcnc-uspace) is not installed")
@pytest.mark.parametrize("head, cycle, start", CASES)
def test_linuxcnc_cuts_along_the_compensated_profile(machines, tmp_path, head, cycle, start):
    """LinuxCNC's interpreter takes each compensated profile, runs the roughing or finishing
    passes along the ones it runs for the program as written (within 0.1 mm), and every motion
    ends elsewhere but the rapids to (and retracts beside) the cycle's start point, which it
    makes from its X / Z as written: the passes it derives from the profile are compensated."""
    program = cycle_program(head, cycle, profile_of(head, cycle))
    # rough, then finish along the same profile
    if cycle.startswith("G71"):
        program = program.replace("\nM30\n", "\n" + re.sub(r" [DIR][0-9.]+", "", cycle).replace("G71", "G70") + "\nM30\n")
    out, _ = compensate_program(machines["lathe_2axis"], program, tol_um=1.0)
    canon = {}
    for name, text in (("in", program), ("out", out)):
        (tmp_path / f"{name}.ngc").write_text(text)
        run = subprocess.run([RS274, "-g", f"{name}.ngc", f"{name}.canon"], capture_output=True, text=True,
                             timeout=60, cwd=tmp_path)
        assert run.returncode == 0, run.stdout[-300:]
        canon[name] = _moves(tmp_path / f"{name}.canon")
    assert len(canon["in"]) > 6   # the cycle ran: more motions than the profile has moves
    start = canon["in"][1]["end"]   # the cycle's first motion: its rapid to its start point, as written
    changed = follows(canon["in"], canon["out"], cycle)
    same = [k for k, c in enumerate(changed) if not c]
    # the cycle's rapids to its start point (and its retract R beside it) are the cycle's own
    assert all(np.linalg.norm(canon["in"][k]["end"] - start) <= 0.5 for k in same), \
        [canon["in"][k]["end"] for k in same]
    assert sum(changed) >= 6   # each of the profile's six moves, cut at least once


def test_a_profile_is_numbered_above_every_o_word_of_the_program():
    """A new subroutine must not take a label the program uses (a loop's o500 in the main program
    and a subroutine o500 are one label to LinuxCNC)."""
    program = cycle_program("G18 G21\nG0 X80 Z-5\no500 repeat [1]\nG0 X80\no500 endrepeat\no<600> sub\no<600> endsub",
                            "G71 Q100 X80 Z-5 D0.5")
    bodies = [body for body, _ in expand(split_lines(program)).lines]
    assert "o601 sub" in bodies and "G71 Q601 X80 Z-5 D0.5" in bodies
