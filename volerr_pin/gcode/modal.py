"""The modal interpreter: the controller's state between blocks, and the moves blocks command."""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..compensate import Arc, arc_from_center
from ..errors import InputError
from ..machine import Machine
from ..units import INCH, MM
from .lexer import (CANNED, CENTRE, MACRO_G, NOT_MOVES, PLANES, Block, GcodeError, Word, parse_block,
                    split_lines, uncommented, word_values)


@dataclass
class ModalState:
    """What the controller remembers between blocks.

    Attributes
    ----------
    position : numpy.ndarray, shape (n_axes,)
        Axis positions after the last move [m, rad]; axes the program has not yet
        programmed hold the start position.
    known : numpy.ndarray of bool, shape (n_axes,)
        Axes whose position the program has set (and no skipped block has moved since).
    motion : int or None
        Motion mode: 0 rapid (G0), 1 line (G1), 2 clockwise arc (G2), 3 counter-clockwise
        arc (G3); None before the first motion word and after a canned cycle or G80.
    plane : int
        Arc plane: 17 (XY), 18 (ZX) or 19 (YZ).
    absolute : bool
        Absolute coordinates (G90) rather than incremental ones (G91).
    inch : bool
        Coordinates in inch (G20) rather than mm (G21).
    canned : bool
        A canned cycle is active: axis words are positions of the cycle, not moves.
    """

    position: np.ndarray
    known: np.ndarray
    motion: int | None = None
    plane: int = 17
    absolute: bool = True
    inch: bool = False
    canned: bool = False

    def apply_g(self, codes: Iterable[float]) -> None:
        """Apply the modal G codes of a block (motion, plane, distance and unit modes).

        Parameters
        ----------
        codes : iterable of float
            The values of the block's G words, in order; codes without a modal effect
            modelled here are ignored.
        """
        for g in codes:
            if g in (0, 1, 2, 3):
                self.motion = int(g)
            elif g in CANNED or g == 80:
                self.motion = None  # a cycle, or its cancellation, ends the motion mode
            elif g in (17, 18, 19):
                self.plane = int(g)
            elif g == 90:
                self.absolute = True
            elif g == 91:
                self.absolute = False
            elif g == 20:
                self.inch = True
            elif g == 21:
                self.inch = False


@dataclass
class BlockMove:
    """The move a block commands, in axis positions.

    Attributes
    ----------
    motion : int
        The motion mode it is made in: 0 rapid, 1 line, 2 clockwise arc, 3 counter-clockwise arc.
    start, target : numpy.ndarray, shape (n_axes,)
        Axis positions before and after the move [m, rad].
    start_known : numpy.ndarray of bool, shape (n_axes,)
        Axes whose start position was known (programmed) before the block.
    coord_words : list of Word
        The block's coordinate (axis) words.
    """

    motion: int
    start: np.ndarray
    target: np.ndarray
    start_known: np.ndarray
    coord_words: list[Word]


def check_axes(machine: Machine) -> None:
    """Check that every axis of a machine is named by an NC address letter.

    Parameters
    ----------
    machine : Machine
        The machine.

    Raises
    ------
    GcodeError
        An axis name that is not one of X, Y, Z, A, B, C, U, V, W.
    """
    for axis in machine.axes:
        if not (len(axis) == 1 and axis in "XYZABCUVW"):
            raise GcodeError(f"{machine.name}: axis '{axis}' is not an NC address letter")


