"""The per-line shortcuts of the NC compensator give what the plain definitions give.

Issue 25's throughput work replaced per-line steps by cheaper ones (numbers written in one loop
over plain floats, the lexer's quick path for lines of plain words, ``.tolist()`` instead of
NumPy scalars). Each is checked here against its definition, on numbers drawn at random with
fixed seeds and on the spellings that could tell them apart (negative zero, halves at the last
decimal, incremental sections, inch, rotary axes, an origin).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from volerr_pin.compensation.gcode import _lexer as lexer, parse_block
from volerr_pin.compensation.gcode._modal import Interpreter
from volerr_pin.compensation.gcode._rewrite import Writer
from volerr_pin.compensation.gcode._arc_words import arc_errors


def _values_by_definition(writer: Writer, end, prev, st: dict) -> dict[str, str]:
    """Writer.values as documented: fmt(round(from_si(end - origin), digits)), less the same
    of the start in incremental mode."""
    reader, inch = writer.reader, st["inch"]
    out = {}
    for j, axis in enumerate(reader.axes):
        d = writer.digits(axis, inch)
        origin = float(reader.origin[j])
        value = round(reader.from_si(axis, float(end[j]) - origin, inch), d)
        if not st["absolute"]:
            value -= round(reader.from_si(axis, float(prev[j]) - origin, inch), d)
        out[axis] = writer.fmt(axis, value, inch)
    return out


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_written_numbers_match_their_definition(machines, name):
    """Random positions (with values at halves of the last decimal and near zero of both
    signs), absolute and incremental, mm and inch, with and without an origin."""
    machine = machines[name]
    rng = np.random.default_rng(25)
    n = len(machine.axes)
    for origin in (None, rng.normal(0.0, 0.05, n)):
        reader = Interpreter(machine, origin=origin)
        writer = Writer(reader, 1e-6, 1e-7)
        ends = rng.uniform(-1.0, 1.0, (400, n))
        ends[:50] = rng.normal(0.0, 1e-8, (50, n))  # around zero: "-0.0000" must not appear
        ends[50:100] = np.round(ends[50:100], 7) + 0.5e-7  # halves at the fourth mm decimal
        if reader.origin.any():
            ends += reader.origin
        prevs = ends + rng.normal(0.0, 1e-4, ends.shape)
        rel = (ends - reader.origin)[:, 0]
        assert ((rel < 0) & (rel > -5e-8)).any()  # the draw reaches "-0.0000", written "0.0000"
        for absolute in (True, False):
            for inch in (False, True):
                st = {"absolute": absolute, "inch": inch}
                for end, prev in zip(ends, prevs):
                    want = _values_by_definition(writer, end, prev, st)
                    assert writer.values(end, prev, st) == want
                    # sequences of floats (not arrays) give the same
                    assert writer.values(list(end), tuple(prev), st) == want
                    assert not any(v.startswith("-0.") and float(v) == 0 for v in want.values())


def test_quick_word_reading_matches_the_full_scan(monkeypatch):
    """Lines of plain words read the same through the lexer's quick path as through its full
    scan (forced here by a pattern that matches nothing)."""
    rng = np.random.default_rng(7)
    letters = "XYZABCFSGMNIJKRxyz"
    for _ in range(500):
        words = []
        for _ in range(rng.integers(1, 7)):
            letter = letters[rng.integers(len(letters))]
            sign = ["", "-", "+"][rng.integers(3)] if letter not in "GMNFS" else ""
            whole = str(rng.integers(0, 10 ** rng.integers(1, 5)))
            number = [whole, whole + ".", whole + "." + str(rng.integers(0, 10000)), "." + str(rng.integers(1, 99))]
            words.append(letter + [" ", "", "\t"][rng.integers(3)] * int(rng.integers(0, 2)) + sign
                         + number[rng.integers(4)])
        line = (" " * int(rng.integers(0, 2))).join(w + " " * int(rng.integers(0, 3)) for w in words)
        assert lexer.SIMPLE.fullmatch(line)  # the quick path takes it
        quick = parse_block(line, 5, "p")
        with monkeypatch.context() as patch:
            patch.setattr(lexer, "SIMPLE", re.compile(r"(?!)"))
            full = parse_block(line, 5, "p")
        assert [(w.letter, w.value, w.text, w.start, w.end) for w in quick.words] == \
               [(w.letter, w.value, w.text, w.start, w.end) for w in full.words]


def _random_program(rng, axes: str, travel_mm: np.ndarray, n: int) -> str:
    """A program mixing plain axis-word lines with everything the fast path must leave to the
    full reader: N, G, F, M and comment words, G91 sections, inch, lower case, blanks inside
    words, repeated modes, a tool change (positions lost), arcs."""
    lines = ["G21 G90 G17 G94", "G0 " + " ".join(f"{a}{v:.3f}" for a, v in zip(axes, travel_mm.mean(axis=1))),
             "G1 F1500"]
    p = travel_mm.mean(axis=1)
    incremental = inch = False
    for i in range(n):
        step = rng.normal(0.0, 2.0, len(axes))
        q = np.clip(p + step, travel_mm[:, 0] + 5, travel_mm[:, 1] - 5)
        pick = rng.random(len(axes)) < 0.7
        pick[rng.integers(len(axes))] = True
        q = np.where(pick, q, p)  # the axes not named stay
        scale = 1 / 25.4 if inch else 1.0
        vals = (q - p if incremental else q) * np.where([a in "XYZ" for a in axes], scale, 1.0)
        words = [f"{a}{v:.4f}" for a, v, k in zip(axes, vals, pick) if k]
        r = rng.random()
        if r < 0.55:
            line = " ".join(words)
        elif r < 0.60:
            line = "".join(words)  # no blanks
        elif r < 0.65:
            line = "\t ".join(w.lower() for w in words)
        elif r < 0.70:
            line = f"N{10 * i} " + " ".join(words)
        elif r < 0.75:
            line = " ".join(words) + " (a comment)"
        elif r < 0.80:
            line = "G1 " + " ".join(words) + f" F{rng.integers(100, 3000)}"
        elif r < 0.83:
            line = "G0 " + " ".join(words)
        elif r < 0.86:
            line = " ".join(w[0] + " " + w[1:] for w in words)  # blank between letter and number
        elif r < 0.88:
            incremental = not incremental
            line = ("G91 " if incremental else "G90 ") + " ".join(words)
            vals = (q - p if incremental else q) * np.where([a in "XYZ" for a in axes], scale, 1.0)
            line = ("G91 " if incremental else "G90 ") + " ".join(
                f"{a}{v:.4f}" for a, v, k in zip(axes, vals, pick) if k)
        elif r < 0.90 and not incremental:
            inch = not inch
            line = "G20" if inch else "G21"
            q = p
        elif r < 0.92:
            line = "M8"
            q = p
        elif r < 0.93 and not incremental:
            line = "T2 M6"  # positions lost until every axis is programmed again
            q = p
            lines.append(line)
            line = "G0 " + " ".join(f"{a}{v * (scale if a in 'XYZ' else 1.0):.4f}" for a, v in zip(axes, p))
        elif r < 0.95 and "X" in axes and not incremental and not inch:
            # a quarter circle in XY, then G1 again
            rad = 3.0
            cx, cy = p[0] + rad, p[1]
            q = p.copy()
            q[0], q[1] = cx, cy + rad
            line = f"G3 X{q[0]:.4f} Y{q[1]:.4f} I{rad:.4f} J0"
            lines.append(line)
            line = "G1"
        else:
            line = " ".join(words) + " ; end comment"
        lines.append(line)
        p = q
    lines.append("M30")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("name,seed", [("vmc500", 1), ("vmc500", 2), ("cgm4000", 3)])
def test_fast_path_writes_what_the_full_reader_writes(machines, name, seed):
    """Programs drawn at random (fixed seeds) compensate to the same text and the same report
    with the fast path for plain axis-word lines as with every line through the full reader."""
    from volerr_pin.compensation.gcode import Program

    machine = machines[name]
    axes = "".join(machine.axes)
    rotary = np.array([k == "rotary" for k in machine.axis_kinds])[:, None]
    travel = np.where(np.isfinite(machine.travel), machine.travel, 0.5)
    travel_mm = np.where(rotary, np.clip(np.degrees(travel), -40, 40), travel * 1e3)
    text = _random_program(np.random.default_rng(seed), axes, travel_mm, 300)
    outs = []
    for fast in (True, False):
        program = Program(machine, tol_um=1.0)
        if not fast:
            program._plain = program._arc = None
        out = program.compensate(text)
        outs.append((out, program.report.to_dict()))
    assert outs[0][0] == outs[1][0]
    assert repr(outs[0][1]) == repr(outs[1][1])
    plain = sum(bool(Program(machine)._plain.fullmatch(line)) for line in text.splitlines())
    assert plain > 100  # the fast path took a good share of the lines


def _runs_program(rng, axes: str, travel_mm: np.ndarray, n: int) -> str:
    """Long runs of plain lines (beyond a chunk) between other lines: G0 and G1 runs, moves
    short and across the workspace (split into pieces), runs with sequence numbers (N) on
    every line and feed words (F) on some, inverse time feed sections, inch sections, values around zero, runs of arc lines (the first with its G
    word, the others modal, some with a centre word of another plane), CR LF endings and a
    last line without an ending."""
    lines = ["G21 G90 G17 G94", "G0 " + " ".join(f"{a}{v:.3f}" for a, v in zip(axes, travel_mm.mean(axis=1))),
             "G1 F1500"]
    p = travel_mm.mean(axis=1)
    inch = False
    low, high = travel_mm[:, 0] + 1, travel_mm[:, 1] - 1
    while len(lines) < n:
        r = rng.random()
        if r < 0.1:
            lines.append(["G0", "G1", "G20" if not inch else "G21", "M8", "N5 G1", "G93", "G94"][rng.integers(7)])
            inch = inch != (lines[-1] in ("G20", "G21"))
            continue
        if r < 0.16 and "X" in axes and not inch:
            # quarter circles, the first with its G word (G2, G02, G3 or G03), the next ones
            # modal; some with the plane's third centre word (kept, with a note); then G1
            code = ["G2", "G02", "G3", "G03"][rng.integers(4)]
            clockwise = code in ("G2", "G02")
            for k in range(int(rng.integers(1, 40))):
                rad = float(rng.uniform(0.5, 3.0))
                q = p.copy()
                q[0], q[1] = p[0] + rad, p[1] + rad
                if not (q[:2] < high[:2]).all():
                    break
                centre = f"I{rad:.4f} J0" if clockwise else f"I0 J{rad:.4f}"
                third = f" K{rng.normal():.3f}" if rng.random() < 0.05 else ""
                lines.append((f"{code} " if k == 0 else "") + f"X{q[0]:.4f} Y{q[1]:.4f} {centre}{third}")
                p = q
            lines.append("G1")
            continue
        count = int(rng.integers(50, 3000))
        far = rng.random() < 0.3
        numbered = rng.random() < 0.3  # a sequence number on every line of the run
        feeds = rng.random() < 0.3  # feed words on half the lines of the run
        for _ in range(count):
            if far and rng.random() < 0.2:
                q = low + rng.random(len(axes)) * (high - low)
            else:
                q = np.clip(p + rng.normal(0.0, 0.5, len(axes)), low, high)
            pick = rng.random(len(axes)) < 0.8
            pick[rng.integers(len(axes))] = True
            q = np.where(pick, q, p)
            scale = np.where([a in "XYZ" for a in axes], 1 / 25.4 if inch else 1.0, 1.0)
            words = [f"{a}{v * s:.4f}" for a, v, s, k in zip(axes, q, scale, pick) if k]
            line = (" " if rng.random() < 0.9 else "").join(words)
            if feeds and rng.random() < 0.5:  # a feed word, somewhere among the axis words
                at = int(rng.integers(0, len(words) + 1))
                line = " ".join(words[:at] + [f"F{rng.integers(1, 5000)}" + ["", ".", ".5"][rng.integers(3)]]
                                + words[at:])
            if numbered:
                line = f"N{len(lines) * 10:0{int(rng.integers(1, 6))}d}" + ["", " ", "  "][rng.integers(3)] + line
            lines.append(line)
            p = q
    ends = ["\r\n" if rng.random() < 0.05 else "\n" for _ in lines]
    return "".join(line + end for line, end in zip(lines, ends)) + "X" + f"{p[0] * (1 / 25.4 if inch else 1):.4f}"


@pytest.mark.parametrize("name,seed,programming", [("vmc500", 4, "axes"), ("cgm4000", 5, "axes"),
                                                   ("cgm4000", 6, "tool-tip")])
def test_runs_of_plain_lines_write_what_the_full_reader_writes(machines, name, seed, programming):
    """Runs of plain lines longer than a chunk, read and written as arrays, give the same text,
    report and per-move detail as every line through the full reader."""
    from volerr_pin.compensation.gcode import _chunks as chunks
    from volerr_pin.compensation.gcode import Program

    machine = machines[name]
    axes = "".join(machine.axes)
    rotary = np.array([k == "rotary" for k in machine.axis_kinds])[:, None]
    travel = np.where(np.isfinite(machine.travel), machine.travel, 0.5)
    travel_mm = np.where(rotary, np.clip(np.degrees(travel), -20, 20), travel * 1e3)
    if programming == "tool-tip":  # tool tips near mid-travel, where the axes can reach them
        mid = travel_mm.mean(axis=1, keepdims=True)
        travel_mm = mid + 0.2 * (travel_mm - mid)
    text = _runs_program(np.random.default_rng(seed), axes, travel_mm, 12_000)
    outs, runs = [], []
    for fast in (True, False):
        program = Program(machine, tol_um=1.0, detail=True, programming=programming,
                          origin=np.zeros(len(axes)) if fast else None)
        if not fast:
            program._plain = program._arc = None
        if fast:
            close = program._close
            program._close = lambda run, state: runs.append(run.count) or close(run, state)
        out = program.compensate(text)
        d = program.report.detail
        outs.append((out, repr(program.report.to_dict()), (d._line, d._pieces, d._before, d._after)))
    assert outs[0][0] == outs[1][0]
    assert outs[0][1] == outs[1][1]
    assert outs[0][2] == outs[1][2]
    assert max(runs) > chunks.FIRST_CHUNK  # runs longer than a chunk were taken
    assert sum(runs) > 0.8 * text.count("\n")
    assert program.report.pieces > program.report.moves  # some moves were split


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_run_templates_write_what_the_writer_writes(machines, name):
    """The templates of a run write each line as Writer.rewrite writes it, with and without a
    sequence number, with values around zero of both signs and at halves of the last decimal, mm and inch, an origin, and the
    motion word a run's first line gets when the output's modal motion differs; a split move's
    further pieces as Writer.new_line writes them."""
    from volerr_pin.compensation import Piece
    from volerr_pin.compensation.gcode._runs import PlainRun, PlainRuns, plain_line, plain_words

    machine = machines[name]
    rng = np.random.default_rng(11)
    axes = machine.axes
    n = len(axes)
    reader = Interpreter(machine, origin=rng.normal(0.0, 0.01, n))
    writer = Writer(reader, 1e-6, 1e-7)
    runs, plain = PlainRuns(reader, writer), plain_line(axes)
    for inch in (False, True):
        for motion, out_motion in ((1, 1), (1, 0), (0, None)):
            run = PlainRun(7)
            run.motion = motion
            for _ in range(200):
                pick = [a for a in axes if rng.random() < 0.6] or [axes[0]]
                order = rng.permutation(len(pick))
                body = (" " * int(rng.integers(0, 2))) + (" " if rng.random() < 0.8 else "\t").join(
                    f"{pick[i]}{['', ' '][rng.integers(2)]}{rng.normal(0, 100):.3f}" for i in order)
                if rng.random() < 0.3:
                    body = body + [" ", ""][rng.integers(2)] + f"F{rng.integers(1, 9000)}"
                if rng.random() < 0.3:
                    body = f"N{rng.integers(0, 10 ** 6)}" + [" ", "", "\t"][rng.integers(3)] + body.lstrip()
                shape = runs.shape(body)
                assert shape is not None, body
                assert runs.add(run, body, ["\n", "\r\n", ""][rng.integers(3)], shape)
            counts = rng.integers(1, 4, run.count)
            ends = rng.uniform(-0.5, 0.5, (int(counts.sum()), n))
            ends[::7] = rng.normal(0.0, 1e-8, ends[::7].shape)  # around zero: "-0.0000" must not appear
            ends[3::7] = np.round(ends[3::7], 7) + 0.5e-7  # halves at the fourth mm decimal
            ends += reader.origin
            got = runs.write(run, ends, counts, inch, out_motion, "\r\n")
            want = []
            st = {"absolute": True, "inch": inch, "out_motion": out_motion}
            rows = iter(ends)
            for body, newline, count in zip(run.bodies, run.newlines, counts):
                block = parse_block(body, 1, "p")
                words = [w for w in block.words if w.letter not in "NF"]
                if not body.startswith("N") and "F" not in body:
                    assert words == plain_words(plain, body)
                end = next(rows)
                inner = newline or "\r\n"  # a line's own ending, else the program's
                first = writer.rewrite(block, Piece("line", end, end), end, st, motion, words)
                want.append(first + (newline if count == 1 else inner))
                for m in range(count - 1):
                    end2 = next(rows)
                    want.append(writer.new_line(Piece("line", end, end2), end, st, motion)
                                + (newline if m == count - 2 else inner))
            assert got == want
            assert ("G" in want[0]) == (out_motion != motion)  # (no other word holds a G)


@pytest.mark.parametrize("bad", ["X900.0 Y100", "Y1" + "0" * 400, "X10 X20", "X1.2.3", "x10", "N-3 X101",
                                 "X101 F-5", "X101 F+5", "X101 F100 F200", "F100",
                                 "N10.5 X101", "X101 N10", "N5 N6 X101", "G2 X101 Y100 I0.5", "X101 I1 J0",
                                 "G3 X117 Y101 I0 J0", "G2 X117 Y101 I1 I2", "G2 X900 Y101 I1 J0"])
def test_a_bad_line_inside_a_run_is_named_as_the_full_reader_names_it(machines, bad):
    """A line beyond the travel or any number, a repeated axis, a malformed number or sequence
    number, an arc that its words cannot define or a centre word on a straight move, in the
    middle of a long run of plain lines: the same error, naming the same line, with and
    without the run path."""
    from volerr_pin.compensation.gcode import GcodeError
    from volerr_pin.compensation.gcode import Program

    machine = machines["vmc500"]
    body = [f"X{100 + 0.01 * i:.3f} Y{100 + 0.02 * (i % 50):.3f}" for i in range(3000)]
    body[1700] = bad
    text = "G90 G21\nG0 X100 Y100 Z100\nG1 F1000\n" + "\n".join(body) + "\nM30\n"
    messages = []
    for fast in (True, False):
        program = Program(machine, tol_um=1.0)
        if not fast:
            program._plain = program._arc = None
        try:
            program.compensate(text)
            messages.append(None)
        except GcodeError as err:
            messages.append(str(err))
    assert messages[0] == messages[1]
    if bad not in ("x10", "F100"):  # a lower-case letter is read (by the full reader); F alone moves nothing
        assert messages[0] is not None and ":1704" in messages[0], messages[0]


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_arc_read_back_errors_of_a_chunk_match_each_piece(machines, name):
    """arc_errors (a chunk's arc pieces at once) gives what ArcWords.arc_error gives piece
    by piece: random arcs in the three planes, mm and inch, with an origin, clockwise and not,
    from 0.2 um to 50 mm of radius (the smallest round to no centre, or to one whose circle
    misses the written ends), including arcs read back as the rest of the circle; with centres
    as offsets or (G90.1) absolute, X as a radius or (G7) a diameter."""
    from volerr_pin.compensation import Piece

    machine = machines[name]
    rng = np.random.default_rng(12)
    n = len(machine.axes)
    reader = Interpreter(machine, origin=rng.normal(0.0, 0.01, n))
    writer = Writer(reader, 1e-6, 1e-7)
    count = 3000
    plane = rng.choice([17, 18, 19], count)
    inch = rng.random(count) < 0.3
    radius = np.exp(rng.uniform(np.log(2e-7), np.log(0.05), count))
    a0 = rng.uniform(-np.pi, np.pi, count)
    turns = rng.uniform(0.05, 1.5, count) * np.where(rng.random(count) < 0.5, -1, 1)
    turns[:200] = np.sign(turns[:200]) * (2 * np.pi - rng.uniform(1e-9, 1e-5, 200))  # nearly full circles
    start = rng.uniform(-0.3, 0.3, (count, n))
    end = start + rng.normal(0.0, 1e-3, (count, n))
    centre = np.zeros((count, 2))
    for m in range(count):
        i, j = (machine.axes.index(a) for a in {17: "XY", 18: "ZX", 19: "YZ"}[plane[m]])
        centre[m] = start[m, [i, j]] - radius[m] * np.array([np.cos(a0[m]), np.sin(a0[m])])
        end[m, i] = centre[m, 0] + radius[m] * np.cos(a0[m] + turns[m])
        end[m, j] = centre[m, 1] + radius[m] * np.sin(a0[m] + turns[m])
    absolute = rng.random(count) < 0.3
    diameter = rng.random(count) < 0.3
    got = arc_errors(writer, start, end, centre, turns, plane, inch, absolute, diameter)
    want = np.array([writer.arcs.arc_error(Piece("arc", start[m], end[m], centre[m], turns[m] < 0, turns[m]),
                                           start[m], {"plane": plane[m], "inch": inch[m],
                                                      "centres_absolute": absolute[m], "diameter": diameter[m]},
                                           {"ijk"})
                     for m in range(count)])
    finite = np.isfinite(want)
    assert 0.5 < finite.mean() < 0.99  # both outcomes occur
    assert (np.isfinite(got) == finite).all()
    assert np.allclose(got[finite], want[finite], rtol=1e-9, atol=1e-13)


def test_feed_words_in_runs_under_inverse_time_are_shared_out_as_the_writer_does(machines):
    """Under G93 a split move's F words are its pieces' shares of its time; lines with F in a
    run of long moves (split into pieces) give what the full reader gives, and so do the same
    lines under G94, where F stays on the first piece."""
    from volerr_pin.compensation.gcode import Program

    machine = machines["vmc500"]
    rng = np.random.default_rng(93)
    points = np.array([5.0, 5.0, 5.0]) + rng.random((600, 3)) * np.array([490.0, 390.0, 390.0])
    body = [f"X{x:.3f} Y{y:.3f} Z{z:.3f}" + (f" F{rng.integers(2, 60)}" if i % 3 else "")
            for i, (x, y, z) in enumerate(points)]
    for mode in ("G93", "G94"):
        text = f"G90 G21 {mode}\nG0 X250 Y200 Z200\nG1 X251 F10\n" + "\n".join(body) + "\n"
        outs = []
        for fast in (True, False):
            program = Program(machine, tol_um=1.0)
            if not fast:
                program._plain = program._arc = None
            outs.append((program.compensate(text), repr(program.report.to_dict())))
        assert outs[0] == outs[1]
        assert outs[0][0].count("\n") > 1.5 * len(body)  # the moves were split
        feeds = [line for line in outs[0][0].splitlines() if "F" in line]
        assert (len(feeds) > len(body)) == (mode == "G93")  # every piece has its F under G93 only
