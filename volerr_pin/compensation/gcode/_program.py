"""Compensating a program as a stream: read, compensate and write it chunk by chunk.

The lines are read one at a time; the modal state and the compensated position carry from
chunk to chunk; a chunk's moves are compensated together (a few calls of the model for
thousands of moves, :meth:`~volerr_pin.compensation.PathCompensator.compensate`) and its
lines written before the next chunk is read, so memory stays bounded whatever the program's
length. Every line that is not a compensated move is written byte for byte.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable

import numpy as np

from .._moves import ARC, LINE, POINT
from .._path import PathCompensator
from ...model import Machine, axis_jacobian
from ._dialect import check_lines_points
from ._flow import Flow
from . import _kept as kept, _macros as macros
from ._lexer import LATHE_CYCLES, PROGRAM_END, Block, GcodeError, mask_comments, split_lines
from ._modal import Interpreter, check_axes, move_of
from ._polar import has_polar, read_polar
from ._profiles import Profiles
from ._report import Report
from ._rewrite import Writer
from ._chunks import FIRST_CHUNK, ChunkWriting, _Move
from ._runs import PlainRun, PlainRuns, arc_line, arc_words, plain_line, plain_words

__all__ = ["MIN_TOL_UM", "Program", "compensate_program"]

#: the finest tolerance taken [um]: the point compensation itself stops at 0.01 um, and the
#: written numbers resolve 0.05 um
MIN_TOL_UM = 0.01
#: lines held before they are written, whether or not they hold moves
MOST_LINES = 32_768


class Program(ChunkWriting):
    """Compensates a program for a machine whose axes are NC letters (X, Y, Z, A, B, C).

    Parameters
    ----------
    machine : Machine
        The machine, in the state (time, temperatures ...) to compensate for.
    tol_um : float
        Position tolerance along every move [um].
    pass_through : bool, default False
        True also keeps G codes the reader does not know (named, with a warning that the
        blocks after them may be misread), which are refused otherwise.
    start : array_like, shape (n_axes,), optional
        Axis positions [m, rad] where the program starts, NaN where not known (see
        :class:`~volerr_pin.compensation.gcode._modal.Interpreter`; default: none known).
    method : str
        Solver of the compensated commands (see :class:`~volerr_pin.compensation.PathCompensator`).
    source : str
        Name of the program, for messages.
    tol_urad : float, optional
        Tool-axis tolerance on machines with rotary axes [urad] (default 10 urad per um of
        ``tol_um``).
    origin : array_like, shape (n_axes,), optional
        Program coordinates [m, rad] of the program's zero (the work offset, G54 ...): absolute
        program words plus ``origin`` are axis positions (or, in tool-tip programming, the tool
        tip in the workpiece frame and the rotary axes). Default zero.
    strict : bool, default False
        Stop with an error at the first block that cannot be compensated (canned cycles,
        macros, subprograms, polar or cylindrical interpolation ...) instead of keeping it
        unchanged and naming it in the warnings (the default).
    programming : str, default "axes"
        Programming mode when the program starts: ``"axes"`` (the words are axis positions)
        or ``"tool-tip"`` (tool centre point control is on: X, Y, Z are the tool tip in the
        workpiece frame). G43.4 / TRAORI and G49 / TRAFOOF in the program change it.
    detail : bool, default False
        Keep per-move results in :attr:`Report.detail` (for pictures; 16 bytes a move).
    most_blocks : int, default 1,000,000
        The most blocks a program whose parameters, loops and subroutine calls are expanded may
        run (every line run and every loop pass counts); a program that would run more is
        refused.
    dialect : str, optional
        ``"linuxcnc"``, ``"fanuc"`` or ``"haas"`` (:mod:`._dialect`); default: told from the
        program's text where it says one (:meth:`decide`), else LinuxCNC's.
    work_offsets : dict of str to array_like, optional
        The controller's work offsets [m, rad] by name (``"G54"``, ``"G55"``, ``"G54.1 P2"``;
        :func:`~volerr_pin.compensation.gcode.read_work_offsets`): a program with several
        set-ups is read with each one's values. Not with ``origin``.
    subroutines : str or Path, optional
        The folder where LinuxCNC finds the subroutine files the program calls
        (``o<rcone> call`` runs ``rcone.ngc``): their blocks are followed where they run.
        None: such a call is kept, and named.

    Attributes
    ----------
    reader : Interpreter
        The modal interpreter.
    comp : PathCompensator
        The path compensation.
    writer : Writer
        Writes the pieces.
    report : Report
        What the compensation did (complete after :meth:`run`).

    Raises
    ------
    GcodeError
        An axis that is not an NC address letter, a tolerance that is not finite or finer
        than :data:`MIN_TOL_UM`, a ``tol_urad`` that is not positive and finite, an invalid
        ``start`` or ``origin``, both ``strict`` and ``pass_through`` (strict refuses what
        pass_through keeps), a ``programming`` the machine cannot take, or a ``most_blocks``
        that is not a whole number of at least 1.
    """

    def __init__(self, machine: Machine, tol_um: float = 1.0, pass_through: bool = False,
                 start=None, method: str = "newton", source: str = "<program>", tol_urad: float | None = None,
                 origin=None, *, strict: bool = False, programming: str = "axes", detail: bool = False,
                 most_blocks: int = macros.MOST_BLOCKS, dialect=None, work_offsets=None, subroutines=None):
        check_axes(machine)  # the machine is reported before the tolerance
        if not (math.isfinite(tol_um) and tol_um >= MIN_TOL_UM):
            raise GcodeError(f"tol_um must be finite and at least {MIN_TOL_UM:g} um (what the point compensation "
                             f"resolves), got {tol_um}", parameters=("tol_um",))
        if tol_urad is not None and not (math.isfinite(tol_urad) and tol_urad > 0):
            raise GcodeError(f"tol_urad must be positive and finite, got {tol_urad}", parameters=("tol_urad",))
        if strict and pass_through:
            raise GcodeError("strict refuses the codes pass_through keeps: give one of them",
                             parameters=("strict", "pass_through"))
        self.strict = bool(strict)
        self.keep_unknown = bool(pass_through)
        self.reader = Interpreter(machine, source=source, start=start, origin=origin, programming=programming,
                                  dialect=dialect, work_offsets=work_offsets)
        self._dialect = dialect
        self._decided = False
        self.subroutines = subroutines
        # the written numbers are rounded (0.05 um per linear axis at most, and the rotary
        # axes' 0.5e-5 deg times the tool's lever): the paths are compensated to the tolerance
        # less that margin, so the program as written meets it
        rounding = math.sqrt(0.05**2 * sum(self.reader.linear) + sum(lever**2 for lever in _levers(machine)))
        margin = min(rounding, 0.5 * tol_um)
        self.margin = margin * 1e-6
        self.tol_urad = 10.0 * tol_um if tol_urad is None else tol_urad
        inner_urad = None if tol_urad is None else tol_urad * (tol_um - margin) / tol_um
        self.comp = PathCompensator(machine, tol_um=tol_um - margin, method=method, tol_urad=inner_urad)
        self.report = Report(tolerance_um=tol_um)
        self.flow = Flow(source)
        self.writer = Writer(self.reader, tol_um * 1e-6, self.margin)
        self._plain = plain_line(self.reader.axes)
        self._arc = arc_line(self.reader.axes)
        self._runs = PlainRuns(self.reader, self.writer) if self._plain is not None else None
        self._groups: list = []
        self.detail = detail
        self._general = []
        if rounding > 0.5 * tol_um:
            self._general.append(
                f"the tolerance {tol_um:g} um is finer than the written numbers resolve (they round by up "
                f"to {rounding:.3f} um): the program as written may miss it by that much")
        self._chunk = FIRST_CHUNK
        self._last = None  # (axis positions, residual) of the last compensated move's end
        self._eol = None
        self._noted: set = set()
        # an axis word of a kept line: the letter (not inside a keyword) and a value
        self._axis_word = re.compile(r"(?<![A-Z])[" + "".join(self.reader.axes) + r"][ \t]*[-+.0-9#\[]")
        if isinstance(most_blocks, bool) or not isinstance(most_blocks, int) or most_blocks < 1:
            raise GcodeError(f"most_blocks must be a whole number of at least 1, got {most_blocks!r}",
                             parameters=("most_blocks",))
        self.most_blocks = most_blocks
        self.source = source
        self._origin = None   # for an expanded program: the line each block as run comes from
        self._lines_in = None
        self._profiles = Profiles()   # lathe cycles' profiles written by the expansion

    # the run --------------------------------------------------------------------
    def compensate(self, text: str, progress: Callable[[int], None] | None = None) -> str:
        """The compensated program (a whole text; see :meth:`run` for a stream).

        Parameters
        ----------
        text : str
            The program (mm, inch and deg as it selects); its line endings are kept.
        progress : callable, optional
            Called as ``progress(lines_done)`` as the lines are compensated.

        Returns
        -------
        str
            The compensated program; :attr:`report` describes it.

        Raises
        ------
        GcodeError
            A block that cannot be read or compensated, naming its line.
        """
        out: list[str] = []
        lines = split_lines(text)
        self.decide(lines)
        self.run(self.expand(lines), out.append, progress)
        return "".join(out)

    def decide(self, lines: Iterable[tuple[str, str]] | None) -> None:
        """Take the dialect given, or tell it from the program's lines (before :meth:`run`).

        Parameters
        ----------
        lines : iterable of (str, str) or None
            The program's lines (None: take the dialect given, or LinuxCNC's).

        Raises
        ------
        GcodeError
            A program of a dialect the reader does not read, naming the line that says it.
        """
        from ._dialect import choose

        self.reader.dialect, said = choose(self._dialect, lines, self.source)
        self.report.dialect, self.report.dialect_said = self.reader.dialect.name, said
        self._decided = True

    def expand(self, lines: list[tuple[str, str]]) -> list[tuple[str, str]]:
        """The program as it runs, if its parameters, expressions and O-words can be followed.

        Parameters
        ----------
        lines : list of (str, str)
            The program's lines and their endings.

        Returns
        -------
        list of (str, str)
            The blocks as run (see :mod:`._macros`), or ``lines`` itself when there is nothing
            to expand or the expansion is stopped by what only the running machine knows
            (the report's warnings say what); give the result to :meth:`run`. Messages about
            an expanded program name the line each block comes from.

        Raises
        ------
        GcodeError
            A program that would run more than ``most_blocks`` blocks, naming the loop or
            call running then.
        """
        return _expanded(self, lines)

    def run(self, lines: Iterable[tuple[str, str]], write: Callable[[str], object],
            progress: Callable[[int], None] | None = None) -> Report:
        """Compensate a program given line by line, writing the result as it goes.

        Parameters
        ----------
        lines : iterable of (str, str)
            Each line without its ending, and the ending (``"\\n"``, ``"\\r\\n"`` or ``""``).
        write : callable
            Called with the text of each written line (ending included), in order.
        progress : callable, optional
            Called as ``progress(lines_done)`` after each chunk.

        Returns
        -------
        Report
            :attr:`report`.

        Raises
        ------
        GcodeError
            A block that cannot be read or compensated, naming its line (lines before it may
            have been written already).
        """
        if not self._decided:
            self.decide(None)
        try:
            return self._run(lines, write, progress)
        except GcodeError as err:
            if self._origin is None:
                raise
            raise macros.renamed(err, self.source, self._origin) from None

    def _run(self, lines, write, progress) -> Report:
        reader = self.reader
        state = reader.initial_state()
        entries: list = []
        moves = 0
        mode = None
        number = 0
        runs = self._runs if self._plain is not None else None
        fast = runs is not None and runs.takes(state)
        run = None  # the open run of plain lines
        ended = 0   # the line of the M2 / M30 that ended the program
        for number, (body, newline) in enumerate(lines, start=1):
            if self._eol is None and newline:
                self._eol = newline
            if fast:
                shape = runs.shape(body)
                if shape is not None:
                    if run is None:
                        run = PlainRun(number)
                        run.mode = "tool-tip" if state.tool_tip else "axes"
                        if mode is not None and run.mode != mode:
                            self._flush(entries, write)
                            entries, moves = [], 0
                        mode = run.mode
                    if not runs.add(run, body, newline, shape, state.inverse_time):
                        shape = None
                if shape is not None:
                    moves += 1
                    if moves >= self._chunk or len(entries) + run.count >= MOST_LINES:
                        entries += self._close(run, state)
                        run = None
                        self._flush(entries, write)
                        entries, moves = [], 0
                        if progress is not None:
                            progress(number)
                    continue
            if run is not None:
                entries += self._close(run, state)
                run = None
            if ended:
                # after M2 / M30 the program has ended: a controller reads nothing more (the tape's
                # closing '%' is no block)
                if body.strip(" \t") != "%" and not (reader.dialect.tape_text and body.lstrip(" \t").startswith("%")):
                    reader.notes.add(number, f"after the program's end (line {ended}'s M2 / M30) kept unchanged: a "
                                     "controller does not read it")
                entries.append(("raw", body + newline))
                continue
            origin = reader.origin
            entry = self._read(body, newline, number, state)
            if reader.origin is not origin:
                # another work offset: what was read before it is written from the zero it was read with
                self._flush(entries, write)
                entries, moves = [], 0
                self.writer.set_origin(reader.origin)
                if runs is not None:
                    runs.set_origin(reader.origin)
            if entry[0] in ("plain", "move") and any(w.letter == "M" and w.value in PROGRAM_END
                                                      for w in entry[1].words):
                ended, fast = number, False
            if entry[0] == "move":
                if mode is not None and entry[3].mode != mode:
                    self._flush(entries, write)
                    entries, moves = [], 0
                mode = entry[3].mode
                moves += 1
            entries.append(entry)
            edge = self._profiles.take()
            if edge:   # a profile's moves are compensated apart: the cycle's path, not the program's
                self._flush(entries, write)
                entries, moves = [], 0
                write = self._profiles.switch(self, edge, write)
            if runs is not None:   # a subroutine body is kept line by line, not read as moves
                fast = runs.takes(state) and self.flow.body is None and not self._profiles.reading
            if moves >= self._chunk or len(entries) >= MOST_LINES:
                self._flush(entries, write)
                entries, moves = [], 0
                if progress is not None:
                    progress(number)
        if run is not None:
            entries += self._close(run, state)
        self._flush(entries, write)
        self.flow.finish(number)
        self.report.blocks_in = number if self._lines_in is None else self._lines_in
        if progress is not None:
            progress(number)
        notes = reader.notes
        self.report.warnings = self._general + notes.render()
        return self.report

    def _close(self, run: PlainRun, state) -> list:
        """The entries of a run of plain lines: the run itself, or, if it cannot be taken as
        a whole, its lines read one by one (which names what is wrong)."""
        if not run.count:
            return []
        if self._runs.close(run, state):
            run.kind = LINE if run.motion == 1 else POINT
            run.modes = {"absolute": True, "inch": state.inch, "plane": state.plane, "all_known": True,
                         "inverse": state.inverse_time, "centres_absolute": state.centres_absolute,
                         "diameter": state.diameter}
            return [("run", run)]
        return [self._read(body, newline, run.first + i, state)
                for i, (body, newline) in enumerate(zip(run.bodies, run.newlines))]

    # reading --------------------------------------------------------------------
    def _read(self, body: str, newline: str, number: int, state) -> tuple:
        """One line as ("raw", text) (kept unchanged), ("plain", block, newline) (no move) or
        ("move", block, newline, _Move)."""
        reader = self.reader
        if self._profiles.reading:
            self._profiles.raw.append(body + newline)
        if not state.regions and not state.canned and self.flow.body is None:
            words = plain_words(self._plain, body)
            if words is not None and reader.dialect.decimal_point and any("." not in w.text for w in words):
                words = None   # (FANUC: a whole number may be increments; the full reader checks it)
            if words is not None:  # the fast path (see runs.plain_words)
                block = Block(number, body, words, body, False)
                return self._entry(block, newline, number, state, state.lost,
                                   move_of(reader, block, state, words, not state.tool_tip))
            words = arc_words(self._arc, body, reader.axes)
            if words is not None and reader.dialect.decimal_point and any("." not in w.text for w in words
                                                                           if w.letter != "G"):
                words = None
            if words is not None and (words[0].value if words[0].letter == "G" else state.motion) in (2, 3):
                # the fast path for arcs (see runs.arc_words)
                if words[0].letter == "G":
                    state.apply_g([words[0].value])
                block = Block(number, body, words, body, False)
                coord_words = [w for w in words if w.letter in reader.axes]
                return self._entry(block, newline, number, state, state.lost,
                                   move_of(reader, block, state, coord_words, not state.tool_tip))
        masked = mask_comments(body, number, reader.source)
        if has_polar(masked) and self.flow.body is None:
            cartesian = read_polar(reader, body, masked, number, state)
            if cartesian is None:
                reader.notes.add(number, "polar coordinates (@ ^) of a canned cycle kept unchanged")
                self._kept(masked, move=True)
                return ("raw", body + newline)
            body = cartesian
            masked = mask_comments(body, number, reader.source)
            reader.notes.add(number, "polar coordinates (@ ^) written as the X and Y they mean")
        code = masked.upper()
        if self.flow.body is None and self._profiles.line(reader, code, number, state):
            return ("raw", body + newline)
        if self.flow.line(code, number):
            body_of = self.flow.body[0] if self.flow.body else None
            reader.notes.add(number, f"the body of subroutine o{body_of.lower()} kept unchanged: it runs where it "
                             "is called" if body_of else "the end of a subroutine body kept unchanged")
            self.report.passed_through += 1   # a definition: its moves run where it is called
            return ("raw", body + newline)
        block, problem = kept.classify(reader, body, number, state, masked)
        for at, text in reader.told():
            reader.notes.add(at, text)
        done = self._profiles.done
        if problem and done and block is not None and any(w.letter == "G" and w.value in LATHE_CYCLES
                                                          for w in block.words):
            self._profiles.done = None
            reader.notes.add(number, f"{problem} kept as written: it cuts along its profile, compensated as "
                             f"subroutine o{done[0]} written before it")
            kept.skip(reader, body, state, block, number)
            return ("raw", body + newline)
        if problem:
            if self.strict:
                raise GcodeError(f"{reader.source}:{number}: {problem} cannot be compensated (strict refuses it; "
                                 "without strict it is kept unchanged and named in the report)",
                                 parameters=("strict",))
            if problem.unknown_code and not self.keep_unknown:
                raise GcodeError(f"{reader.source}:{number}:{problem.column}: {problem}: what it changes cannot be "
                                 "told, so the blocks after it may be misread (pass_through keeps it unchanged and "
                                 "goes on)", parameters=("pass_through",))
            reader.notes.add(number, kept.named(problem, "kept unchanged"))
            self._kept(code)
            kept.skip(reader, body, state, block, number)
            self.flow.called(code, state, f"{reader.source}:{number}")
            return ("raw", body + newline)
        if block.words:
            _note_offsets(self, block)
        lost = state.lost
        return self._entry(block, newline, number, state, lost, reader.advance(block, state))

    def _kept(self, code: str, move: bool | None = None) -> None:
        """Count a line kept unchanged (and, if it names an axis or ``move``, a move run
        uncompensated)."""
        self.report.passed_through += 1
        if move or (move is None and (self._axis_word.search(code) or CALLS.search(code))):
            self.report.moves_kept += 1

    def _entry(self, block: Block, newline: str, number: int, state, lost: str, move) -> tuple:
        """The entry of a block that was read and followed (``move`` as advance gives it)."""
        reader = self.reader
        if move is None:
            return ("plain", block, newline)
        if not state.absolute:
            self.flow.incremental(number)   # compensated for this pass: a loop may not run it again
        kind = LINE if move.motion == 1 or (move.motion == 0 and self._profiles.reading) else (
            ARC if move.motion in (2, 3) else POINT)   # (a lathe cycle cuts its profile's G0 as G1)
        all_known = all(state.known.tolist())  # (as ndarray.all(), without its overhead on a few axes)
        if not all(move.start_known.tolist()):
            missing = ", ".join(a for a, k in zip(reader.axes, move.start_known) if not k)
            why = f"axes {missing} not known since {lost}" if lost else f"axes {missing} not yet programmed"
            if move.motion in (2, 3):
                if self.strict:
                    raise GcodeError(f"{reader.source}:{number}: an arc from an unknown position ({why}); move "
                                     "every axis to a known point with G0 or G1 first, or give where the axes stand "
                                     "when the program starts (start; a 2-D program never writes Z)",
                                     parameters=("start", "strict"))
                reader.notes.add(number, f"an arc from an unknown position ({why}) kept unchanged: give where the "
                                 "axes stand when the program starts (start; a 2-D program never writes Z) to "
                                 "compensate it")
                self._kept(block.text.upper())
                return ("raw", block.text + newline)
            rest = ""
            if not all_known:
                rest = (", taking the axes it does not name where they were last programmed" if lost else
                        ", taking the unprogrammed axes at mid-travel")
            reader.notes.add(number, f"the position before this move is not known ({why}); it is compensated at "
                             f"its end point only{rest}")
            kind = POINT
        arc = reader.arc(block, move.start, move.target, move.motion == 2, state) if kind == ARC else None
        modes = {"absolute": state.absolute, "inch": state.inch, "plane": state.plane,
                 "all_known": all_known, "inverse": state.inverse_time, "centres_absolute": state.centres_absolute,
                 "diameter": state.diameter}
        mode = "tool-tip" if move.tool_tip else "axes"
        return ("move", block, newline, _Move(kind, move.motion, move.start, move.target, arc, move.coord_words,
                                               modes, number, mode))

    # compensating and writing -------------------------------------------------------


#: a kept call runs blocks the reader does not follow (an O-word call, M98, G65 / G66): a move kept
CALLS = re.compile(r"\bCALL\b|(?<![A-Z])M[ \t]*0*98(?![0-9])|(?<![A-Z])G[ \t]*0*6[56](?![0-9.])")


def _note_offsets(program: Program, block: Block) -> None:
    """Warn (once) of work and tool offsets, which the model does not know."""
    reader = program.reader
    for text in kept.offset_notes(block, reader.origin_given or reader.table_given, program._noted, reader.programmed):
        program.reader.notes.add(block.number, text)


def _expanded(program: Program, lines: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """:meth:`Program.expand`: the lines to run, with the program's report and warnings told."""
    if not program.reader.dialect.expands:
        return lines
    try:
        expansion = macros.expand(lines, program.source, program.most_blocks, program.subroutines)
    except macros.Unfollowable as why:
        program.reader.notes.note(f"the program's parameters, expressions and O-words are not followed (line "
                                  f"{why.line}: {why}): their blocks are kept unchanged")
        return lines
    if expansion is None:
        return lines
    reader = program.reader
    check_lines_points(reader.dialect, lines, reader.coordinate_letters, program.source)
    reader.points_checked = True
    program._origin = expansion.origin
    program._lines_in = len(lines)
    program.reader.notes.origin = expansion.origin
    program.report.expanded = {"blocks_run": len(expansion.lines), "calls": expansion.calls,
                               "loop_passes": expansion.passes, "profiles": len(expansion.profiles)}
    program._profiles = Profiles(expansion.profiles)
    program.reader.notes.note(
        f"the program's parameters, expressions and O-words were followed as LinuxCNC runs them ({len(lines):,} "
        f"lines run as {len(expansion.lines):,} blocks; {expansion.calls:,} subroutine calls, "
        f"{expansion.passes:,} loop passes): the output is the program as run, numbers in place of "
        "parameters and expressions")
    return expansion.lines


def _levers(machine: Machine) -> list[float]:
    """For each rotary axis, how far the rounding of its written angle (0.5e-5 deg) moves the
    tool tip at most [um] (its largest lever over a few poses)."""
    rotary = [j for j, kind in enumerate(machine.axis_kinds) if kind == "rotary"]
    if not rotary:
        return []
    rng = np.random.default_rng(0)
    travel = np.where(np.isfinite(machine.travel), machine.travel, np.array([-math.pi, math.pi]))
    q = travel[:, 0] + rng.random((32, len(machine.axes))) * (travel[:, 1] - travel[:, 0])
    J = axis_jacobian(machine.model, q, nominal=True)   # (random poses within the travel)
    return [float(np.linalg.norm(J[:, :3, j], axis=1).max()) * math.radians(0.5e-5) * 1e6 for j in rotary]


def compensate_program(machine: Machine, text: str, *, tol_um: float = 1.0, pass_through: bool = False,
                       method: str = "newton", source: str = "<program>", tol_urad: float | None = None,
                       origin=None, strict: bool = False, programming: str = "axes",
                       start=None, most_blocks: int = macros.MOST_BLOCKS, dialect=None,
                       work_offsets=None, subroutines=None) -> tuple[str, Report]:
    """Compensate an NC program.

    Parameters
    ----------
    machine : Machine
        The machine; its axes are NC address letters.
    text : str
        The program (mm, inch and deg as it selects).
    tol_um : float
        Position tolerance along every move [um].
    pass_through : bool, default False
        True also keeps G codes the reader does not know.
    method : str
        Solver of the compensated commands.
    source : str
        Name of the program, for messages.
    tol_urad : float, optional
        Tool-axis tolerance on machines with rotary axes [urad] (default 10 urad per um of
        ``tol_um``).
    origin : array_like, shape (n_axes,), optional
        Program coordinates [m, rad] of the program's zero (default zero).
    strict : bool, default False
        Refuse blocks that cannot be compensated instead of keeping them (default: keep and
        name them).
    programming : str, default "axes"
        Programming mode when the program starts (``"axes"`` or ``"tool-tip"``).
    start : array_like, shape (n_axes,), optional
        Axis positions [m, rad] where the program starts, NaN where not known (see
        :class:`~volerr_pin.compensation.gcode._modal.Interpreter`; default: none known).
    most_blocks : int
        The most blocks a program whose loops and subroutine calls are followed may run
        (see :mod:`~volerr_pin.compensation.gcode`).
    dialect : str, optional
        ``"linuxcnc"``, ``"fanuc"`` or ``"haas"`` (default: told from the program, else LinuxCNC's).
    work_offsets : dict of str to array_like, optional
        The controller's work offsets [m, rad] by name (see :class:`Program`).
    subroutines : str or Path, optional
        The folder of the subroutine files the program calls (see :class:`Program`).

    Returns
    -------
    text : str
        The compensated program.
    report : Report
        What the compensation did.

    Raises
    ------
    GcodeError
        Invalid arguments, or a block that cannot be read or compensated, naming its line.
    """
    program = Program(machine, tol_um=tol_um, pass_through=pass_through, method=method, source=source,
                      tol_urad=tol_urad, origin=origin, strict=strict, programming=programming, start=start,
                      most_blocks=most_blocks, dialect=dialect, work_offsets=work_offsets,
                      subroutines=subroutines)
    return program.compensate(text), program.report
