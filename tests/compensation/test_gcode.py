"""NC programs: parsing, byte-for-byte preservation, round trips through the model."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from scipy.spatial import cKDTree

from volerr_pin.compensation.gcode import GcodeError, compensate_program, interpret

PROGRAM_500 = """%
O1001 (test program)
N10 G21 G90 G17 (metric, absolute)
N20 T1 M6 ; tool change
N30 S8000 M3
N40 G0 X50 Y50 Z100
N50 G1 Z50 F500
N60 G1 X300 Y200 (long diagonal)
N70 G2 X400 Y100 I100 J0
N80 G3 X300 Y10 R100 F300

N90 G18 G2 X350 Z50 I25 K0
N100 G19 G2 Y60 Z100 J50 K0
N110 G17 G91 G1 X-50 Y20
N120 X-50
N125 Y-10.5 Z-20
N130 G90 G20 G1 X5.0 Y3.0 Z2.0
N135 G2 X6.0 Y4.0 I0.5 J0.5
N140 G21 M5
N150 M30
%
"""

PROGRAM_700 = """N10 G21 G90 G17
N20 T2 M6
N30 S6000 M3
N40 G0 X10 Y10 Z10
N50 G1 X680 Y240 Z190 F800
N60 G0 X500 Y10 Z50
N70 G3 X100 Y30 Z150 I-200 J10
N80 G18 G2 X150 Z100 R50
N90 G19 G91 G3 Y20 Z20 J20 K0
N100 G90 G17 G1 X300 Y100
N110 G20 X10. Y5. Z3.
N120 M30
"""

PROGRAM_CGM = """(5-axis head)
N10 G21 G90
N20 G0 X1000 Y800 Z300 A0 B0
N30 G1 X2500 Y1500 Z400 A30 B45 F2000
N40 G1 X3000 Y1000 Z200 A-60 B-60
N50 G1 Y2000 A10
N60 M30
"""


def _project(p, P, A):
    """Distance of points p to the polyline P, and the polyline's tool axis A there."""
    i = cKDTree(P).query(p)[1]
    best = np.full(len(p), np.inf)
    axis = np.zeros_like(p)
    for a, b in ((np.maximum(i - 1, 0), i), (i, np.minimum(i + 1, len(P) - 1))):
        d = P[b] - P[a]
        t = np.clip(((p - P[a]) * d).sum(1) / np.maximum((d * d).sum(1), 1e-30), 0, 1)
        dist = np.linalg.norm(P[a] + t[:, None] * d - p, axis=1)
        better = dist < best
        best = np.where(better, dist, best)
        axis[better] = (A[a] + t[:, None] * (A[b] - A[a]))[better]
    return best, axis / np.linalg.norm(axis, axis=1)[:, None]


def round_trip(m, original, compensated, samples=250):
    """Simulate the compensated program with the model: every sampled point of every
    interpolated move against the desired (nominal) original path, move by move."""
    orig, comp = interpret(m, original), interpret(m, compensated)
    idx, worst_pos, worst_axis = 0, 0.0, 0.0
    for seg in comp:
        o = orig[idx]
        pts = seg.end[None, :] if seg.kind == "rapid" else seg.sample(samples)
        R, p = m.tool_poses(pts, extrapolate=True)
        dense = o.end[None, :] if o.kind == "rapid" else o.sample(5000)
        R_d, p_d = m.tool_poses(dense, nominal=True)
        dist, axis = _project(p, p_d, R_d[:, :, 2])
        worst_pos = max(worst_pos, dist.max())
        worst_axis = max(worst_axis, np.linalg.norm(np.cross(R[:, :, 2], axis), axis=1).max())
        if np.linalg.norm(p[-1] - p_d[-1]) < 2e-6:  # this output move ends the original one
            idx += 1
    assert idx == len(orig), "the compensated program does not reach every original end point"
    return worst_pos, worst_axis


def _uncompensated_error(m, text):
    """Largest tool position and tool-axis error along the program run uncompensated."""
    pos = axis = 0.0
    for seg in interpret(m, text):
        q = seg.end[None, :] if seg.kind == "rapid" else seg.sample(400)
        R, p = m.tool_poses(q)
        R_d, p_d = m.tool_poses(q, nominal=True)
        pos = max(pos, np.linalg.norm(p - p_d, axis=1).max())
        axis = max(axis, np.linalg.norm(np.cross(R[:, :, 2], R_d[:, :, 2]), axis=1).max())
    return pos, axis


@pytest.mark.parametrize("name, program", [("vmc500", PROGRAM_500), ("vmc700", PROGRAM_700)])
@pytest.mark.parametrize("tol", [1.0, 3.0])
def test_round_trip_within_tolerance(machines, name, program, tol):
    m = machines[name]
    out, report = compensate_program(m, program, tol_um=tol)
    pos, _ = round_trip(m, program, out)
    assert _uncompensated_error(m, program)[0] > 5 * tol * 1e-6  # the check can fail
    assert pos <= tol * 1e-6
    assert report.max_residual_um <= tol
    assert report.max_before_um > 5 * tol
    assert report.arcs_as_lines == 0
    assert report.arcs_kept == len([s for s in interpret(m, program) if s.kind == "arc"]) >= 3


def test_round_trip_cgm4000_position_and_tool_axis(machines):
    m = machines["cgm4000"]
    out, report = compensate_program(m, PROGRAM_CGM, tol_um=1.0, tol_urad=5.0)
    pos, axis = round_trip(m, PROGRAM_CGM, out)
    before_pos, before_axis = _uncompensated_error(m, PROGRAM_CGM)
    assert before_pos > 10e-6 and before_axis > 20e-6
    assert pos <= 1.0e-6 and axis <= 5.0e-6
    assert not [w for w in report.warnings if "residual stays" in w]


def test_singular_pose_is_reported_not_hidden(machines):
    """At B = -90 deg the A axis of cgm4000's head is parallel to the tool: the tool axis
    has one free direction less and cannot be corrected; the report says so."""
    m = machines["cgm4000"]
    program = "G90 G0 X1000 Y800 Z300 A0 B0\nG1 X3000 Y1000 Z200 A-60 B-90 F1000\nG1 Y2000 A10\n"
    out, report = compensate_program(m, program)
    limited = [w for w in report.warnings if "residual stays" in w]
    assert limited and report.max_residual_um > 1.0
    assert report.blocks_out < 60  # no runaway splitting


def _strip(text):
    """Remove coordinate and centre words: what must be byte-identical is left."""
    return [re.sub(r" ?[XYZABCIJKR][-+]?(?:\d+\.?\d*|\.\d+)", "", line) for line in text.splitlines()]


@pytest.mark.parametrize("name, program", [("vmc500", PROGRAM_500), ("vmc700", PROGRAM_700)])
def test_non_coordinate_content_is_identical(machines, name, program):
    m = machines[name]
    out, report = compensate_program(m, program)
    assert out.endswith("\n") and out.count("\n") == report.blocks_out
    lines = out.splitlines()
    # the inserted pieces are complete new blocks with a motion word; drop them
    kept = [line for line in lines if not re.match(r"^G[0-3] [XYZ]", line)]
    assert len(kept) == report.blocks_in == len(program.splitlines())
    assert _strip("\n".join(kept)) == _strip(program)
    # and the original coordinates are what was compensated: no word lost
    for a, b in zip(program.splitlines(), kept):
        words_a = set(re.findall(r"[XYZIJKR](?=[-+.\d])", a))
        words_b = set(re.findall(r"[XYZIJKR](?=[-+.\d])", b))
        assert words_a <= words_b


def test_crlf_and_whitespace_are_preserved(machines):
    m = machines["vmc500"]
    program = "N1 G90 G21\r\nN2 G0   X50 Y50 Z100 ( spaced )\r\n\r\nN3 G1 X60 F100\r\n"
    out, _ = compensate_program(m, program)
    assert out.count("\r\n") == out.count("\n")
    assert "( spaced )" in out and "N2 G0   X" in out


def test_arcs_stay_valid(machines):
    m = machines["vmc500"]
    out, _ = compensate_program(m, PROGRAM_500)
    arcs = [s for s in interpret(m, out) if s.kind == "arc"]
    assert len(arcs) >= 6
    for seg in arcs:
        i, j, _ = seg.arc.plane
        r0 = math.hypot(seg.start[i] - seg.arc.center[0], seg.start[j] - seg.arc.center[1])
        r1 = math.hypot(seg.end[i] - seg.arc.center[0], seg.end[j] - seg.arc.center[1])
        assert abs(r0 - r1) < 0.5e-6


def test_incremental_sections_do_not_accumulate_rounding(machines):
    m = machines["vmc500"]
    program = "G90 G21 G0 X100 Y100 Z100\nG91 G1 F1000\n" + "X0.7 Y0.3 Z0.1\n" * 120 + "G90\n"
    out, _ = compensate_program(m, program, tol_um=1.0)
    pos, _ = round_trip(m, program, out)
    assert pos <= 1.0e-6


