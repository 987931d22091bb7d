"""Lathe cycles compensated through their profiles.

LinuxCNC's lathe cycles (G70 finishing, G71 / G72 roughing) cut along a profile given as a
subroutine (``G71 Q100 X15 Z4 D0.5 I1 R0.3`` with ``o100 sub`` ... ``o100 endsub``). The
controller derives every pass from the profile: the finishing pass follows it, the roughing
passes end on it at the distance D. So a cycle is compensated through its profile: where the
profile's commanded points stand on the compensated path, the surface the cycle cuts stands
where the profile puts it.

The expansion (:meth:`.macros._Expander.profile`) writes each cycle's profile as run as a new
subroutine right before the cycle, which then names it. Its moves are read here as the path the
cycle follows (as LinuxCNC's ``convert_g7x`` builds it):

- from the cycle's start point: the cycle first rapids to its X / Z (incremental under G91), or
  starts where the tool is;
- in the modes the cycle runs in (distance, units, diameter, arc centres), each block's motion
  code G0 - G3 (G0 read as G1: a profile is cut);
- the profile's definition is passed over where it stands, so the program's modes and position
  after it are those before it, and the cycle that follows is kept as written (its own motions
  are the controller's).

The axes a profile does not name (Y, rotary axes) stay where they are through the cycle; where
their position is not known they are taken as for any move (where last programmed, or at
mid-travel), and the report says so. A profile's Y words are not read by the cycle: the
corrections it applies are those in X and Z.
"""

from __future__ import annotations

import copy
import dataclasses

from ._flow import O_WORD
from ._lexer import mask_comments, parse_block, uncommented, word_values
from ._modal import Interpreter, ModalState

__all__ = ["Profiles"]

#: how far a profile's block may turn back along the axis LinuxCNC's cycle needs monotonic
#: [program units] (its ``segment::monotonic``: 1e-3, in radii)
TURN_BACK = 1e-3


