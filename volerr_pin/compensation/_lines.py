"""Straight moves: where to split them, from one sampling of the error along the desired path.

Seed 002 splits a straight move at the point of largest residual until every point is within
the tolerance. Done literally, every round evaluates the model along every new piece. Here the
error is evaluated once, on a grid along the desired path (spaced so that nothing larger than
:data:`~.context.EPS` of the tolerance hides between grid points, :mod:`._smoothness`), and the
residual of *any* piece between two grid points is predicted from it:

    g_j = E_j + J_j ((1 - s) d_a + s d_b)

where ``E_j`` is the uncompensated error at grid point ``j``, ``J_j`` its derivative with
respect to the program coordinates (nominal), ``d_a``, ``d_b`` the compensations (changes of
program coordinates) at the piece's ends and ``s`` the fraction of the piece. The splitting
runs on these predictions (all moves of a batch at once); then the chosen split points are
compensated exactly. Where the nominal machine is affine in program coordinates (a Cartesian
machine in axis programming) the prediction is exact but for the error's change over the few
micrometres of compensation, ``2 S |d|`` (slope ``S``), which is added to it; elsewhere every
final piece is evaluated exactly at its grid points, and pieces that fail are handed to the
round-by-round splitter (:mod:`._splitter`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._context import Context, segment_max
from ._moves import PieceSet
from ._points import solve_damped

__all__ = ["LinePieces", "plan_lines"]

#: most grid points of one move (a longer grid is a move that needs thousands of pieces anyway)
MOST_GRID = 100_000


@dataclass
class LinePieces:
    """The straight moves of a batch, compensated.

    Attributes
    ----------
    pieces : PieceSet
        Pieces within the tolerance, or limited (``move`` are batch rows).
    before : ndarray, shape (L,)
        Per move: largest uncompensated residual at the grid points [m].
    retry : dict of str to ndarray
        Pieces whose exact evaluation missed the tolerance, for :mod:`._splitter`: ``move``,
        ``k0``, ``k1``, ``cw0``, ``cw1``, ``r0``, ``r1`` (end residuals), ``depth``.
    """

    pieces: PieceSet
    before: np.ndarray
    retry: dict


def _measure(g: np.ndarray) -> np.ndarray:
    """The residual measure of difference vectors (position, and lever times tool axis)."""
    pos = np.sqrt(np.einsum("ij,ij->i", g[:, :3], g[:, :3]))
    if g.shape[1] > 3:
        pos = np.maximum(pos, np.sqrt(np.einsum("ij,ij->i", g[:, 3:], g[:, 3:])))
    return pos


class _Grid:
    """The error sampled along every move of a batch: flattened, move ``i`` at
    ``base[i]:base[i] + size[i]`` (its start and end included)."""

    def __init__(self, ctx: Context, w0: np.ndarray, w1: np.ndarray, n0: np.ndarray, cw0: np.ndarray,
                 cw1: np.ndarray):
        metric, prog, solver = ctx.metric, ctx.programming, ctx.solver
        self.size = n0 + 2
        self.base = np.concatenate([[0], np.cumsum(self.size)[:-1]])
        move = np.repeat(np.arange(len(n0)), self.size)
        j = np.arange(len(move)) - self.base[move]
        self.k = j / (n0[move] + 1.0)
        words = w0[move] + self.k[:, None] * (w1 - w0)[move]
        last = self.base + self.size - 1
        words[self.base], words[last] = w0, w1
        self.words = words
        self.q = prog.to_axes(words)
        self.a_d, self.p_d = metric.nominal(self.q)
        a, p = metric.actual(self.q)
        rows = 6 if metric.orientation else 3
        self.E = metric.difference(a, p, self.a_d, self.p_d)[:, :rows]
        self.before = metric.residual(a, p, self.a_d, self.p_d)
        self.affine = prog.identity and solver.constant is not None
        if self.affine:
            self.J = solver.constant_rows
            self.d = -(self.E @ solver.constant.T)
        else:
            J = metric.jacobian(self.q, nominal=True)
            self.J = prog.word_rows(solver.rows(J, self.a_d), J)
            self.d = -solve_damped(self.J, self.E, metric.scale, solver.damping)
        # the compensation at the ends is known exactly
        self.d[self.base], self.d[last] = cw0 - w0, cw1 - w1
        self.cw0, self.cw1 = cw0, cw1
        self.floor = _measure(self.E + self._apply(np.arange(len(move)), self.d))

    def _apply(self, index: np.ndarray, x: np.ndarray) -> np.ndarray:
        if self.affine:
            return x @ self.J.T
        return np.einsum("nij,nj->ni", self.J[index], x)

    def predict(self, index: np.ndarray, s: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Predicted residual vectors at grid points ``index`` of pieces from grid point ``a``
        to ``b`` at fractions ``s`` of them."""
        x = (1.0 - s)[:, None] * self.d[a] + s[:, None] * self.d[b]
        return self.E[index] + self._apply(index, x)