@pytest.mark.parametrize("text, line, message", [
    ("G90 G0 X10 Y10 Z10\nG1 X20 Y\n", 2, "'Y' is not followed by a number"),
    ("G90 G0 X10 Y10 Z10\nG1 X2$0\n", 2, r"cannot read '\$'"),
    ("G90 G0 X10 Y10 Z10\n(open comment\nG1 X20\n", 2, "parenthesis"),
    ("G90 G0 X10 Y10 Z10\nG1 X20\nG2 X30 Y10\n", 3, "I/J or R"),
    ("G90 G0 X10 Y10 Z10\nG2 X30 Y10 R5\n", 2, "cannot join"),
    ("G90 G0 X10 Y10 Z10\nG2 X30 Y10 I5 J0\n", 2, "radius"),
    ("G90 G21\nX20\n", 2, "motion mode"),
    ("G90 G0 X10 Y10 Z10\n\nG1 X900\n", 3, "outside the travel"),
    ("G90 G0 X10 Y10 Z10\nG81 X20 Y20 Z-5 R2 F100\n", 2, "canned cycle"),
    ("G90 G0 X10 Y10 Z10\n#1 = 5\n", 2, "macro"),
    ("G90 G0 X10 Y10 Z10\nM98 P100\n", 2, "subprogram"),
    ("G90 G0 X10 Y10 Z10\nWHILE [1 LT 2] DO1\n", 2, "macro"),
    ("G90 G0 X10 Y10 Z10\n#5221 = -50.\n", 2, "system variable #5221"),
    ("G2 X10 Y10 I5 J5\n", 1, "arc from an unknown position"),
    ("G90 G0 X450 Y200 Z10\nG3 X450 Y200 I0 J100\n", 2, "leaves the travel"),
])
def test_malformed_programs_fail_with_the_line_number(machines, text, line, message):
    """Blocks that cannot be read, and (with strict) blocks that cannot be compensated."""
    with pytest.raises(GcodeError, match=rf"prog\.nc:{line}:(\d+:)? .*{message}"):
        compensate_program(machines["vmc500"], text, source="prog.nc", strict=True, dialect="linuxcnc")


START = "G90 G21 G17 G0 X100 Y100 Z100\n"


@pytest.mark.parametrize("block, where, message", [
    # the cases of the issue
    ("G2 X200 Y100 R50 I30 J0 F100", "2:14", "R50 and I30 J0 disagree: their centres are 20.0000 mm apart"),
    ("G1 X200 X300", "2:9", r"X appears twice in the block \(X200 and X300\)"),
    ("G0 G1 X200", "2:4", "G0 and G1 in one block: both are motion codes"),
    ("G77 X200", "2", r"G77 \(a G code this reader does not know\) cannot be compensated \(strict refuses it"),
    ("G77", "2", "G77 .*cannot be compensated"),
    ("G1 X1E300 Z100.0009E300", "2:4", "'X1E300': NC numbers have no exponent"),
    ("G1 X150 Z100.0009E300", "2:9", "'Z100.0009E300': NC numbers have no exponent"),
    ("G2 X100.0001 Y100 R0.00005", "2:19", r"degenerate arc \(R0.00005\)"),
    ("G2 X100.0001 Y100 I0.00005 J0", "2", r"degenerate arc \(I0.00005 J0\): its radius 5e-05 mm"),
    ("G2 X100 Y100 I0 J0", "2", r"degenerate arc \(I0 J0\): its radius 0 mm is zero"),
    ("G2 X200 Y100 R0", "2:14", r"degenerate arc \(R0\)"),
    # words and numbers
    ("G1 X", "2:4", "'X' is not followed by a number$"),
    ("G1 X1.2.3", "2:8", "'X1.2.3' is not a number"),
    ("G1 X--5", "2:4", r"'X' is not followed by a number \('X--5'\)"),
    ("G1 X+-5", "2:4", "'X' is not followed by a number"),
    ("G1 X - 5", "2:4", "'X' is not followed by a number"),
    ("G1 X1 0", "2:7", "a number without an address letter .*blanks do not join digits"),
    ("G1 X10 )", "2:8", r"unbalanced parenthesis: '\)' without '\('"),
    ("G1 X10 (a (b) c)", "2:11", "comments do not nest"),
    ("G1 X10 (open", "2:8", "not closed"),
    ("G1 X1" + "0" * 400, "2:4", "too large a number"),
    ("G1 X99999999999999999999", "2:4", "outside the travel"),
    ("G1 Xnan", "2:4", "not followed by a number"),
    ("G1 XINF", "2:4", "not followed by a number"),
    ("G1 X150 Y120 \u00e9", "2:14", r"U\+00E9 .*not an ASCII character"),
    ("G1 X\u0661\u0665\u0660", "2:4", "not followed by a number"),
    ("G1 X\u2212150", "2:4", "not followed by a number"),
    ("G1 X150\u00a0Y120", "2:8", r"U\+00A0.*not an ASCII character"),
    ("G1 X2\u200b00", "2:6", r"U\+200B"),
    ("G1 X150\x00", "2:8", r"cannot read U\+0000"),
    ("G1 X150\f", "2:8", r"cannot read U\+000C"),
    ("G1 X150\rG1 X160", "2:8", r"carriage return \(CR\) inside a line"),
    ("G1 X150 %", "2:9", "a '%' must stand on its own line"),
    ("%abc", "2:2", "text after '%'"),
    ("G1 X150 /Y120", "2:9", "a block delete '/' must begin the block"),
    # codes
    ("N10.5 G1 X150", "2:1", "N10.5: an N word is a whole number"),
    ("N-10 G1 X150", "2:1", "N-10: an N word has no sign"),
    ("G1 N10 X150", "2:4", "N10: a sequence number begins its block"),
    ("N10 N20 G1 X150", "2:5", "N20: a sequence number begins its block"),
    ("O1234 G1 X150", "2:1", "O1234: a program number stands alone"),
    ("G+1 X150", "2:1", "G\\+1: a G word has no sign"),
    ("G-1 X150", "2", "G-1 .*does not know"),
    ("G1.5 X150", "2", "G1.5 .*does not know"),
    ("G1000000000000000000000 X150", "2:1", "G1000000000000000000000 is not a G code"),
    ("G 1234 X150", "2:1", "G1234 is not a G code"),
    ("G16", "2", r"G16 \(polar coordinates\) cannot be compensated"),
    ("G68.2 X0 Y0 Z0 I0 J45 K0", "2", r"G68.2 \(tilted working plane\) cannot be compensated"),
    ("G12.1", "2", r"G12.1 \(polar interpolation\) cannot be compensated"),
    ("G43.5 H1", "2", r"G43.5 \(tool orientation given as a vector\) cannot be compensated"),
    ("G1 G1 X150", "2:4", "G1 appears twice"),
    ("G90 G91 G1 X150", "2:5", "G90 and G91 in one block: both are distance codes"),
    ("G17 G18 G2 X200 Y100 I50 J0", "2:5", "G17 and G18 in one block: both are plane codes"),
    ("G20 G21 G1 X150", "2:5", "G20 and G21 in one block: both are units codes"),
    ("G2 G3 X200 Y100 I50 J0", "2:4", "G2 and G3 in one block"),
    ("G1 X200 G4", "2:1", "G1 and G4 \\(dwell\\) in one block without P"),
    ("G4 P1 G2 X200 Y100 R60", "2:7", "G2 and G4 \\(dwell\\) in one block: P would be both the dwell time and "
                                      "the arc's turns"),
    ("G4 Y10", "2:4", r"Y10 in a dwell \(G4\)"),
    ("M3 M4", "2:4", "M3 and M4 in one block: both are spindle codes"),
    ("M3 M3", "2:4", "M3 appears twice"),
    ("M1.5", "2:1", "M1.5: an M word is a whole number"),
    ("T1.5 M6", "2:1", "T1.5: a T word is a whole number"),
    ("G1 X150 F-100", "2:9", "F-100: an F word has no sign"),
    ("G1 X150 S-100", "2:9", "S-100: an S word has no sign"),
    ("G1 X150 F100 F200", "2:14", r"F appears twice in the block \(F100 and F200\)"),
    # words that mean nothing here
    ("G1 X150 A10", "2:9", "A10: vmc500 has no axis A"),
    ("G1 X150 U10", "2:9", "U10: vmc500 has no axis U"),
    ("G1 X150 R2", "2:9", r"R2: R on a straight move \(G1\).*corner rounding"),
    ("G1 X150 I2", "2:9", "I2: I on a straight move"),
    ("I2", "2:1", "I2: I outside an arc move"),
    ("G2 R50", "2:4", "R50: an arc without end point words: only a full circle may leave them out"),
    ("G1 X150 P2", "2:9", "P2: P words mean nothing this reader knows here"),
    ("G1 X150 Q2", "2:9", "Q2: Q words mean nothing"),
    ("G1 X150 L2", "2:9", "L2: L words mean nothing"),
    ("G1 X150 E5", "2:9", "E5: E words mean nothing"),
    ("G1 X150 E-5", "2:9", "E-5: E words mean nothing"),
    # arcs
    ("G2 X200 Y110 I50 J0", "2", "end radius 50.9902 mm differ by 990.2 um"),
    ("G2 X200 Y100.01 R50", "2:17", "R50 cannot join these end points: the end points are 100.0000 mm apart"),
    ("G2 X100 Y100 R50", "2:14", "R cannot program a full circle"),
    ("G2 X200 Y100 I200000 J0", "2:14", "I200000: an arc radius or centre offset over 100 m"),
    ("G2 X200 Y100 I50 J0 P0", "2:21", "P0 on an arc must be a whole number of turns from 1 to 1000"),
    ("G2 X200 Y100 I50 J0 P1.5", "2:21", "P1.5 on an arc"),
    ("G2 X200 Y100 I50 J0 P1000000000", "2:21", "P1000000000 on an arc"),
    ("G2 X200 Y100 I1e6 J0", "2:14", "'I1e6': NC numbers have no exponent"),
    # program structure
    ("G54 G1 X150\nG55 G1 X160", "3", r"G55 changes the work offset from G54 \(line 2\)"),
    ("G54.1 P1 G1 X150\nG54.1 P2 G1 X160", "3", "G54.1 P2 changes the work offset from G54.1 P1"),
    ("M6\nG91 G1 X10", "3:8", "an incremental move of X before its position is known"),
    ("O1\nG1 X150\nO2", "4", r"O2 \(a second program number: the start of a subprogram\)"),
    ("/G91", "2", r"G codes with block delete \(/\)"),
    ("/G1 X150", "2", r"a move with block delete \(/\)"),
])
def test_bad_blocks_are_refused_naming_line_and_column(machines, block, where, message):
    """Each used to be read as something else (or its error named no column): now one error
    naming the line (and the column where a character or word is to blame); blocks that can be
    read but not compensated are refused with strict."""
    with pytest.raises(GcodeError, match=rf"^prog\.nc:{where}: .*{message}"):
        compensate_program(machines["vmc500"], START + block + "\n", source="prog.nc", strict=True, dialect="linuxcnc")


