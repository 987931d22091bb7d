"""The modal interpreter: the controller's state between blocks, and the moves blocks command."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..compensate import Arc, arc_from_center
from ..errors import InputError
from ..machine import Machine
from ..units import INCH, MM
from .lexer import (CANNED, CENTRE, G_GROUPS, M_GROUPS, MACRO_G, NOT_MOVES, PLANES, TOOL_CHANGE_M, WORK_OFFSETS,
                    Block, GcodeError, Word, check_words, macro_statement, mask_comments, parse_block, split_lines,
                    uncommented, word_values)

#: an arc's end may lie this far off its start's circle [m] (about what controllers accept);
#: an arc whose radius is not larger is degenerate: its end could lie anywhere around it
ARC_SLACK = 2e-6
#: the largest arc radius or centre offset read [m]: NC numbers hold nine digits (99999.9999 mm)
MAX_ARC = 100.0
#: the most whole turns (P) of one arc block
MAX_TURNS = 1000
AXIS_LETTERS = "XYZABCUVW"


@dataclass
class ModalState:
    """What the controller remembers between blocks.

    Attributes
    ----------
    position : numpy.ndarray, shape (n_axes,)
        Axis positions after the last move [m, rad]; axes the program has not yet
        programmed hold the start position.
    known : numpy.ndarray of bool, shape (n_axes,)
        Axes whose position the program has set (and no skipped block, tool change or
        new program has moved since).
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
    lost : str
        Why positions the program had set are no longer known (e.g. ``"line 20's M6
        tool change"``); empty while none was lost.
    offset : tuple of (str, int) or None
        The work offset in use (``"G54"``, ``"G54.1 P2"``) and the line that selected it.
    programs : int
        Program numbers (O words) read.
    """

    position: np.ndarray
    known: np.ndarray
    motion: int | None = None
    plane: int = 17
    absolute: bool = True
    inch: bool = False
    canned: bool = False
    lost: str = ""
    offset: tuple[str, int] | None = None
    programs: int = 0

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

    def lose_position(self, why: str) -> None:
        """Forget every axis position (a block moved the machine somewhere not followed).

        Parameters
        ----------
        why : str
            What moved it, for messages (``"line 5"``).
        """
        if self.known.any():  # what was never programmed is "not yet programmed", not lost
            self.lost = why
        self.known[:] = False


class Problem(str):
    """Why a block cannot be followed (a str for messages).

    Attributes
    ----------
    modes_unknown : bool
        The block holds a code the reader does not know, which may set a mode that changes
        how later blocks read.
    """

    modes_unknown = False


def _unknown(text: str) -> Problem:
    problem = Problem(text)
    problem.modes_unknown = True
    return problem


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
        if not (len(axis) == 1 and axis in AXIS_LETTERS):
            raise GcodeError(f"{machine.name}: axis '{axis}' is not an NC address letter")


def centre_from_radius(start: np.ndarray, end: np.ndarray, radius: float, clockwise: bool) -> np.ndarray | None:
    """The centre of the arc of a given radius between two points of its plane.

    Parameters
    ----------
    start, end : numpy.ndarray, shape (2,)
        The ends in the arc plane [m].
    radius : float
        The radius [m]; negative for the arc of more than half a turn (the R word's sign).
    clockwise : bool
        G2 (True) or G3 (False).

    Returns
    -------
    numpy.ndarray, shape (2,), or None
        The centre [m]; None when no circle of that radius joins the ends (they are more
        than a diameter apart, or the same point).
    """
    d = end - start
    chord = math.hypot(*d)
    a = abs(radius)
    if chord < 1e-12 or chord > 2 * a * (1 + 1e-9):
        return None
    h = math.sqrt(max((a - chord / 2) * (a + chord / 2), 0.0))
    normal = np.array([-d[1], d[0]]) / chord
    side = (1 if clockwise else -1) * (-1 if radius < 0 else 1)
    return start + d / 2 - side * h * normal


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

    Attributes
    ----------
    start_given : bool
        Whether ``start`` was given (rather than mid-travel).
    warnings : list of str
        What the blocks read so far hold that is kept but not understood (``"line N: ..."``).

    Raises
    ------
    GcodeError
        An axis name that is not an NC address letter, or a ``start`` or ``origin`` of the
        wrong shape or not finite.
    """

    def __init__(self, machine: Machine, source: str = "<program>", start=None, origin=None):
        check_axes(machine)
        self.machine = machine
        self.axes = list(machine.axes)
        self.linear = [k == "linear" for k in machine.axis_kinds]
        self.source = source
        self.start_given = start is not None
        self.start = machine.mid_travel if start is None else self._vector(start, "start")
        self.origin = np.zeros(len(self.axes)) if origin is None else self._vector(origin, "origin")
        self.warnings: list[str] = []
        self._noted: set = set()

    def _vector(self, value, name: str) -> np.ndarray:
        try:
            v = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            v = np.array([np.nan])
        if v.shape != (len(self.axes),) or not np.all(np.isfinite(v)):
            raise GcodeError(f"{name} must hold {len(self.axes)} finite values (axes {', '.join(self.axes)})",
                             parameters=(name,))
        return v

    def warn(self, number: int, text: str, key=None) -> None:
        """Note something a block holds that is kept but not understood.

        Parameters
        ----------
        number : int
            The line.
        text : str
            What, for :attr:`warnings`.
        key : hashable, optional
            Note it only the first time this key is given.
        """
        if key is not None:
            if key in self._noted:
                return
            self._noted.add(key)
        self.warnings.append(f"line {number}: {text}")

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

    def _where(self, block: Block, word: Word | None = None) -> str:
        return f"{self.source}:{block.number}" + (f":{word.start + 1}" if word is not None else "")

    # blocks -------------------------------------------------------------------------
    def classify(self, line: str, number: int, state: ModalState) -> tuple[Block | None, Problem | None]:
        """Read a line, and say whether it can be followed.

        Parameters
        ----------
        line : str
            The line without its line ending.
        number : int
            Its 1-based line number.
        state : ModalState
            The modal state before the block (``canned`` and ``programs`` are updated).

        Returns
        -------
        block : Block or None
            The block (None for a macro statement, which is not read).
        problem : Problem or None
            What the block holds that cannot be followed (canned cycles, macros,
            subprograms, codes the reader does not know ...); None if it can be.

        Raises
        ------
        GcodeError
            A line that cannot be read (see :func:`~volerr_pin.gcode.lexer.parse_block`).
        """
        code = mask_comments(line, number, self.source)
        macro = macro_statement(code)
        if macro:
            problem = Problem(macro[0])
            problem.modes_unknown = macro[1]
            return None, problem
        block = parse_block(line, number, self.source, code)
        return block, self._problem(block, state)

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

        Raises
        ------
        GcodeError
            A line that cannot be read.
        """
        return self.classify(line, 0, state)[1]

    def _problem(self, block: Block, state: ModalState) -> Problem | None:
        words = block.words
        has_axes = any(w.letter in self.axes for w in words)
        if block.delete and has_axes:
            return Problem("a move with block delete (/), whose execution depends on the operator's switch,")
        if block.delete and any(w.letter == "G" for w in words):
            return Problem("G codes with block delete (/), whose effect depends on the operator's switch,")
        for w in words:
            if w.letter == "G" and w.value in CANNED:
                state.canned = True
                return Problem(f"{w.name} (canned cycle)")
            if w.letter == "G" and w.value in MACRO_G:
                return Problem(f"{w.name} (macro call)")
            if w.letter == "G" and w.value in NOT_MOVES:
                return Problem(f"{w.name} ({NOT_MOVES[w.value]})")
            if w.letter == "G" and w.value not in G_GROUPS:
                return _unknown(f"{w.name} (a G code this reader does not know)")
            if w.letter == "M" and w.value in (98, 99):
                return Problem(f"{w.name} (subprogram call or return)")
            if w.letter == "O" and state.programs:
                return Problem(f"{w.name} (a second program number: the start of a subprogram)")
        if any(w.letter == "O" for w in words):
            state.programs += 1
        if state.canned:
            if any(w.letter == "G" and w.value in (0, 1, 2, 3, 80) for w in words):
                state.canned = False
            elif any(w.letter in self.axes or w.letter in AXIS_LETTERS + "IJKRQPL" for w in words):
                return Problem("a canned-cycle position (the cycle is still active)")
        return None

    def skip(self, line: str, state: ModalState, block: Block | None = None, number: int = 0) -> None:
        """Follow a block that is kept unchanged rather than interpreted.

        It still sets its modal words (G91 G28 ... stays G91), and if it names axes (or
        changes tools, calls or returns from a subprogram or macro, starts another program,
        jumps or loops, or has a word whose value is a macro variable) it moves the machine
        somewhere not followed: every axis position becomes unknown.

        Parameters
        ----------
        line : str
            The line without its line ending.
        state : ModalState
            Updated in place.
        block : Block, optional
            The line read already (None for a macro statement: its words are guessed).
        number : int
            Its line number, for messages.
        """
        if block is not None:
            words = [(w.letter, w.value) for w in block.words]
        else:
            words = word_values(uncommented(line))
            macro = macro_statement(mask_comments(line, number, self.source))
            if macro and macro[1]:  # a jump, loop or variable word: where the machine goes is not known
                state.lose_position(f"line {number}")
        self._work_offset(words, number, state)
        state.apply_g([v for letter, v in words if letter == "G"])
        calls = {("M", TOOL_CHANGE_M), ("M", 98), ("M", 99)} | {("G", g) for g in MACRO_G}
        if any(letter in self.axes or letter in AXIS_LETTERS + "O" or (letter, v) in calls for letter, v in words):
            state.lose_position(f"line {number}")

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
            Words that contradict each other or mean nothing here (see
            :func:`~volerr_pin.gcode.lexer.check_words` and :meth:`check_letters`), a change
            of work offset, axis words without a motion mode, an incremental move of an axis
            whose position is not known, or a target the machine cannot take.
        """
        check_words(block, self.source)
        gs = [w.value for w in block.words if w.letter == "G"]
        self._work_offset([(w.letter, w.value) for w in block.words], block.number, state)
        state.apply_g(gs)
        coord_words = [w for w in block.words if w.letter in self.axes]
        dwell = 4 in gs
        self.check_letters(block, state, coord_words)
        for w in block.words:
            if w.letter == "M" and w.value not in M_GROUPS:
                self.warn(block.number, f"{w.name} is not an M code this reader knows: kept unchanged, taken to "
                          "move no axis", key=("M", w.value))
        move = None
        if coord_words and not dwell:
            move = self._move(block, state, coord_words, check_travel)
        if any(w.letter == "M" and w.value == TOOL_CHANGE_M for w in block.words):
            state.lose_position(f"line {block.number}'s M{TOOL_CHANGE_M} tool change")
        return move

    def _move(self, block: Block, state: ModalState, coord_words: list[Word], check_travel: bool) -> BlockMove:
        if state.motion is None:
            raise GcodeError(f"{self._where(block)}: coordinates without a motion mode (G0/G1/G2/G3)")
        start_known = state.known.copy()
        target = state.position.copy()
        for w in coord_words:
            j = self.axes.index(w.letter)
            if state.absolute:
                target[j] = self._position(w.letter, w.value, state.inch)
            elif state.known[j]:
                target[j] = state.position[j] + self.to_si(w.letter, w.value, state.inch)
            else:
                raise GcodeError(f"{self._where(block, w)}: an incremental move of {w.letter} before its "
                                 "position is known; program it absolutely (G90) first")
            if not math.isfinite(target[j]):
                raise GcodeError(f"{self._where(block, w)}: {w.name} takes axis {w.letter} beyond any number")
            state.known[j] = True
        outside = np.flatnonzero(self.machine.outside_travel(target[None, :])[0]) if check_travel else []
        if len(outside):
            named = {w.letter: w for w in coord_words}
            j = next((j for j in outside if self.axes[j] in named), outside[0])  # a word to blame first
            axis = self.axes[j]
            lo, hi = (self.from_si(axis, t, False) for t in self.machine.travel[j])
            unit = "mm" if self.linear[j] else "deg"
            what = (f"{self._where(block, named[axis])}: {named[axis].name} takes axis {axis} to" if axis in named
                    else f"{self._where(block)}: axis {axis} (not named, from the start position) is at")
            raise GcodeError(f"{what} {self.from_si(axis, target[j], False):.10g} {unit}, outside the travel "
                             f"[{lo:g}, {hi:g}] {unit}")
        move = BlockMove(state.motion, state.position.copy(), target, start_known, coord_words)
        state.position = target
        return move

    def _work_offset(self, words: list[tuple[str, float]], number: int, state: ModalState) -> None:
        """One work offset per program (kept blocks included): it is compensated with one origin."""
        for letter, value in words:
            if letter != "G" or value not in WORK_OFFSETS:
                continue
            name = f"G{value:g}"
            if value == 54.1:
                p = [v for other, v in words if other == "P"]
                name += f" P{p[0]:g}" if p else ""
            if state.offset is not None and state.offset[0] != name:
                raise GcodeError(f"{self.source}:{number}: {name} changes the work offset from {state.offset[0]} "
                                 f"(line {state.offset[1]}); a program is compensated with one origin: compensate "
                                 "the blocks of each work offset as a program of their own")
            state.offset = (name, number)

    def check_letters(self, block: Block, state: ModalState, coord_words: list[Word]) -> None:
        """Check that every word of a block means something in its modal state.

        Axis words name axes of the machine; I, J, K and R belong to arc moves; P to a
        dwell, an arc, G54.1 or an M code; Q and L to an M code; a dwell (G4) carries no
        motion code and no axis word but X (its time).

        Parameters
        ----------
        block : Block
            The block.
        state : ModalState
            The modal state after the block's G codes.
        coord_words : list of Word
            The block's axis words.

        Raises
        ------
        GcodeError
            Naming line, column and word.
        """
        gs = [w for w in block.words if w.letter == "G"]
        dwell = any(w.value == 4 for w in gs)
        if dwell:
            motion = [w for w in gs if w.value in (0, 1, 2, 3)]
            if motion:
                raise GcodeError(f"{self._where(block, motion[0])}: {motion[0].name} and G4 (dwell) in one block")
            other = [w for w in coord_words if w.letter != "X"]
            if other:
                raise GcodeError(f"{self._where(block, other[0])}: {other[0].name} in a dwell (G4): a dwell "
                                 "takes its time in P or X and moves no axis")
        arc_move = bool(coord_words) and not dwell and state.motion in (2, 3)
        has_m = any(w.letter == "M" for w in block.words)
        for w in block.words:
            letter = w.letter
            if letter in "GMNOFSTHD" or letter in self.axes or (dwell and letter in "XP"):
                continue
            where = f"{self._where(block, w)}: {w.name}"
            if letter in AXIS_LETTERS:
                raise GcodeError(f"{where}: {self.machine.name} has no axis {letter}")
            if letter in "IJKR":
                if arc_move:
                    continue
                if state.motion in (2, 3) and not coord_words:
                    why = ("an arc without end point words: write its end point (a full circle ends where it "
                           "starts)")
                elif coord_words and state.motion in (0, 1):
                    why = (f"{letter} on a straight move (G{state.motion}): I, J, K and R belong to arcs; corner "
                           "rounding and chamfers are not understood")
                else:
                    why = f"{letter} outside an arc move: I, J, K and R belong to arcs (G2/G3)"
                raise GcodeError(f"{where}: {why}")
            if letter == "P" and (arc_move or has_m or any(g.value == 54.1 for g in gs)):
                continue
            if letter in "QL" and has_m:
                continue
            raise GcodeError(f"{where}: {letter} words mean nothing this reader knows here")

    def arc(self, block: Block, start: np.ndarray, target: np.ndarray, clockwise: bool,
            state: ModalState) -> Arc:
        """The arc of a G2/G3 block, from its centre words (I/J/K) or radius (R).

        Parameters
        ----------
        block : Block
            The block: I/J/K centre offsets from the start, or R (negative for more than half
            a turn), in the program's units; both only if they give the same centre; P whole
            turns (default 1).
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
            missing, R cannot join the end points, R and I/J/K disagree, the radius is zero
            or degenerate (not more than :data:`ARC_SLACK`) or too large (:data:`MAX_ARC`),
            P is not a whole number of turns from 1 to :data:`MAX_TURNS`, or the start and
            end radii differ.
        """
        plane = PLANES[state.plane]
        where = self._where(block)
        if not all(a in self.axes and self.linear[self.axes.index(a)] for a in plane):
            raise GcodeError(f"{where}: an arc needs linear axes {', '.join(plane)}")
        i, j, k = (self.axes.index(a) for a in plane)
        words = {w.letter: w for w in block.words}
        scale = INCH if state.inch else MM
        unit = "inch" if state.inch else "mm"
        offs = [CENTRE[plane[0]], CENTRE[plane[1]]]
        third = words.get(CENTRE[plane[2]])
        if third is not None:
            self.warn(block.number, f"{third.name} is not a centre word of a G{state.plane} arc (its centre "
                      f"words are {offs[0]} and {offs[1]}): kept unchanged, not read")
        s, e = start[[i, j]], target[[i, j]]
        big = [w for w in block.words if w.letter in offs + ["R"] and abs(w.value) * scale > MAX_ARC]
        if big:
            raise GcodeError(f"{self._where(block, big[0])}: {big[0].name}: an arc radius or centre offset over "
                             f"{MAX_ARC:g} m; NC numbers hold nine digits (program a line)")
        centre = None
        named = [words[o] for o in offs if o in words]
        if named:
            offset = np.array([words[o].value if o in words else 0.0 for o in offs]) * scale
            centre = s + offset
            r0 = math.hypot(*offset)
            if r0 <= ARC_SLACK:
                text = " ".join(w.name for w in named)
                raise GcodeError(f"{where}: a degenerate arc ({text}): its radius {r0 / scale:.6g} {unit} is zero "
                                 f"or not more than the {ARC_SLACK * 1e6:g} um its end may lie off its circle; "
                                 "program a line")
        if "R" in words:
            rw = words["R"]
            r = rw.value * scale
            if abs(r) <= ARC_SLACK:
                raise GcodeError(f"{self._where(block, rw)}: a degenerate arc ({rw.name}): a radius of zero or not "
                                 f"more than the {ARC_SLACK * 1e6:g} um its end may lie off its circle; program a "
                                 "line")
            from_r = centre_from_radius(s, e, r, clockwise)
            if from_r is None:
                chord = math.hypot(*(e - s))
                if chord < 1e-12:
                    why = f"R cannot program a full circle (start and end are one point): use {offs[0]}/{offs[1]}"
                else:
                    why = f"the end points are {chord / scale:.4f} {unit} apart, more than its diameter"
                raise GcodeError(f"{self._where(block, rw)}: {rw.name} cannot join these end points: {why}")
            if centre is not None and math.hypot(*(from_r - centre)) > ARC_SLACK:
                text = " ".join(w.name for w in named)
                raise GcodeError(f"{self._where(block, rw)}: {rw.name} and {text} disagree: their centres are "
                                 f"{math.hypot(*(from_r - centre)) / scale:.4f} {unit} apart; give one of them")
            if centre is None:
                centre = from_r
        if centre is None:
            raise GcodeError(f"{where}: an arc needs {offs[0]}/{offs[1]} or R")
        turns = 1.0
        if "P" in words:
            turns = words["P"].value
            if turns != int(turns) or not 1 <= turns <= MAX_TURNS:
                raise GcodeError(f"{self._where(block, words['P'])}: {words['P'].name} on an arc must be a whole "
                                 f"number of turns from 1 to {MAX_TURNS} (split a longer helix into blocks)")
        try:
            return arc_from_center(start, target, centre, (i, j, k), clockwise, full_turns=int(turns) - 1)
        except InputError as err:
            raise GcodeError(f"{where}: {err}") from None


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
        block, problem = reader.classify(body, number, state)
        if problem:
            reader.skip(body, state, block, number)
            continue
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