def plan_lines(ctx: Context, w0: np.ndarray, w1: np.ndarray, cw0: np.ndarray, cw1: np.ndarray, r0: np.ndarray,
               r1: np.ndarray, rows: np.ndarray) -> LinePieces:
    """Compensated pieces of straight moves whose ends are compensated.

    Parameters
    ----------
    ctx : Context
        Machine state, programming mode, tolerances.
    w0, w1 : ndarray, shape (L, n)
        Desired ends (program coordinates) [m, rad].
    cw0, cw1 : ndarray, shape (L, n)
        Compensated commands at the ends (program coordinates) [m, rad].
    r0, r1 : ndarray, shape (L,)
        Residuals at the compensated ends [m].
    rows : ndarray of int, shape (L,)
        The moves' rows in their batch (for :attr:`PieceSet.move`).

    Returns
    -------
    LinePieces
        The pieces, the uncompensated residual per move, the pieces to split further.
    """
    smooth = ctx.smooth
    tol = ctx.tol
    length = smooth.lengths(w1 - w0)
    reach = np.maximum(smooth.lengths(cw0 - w0), smooth.lengths(cw1 - w1))
    bend = smooth.bend(length, reach, smooth.lengths((cw1 - w1) - (cw0 - w0)))
    n0 = ctx.samples_for(bend, most=MOST_GRID)
    out_parts, retry = [], []
    before = np.zeros(len(w0))
    one = n0 == 0
    if one.any():  # the bound alone keeps the tolerance: one piece, nothing sampled
        res = np.maximum(r0[one], r1[one]) + bend[one] / 8
        out_parts.append(PieceSet(rows[one], np.zeros(one.sum()), np.ones(one.sum()), np.zeros(one.sum(), bool),
                                  cw0[one], cw1[one], np.zeros((one.sum(), 2)), np.zeros(one.sum()), res, res > tol))
    many = np.flatnonzero(~one)
    if len(many):
        grid = _Grid(ctx, w0[many], w1[many], n0[many], cw0[many], cw1[many])
        part, rest, worst_before = _split(ctx, grid, length[many] / (n0[many] + 1.0), r0[many], r1[many], rows[many])
        out_parts.append(part)
        before[many] = worst_before
        if rest is not None:
            retry.append(rest)
    pieces = PieceSet.concat(out_parts, np.zeros(0))
    merged = {key: np.concatenate([r[key] for r in retry]) for key in retry[0]} if retry else {}
    return LinePieces(pieces, before, merged)