def test_pass_through_keeps_unsupported_blocks_and_warns(machines):
    m = machines["vmc500"]
    program = "G90 G0 X10 Y10 Z10\nG81 X20 Y20 Z5 R12 F100\nG80\nM98 P100\nG1 X30 Y30\n"
    out, report = compensate_program(m, program, pass_through=True)
    lines = out.splitlines()
    assert lines[1] == "G81 X20 Y20 Z5 R12 F100" and lines[2] == "G80" and lines[3] == "M98 P100"
    # G80 only cancels the cycle: nothing to keep unchanged there
    assert [w.split(":")[0] for w in report.warnings if "kept unchanged" in w] == ["line 2", "line 4"]
    assert report.blocks_in == 5
    # after a block that moved the machine out of our sight the next move is end point only
    assert any(w.startswith("line 5: the position before this move is not known") for w in report.warnings)


def test_report_fields(machines):
    out, report = compensate_program(machines["vmc700"], PROGRAM_700)
    d = report.to_dict()
    for key in ("blocks_in", "blocks_out", "max_residual_um", "tolerance_um", "warnings"):
        assert key in d
    assert d["blocks_in"] == 12 and d["blocks_out"] > d["blocks_in"]
    assert d["blocks_out"] == len(out.splitlines())
    assert any("not known" in w for w in d["warnings"])


def test_full_circles_and_modal_arcs(machines):
    m = machines["vmc500"]
    program = ("G90 G21 G17\nG0 X200 Y200 Z100\nG1 Z50 F300\nG2 X200 Y200 I50 J0\nX200 Y200 I0 J50\n"
               "G3 X250 Y250 R50\nY300 X300 R50\nM30\n")
    out, report = compensate_program(m, program)
    pos, _ = round_trip(m, program, out)
    assert pos <= 1e-6
    assert report.arcs_kept == 4 and report.arcs_as_lines == 0
    assert report.pieces <= 16  # a full circle is four quarter arcs, not a thousand lines
    # the block relying on the modal G2 still carries no motion word and is still an arc
    assert [s.kind for s in interpret(m, out)].count("arc") >= 10


def test_an_arc_piece_written_as_a_line_drops_its_centre_words(machines):
    """When a compensated arc piece is a straight line (three collinear compensated points),
    the block becomes G1 and loses I/J without leaving gaps; a following modal arc block
    gets its G2 back."""
    from volerr_pin.compensation import Piece
    from volerr_pin.compensation.gcode import Program, parse_block

    m = machines["vmc500"]
    writer = Program(m).writer
    block = parse_block("N5 G2 X110 Y100 I5 J0 F200 (arc)", 5, "p")
    coords = [w for w in block.words if w.letter in "XY"]
    piece = Piece("line", np.array([0.1, 0.1, 0.05]), np.array([0.11, 0.1, 0.05]))
    st = {"absolute": True, "inch": False, "plane": 17, "out_motion": 2}
    text = writer.rewrite(block, piece, piece.start, st, 2, coords)
    assert text == "N5 G1 X110.0000 Y100.0000 Z50.0000 F200 (arc)"
    assert st["out_motion"] == 1
    arc_piece = Piece("arc", np.array([0.11, 0.1, 0.05]), np.array([0.12, 0.1, 0.05]),
                      center=np.array([0.115, 0.1]), clockwise=True, turns=-math.pi)
    follow = parse_block("X120 Y100 I5 J0", 6, "p")
    text = writer.rewrite(follow, arc_piece, arc_piece.start, st, 2, [w for w in follow.words if w.letter in "XY"])
    assert text.startswith("G2 X120.0000 Y100.0000") and "I5.0000 J0.0000" in text


def test_review_cases(machines):
    """Cases a review found: each used to write a wrong program."""
    m = machines["vmc500"]
    # last line without a newline: the pieces of its split move are still separate blocks
    out, _ = compensate_program(m, "G90 G0 X10 Y10 Z10\nG1 X450 Y390 Z390 F300")
    assert not out.endswith("\n") and out.count("\n") >= 2 and all(line.count("X") == 1 for line in out.splitlines())
    # a first move naming some axes does not command the others
    out, report = compensate_program(m, "G90 G21\nG0 Z350\nG0 X100 Y100\n")
    assert out.splitlines()[1].startswith("G0 Z") and "X" not in out.splitlines()[1]
    assert "taking the unprogrammed axes at mid-travel" in report.warnings[0]
    # G4's X is a dwell time; G10/G28/G53 are not moves of the program
    out, _ = compensate_program(m, "G90 G0 X10 Y10 Z10\nG4 X1.5\nG1 Y100 F100\n")
    assert out.splitlines()[1] == "G4 X1.5" and abs(float(re.search(r"X([-\d.]+)", out.splitlines()[2]).group(1)) - 10) < 0.01
    for block in ("G10 L20 P1 X100 Y50 Z0 R30", "G91 G28 Z0", "G53 G0 Z0"):
        with pytest.raises(GcodeError, match=":2: G"):
            compensate_program(m, f"G90 G0 X10 Y10 Z10\n{block}\nG1 X200 F100\n", strict=True)
    # passed through, G91 G28 leaves incremental mode on and the position unknown
    out, report = compensate_program(m, "G90 G0 X10 Y10 Z10\nG91 G28 Z0\nG90 G1 X200 Y20 Z30 F100\n",
                                     pass_through=True)
    assert "line 3: the position before this move is not known" in " ".join(report.warnings)
    with pytest.raises(GcodeError, match=":3:4: an incremental move"):
        compensate_program(m, "G90 G0 X10 Y10 Z10\nG91 G28 Z0\nG1 X20 F100\n", pass_through=True)
    # P turns on a helix
    program = "G90 G0 X100 Y100 Z100\nG2 X100 Y100 Z200 I50 J0 P3 F100\n"
    out, report = compensate_program(m, program)
    assert "P3" not in out and report.pieces >= 13
    assert round_trip(m, program, out)[0] <= 1e-6
    assert sum(s.arc.sweep for s in interpret(m, out) if s.kind == "arc") == pytest.approx(-6 * math.pi, rel=1e-5)
    # M codes that end the move go to its last piece
    out, _ = compensate_program(m, "G90 G0 X10 Y10 Z10\nG1 X450 Y390 Z390 F300 M30\n")
    lines = out.splitlines()
    assert lines[-1].endswith(" M30") and "M30" not in "".join(lines[1:-1])
    # a K word on a G17 arc is not ours to delete
    out, _ = compensate_program(m, "G90 G0 X100 Y100 Z100\nG2 X200 Y100 I50 J0 K2 F100\n")
    assert " K2 " in out
    # an end point 1.8 um off the start's circle: the arc is spread, the residual stays small
    program = "G90 G0 X100 Y100 Z100\nG2 X200.0018 Y100 I50 J0 F100\n"
    out, report = compensate_program(m, program)
    assert report.max_residual_um < 0.95 and not [w for w in report.warnings if "stays" in w]
    assert round_trip(m, program, out)[0] <= 1e-6
    # block delete on a move, work offsets and tool length offsets
    with pytest.raises(GcodeError, match=":2: a move with block delete"):
        compensate_program(m, "G90 G0 X10 Y10 Z10\n/G1 X20\n", strict=True)
    _, report = compensate_program(m, "G90 G54 G43 H1 G0 X10 Y10 Z10\nG80\nG1 X20 F100\n")
    assert any("work offset G54" in w for w in report.warnings) and any("G43" in w for w in report.warnings)
    _, report = compensate_program(m, "G90 G0 X100 Y100 Z100\nG1 X400 Y300 F100\n", tol_um=0.05)
    assert "finer than the written numbers resolve" in report.warnings[0]


def test_origin_shifts_program_coordinates_to_axis_positions(machines):
    """With a work offset, program zero sits at ``origin``: the errors are those of the axis
    positions, and the written numbers stay program coordinates."""
    m = machines["vmc500"]
    program = "G90 G0 X10 Y10 Z10\nG1 X150 Y120 Z60 F300\n"
    origin = np.array([0.2, 0.15, 0.1])
    out, _ = compensate_program(m, program, origin=origin)
    shifted = "G90 G0 X210 Y160 Z110\nG1 X350 Y270 Z160 F300\n"
    out_shifted, _ = compensate_program(m, shifted)
    for a, b in zip(out.splitlines(), out_shifted.splitlines()):
        va = [float(v) for v in re.findall(r"[XYZ]([-\d.]+)", a)]
        vb = [float(v) for v in re.findall(r"[XYZ]([-\d.]+)", b)]
        np.testing.assert_allclose(np.array(va) + origin * 1e3, vb, atol=1.1e-4)


