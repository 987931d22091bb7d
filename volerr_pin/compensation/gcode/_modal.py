"""The modal interpreter: the moves blocks command, through the controller's state between
blocks (:class:`~volerr_pin.compensation.gcode._state.ModalState`).

Positions are program coordinates in SI (m, rad), with the program's origin added: axis
positions in axis programming, the tool tip in the workpiece frame and the rotary axes in
tool-tip programming (:mod:`volerr_pin.compensation`). G43.4 and TRAORI select
tool-tip programming, G43, G44, G49 and TRAFOOF end it; the position is carried over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._arcs import Arc
from .._modes import programming_for
from .._programming import Programming
from ...base import INCH, MM, InputError
from ...model import Machine
from ._arcs import read_arc
from ._letters import check_letters, full_circle
from ._lexer import (AXIS_LETTERS, DIAMETER_AXIS, TOOL_CHANGE_M, TOOL_TIP_OFF, TOOL_TIP_ON, WORK_OFFSETS, Block, GcodeError,
                    Word, check_words)
from ._report import Warnings
from ._state import ModalState

__all__ = ["AXIS_LETTERS", "BlockMove", "Interpreter", "ModalState", "axis_vector", "check_axes", "move_of"]



@dataclass
class BlockMove:
    """The move a block commands, in program coordinates.

    Attributes
    ----------
    motion : int
        The motion mode it is made in: 0 rapid, 1 line, 2 clockwise arc, 3 counter-clockwise arc.
    start, target : numpy.ndarray, shape (n_axes,)
        Program coordinates before and after the move [m, rad].
    start_known : numpy.ndarray of bool, shape (n_axes,)
        Axes whose start position was known (programmed) before the block.
    coord_words : list of Word
        The block's coordinate (axis) words.
    tool_tip : bool
        Made in tool-tip programming.
    """

    motion: int
    start: np.ndarray
    target: np.ndarray
    start_known: np.ndarray
    coord_words: list[Word]
    tool_tip: bool = False


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


def axis_vector(value, name: str, axes: list[str], unknown: bool = False) -> np.ndarray:
    """A value per axis, checked: finite numbers (or, with ``unknown``, NaN for an axis not
    known).

    Parameters
    ----------
    value : array_like, shape (n_axes,)
        The values.
    name : str
        The parameter, for messages.
    axes : list of str
        The machine's axes.
    unknown : bool, default False
        Whether NaN (not known) is allowed.

    Returns
    -------
    numpy.ndarray, shape (n_axes,)
        The values as floats.

    Raises
    ------
    GcodeError
        Naming ``name``, for another shape, an infinite value, or NaN where not allowed.
    """
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        v = np.array([np.inf])
    if v.shape != (len(axes),) or not np.all(np.isfinite(v) | (unknown & np.isnan(v))):
        what = "finite values or NaN (not known)" if unknown else "finite values"
        raise GcodeError(f"{name} must hold {len(axes)} {what} (axes {', '.join(axes)})", parameters=(name,))
    return v


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
        Axis positions [m, rad] where the program starts, as far as they are known: an axis
        keeps its position until the program moves it, and moves from known positions are
        compensated whole (a 2-D program that never writes Z is compensated with Z where it
        stands). NaN for an axis whose position is not known: it is taken at mid-travel, and a
        move from it is compensated at its end point only. Default: none known.
    origin : array_like, shape (n_axes,), optional
        Program coordinates [m, rad] of the program's zero (the work offset, G54 ...):
        absolute program words plus ``origin`` are axis positions (axis programming) or the
        tool tip in the workpiece frame and the rotary axes (tool-tip programming). Default
        zero.
    programming : str, default "axes"
        The programming mode when the program starts: ``"axes"`` or ``"tool-tip"`` (tool
        centre point control on already); G43.4 / TRAORI and G49 / TRAFOOF change it.

    Attributes
    ----------
    start_given : bool
        Whether ``start`` gave any axis' position (rather than mid-travel).
    start_known : numpy.ndarray of bool, shape (n_axes,)
        The axes whose start position ``start`` gave.
    notes : Warnings
        What the blocks read so far hold that is kept but not understood.

    Raises
    ------
    GcodeError
        An axis name that is not an NC address letter, or a ``start`` or ``origin`` of the
        wrong shape or not finite, or a ``programming`` the machine cannot take.
    """

    def __init__(self, machine: Machine, source: str = "<program>", start=None, origin=None,
                 programming: str = "axes"):
        check_axes(machine)
        self.machine = machine
        self.axes = list(machine.axes)
        self.linear = [k == "linear" for k in machine.axis_kinds]
        self.source = source
        given = np.full(len(self.axes), np.nan) if start is None else axis_vector(start, "start", self.axes, unknown=True)
        self.start_known = np.isfinite(given)
        self.start_given = bool(self.start_known.any())
        self.start = np.where(self.start_known, given, machine.mid_travel)
        self.origin = np.zeros(len(self.axes)) if origin is None else axis_vector(origin, "origin", self.axes)
        self.notes = Warnings()
        self._noted: set = set()
        self._modes: dict[str, Programming] = {}
        if programming not in ("axes", "tool-tip"):
            raise GcodeError(f"programming must be 'axes' or 'tool-tip', got {programming!r}",
                             parameters=("programming",))
        self.programming = programming
        try:
            self.mode(programming)
        except InputError as err:
            raise GcodeError(str(err), parameters=("programming",)) from None
        travel = machine.travel
        self._low = [float(v) for v in travel[:, 0]]
        self._high = [float(v) for v in travel[:, 1]]
        span = travel[:, 1] - travel[:, 0]
        self._slack = [float(v) for v in 1e-9 * np.where(np.isfinite(span), np.maximum(span, 1.0), 1.0)]
        self._scale = {(a, inch): (INCH if inch else MM) if lin else math.pi / 180
                       for a, lin in zip(self.axes, self.linear) for inch in (False, True)}
        self._index = {a: j for j, a in enumerate(self.axes)}

    @property
    def warnings(self) -> list[str]:
        """The notes so far as lines of text (``"line N: ..."``), list of str."""
        return self.notes.render()

    def mode(self, name: str) -> Programming:
        """The programming mode of a name, made on first use.

        Parameters
        ----------
        name : str
            ``"axes"`` or ``"tool-tip"``.

        Returns
        -------
        Programming
            The mode.

        Raises
        ------
        InputError
            The machine cannot be programmed so (naming ``programming``).
        """
        mode = self._modes.get(name)
        if mode is None:
            mode = self._modes[name] = programming_for(name, self.machine)
        return mode

    def warn(self, number: int, text: str, key=None) -> None:
        """Note something a block holds that is kept but not understood.

        Parameters
        ----------
        number : int
            The line.
        text : str
            What, for the report.
        key : hashable, optional
            Note it only the first time this key is given.
        """
        if key is not None:
            if key in self._noted:
                return
            self._noted.add(key)
        self.notes.add(number, text)

    def initial_state(self) -> ModalState:
        """The modal state at the start of a program.

        Returns
        -------
        ModalState
            No motion mode, G17, G90, G21, the axis positions ``start`` gave known (the others
            taken at mid-travel), no canned cycle, the programming mode given.
        """
        tool_tip = self.programming == "tool-tip"
        position = self.mode(self.programming).to_words(self.start[None, :])[0].copy()
        return ModalState(position=position, known=self.start_known.copy(), tool_tip=tool_tip)

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
        return value * self._scale[axis, inch]

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
        return value / self._scale[axis, inch]

    def where(self, block: Block, word: Word | None = None) -> str:
        """``source:line`` or ``source:line:column`` of a block or one of its words, for messages.

        Parameters
        ----------
        block : Block
            The block.
        word : Word, optional
            One of its words.

        Returns
        -------
        str
            The place.
        """
        return f"{self.source}:{block.number}" + (f":{word.start + 1}" if word is not None else "")

    # programming modes ----------------------------------------------------------------
    def _switch(self, state: ModalState, tool_tip: bool, number: int, what: str) -> None:
        """Change the programming mode; the position carries over (same axis positions)."""
        if tool_tip == state.tool_tip:
            return
        old = self.mode("tool-tip" if state.tool_tip else "axes")
        try:
            new = self.mode("tool-tip" if tool_tip else "axes")
        except InputError as err:
            raise GcodeError(f"{self.source}:{number}: {what}: {err}") from None
        state.position = new.to_words(old.to_axes(state.position[None, :]))[0].copy()
        state.tool_tip = tool_tip
        if tool_tip:
            linear = ", ".join(a for a, lin in zip(self.axes, self.linear) if lin)
            rotary = ", ".join(a for a, lin in zip(self.axes, self.linear) if not lin) or "none"
            self.warn(number, f"{what}: tool-tip programming: {linear} are the tool tip in the workpiece frame, "
                      f"the rotary axes ({rotary}) their positions", key="tool-tip")

    def tool_tip_codes(self, codes: list[float], state: ModalState, number: int) -> None:
        """Switch the programming mode on G43.4 (tool tip) and G43 / G44 / G49 (axes).

        Parameters
        ----------
        codes : list of float
            The block's G codes.
        state : ModalState
            Updated in place (``tool_tip``, ``position``).
        number : int
            Its line number.
        """
        for g in codes:
            if g in TOOL_TIP_ON:
                self._switch(state, True, number, f"G{g:g}")
            elif g in TOOL_TIP_OFF:
                self._switch(state, False, number, f"G{g:g}")

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
            compensated one may leave it by micrometres). In tool-tip programming the axis
            positions are found later, for many moves at once, and checked there.

        Returns
        -------
        BlockMove or None
            The move, or None for a block without axis words (or a dwell, G4, whose X or P
            is the time).

        Raises
        ------
        GcodeError
            Words that contradict each other or mean nothing here (see
            :func:`~volerr_pin.compensation.gcode._lexer.check_words` and :meth:`check_letters`), a change
            of work offset, axis words without a motion mode, an incremental move of an axis
            whose position is not known, or a target the machine cannot take.
        """
        if block.statement:
            self._switch(state, block.statement == "TRAORI", block.number, block.statement)
            return None
        check_words(block, self.source)
        gs = [w.value for w in block.words if w.letter == "G"]
        ms = [w.value for w in block.words if w.letter == "M"]
        if ms:
            # LinuxCNC saves and restores the modes before a block's G codes (G91 M72 is incremental)
            state.apply_m(ms, self.where(block))
        if gs:
            self.work_offset([(w.letter, w.value) for w in block.words], block.number, state)
            state.apply_g(gs)
            self.tool_tip_codes(gs, state, block.number)
        coord_words = [w for w in block.words if w.letter in self._index]
        dwell = 4 in gs and not any(g in (0, 1, 2, 3) for g in gs)   # with a motion code, the move follows
        check_letters(block, state, coord_words, self.axes, self.where, self.machine.name)
        move = None
        if (coord_words or full_circle(block, state)) and not dwell:
            move = self._move(block, state, coord_words, check_travel and not state.tool_tip)
        if any(w.letter == "M" and w.value == TOOL_CHANGE_M for w in block.words):
            state.lose_position(f"line {block.number}'s M{TOOL_CHANGE_M} tool change")
        return move

    def _move(self, block: Block, state: ModalState, coord_words: list[Word], check_travel: bool) -> BlockMove:
        if state.motion is None:
            raise GcodeError(f"{self.where(block)}: coordinates without a motion mode (G0/G1/G2/G3)")
        start_known = state.known.copy()
        start = state.position
        target = start.copy()
        known = state.known
        absolute, inch, index, scale = state.absolute, state.inch, self._index, self._scale
        for w in coord_words:
            j = index[w.letter]
            # (in diameter mode, G7, an X word is twice the radius it commands)
            unit = scale[w.letter, inch] * (0.5 if state.diameter and w.letter == DIAMETER_AXIS else 1.0)
            if absolute:
                value = w.value * unit + self.origin[j]
            elif known[j]:
                value = start[j] + w.value * unit
            else:
                raise GcodeError(f"{self.where(block, w)}: an incremental move of {w.letter} before its "
                                 "position is known; program it absolutely (G90) first")
            if not math.isfinite(value):
                raise GcodeError(f"{self.where(block, w)}: {w.name} takes axis {w.letter} beyond any number")
            target[j] = value
            known[j] = True
        if check_travel:
            low, high, slack = self._low, self._high, self._slack
            for j, t in enumerate(target.tolist()):  # plain floats: the same comparisons, faster
                if not (low[j] - slack[j] <= t <= high[j] + slack[j]):
                    self.travel_error(block, coord_words, target)
        move = BlockMove(state.motion, start, target, start_known, coord_words, state.tool_tip)
        state.position = target
        return move

    def travel_error(self, block: Block, coord_words: list[Word], q: np.ndarray) -> None:
        """Raise the error for a move whose axis positions leave the travel.

        Parameters
        ----------
        block : Block
            The block.
        coord_words : list of Word
            Its coordinate words (one that names an axis outside is blamed first).
        q : numpy.ndarray, shape (n_axes,)
            The axis positions of its target [m, rad].

        Raises
        ------
        GcodeError
            Always: naming the line, the word (or the axis) and the travel.
        """
        outside = np.flatnonzero(self.machine.outside_travel(q[None, :])[0])
        named = {w.letter: w for w in coord_words}
        j = next((j for j in outside if self.axes[j] in named), outside[0] if len(outside) else 0)
        axis = self.axes[j]
        lo, hi = (self.from_si(axis, t, False) for t in self.machine.travel[j])
        unit = "mm" if self.linear[j] else "deg"
        what = (f"{self.where(block, named[axis])}: {named[axis].name} takes axis {axis} to" if axis in named
                else f"{self.where(block)}: axis {axis} (not named, from the start position) is at")
        raise GcodeError(f"{what} {self.from_si(axis, q[j], False):.10g} {unit}, outside the travel "
                         f"[{lo:g}, {hi:g}] {unit}")

    def work_offset(self, words: list[tuple[str, float]], number: int, state: ModalState) -> None:
        """Follow the work offsets a block selects: one per program (kept blocks included),
        since a program is compensated with one origin.

        Parameters
        ----------
        words : list of (str, float)
            The block's words, (letter, value).
        number : int
            Its line number.
        state : ModalState
            Updated in place (``offset``).

        Raises
        ------
        GcodeError
            A second, different work offset.
        """
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

    def arc(self, block: Block, start: np.ndarray, target: np.ndarray, clockwise: bool,
            state: ModalState) -> Arc:
        """The arc of a G2/G3 block, from its centre words (I/J/K) or radius (R).

        Parameters
        ----------
        block : Block
            The block (see :func:`~volerr_pin.compensation.gcode._arcs.read_arc`).
        start, target : numpy.ndarray, shape (n_axes,)
            Program coordinates at the ends [m, rad].
        clockwise : bool
            G2 (True) or G3 (False).
        state : ModalState
            The modal state of the block (plane, units, arc centre distance mode).

        Returns
        -------
        Arc
            The desired arc, in program coordinates [m, rad].

        Raises
        ------
        GcodeError
            See :func:`~volerr_pin.compensation.gcode._arcs.read_arc`.
        """
        return read_arc(block, self.where(block), self.axes, self.linear, start, target, clockwise, state.plane,
                        state.inch, self.warn, self.origin if state.centres_absolute else None)


def move_of(reader: Interpreter, block: Block, state: ModalState, coord_words: list[Word],
            check_travel: bool) -> BlockMove:
    """The move of a block whose words are all axis words (each once), without the checks
    :meth:`Interpreter.advance` makes of other words (a fast path for plain lines).

    Parameters
    ----------
    reader : Interpreter
        The program's interpreter.
    block : Block
        The block (for messages).
    state : ModalState
        The modal state; updated in place (``known``, and ``position`` to the target).
    coord_words : list of Word
        Its axis words, each axis once.
    check_travel : bool
        Reject targets outside the travel.

    Returns
    -------
    BlockMove
        The move.

    Raises
    ------
    GcodeError
        No motion mode, an incremental move of an axis whose position is not known, a
        target beyond any number or outside the travel.
    """
    return reader._move(block, state, coord_words, check_travel)
