"""Reading a program back: its moves as the controller interpolates them, as one
:class:`~volerr_pin.compensation.MoveBatch` (:func:`interpret`)."""

from __future__ import annotations

from collections.abc import Iterable

from .._moves import ARC, LINE, POINT, MoveBatch, skip_run
from ...model import Machine
from ._flow import Flow
from . import _kept as kept, _macros as macros
from ._lexer import PROGRAM_END, GcodeError, mask_comments, split_lines
from ._modal import Interpreter
from ._polar import has_polar, read_polar
from ._source import ProgramFile
from ._dialect import check_lines_points, choose

__all__ = ["interpret"]


def interpret(machine: Machine, program: str | ProgramFile | Iterable[tuple[str, str]], source: str = "<program>",
              start=None, origin=None, programming: str = "axes", dialect=None, work_offsets=None,
              subroutines=None) -> MoveBatch:
    """The moves of a program as the controller interpolates them.

    Lines are straight in program coordinates, arcs turn about their centres. Moves before
    every axis' position is known are taken as rapids to their ends, and blocks that cannot be
    followed (canned cycles ...) are left out; both are listed in the batch's ``skipped``,
    with the reason (the construct as compensate's report names it), and the work and tool
    offsets the program selects are told in its ``notes``.

    Parameters
    ----------
    machine : Machine
        The machine; its axes are NC address letters.
    program : str, ProgramFile or iterable of (str, str)
        The program (mm, inch and deg as it selects): its text, its file (read once, line by
        line), or its lines with their endings (:meth:`ProgramFile.lines`,
        :func:`~volerr_pin.compensation.gcode.split_lines`).
    source : str
        Name of the program, for messages.
    start : array_like, shape (n_axes,), optional
        Axis positions [m, rad] before the program (default: mid-travel).
    origin : array_like, shape (n_axes,), optional
        Program coordinates [m, rad] of the program's zero (default zero).
    programming : str, default "axes"
        Programming mode when the program starts.
    dialect : str, optional
        ``"linuxcnc"``, ``"fanuc"`` or ``"haas"`` (default: told from the program, else
        LinuxCNC's; the batch's ``dialect`` says which and why).
    work_offsets : dict of str to array_like, optional
        The controller's work offsets [m, rad] by name (``"G54"``, ``"G55"`` ...).
    subroutines : str or Path, optional
        The folder of the subroutine files the program calls (``o<rcone> call`` runs
        ``rcone.ngc``; default: not followed).

    Returns
    -------
    MoveBatch
        One row per move, in program order, in program coordinates [m, rad] (targets may lie
        outside the travel): its ``line``, its ``kind`` (:data:`~volerr_pin.compensation.POINT`
        for a rapid or a move from an unknown position, ``LINE`` or ``ARC``, with the arc's
        circle) and whether it is in tool-tip programming. Its rows read one at a time as
        :class:`~volerr_pin.compensation._moves.Move`. Its ``skipped`` lists the blocks not
        followed (:class:`~volerr_pin.compensation.Skipped`), its ``notes`` the offsets.

    Raises
    ------
    GcodeError
        A block that cannot be read, a value LinuxCNC refuses (naming line and column), or
        text after the ``%`` that ends the program.
    """
    reader = Interpreter(machine, source=source, start=start, origin=origin, programming=programming,
                         work_offsets=work_offsets)
    if isinstance(program, str):
        lines = split_lines(program)
    else:
        lines = list(program.lines() if isinstance(program, ProgramFile) else program)
    reader.dialect, said = choose(dialect, lines, source)
    try:
        expansion = macros.expand(lines, source, subroutines=subroutines) if reader.dialect.expands else None
    except macros.Unfollowable:
        expansion = None   # read as it is, macro blocks kept (as compensate_program reads it)
    if expansion is None:
        batch = _moves(reader, lines, source, None)
    else:
        check_lines_points(reader.dialect, lines, reader.coordinate_letters, source)
        reader.points_checked = True
        try:
            batch = _moves(reader, expansion.lines, source, expansion.origin)
        except GcodeError as err:
            raise macros.renamed(err, source, expansion.origin) from None
    batch.dialect = (reader.dialect.name, said)
    return batch


def _moves(reader: Interpreter, lines, source: str, origin) -> MoveBatch:
    """The moves of the blocks ``lines`` (``origin``: the program line each comes from, for an
    expanded program), gathered in lists and laid into one batch at the end, with the blocks
    not followed (:attr:`MoveBatch.skipped`)."""
    state = reader.initial_state()
    flow = Flow(source)
    numbers, kinds, tips, starts, targets = [], [], [], [], []
    arc_rows, arcs = [], []
    skipped: list = []
    notes: list = []
    noted: set = set()
    origin_given = reader.origin_given or reader.table_given
    followed = 0        # moves followed when the last block was skipped
    lost_at = 0         # the program line after which the position was lost
    for number, (body, _) in enumerate(lines, start=1):
        at = number if origin is None else origin[number - 1]
        masked = mask_comments(body, number, source)
        if has_polar(masked) and flow.body is None:
            body = read_polar(reader, body, masked, number, state)
            if body is None:   # a canned cycle's position
                skip_run(skipped, at, "polar coordinates (@ ^) of a canned cycle", followed != len(kinds))
                followed = len(kinds)
                continue
            masked = mask_comments(body, number, source)
        code = masked.upper()
        if flow.line(code, number):
            continue   # a subroutine body runs where it is called
        lost = state.lost
        block, problem = kept.classify(reader, body, number, state, masked)
        notes += [f"line {at}: {text}" for _, text in reader.told()]
        if problem:
            kept.skip(reader, body, state, block, number)
            flow.called(code, state, f"{source}:{number}")
            skip_run(skipped, at, kept.named(problem), followed != len(kinds))
            followed = len(kinds)
            lost_at = at if state.lost != lost else lost_at
            continue
        if block.words:
            notes += [f"line {at}: {text}" for text in kept.offset_notes(block, origin_given, noted, reader.programmed)]
        move = reader.advance(block, state, check_travel=False)
        if move is not None:
            # a rapid, or a move from an unknown position: only its end is meaningful
            if not move.start_known.all() or move.motion == 0:
                kind = POINT
                if move.motion != 0:
                    missing = ", ".join(a for a, k in zip(reader.axes, move.start_known) if not k)
                    why = (f"axes {missing} not known since line {lost_at}" if state.lost and lost_at else
                           f"axes {missing} not yet programmed")
                    skip_run(skipped, at, f"a cut from an unknown position ({why})", followed != len(kinds), True)
                    followed = len(kinds) + 1
            elif move.motion == 1:
                kind = LINE
            else:
                kind = ARC
                arc_rows.append(len(kinds))
                arcs.append(reader.arc(block, move.start, move.target, move.motion == 2, state))
            kinds.append(kind)
            numbers.append(at)
            tips.append(move.tool_tip)
            starts.append(move.start)
            targets.append(move.target)
        if state.lost != lost:   # (a tool change)
            lost_at = at
        if any(w.letter == "M" and w.value in PROGRAM_END for w in block.words):
            break   # the program ends: nothing after it is read
    batch = MoveBatch.empty(len(kinds), len(reader.axes))
    batch.skipped, batch.notes = skipped, notes
    if kinds:
        batch.kind[:] = kinds
        batch.w0[:] = starts
        batch.w1[:] = targets
        batch.line[:] = numbers
        batch.tool_tip[:] = tips
        batch.put_arcs(arc_rows, arcs)
    return batch