def test_modal_state_follows_the_blocks(machines):
    """The modal state between blocks: modes and position from the blocks read, canned
    cycles tracked, and a skipped block that names axes makes every position unknown."""
    from volerr_pin.compensation.gcode import _kept as kept, parse_block
    from volerr_pin.compensation.gcode._modal import Interpreter

    reader = Interpreter(machines["vmc500"])
    state = reader.initial_state()
    for number, line in enumerate(["G0 X10 Y20 Z30", "G20 G91 G18 G1 Z1"], start=1):
        move = reader.advance(parse_block(line, number, "p"), state)
    assert (state.motion, state.plane, state.absolute, state.inch) == (1, 18, False, True)
    np.testing.assert_allclose(move.start, [0.010, 0.020, 0.030])
    np.testing.assert_allclose(state.position, [0.010, 0.020, 0.030 + 0.0254])
    assert state.known.all() and move.start_known.all()
    assert "canned cycle" in kept.unsupported(reader, "G81 X20 Y20 Z5 R2", state)
    kept.skip(reader, "G81 X20 Y20 Z5 R2", state)
    assert state.canned and state.motion is None and not state.known.any()
    assert "cycle is still active" in kept.unsupported(reader, "X30", state)
    assert kept.unsupported(reader, "G80", state) is None and not state.canned


def test_accepted_spellings_read_as_their_plain_form(machines):
    """Lower case, leading zeros, blanks between letter and number, words without blanks,
    a decimal point without digits after it, a plus sign, tabs, a byte order mark: each reads
    as the plain program, and the rewritten words keep their letters' case."""
    m = machines["vmc500"]
    plain = "G90 G21 G17\nG0 X100 Y100 Z100\nG1 X150 Y120 F100\nG2 X200 Y120 I25 J0\nG1 X0.5 Z90\n"
    spelled = ("\ufeffg90 g21 g17\nG00 X 100 Y100 Z+100\nG1X150.Y120F100\ng02\tx200 y120 i25 j0\nG1.0 X.5 Z90.\n")
    a, b = interpret(m, plain), interpret(m, spelled)
    assert [s.kind for s in a] == [s.kind for s in b] == ["rapid", "line", "arc", "line"]
    for s, t in zip(a, b):
        np.testing.assert_array_equal(s.end, t.end)
    out, _ = compensate_program(m, spelled)
    lines = out.splitlines()
    assert lines[0] == "\ufeffg90 g21 g17"
    assert re.fullmatch(r"g02\tx[\d.]+ y[\d.]+ i[-\d.]+ j[-\d.]+ Z[\d.]+", lines[3]), lines[3]


def test_non_motion_lines_of_every_kind_stay_byte_identical(machines):
    m = machines["vmc500"]
    program = ("%\nO0042 (part \u00e9 42)\n(header; with a semicolon)\n; a whole-line comment ( with a paren\n"
               "N10 G21 G90 G17 G40 G49 G80 G94\n   \n\t\nN20 T1 M6\n/M8\nM7 M8\nM77\n()\nN30 S8000 M3\n"
               "G0 X10 Y10 Z10\nG4 P500\nG4 X1.5\nG1 F200\nG2\nG1 X20\nM5\nM30\n%_N_SUB_SPF\n%\n")
    out, report = compensate_program(m, program, pass_through=True, dialect="linuxcnc")
    kept = [ln for ln in program.splitlines() if not re.match(r"G[01] X", ln)]
    assert [ln for ln in out.splitlines() if not re.match(r"G[01] X", ln)] == kept
    # an M code the reader does not know is kept with pass_through, and said so, naming its line
    assert [w for w in report.warnings if "M77" in w] == [
        "line 11: M77 (an M code this reader does not know) kept unchanged; what it changes is not followed, so "
        "the blocks after it may be misread"]


def test_unknown_g_codes_are_refused_unless_pass_through_and_never_moves(machines):
    m = machines["vmc500"]
    program = START + "G77 X200 Y50\nG1 X150 Y120 Z90 F100\n"
    with pytest.raises(GcodeError, match=r"prog\.nc:2: G77 .*does not know.*\(strict refuses it") as info:
        compensate_program(m, program, source="prog.nc", strict=True)
    assert info.value.parameters == ("strict",)
    with pytest.raises(GcodeError, match="strict refuses the codes pass_through keeps"):
        compensate_program(m, program, strict=True, pass_through=True)
    # by default too: what an unknown code changes cannot be told, so it is not passed over
    with pytest.raises(GcodeError, match=r"^prog\.nc:2:1: G77 .*does not know.*may be misread") as info:
        compensate_program(m, program, source="prog.nc")
    assert info.value.parameters == ("pass_through",)
    out, report = compensate_program(m, program, pass_through=True)
    assert report.passed_through == 1
    assert out.splitlines()[1] == "G77 X200 Y50"
    assert "line 2: G77 (a G code this reader does not know) kept unchanged; what it changes is not followed, " \
           "so the blocks after it may be misread" in report.warnings
    # it named axes: where the machine went is not known, so the next move is end point only
    assert any(w.startswith("line 3: the position before this move is not known (axes X, Y, Z not known "
                            "since line 2)") for w in report.warnings)
    assert report.moves == 2 and report.pieces == 2


@pytest.mark.parametrize("kept, lost", [
    ("#1 = 5", False), ("N10 #100 = [#5001 + 2] (scale)", False),
    ("G1 X#5420", True), ("G1 X[#5420 + 2]", True), ("G#5400 X10", True), ("IF [#1 GT 2] GOTO 10", True),
    ("WHILE [#1 LT 10] DO1", True), ("END1", True), ("M98 P100", True), ("G65 P9010 A1", True),
    ("G81 X20 Y20 Z5 R12", True), ("G77", False),
])
def test_a_kept_block_that_may_move_loses_the_position(machines, kept, lost):
    """A jump, a loop, a call or a word whose value only the running machine knows (#5420, the
    current X) may move the machine or run the blocks in another order: the move after it is
    compensated at its end point only."""
    program = START + f"{kept}\nG80\nG1 X150 F100\n"
    out, report = compensate_program(machines["vmc500"], program, pass_through=True, dialect="linuxcnc")
    assert out.splitlines()[1] == kept
    assert any(w.startswith("line 2: ") and "kept unchanged" in w for w in report.warnings)
    assert any(w.startswith("line 4: the position before this move is not known") for w in report.warnings) == lost


def test_a_tool_change_loses_the_position(machines):
    """M6 runs the machine's tool change, which moves the axes: the move after it starts
    where the change left the tool, not at the last programmed point."""
    m = machines["vmc500"]
    out, report = compensate_program(m, START + "T2 M6\nG1 X450 Y390 Z390 F300\n")
    assert out.splitlines()[1] == "T2 M6" and len(out.splitlines()) == 3  # end point only, not split
    assert any("not known since line 2's M6 tool change" in w for w in report.warnings)
    # before any move nothing is lost: the axes are not yet programmed
    _, report = compensate_program(m, "G90 G21\nT1 M6\nG0 X10 Y10 Z10\n")
    assert report.warnings == ["line 3: the position before this move is not known (axes X, Y, Z not yet "
                               "programmed); it is compensated at its end point only"]


def test_r_and_ijk_that_agree_are_both_rewritten(machines):
    m = machines["vmc500"]
    program = START + "G2 X200 Y100 R50 I50 J0 F100\n"
    out, report = compensate_program(m, program)
    first = out.splitlines()[1]
    assert re.search(r" R4\d\.\d{4} I4\d\.\d{4} J-?0\.\d{4} ", first), first
    assert report.arcs_kept == 1
    assert round_trip(m, program, out)[0] <= 1e-6  # reading it back checks that R and I/J agree


def _written_arcs(text: str, inch: bool):
    """(start, end, centre offsets or None, radius or None) of every arc block as written
    (absolute XY, plane G17), from the numbers alone."""
    pos, arcs, motion = {}, [], None
    for line in text.splitlines():
        words = dict((k.upper(), float(v)) for k, v in re.findall(r"([A-Za-z])([-+]?[\d.]+)", line))
        motion = int(words["G"]) if words.get("G") in (0, 1, 2, 3) else motion
        start = (pos.get("X"), pos.get("Y"))
        pos.update({k: v for k, v in words.items() if k in "XYZ"})
        if motion in (2, 3) and ("X" in words or "Y" in words):
            ijk = (words.get("I", 0.0), words.get("J", 0.0)) if "I" in words or "J" in words else None
            arcs.append((start, (pos["X"], pos["Y"]), ijk, words.get("R")))
    return arcs


@pytest.mark.parametrize("units, program, resolution", [
    ("mm", "G90 G21 G17 G0 X100 Y100 Z100\nG1 X100 Y100 F100\n" + "".join(
        f"G2 X{100 + 2 * r:.4f} Y100 I{r:.4f} J0\nG1 X100 Y100\n" for r in (0.0021, 0.003, 0.02)), 1e-4),
    ("inch", "G90 G20 G17 G0 X4 Y4 Z4\nG1 X4 Y4 F10\n" + "".join(
        f"G3 X{4 + 2 * r:.6f} Y4 R{r:.6f}\nG1 X4 Y4\n" for r in (0.0001, 0.0003, 0.001)), 1e-6),
])
def test_written_arcs_are_defined_at_the_written_precision(machines, units, program, resolution):
    """Small arcs (radius 2.1 um up): no output arc has centre words or a radius that round
    to zero, or a start and end radius that disagree beyond the rounding of the numbers."""
    m = machines["vmc500"]
    out, report = compensate_program(m, program)
    arcs = _written_arcs(out, units == "inch")
    assert len(arcs) == 6 and report.arcs_kept == 3
    for (sx, sy), (ex, ey), ijk, r in arcs:
        if ijk is not None:
            assert ijk != (0.0, 0.0)
            cx, cy = sx + ijk[0], sy + ijk[1]
            r_start, r_end = math.hypot(sx - cx, sy - cy), math.hypot(ex - cx, ey - cy)
            assert abs(r_start - r_end) <= 3 * resolution, (r_start, r_end)
        if r is not None:
            assert r != 0.0 and math.hypot(ex - sx, ey - sy) <= 2 * abs(r) + 2 * resolution
    assert round_trip(m, program, out)[0] <= 1e-6