def _bound(ctx: Context, grid: _Grid, spacing: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """What may hide between the grid points of pieces from grid point ``a`` to ``b``
    (:mod:`._smoothness`, with each piece's own compensations at its ends)."""
    smooth = ctx.smooth
    intervals = (b - a).astype(float)
    reach = np.maximum(smooth.lengths(grid.d[a]), smooth.lengths(grid.d[b]))
    bend = smooth.bend(spacing * intervals, reach, smooth.lengths(grid.d[b] - grid.d[a]))
    return bend / (8 * intervals**2)


def _interior(a: np.ndarray, b: np.ndarray, rows: np.ndarray):
    """Grid points strictly inside pieces ``rows``: piece of each, grid index, fraction of the
    piece, and where each piece's points start."""
    counts = b[rows] - a[rows] - 1
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    piece = np.repeat(rows, counts)
    j = a[piece] + 1 + (np.arange(counts.sum()) - np.repeat(starts, counts))
    return piece, j, (j - a[piece]) / (b - a)[piece], starts


def _split(ctx: Context, grid: _Grid, spacing: np.ndarray, r0: np.ndarray, r1: np.ndarray, rows: np.ndarray):
    """Split at the largest predicted residual, all moves at once; then compensate the split
    points and (where the prediction is linearised) check every piece exactly. Pieces the
    grid is too coarse for (the bound between two grid points alone misses the tolerance) go
    to the round-by-round splitter."""
    tol, slope = ctx.tol, ctx.smooth.slope
    last = grid.base + grid.size - 1
    worst_before = np.maximum.reduceat(grid.before, grid.base)
    # the residual at each grid point once compensated: exact at the ends, predicted inside
    point_res = grid.floor.copy()
    point_res[grid.base], point_res[last] = r0, r1
    move = np.arange(len(spacing))
    a, b, depth = grid.base.copy(), last.copy(), np.zeros(len(spacing), dtype=int)
    done_parts = []
    while len(move):
        worst = np.zeros(len(move))
        where = a.copy()
        hm = np.flatnonzero(b - a > 1)
        if len(hm):
            piece, j, frac, starts = _interior(a, b, hm)
            res = _measure(grid.predict(j, frac, a[piece], b[piece]))
            w, at = segment_max(res, starts)
            worst[hm], where[hm] = w, a[hm] + 1 + at
        if grid.affine:  # the error changes over the compensation itself
            reach = np.maximum(ctx.smooth.lengths(grid.d[a]), ctx.smooth.lengths(grid.d[b]))
            worst = worst + 2 * slope * reach
        est = np.maximum(worst, np.maximum(point_res[a], point_res[b])) + _bound(ctx, grid, spacing[move], a, b)
        split = (b - a > 1) & (est > tol) & (depth < ctx.max_depth) & (point_res[where] <= 0.9 * worst)
        keep = ~split
        done_parts.append((move[keep], a[keep], b[keep], depth[keep], est[keep]))
        sm = np.flatnonzero(split)
        move = np.concatenate([move[sm], move[sm]])
        a, b = np.concatenate([a[sm], where[sm]]), np.concatenate([where[sm], b[sm]])
        depth = np.concatenate([depth[sm], depth[sm]]) + 1
    move, a, b, depth, est = (np.concatenate(x) for x in zip(*done_parts))
    # compensate the split points exactly
    inner_points = np.setdiff1d(np.union1d(a, b), np.concatenate([grid.base, last]))
    cw = np.full_like(grid.words, np.nan)
    cw[grid.base], cw[last] = grid.cw0, grid.cw1
    if len(inner_points):
        solved = ctx.solver.solve(grid.q[inner_points], grid.a_d[inner_points], grid.p_d[inner_points])
        cw[inner_points] = ctx.programming.to_words(solved.c)
        grid.d[inner_points] = cw[inner_points] - grid.words[inner_points]
        point_res[inner_points] = solved.residual
    bound = _bound(ctx, grid, spacing[move], a, b)
    est = np.maximum(est, np.maximum(point_res[a], point_res[b]) + bound)
    if not grid.affine:
        est = _verify(ctx, grid, cw, point_res, a, b, bound)
    k = grid.k
    again = (est > tol) & (depth < ctx.max_depth) & (np.maximum(point_res[a], point_res[b]) <= 0.9 * est)
    retry = None
    if again.any():
        retry = {"move": rows[move[again]], "k0": k[a[again]], "k1": k[b[again]], "cw0": cw[a[again]],
                 "cw1": cw[b[again]], "r0": point_res[a[again]], "r1": point_res[b[again]], "depth": depth[again]}
        keep = ~again
        move, a, b, est = move[keep], a[keep], b[keep], est[keep]
    n = len(move)
    part = PieceSet(rows[move], k[a], k[b], np.zeros(n, dtype=bool), cw[a], cw[b], np.zeros((n, 2)), np.zeros(n),
                    est, est > tol)
    return part, retry, worst_before


def _verify(ctx: Context, grid: _Grid, cw: np.ndarray, point_res: np.ndarray, a: np.ndarray, b: np.ndarray,
            bound: np.ndarray) -> np.ndarray:
    """The exact residual of every piece at its grid points, plus the bound between them."""
    est = np.maximum(point_res[a], point_res[b]) + bound
    has = np.flatnonzero(b - a > 1)
    if len(has):
        piece, j, frac, starts = _interior(a, b, has)
        s = frac[:, None]
        words = (1 - s) * cw[a[piece]] + s * cw[b[piece]]
        res = ctx.metric.residual(*ctx.poses(words), grid.a_d[j], grid.p_d[j])
        est[has] = np.maximum(est[has], np.maximum.reduceat(res, starts) + bound[has])
    return est
