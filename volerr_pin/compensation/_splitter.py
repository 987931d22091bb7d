"""Round-by-round splitting of pieces at their largest residual (seed 002), all pieces at once.

Used for arcs and helices (eqs. 25-29: each piece is the helix through its compensated start,
middle and end, so its path is known only once its middle is compensated) and for the straight
pieces whose exact check failed (:mod:`._lines`). Every round samples every open piece (as many
samples as the bound of :mod:`._smoothness` asks, at most ``samples``), keeps the pieces whose
sampled maximum plus the bound between samples is within the tolerance, and splits the others
at their largest sample: the split point (and, for arcs, the two new middles) compensated in
one batch. A piece is kept as it is, reported as limited, when the split point itself cannot
be brought closer than 0.9 of the piece's residual (a singular pose: splitting would not help)
or the deepest split is reached. Every round also checks the bound: where the sampled residual
bends more than the bound assumed, the larger bend counts.
"""

from __future__ import annotations

import math

import numpy as np

from ._arcs import circles_through, sweeps
from ._context import Context, segment_max
from ._moves import MoveBatch, PieceSet

__all__ = ["arc_pieces", "split_pieces"]

#: most samples evaluated in one call (bounded memory)
SLICE = 65_536


def _fit(batch: MoveBatch, move: np.ndarray, cw0: np.ndarray, cwm: np.ndarray, cw1: np.ndarray, k0: np.ndarray,
         k1: np.ndarray):
    """Commanded circles of arc pieces through their compensated start, middle and end; ``ok``
    false where the points are collinear, the middle does not lie between the ends, or the
    sweep is far from the desired one (the piece becomes straight)."""
    plane = batch.plane[move, :2]
    rows = np.arange(len(move))
    pick = lambda w: np.column_stack([w[rows, plane[:, 0]], w[rows, plane[:, 1]]])
    p0, pm, p1 = pick(cw0), pick(cwm), pick(cw1)
    center, radius, ok = circles_through(p0, pm, p1)
    ccw = batch.sweep[move] > 0
    c = np.where(ok[:, None], center, 0.0)
    ang = lambda p: np.arctan2(p[:, 1] - c[:, 1], p[:, 0] - c[:, 0])
    a0, am, a1 = ang(p0), ang(pm), ang(p1)
    sweep = sweeps(a0, a1, ccw)
    mid = sweeps(a0, am, ccw)
    desired = batch.sweep[move] * (k1 - k0)
    ok &= (np.abs(mid) < np.abs(sweep)) & (np.abs(sweep - desired) < math.pi / 2)
    return center, np.where(ok, radius, 0.0), a0, np.where(ok, sweep, 0.0), ok, plane


def _commanded(u, cw0, cw1, arc, center, radius, a0, sweep, plane):
    out = cw0 + u[:, None] * (cw1 - cw0)
    if arc.any():
        rows = np.flatnonzero(arc)
        ang = a0[rows] + u[rows] * sweep[rows]
        out[rows, plane[rows, 0]] = center[rows, 0] + radius[rows] * np.cos(ang)
        out[rows, plane[rows, 1]] = center[rows, 1] + radius[rows] * np.sin(ang)
    return out


def _evaluate(ctx: Context, cmd: np.ndarray, des: np.ndarray, before: bool):
    """Residual (and its vector) of commanded against desired points, and optionally the
    uncompensated residual at the desired points, in slices of bounded memory."""
    metric = ctx.metric
    res, vec, unc = np.empty(len(cmd)), np.empty((len(cmd), 6)), np.zeros(len(cmd))
    for lo in range(0, len(cmd), SLICE):
        sl = slice(lo, lo + SLICE)
        q_d = ctx.programming.to_axes(des[sl])
        a_d, p_d = metric.nominal(q_d)
        a, p = ctx.poses(cmd[sl])
        res[sl] = metric.residual(a, p, a_d, p_d)
        vec[sl] = metric.difference(a, p, a_d, p_d)
        if before:
            unc[sl] = metric.residual(*metric.actual(q_d), a_d, p_d)
    return res, vec, unc