def test_an_arc_the_written_numbers_cannot_hold_is_written_as_chords(machines):
    """A compensated arc piece whose centre words would round to zero, whose written ends
    would read as nearly a full circle, or whose centre is too far for nine digits, becomes
    straight pieces along it, within the tolerance."""
    from volerr_pin.compensation import Piece
    from volerr_pin.compensation.gcode import Program, parse_block

    m = machines["vmc500"]
    writer = Program(m, tol_um=1.0).writer
    program = writer.arcs
    st = {"absolute": True, "inch": False, "plane": 17, "out_motion": 2}
    start = np.array([0.1, 0.1, 0.05])

    def piece(radius, sweep):
        centre = start[:2] - np.array([radius, 0.0])
        end = start.copy()
        end[:2] = centre + radius * np.array([math.cos(sweep), math.sin(sweep)])
        return Piece("arc", start, end, center=centre, clockwise=sweep < 0, turns=sweep, residual=0.2e-6)

    normal = piece(0.05, -math.pi / 2)
    assert program.writable([normal], st, {"ijk"}) == [normal]
    for p in (piece(0.3e-6, -math.pi / 2),  # I/J round to zero
              piece(5e-6, -0.004),  # 20 nm long: the written ends read as a full turn
              piece(200.0, -2e-4)):  # a centre 200 m away: too many digits
        out = program.writable([p], st, {"ijk"})
        assert out and all(q.kind == "line" for q in out)
        np.testing.assert_array_equal(out[0].start, p.start)
        np.testing.assert_array_equal(out[-1].end, p.end)
        r = math.hypot(*(p.start[:2] - p.center))
        for q in out:  # chord ends on the arc, chord middles within the tolerance of it
            assert abs(math.hypot(*(q.end[:2] - p.center)) - r) < 1e-12
            assert r - math.hypot(*((q.start[:2] + q.end[:2]) / 2 - p.center)) <= 1e-6 - p.residual
            assert q.residual <= 1e-6
    block = parse_block("N5 G2 X100.0000 Y100.0003 I-0.0003 J0 F200", 5, "p")
    tiny = piece(0.3e-6, -math.pi / 2)
    line = program.writable([tiny], st, {"ijk"})[0]
    text = writer.rewrite(block, line, line.start, st, 2, [w for w in block.words if w.letter in "XY"])
    assert text.startswith("N5 G1 X") and "I" not in text and "J" not in text


@pytest.mark.parametrize("kwargs, parameter", [
    ({"tol_um": 0.0}, "tol_um"), ({"tol_um": -1.0}, "tol_um"), ({"tol_um": math.nan}, "tol_um"),
    ({"tol_um": math.inf}, "tol_um"), ({"tol_um": 1e-9}, "tol_um"),
    ({"tol_urad": -1.0}, "tol_urad"), ({"tol_urad": math.nan}, "tol_urad"),
    ({"origin": [0.0, math.inf, 0.0]}, "origin"), ({"origin": [0.0, 0.0]}, "origin"),
])
def test_program_arguments_are_checked(machines, kwargs, parameter):
    with pytest.raises(GcodeError, match=rf"^{parameter} must") as info:
        compensate_program(machines["vmc500"], START, **kwargs)
    assert info.value.parameters == (parameter,)


def test_start_is_checked(machines):
    from volerr_pin.compensation.gcode import Program

    with pytest.raises(GcodeError, match="^start must hold 3 finite values or NaN") as info:
        Program(machines["vmc500"], start=[0.1, math.inf, 0.1])
    assert info.value.parameters == ("start",)
    Program(machines["vmc500"], start=[0.1, math.nan, 0.1])   # NaN: that axis' position is not known


def test_a_kept_block_cannot_change_the_work_offset(machines):
    """pass_through keeps a cycle unchanged, but not the origin the blocks after it are
    compensated at."""
    program = START + "G54 G1 X150 F100\nG55 G81 X20 Y20 Z5 R12\nG80\nG1 X160\n"
    with pytest.raises(GcodeError, match=r"^prog\.nc:3: G55 changes the work offset from G54 \(line 2\)"):
        compensate_program(machines["vmc500"], program, pass_through=True, source="prog.nc")


def test_a_block_delete_without_moves_or_modes_is_kept(machines):
    out, report = compensate_program(machines["vmc500"], START + "/M8\n/1 M9 (switch 1)\nG1 X150 F100\n")
    assert out.splitlines()[1:3] == ["/M8", "/1 M9 (switch 1)"] and report.moves == 2


def test_inverse_time_feed_is_shared_among_the_pieces_of_a_split_move(machines):
    """Under G93 every block's F is the reciprocal of its time [1/min]: a split move's pieces
    each carry an F, and their times add up to the programmed one (a controller refuses a G93
    block without F, and the first piece alone would otherwise take the whole time)."""
    program = "G21 G90 G17\nG0 X10 Y10 Z10\nG93 G1 X490 Y390 Z390 F2\nX10 Y10 Z10 F0.5\nG94 G1 X400 F1000\n"
    out, report = compensate_program(machines["vmc500"], program)
    lines = out.splitlines()
    g94 = next(i for i, line in enumerate(lines) if line.startswith("G94"))
    g93 = lines[2:g94]
    assert len(g93) > 2 and all(re.search(r"\bF[0-9.]+$", line) for line in g93)
    feeds = [float(re.search(r"F([0-9.]+)$", line).group(1)) for line in g93]
    second = next(i for i, line in enumerate(g93) if not line.startswith(("G93", "G1")))  # "X10 ..." kept its form
    assert sum(1 / f for f in feeds[:second]) == pytest.approx(1 / 2, rel=1e-4)
    assert sum(1 / f for f in feeds[second:]) == pytest.approx(1 / 0.5, rel=1e-4)
    # under G94 the pieces after the first run at the modal feed: no F of their own
    assert lines[g94].endswith("F1000") and not any("F" in line for line in lines[g94 + 1:])
    assert report.pieces > report.moves


@pytest.mark.parametrize("body, kept, compensated", [
    # a shift lasts until every shifted axis is set back to zero
    ("G52 X10 Y5\nG1 X200\nG52 X0\nG1 X150\nG52 Y0\nG1 X120\n", range(3, 8), [8]),
    # modes nest: the rotation started inside the shift outlives the shift's end
    ("G52 X10\nG1 X150\nG68 X0 Y0 R10\nG52 X0\nG1 X120\nG69\nG1 X130\n", range(3, 9), [9]),
    ("G92 X0 Y0\nG1 X20\nG92.1\nG1 X120\n", range(3, 6), [6]),
    ("G51 X0 Y0 P2\nG1 X20\nG50\nG1 X120\n", range(3, 6), [6]),
    ("G16\nG1 X50 Y30\nG15\nG1 X120\n", range(3, 6), [6]),
    # a work offset set by the program in a way not followed (rotated): to the end
    ("G10 L2 P1 X5 R30\nG1 X150\nG1 X120\n", range(3, 6), []),
    # a shift of nothing starts nothing
    ("G52 X0\nG1 X150\n", [3], [4]),
])
def test_modes_that_change_how_coordinates_read_keep_every_block_until_they_end(machines, body, kept, compensated):
    program = "G21 G90 G17\nG0 X100 Y100 Z100\n" + body
    out, report = compensate_program(machines["vmc500"], program, dialect="linuxcnc")
    given, written = program.splitlines(), out.splitlines()
    assert len(written) == len(given)
    for line in kept:
        assert written[line - 1] == given[line - 1], f"line {line} changed"
    named = set()
    for w in report.warnings:
        m = re.match(r"lines? (\d+)(?:-(\d+))?: .*kept unchanged", w)
        if m:
            named.update(range(int(m.group(1)), int(m.group(2) or m.group(1)) + 1))
    assert named == set(kept) and report.passed_through == len(kept)
    for line in compensated:
        assert written[line - 1] != given[line - 1], f"line {line} not compensated"
    with pytest.raises(GcodeError, match=r"^<program>:3: .*strict refuses it"):
        compensate_program(machines["vmc500"], program, strict=True, dialect="linuxcnc")


@pytest.mark.parametrize("line, system", [("#5221=-50.", True), ("# 2001 = 1.5 (tool length)", True),
                                          ("#100=3", False), ("#999 = #5221", False), ("#1 = #5001 + 2", False)])
def test_a_write_to_a_system_variable_is_named_and_loses_the_position(machines, line, system):
    """Writing #1000 and above (work and tool offsets on Fanuc-style controls) may change what
    the coordinates after it mean: it is named as such, and the next move is compensated at
    its end point only; reading a system variable or writing a common one is a plain macro
    variable line."""
    text, report = compensate_program(machines["vmc500"], f"G90 G0 X100 Y100 Z100\n{line}\nG1 X101 F100\n")
    assert text.splitlines()[1] == line
    named = [w for w in report.warnings if w.startswith("line 2:")]
    assert len(named) == 1
    assert ("system variable" in named[0]) == system
    assert ("may be misread" in named[0]) == system
    assert any(w.startswith("line 3: the position before this move is not known") for w in report.warnings) == system


G90_1 = """G90.1
G0 X100 Y100 Z100
G1 Z50 F300
G2 X300 Y100 R100
G0 X30 Y30
G2 X30 Y30 I20 J20
G91.1
G2 X30 Y30 I-10 J-10
M30
"""


