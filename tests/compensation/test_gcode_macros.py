"""Issue 43: parameters, expressions, O-word control flow and polar coordinates followed as
LinuxCNC runs them (the values here are worked by hand from LinuxCNC's rules; the real-client
suite checks the same programs against LinuxCNC's own interpreter)."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from volerr_pin.cli import main
from volerr_pin.compensation.gcode import GcodeError, compensate_program, interpret, may_need, split_lines
from volerr_pin.compensation.gcode._expressions import Unfollowable
from volerr_pin.compensation.gcode._macros import expand

START = "G21 G90 G17\nG0 X100 Y100 Z100\n"


def run(text: str) -> list[str]:
    """The program as run, one string per block."""
    expansion = expand(split_lines(text))
    assert expansion is not None
    return [body for body, _ in expansion.lines]


def x_of(text: str) -> list[float]:
    """The X values the program as run writes."""
    return [float(v) for v in re.findall(r"X(-?[0-9.]+)", "\n".join(run(text)))]


@pytest.mark.parametrize("expr, value", [
    ("[1 + 2 * 3 ** 2]", 19.0),            # ** binds tighter than *, * than +
    ("[2 ** 3 ** 2]", 64.0),               # left to right within a precedence
    ("[10 - 4 - 3]", 3.0), ("[12 / 3 / 2]", 2.0),
    ("[7 MOD 3]", 1.0), ("[-7 MOD 3]", 2.0),   # LinuxCNC's MOD is never negative
    ("[1 EQ 1.0000001]", 1.0), ("[1 EQ 1.00001]", 0.0), ("[1 NE 1.0000001]", 0.0),
    ("[2 GE 1.9999999]", 1.0), ("[2 GT 2.0000001]", 0.0), ("[1 LE 1.0000001]", 1.0), ("[2 LE 2]", 1.0),
    ("[1 LT 2 AND 3 GT 4]", 0.0), ("[1 LT 2 OR 3 GT 4]", 1.0), ("[1 XOR 1]", 0.0),
    ("[1 + 2 LT 4]", 1.0),                 # + before LT
    ("ATAN[1]/[1]", 45.0), ("ATAN[-1]/[-1]", -135.0), ("SIN[30]", 0.5), ("COS[60]", 0.5),
    ("TAN[45]", 1.0), ("ASIN[0.5]", 30.0), ("ACOS[0.5]", 60.0), ("SQRT[16]", 4.0), ("ABS[-3]", 3.0),
    ("EXP[0]", 1.0), ("LN[1]", 0.0), ("FIX[-1.5]", -2.0), ("FUP[-1.5]", -1.0), ("ROUND[2.5]", 3.0),
    ("ROUND[-2.5]", -3.0), ("-[2 + 3]", -5.0), ("-SQRT[4]", -2.0),
])
def test_expressions_read_as_linuxcnc_computes_them(expr, value):
    (x,) = x_of(f"G0 X{expr}\n")
    assert x == pytest.approx(value, abs=1e-12)


def test_parameters_numbered_named_indirect_and_set_after_the_line():
    program = ("#1 = 2\n#<Width> = 10\n#2 = 3 #3 = #2\n"   # #3 takes #2 as it was before the line: 0
               "#[1 + 3] = 7\n##1 = 5\n"                     # #4 = 7, then #(#1) = #2 = 5
               "G0 X#3 Y#< width > Z#4\nG0 X#2 Y[#<width> * #1]\n"
               "G0 X[EXISTS[#<width>]] Y[EXISTS[#<depth>]]\n")
    lines = run(program)
    assert lines[-3:] == ["G0 X0 Y10 Z7", "G0 X5 Y20", "G0 X1 Y0"]
    # the main program's settings stay (computed ones as numbers); numbers as written stay
    assert lines[:5] == ["#1 = 2", "#<Width> = 10", "#2 = 3 #3 = 0", "#[1 + 3] = 7", "##1 = 5"]


def test_a_subroutine_runs_where_it_is_called_with_its_own_locals():
    program = ("#1 = 100\n#<_g> = 1\n"
               "o10 sub\n#<local> = [#1 + #2]\n#<_g> = [#<_g> + 1]\nG1 X#<local> Y#3 F100\n"
               "o10 return [#<local> * 2]\n"
               "o10 endsub\n"
               "o10 call [20] [30]\nG0 X#1 Y#<_value> Z#<_g>\n"
               "o10 call [1]\nG0 X#<_value_returned> Y#<_value>\n")
    lines = [line for line in run(program) if line.strip()]
    assert lines == ["#1 = 100", "#<_g> = 1", *program.splitlines()[2:8],   # the definition, as written
                     "#<_g> = 2", "G1 X50 Y0 F100", "G0 X100 Y100 Z2",
                     "#<_g> = 3", "G1 X1 Y0 F100", "G0 X1 Y2"], lines
    with pytest.raises(Unfollowable, match=r"#<local> is read before it is set"):
        expand(split_lines("o10 sub\n#<local> = 1\no10 endsub\no10 call\nG0 X#<local>\n"))


def test_loops_and_branches():
    program = ("#1 = 0\no1 while [#1 LT 5]\n#1 = [#1 + 1]\n"
               "o2 if [#1 EQ 2]\nG0 X200\no2 elseif [#1 EQ 4]\nG0 X400\no2 else\nG0 X#1\no2 endif\n"
               "o1 endwhile\n"
               "o3 do\nG0 X99\no3 while [0]\n"           # a do loop runs once before its test
               "o4 repeat [2]\nG0 X[#1 * 10]\no4 endrepeat\n"
               "o5 while [0]\nG0 X1234\no5 endwhile\n")
    assert x_of(program) == [1, 200, 3, 400, 5, 99, 50, 50]


@pytest.mark.parametrize("program, why", [
    # LinuxCNC keeps a break's state past its loop: the do loop after it runs once (not 3 times)
    ("o1 while [1]\nG0 X1\no1 break\no1 endwhile\n#1 = 0\no2 do\n#1 = [#1 + 1]\nG0 Y#1\no2 while [#1 LT 3]\n",
     r"o1 break: LinuxCNC's break and continue leave state"),
    ("o1 repeat [2]\nG0 X1\no1 continue\no1 endrepeat\n", r"o1 continue"),
    # its repeat count survives a return from inside the loop, into the next call
    ("o1 sub\no2 repeat [2]\nG0 X#1\no1 return\no2 endrepeat\no1 endsub\no1 call [1]\no1 call [2]\n",
     r"o2 repeat: a return from inside it leaves its count"),
    ("o1 if [EXISTS[#<_metric>]]\nG0 X1\no1 endif\n", r"LinuxCNC predefines names beginning with _"),
    ("o1 if [1]\nG0 X1\no1 endif\no1 if [1]\nG0 X2\no1 endif\n", r"label o1 opens two blocks \(lines 1 and 4\)"),
])
def test_what_linuxcnc_runs_its_own_way_is_not_followed(program, why):
    """Found by running programs through rs274 beside the product: these run by LinuxCNC's own
    state, which the product does not guess."""
    with pytest.raises(Unfollowable, match=why):
        expand(split_lines(program))


@pytest.mark.parametrize("program, where", [
    ("o1 if [1] G0 X5\nG0 Y5\no1 endif\n", r"p\.ngc:1:11: 'G0X5' after an O-word statement; LinuxCNC refuses it"),
    ("o1 repeat [2]\nG0 X1\no1 endrepeat G0 X2\n", r"p\.ngc:3:14: 'G0X2' after an O-word"),
    ("G0 X[1 (c) + 2]\n", r"p\.ngc:1:8: a comment inside an expression; LinuxCNC refuses it"),
])
def test_what_linuxcnc_refuses_is_refused(program, where):
    with pytest.raises(GcodeError, match=where):
        expand(split_lines(program), "p.ngc")


@pytest.mark.parametrize("expr, column", [("[0 ** -1]", 14), ("EXP[800]", 5), ("[10 ** 400]", 16),
                                          ("FIX[1" + "0" * 400 + "]", 9), ("[1 / 0]", 12), ("[SQRT[-1]]", 6),
                                          ("[ASIN[2]]", 6), ("[LN[0]]", 6), ("[[-8] ** 0.5]", 18), ("[1 +]", 9),
                                          ("[" * 5000 + "1" + "]" * 5000, 133)])
def test_values_linuxcnc_refuses_are_refused_naming_line_and_column(expr, column):
    """LinuxCNC stops the program at them ("Calculation resulted in 'infinity'", "Attempt to
    divide by zero", ...): the product never writes X inf, nor reads the block as it is and
    drops the cut (the fourth hostile pass: the block and the next cut were lost, no word)."""
    with pytest.raises(GcodeError, match=rf"^p\.ngc:2:{column}: .*LinuxCNC stops the program there, so it is "
                                         "refused"):
        expand(split_lines(f"G0 X1\nG0 X{expr}\n"), "p.ngc")


def test_calls_nest_as_deep_as_linuxcnc_lets_them_and_a_definition_read_in_passing_clears_value():
    recursion = "o1 sub\no2 if [#1 GT 0]\no1 call [#1 - 1]\no2 endif\nG0 X#1\no1 endsub\n"
    assert x_of(recursion + "o1 call [8]\n") == list(range(9))     # 9 nested calls
    with pytest.raises(Unfollowable, match=r"calls nested deeper than 10"):
        expand(split_lines(recursion + "o1 call [9]\n"))            # LinuxCNC: too many subroutine levels
    program = "o1 sub\no1 return [3]\no1 endsub\no1 call\no2 sub\nG0 Z1\no2 endsub\nG0 X#<_value>\n"
    assert x_of(program) == [0]   # rs274: X0 (passing o2's endsub cleared the 3 o1 returned)


def test_an_endless_loop_is_refused_naming_it():
    with pytest.raises(GcodeError, match=r"^p\.ngc:[23]: following o7 while \(line 2\) would run more than 1,000 "
                                         r"blocks.*most_blocks") as err:
        expand(split_lines("G0 X1\no7 while [1]\nG0 X2\no7 endwhile\n"), "p.ngc", most_blocks=1000)
    assert err.value.parameters == ("most_blocks",)
    # a loop that writes nothing, or a vast repeat count, is bounded all the same
    for spin in ("o7 while [1]\no7 endwhile\n", "o7 repeat [1000000000000]\n#1 = [#1 + 1]\no7 endrepeat\n",
                 "o8 sub\n#1 = 1\no8 endsub\no7 do\no8 call\no7 while [1]\n"):
        with pytest.raises(GcodeError, match=r"following o7 \w+ \(line \d\)(, o8 call \(line 5\))? would run more "
                                             r"than 1,000 blocks"):
            expand(split_lines(spin), "p.ngc", most_blocks=1000)
    with pytest.raises(GcodeError, match=r"most_blocks must be a whole number"):
        compensate_program_with(most_blocks=0)


def compensate_program_with(**kw):
    from volerr_pin import load_machine
    from pathlib import Path
    m = load_machine(Path(__file__).resolve().parents[2] / "machines" / "vmc500")
    return compensate_program(m, START, **kw)


def test_a_comparison_linuxcnc_versions_decide_differently_stops_the_expansion():
    """LinuxCNC 2.9.0 and later take LE / GE within 1e-6 as equal, earlier versions (Debian 12
    ships 2.9.0~pre1) compare exactly: LinuxCNC's own threading.ngc counts 0.0005 steps up to
    0.0375 and, by the version, runs 76 passes or 75. The product does not guess which."""
    program = "#1 = 0\no1 while [#1 LE 0.0375]\nG0 X[#1 * 100]\n#1 = [#1 + 0.0005]\no1 endwhile\n"
    with pytest.raises(Unfollowable, match=r"0\.0375000000000000\d* LE 0\.0375 \(equal within 1e-06\) is true "
                                           r"for LinuxCNC 2\.9\.0 and later and false for earlier versions"):
        expand(split_lines(program))


@pytest.mark.parametrize("program, why", [
    ("G0 X#5420\n", r"#5420 is known only to the running machine"),
    ("#5070 = 1\no1 while [#5070 NE 0]\nG38.2 Z1\no1 endwhile\n", r"#5070 is known only to the running machine"),
    ("G0 X#<_x>\n", r"#<_x> is known only to the running machine"),
    ("o<probe> call [1]\n", r"o<probe> is not defined in this program"),
    ("o1 sub\nM73\no1 endsub\no1 call\n", r"M73 in a subroutine"),
    ("WHILE [#1 LT 3] DO1\nG0 X#1\nEND1\n", r"'HILE\[#1L' is not a value this reader knows"),
    ("o1 if [1]\nG0 X1\n", r"o1 if is never closed"),
    ("o1 endwhile\n", r"o1 endwhile without its o1 while"),
])
def test_what_only_the_machine_knows_stops_the_expansion(program, why):
    with pytest.raises(Unfollowable, match=why):
        expand(split_lines(program))


def test_an_unfollowable_program_is_read_as_before_and_says_why(machines):
    program = START + "#1 = #5420\no1 while [#1 LT 3]\nG1 X150 F100\n#1 = [#1 + 1]\no1 endwhile\nM30\n"
    out, report = compensate_program(machines["vmc500"], program)
    assert report.expanded is None and "o1 while" in out
    assert any(w.startswith("the program's parameters, expressions and O-words are not followed (line 3: #5420 is "
                            "known only to the running machine") for w in report.warnings), report.warnings


def test_a_subroutine_no_call_runs_stays_defined_and_globals_stay_set(machines):
    """A subroutine no call runs stays defined (another program's call, or a controller's menu,
    may name it), and the globals set are set in the program as run; a lathe cycle runs its
    profile as a call (tests/compensation/test_gcode_profiles.py)."""
    program = ("G18 G21 G90 G7\nG0 X40 Z10\n#<_d> = [2 * 1.5]\n"
               "o100 sub\nG1 X[10 + #<_d>] Z0\nG1 Z-10\no100 endsub\n"
               "o200 sub\nG1 X#1 F100\no200 endsub\no300 sub\nG1 X[#<_d>]\no300 endsub\n"
               "G71 Q100 X40 Z10 D0.5 I1 R0.3\no200 call [30]\nM30\n")
    lines = run(program)
    assert lines[2] == "#<_d> = 3"
    # every definition stays as written; the cycle names its profile as run, the call runs its body
    assert lines[3:13] == program.splitlines()[3:13]
    assert lines[13:17] == ["o301 sub", "G1 X13 Z0", "G1 Z-10", "o301 endsub"]
    assert lines[17] == "G71 Q301 X40 Z10 D0.5 I1 R0.3"
    assert lines[18:] == ["G1 X30 F100", "M30"]


def test_errors_name_the_line_a_block_comes_from(machines):
    program = START + "o1 sub\nG1 X#1 F100\no1 endsub\no1 call [120]\no1 call [9999]\nM30\n"
    with pytest.raises(GcodeError, match=r"^p\.ngc:4: \(block 7 of the program as run\) X9999 takes axis X to "
                                         r"9999 mm, outside the travel"):
        compensate_program(machines["vmc500"], program, source="p.ngc")
    out, report = compensate_program(machines["vmc500"], START + "o1 sub\nG1 X#1 F100\nG77\no1 endsub\n"
                                     "o1 call [120]\nM30\n", pass_through=True, source="p.ngc")
    # warnings name the line in the subroutine (5), not the block as run (4)
    assert any(w.startswith("line 5: G77 (a G code this reader does not know) kept") for w in report.warnings)
    assert report.blocks_in == 8 and report.expanded == {"blocks_run": 9, "calls": 1, "loop_passes": 0, "profiles": 0}


def test_a_loop_is_compensated_pass_by_pass(machines):
    """A helix of G91 steps in a loop: each pass compensated where it runs; the program as run
    reads (through the product and, in the real-client suite, through LinuxCNC) as the loop."""
    m = machines["vmc500"]
    program = START + ("#1 = 0\no1 while [#1 LT 8]\nG91 G1 X[10 * COS[#1 * 45]] Y[10 * SIN[#1 * 45]] Z-1 F300\n"
                       "#1 = [#1 + 1]\no1 endwhile\nG90\nM30\n")
    out, report = compensate_program(m, program)
    assert report.moves == 9 and report.moves_kept == 0 and report.expanded["loop_passes"] == 8
    nominal = np.array([s.end for s in interpret(m, program)])
    written = np.array([s.end for s in interpret(m, out)])
    assert nominal[-1] == pytest.approx([0.1, 0.1, 0.092], abs=1e-12)   # the loop closes the octagon
    assert 0 < np.abs(written - nominal).max() < 30e-6   # compensated by the few um of the model


R0 = math.hypot(100, 100)   # START's distance from the origin, at 45 deg


@pytest.mark.parametrize("words, x, y", [
    ("G1 @10 ^30", 10 * math.cos(math.radians(30)), 5.0),
    ("G1 ^90", 0.0, R0),                                   # @ left out: the current distance
    ("G1 @50", 50 / math.sqrt(2), 50 / math.sqrt(2)),     # ^ left out: the current angle
    ("G91 G1 @10", (R0 + 10) / math.sqrt(2), (R0 + 10) / math.sqrt(2)),   # added to the distance
    ("G91 G1 ^45", 0.0, R0),                               # added to the angle
])
def test_polar_words_are_written_as_the_x_and_y_they_mean(machines, words, x, y):
    m = machines["vmc500"]
    program = START + words + " F100\nM30\n"
    assert interpret(m, program)[-1].end[:2] * 1e3 == pytest.approx([x, y], abs=1e-9)
    out, report = compensate_program(m, program)
    assert "@" not in out and "^" not in out and re.search(r"G1 X\S+ Y\S+", out)
    assert any("polar coordinates (@ ^) written as the X and Y they mean" in w for w in report.warnings)


@pytest.mark.parametrize("line, error", [
    ("G18\nG1 @10 ^30", r":4:4: polar coordinates \(@ \^\) in the G18 plane"),
    ("G92 @5 ^10", r":3:5: polar coordinates \(@ \^\) in a G92 block; LinuxCNC takes them for moves only"),
    ("G53 G0 @50 ^30", r":3:8: polar coordinates \(@ \^\) in a G53 block"),
    ("G0 X0 Y0\nG0 @50", r":4:4: a polar word from the origin, where the angle is indeterminate"),
    ("G0 X0 Y0\nG91 G0 @50 ^10", r":4:8: a polar word from the origin"),
    ("G1 X10 @10", r":3:4: X or Y with polar coordinates"),
    ("G1 @10 @20", r":3:8: two @ words in one block"),
    ("G1 @ ^30", r":3:4: '@' without a number"),
])
def test_polar_words_linuxcnc_refuses_are_refused(machines, line, error):
    with pytest.raises(GcodeError, match="<program>" + error):
        compensate_program(machines["vmc500"], START + line + " F100\n")
    with pytest.raises(GcodeError, match=r"a polar word beside the current position, which is not known"):
        compensate_program(machines["vmc500"], "G21 G90\nG1 @10 F100\n")


@pytest.mark.parametrize("code", ["G33 Z50 K2", "G33.1 Z50 K2", "G38.2 Z50 F100", "G5.1 X120 Y120 I5 J5"])
def test_linuxcnc_motions_the_model_does_not_interpolate_are_kept(machines, code):
    """Spindle-synchronized moves, rigid tapping, probing and splines run as LinuxCNC runs them:
    kept unchanged and named (with their modal continuation), never refused as unknown codes."""
    program = START + code + "\nZ60\nG1 X150 F100\nM30\n"
    out, report = compensate_program(machines["vmc500"], program)
    assert out.splitlines()[2:4] == [code, "Z60"]
    assert report.moves_kept == 2 and report.moves == 2
    g = code.split()[0]
    assert any(re.match(rf"line 3: {g} \(.*\) kept unchanged$", w) for w in report.warnings), report.warnings
    assert any(re.match(rf"line 4: a block of the {g} \(.*\) still in force kept unchanged$", w)
               for w in report.warnings), report.warnings
    # where it ends is not followed: the move after it is compensated at its end point only
    assert any(w.startswith("line 5: the position before this move is not known") for w in report.warnings)


def test_a_lathe_cycle_needs_its_q_word(machines):
    program = "G18 G21 G90\nG0 X40 Z10\nG71 Q100 X40 Z10 D0.5\nM30\n"
    out, report = compensate_program(machines["vmc500"], program)
    assert out.splitlines()[2] == "G71 Q100 X40 Z10 D0.5" and report.moves_kept == 1
    with pytest.raises(GcodeError, match=r"G71 \(a G code this reader does not know\)"):
        compensate_program(machines["vmc500"], "G71\nG0 X40 Z10\n")   # Siemens: metric


def test_cutter_radius_compensation_is_kept_to_g40(machines):
    """The controller offsets the path by the tool radius and joins the pieces itself: a split
    move would get corners LinuxCNC refuses ("Tool radius not less than arc radius with comp")."""
    program = START + "G41 G1 X120 Y100 F100\nG3 X120 Y100 I-10 J0\nG40 G1 X100 Y100\nG1 X150\nM30\n"
    out, report = compensate_program(machines["vmc500"], program)
    assert out.splitlines()[2:5] == program.splitlines()[2:5]
    assert report.moves == 2 and report.moves_kept == 3


def test_the_report_gives_the_share_of_motion_compensated(machines, tmp_path, capsys):
    program = tmp_path / "p.ngc"
    program.write_text(START + "#1 = 0\no1 while [#1 LT 3]\nG1 X[110 + #1] F100\n#1 = [#1 + 1]\no1 endwhile\n"
                       "G38.2 Z50\nM30\n")
    assert may_need(split_lines(program.read_text())) and not may_need(split_lines(START + "(#1 [x])\n"))
    assert main(["compensate", "vmc500", str(program), "-o", str(tmp_path / "o.ngc"), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["moves"] == 4 and report["moves_kept"] == 1 and report["motion_compensated"] == pytest.approx(0.8)
    assert report["expanded"] == {"blocks_run": 11, "calls": 0, "loop_passes": 3, "profiles": 0} and report["blocks_in"] == 9
    assert "o1" not in (tmp_path / "o.ngc").read_text()
    assert main(["compensate", "vmc500", str(program), "-o", str(tmp_path / "o1.ngc"),
                 "--most-blocks", "5"]) != 0
    assert "following o1 while (line 4) would run more than 5 blocks" in capsys.readouterr().err
    assert main(["compensate", "vmc500", str(program), "-o", str(tmp_path / "o2.ngc")]) == 0
    assert "moves compensated: 4 of 5 (80.0 %)" in capsys.readouterr().out
