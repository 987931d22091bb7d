"""Runs of plain lines, read, followed and written as arrays.

Most of a long finishing program is lines of axis words only (``X12.5 Y-3 Z40.25``). Between
two other lines such lines change nothing but the position, so a run of them is read as one
table of numbers: the targets are the written values filled forward from the position before
the run, the travel is checked for the whole table at once, and the compensated lines are
written from one template per shape of line (its letters and blanks) with the numbers put in.
Everything done here is what the line-by-line reader and writer do for such lines, with the
same arithmetic, so the output is the same byte for byte (``tests/compensation/test_nc_throughput.py``);
whatever this path cannot take (a move split into pieces, a number beyond range, a target
outside the travel) goes back to the line-by-line path, which writes it or names the error.
"""

from __future__ import annotations

import math
import re

import numpy as np

from ._lexer import NUMBER, WORD, Word
from ._modal import Interpreter, ModalState

__all__ = ["PlainRun", "PlainRuns", "arc_line", "arc_words", "plain_line", "plain_words"]

#: distinct shapes of line remembered (a program has a handful; past this the memory is reset)
MOST_SHAPES = 4096


class _Shape:
    """One shape of plain line: the axes its words name (in the order written), where its
    sequence number (N) and feed (F) words are among its numbers (``kept``: field name by
    position, None if it has neither), and the templates of the compensated line (mm and inch;
    the kept words are the fields ``n`` and ``f``, written as they were) with the part before
    the first axis word (``head``)."""

    __slots__ = ("axes", "kept", "feed", "templates", "head")

    def __init__(self, axes: tuple[int, ...], kept: dict | None, templates: dict, head: str):
        self.axes, self.kept, self.templates, self.head = axes, kept, templates, head
        self.feed = kept is not None and "f" in kept.values()


class PlainRun:
    """Consecutive plain lines: their text, shapes and numbers, and once closed the moves.

    Attributes
    ----------
    first : int
        Line number of the first line.
    bodies, newlines : list of str
        Each line without its ending, and the ending.
    shapes : list of _Shape
        Each line's shape.
    numbers : list of str
        The axis words' numbers of every line, in order.
    labels : dict of int to dict
        The sequence numbers and feeds of the lines that have them (``{"n": "120", "f":
        "1500"}``, as written), by line of the run.
    starts, targets : ndarray, shape (N, n_axes)
        Once closed: program coordinates before and after each line's move [m, rad].
    kind : int
        LINE (G1) or POINT (G0) for every move of the run.
    modes : dict
        The output state the lines are written in.
    mode : str
        Programming mode, ``"axes"`` or ``"tool-tip"``.
    """

    __slots__ = ("first", "bodies", "newlines", "shapes", "numbers", "labels", "starts", "targets", "kind", "motion",
                 "modes", "mode")

    def __init__(self, first: int):
        self.first = first
        self.bodies: list[str] = []
        self.newlines: list[str] = []
        self.shapes: list[_Shape] = []
        self.numbers: list[str] = []
        self.labels: dict[int, dict] = {}

    @property
    def count(self) -> int:
        """Moves (lines) of the run (int)."""
        return len(self.bodies)


