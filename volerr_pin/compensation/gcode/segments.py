"""The moves of a program as the controller interpolates them (for reading programs back)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arcs import Arc
from ...model import Machine
from .flow import Flow
from . import macros
from .lexer import PROGRAM_END, GcodeError, mask_comments, split_lines
from . import kept
from .modal import Interpreter
from .polar import has_polar, read_polar

__all__ = ["Segment", "interpret"]


@dataclass
class Segment:
    """One interpolated move of a program.

    Attributes
    ----------
    line : int
        1-based line number of its block.
    kind : str
        "rapid" (only the end point is meaningful), "line" (straight in program coordinates) or
        "arc".
    start, end : numpy.ndarray, shape (n_axes,)
        Program coordinates at the ends [m, rad] (axis positions in axis programming).
    arc : Arc or None
        The arc, for ``kind == "arc"``.
    programming : str
        ``"axes"`` or ``"tool-tip"``: what the coordinates are.
    """

    line: int
    kind: str
    start: np.ndarray
    end: np.ndarray
    arc: Arc | None = None
    programming: str = "axes"

    def sample(self, n: int) -> np.ndarray:
        """Points along the move, evenly spaced in its parameter.

        Parameters
        ----------
        n : int
            Number of points, ends included.

        Returns
        -------
        numpy.ndarray, shape (n, n_axes)
            Program coordinates [m, rad].
        """
        k = np.linspace(0.0, 1.0, n)
        if self.kind == "arc":
            return self.arc.point(k)
        return self.start + np.outer(k, self.end - self.start)


def interpret(machine: Machine, text: str, source: str = "<program>", start=None, origin=None,
              programming: str = "axes") -> list[Segment]:
    """The moves of a program as the controller interpolates them.

    Lines are straight in program coordinates, arcs turn about their centres. Moves before
    every axis' position is known, and blocks that cannot be followed (canned cycles ...), are
    taken as rapids or skipped.

    Parameters
    ----------
    machine : Machine
        The machine; its axes are NC address letters.
    text : str
        The program (mm, inch and deg as it selects).
    source : str
        Name of the program, for messages.
    start : array_like, shape (n_axes,), optional
        Axis positions [m, rad] before the program (default: mid-travel).
    origin : array_like, shape (n_axes,), optional
        Program coordinates [m, rad] of the program's zero (default zero).
    programming : str, default "axes"
        Programming mode when the program starts.

    Returns
    -------
    list of Segment
        One per move, in program order, in program coordinates [m, rad]; targets may lie
        outside the travel.

    Raises
    ------
    GcodeError
        A block that cannot be read, naming its line.
    """
    reader = Interpreter(machine, source=source, start=start, origin=origin, programming=programming)
    lines = split_lines(text)
    try:
        expansion = macros.expand(lines, source)
    except macros.Unfollowable:
        expansion = None   # read as it is, macro blocks kept (as compensate_program reads it)
    if expansion is None:
        return _segments(reader, lines, source, None)
    try:
        return _segments(reader, expansion.lines, source, expansion.origin)
    except GcodeError as err:
        raise macros.renamed(err, source, expansion.origin) from None


def _segments(reader: Interpreter, lines, source: str, origin) -> list[Segment]:
    state = reader.initial_state()
    flow = Flow(source)
    out = []
    for number, (body, _) in enumerate(lines, start=1):
        masked = mask_comments(body, number, source)
        if has_polar(masked) and flow.body is None:
            body = read_polar(reader, body, masked, number, state)
            if body is None:   # a canned cycle's position
                continue
            masked = mask_comments(body, number, source)
        code = masked.upper()
        if flow.line(code, number):
            continue   # a subroutine body runs where it is called
        block, problem = kept.classify(reader, body, number, state, masked)
        if problem:
            kept.skip(reader, body, state, block, number)
            flow.called(code, state, f"{source}:{number}")
            continue
        move = reader.advance(block, state, check_travel=False)
        if move is not None:
            out.append(_segment(reader, block, move, state, number if origin is None else origin[number - 1]))
        if any(w.letter == "M" and w.value in PROGRAM_END for w in block.words):
            break   # the program ends: nothing after it is read
    return out


def _segment(reader: Interpreter, block, move, state, number: int) -> Segment:
    """The segment of a block's move: a rapid (also a move from an unknown position), a line or
    an arc."""
    mode = "tool-tip" if move.tool_tip else "axes"
    if not move.start_known.all() or move.motion == 0:
        return Segment(number, "rapid", move.start, move.target, programming=mode)
    if move.motion == 1:
        return Segment(number, "line", move.start, move.target, programming=mode)
    return Segment(number, "arc", move.start, move.target,
                   reader.arc(block, move.start, move.target, move.motion == 2, state), mode)