def arc_pieces(ctx: Context, batch: MoveBatch, rows: np.ndarray, cw0: np.ndarray, cw1: np.ndarray, r0: np.ndarray,
               r1: np.ndarray) -> tuple[PieceSet, np.ndarray]:
    """Compensated pieces of arc moves whose ends are compensated.

    Arcs of more than a quarter turn start as quarters (a circle through three compensated
    points is well-posed only when they are well apart).

    Parameters
    ----------
    ctx : Context
        Machine state, programming mode, tolerances.
    batch : MoveBatch
        The moves.
    rows : ndarray of int, shape (A,)
        Rows of the arc moves.
    cw0, cw1 : ndarray, shape (A, n)
        Compensated commands at their ends (program coordinates) [m, rad].
    r0, r1 : ndarray, shape (A,)
        Residuals there [m].

    Returns
    -------
    pieces : PieceSet
        The pieces (``move`` are batch rows).
    before : ndarray, shape (A,)
        Per move: largest uncompensated residual sampled [m].
    """
    quarters = np.maximum(1, np.ceil(np.abs(batch.sweep[rows]) / (math.pi / 2) - 1e-9)).astype(int)
    move = np.repeat(rows, quarters)
    which = np.repeat(np.arange(len(rows)), quarters)
    first = np.concatenate([[0], np.cumsum(quarters)[:-1]])
    index = np.arange(len(move)) - np.repeat(first, quarters)
    k0 = index / quarters[which]
    k1 = (index + 1) / quarters[which]
    # compensate the inner section ends and every middle in one batch
    inner = index > 0
    ks = np.concatenate([k0[inner], 0.5 * (k0 + k1)])
    mv = np.concatenate([move[inner], move])
    solved = ctx.solver.solve(ctx.programming.to_axes(batch.desired(mv, ks)))
    cw = ctx.programming.to_words(solved.c)
    n_inner = int(inner.sum())
    start_w = cw0[which].copy()
    start_r = r0[which].copy()
    start_w[inner], start_r[inner] = cw[:n_inner], solved.residual[:n_inner]
    last = np.append(first[1:] - 1, len(move) - 1)
    end_w = np.empty_like(start_w)
    end_r = np.empty(len(move))
    end_w[:-1], end_r[:-1] = start_w[1:], start_r[1:]
    end_w[last], end_r[last] = cw1, r1
    pieces = {"move": move, "k0": k0, "k1": k1, "arc": np.ones(len(move), dtype=bool), "cw0": start_w, "cw1": end_w,
              "cwm": cw[n_inner:], "r0": start_r, "r1": end_r, "rm": solved.residual[n_inner:],
              "depth": np.zeros(len(move), dtype=int)}
    before = np.zeros(batch.w0.shape[0])
    np.maximum.at(before, mv, solved.before)
    out = split_pieces(ctx, batch, pieces, before)
    return out, before[rows]


