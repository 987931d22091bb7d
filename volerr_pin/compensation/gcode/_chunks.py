"""Compensating and writing a program's chunks: the second half of
:class:`~volerr_pin.compensation.gcode.Program`.

A chunk is a list of entries as the reader made them: lines kept as they are, blocks without a
move, single moves (:class:`_Move`) and runs of plain lines (:class:`~.runs.PlainRun`). Its moves
are compensated in one batch, and its lines written in order: runs from their templates where a
move stays one piece, everything else through :class:`~.rewrite.Writer`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._arcs import arc_extent
from .._moves import ARC, POINT, MoveBatch
from .._path import Piece
from ._arc_words import arc_errors
from ._lexer import Block, GcodeError, parse_block
from ._modal import Interpreter
from ._runs import PlainRun

__all__ = ["FIRST_CHUNK", "MOST_CHUNK", "PIECE_BUDGET", "ChunkWriting"]

#: moves compensated together, at first and at most (the chunk grows while its pieces stay few)
FIRST_CHUNK, MOST_CHUNK = 512, 8192
#: pieces one chunk may hold; a chunk that splits its moves into more makes the next smaller
PIECE_BUDGET = 100_000


class _Move:
    """A desired move read from a block: ``kind`` POINT / LINE / ARC, the block's ``motion``,
    its ``modes`` (the output state it is written in) and its programming mode."""

    __slots__ = ("kind", "motion", "start", "target", "arc", "coord_words", "modes", "line", "mode")
    count = 1  # moves (as a run of plain lines counts its lines)

    def __init__(self, kind, motion, start, target, arc, coord_words, modes, line, mode):
        self.kind, self.motion, self.start, self.target, self.arc = kind, motion, start, target, arc
        self.coord_words, self.modes, self.line, self.mode = coord_words, modes, line, mode

class ChunkWriting:
    """The compensating and writing of chunks, for :class:`~volerr_pin.compensation.gcode.Program`
    (which holds the state these methods use: reader, comp, writer, runs, report ...)."""

    def _flush(self, entries: list, write: Callable[[str], object]) -> None:
        groups = [e[3] if e[0] == "move" else e[1] for e in entries if e[0] in ("move", "run")]
        results = self._compensate(groups) if groups else None
        st = {"out_motion": getattr(self, "_out_motion", None)}
        eol = self._eol or "\n"
        written = 0
        k = 0
        for entry in entries:
            kind = entry[0]
            if kind == "raw":
                write(entry[1])
                written += 1
            elif kind == "plain":
                block = entry[1]
                for w in block.words:
                    if w.letter == "G" and w.value in (0, 1, 2, 3):
                        st["out_motion"] = int(w.value)
                write(block.text + entry[2])
                written += 1
            elif kind == "run":
                run = entry[1]
                st.update(run.modes)
                written += self._write_run(run, results, k, st, eol, write)
                k += run.count
            else:
                mv = entry[3]
                st.update(mv.modes)
                lines = self._write_move(entry[1], entry[2], eol, mv, results, k, st)
                for line in lines:
                    write(line)
                written += len(lines)
                k += 1
        self._out_motion = st["out_motion"]
        self.report.blocks_out += written

    def _compensate(self, groups: list):
        """Compensate the moves of one chunk (one programming mode) in one batch: single
        moves (_Move) and runs of plain lines (PlainRun)."""
        reader, comp = self.reader, self.comp
        mode = reader.mode(groups[0].mode)
        n = len(reader.axes)
        total = sum(g.count for g in groups)
        batch = MoveBatch.empty(total, n)
        line = batch.line
        singles: list[int] = []
        ones: list = []
        k = 0
        for g in groups:
            if isinstance(g, _Move):
                singles.append(k)
                ones.append(g)
            else:
                rows = slice(k, k + g.count)
                batch.kind[rows] = g.kind
                batch.w0[rows] = g.starts
                batch.w1[rows] = g.targets
                line[rows] = np.arange(g.first, g.first + g.count)
            k += g.count
        if singles:
            batch.kind[singles] = [mv.kind for mv in ones]
            batch.w0[singles] = [mv.start for mv in ones]
            batch.w1[singles] = [mv.target for mv in ones]
            line[singles] = [mv.line for mv in ones]
            arcs = [(i, mv.arc) for i, mv in zip(singles, ones) if mv.arc is not None]
            if arcs:
                batch.put_arcs([i for i, _ in arcs], [a for _, a in arcs])
        batch.tool_tip[:] = not mode.identity   # (a chunk is in one programming mode)
        self._groups = groups
        _check_travel(self, line, batch, mode)
        start, start_residual = None, 0.0
        if self._last is not None and batch.kind[0] != POINT:
            start = mode.to_words(self._last[0][None, :])[0]
            start_residual = self._last[1]
        result = comp.compensate(batch, start=start, start_residual=start_residual, programming=mode)
        self._last = (mode.to_axes(result.end[-1:])[0], float(result.end_residual[-1]))
        _commands_outside(reader, line, result, mode)
        self.report.moves += total
        self.report.max_before_um = max(self.report.max_before_um, float(result.before.max()) * 1e6)
        if mode.name not in self.report.programming:
            self.report.programming.append(mode.name)
        # the next chunk: as many moves as keep its pieces within the budget
        per_move = max(len(result.pieces) / total, 1.0)
        self._chunk = int(min(MOST_CHUNK, 2 * self._chunk, max(64, PIECE_BUDGET / per_move)))
        ps = result.pieces
        # the per-piece numbers as plain Python values, converted once for the whole chunk
        columns = (ps.arc.tolist(), ps.sweep.tolist(), ps.residual.tolist(), ps.k0.tolist(), ps.k1.tolist(),
                   ps.limited.tolist())
        return result, ps.bounds(total), columns, self._arc_errors(ps, total, singles, ones)

    def _arc_errors(self, ps, total: int, singles: list[int], ones: list) -> list | None:
        """How far each arc piece of the chunk, written with centre words, is read back off
        its path (:func:`~.arc_words.arc_errors`; NaN for straight pieces), or None if
        there are no arc pieces."""
        rows = np.flatnonzero(ps.arc)
        if not len(rows):
            return None
        plane = np.full(total, 17)
        inch = np.zeros(total, dtype=bool)
        absolute = np.zeros(total, dtype=bool)
        diameter = np.zeros(total, dtype=bool)
        plane[singles] = [mv.modes["plane"] for mv in ones]  # (runs of plain lines hold no arcs)
        inch[singles] = [mv.modes["inch"] for mv in ones]
        absolute[singles] = [mv.modes["centres_absolute"] for mv in ones]
        diameter[singles] = [mv.modes["diameter"] for mv in ones]
        moves = ps.move[rows]
        errors = np.full(len(ps.arc), np.nan)
        errors[rows] = arc_errors(self.writer, ps.cw0[rows], ps.cw1[rows], ps.center[rows], ps.sweep[rows],
                                               plane[moves], inch[moves], absolute[moves], diameter[moves])
        return errors.tolist()

    def move_at(self, i: int) -> _Move:
        """The ``i``-th move of the chunk being compensated (for messages).

        Parameters
        ----------
        i : int
            Index of the move in the chunk.

        Returns
        -------
        _Move
            The move, with its coordinate words.
        """
        for g in self._groups:
            if i < g.count:
                return g if isinstance(g, _Move) else self._run_move(g, i)[0]
            i -= g.count
        raise IndexError(i)

    def _run_move(self, run: PlainRun, i: int) -> tuple[_Move, Block]:
        """Line ``i`` of a run as the line-by-line reader gives it: its move and block."""
        body, number = run.bodies[i], run.first + i
        block = parse_block(body, number, self.reader.source)
        words = [w for w in block.words if w.letter in self.reader.axes]
        return _Move(run.kind, run.motion, run.starts[i], run.targets[i], None, words, run.modes, number,
                     run.mode), block

    def _write_run(self, run: PlainRun, results, k: int, st: dict, eol: str, write) -> int:
        """Write the lines of a run from its templates (see :meth:`~.runs.PlainRuns.write`);
        returns the lines written."""
        result, bounds, columns, _ = results
        ps, report = result.pieces, self.report
        b = bounds[k:k + run.count + 1]
        first, last = int(b[0]), int(b[-1])
        if ps.arc[first:last].any():  # (straight moves give straight pieces: never so)
            return self._write_run_lines(run, results, k, st, eol, write)
        counts = np.diff(b)
        texts = self._runs.write(run, ps.cw1[first:last], counts, st["inch"], st["out_motion"], eol)
        for text in texts:
            write(text)
        st["out_motion"] = run.motion
        residual = ps.residual[first:last]
        report.pieces += last - first
        report.max_residual_um = max(report.max_residual_um, float(residual.max()) * 1e6)
        limited = result.limited[k:k + run.count]
        if limited.any() or self.detail:
            worst = np.maximum.reduceat(residual, b[:-1] - first).tolist()
            for i in np.flatnonzero(limited).tolist():
                self._note_limited(run.first + i, worst[i])
            if self.detail:
                report.detail.extend(np.arange(run.first, run.first + run.count), counts,
                                     result.before[k:k + run.count] * 1e6, np.array(worst) * 1e6)
        return len(texts)

    def _write_run_lines(self, run: PlainRun, results, k: int, st: dict, eol: str, write) -> int:
        """Write the lines of a run one by one, as the line-by-line reader would."""
        written = 0
        for i in range(run.count):
            mv, block = self._run_move(run, i)
            lines = self._write_move(block, run.newlines[i], eol, mv, results, k + i, st)
            for line in lines:
                write(line)
            written += len(lines)
        return written

    def _note_limited(self, line: int, residual: float) -> None:
        report = self.report
        what = (f"{report.tolerance_um:g} um / {self.tol_urad:g} urad" if self.comp.orientation
                else f"{report.tolerance_um:g} um")
        self.reader.notes.add(line, f"the residual stays at up to {{worst:.2f}} um (tolerance {what}); no command "
                              "reaches the desired pose there (singular pose of the rotary axes, or an error the "
                              "axes cannot undo)", worst=residual * 1e6)

    def _write_move(self, block: Block, newline: str, eol: str, mv: _Move, results, k: int, st: dict) -> list[str]:
        result, bounds, (arc, sweep, residual, k0, k1, limited), errors = results
        ps = result.pieces
        rows = range(bounds[k], bounds[k + 1])
        pieces = [Piece("arc" if arc[i] else "line", ps.cw0[i], ps.cw1[i], ps.center[i] if arc[i] else None,
                        sweep[i] < 0, sweep[i], residual[i], k0[i], k1[i], bool(limited[i])) for i in rows]
        lines, written = self.writer.write_move(block, newline, eol, mv.motion, mv.coord_words, pieces, st,
                                                errors=None if errors is None else errors[bounds[k]:bounds[k + 1]])
        report = self.report
        report.pieces += len(written)
        residual = max(p.residual for p in written)
        report.max_residual_um = max(report.max_residual_um, residual * 1e6)
        if mv.kind == ARC:
            if all(p.kind == "arc" for p in written):
                report.arcs_kept += 1
            else:
                report.arcs_as_lines += 1
        if result.limited[k]:
            self._note_limited(mv.line, residual)
        if self.detail:
            report.detail.extend([mv.line], [len(written)], [result.before[k] * 1e6], [residual * 1e6])
        return lines


def _check_travel(program: "ChunkWriting", line: np.ndarray, batch: MoveBatch, mode) -> None:
    """Desired moves must stay within the travel: arcs between their ends, and in tool-tip
    programming the axis positions the tool tips need (``line``: each move's line)."""
    reader, machine = program.reader, program.reader.machine
    travel = machine.travel
    arcs = np.flatnonzero(batch.kind == ARC)
    if mode.identity:
        if len(arcs):
            low, high = _arc_bounds(batch, arcs)
            span = np.maximum(travel[:, 1] - travel[:, 0], 1.0)
            over = np.maximum(travel[:, 0] - low, high - travel[:, 1])
            bad = np.flatnonzero((over > 1e-9 * span).any(axis=1))
            if len(bad):
                i = bad[0]
                raise GcodeError(f"{reader.source}:{line[arcs[i]]}: the arc leaves the travel "
                                 f"({_amounts(reader, over[i], 1e-9 * span)})")
        return
    # tool-tip programming: the axis positions of every target, and along every arc
    q = mode.to_axes(batch.w1)
    outside = machine.outside_travel(q).any(axis=1)
    if outside.any():
        i = int(np.flatnonzero(outside)[0])
        mv = program.move_at(i)
        reader.travel_error(_block_of(mv), mv.coord_words, q[i])
    if len(arcs):
        k = np.linspace(0.0, 1.0, 33)
        rows = np.repeat(arcs, len(k))
        qa = mode.to_axes(batch.desired(rows, np.tile(k, len(arcs))))
        out = machine.outside_travel(qa).reshape(len(arcs), len(k), -1).any(axis=(1, 2))
        if out.any():
            i = int(np.flatnonzero(out)[0])
            over = np.maximum(travel[:, 0] - qa.reshape(len(arcs), len(k), -1)[i].min(axis=0),
                              qa.reshape(len(arcs), len(k), -1)[i].max(axis=0) - travel[:, 1])
            raise GcodeError(f"{reader.source}:{line[arcs[i]]}: the arc leaves the travel "
                             f"({_amounts(reader, over, np.zeros(len(over)))})")

def _commands_outside(reader: Interpreter, line: np.ndarray, result, mode) -> None:
    """Warn where compensated commands leave the travel (by micrometres, at a travel's end;
    ``line``: each move's line)."""
    machine = reader.machine
    ps = result.pieces
    q = mode.to_axes(ps.cw1)
    travel = machine.travel
    over = np.maximum(travel[:, 0] - q, q - travel[:, 1])
    bad = np.flatnonzero((over > 0).any(axis=1))
    for i in bad:
        for j in np.flatnonzero(over[i] > 0):
            axis = reader.axes[j]
            unit = "um" if reader.linear[j] else "urad"
            reader.notes.add(int(line[ps.move[i]]), f"the compensated command leaves the travel of axis {axis} "
                             f"(by up to {{worst:.2f}} {unit}); check the machine's soft limits",
                             worst=float(over[i, j]) * 1e6)


def _arc_bounds(batch: MoveBatch, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest coordinates of arcs: the exact extent in their plane, their ends
    in the other coordinates (which move linearly)."""
    w0, w1 = batch.w0[rows], batch.w1[rows]
    low, high = np.minimum(w0, w1), np.maximum(w0, w1)
    radius = np.maximum(batch.r0[rows], batch.r1[rows])
    lo2, hi2 = arc_extent(batch.center[rows], radius, batch.a0[rows], batch.sweep[rows])
    idx = np.arange(len(rows))
    for c in range(2):
        plane = batch.plane[rows, c]
        low[idx, plane] = lo2[:, c]
        high[idx, plane] = hi2[:, c]
    return low, high


def _amounts(reader: Interpreter, over: np.ndarray, slack: np.ndarray) -> str:
    parts = []
    for j, axis in enumerate(reader.axes):
        if over[j] > slack[j]:
            unit = "um" if reader.linear[j] else "urad"
            parts.append(f"{axis} by {over[j] * 1e6:.2f} {unit}")
    return ", ".join(parts)


def _block_of(mv: _Move) -> Block:
    return Block(mv.line, "", list(mv.coord_words), "")