class Interpreter:
    """Follows the modal state of a program through its blocks, for a machine whose axes are
    NC address letters (X, Y, Z, A, B, C, U, V, W).

    Parameters
    ----------
    machine : Machine
        The machine; linear axes are programmed in mm or inch, rotary axes in deg.
    source : str
        Name of the program, for messages.
    start : array_like, shape (n_axes,), optional
        Axis positions [m, rad] before the program (default: mid-travel); an axis keeps it
        until the program moves it.
    origin : array_like, shape (n_axes,), optional
        Axis positions [m, rad] of the program's zero (the work offset, G54 ...): absolute
        program coordinates plus ``origin`` are the axis positions. Default zero.

    Raises
    ------
    GcodeError
        An axis name that is not an NC address letter, or an ``origin`` of the wrong shape
        or not finite.
    """

    def __init__(self, machine: Machine, source: str = "<program>", start=None, origin=None):
        check_axes(machine)
        self.machine = machine
        self.axes = list(machine.axes)
        self.linear = [k == "linear" for k in machine.axis_kinds]
        self.source = source
        self.start = machine.mid_travel if start is None else np.asarray(start, float)
        self.origin = np.zeros(len(self.axes)) if origin is None else np.asarray(origin, dtype=float)
        if self.origin.shape != (len(self.axes),) or not np.all(np.isfinite(self.origin)):
            raise GcodeError(f"origin must hold {len(self.axes)} finite values (axes {', '.join(self.axes)})")

    def initial_state(self) -> ModalState:
        """The modal state at the start of a program.

        Returns
        -------
        ModalState
            No motion mode, G17, G90, G21, no axis position known (taken at ``start``),
            no canned cycle.
        """
        return ModalState(position=self.start.copy(), known=np.zeros(len(self.axes), dtype=bool))

    # units --------------------------------------------------------------------------
    def to_si(self, axis: str, value: float, inch: bool) -> float:
        """A program distance or angle of one axis in SI units.

        Parameters
        ----------
        axis : str
            The axis letter.
        value : float
            The number as programmed: mm or inch (linear axis), deg (rotary axis).
        inch : bool
            Whether linear values are in inch (G20).

        Returns
        -------
        float
            The value in m or rad.
        """
        j = self.axes.index(axis)
        if self.linear[j]:
            return value * (INCH if inch else MM)
        return math.radians(value)

    def from_si(self, axis: str, value: float, inch: bool) -> float:
        """The inverse of :meth:`to_si`: an SI value of one axis as programmed.

        Parameters
        ----------
        axis : str
            The axis letter.
        value : float
            The value in m (linear axis) or rad (rotary axis).
        inch : bool
            Whether linear values are written in inch (G20).

        Returns
        -------
        float
            The value in mm or inch, or deg.
        """
        j = self.axes.index(axis)
        if self.linear[j]:
            return value / (INCH if inch else MM)
        return math.degrees(value)

    def _position(self, axis: str, value: float, inch: bool) -> float:
        """Axis position (SI) of an absolute program coordinate."""
        return self.to_si(axis, value, inch) + self.origin[self.axes.index(axis)]

    # blocks -------------------------------------------------------------------------
    def unsupported(self, line: str, state: ModalState) -> str | None:
        """Why a block cannot be followed (canned cycles, macros, subprograms, ...).

        Also tracks canned cycles in ``state``: a cycle starts one, and a motion word or G80
        ends it; until then the axis words of a block are positions of the cycle.

        Parameters
        ----------
        line : str
            The line without its line ending.
        state : ModalState
            The modal state before the block (``canned`` is updated).

        Returns
        -------
        str or None
            What the block holds that cannot be followed, for a message; None if it can.
        """
        code = uncommented(line)
        if "#" in code:
            return "a macro variable (#)"
        keyword = re.search(r"\b(IF|WHILE|GOTO|DO\d*|END\d*)\b", code)
        if keyword:
            return f"a macro statement ({keyword.group(1)})"
        words = word_values(code)
        has_axes = any(letter in self.axes for letter, _ in words)
        if code.lstrip().startswith("/") and has_axes:
            return "a move with block delete (/), whose execution depends on the operator's switch,"
        for letter, value in words:
            if letter == "G" and value in CANNED:
                state.canned = True
                return f"G{value:g} (canned cycle)"
            if letter == "G" and value in MACRO_G:
                return f"G{value:g} (macro call)"
            if letter == "M" and value in (98, 99):
                return f"M{value:g} (subprogram call or return)"
            if letter == "G" and value in NOT_MOVES:
                return f"G{value:g} ({NOT_MOVES[value]})"
        if state.canned:
            if any(letter == "G" and value in (0, 1, 2, 3, 80) for letter, value in words):
                state.canned = False
            elif has_axes:
                return "a canned-cycle position (the cycle is still active)"
        return None

    def skip(self, line: str, state: ModalState) -> None:
        """Follow a block that is kept unchanged rather than interpreted.

        It still sets its modal words (G91 G28 ... stays G91), and if it names axes it
        moves the machine somewhere not followed: every axis position becomes unknown.

        Parameters
        ----------
        line : str
            The line without its line ending.
        state : ModalState
            Updated in place.
        """
        words = word_values(uncommented(line))
        state.apply_g([v for letter, v in words if letter == "G"])
        if any(letter in self.axes for letter, _ in words):
            state.known[:] = False

    def advance(self, block: Block, state: ModalState, check_travel: bool = True) -> BlockMove | None:
        """Update the modal state from a block and read the move it commands.

        Parameters
        ----------
        block : Block
            The block.
        state : ModalState
            The modal state before the block; updated in place (modes, ``known``, and
            ``position`` to the move's target).
        check_travel : bool
            Reject targets outside the travel (the desired program must lie inside it; a
            compensated one may leave it by micrometres).

        Returns
        -------
        BlockMove or None
            The move, or None for a block without axis words (or a dwell, G4, whose X or P
            is the time).

        Raises
        ------
        GcodeError
            Axis words without a motion mode, an incremental move of an axis whose position
            is not known, or a target the machine cannot take.
        """
        gs = [w.value for w in block.words if w.letter == "G"]
        state.apply_g(gs)
        coord_words = [w for w in block.words if w.letter in self.axes]
        if not coord_words or 4 in gs:
            return None
        if state.motion is None:
            raise GcodeError(f"{self.source}:{block.number}: coordinates without a motion mode (G0/G1/G2/G3)")
        start_known = state.known.copy()
        target = state.position.copy()
        for w in coord_words:
            j = self.axes.index(w.letter)
            if state.absolute:
                target[j] = self._position(w.letter, w.value, state.inch)
            elif state.known[j]:
                target[j] = state.position[j] + self.to_si(w.letter, w.value, state.inch)
            else:
                raise GcodeError(f"{self.source}:{block.number}: an incremental move of {w.letter} before its "
                                 "position is known; program it absolutely (G90) first")
            state.known[j] = True
        try:
            self.machine.check_q(target[None, :], extrapolate=not check_travel)
        except InputError as err:
            raise GcodeError(f"{self.source}:{block.number}: {err}") from None
        move = BlockMove(state.motion, state.position.copy(), target, start_known, coord_words)
        state.position = target
        return move

    def arc(self, block: Block, start: np.ndarray, target: np.ndarray, clockwise: bool,
            state: ModalState) -> Arc:
        """The arc of a G2/G3 block, from its centre words (I/J/K) or radius (R).

        Parameters
        ----------
        block : Block
            The block: I/J/K centre offsets from the start, or R (negative for more than half
            a turn), in the program's units; P whole turns (default 1).
        start, target : numpy.ndarray, shape (n_axes,)
            Axis positions at the ends [m, rad].
        clockwise : bool
            G2 (True) or G3 (False).
        state : ModalState
            The modal state of the block (plane and units).

        Returns
        -------
        Arc
            The desired arc, in axis positions [m, rad].

        Raises
        ------
        GcodeError
            The plane's axes are not linear axes of the machine, the centre words are
            missing, R cannot join the end points, P is not a whole number, or the start and
            end radii differ.
        """
        plane = PLANES[state.plane]
        if not all(a in self.axes and self.linear[self.axes.index(a)] for a in plane):
            raise GcodeError(f"{self.source}:{block.number}: an arc needs linear axes {', '.join(plane)}")
        i, j, k = (self.axes.index(a) for a in plane)
        words = {w.letter: w.value for w in block.words}
        scale = INCH if state.inch else MM
        if "R" in words:
            r = abs(words["R"]) * scale
            d = target[[i, j]] - start[[i, j]]
            chord = math.hypot(*d)
            if chord < 1e-12 or chord > 2 * r * (1 + 1e-9):
                raise GcodeError(f"{self.source}:{block.number}: R{words['R']:g} cannot join these end points")
            h = math.sqrt(max(r * r - chord * chord / 4, 0.0))
            mid = start[[i, j]] + d / 2
            normal = np.array([-d[1], d[0]]) / chord
            big = words["R"] < 0
            side = (1 if clockwise else -1) * (-1 if big else 1)
            centre = mid - side * h * normal
        else:
            offs = [CENTRE[plane[0]], CENTRE[plane[1]]]
            if not any(o in words for o in offs):
                raise GcodeError(f"{self.source}:{block.number}: an arc needs {offs[0]}/{offs[1]} or R")
            centre = start[[i, j]] + np.array([words.get(offs[0], 0.0), words.get(offs[1], 0.0)]) * scale
        turns = words.get("P", 1.0)
        if turns != int(turns) or turns < 1:
            raise GcodeError(f"{self.source}:{block.number}: P{turns:g} on an arc must be a whole number of turns >= 1")
        try:
            return arc_from_center(start, target, centre, (i, j, k), clockwise, full_turns=int(turns) - 1)
        except InputError as err:
            raise GcodeError(f"{self.source}:{block.number}: {err}") from None


