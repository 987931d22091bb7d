"""Checks that every word of a block means something in its modal state."""

from __future__ import annotations

from collections.abc import Callable

from ._lexer import AXIS_LETTERS, CENTRE, PLANES, SHIFT_RESETS, Block, GcodeError, Word
from ._state import ModalState

#: G64: path blending, whose P and Q are its tolerances
BLENDING = 64
#: LinuxCNC's M66 (wait on an input), M67 and M68 (analog outputs): their E word names the channel
ANALOG_M = (66, 67, 68)

__all__ = ["check_letters", "full_circle"]


def full_circle(block: Block, state: ModalState) -> bool:
    """Whether a block is a full circle without end words: an arc move (G2 / G3, modal or
    written) with a centre word of its plane and no axis word, which LinuxCNC turns about the
    centre from where the tool stands back to it (R alone cannot: no end words, no circle).

    Parameters
    ----------
    block : Block
        The block.
    state : ModalState
        The modal state after its G codes.

    Returns
    -------
    bool
        True for such a block.
    """
    if state.motion not in (2, 3):
        return False
    plane = PLANES[state.plane]
    letters = {w.letter for w in block.words}
    return bool(letters & {CENTRE[plane[0]], CENTRE[plane[1]]}) and not letters & set(AXIS_LETTERS)


def check_letters(block: Block, state: ModalState, coord_words: list[Word], axes, where: Callable[[Block, Word], str],
                  machine_name: str) -> None:
    """Check that every word of a block means something in its modal state.

    Axis words name axes of the machine; I, J, K and R belong to arc moves; P to a
    dwell, an arc, G54.1 or an M code; Q and L to an M code; E to M66 - M68 (an analog
    channel); P and Q to G64 (path blending tolerances, which pass through); a dwell (G4)
    carries no axis word but X (its time), or P (its time) with a motion code whose move
    follows the dwell.

    Parameters
    ----------
    block : Block
        The block.
    state : ModalState
        The modal state after the block's G codes.
    coord_words : list of Word
        The block's axis words.
    axes : collection of str
        The machine's axis letters.
    where : callable
        ``where(block, word)``: the file, line and column of a word, for messages.
    machine_name : str
        The machine's name, for messages.

    Raises
    ------
    GcodeError
        Naming line, column and word.
    """
    gs = [w for w in block.words if w.letter == "G"]
    reset = next((w for w in gs if w.value in SHIFT_RESETS), None)
    if reset is not None and coord_words:
        raise GcodeError(f"{where(block, coord_words[0])}: {coord_words[0].name} with {reset.name}: LinuxCNC "
                         f"moves there after resetting the G92 offsets, Fanuc controls preset the workpiece "
                         f"coordinates to it; which cannot be told: write {reset.name} on a line of its own")
    dwell = any(w.value == 4 for w in gs)
    motion = [w for w in gs if w.value in (0, 1, 2, 3)]
    if dwell and motion:
        # LinuxCNC dwells, then moves (its skeleton program opens so: G04 P.001 G0 X1 Y1); the
        # axis words are the move's, so the time must be in P (Fanuc's G4 X would be ambiguous)
        if motion[0].value in (2, 3):
            raise GcodeError(f"{where(block, motion[0])}: {motion[0].name} and G4 (dwell) in one block: P "
                             "would be both the dwell time and the arc's turns; dwell on a line of its own")
        if not any(w.letter == "P" for w in block.words):
            raise GcodeError(f"{where(block, motion[0])}: {motion[0].name} and G4 (dwell) in one block "
                             "without P: give the dwell time in P (an X word is the move's)")
        dwell = False
    elif dwell:
        other = [w for w in coord_words if w.letter != "X"]
        if other:
            raise GcodeError(f"{where(block, other[0])}: {other[0].name} in a dwell (G4): a dwell "
                             "takes its time in P or X and moves no axis")
    arc_move = not dwell and state.motion in (2, 3) and (bool(coord_words) or full_circle(block, state))
    has_m = None
    for w in block.words:
        letter = w.letter
        if letter in "GMNOFSTHD" or letter in axes or (dwell and letter in "XP"):
            continue
        here = f"{where(block, w)}: {w.name}"
        if letter in AXIS_LETTERS:
            raise GcodeError(f"{here}: {machine_name} has no axis {letter}")
        if letter in "IJKR":
            if arc_move:
                continue
            if state.motion in (2, 3) and not coord_words:
                why = ("an arc without end point words: only a full circle may leave them out, given by the "
                       "centre words of its plane (R gives none)")
            elif coord_words and state.motion in (0, 1):
                why = (f"{letter} on a straight move (G{state.motion}): I, J, K and R belong to arcs; corner "
                       "rounding and chamfers are not understood")
            else:
                why = f"{letter} outside an arc move: I, J, K and R belong to arcs (G2/G3)"
            raise GcodeError(f"{here}: {why}")
        if has_m is None:
            has_m = any(v.letter == "M" for v in block.words)
        if letter == "P" and (arc_move or has_m or any(g.value in (54.1, 154, 4) for g in gs)):
            continue
        if letter in "QL" and has_m:
            continue
        if letter == "E" and any(v.letter == "M" and v.value in ANALOG_M for v in block.words):
            continue   # the analog channel of LinuxCNC's M66 - M68
        if letter in "PQ" and any(g.value == BLENDING for g in gs):
            continue
        raise GcodeError(f"{here}: {letter} words mean nothing this reader knows here")
