"""The modal state of an NC program: what the controller remembers between blocks."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from ._lexer import AUTORESTORE_MODES, CANNED, FORGET_MODES, RESTORE_MODES, SAVE_MODES, GcodeError

__all__ = ["ModalState"]


@dataclass
class ModalState:
    """What the controller remembers between blocks.

    Attributes
    ----------
    position : numpy.ndarray, shape (n_axes,)
        Program coordinates after the last move [m, rad] (the origin added); axes the
        program has not yet programmed hold the start position.
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
    centres_absolute : bool
        Arc centre words I, J, K are absolute program coordinates (G90.1) rather than offsets
        from the arc's start (G91.1, the initial state).
    inch : bool
        Coordinates in inch (G20) rather than mm (G21).
    diameter : bool
        X words are diameters (LinuxCNC's lathe diameter mode, G7; a FANUC or Haas lathe's
        default) rather than radii (G8, LinuxCNC's initial state); I stays a radius.
    inverse_time : bool
        Inverse time feed (G93): each block's F is the reciprocal of its time [1/min].
    canned : bool
        A canned cycle is active: axis words are positions of the cycle, not moves.
    lost : str
        Why positions the program had set are no longer known (e.g. ``"line 20's M6
        tool change"``); empty while none was lost.
    offset : tuple of (str, int) or None
        The work offset in use (``"G54"``, ``"G54.1 P2"``) and the line that selected it.
    programs : int
        Program numbers (O words) read.
    tool_tip : bool
        Tool-tip programming (G43.4, TRAORI) rather than axis programming.
    regions : list of tuple
        The modes in force whose blocks are kept unchanged (:mod:`._regions`), oldest first;
        empty outside them.
    saved : tuple or None
        The modes M70 (or M73) saved (:meth:`modes`), and its line; None before any and after
        M71.
    linuxcnc : bool
        LinuxCNC's M70 - M73 and G7 / G8 hold (other dialects give these codes other meanings).
    """

    position: np.ndarray
    known: np.ndarray
    motion: int | None = None
    plane: int = 17
    absolute: bool = True
    centres_absolute: bool = False
    inch: bool = False
    diameter: bool = False
    inverse_time: bool = False
    canned: bool = False
    lost: str = ""
    offset: tuple[str, int] | None = None
    programs: int = 0
    tool_tip: bool = False
    regions: list = field(default_factory=list)
    saved: tuple | None = None
    linuxcnc: bool = True

    def modes(self) -> tuple:
        """The modes LinuxCNC's M70 saves and M72 restores, as far as they change how blocks read:
        plane, distance, arc centre distance, units, feed mode, work offset (the motion mode is
        not among them).

        Returns
        -------
        tuple
            ``(plane, absolute, centres_absolute, inch, inverse_time, offset)``.
        """
        return self.plane, self.absolute, self.centres_absolute, self.inch, self.inverse_time, self.offset

    def apply_m(self, codes: Iterable[float], where: str) -> None:
        """Apply the M codes of a block that save and restore the modes (M70 - M73).

        Parameters
        ----------
        codes : iterable of float
            The values of the block's M words.
        where : str
            ``source:line``, for messages.

        Raises
        ------
        GcodeError
            M72 with nothing saved (LinuxCNC refuses it too).
        """
        if not self.linuxcnc:   # M70 - M73 are the machine builder's on other controls
            return
        for m in codes:
            if m in (SAVE_MODES, AUTORESTORE_MODES):
                self.saved = (self.modes(), where)
            elif m == FORGET_MODES:
                self.saved = None
            elif m == RESTORE_MODES:
                if self.saved is None:
                    raise GcodeError(f"{where}: M72 restores the modes M70 saved, and none are saved (no M70 "
                                     "before it, or M71 since)")
                (self.plane, self.absolute, self.centres_absolute, self.inch, self.inverse_time,
                 self.offset) = self.saved[0]   # (the reader takes the offset's zero: Interpreter.restored)

    def apply_g(self, codes: Iterable[float]) -> None:
        """Apply the modal G codes of a block (motion, plane, distance, arc centre distance and
        unit modes).

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
            elif g in (90.1, 91.1):
                self.centres_absolute = g == 90.1
            elif g in (7, 8) and self.linuxcnc:   # (FANUC: G7 a hypothetical axis, G8 look-ahead)
                self.diameter = g == 7
            elif g == 20:
                self.inch = True
            elif g == 21:
                self.inch = False
            elif g in (93, 94, 95):
                self.inverse_time = g == 93

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