class PlainRuns:
    """Reads and writes runs of plain lines for one program.

    Parameters
    ----------
    reader : Interpreter
        The program's interpreter (axes, scales, origin, travel).
    writer : Writer
        The program's writer (decimals of each axis).
    """

    def __init__(self, reader: Interpreter, writer):
        self.reader = reader
        self.axes = reader.axes
        self._number = re.compile(NUMBER)
        letters = "".join(reader.axes)
        # a plain line with its numbers replaced by "#": a sequence number, then axis words and a
        # feed word separated by blanks or nothing
        self._skeleton = re.compile(rf"[ \t]*(?:N[ \t]*#[ \t]*)?(?:[F{letters}][ \t]*#[ \t]*)+")
        self._word = re.compile(rf"([NF{letters}])[ \t]*#")
        self._shapes: dict[str, _Shape | None] = {}
        n = len(reader.axes)
        self.set_origin(reader.origin)
        self._scale = {inch: np.array([reader._scale[a, inch] for a in reader.axes]) for inch in (False, True)}
        self._digits = {inch: [writer.digits(a, inch) for a in reader.axes] for inch in (False, True)}
        self._low = np.array(reader._low) - np.array(reader._slack)
        self._high = np.array(reader._high) + np.array(reader._slack)
        self._n = n

    # reading -------------------------------------------------------------------------

    def set_origin(self, origin: np.ndarray) -> None:
        """Read and write the runs that follow from another program zero (a work offset the
        program selects).

        Parameters
        ----------
        origin : numpy.ndarray, shape (n_axes,)
            The program's zero [m, rad].
        """
        self._origin = np.array([float(v) for v in origin])
    def takes(self, state: ModalState) -> bool:
        """Whether plain lines can be read as a run in this state: absolute G0 / G1 with every
        axis known, outside canned cycles, kept regions and lathe diameter mode.

        Parameters
        ----------
        state : ModalState
            The modal state.

        Returns
        -------
        bool
            True if a plain line would only move the axes it names.
        """
        return (state.motion in (0, 1) and state.absolute and not state.canned and not state.regions
                and not state.diameter and all(state.known.tolist()))

    def shape(self, body: str) -> _Shape | None:
        """The shape of a plain line, or None if the line is anything else.

        Parameters
        ----------
        body : str
            The line without its ending.

        Returns
        -------
        _Shape or None
            Its axes and templates.
        """
        skeleton = self._number.sub("#", body)
        try:
            return self._shapes[skeleton]
        except KeyError:
            pass
        if len(self._shapes) >= MOST_SHAPES:
            self._shapes.clear()
        shape = self._shapes[skeleton] = self._make(skeleton)
        return shape

    def _make(self, skeleton: str) -> _Shape | None:
        if not self._skeleton.fullmatch(skeleton):
            return None
        words = list(self._word.finditer(skeleton))
        letters = [m.group(1) for m in words]
        if len(set(letters)) != len(letters) or not set(letters) - {"N", "F"}:
            return None  # a repeated word, or no axis: the full reader takes it
        index = {a: j for j, a in enumerate(self.axes)}
        axes = tuple(index[a] for a in letters if a in index)
        kept = {k: a.lower() for k, a in enumerate(letters) if a in "NF"} or None
        last = max(k for k, a in enumerate(letters) if a in index)
        templates, head = {}, None
        for inch in (False, True):
            digits = self._digits[inch]
            parts, at = [], 0
            for k, (m, letter) in enumerate(zip(words, letters)):
                parts.append(skeleton[at:m.start()])
                if letter in index:
                    if head is None:
                        head = "".join(parts)
                    j = index[letter]
                    parts.append(f"{letter}{{{j}:.{digits[j]}f}}")
                else:  # a sequence number or feed, as written
                    parts.append(skeleton[m.start():m.end()].replace("#", "{" + letter.lower() + "}"))
                at = m.end()
                if k == last:
                    # axes the line does not name follow its last axis word, in the machine's order
                    parts.extend(f" {self.axes[j]}{{{j}:.{digits[j]}f}}" for j in range(self._n) if j not in axes)
            parts.append(skeleton[at:])
            templates[inch] = "".join(parts)
        return _Shape(axes, kept, templates, head)

    def add(self, run: PlainRun, body: str, newline: str, shape: _Shape, inverse_time: bool = False) -> bool:
        """Add a plain line to a run.

        Parameters
        ----------
        run : PlainRun
            The open run.
        body, newline : str
            The line without its ending, and the ending.
        shape : _Shape
            Its shape (:meth:`shape`).
        inverse_time : bool
            Inverse time feed (G93) is on: a feed word then changes with the pieces of a
            split move, so a line with one is left to the line-by-line writer.

        Returns
        -------
        bool
            False (and nothing added) if the line's sequence number is not a whole number
            without sign, its feed has a sign or no value, or it has a feed under inverse
            time (the full reader takes it).
        """
        numbers = self._number.findall(body)
        if shape.kept is not None:
            if shape.feed and inverse_time:
                return False
            words = {}
            for k, name in shape.kept.items():
                text = numbers[k]
                if (name == "n" and not text.isdigit()) or text[0] in "+-" or not math.isfinite(float(text)):
                    return False
                words[name] = text
            run.labels[run.count] = words
            numbers = [v for k, v in enumerate(numbers) if k not in shape.kept]
        if self.reader.dialect.decimal_point and any("." not in v and float(v) for v in numbers):
            return False   # a whole number of increments: the full reader names it
        run.bodies.append(body)
        run.newlines.append(newline)
        run.shapes.append(shape)
        run.numbers += numbers
        return True

    def close(self, run: PlainRun, state: ModalState) -> bool:
        """Follow a run's moves from the state before it: targets, travel, and the state after.

        Parameters
        ----------
        run : PlainRun
            The run (its lines added).
        state : ModalState
            The modal state before the run; updated (position) when the run is taken.

        Returns
        -------
        bool
            True if the run was taken; False if some line holds a number beyond range or a
            target outside the travel (the state is then unchanged, and the lines go through
            the line-by-line reader, which names the problem).
        """
        n, count = self._n, run.count
        values = np.fromiter(map(float, run.numbers), dtype=float, count=len(run.numbers))
        lengths = [len(s.axes) for s in run.shapes]
        rows = np.repeat(np.arange(1, count + 1), lengths)
        cols = np.fromiter((j for s in run.shapes for j in s.axes), dtype=np.intp, count=len(values))
        scale = self._scale[state.inch]
        # the reader's arithmetic, value * scale + origin, per element
        table = np.empty((count + 1, n))
        table[0] = state.position
        table[rows, cols] = values * scale[cols] + self._origin[cols]
        if not np.isfinite(table[rows, cols]).all():
            return False
        source = np.zeros((count + 1, n), dtype=np.intp)
        source[rows, cols] = rows
        np.maximum.accumulate(source, axis=0, out=source)
        table = table[source, np.arange(n)]
        targets = table[1:]
        if not state.tool_tip and ((targets < self._low) | (targets > self._high)).any():
            return False
        run.starts, run.targets = table[:-1], targets
        run.motion = state.motion
        state.position = targets[-1].copy()
        return True

    # writing -------------------------------------------------------------------------
    def write(self, run: PlainRun, ends: np.ndarray, counts: np.ndarray, inch: bool, out_motion: int | None,
              eol: str) -> list[str]:
        """The compensated text of a run's lines: each line carries its move's first piece
        (its words' numbers replaced, the axes it does not name appended), further pieces of
        a split move follow as new lines with every axis and the motion word, as
        :meth:`~volerr_pin.compensation.gcode._rewrite.Writer.write_move` writes them.

        Parameters
        ----------
        run : PlainRun
            The run.
        ends : ndarray, shape (P, n_axes)
            The compensated command at the end of every piece of the run's moves, in order
            (program coordinates) [m, rad]; the pieces are straight.
        counts : ndarray of int, shape (N,)
            Pieces of each line's move.
        inch : bool
            Whether linear values are written in inch.
        out_motion : int or None
            The output's modal motion before the run's first line.
        eol : str
            The line ending of inserted lines (a line's own ending is used where it has one).

        Returns
        -------
        list of str
            The lines, with their endings.
        """
        values = (ends - self._origin) / self._scale[inch]
        # "-0.0000" is written "0.0000": the few values that may format so are checked one by one
        digits = self._digits[inch]
        near = np.flatnonzero(((values <= 0) & (values > -np.power(10.0, -np.array(digits)))).any(axis=1))
        table = values.tolist()
        zeros = {d: "-0." + "0" * d for d in digits}
        for i in near.tolist():
            row = table[i]
            for j, d in enumerate(digits):
                if row[j] <= 0 and f"{row[j]:.{d}f}" == zeros[d]:
                    row[j] = 0.0
        shapes, newlines, labels = run.shapes, run.newlines, run.labels
        if len(table) == run.count and not labels:  # every move one piece, no sequence numbers
            out = [shape.templates[inch].format(*row) + newline
                   for shape, row, newline in zip(shapes, table, newlines)]
        else:
            new = self._new_line(inch, run.motion)
            out = []
            rows = iter(table)
            for i, (shape, count, newline) in enumerate(zip(shapes, counts.tolist(), newlines)):
                template = shape.templates[inch]
                first = (template.format(*next(rows), **labels[i]) if shape.kept is not None
                         else template.format(*next(rows)))
                if count == 1:
                    out.append(first + newline)
                    continue
                inner = newline or eol
                out.append(first + inner)
                for _ in range(count - 2):
                    out.append(new.format(*next(rows)) + inner)
                out.append(new.format(*next(rows)) + newline)
        if out and out_motion != run.motion:
            # the run's first line relied on the modal motion: it gets it written when the
            # output's differs (after it, the output's is the run's)
            lead = len(shapes[0].head.format(**labels.get(0, {})))
            out[0] = out[0][:lead] + f"G{run.motion} " + out[0][lead:]
        return out

    def _new_line(self, inch: bool, motion: int) -> str:
        """The template of an inserted line: motion word and every axis."""
        digits = self._digits[inch]
        return f"G{motion} " + " ".join(f"{a}{{{j}:.{digits[j]}f}}" for j, a in enumerate(self.axes))