def test_absolute_arc_centres_are_followed(machines):
    """G90.1 makes I, J, K absolute program coordinates until G91.1 (the issue's programs: the
    arcs after it were read and written as offsets, so LinuxCNC centred a written piece 16 mm off
    the path and a full circle about (20, 20) became four arcs about (50, 50)). The programs are
    read with their centres where the standard puts them, compensated within the tolerance, and
    every absolute centre written holds the centre to the micrometres the compensation moves it."""
    m = machines["vmc500"]
    arcs = [s.arc for s in interpret(m, G90_1) if s.kind == "arc"]
    # (the R arc's centre is on its chord; the two full circles are about (20, 20), radius 14.14)
    np.testing.assert_allclose([np.asarray(a.center) * 1e3 for a in arcs], [[200, 100], [20, 20], [20, 20]],
                               atol=1e-3)   # mm (the R arc's half circle: its centre from the chord)
    out, report = compensate_program(m, G90_1, tol_um=1.0)
    assert round_trip(m, G90_1, out)[0] <= 1.0e-6 + 1e-9
    lines = out.splitlines()
    absolute = lines[:lines.index("G91.1")]
    centres = [(float(i), float(j)) for i, j in re.findall(r"I(-?[\d.]+) J(-?[\d.]+)", "\n".join(absolute))]
    assert centres and all(min(math.hypot(i - 200, j - 100), math.hypot(i - 20, j - 20)) < 0.01 for i, j in centres)
    offsets = re.findall(r"I(-?[\d.]+) J(-?[\d.]+)", "\n".join(lines[lines.index("G91.1"):]))
    assert offsets and all(math.hypot(float(i), float(j)) == pytest.approx(math.hypot(10, 10), abs=0.01)
                           for i, j in offsets)


@pytest.mark.parametrize("block, missing", [("G2 X110 Y5 I100", "J"), ("G2 X90 Y5 J5", "I")])
def test_an_absolute_centre_needs_both_words(machines, block, missing):
    """Under G90.1 a centre word left out is not an offset of zero: LinuxCNC refuses the block
    ("J word missing in absolute center arc"), and so does the reader."""
    program = f"G90.1 F100\nG0 X90 Y5 Z0\n{block}\nM30\n"
    with pytest.raises(GcodeError, match=rf"<program>:3: an arc with absolute centres \(G90.1\) needs both I and J; "
                                         rf"{missing} is missing"):
        compensate_program(machines["vmc500"], program, tol_um=1.0)


@pytest.mark.parametrize("name, program, line", [
    ("lathe_2axis", "G18 G21 G90\nG0 X40 Z-10\nG50 X200 Z0\nG1 X50 Z-10 F100\nM30\n", 3),
    ("vmc500", "G0 X100 Y100 Z50\nG50 X200\nG1 X50 F100\nM30\n", 2),
])
def test_g50_with_axis_words_is_not_a_move(machines, name, program, line):
    """G50 with axis words sets the coordinate system on Fanuc lathes (and on a mill it is no
    scaling's end either): it is no move. It was compensated as one ("G50 X199.9934 Z-0.0009")
    and every later block from the wrong place; now it and the blocks after it are kept unchanged
    and named, as after a work offset the program sets."""
    out, report = compensate_program(machines[name], program, tol_um=1.0, dialect="linuxcnc")
    lines, given = out.splitlines(), program.splitlines()
    assert lines[line - 1:] == given[line - 1:]
    assert any(w.startswith(f"line {line}: G50 (coordinate system set by G50 with axis words) kept unchanged")
               for w in report.warnings), report.warnings
    # G50 alone (scaling off) and a lathe's G50 S (spindle speed limit) set no coordinates
    out, report = compensate_program(machines["vmc500"], "G50\nG0 X100. Y100. Z50.\nG1 X200. F100\n", tol_um=1.0)
    assert out.splitlines()[1] != "G0 X100. Y100. Z50." and report.passed_through == 0


def test_path_blending_tolerances_pass_through(machines):
    """``G64 P0.01 Q0.001``, a usual first line of LinuxCNC programs, was refused ("P words mean
    nothing this reader knows here") even with pass_through: its P and Q are G64's."""
    program = "G64 P0.01 Q0.001\nG0 X100 Y100 Z50\nG1 X200 F100\nM30\n"
    out, report = compensate_program(machines["vmc500"], program, tol_um=1.0)
    assert out.splitlines()[0] == "G64 P0.01 Q0.001" and report.passed_through == 0
    with pytest.raises(GcodeError, match=r"<program>:1:5: P0.01: P words mean nothing this reader knows here"):
        compensate_program(machines["vmc500"], "G61 P0.01\nG0 X100 Y100 Z50\n", tol_um=1.0)


LATHE_PROFILE = """G18 G21 G90
G0 X40 Z-10
G1 Z-20 F100
G2 X60 Z-30 R15
G1 Z-60
G3 X70 Z-70 I10 K0
M30
"""


def test_a_two_axis_lathe_turns_its_arcs(machines):
    """lathe_2axis has Z and X only: its arcs are G18's (Z, X), with no third axis for a helix.
    Every lathe profile with an arc used to fail ("an arc needs linear axes Z, X, Y"); it is
    compensated within the tolerance the lathe's two axes can reach (its errors in y are left:
    no axis moves in y)."""
    m = machines["lathe_2axis"]
    arcs = [s.arc for s in interpret(m, LATHE_PROFILE) if s.kind == "arc"]
    np.testing.assert_allclose([np.asarray(a.center) * 1e3 for a in arcs], [[-16.0557, 54.4721], [-60, 70]],
                               atol=1e-3)   # (Z, X) [mm], as LinuxCNC's interpreter reads the program (ARC_FEED)
    out, report = compensate_program(m, LATHE_PROFILE, tol_um=1.0)
    assert report.arcs_kept >= 2 and [line for line in out.splitlines() if line.startswith("G3")]
    with pytest.raises(GcodeError, match=r"<program>:2: an arc in G17 needs linear axes X and Y"):
        compensate_program(m, "G0 X40 Z-10\nG17 G2 X60 Z-30 R15\n", tol_um=1.0)


def test_m72_restores_what_m70_saved(machines):
    """LinuxCNC's M70 saves the modes, M72 restores them (not the motion mode), both before the
    G codes of their block. M72 was read as "moves no axis", so the G91 saved before it stayed in
    force: the issue's program plunged Z from 50 to -0.003 and rapided to X0 Y0. Each case is as
    LinuxCNC's interpreter reads it (rs274's canonical moves)."""
    m = machines["vmc500"]
    program = "G0 X10 Y10 Z50 F100\nM70\nG91\nG1 X5\nM72\nG1 X100 Y20\nG0 Z60\nM30\n"
    ends = [s.end * 1e3 for s in interpret(m, program)]
    np.testing.assert_allclose(ends, [[10, 10, 50], [15, 10, 50], [100, 20, 50], [100, 20, 60]], atol=1e-9)
    # M70 saves before its block's G91; G91 after M72 in one block holds
    saved_first = "G0 X1 Y1 Z1\nG91 M70\nG90\nM72\nX1\n"
    assert interpret(m, saved_first)[-1].end[0] == pytest.approx(1e-3)
    g_after = "G0 X1 Y1 Z1\nM70\nG91 M72\nX1\n"
    assert interpret(m, g_after)[-1].end[0] == pytest.approx(2e-3)
    # the plane, the units and the arc centre mode come back too
    restored = "G0 X10 Y10 Z50\nM70\nG18 G20 G90.1\nM72\nG2 X30 Y10 I10 J0 F100\n"
    arc = interpret(m, restored)[-1].arc
    assert arc.plane[:2] == (0, 1) and np.allclose(arc.center, [0.02, 0.01])
    out, report = compensate_program(m, program)
    assert out.splitlines()[4] == "M72" and re.match(r"G1 X99\.99\d\d Y(19\.99|20\.00)\d\d Z(49\.99|50\.00)", out.splitlines()[5])


@pytest.mark.parametrize("program", ["G0 X1 Y1 Z1\nM72\n", "G0 X1 Y1 Z1\nM70\nM71\nM72\n"])
def test_m72_with_nothing_saved_is_refused(machines, program):
    """LinuxCNC refuses M72 with nothing saved ("Cannot restore context from invalid stack frame")."""
    with pytest.raises(GcodeError, match=r"<program>:\d: M72 restores the modes M70 saved, and none are saved"):
        compensate_program(machines["vmc500"], program)


def test_an_unknown_m_code_stops_the_run(machines):
    """An M code whose effect on the modes is unknown may change how every later block reads: it
    stops the run naming it (as an unknown G code does), unless pass_through keeps it."""
    program = "G0 X10 Y10 Z50\nM77\nG1 X20 F100\n"
    with pytest.raises(GcodeError, match=r"<program>:2:1: M77 \(an M code this reader does not know\): what it "
                                         r"changes cannot be told"):
        compensate_program(machines["vmc500"], program)
    out, report = compensate_program(machines["vmc500"], program, pass_through=True)
    assert out.splitlines()[1] == "M77" and report.passed_through == 1
    # LinuxCNC's user M codes (M100 - M199) run programs of the configuration, which change no mode
    out, report = compensate_program(machines["vmc500"], "G0 X10 Y10 Z50\nM101 P2 Q3\nG1 X20 F100\n")
    assert out.splitlines()[1] == "M101 P2 Q3" and report.passed_through == 0


