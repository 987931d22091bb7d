"""Path compensation (seed 002): moves split until the compensated path is within the tolerance.

Rapid moves compensate their end point. Straight moves compensate both ends, and are split at
the point of largest residual until every point is within the tolerance (the residual of the
actual tool at the commanded path against the nominal tool at the desired path, at the same
fraction of the move: the controller interpolates in program coordinates). Helical and circular
moves compensate start, middle and end, and each piece is the helix through its three
compensated points (eqs. 25-29), split likewise.

:meth:`PathCompensator.compensate` does this for a whole batch of moves with a few calls of the
model per round (:mod:`._lines` for straight moves, :mod:`._splitter` for arcs); how densely each
piece is sampled, and how much it is trusted between samples, follows from bounds measured on
the machine (:mod:`._smoothness`). ``line``, ``arc`` and ``rapid`` compensate one move.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base import InputError, integer as _integer, positive as _positive, require_memory
from ..model import Machine, check_q
from ._arcs import Arc
from ._context import Context
from ._lines import plan_lines
from ._moves import ARC, LINE, POINT, MoveBatch, PieceSet
from ._points import has_rotary
from ._modes import programming_for
from ._programming import Programming
from ._smoothness import Smoothness
from ._solver import PointSolver, PoseMetric
from ._splitter import arc_pieces, split_pieces

__all__ = ["MAX_DEPTH", "BatchResult", "PathCompensation", "PathCompensator", "Piece"]

#: deepest split of a move: 2^-60 of it is below double precision
MAX_DEPTH = 60
#: most grid points of straight moves sampled at once (memory: about 1 kB each)
GRID_BUDGET = 200_000


@dataclass
class Piece:
    """One commanded piece of a compensated move (SI, axis positions in axis programming).

    Attributes
    ----------
    kind : str
        "line" or "arc".
    start : ndarray, shape (n_axes,)
        Compensated command at the start [m, rad].
    end : ndarray, shape (n_axes,)
        Compensated command at the end [m, rad].
    center : ndarray, shape (2,), optional
        Arc centre in the plane, compensated [m]; None for a line.
    clockwise : bool
        Arc sense.
    turns : float
        Signed swept angle [rad].
    residual : float
        Bound of the residual along the piece [m].
    k0, k1 : float
        Parameter range on the original move (0 to 1).
    limited : bool
        The tolerance cannot be reached here by any command.
    """

    kind: str
    start: np.ndarray
    end: np.ndarray
    center: np.ndarray | None = None
    clockwise: bool = False
    turns: float = 0.0
    residual: float = 0.0
    k0: float = 0.0
    k1: float = 1.0
    limited: bool = False


@dataclass
class PathCompensation:
    """The compensated pieces of one programmed move.

    Attributes
    ----------
    pieces : list of Piece
        The commanded pieces, in order.
    max_residual : float
        Bound of the residual along the compensated pieces [m].
    max_before : float
        Largest residual along the uncompensated move (sampled) [m].
    samples : int
        Most samples per piece and round.
    """

    pieces: list[Piece]
    max_residual: float
    max_before: float
    samples: int

    @property
    def limited(self) -> bool:
        """True if any piece could not reach the tolerance (bool)."""
        return any(p.limited for p in self.pieces)


@dataclass
class BatchResult:
    """What :meth:`PathCompensator.compensate` gives for a batch of moves.

    Attributes
    ----------
    pieces : PieceSet
        Every piece, ordered by move and along it (program coordinates).
    end : ndarray, shape (M, n_axes)
        Compensated command at each move's end (program coordinates) [m, rad].
    end_residual : ndarray, shape (M,)
        Residual there [m].
    before : ndarray, shape (M,)
        Per move: largest uncompensated residual (sampled) [m].
    residual : ndarray, shape (M,)
        Per move: bound of the residual along its pieces [m].
    limited : ndarray of bool, shape (M,)
        Per move: some piece cannot reach the tolerance.
    """

    pieces: PieceSet
    end: np.ndarray
    end_residual: np.ndarray
    before: np.ndarray
    residual: np.ndarray
    limited: np.ndarray


class PathCompensator:
    """Splits moves until the compensated path is within the tolerance everywhere (seed 002).

    A machine with time-, temperature- or load-dependent terms is compensated in one
    state: ``PathCompensator(machine.with_state(t=3600, temperatures={"spindle": 24}))``.

    Parameters
    ----------
    machine : Machine
        The machine.
    tol_um : float, default 1.0
        Position tolerance of the path [um].
    samples : int, default 48
        Most samples of one piece per round of splitting (how many a piece gets follows from
        the machine's bounds, :mod:`~volerr_pin.compensation`).
    max_depth : int, default 14
        Deepest split of a move.
    method : "newton" or "recursive", default "newton"
        Point compensation method (see :func:`compensate_points`).
    tol_urad : float, optional
        Tool-axis tolerance [urad] on machines with rotary axes (default 10 urad per um of
        ``tol_um``): the tool-axis angle counts as ``lever`` x angle against the position
        tolerance, ``lever = tol_um / tol_urad`` [m per rad].

    Attributes
    ----------
    machine : Machine
        The machine.
    tol : float
        Position tolerance [m].
    samples, max_depth, method
        As given.
    orientation : bool
        Whether the tool axis is corrected (the machine has rotary axes).
    tol_urad : float
        Tool-axis tolerance [urad].
    lever : float
        Weight of the tool-axis angle [m per rad].

    Raises
    ------
    InputError
        If ``tol_um`` or ``tol_urad`` is not a positive finite number, ``samples`` is not a
        whole number >= 1 or too many for the free memory, ``max_depth`` not one from 0 to
        :data:`MAX_DEPTH`, or ``method`` is unknown.
    """

    def __init__(self, machine: Machine, tol_um: float = 1.0, samples: int = 48, max_depth: int = 14,
                 method: str = "newton", tol_urad: float | None = None):
        tol_um = _positive("tol_um", tol_um)
        if tol_urad is not None:
            tol_urad = _positive("tol_urad", tol_urad)
        if method not in ("newton", "recursive"):
            raise InputError(f"method must be 'newton' or 'recursive', got {method!r}", parameters=("method",))
        self.machine = machine
        self.tol = tol_um * 1e-6
        self.samples = _integer("samples", samples, 1)
        # the sampled commands, desired points and their poses along one piece
        require_memory(self.samples * (8 * 6 * len(machine.axes) + 600), f"{self.samples:,} samples along a move",
                       ("samples",))
        self.max_depth = _integer("max_depth", max_depth, 0)
        if self.max_depth > MAX_DEPTH:
            raise InputError(f"max_depth must be at most {MAX_DEPTH} (a piece of 2^-{MAX_DEPTH} of a move is below "
                             f"double precision), got {self.max_depth}", parameters=("max_depth",))
        self.method = method
        self.orientation = has_rotary(machine)
        self.tol_urad = 10.0 * tol_um if tol_urad is None else tol_urad
        self.lever = tol_um / self.tol_urad
        self.metric = PoseMetric(machine, self.lever, self.orientation and method != "recursive")
        # point tolerances: a twentieth of the path's (at most 0.01 um and 0.1 urad)
        self.solver = PointSolver(self.metric, method, tol=min(0.01e-6, self.tol / 20),
                                  tol_axis=min(0.1e-6, self.tol_urad * 1e-6 / 20))
        self._contexts: dict[str, Context] = {}

    def context(self, programming: str | Programming = "axes") -> Context:
        """The tools of path compensation in a programming mode (its bounds measured on first use).

        Parameters
        ----------
        programming : str or Programming, default "axes"
            The mode, or its name.

        Returns
        -------
        Context
            Metric, solver, mode, bounds, tolerances.
        """
        prog = programming_for(programming, self.machine) if isinstance(programming, str) else programming
        ctx = self._contexts.get(prog.name)
        if ctx is None:
            smooth = Smoothness(self.metric, prog, self.method)
            ctx = Context(self.metric, self.solver, prog, smooth, self.tol, self.samples, self.max_depth)
            self._contexts[prog.name] = ctx
        return ctx

    # points ---------------------------------------------------------------------------
    def points(self, q_d: np.ndarray) -> np.ndarray:
        """Compensated commands for many desired positions at once.

        Point tolerances are a twentieth of the path's (at most 0.01 um and 0.1 urad).

        Parameters
        ----------
        q_d : ndarray, shape (N, n_axes)
            Desired NC positions [m, rad].

        Returns
        -------
        ndarray, shape (N, n_axes)
            Compensated commands [m, rad].

        Raises
        ------
        InputError
            If ``q_d`` is not (N, n_axes) finite positions.
        """
        return self.solver.solve(self._checked(np.atleast_2d(np.asarray(q_d, dtype=float)))).c

    def point(self, q_d: np.ndarray) -> np.ndarray:
        """Compensated command for one desired position (see :meth:`points`).

        Parameters
        ----------
        q_d : ndarray, shape (n_axes,)
            Desired NC position [m, rad].

        Returns
        -------
        ndarray, shape (n_axes,)
            Compensated command [m, rad].

        Raises
        ------
        InputError
            If ``q_d`` is not n_axes finite positions.
        """
        return self.points(np.asarray(q_d, dtype=float)[None, :])[0]

    # batches --------------------------------------------------------------------------
    def compensate(self, batch: MoveBatch, start: np.ndarray | None = None, start_residual: float = 0.0,
                   programming: str | Programming = "axes", end: np.ndarray | None = None) -> BatchResult:
        """Compensate a batch of consecutive moves.

        The batch is the library's own (the NC reader checks the program's words as it reads
        them): its positions and the commands given are evaluated as they are, outside the
        travel too.

        Parameters
        ----------
        batch : MoveBatch
            The desired moves (program coordinates of ``programming``).
        start : ndarray, shape (n_axes,), optional
            Compensated command (program coordinates) where the first move starts, when it
            continues a path compensated before; else its desired start is compensated.
        start_residual : float, default 0
            Residual at ``start`` [m].
        programming : str or Programming, default "axes"
            How program coordinates map to axis positions.
        end : ndarray, shape (M, n_axes), optional
            Compensated commands at the moves' ends, when known already.

        Returns
        -------
        BatchResult
            The pieces and per-move results.
        """
        ctx = self.context(programming)
        prog = ctx.programming
        m = len(batch)
        if end is None:
            solved = self.solver.solve(prog.to_axes(batch.w1))
            cw_end, r_end, before = prog.to_words(solved.c), solved.residual, solved.before.copy()
        else:
            cw_end = np.asarray(end, dtype=float)
            a_d, p_d = ctx.poses(batch.w1, nominal=True)
            r_end = self.metric.residual(*ctx.poses(cw_end), a_d, p_d)
            before = self.metric.residual(*ctx.poses(batch.w1), a_d, p_d)
        cw_start = np.empty_like(cw_end)
        r_start = np.empty(m)
        cw_start[1:], r_start[1:] = cw_end[:-1], r_end[:-1]
        if start is not None:
            cw_start[0], r_start[0] = start, start_residual
        elif m and batch.kind[0] != POINT:
            first = self.solver.solve(prog.to_axes(batch.w0[:1]))
            cw_start[0], r_start[0] = prog.to_words(first.c)[0], first.residual[0]
            before[0] = max(before[0], first.before[0])
        elif m:
            cw_start[0], r_start[0] = batch.w0[0], 0.0
        parts = []
        point = np.flatnonzero(batch.kind == POINT)
        if len(point):
            z = np.zeros(len(point))
            parts.append(PieceSet(point, z, z + 1.0, np.zeros(len(point), dtype=bool), cw_start[point], cw_end[point],
                                  np.zeros((len(point), 2)), z.copy(), r_end[point], r_end[point] > self.tol))
        lines = np.flatnonzero(batch.kind == LINE)
        for group in _groups(lines, ctx, batch, cw_start, cw_end):
            res = plan_lines(ctx, batch.w0[group], batch.w1[group], cw_start[group], cw_end[group], r_start[group],
                             r_end[group], group)
            parts.append(res.pieces)
            before[group] = np.maximum(before[group], res.before)
            if res.retry:
                parts.append(split_pieces(ctx, batch, res.retry))
        arcs = np.flatnonzero(batch.kind == ARC)
        if len(arcs):
            pieces, arc_before = arc_pieces(ctx, batch, arcs, cw_start[arcs], cw_end[arcs], r_start[arcs], r_end[arcs])
            parts.append(pieces)
            before[arcs] = np.maximum(before[arcs], arc_before)
        pieces = PieceSet.concat(parts, before)
        residual = np.zeros(m)
        limited = np.zeros(m, dtype=bool)
        np.maximum.at(residual, pieces.move, pieces.residual)
        np.logical_or.at(limited, pieces.move, pieces.limited)
        return BatchResult(pieces, cw_end, r_end, before, residual, limited)

    # one move -------------------------------------------------------------------------
    def _checked(self, q: np.ndarray) -> np.ndarray:
        """Positions a caller gives, checked once as the machine's evaluations check them (finite,
        (N, n_axes); outside the travel allowed): the solver and the splitting trust them."""
        return check_q(self.metric.inputs.model, q, extrapolate=True)

    def _one(self, batch: MoveBatch, start_c, end_c) -> PathCompensation:
        self._checked(batch.w0)
        self._checked(batch.w1)
        end = None if end_c is None else self._checked(np.asarray(end_c, dtype=float)[None, :])
        start = None if start_c is None else self._checked(np.asarray(start_c, dtype=float)[None, :])[0]
        r0 = 0.0
        if start is not None:
            ctx = self.context()
            a_d, p_d = ctx.poses(batch.w0, nominal=True)
            r0 = float(self.metric.residual(*ctx.poses(start[None, :]), a_d, p_d)[0])
        out = self.compensate(batch, start=start, start_residual=r0, end=end)
        ps = out.pieces
        pieces = [Piece("arc" if ps.arc[i] else "line", ps.cw0[i], ps.cw1[i],
                        ps.center[i].copy() if ps.arc[i] else None, bool(ps.sweep[i] < 0), float(ps.sweep[i]),
                        float(ps.residual[i]), float(ps.k0[i]), float(ps.k1[i]), bool(ps.limited[i]))
                  for i in range(len(ps))]
        return PathCompensation(pieces, float(out.residual[0]), float(out.before[0]), self.samples)

    def rapid(self, q_start: np.ndarray, q_end: np.ndarray, end_c: np.ndarray | None = None,
              start_c: np.ndarray | None = None) -> PathCompensation:
        """Compensate a rapid move: its end point only.

        Parameters
        ----------
        q_start : ndarray, shape (n_axes,)
            Desired start [m, rad].
        q_end : ndarray, shape (n_axes,)
            Desired end [m, rad].
        end_c : ndarray, shape (n_axes,), optional
            Compensated end, when known already (default: compensated here).
        start_c : ndarray, shape (n_axes,), optional
            Commanded start (default: ``q_start`` as it is).

        Returns
        -------
        PathCompensation
            One line piece; residual and ``before`` are those at the end point [m].

        Raises
        ------
        InputError
            If a position given is not n_axes finite values.
        """
        batch = _single(POINT, q_start, q_end)
        return self._one(batch, q_start if start_c is None else start_c, end_c)

    def line(self, q_start: np.ndarray, q_end: np.ndarray, start_c: np.ndarray | None = None,
             end_c: np.ndarray | None = None) -> PathCompensation:
        """Compensate a straight move, splitting it until it is within the tolerance.

        Parameters
        ----------
        q_start : ndarray, shape (n_axes,)
            Desired start [m, rad].
        q_end : ndarray, shape (n_axes,)
            Desired end [m, rad].
        start_c : ndarray, shape (n_axes,), optional
            Compensated start, when known already (default: compensated here).
        end_c : ndarray, shape (n_axes,), optional
            Compensated end, when known already (default: compensated here).

        Returns
        -------
        PathCompensation
            The line pieces.

        Raises
        ------
        InputError
            If a position given is not n_axes finite values.
        """
        return self._one(_single(LINE, q_start, q_end), start_c, end_c)

    def arc(self, arc: Arc, start_c: np.ndarray | None = None, end_c: np.ndarray | None = None) -> PathCompensation:
        """Compensate a helical (or circular) move, splitting it until it is within the tolerance.

        Arcs of more than a quarter turn (full circles included) start as quarters; each piece is
        the helical arc through its compensated start, middle and end.

        Parameters
        ----------
        arc : Arc
            The desired arc.
        start_c : ndarray, shape (n_axes,), optional
            Compensated start, when known already (default: compensated here).
        end_c : ndarray, shape (n_axes,), optional
            Compensated end, when known already (default: compensated here).

        Returns
        -------
        PathCompensation
            The arc (or, where degenerate, line) pieces.

        Raises
        ------
        InputError
            If a position given is not n_axes finite values.
        """
        batch = _single(ARC, arc.start, arc.end)
        batch.plane[0] = arc.plane
        batch.center[0] = arc.center
        batch.r0[0] = arc.radius
        batch.r1[0] = arc.radius if arc.end_radius is None else arc.end_radius
        batch.a0[0], batch.sweep[0] = arc.start_angle, arc.sweep
        return self._one(batch, start_c, end_c)


def _single(kind: int, start, end) -> MoveBatch:
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    batch = MoveBatch.empty(1, len(start))
    batch.kind[0] = kind
    batch.w0[0], batch.w1[0] = start, end
    return batch


def _groups(rows: np.ndarray, ctx: Context, batch: MoveBatch, cw0: np.ndarray, cw1: np.ndarray
            ) -> list[np.ndarray]:
    """Straight moves in groups whose grids together stay within :data:`GRID_BUDGET` points."""
    if not len(rows):
        return []
    smooth = ctx.smooth
    length = smooth.lengths(batch.w1[rows] - batch.w0[rows])
    d0, d1 = cw0[rows] - batch.w0[rows], cw1[rows] - batch.w1[rows]
    reach = np.maximum(smooth.lengths(d0), smooth.lengths(d1))
    grid = ctx.samples_for(smooth.bend(length, reach, smooth.lengths(d1 - d0)), most=GRID_BUDGET) + 2
    total = np.cumsum(grid)
    cut = np.searchsorted(total, np.arange(1, math.ceil(total[-1] / GRID_BUDGET) + 1) * GRID_BUDGET, side="right")
    edges = np.unique(np.concatenate([[0], np.clip(cut, 1, len(rows)), [len(rows)]]))
    return [rows[a:b] for a, b in zip(edges[:-1], edges[1:]) if b > a]