def split_pieces(ctx: Context, batch: MoveBatch, pieces: dict, before: np.ndarray | None = None) -> PieceSet:
    """Split pieces round by round until each is within the tolerance (or limited).

    Parameters
    ----------
    ctx : Context
        Machine state, programming mode, tolerances.
    batch : MoveBatch
        The moves the pieces belong to.
    pieces : dict of str to ndarray
        ``move``, ``k0``, ``k1``, ``cw0``, ``cw1`` (compensated ends, program coordinates),
        ``r0``, ``r1`` (their residuals), ``depth``; for arcs also ``arc`` (bool), ``cwm`` and
        ``rm`` (the compensated middle and its residual; any value for straight pieces).
    before : ndarray, shape (M,), optional
        Per batch row: the uncompensated residual, raised in place by the first round's samples.

    Returns
    -------
    PieceSet
        The pieces.
    """
    n = batch.w0.shape[1]
    P = len(pieces["move"])
    op = {"arc": np.zeros(P, dtype=bool), "cwm": np.zeros((P, n)), "rm": np.zeros(P), **pieces}
    smooth, tol = ctx.smooth, ctx.tol
    done = []
    first = True
    while len(op["move"]):
        move = op["move"]
        center, radius, a0, sweep, ok, plane = _fit(batch, move, op["cw0"], op["cwm"], op["cw1"], op["k0"], op["k1"])
        arc = op["arc"] & ok
        op["arc"] = arc
        other = smooth.lengths(op["cw1"] - op["cw0"])
        length = np.where(arc, np.hypot(radius * np.abs(sweep), other), other)
        d0, d1 = op["cw0"] - batch.desired(move, op["k0"]), op["cw1"] - batch.desired(move, op["k1"])
        reach = np.maximum(smooth.lengths(d0), smooth.lengths(d1))
        bend = smooth.bend(length, reach, smooth.lengths(d1 - d0), np.where(arc, radius, 0.0),
                           np.where(arc, sweep, 0.0))
        count = ctx.samples_for(bend)
        piece = np.repeat(np.arange(len(move)), count)
        starts = np.concatenate([[0], np.cumsum(count)[:-1]])
        j = np.arange(len(piece)) - np.repeat(starts, count) + 1
        u = j / (count[piece] + 1.0)
        cmd = _commanded(u, op["cw0"][piece], op["cw1"][piece], arc[piece], center[piece], radius[piece],
                         a0[piece], sweep[piece], plane[piece])
        k = op["k0"][piece] + u * (op["k1"] - op["k0"])[piece]
        des = batch.desired(move[piece], k)
        res, vec, unc = _evaluate(ctx, cmd, des, before is not None and first)
        if before is not None and first and len(piece):
            np.maximum.at(before, move[piece], unc)
        first = False
        worst = np.zeros(len(move))
        at = np.zeros(len(move))
        bent = np.zeros(len(move))
        has = count > 0
        if has.any():
            w, where = segment_max(res, starts[has])
            worst[has] = w
            at[has] = (where + 1) / (count[has] + 1.0)
            # the bend the samples show (second differences), against the bound assumed
            d2 = np.zeros(len(res))
            inside = (j > 1) & (j < count[piece])
            idx = np.flatnonzero(inside)
            d2[idx] = np.linalg.norm(vec[idx - 1] - 2 * vec[idx] + vec[idx + 1], axis=1)
            bent[has] = np.maximum.reduceat(d2, starts[has]) * (count[has] + 1.0) ** 2
        ends = np.maximum(np.maximum(op["r0"], op["r1"]), np.where(arc, op["rm"], 0.0))
        est = np.maximum(worst, ends) + np.maximum(bend, 2 * bent) / (8 * (count + 1.0) ** 2)
        want = (est > tol) & has & (op["depth"] < ctx.max_depth)
        ks = op["k0"] + at * (op["k1"] - op["k0"])
        # compensate the split points (and the new middles of arc pieces)
        sp = np.flatnonzero(want)
        ar = sp[arc[sp]]
        kk = np.concatenate([ks[sp], 0.5 * (op["k0"][ar] + ks[ar]), 0.5 * (ks[ar] + op["k1"][ar])])
        mm = np.concatenate([move[sp], move[ar], move[ar]])
        if len(kk):
            solved = ctx.solver.solve(ctx.programming.to_axes(batch.desired(mm, kk)))
            cw = ctx.programming.to_words(solved.c)
            floor = solved.residual[: len(sp)]
            useful = floor <= 0.9 * worst[sp]
        else:
            cw, solved, useful = np.zeros((0, n)), None, np.zeros(0, dtype=bool)
        split = np.zeros(len(move), dtype=bool)
        split[sp[useful]] = True
        keep = ~split
        done.append(PieceSet(move[keep], op["k0"][keep], op["k1"][keep], arc[keep], op["cw0"][keep],
                             op["cw1"][keep], np.where(arc[keep, None], center[keep], 0.0), sweep[keep], est[keep],
                             est[keep] > tol))
        if not split.any():
            break
        # children: [k0, k*] and [k*, k1]
        sel = sp[useful]
        i_sp = np.flatnonzero(useful)  # their places among the solved points
        cws, rs = cw[i_sp], solved.residual[i_sp]
        mid_a = np.zeros((len(sel), n))
        mid_b = np.zeros((len(sel), n))
        rm_a = np.zeros(len(sel))
        rm_b = np.zeros(len(sel))
        is_arc = arc[sel]
        if is_arc.any():
            i_ar = len(sp) + np.searchsorted(ar, sel[is_arc])
            mid_a[is_arc], rm_a[is_arc] = cw[i_ar], solved.residual[i_ar]
            mid_b[is_arc], rm_b[is_arc] = cw[i_ar + len(ar)], solved.residual[i_ar + len(ar)]
        cat = lambda x, y: np.concatenate([x, y])
        op = {"move": cat(move[sel], move[sel]), "k0": cat(op["k0"][sel], ks[sel]), "k1": cat(ks[sel], op["k1"][sel]),
              "arc": cat(is_arc, is_arc), "cw0": cat(op["cw0"][sel], cws), "cw1": cat(cws, op["cw1"][sel]),
              "cwm": cat(mid_a, mid_b), "r0": cat(op["r0"][sel], rs), "r1": cat(rs, op["r1"][sel]),
              "rm": cat(rm_a, rm_b), "depth": cat(op["depth"][sel], op["depth"][sel]) + 1}
    return PieceSet.concat(done, np.zeros(0))