LOOPS = {
    "goto": "G0 X100 Y100 Z100\n#1 = 0\nN10 G91 G1 Z-10 F100\n#1 = [#1 + 1]\nIF [#1 LT 3] GOTO 10\nG90 G0 Z150\nM30\n",
    "fanuc_while": "G0 X100 Y100 Z100\n#1 = 0\nWHILE [#1 LT 3] DO1\nG91 G1 Z-10 F100\n#1 = [#1 + 1]\nEND1\nM30\n",
    "o_while": "G0 X100 Y100 Z100\n#1 = 0\no101 while [#1 LT 3]\nG91 G1 Z-10 F100\n#1 = [#1 + 1]\n"
               "o101 endwhile\nM30\n",
    "o_repeat": "G0 X100 Y100 Z100\no102 repeat [3]\nG91 G1 Z-10 F100\no102 endrepeat\nM30\n",
    "o_do": "G0 X100 Y100 Z100\n#1 = 0\no103 do\nG91 G1 Z-10 F100\n#1 = [#1 + 1]\no103 while [#1 LT 3]\nM30\n",
    "unseen_label": "G0 X100 Y100 Z100\nG91 G1 Z-10 F100\nIF [#1 LT 3] GOTO 99\nM30\n",
}


@pytest.mark.parametrize("kind", ["o_while", "o_repeat", "o_do"])
def test_a_loop_over_an_incremental_move_is_followed(machines, kind):
    """A block a loop runs again was compensated for one pass: an incremental move among them
    added that pass's correction at every other place (three passes of the issue's G91 step: Z
    4.1 um off, with no warning). A LinuxCNC loop is now followed: the program as run holds the
    step three times, each compensated where it runs, and ends where the program means."""
    m = machines["vmc500"]
    program = LOOPS[kind]
    out, report = compensate_program(m, program)
    steps = [line for line in out.splitlines() if line.startswith("G91 G1 Z")]
    assert len(steps) == 3 and report.expanded["loop_passes"] == 3, out
    assert report.moves == 4 and report.moves_kept == 0 and report.motion_compensated == 1.0
    # each pass ends where the same steps written absolutely are compensated to (Z 90, 80, 70)
    absolute, _ = compensate_program(m, "G0 X100 Y100 Z100\nG1 Z90 F100\nG1 Z80\nG1 Z70\nM30\n")
    ends = np.array([s.end for s in interpret(m, out)])
    expected = np.array([s.end for s in interpret(m, absolute)])
    assert interpret(m, program)[-1].end[2] == pytest.approx(0.070)
    assert ends.shape == expected.shape and np.abs(ends - expected).max() < 0.11e-6   # the written digits


@pytest.mark.parametrize("kind", ["goto", "fanuc_while", "unseen_label"])
def test_a_fanuc_loop_over_an_incremental_move_is_refused_by_name(machines, kind):
    """A Fanuc-style loop or jump is not followed: a block it runs again would be compensated
    for one pass, so such a loop over an incremental move is refused, naming it and the move."""
    program = LOOPS[kind]
    # (a loop statement itself loses the position: an incremental move right after it is refused
    # for that, before the loop's end is read)
    with pytest.raises(GcodeError, match=r"runs lines \d+-\d+ again, and line \d+ among them moves incrementally|"
                                         r":[34]:8: an incremental move of Z before its position is known"):
        compensate_program(machines["vmc500"], program, pass_through=True, dialect="linuxcnc")
    if kind in ("goto", "unseen_label"):
        with pytest.raises(GcodeError, match=r"GOTO (10|99).* runs lines \d-\d again, and line \d among them"):
            compensate_program(machines["vmc500"], program, pass_through=True, dialect="linuxcnc")


def test_loops_over_absolute_moves_and_jumps_forward_are_compensated(machines):
    """A move to absolute coordinates is the same wherever it runs from; a jump forward runs
    nothing again."""
    m = machines["vmc500"]
    absolute = "G0 X100 Y100 Z100\n#1 = 0\nWHILE [#1 LT 3] DO1\nG1 X200 F100\nG1 X100\n#1 = [#1 + 1]\nEND1\nM30\n"
    out, _ = compensate_program(m, absolute, pass_through=True, dialect="linuxcnc")
    assert out.splitlines()[3] != "G1 X200 F100"
    forward = "G0 X100 Y100 Z100\nG91 G1 Z-10 F100\nGOTO 20\nG90 G1 Z50\nN20 G90 G0 Z150\nM30\n"
    compensate_program(m, forward, pass_through=True, dialect="linuxcnc")
    # the same, as a FANUC control reads it: whole numbers are increments, so it asks for points
    with pytest.raises(GcodeError, match=":1:4: X100 has no decimal point"):
        compensate_program(m, absolute, pass_through=True)
    out, _ = compensate_program(m, re.sub(r"([XYZ]-?\d+)(?=[ \n])", r"\1.", absolute), pass_through=True)
    assert out.splitlines()[3] != "G1 X200. F100"


SUB = """o100 sub
G18
G20
o100 endsub
G17 G21 G90
G0 X100 Y100 Z100
G2 X120 Y120 I10 J10 F100
o100 call
G1 Z5
M30
"""


def test_a_subroutine_body_runs_where_it_is_called(machines):
    """The modes a LinuxCNC subroutine body sets hold where it is called, not where it is
    defined: its G18 made the main program's G17 arc split as a ZX arc, its G20 made mm moves
    read as inches. The body now runs where it is called (the program as run holds it there);
    the arc before the call is an XY arc in mm, the move after it is in inch (LinuxCNC: Z 5
    inch), as LinuxCNC's interpreter reads both."""
    m = machines["vmc500"]
    segments = interpret(m, SUB)
    arc = [s.arc for s in segments if s.kind == "arc"][0]
    assert arc.plane[:2] == (0, 1) and np.allclose(arc.center, [0.11, 0.11])
    assert segments[-1].end[2] == pytest.approx(5 * 0.0254)
    out, report = compensate_program(m, SUB)
    lines = out.splitlines()
    # the definition stays as written (a program of other files may call it), the call runs it
    assert lines[:5] == ["o100 sub", "G18", "G20", "o100 endsub", "G17 G21 G90"], lines
    assert lines[-4:-2] == ["G18", "G20"], lines
    assert re.fullmatch(r"G1 Z(4\.99|5\.00)\d{4} X\S+ Y\S+", lines[-2]), lines   # inch, 6 decimals
    assert "o100 call" not in lines and report.expanded == {"blocks_run": 11, "calls": 1, "loop_passes": 0,
                                                             "profiles": 0}
    assert any(w.startswith("the program's parameters, expressions and O-words were followed") for w in report.warnings)
    # a body that saves the modes with M73 leaves none in force after its return
    restored = SUB.replace("o100 sub\n", "o100 sub\nM73\n")
    assert interpret(m, restored)[-1].end[2] == pytest.approx(5e-3)


G92_RESETS = "G92.1\nG0 X100 Y100 Z50\nG1 X200 F100\nG92 X0 Y0\nG1 X10\nG92.2\nG1 X150\nG92.3\nG1 X20\nG92.1\nG1 X250\nM30\n"


def test_g92_resets_end_a_shift_and_g92_3_starts_one(machines):
    """Bare G92.1 and G92.2 leave coordinates as the program's origin reads them (LinuxCNC resets
    or sets aside the G92 offsets): they end a G92 region, and before any shift they change
    nothing (43 of LinuxCNC's sample programs were refused for them). G92.3 restores offsets
    from the parameters, which the reader cannot know: a region of its own, to G92.1 / G92.2."""
    out, report = compensate_program(machines["vmc500"], G92_RESETS)
    lines = out.splitlines()
    assert lines[0] == "G92.1" and lines[1] != "G0 X100 Y100 Z50"           # compensated after it
    assert lines[4] == "G1 X10" and lines[8] == "G1 X20"                       # kept in the shifts
    assert lines[6] != "G1 X150" and lines[10] != "G1 X250"                    # compensated after them
    assert any(w.startswith("line 8: G92.3 (coordinate shift restored from the parameters) kept unchanged")
               for w in report.warnings), report.warnings


def test_a_g92_reset_with_axis_words_is_refused(machines):
    """LinuxCNC moves to the axis words of a G92.1 block after resetting the offsets; Fanuc
    controls preset the workpiece coordinates to them. Which a program means cannot be told."""
    with pytest.raises(GcodeError, match=r"<program>:2:7: X5 with G92.1: LinuxCNC moves there .* Fanuc controls "
                                         r"preset the workpiece coordinates"):
        compensate_program(machines["vmc500"], "G0 X1 Y1 Z1\nG92.1 X5\n")


FULL_CIRCLES = "G0 X100 Y100 Z50 F100\nG2 I10\nG3 J-5\nG1 X120\nM30\n"


def test_a_full_circle_without_end_words_turns_where_the_tool_stands(machines):
    """``G2 I10`` turns a full circle about the centre from where the tool stands back to it, as
    LinuxCNC reads it (two sample programs were refused for it); its compensated pieces get end
    words, the first before its centre words."""
    m = machines["vmc500"]
    arcs = [s.arc for s in interpret(m, FULL_CIRCLES) if s.kind == "arc"]
    np.testing.assert_allclose([np.asarray(a.center) * 1e3 for a in arcs], [[110, 100], [100, 95]], atol=1e-9)
    assert [round(abs(a.sweep) / (2 * math.pi), 12) for a in arcs] == [1.0, 1.0]
    out, report = compensate_program(m, FULL_CIRCLES, tol_um=1.0)
    assert re.match(r"G2 X\d+\.\d{4} Y\d+\.\d{4} Z\d+\.\d{4} I\d", out.splitlines()[1]), out.splitlines()[1]
    assert round_trip(m, FULL_CIRCLES, out)[0] <= 1e-6 + 1e-9


def test_nothing_after_the_programs_end_is_read(machines):
    """A controller reads nothing after M2 / M30: notes there ("These ..." reads as a T word) and
    anything else are kept unchanged and named, not read (four sample programs were refused)."""
    program = "G0 X100 Y100 Z50\nG1 X200 F100 M30\nThese are notes: T is not read\nG1 X300\n"
    out, report = compensate_program(machines["vmc500"], program)
    assert out.splitlines()[2:] == program.splitlines()[2:] and out.splitlines()[1] != "G1 X200 F100 M30"
    assert "lines 3-4: after the program's end (line 2's M2 / M30) kept unchanged: a controller does not read it" \
        in report.warnings
    assert [s.line for s in interpret(machines["vmc500"], program)] == [1, 2]