class Profiles:
    """The profiles of a program's lathe cycles, as its lines are read.

    Parameters
    ----------
    cycles : dict of str to str
        The name of each profile's subroutine, and its cycle's block (see
        :attr:`.macros.Expansion.profiles`).

    Attributes
    ----------
    reading : bool
        A profile's body is being read (its moves are the cycle's path).
    edge : str or None
        ``"enter"`` or ``"leave"`` after the line that opens or closes a profile's body (the
        moves before and in it are compensated apart), then None once taken (:meth:`take`).
    done : tuple of (str, int, int) or None
        The profile just read: its name and its first and last lines, until its cycle is read.
    count : int
        Profiles read.
    """

    def __init__(self, cycles: dict[str, str] | None = None):
        self.cycles = cycles or {}
        self.reading = False
        self.edge: str | None = None
        self.done: tuple[str, int, int] | None = None
        self.count = 0
        self.raw: list[str] = []    # the profile's lines as read (written instead if it must be)
        self._saved: tuple[ModalState, int] | None = None
        self._outside: tuple | None = None

    def line(self, reader: Interpreter, code: str, number: int, state: ModalState) -> bool:
        """Follow a line that may open or close a profile's body.

        Parameters
        ----------
        reader : Interpreter
            The program's interpreter.
        code : str
            The line with its comments blanked out, upper case.
        number : int
            Its line.
        state : ModalState
            The modal state: at the opening set where the cycle starts, at the closing back to
            what it was before the opening.

        Returns
        -------
        bool
            True for the ``sub`` or ``endsub`` line of a profile (kept as written).
        """
        if not self.cycles:
            return False
        o_word = O_WORD.match(code)
        if o_word is None or o_word.group(2) not in ("SUB", "ENDSUB") or o_word.group(1) not in self.cycles:
            return False
        name = o_word.group(1)
        if o_word.group(2) == "SUB":
            self._saved = (copy.deepcopy(state), number)
            self.raw = []
            cycle = parse_block(self.cycles[name], number, reader.source)
            state.apply_g([w.value for w in cycle.words if w.letter == "G"])   # (G91 G71 ...: before it runs)
            ends = [w.text for w in cycle.words if w.letter in "XZ"]
            if ends:   # the cycle's rapid to its start point
                reader.advance(parse_block("G0 " + " ".join(ends), number, reader.source), state)
            state.motion, state.canned = None, False
            # the axes a profile does not name stay where they are through the cycle: taken
            # where they were last programmed, or at mid-travel if never (as for any move)
            other = [k for k, a in enumerate(reader.axes) if a not in "XZ" and not state.known[k]]
            if other:
                reader.notes.add(number, f"a lathe cycle's profile compensated taking axes "
                                 f"{', '.join(reader.axes[k] for k in other)} (which it does not move) "
                                 f"{'where they were last programmed' if state.lost else 'at mid-travel'}")
                state.known[other] = True
            self.reading, self.edge = True, "enter"
        else:
            saved, first = self._saved
            self._modes = copy.copy(state)   # the modes the profile ran in
            for f in dataclasses.fields(state):
                setattr(state, f.name, getattr(saved, f.name))
            self._saved = None
            self.reading, self.edge = False, "leave"
            self.done = (name, first, number)
            self.count += 1
        return True

    def take(self) -> str | None:
        """The edge the last line made (see :attr:`edge`), once."""
        edge, self.edge = self.edge, None
        return edge

    def switch(self, program, edge: str, write):
        """Where a program's lines are written at a profile's edge (after its lines before were).

        Entering, the profile's moves are compensated apart: from the cycle's start point, with
        the output's motion mode not known, and written to a buffer. Leaving, the buffer is
        written if LinuxCNC's cycle takes the compensated profile (:meth:`refusal`), else the
        profile as read (its moves not counted as compensated; the cycle that follows is then
        kept, as any); the program's writing goes on.

        Parameters
        ----------
        program : Program
            The program being compensated (its report, and the writer's last motion and command).
        edge : str
            ``"enter"`` or ``"leave"`` (:meth:`take`).
        write : callable
            Where lines are written now.

        Returns
        -------
        callable
            Where lines are written from now on.
        """
        if edge == "enter":
            self._outside = (getattr(program, "_out_motion", None), program._last, write, program.report.moves,
                             program.report.blocks_out)
            program._out_motion = program._last = None
            buffer: list[str] = []
            self._buffer = buffer
            return buffer.append
        program._out_motion, program._last, write, moves, blocks = self._outside
        name, first, last = self.done
        why = self.refusal(self._buffer, self.cycles[name], self._modes)
        if why is None:
            lines = self._buffer
        else:
            lines = self.raw
            report = program.report
            report.moves, report.blocks_out = moves, blocks + len(lines)
            report.expanded["profiles"] -= 1
            program.reader.notes.add(first, f"a lathe cycle's profile written as it runs, uncompensated: {why}")
            self.done = None
        for line in lines:
            write(line)
        return write

    @staticmethod
    def refusal(lines: list[str], cycle: str, state: ModalState) -> str | None:
        """Why LinuxCNC's cycle would refuse a compensated profile, or None.

        LinuxCNC needs a G71 profile monotonic in Z, a G72 profile in X and a G70 profile in
        either, each block turning back by at most :data:`TURN_BACK` (its first block excepted).
        A block the profile as written runs straight along the other axis may turn back by the
        machine's error there once compensated.
        """
        g = next((v for letter, v in word_values(uncommented(cycle)) if letter == "G" and 70 <= v < 73), 70)
        axes = {70: "ZX", 71: "Z", 72: "X"}[int(g)]
        points: list[dict[str, float]] = []
        here = {"X": 0.0, "Z": 0.0}
        for n, line in enumerate(lines, start=1):
            words = dict((letter, v) for letter, v in word_values(uncommented(mask_comments(line.rstrip("\r\n"), n, "")))
                         if letter in "XZ")
            if not words:
                continue
            here = {a: (words.get(a, here[a]) if state.absolute else here[a] + words.get(a, 0.0)) for a in "XZ"}
            points.append(dict(here))
        worst = []
        for a in axes:
            values = [p[a] for p in points]
            if len(values) < 2:
                return None
            sign = 1.0 if values[-1] >= values[0] else -1.0
            tolerance = TURN_BACK * (2.0 if a == "X" and state.diameter else 1.0)
            back = max(sign * (u - v) for u, v in zip(values[:-1], values[1:]))
            if back <= tolerance:
                return None
            worst.append(f"it would turn back by {back:.4g} {'in' if state.inch else 'mm'} in {a}")
        need = " or ".join(axes)
        return f"{' and '.join(worst)}, and G{g:g} needs it monotonic in {need} (LinuxCNC refuses it)"
