"""Programs as shops write them (issue 62): dialects, work offsets, several set-ups.

Each dialect's defaults are checked against what its controller's manual says; work offsets
against LinuxCNC's own interpreter (rs274) where it reads the program, and every compensated
program by reading it back: its moves, with the same offsets, must end where the original's
tool should be.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from volerr_pin.compensation import POINT
from volerr_pin.compensation.gcode import GcodeError, compensate_program, interpret, read_work_offsets
from volerr_pin.compensation.gcode._dialect import detect

RS274 = shutil.which("rs274")
MM = 1e-3

#: two set-ups on one table: G54 and G55 [mm], set by the program's own G10 blocks
TWO_SETUPS = """G21 G90 G17
G10 L2 P1 X100 Y50 Z200
G10 L2 P2 X300 Y200 Z150
G54 G0 X0 Y0 Z50
G1 Z-10 F300
G1 X150 Y100
G2 X100 Y50 I-25 J-25
G0 Z50
G55 G0 X0 Y0
G1 Z-20
G1 X120 Y150
G0 Z50
G54 G0 X10 Y10
G1 Z-5
M30
"""
OFFSETS = {"G54": np.array([100, 50, 200]) * MM, "G55": np.array([300, 200, 150]) * MM}


def _ends(m, original: str, compensated: str, **kw) -> float:
    """The largest distance [m] between where the tool is at the end of each original move
    (nominal machine at the original's axis positions) and where the compensated program
    takes it (the modelled machine at the compensated axis positions), both read with ``kw``."""
    want, got = interpret(m, original, **kw), interpret(m, compensated, **kw)
    _, desired = m.tool_poses(want.w1, nominal=True)
    _, actual = m.tool_poses(got.w1, extrapolate=True)
    worst, k = 0.0, 0
    for p in actual:   # split moves end where their last piece does
        if k < len(desired) and np.linalg.norm(p - desired[k]) < 5e-6:
            worst = max(worst, float(np.linalg.norm(p - desired[k])))
            k += 1
    assert k == len(desired), f"the compensated program reaches {k} of the {len(desired)} ends"
    return worst


def test_two_set_ups_set_by_the_program_are_each_read_with_their_own_zero(machines):
    m = machines["vmc500"]
    batch = interpret(m, TWO_SETUPS)
    ends = {int(line): w1 / MM for line, w1 in zip(batch.line, batch.w1)}
    np.testing.assert_allclose(ends[6], [250, 150, 190])        # G54: (150, 100, -10) + (100, 50, 200)
    np.testing.assert_allclose(ends[11], [420, 350, 130])       # G55: (120, 150, -20) + (300, 200, 150)
    np.testing.assert_allclose(ends[14], [110, 60, 195])        # back on G54
    assert not batch.skipped
    assert any("G10 sets G55: followed" in n for n in batch.notes)
    out, report = compensate_program(m, TWO_SETUPS)
    assert report.passed_through == 0 and report.motion_compensated == 1.0
    # the G10 lines are written as they are; every move's numbers are the original's near enough
    assert out.splitlines()[1:3] == TWO_SETUPS.splitlines()[1:3]
    assert _ends(m, TWO_SETUPS, out) <= 1e-6


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's interpreter rs274 is not installed (Debian's linuxcnc-uspace)")
def test_the_work_offsets_are_where_linuxcnc_puts_them(machines, tmp_path):
    """rs274 gives each feed's end in program coordinates and the work offset apart
    (SET_G5X_OFFSET): their sum is the axis position the product reads; G10 L20 included."""
    program = TWO_SETUPS.replace("G10 L2 P2 X300 Y200 Z150", "G0 X300 Y200 Z150\nG10 L20 P2 X0 Y0 Z0")
    source, canon = tmp_path / "p.ngc", tmp_path / "p.canon"
    source.write_text("".join(f"N{k} {line}\n" for k, line in enumerate(program.splitlines(), start=1)))
    run = subprocess.run([RS274, "-g", str(source), str(canon)], capture_output=True, text=True, timeout=60,
                         stdin=subprocess.DEVNULL, cwd=tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    offset, ends = np.zeros(3), []
    for line in canon.read_text().splitlines():
        shift = re.search(r"SET_G5X_OFFSET\(\d+, ([-\d.]+), ([-\d.]+), ([-\d.]+),", line)
        if shift:
            offset = np.array([float(v) for v in shift.groups()])
        call = re.search(r"N\.*(\d+)\s+STRAIGHT_(?:FEED|TRAVERSE)\(([-\d.]+), ([-\d.]+), ([-\d.]+),", line)
        if call:
            ends.append((int(call.group(1)), np.array([float(v) for v in call.groups()[1:]]) + offset))
    batch = interpret(machines["vmc500"], source.read_text(), dialect="linuxcnc")
    mine = [(int(line), w1 / MM) for line, w1, kind in zip(batch.line, batch.w1, batch.kind)
            if not (kind == POINT and line == 0)]
    assert [line for line, _ in mine if line != 8] == [line for line, _ in ends if line != 8]
    for (_, a), (_, b) in zip([e for e in mine if e[0] != 8], [e for e in ends if e[0] != 8]):
        np.testing.assert_allclose(a, b, atol=1e-4)


def test_a_set_up_whose_offset_is_not_known_is_refused_naming_the_line(machines):
    m = machines["vmc500"]
    text = "G21 G90\nG54 G0 X10 Y10 Z10\nG55 G0 X10 Y10 Z10\nM30\n"
    with pytest.raises(GcodeError, match=r"p\.nc:3: G55 changes the work offset from G54 \(line 2\).*work_offsets"):
        compensate_program(m, text, source="p.nc")
    # a table gives both
    out, report = compensate_program(m, text, work_offsets=OFFSETS)
    assert report.moves == 2 and _ends(m, text, out, work_offsets=OFFSETS) <= 1e-6
    ends = interpret(m, text, work_offsets=OFFSETS).w1 / MM
    np.testing.assert_allclose(ends, [[110, 60, 210], [310, 210, 160]])
    # G54 is in force when a program starts: a table's G54 holds for a program that selects none
    np.testing.assert_allclose(interpret(m, "G0 X1 Y2 Z3\n", work_offsets=OFFSETS).w1[0] / MM, [101, 52, 203])
    with pytest.raises(GcodeError, match="origin or work_offsets, not both"):
        interpret(m, text, work_offsets=OFFSETS, origin=[0, 0, 0])
    with pytest.raises(GcodeError, match=r"p\.nc:3: G56 .* not in the work-offset table"):
        interpret(m, text.replace("G55", "G56"), "p.nc", work_offsets=OFFSETS)


def test_g10_in_incremental_mode_adds_on_fanuc_and_sets_on_linuxcnc(machines):
    m = machines["vmc500"]
    body = "G21 G90\nG10 L2 P2 X300. Y200. Z150.\nG91 G10 L2 P2 X10.\nG90 G55 G0 X0 Y0 Z0\nM30\n"
    assert interpret(m, body, dialect="fanuc").w1[0] / MM == pytest.approx([310, 200, 150])
    assert interpret(m, body, dialect="linuxcnc").w1[0] / MM == pytest.approx([10, 200, 150])
    # FANUC's G10 L20 Pn sets G54.1 Pn; P0 the external offset, which every work offset adds
    fanuc = "O1\nG10 L20 P3 X200. Y100. Z100.\nG10 L2 P0 X1. Y2. Z3.\nG54.1 P3 G0 X0 Y0 Z0\nM30\n"
    assert interpret(m, fanuc, dialect="fanuc").w1[0] / MM == pytest.approx([201, 102, 103])


def test_the_three_table_forms_give_the_same_offsets(machines, tmp_path):
    m = machines["vmc500"]
    (tmp_path / "o.csv").write_text("offset,X_mm,Y_mm,Z_mm\nG54,100,50,200\nG55,300,200,150\n")
    (tmp_path / "linuxcnc.var").write_text("5220\t1.000000\n" + "".join(
        f"{5221 + 20 * k + j}\t{v / 25.4:.6f}\n" for k, name in enumerate(("G54", "G55"))
        for j, v in enumerate(OFFSETS[name] / MM)) + "5230\t0.000000\n5250\t0.000000\n")
    (tmp_path / "offsets.txt").write_text("%\nO0001\nG10 L2 P1 X100.000 Y50.000 Z200.000\n"
                                          "G10 L2 P2 X300.000 Y200.000 Z150.000\n%\n")
    tables = [read_work_offsets(tmp_path / "o.csv", list(m.axes), list(m.axis_kinds)),
              read_work_offsets(tmp_path / "linuxcnc.var", list(m.axes), list(m.axis_kinds), unit="inch"),
              read_work_offsets(tmp_path / "offsets.txt", list(m.axes), list(m.axis_kinds), unit="mm")]
    for table in tables:
        assert sorted(table) == ["G54", "G55"]
        for name in ("G54", "G55"):
            np.testing.assert_allclose(table[name], OFFSETS[name], atol=1e-9)


@pytest.mark.parametrize("name, text, unit, message", [
    ("o.csv", "offset,X_mm,Y_mm\nG54,1,2\n", None, r"o\.csv:1: no column for axis Z"),
    ("o.csv", "offset,X_mm,Y_mm,Z_deg\nG54,1,2,3\n", None, r"o\.csv:1:4: axis Z is linear"),
    ("o.csv", "offset,X_mm,Y_mm,Z_mm\nG54,1,2,abc\n", None, r"o\.csv:2:4: 'abc' is not a finite number"),
    ("o.csv", "offset,X_mm,Y_mm,Z_mm\nG54,1,2,inf\n", None, r"o\.csv:2:4: 'inf' is not a finite number"),
    ("o.csv", "offset,X_mm,Y_mm,Z_mm\nG54,1,2,3\nG54,1,2,3\n", None, r"o\.csv:3: G54 is given twice"),
    ("o.csv", "offset,X_mm,Y_mm,Z_mm\nG60,1,2,3\n", None, r"o\.csv:2:1: 'G60' is not a work offset"),
    ("o.csv", "offset,X_mm,Y_mm,Z_mm\nG54,1,2\n", None, r"o\.csv:2: 3 fields, the header has 4"),
    ("v.var", "5221 1.0\n5222 2.0\n5223 3.0\n", None, r"v\.var: a LinuxCNC parameter file does not say its length unit"),
    ("v.var", "5221 1.0\n5222 2.0\n", "mm", r"v\.var: G54's axis Z \(parameter 5223\) is not in the file"),
    ("v.var", "5221 1.0\n5222 2.0\n5223 3.0\n5230 15\n", "mm", r"G54 is rotated by 15 deg"),
    ("f.txt", "G10 L2 P1 X1. Y2.\n", "mm", r"f\.txt:1: G54 gives no value for axis Z"),
    ("f.txt", "G10 L2 P1 X1. Y2. Z3. A4.\n", "mm", r"f\.txt:1: A is not an axis of the machine"),
    ("f.txt", "G1 X1. Y2. Z3.\n", "mm", r"f\.txt:1: 'G1 X1. Y2. Z3.' is not a work offset"),
    ("f.txt", "G10 L2 P1 X1000 Y2. Z3.\n", "mm", r"f\.txt:1:11: X1000 has no decimal point"),
])
def test_a_bad_table_is_refused_naming_file_and_line(machines, tmp_path, name, text, unit, message):
    m = machines["vmc500"]
    (tmp_path / name).write_text(text)
    with pytest.raises(GcodeError, match=message):
        read_work_offsets(tmp_path / name, list(m.axes), list(m.axis_kinds), unit=unit)


def test_a_table_too_large_is_refused_before_it_is_read(machines, tmp_path):
    m = machines["vmc500"]
    big = tmp_path / "o.csv"
    with open(big, "wb") as f:
        f.truncate(2 << 20)
    with pytest.raises(GcodeError, match="more than a work-offset table holds"):
        read_work_offsets(big, list(m.axes), list(m.axis_kinds))


# --- M codes, tapes and program numbers ------------------------------------------------------

HAAS_MILL = """%
O01000 (HAAS VF2 POST)
G00 G17 G40 G49 G80 G90
T1 M06
G00 G90 G54 X10. Y10. S5000 M03
G43 H01 Z50. M08
G187 P1
M10
G01 Z-5. F300.
X150. Y100.
M11
G00 Z50. M09
M30
%
"""


def test_machine_m_codes_that_move_no_axis_are_kept_in_fanuc_and_haas_programs(machines):
    m = machines["vmc500"]
    assert detect([(line, "\n") for line in HAAS_MILL.splitlines()])[0] == "haas"
    out, report = compensate_program(m, HAAS_MILL, origin=[0.1, 0.05, 0.2])
    assert report.dialect == "haas" and report.dialect_said.startswith("detected: line 7: G187 P1")
    assert report.moves == 5 and report.motion_compensated == 1.0
    for line in ("M10", "M11", "G187 P1", "%", "O01000 (HAAS VF2 POST)"):
        assert line in out.splitlines()
    # the same M10 in a LinuxCNC program is refused, as LinuxCNC refuses it
    with pytest.raises(GcodeError, match=r":8:1: M10 \(an M code this reader does not know\)"):
        compensate_program(m, HAAS_MILL.replace("G187 P1", "(G187)"), dialect="linuxcnc")
    # a code Haas's manual does not list is refused in a Haas program, naming the dialect
    with pytest.raises(GcodeError, match=r":8:1: M87 \(an M code this reader does not know in the Haas dialect\)"):
        compensate_program(m, HAAS_MILL.replace("M10", "M87"))
    # a FANUC builder's code is kept and named: FANUC leaves it to the builder
    fanuc = HAAS_MILL.replace("G187 P1", "M41").replace("(HAAS VF2 POST)", "(FANUC)")
    assert detect([(line, "\n") for line in fanuc.splitlines()]) is None   # (an O number LinuxCNC reads too)
    out, report = compensate_program(m, fanuc, origin=[0.1, 0.05, 0.2], dialect="fanuc")
    assert report.dialect == "fanuc" and report.moves == 5
    named = [w for w in report.warnings if "auxiliary function of the machine builder" in w]
    assert [w.split(":")[0] for w in named] == ["line 7", "line 8", "line 11"]


def test_tape_leaders_with_text_and_colon_program_numbers_are_fanuc_s(machines):
    m = machines["vmc500"]
    text = "% vfd enable\n:0097\nG21 G90 G54\nG0 X10. Y10. Z10.\nG1 X20. F100\nM30\n%\n"
    out, report = compensate_program(m, text)
    assert report.dialect == "fanuc" and report.moves == 2
    assert out.splitlines()[:2] == ["% vfd enable", ":0097"]
    assert len(interpret(m, "%O1200(PART)\nG0 X10. Y10. Z10.\nG1 X20. F100\nM30\n")) == 2
    with pytest.raises(GcodeError, match=r":1:3: text after '%'"):
        compensate_program(m, text, dialect="linuxcnc")


def test_a_whole_number_coordinate_of_a_fanuc_program_is_refused_not_read_as_millimetres(machines):
    """FANUC's standard input reads X10 as 10 least increments (0.010 mm): read as 10 mm it
    would be a thousand times off, so the reader asks for the decimal point."""
    m = machines["vmc500"]
    text = "O1\nG21 G90 G54\nG0 X0 Y0 Z10.\nG1 X10 F100\nM30\n"
    with pytest.raises(GcodeError, match=r"p\.nc:4:4: X10 has no decimal point: a FANUC control reads it as 10 least "
                                         r"input increments"):
        compensate_program(m, text, source="p.nc", dialect="fanuc")
    with pytest.raises(GcodeError, match=r"p\.nc:4:4: X10 has no decimal point"):
        interpret(m, text, "p.nc", dialect="haas")
    # zero is zero either way; feeds, sequence numbers and codes are whole numbers anyway
    out, report = compensate_program(m, text.replace("X10 ", "X10. "), source="p.nc", dialect="fanuc")
    assert report.moves == 2
    # the same program as LinuxCNC reads it: millimetres
    assert interpret(m, text, dialect="linuxcnc").w1[-1, 0] == pytest.approx(0.010)


# --- lathes ----------------------------------------------------------------------------------

LATHE = """%
O1200 (FANUC LATHE)
G18 G21 G40 G99
T0101
G50 S2000
G96 S180 M03
G00 X100. Z-5.
G01 Z-30. F0.2
X160. Z-60.
G00 X205. Z-5.
M30
%
"""


def test_a_fanuc_lathe_programs_x_as_a_diameter(machines):
    m = machines["lathe_2axis"]
    batch = interpret(m, LATHE)
    assert batch.dialect[0] == "fanuc"
    x = list(m.axes).index("X")
    np.testing.assert_allclose(batch.w1[:, x] / MM, [50, 50, 80, 102.5])
    out, report = compensate_program(m, LATHE)
    assert report.moves == 4
    # as LinuxCNC's diameter mode (G7) reads and writes it, which its own tests check against rs274
    as_g7, _ = compensate_program(m, LATHE.replace("G18 G21", "G7 G18 G21").replace("O1200 (FANUC LATHE)", ""),
                                  dialect="linuxcnc")
    assert [line for line in out.splitlines() if "X" in line and "FANUC" not in line] == [
        line for line in as_g7.splitlines() if "X" in line]
    # the written X words are diameters: twice the compensated radius
    written = interpret(m, out, dialect="fanuc")
    words = [float(v) for v in re.findall(r"X([-\d.]+)", out)]
    assert words[-1] == pytest.approx(2 * written.w1[-1, x] / MM, abs=2e-4)
    assert abs(words[-1] - 205) > 1e-3   # (compensated: the numbers moved)
    # the same program as LinuxCNC reads it: X205 is a radius beyond the 200 mm travel
    with pytest.raises(GcodeError, match="X205. takes axis X to 205 mm, outside the travel"):
        compensate_program(m, LATHE, dialect="linuxcnc")


def test_fanuc_lathe_cycles_and_incremental_words_are_kept_and_named(machines):
    m = machines["lathe_2axis"]
    text = ("O1\nG18 G21\nG0 X100. Z-5.\nG71 U2. R0.5\nG71 P10 Q20 U0.4 W0.1 F0.25\nN10 G0 X40.\nN20 G1 Z-30.\n"
            "G70 P10 Q20\nG90 X80. Z-20. F0.2\nX70.\nG0 X100. Z-5.\nG1 U-10. W-5.\nM30\n")
    out, report = compensate_program(m, text, dialect="fanuc")
    kept = " ".join(report.warnings)
    for what in ("lines 4-5: G71 (FANUC lathe stock removal in turning)",
                 "lines 6-7: in the profile N10 - N20 of the G71 (FANUC lathe stock removal in turning) of line 5",
                 "line 8: G70 (FANUC lathe finishing cycle)",
                 "line 9: G90 (FANUC lathe outer diameter cutting cycle)", "line 10: a block of the G90",
                 "line 12: U-10. (an incremental X of FANUC lathes"):
        assert what in kept
    # the profile, the cycles and the incremental words are as written; the moves after them compensated
    written = out.splitlines()
    assert written[3:10] + written[11:] == text.splitlines()[3:10] + text.splitlines()[11:]
    assert written[10] != "G0 X100. Z-5." and report.moves == 2


# --- other dialects: refused by name ----------------------------------------------------------

@pytest.mark.parametrize("text, message", [
    ("0 BEGIN PGM PART MM\n1 BLK FORM 0.1 Z X+0 Y+0 Z-20\n2 L X+10 Y+5 R0 FMAX\n3 END PGM PART MM\n",
     r"p\.nc:1: 0 BEGIN PGM PART MM, BEGIN PGM \(a HEIDENHAIN Klartext program\); HEIDENHAIN programs are not read"),
    ("; part\nG54\nDEF REAL DEPTH\nG0 X10 Y10 Z10\n",
     r"p\.nc:3: DEF REAL DEPTH: DEF \(a SINUMERIK variable definition\); SINUMERIK's own language is not read"),
    ("OPART\nVC1=10\nG0 X10\n", r"p\.nc:1: OPART, an OKUMA OSP construct; OKUMA OSP programs are not read"),
])
def test_programs_of_dialects_not_read_are_refused_naming_dialect_construct_and_line(machines, text, message):
    with pytest.raises(GcodeError, match=message):
        compensate_program(machines["vmc500"], text, source="p.nc")


def test_a_sinumerik_construct_in_an_iso_program_is_refused_by_name(machines):
    m = machines["vmc500"]
    text = "%_N_PART_MPF\nG54 G0 X10 Y10 Z10\nG1 X20 F100\nR1=5\nM30\n"
    with pytest.raises(GcodeError, match=r"p\.nc:4: R1=5: an R parameter assignment \(SINUMERIK\); SINUMERIK's own"):
        compensate_program(m, text, source="p.nc")
    out, report = compensate_program(m, text.replace("R1=5\n", ""))
    assert report.dialect == "siemens" and report.moves == 2


@pytest.mark.parametrize("lines, dialect", [
    (["O1000", "G0 X1"], None), ([":0097", "G0 X1"], "fanuc"), (["% leader", "G0 X1"], "fanuc"),
    (["G65 P9010 A1."], "fanuc"), (["G54.1 P2"], "fanuc"), (["IF [#1 GT 2] GOTO 10"], "fanuc"),
    (["WHILE [#1 LT 3] DO1"], "fanuc"), (["G50 S2000"], "fanuc"), (["o100 if [#1 GT 2]"], "linuxcnc"),
    (["%", "G0 X1", "%"], None),
    (["O1000", "G187 P1"], "haas"), (["O1000", "G154 P3"], "haas"), (["G0 X1", "M97 P100"], "haas"),
    (["o<sub> sub", "G0 X1"], "linuxcnc"), (["(debug, #1)"], "linuxcnc"), (["#<depth> = 3"], "linuxcnc"),
    (["%_N_PART_MPF"], "siemens"), (["G0 X1 ; DEF REAL X"], None), (["G0 X1", "G1 X2"], None),
    (["G65 P1", "o<sub> sub"], None), (["1 BEGIN PGM X MM"], "heidenhain"), (["(O1000)", "G0 X1"], None),
    (["G112 X1 C0"], None),
])
def test_a_dialect_is_detected_only_where_the_program_says_it(lines, dialect):
    found = detect([(line, "\n") for line in lines])
    assert (found and found[0]) == dialect


# --- the numbers' resolution ------------------------------------------------------------------

INCH_ARC = "G20 G90 G17\nG0 X6.0000 Y5.0000 Z3.0000\nG3 X5.7955 Y5.6061 I-1.0000 J0.0000 F10\nM2\n"


def test_an_arc_rounded_to_its_program_s_digits_is_read_as_its_controller_reads_it(machines, tmp_path):
    """A post rounding to four inch decimals leaves 2.25 um between the start and end radii
    (up to 2 sqrt(2) units of the last digit, 7.2 um): it was refused at the 2 um limit."""
    m = machines["vmc500"]
    out, report = compensate_program(m, INCH_ARC)
    assert report.arcs_kept == 1 and report.max_residual_um < 1.0
    # what rounding cannot explain still is refused: 3 um to four millimetre decimals ...
    with pytest.raises(GcodeError, match=r"differ by 3\.0 um, more than the 2\.00 um allowed"):
        compensate_program(m, "G21 G90 G17\nG0 X100 Y100 Z50\nG3 X0 Y200.0030 I-100 J0 F100\nM2\n")
    # ... and ten times the rounding in inch
    with pytest.raises(GcodeError, match=r"more than the 7\.18 um allowed"):
        compensate_program(m, INCH_ARC.replace("Y5.6061", "Y5.6071"))
    if RS274 is not None:   # LinuxCNC reads the program and its compensation alike
        for k, text in enumerate((INCH_ARC, out)):
            (tmp_path / f"a{k}.ngc").write_text(text)
            run = subprocess.run([RS274, "-g", str(tmp_path / f"a{k}.ngc"), str(tmp_path / f"a{k}.canon")],
                                 capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL, cwd=tmp_path)
            assert run.returncode == 0 and "ARC_FEED" in (tmp_path / f"a{k}.canon").read_text(), run.stdout


# --- LinuxCNC's own: definitions and messages ------------------------------------------------

MYSUB = ("o<mysub> sub\n#<depth> = [#1 / 10]\n(debug, depth #<depth> at #1)\nG0 X#1 Y10 Z50\n"
         "G1 Z[40 - #<depth>] F100\nG0 Z50\no<mysub> endsub\n#100 = 4712\n(debug, #100)\no<mysub> call [10]\nM2\n")


def _rs274(path, tmp_path):
    run = subprocess.run([RS274, "-g", str(path), str(tmp_path / "out.canon")], capture_output=True, text=True,
                         timeout=60, stdin=subprocess.DEVNULL, cwd=path.parent)
    assert run.returncode == 0, run.stdout + run.stderr
    return (tmp_path / "out.canon").read_text()


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's interpreter rs274 is not installed (Debian's linuxcnc-uspace)")
def test_a_compensated_subroutine_file_keeps_its_definition_and_prints_what_it_printed(machines, tmp_path):
    """A file that defines o<mysub> and calls it lost the definition in its output: a program
    of another file calling o<mysub> (LinuxCNC looks it up in mysub.ngc) then failed; and its
    debug messages printed 0 for the parameters whose settings the program as run leaves out."""
    m = machines["vmc500"]
    out, report = compensate_program(m, "G21 G90 G0 X0 Y10 Z50\n" + MYSUB)
    assert report.moves >= 3
    folder = tmp_path / "compensated"
    folder.mkdir()
    (folder / "mysub.ngc").write_text(out)
    (tmp_path / "mysub.ngc").write_text("G21 G90 G0 X0 Y10 Z50\n" + MYSUB)
    printed = [re.findall(r"MESSAGE\((.*)\)", _rs274(path, tmp_path)) for path in (tmp_path / "mysub.ngc",
                                                                                    folder / "mysub.ngc")]
    assert printed[0] == printed[1] == ['" 4712.000000"', '" depth 1.000000 at 10.000000"']
    # another program calls it from its file, as LinuxCNC finds it
    (folder / "caller.ngc").write_text("G21 G90\no<mysub> call [20]\nM2\n")
    feeds = re.findall(r"STRAIGHT_FEED\(([-\d.]+), ([-\d.]+), ([-\d.]+)", _rs274(folder / "caller.ngc", tmp_path))
    assert [tuple(map(float, f)) for f in feeds] == [(20, 10, 38)]


ZIG = "o<zig> sub\nG1 X#1 Y10 F300\nG1 X#1 Y#2\nG1 X[#1 + 20] Y#2\no<zig> endsub\nM2\n"
MAIN = "G21 G90 G17\nG0 X10 Y10 Z50\no<zig> call [100] [60]\no<zig> call [200] [80]\nG1 X10 Y10\nM2\n"


def test_a_subroutine_in_a_file_beside_the_program_is_followed(machines, tmp_path):
    """``o<zig> call`` of zig.ngc beside the program: LinuxCNC runs zig.ngc's blocks there; they
    were passed uncompensated (LinuxCNC's rcone.ngc: 9,009 moves). They are now followed where
    they run; rs274, reading the program in its folder, makes the same moves."""
    m = machines["vmc500"]
    (tmp_path / "zig.ngc").write_text(ZIG)
    (tmp_path / "main.ngc").write_text(MAIN)
    out, report = compensate_program(m, MAIN, source="main.ngc", subroutines=tmp_path)
    assert report.moves == 1 + 6 + 1 and report.moves_kept == 0 and "call" not in out
    batch = interpret(m, MAIN, "main.ngc", subroutines=tmp_path)
    assert list(batch.line) == [2, 3, 3, 3, 4, 4, 4, 5]   # each block at the call it runs from
    if RS274 is not None:
        canon = _rs274(tmp_path / "main.ngc", tmp_path)
        feeds = [tuple(map(float, f)) for f in re.findall(r"STRAIGHT_FEED\(([-\d.]+), ([-\d.]+), ([-\d.]+)", canon)]
        np.testing.assert_allclose(batch.w1[1:] / MM, feeds)
    # without the folder the calls are kept, and named
    out, report = compensate_program(m, MAIN, source="main.ngc")
    assert report.moves_kept == 2 and any("o<zig> is not defined in this program" in w for w in report.warnings)
    # an error in the file names the file's line and the program's call
    (tmp_path / "zig.ngc").write_text(ZIG.replace("G1 X#1 Y#2", "G1 X[#1 / 0] Y#2"))
    with pytest.raises(GcodeError, match=r"main\.ngc:3:.*in o<zig> \(zig\.ngc:3\).*division by zero"):
        compensate_program(m, MAIN, source="main.ngc", subroutines=tmp_path)


@pytest.mark.parametrize("call, make, message", [
    ("o<../zig> call", None, r"main\.ngc:3: o<\.\./zig> call: .* no plain file name"),
    ("o<link> call", "link", r"main\.ngc:3: o<link> call: .* leads outside"),
    ("o<big> call", "big", r"big\.ngc: .* more than a subroutine file"),
    ("o<nosub> call", "nosub", r"nosub\.ngc: no o<nosub> sub \.\.\. o<nosub> endsub in it"),
])
def test_a_hostile_subroutine_file_is_refused_naming_it(machines, tmp_path, call, make, message):
    folder = tmp_path / "programs"
    folder.mkdir()
    (tmp_path / "outside.ngc").write_text(ZIG.replace("zig", "link"))
    if make == "link":
        (folder / "link.ngc").symlink_to(tmp_path / "outside.ngc")
    elif make == "big":
        with open(folder / "big.ngc", "wb") as f:
            f.truncate(17 << 20)
    elif make == "nosub":
        (folder / "nosub.ngc").write_text("G0 X1\nM2\n")
    with pytest.raises(GcodeError, match=message):
        compensate_program(machines["vmc500"], MAIN.replace("o<zig> call [100] [60]", call), source="main.ngc",
                           subroutines=folder)


def test_sinumerik_statements_that_move_nothing_stand_beside_the_words(machines):
    m = machines["vmc500"]
    text = ('%_N_P_MPF\nN10 G17 G90 G710 G500\nN20 T="MILL_10" M6\nN30 CYCLE832(0.01,_ORI_ROUGH,1)\n'
            "N40 G54 G642 SOFT FFWON\nN50 G0 X10 Y10 Z50\nN60 G1 Z-2 F500 COMPCAD ; plunge\nN70 X100 Y50\nN80 M30\n")
    out, report = compensate_program(m, text, origin=[0.1, 0.1, 0.3])
    assert report.dialect == "siemens" and report.moves == 3 and report.passed_through == 0
    lines = out.splitlines()
    assert lines[:5] == text.splitlines()[:5]
    assert re.fullmatch(r"N60 G1 Z-2\.00\d\d X9\.99\d\d Y10\.00\d\d F500 COMPCAD ; plunge", lines[6]), lines[6]
    # G500 is no settable offset (zero); the first offset selected after it takes the origin given
    batch = interpret(m, text, origin=[0.1, 0.1, 0.3])
    np.testing.assert_allclose(batch.w1[-1] / MM, [200, 150, 298])
    # what moves or changes frames is refused, naming it
    with pytest.raises(GcodeError, match=r"p\.nc:4: N30 CYCLE800\(.*CYCLE800 \(SINUMERIK's swivel"):
        compensate_program(m, text.replace("CYCLE832(0.01,_ORI_ROUGH,1)", "CYCLE800(1,\"TC1\",0,57,0,30,0)"),
                           source="p.nc", origin=[0.1, 0.1, 0.3])


# --- a review's findings ------------------------------------------------------------------------

def test_what_a_review_found_in_the_offsets_is_read_as_the_controllers_read_it(machines, tmp_path):
    m = machines["vmc500"]
    # Haas's G154 Pn is selectable (its P was refused), from a G10 L20 or a FANUC table's G54.1 Pn
    text = "G20 G90\nG10 L20 P3 X1. Y1. Z1.\nG154 P3\nG0 X0 Y0 Z0\nM30\n"
    np.testing.assert_allclose(interpret(m, text, dialect="haas").w1[0] / MM, [25.4] * 3)
    table = {"G54.1 P3": np.array([0.1, 0.1, 0.1])}
    np.testing.assert_allclose(interpret(m, "G154 P3 G0 X0. Y0. Z0.\n", dialect="haas", work_offsets=table).w1[0]
                               / MM, [100] * 3)
    # M72 restores the work offset M70 saved, as rs274 does
    restored = "G10 L2 P2 X100 Y100 Z100\nG54 G0 X1 Y1 Z1\nM70\nG55 G0 X2 Y2 Z2\nM72\nG1 X3 Y3 Z3 F100\nM2\n"
    np.testing.assert_allclose(interpret(m, restored, dialect="linuxcnc").w1[-1] / MM, [3, 3, 3])
    # FANUC's external offset moves every work offset, the one in force included
    ext = "G21 G90\nG10 L2 P0 X10. Y10. Z10.\nG0 X0 Y0 Z0\nG54 G0 X0 Y0 Z0\nM30\n"
    np.testing.assert_allclose(interpret(m, ext, dialect="fanuc").w1 / MM, [[10] * 3, [10] * 3])
    # FANUC's G54.1 alone is G54.1 P1
    bare = "G21 G90\nG10 L20 P1 X100. Y50. Z20.\nG54.1 G0 X0 Y0 Z0\nM30\n"
    np.testing.assert_allclose(interpret(m, bare, dialect="fanuc").w1[0] / MM, [100, 50, 20])
    # a G20 in the G10's own block sets its units
    units = "G21 G90\nG20 G10 L2 P2 X1 Y1 Z1\nG55 G0 X0 Y0 Z0\nM2\n"
    np.testing.assert_allclose(interpret(m, units, dialect="linuxcnc").w1[0] / MM, [25.4] * 3)


def test_what_a_review_found_in_the_messages_and_the_decimal_points(machines):
    m = machines["vmc500"]
    # a message reading what only the machine knows leaves the program's parameters followed
    text = "#1=2.5\nG0 X#1 Y1 Z1\n(debug, at X=#5420 and #<_zz>)\nG1 X[#1*2] F100\nM2\n"
    out, report = compensate_program(m, text, dialect="linuxcnc")
    assert report.expanded is not None and report.moves == 2
    assert "(debug, at X=#5420 and #<_zz>)" in out
    # FANUC: a variable's value is no count of increments; a cycle's K and a G73's R are counts
    compensate_program(m, "G21 G90\n#100=50.\nG0 X#100 Y10. Z10.\nG1 X100. F100.\nM30\n", dialect="fanuc")
    compensate_program(m, "G21 G90\nG0 X100. Y100. Z50.\nG91 G81 X10. Z-5. R-45. K3 F100.\nG80\nM30\n",
                       dialect="fanuc")
    # ... but a whole number in an arc's centre is refused as in its end
    with pytest.raises(GcodeError, match=r":3:14: I5 has no decimal point"):
        compensate_program(m, "G21 G90\nG0 X10. Y10. Z10.\nG2 X20. Y10. I5 J0\nM30\n", dialect="fanuc")
    # an arc's radii may differ by its numbers' rounding, up to what four inch decimals make
    with pytest.raises(GcodeError, match=r"differ by 200\.0 um, more than the 7\.18 um allowed"):
        compensate_program(m, "G21 G90\nG0 X10. Y10. Z10.\nG2 X20.2 Y10. I5. J0.\nM2\n", dialect="linuxcnc")


def test_what_a_review_found_in_the_tables(machines, tmp_path):
    m = machines["vmc500"]
    axes, kinds = list(m.axes), list(m.axis_kinds)
    (tmp_path / "bom.csv").write_text("\ufeffoffset,X_mm,Y_mm,Z_mm\nG54,1,2,3\n", encoding="utf-8")
    np.testing.assert_allclose(read_work_offsets(tmp_path / "bom.csv", axes, kinds)["G54"], [1e-3, 2e-3, 3e-3])
    (tmp_path / "twice.txt").write_text("G10 L2 P1 X1. X2. Y1. Z1.\n")
    with pytest.raises(GcodeError, match=r"twice\.txt:1:.*X appears twice"):
        read_work_offsets(tmp_path / "twice.txt", axes, kinds, unit="mm")
    (tmp_path / "inc.txt").write_text("G91 G10 L2 P1 X1. Y1. Z1.\n")
    with pytest.raises(GcodeError, match=r"inc\.txt:1: G91"):
        read_work_offsets(tmp_path / "inc.txt", axes, kinds, unit="mm")
    with pytest.raises(GcodeError, match="not a regular file"):
        read_work_offsets("/dev/zero", axes, kinds)
    # a table without G54 says so
    _, report = compensate_program(m, "G0 X1 Y2 Z3\n", work_offsets={"G55": np.zeros(3)})
    assert any("gives no G54" in w for w in report.warnings)