LATHE_DIAMETER = """G18 G21 G90 G7
G0 X80 Z-10
G1 X80 Z-20 F100
G2 X120 Z-30 R15
G1 Z-60
G3 X140 Z-70 I10 K0
G91 G1 X10
G90 G8
G1 X40
M30
"""


def test_lathe_diameter_mode_reads_x_as_a_diameter(machines):
    """LinuxCNC's G7: X words are diameters (absolute and incremental), the centre word I stays
    a radius; G8 returns to radii. The diameter program is the radius profile's (LATHE_PROFILE)
    to the micrometre, as LinuxCNC reads both, and is written back in diameters (14 sample
    programs were refused for G7)."""
    m = machines["lathe_2axis"]
    diameter, radius = interpret(m, LATHE_DIAMETER), interpret(m, LATHE_PROFILE)
    for d, r in zip(diameter, radius):
        np.testing.assert_allclose(d.end, r.end, atol=1e-12)
        if d.kind == "arc":
            np.testing.assert_allclose(d.arc.center, r.arc.center, atol=1e-12)
    assert diameter[5].end[1] == pytest.approx(0.075) and diameter[6].end[1] == pytest.approx(0.04)
    out, _ = compensate_program(m, LATHE_DIAMETER, tol_um=1.0)
    x = [float(v) for v in re.findall(r"X(-?[\d.]+)", out)]
    assert x[0] == pytest.approx(80, abs=0.01) and x[-1] == pytest.approx(40, abs=0.01)   # diameter, then radius


PLANAR = "G17 G21 G90\nG0 X100 Y100\nG1 X200 F500\nG2 X300 Y200 I0 J100\nG1 Y300\nM30\n"


def test_a_2d_program_is_compensated_with_z_where_it_stands(machines):
    """A 2-D plasma or laser program never writes Z: its arcs were refused ("axes Z not yet
    programmed"). Told where Z stands (start, NaN for the axes not known), every move is
    compensated whole with Z held there; not told, the refusal says what to give."""
    m = machines["vmc500"]
    with pytest.raises(GcodeError, match=r"an arc from an unknown position \(axes Z not yet programmed\).* give "
                                         r"where the axes stand when the program starts \(start") as err:
        compensate_program(m, PLANAR, tol_um=1.0, strict=True)
    assert err.value.parameters == ("start", "strict")
    # not strict, the arc is kept unchanged and named (no Z word is written into a program
    # that never moves Z: its height may be the torch height control's)
    out, report = compensate_program(m, PLANAR, tol_um=1.0)
    assert out.splitlines()[3] == "G2 X300 Y200 I0 J100" and "Z" not in out
    assert any(w.startswith("line 4: an arc from an unknown position (axes Z not yet programmed) kept unchanged")
               for w in report.warnings)
    assert report.moves == 3 and report.moves_kept == 1 and report.motion_compensated == 0.75
    out, report = compensate_program(m, PLANAR, tol_um=1.0, start=[np.nan, np.nan, 0.15])
    assert report.max_residual_um <= 1.0
    assert all(re.search(r"Z1(49\.99|50\.00)\d\d", line) for line in out.splitlines()[1:-1]), out
    assert not any("line 3" in w or "line 4" in w for w in report.warnings), report.warnings
    with pytest.raises(GcodeError, match=r"start must hold 3 finite values or NaN \(not known\)"):
        compensate_program(m, PLANAR, start=[np.inf, 0.1, 0.1])


def test_analog_channel_words_pass_through(machines):
    """LinuxCNC's M66 - M68 name an analog channel with E (three sample programs were refused:
    "E words mean nothing this reader knows here"); E stays refused elsewhere."""
    program = "G0 X100 Y100 Z50\nM68 E0 Q10\nM66 E0 L0\nM67 E1 Q2.5\nM30\n"
    out, report = compensate_program(machines["vmc500"], program)
    assert out.splitlines()[1:] == program.splitlines()[1:] and report.passed_through == 0
    with pytest.raises(GcodeError, match=r"<program>:2:4: E1: E words mean nothing this reader knows here"):
        compensate_program(machines["vmc500"], "G0 X100 Y100 Z50\nM3 E1\n")


#: LinuxCNC's skeleton program opens its rapids with a short dwell in the same block
DWELL_AND_MOVE = "G21 G90 G17\nG04 P.001 G0 X100 Y100 Z50\nG4 P0.5 G1 X200 Y150 F300\nG04 P.01 G1 X300 Y100\nM30\n"


def test_a_dwell_and_a_move_in_one_block_dwell_then_move(machines):
    """Issue 43: `G04 P.001 G0 X1 Y1` (LinuxCNC's skeleton.ngc) was refused as 'G0 and G4 in one
    block'. LinuxCNC dwells, then moves; the axis words are the move's and are compensated."""
    m = machines["vmc500"]
    moves = interpret(m, DWELL_AND_MOVE)
    np.testing.assert_allclose([mv.end * 1e3 for mv in moves],
                               [[100, 100, 50], [200, 150, 50], [300, 100, 50]], atol=1e-12)
    out, report = compensate_program(m, DWELL_AND_MOVE, tol_um=1.0)
    assert report.moves == 3 and "G04 P.001 G0 X" in out and "G4 P0.5 G1 X" in out
    with pytest.raises(GcodeError, match=r"2:\d+: G0 and G4 \(dwell\) in one block without P: give the dwell "
                                         r"time in P"):
        interpret(m, "G21 G90\nG4 G0 X100 Y100 Z50\nM30\n")


def test_a_subroutine_body_of_plain_moves_is_kept_not_read(machines):
    """Issue 43: LinuxCNC's jog_around.ngc defines a body of plain lines after `G91 G0 X 25`
    (`Y-25`, ...). The fast path for plain lines read them as moves where the body is
    defined ('coordinates without a motion mode'); a body is kept unchanged, line by line."""
    program = "O<jog> sub\nG17\nG21\nG91 G0 X 25\nY-25\nZ-25\nO<jog> endsub\nG90 G0 X100 Y100 Z50\nM2\n"
    out, report = compensate_program(machines["vmc500"], program, tol_um=1.0)
    assert out.splitlines()[:7] == program.splitlines()[:7]
    assert report.passed_through == 7 and report.moves == 1


def test_a_program_reads_back_as_one_batch_of_moves(machines, tmp_path):
    """interpret gives the program's moves as one MoveBatch, in program order: each move's
    line, kind (rapids as POINT), programming mode and, for an arc, its circle. Its text, its
    lines and its file (read once, line by line) give the same batch; a row read on its own is
    that row of the arrays, and its points are the batch's (the arcs' through arc_points)."""
    from volerr_pin.compensation.gcode import ProgramFile, split_lines
    from volerr_pin.compensation import ARC, POINT, MoveBatch
    from volerr_pin.compensation._moves import LINE

    m = machines["vmc500"]
    program = "G21 G90 G17\r\nG0 X100 Y100 Z50\nG1 X200 F500\n\nG2 X300 Y100 I50 J0\nG0 Z80\nG1 X250\nM30"
    moves = interpret(m, program)
    assert isinstance(moves, MoveBatch) and len(moves) == 5
    np.testing.assert_array_equal(moves.kind, [POINT, LINE, ARC, POINT, LINE])
    np.testing.assert_array_equal(moves.line, [2, 3, 5, 6, 7])
    assert not moves.tool_tip.any()
    np.testing.assert_allclose(moves.w1[2] * 1e3, [300, 100, 50], atol=1e-12)
    np.testing.assert_allclose(moves.center[2] * 1e3, [250, 100], atol=1e-12)
    assert tuple(moves.plane[2]) == (0, 1, 2) and moves.sweep[2] == pytest.approx(-math.pi)
    assert moves.r0[2] == pytest.approx(0.05) and moves.r1[2] == pytest.approx(0.05)
    path = tmp_path / "p.nc"
    path.write_bytes(program.encode())
    for other in (interpret(m, split_lines(program)), interpret(m, ProgramFile(path)),
                  interpret(m, ProgramFile(path).lines())):
        for name in ("kind", "w0", "w1", "plane", "center", "r0", "r1", "a0", "sweep", "line", "tool_tip"):
            np.testing.assert_array_equal(getattr(other, name), getattr(moves, name), err_msg=name)
    arc = moves[2]
    assert (arc.line, arc.kind, arc.programming) == (5, "arc", "axes") and moves[-1].kind == "line"
    assert [mv.kind for mv in moves] == ["rapid", "line", "arc", "rapid", "line"]
    k = np.linspace(0.0, 1.0, 7)
    np.testing.assert_array_equal(arc.arc.point(k), moves.desired(np.full(7, 2), k))
    np.testing.assert_array_equal(arc.sample(7), moves.desired(np.full(7, 2), k))
    np.testing.assert_allclose(np.linalg.norm(arc.sample(9)[:, :2] - moves.center[2], axis=1), 0.05, atol=1e-15)
    with pytest.raises(IndexError):
        moves[5]
    tip = interpret(machines["cgm4000"], "G21 G90\nG0 X2000 Y1250 Z300 A0 B0\nG43.4 H1\nG1 X2010\nG49\nG1 X2020\nM30\n")
    np.testing.assert_array_equal(tip.tool_tip, [False, True, False])
    assert [mv.programming for mv in tip] == ["axes", "tool-tip", "axes"]
    empty = interpret(m, "G21 G90\nM30\n")
    assert len(empty) == 0 and empty.w0.shape == (0, 3)