@dataclass
class Segment:
    """One interpolated move of a program.

    Attributes
    ----------
    line : int
        1-based line number of its block.
    kind : str
        "rapid" (only the end point is meaningful), "line" (straight in axis space) or "arc".
    start, end : numpy.ndarray, shape (n_axes,)
        Axis positions at the ends [m, rad].
    arc : Arc or None
        The arc, for ``kind == "arc"``.
    """

    line: int
    kind: str
    start: np.ndarray
    end: np.ndarray
    arc: Arc | None = None

    def sample(self, n: int) -> np.ndarray:
        """Points along the move, evenly spaced in its parameter.

        Parameters
        ----------
        n : int
            Number of points, ends included.

        Returns
        -------
        numpy.ndarray, shape (n, n_axes)
            Axis positions [m, rad].
        """
        k = np.linspace(0.0, 1.0, n)
        if self.kind == "arc":
            return self.arc.point(k)
        return self.start + np.outer(k, self.end - self.start)


def interpret(machine: Machine, text: str, source: str = "<program>", start=None, origin=None) -> list[Segment]:
    """The moves of a program as the controller interpolates them.

    Lines are straight in axis space, arcs turn about their centres. Moves before every
    axis' position is known, and blocks that cannot be followed (canned cycles ...), are
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
        Axis positions [m, rad] of the program's zero (default zero).

    Returns
    -------
    list of Segment
        One per move, in program order, in axis positions [m, rad]; targets may lie
        outside the travel.

    Raises
    ------
    GcodeError
        A block that cannot be read, naming its line.
    """
    reader = Interpreter(machine, source=source, start=start, origin=origin)
    state = reader.initial_state()
    out = []
    for number, (body, _) in enumerate(split_lines(text), start=1):
        if reader.unsupported(body, state):
            reader.skip(body, state)
            continue
        block = parse_block(body, number, source)
        move = reader.advance(block, state, check_travel=False)
        if move is None:
            continue
        if not move.start_known.all() or move.motion == 0:
            out.append(Segment(number, "rapid", move.start, move.target))
        elif move.motion == 1:
            out.append(Segment(number, "line", move.start, move.target))
        else:
            out.append(Segment(number, "arc", move.start, move.target,
                               reader.arc(block, move.start, move.target, move.motion == 2, state)))
    return out