def plain_line(axes) -> re.Pattern | None:
    """The lines :meth:`Program._read` takes on its fast path: upper-case axis words with
    plain numbers, separated by blanks or nothing (a subset of what the lexer's quick path
    reads); None if an axis letter could begin an exponent (E)."""
    if "E" in axes:
        return None
    return re.compile(rf"[ \t]*+(?:[{''.join(axes)}][ \t]*+{NUMBER}[ \t]*+)++")


def plain_words(plain: re.Pattern | None, body: str) -> list[Word] | None:
    """The words of a line of upper-case axis words only, with plain numbers (``plain``, from
    :func:`plain_line`), each axis once; None for any other line.

    For such a line (outside canned cycles and kept regions) kept.classify would read the
    same words through the lexer's quick path and find no problem, _note_offsets nothing to
    note, and Interpreter.advance no G, M or other word to check or apply: it goes straight
    to the move. Anything else (a repeated axis, a number too large) takes the full path,
    which names it."""
    if plain is None or not plain.fullmatch(body):
        return None
    words = _words(body)
    if len({w.letter for w in words}) == len(words) and all(math.isfinite(w.value) for w in words):
        return words
    return None


def arc_line(axes) -> re.Pattern | None:
    """The arc lines :meth:`Program._read` takes on a fast path: an optional G2 / G3 (G02,
    G03) first, then upper-case axis and centre (I, J, K) words with plain numbers; None if an
    axis letter could begin an exponent (E)."""
    if "E" in axes:
        return None
    return re.compile(rf"[ \t]*+(?:G0?[23][ \t]*+)?(?:[{''.join(axes)}IJK][ \t]*+{NUMBER}[ \t]*+)++")


def arc_words(pattern: re.Pattern | None, body: str, axes) -> list[Word] | None:
    """The words of an arc line (``pattern``, from :func:`arc_line`): each letter once, at
    least one axis word and one centre word; None for any other line.

    For such a line in an arc motion mode (outside canned cycles and kept regions)
    kept.classify finds no problem, _note_offsets nothing to note, and Interpreter.advance
    nothing to check but what the move and the arc reader check themselves: its only modal
    effect is the motion mode of its G word. Anything else takes the full path."""
    if pattern is None or not pattern.fullmatch(body):
        return None
    words = _words(body)
    letters = {w.letter for w in words}
    if (len(letters) == len(words) and letters & set(axes) and letters & {"I", "J", "K"}
            and all(math.isfinite(w.value) for w in words)):
        return words
    return None


def _words(body: str) -> list[Word]:
    """The words of a line the fast paths took (letters upper case, numbers plain)."""
    words = []
    for m in WORD.finditer(body):
        letter, text = m.groups()
        start, end = m.span()
        words.append(Word(letter, float(text), m.group(), start, end))
    return words
