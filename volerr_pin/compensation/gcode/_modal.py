"""The modal interpreter: the moves blocks command, through the controller's state between
blocks (:class:`~volerr_pin.compensation.gcode._state.ModalState`).

Positions are program coordinates in SI (m, rad), with the program's origin added: axis
positions in axis programming, the tool tip in the workpiece frame and the rotary axes in
tool-tip programming (:mod:`volerr_pin.compensation`). G43.4 and TRAORI select
tool-tip programming, G43, G44, G49 and TRAFOOF end it; the position is carried over.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .._arcs import Arc
from .._modes import programming_for
from .._programming import Programming
from ...base import INCH, MM, InputError
from ...model import Machine
from ._arcs import read_arc
from ._letters import check_letters, full_circle
from ._lexer import (AXIS_LETTERS, DIAMETER_AXIS, TOOL_TIP_OFF, TOOL_TIP_ON, WORK_OFFSETS, Block, GcodeError,
                    Word, check_words)
from ._dialect import dialect_of
from ._offsets import offset_name
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
    dialect : str or Dialect, optional
        The program's dialect (:mod:`._dialect`; default LinuxCNC).
    work_offsets : dict of str to array_like, optional
        The controller's work offsets [m, rad] by name (``"G54"``, ``"G54.1 P3"``, ``"EXT"``,
        :func:`~volerr_pin.compensation.gcode._offsets.read_work_offsets`): a program that
        switches between them is read with each one's values. Not with ``origin``: the
        offset in force when the program starts is G54.

    Attributes
    ----------
    start_given : bool
        Whether ``start`` gave any axis' position (rather than mid-travel).
    start_known : numpy.ndarray of bool, shape (n_axes,)
        The axes whose start position ``start`` gave.
    notes : Warnings
        What the blocks read so far hold that is kept but not understood.
    origin : numpy.ndarray, shape (n_axes,)
        The program's zero in force [m, rad] (it changes with the work offset).
    offsets : dict of str to numpy.ndarray
        The work offsets known [m, rad]: given, set by the program's G10 blocks, or the
        ``origin`` given, which stands for the first one the program selects.
    lathe : bool
        The machine has X and Z and no Y axis (its X may be programmed as a diameter).

    Raises
    ------
    GcodeError
        An axis name that is not an NC address letter, or a ``start`` or ``origin`` of the
        wrong shape or not finite, or a ``programming`` the machine cannot take, an unknown
        ``dialect``, both ``origin`` and ``work_offsets``, or an offset's values not finite.
    """

    def __init__(self, machine: Machine, source: str = "<program>", start=None, origin=None,
                 programming: str = "axes", dialect=None, work_offsets=None):
        check_axes(machine)
        self.machine = machine
        self.axes = list(machine.axes)
        self.linear = [k == "linear" for k in machine.axis_kinds]
        self.source = source
        given = np.full(len(self.axes), np.nan) if start is None else axis_vector(start, "start", self.axes, unknown=True)
        self.start_known = np.isfinite(given)
        self.start_given = bool(self.start_known.any())
        self.start = np.where(self.start_known, given, machine.mid_travel)
        self.dialect = dialect_of(dialect)
        self.lathe = "X" in self.axes and "Z" in self.axes and "Y" not in self.axes
        #: the letters whose words are coordinates (checked for a decimal point where the dialect
        #: reads whole numbers as increments)
        self.coordinate_letters = "".join(self.axes) + ("UW" if self.lathe else "")
        #: whether the program's lines were checked so already (an expanded program: its blocks as
        #: run hold the parameters' values, which are no increments)
        self.points_checked = False
        if origin is not None and work_offsets:
            raise GcodeError("origin stands for the work offset in force when no table is given: give origin or "
                             "work_offsets, not both", parameters=("origin", "work_offsets"))
        self.origin = np.zeros(len(self.axes)) if origin is None else axis_vector(origin, "origin", self.axes)
        self.origin_given = origin is not None
        self.given_origin = self.origin.copy()
        self.offsets: dict[str, np.ndarray] = {
            str(name): axis_vector(v, f"work_offsets[{name!r}]", self.axes) for name, v in (work_offsets or {}).items()}
        self.table_given = bool(self.offsets)
        self.programmed: set[str] = set()   # offsets the program's G10 blocks set
        self.external = self.offsets.pop("EXT", np.zeros(len(self.axes)))
        for name in list(self.offsets):   # FANUC's additional offsets are Haas's G154 Pn (G110 - G129)
            extended = re.fullmatch(r"G(54\.1|154) P([0-9]+)", name)
            if extended:
                other = "G154" if extended.group(1) == "54.1" else "G54.1"
                self.offsets.setdefault(f"{other} P{extended.group(2)}", self.offsets[name])
        if "G54" in self.offsets:   # the offset in force when a program starts
            self.origin = self.offsets["G54"] + self.external
        self.notes = Warnings()
        if self.table_given and "G54" not in self.offsets:
            self.notes.note("the work-offset table gives no G54, which is in force when a program starts: the blocks "
                            "before the program selects an offset are read with the program's zero at the axes' zero")
        self._noted: set = set()
        self._told: list[tuple[int, str]] = []
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
        if self._first(key):
            self.notes.add(number, text)

    def _first(self, key) -> bool:
        """Whether a note's key (None: every note) comes for the first time; it is remembered."""
        if key is None:
            return True
        if key in self._noted:
            return False
        self._noted.add(key)
        return True

    def tell(self, number: int, text: str, key=None) -> None:
        """Keep a note on how a block was read (a work offset a G10 sets, a builder's M code)
        for the caller to take (:meth:`told`): compensate's report and predict's notes say it.

        Parameters
        ----------
        number : int
            The line.
        text : str
            The note.
        key : hashable, optional
            Keep it only the first time this key is given.
        """
        if self._first(key):
            self._told.append((number, text))

    def told(self) -> list[tuple[int, str]]:
        """The notes kept by :meth:`tell` since the last call, (line, text), and forget them.

        Returns
        -------
        list of (int, str)
            The notes.
        """
        told, self._told = self._told, []
        return told

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
        return ModalState(position=position, known=self.start_known.copy(), tool_tip=tool_tip,
                          linuxcnc=self.dialect.linuxcnc_modes, diameter=self.dialect.lathe_diameter and self.lathe,
                          offset=("G54", 0) if "G54" in self.offsets else None)

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
        aliases = self.dialect.g_aliases
        gs = [aliases.get(w.value, w.value) for w in block.words if w.letter == "G"]
        ms = [w.value for w in block.words if w.letter == "M"]
        if ms:
            # LinuxCNC saves and restores the modes before a block's G codes (G91 M72 is incremental)
            state.apply_m(ms, self.where(block))
            self.restored(ms, state)
        if gs:
            self.work_offset([(w.letter, w.value) for w in block.words], block.number, state)
            state.apply_g(gs)
            self.tool_tip_codes(gs, state, block.number)
        coord_words = [w for w in block.words if w.letter in self._index]
        if 10 in gs or (not coord_words and any(g in self.dialect.g_codes for g in gs)):
            # work offset data a classification followed (set_offset), or a setting of the path
            # control (G187 P1, G5.1 Q1) with its own P, Q, E words: nothing moves
            return None
        dwell = 4 in gs and not any(g in (0, 1, 2, 3) for g in gs)   # with a motion code, the move follows
        check_letters(block, state, coord_words, self.axes, self.where, self.machine.name)
        move = None
        if (coord_words or full_circle(block, state)) and not dwell:
            move = self._move(block, state, coord_words, check_travel and not state.tool_tip)
        moving = self.dialect.moving_m
        for w in block.words:
            if w.letter == "M" and w.value in moving:
                state.lose_position(f"line {block.number}'s M{w.value:g} {moving[w.value]}")
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

    def is_offset(self, g: float) -> bool:
        """Whether a G code selects a work offset in the program's dialect.

        Parameters
        ----------
        g : float
            The code.

        Returns
        -------
        bool
            G54 ... G59, G59.1 ... G59.3, G54.1; for Haas also G154 and G110 ... G129 (on a mill).
        """
        if g in WORK_OFFSETS:
            return True
        if self.dialect.extended_offset == "G505":   # SINUMERIK: G500 (none), G505 - G599
            return g == 500 or (505 <= g <= 599 and g == int(g))
        return self.dialect.extended_offset == "G154" and (g == 154 or (110 <= g <= 129 and g == int(g)
                                                                        and not self.lathe))

    def work_offset(self, words: list[tuple[str, float]], number: int, state: ModalState) -> None:
        """Follow the work offsets a block selects: the program's zero becomes the offset's
        (known from the table given, or set by the program's G10 blocks); the first one a
        program selects without a table takes ``origin``.

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
            A work offset whose values are not known (not in the table given, not set by a G10
            block, or set for some axes only).
        """
        for letter, value in words:
            if letter != "G" or not self.is_offset(value):
                continue
            name = offset_name(value, words, self.dialect.extended_offset)
            if state.offset is not None and state.offset[0] == name:
                continue
            values = self.offsets.get(name)
            if values is None and name == "G500":   # SINUMERIK: no settable offset, the base frame
                values = self.offsets[name] = np.zeros(len(self.axes))
            first = state.offset is None or (state.offset[0] == "G500" and set(self.offsets) == {"G500"})
            if values is None and first and not self.table_given:
                # the origin given (or zero) stands for the first offset the program selects
                self.offsets[name] = self.given_origin.copy()
                self._use(name, self.offsets[name], number, state)
                continue
            if values is None:
                was = (f"from {state.offset[0]} (line {state.offset[1]})" if state.offset and state.offset[1] else
                       f"from {state.offset[0]} (in force when the program starts)" if state.offset else "at the start")
                given = "it is not in the work-offset table given" if self.table_given else "its values are not known"
                raise GcodeError(f"{self.source}:{number}: {name} changes the work offset {was}, and {given}: give "
                                 "the controller's work offsets (work_offsets: a CSV, LinuxCNC's parameter file or "
                                 "a FANUC offset listing), or set it in the program with G10 L2",
                                 parameters=("work_offsets",))
            self._use(name, values, number, state)

    def _use(self, name: str, values: np.ndarray, number: int, state: ModalState) -> None:
        """Make a work offset the one in force."""
        unknown = [a for a, v in zip(self.axes, values) if math.isnan(v)]
        if unknown:
            raise GcodeError(f"{self.source}:{number}: {name}'s axis {', '.join(unknown)} not known (the program's G10 "
                             "blocks set the others): give the controller's work offsets (work_offsets) or set every "
                             "axis with G10 L2", parameters=("work_offsets",))
        self.origin = values + self.external
        state.offset = (name, number)

    def restored(self, codes, state: ModalState) -> None:
        """Take the zero of the work offset LinuxCNC's M72 restored (M70 saved it with the modes).

        Parameters
        ----------
        codes : list of float
            The block's M codes.
        state : ModalState
            The modal state after them.
        """
        if not (state.linuxcnc and 72 in codes):
            return
        if state.offset is None:
            self.origin = self.given_origin + self.external
        elif state.offset[0] in self.offsets:
            self.origin = self.offsets[state.offset[0]] + self.external

    def set_offset(self, words: list[tuple[str, float]], number: int, state: ModalState) -> str | None:
        """Follow a G10 L2 / L20 block that sets a work offset.

        Parameters
        ----------
        words : list of (str, float)
            The block's words, (letter, value).
        number : int
            Its line number.
        state : ModalState
            The modal state (units, distance mode, positions; ``offset`` if it sets the one in
            force).

        Returns
        -------
        str or None
            What it set (``"G55"``), or None if it cannot be followed (a P the dialect gives no
            meaning, a rotation, a diameter-mode X, L20 from a position not known, inside
            tool-tip programming): then the blocks after it are kept (:mod:`._regions`).
        """
        from ._offsets import g10_target

        ls = [v for letter, v in words if letter == "L"]
        ps = [v for letter, v in words if letter == "P"]
        target = g10_target(ls[0], ps[0] if ps else None, self.dialect)
        axis_words = [(letter, v) for letter, v in words if letter in self._index]
        others = [letter for letter, v in words if letter not in self._index and letter not in "GLPN" and v]
        if target is None or others or state.tool_tip or (state.diameter and any(a == DIAMETER_AXIS
                                                                                  for a, _ in axis_words)):
            return None
        if target == "current":
            target = "G54" if state.offset is None else state.offset[0]
        if state.offset is None and target == "G54":
            # G54 is in force when a program starts (LinuxCNC, FANUC, Haas); the origin given stands for it
            state.offset = ("G54", 0)
            self.offsets.setdefault("G54", self.origin - self.external)
        relative = ls[0] == 20 and not self.dialect.l20_extended   # LinuxCNC: the position reads as the values
        absolute, inch = state.absolute, state.inch
        for letter, v in words:   # (G91 G20 G10 ...: the block's own distance mode and units)
            if letter == "G" and v in (90, 91):
                absolute = v == 90
            elif letter == "G" and v in (20, 21):
                inch = v == 20
        if relative and not all(state.known[self._index[a]] for a, _ in axis_words):
            return None
        old = self.external if target == "EXT" else self.offsets.get(target)
        values = np.full(len(self.axes), np.nan) if old is None else old.copy()
        for letter, v in axis_words:
            j = self._index[letter]
            amount = self.to_si(letter, v, inch)
            if relative:
                values[j] = state.position[j] - self.external[j] - amount   # the zero where the axis reads it
            elif not absolute and self.dialect.offsets_incremental:
                values[j] = (0.0 if math.isnan(values[j]) else values[j]) + amount
            else:
                values[j] = amount
        if not self.table_given:   # the axes the program does not set: the origin stands for them
            values = np.where(np.isnan(values), self.origin - self.external, values)
        if target == "EXT":
            if np.isnan(values).any():
                return None
            self.origin = self.origin + values - self.external   # (every work offset adds it)
            self.external = values
            return "the external offset"
        self.offsets[target] = values
        self.programmed.add(target)
        if state.offset is not None and state.offset[0] == target:
            self._use(target, values, number, state)
        return target

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
