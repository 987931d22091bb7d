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

from volerr_pin.gcode import parse_block
from volerr_pin.gcode import lexer
from volerr_pin.gcode.modal import Interpreter
from volerr_pin.gcode.rewrite import Writer


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
