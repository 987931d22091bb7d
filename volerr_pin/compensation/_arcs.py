"""Arcs and helices: the desired arc of a program block, and circles through compensated points.

An arc moves two coordinates of a plane (i, j) around a centre and every other coordinate
linearly with the same parameter (a helix in the third axis of the plane; rotary axes in a
5-axis program). Everything here works on many arcs at once (one row per arc) as well as on
one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._points import COMPENSATION_BYTES
from ..base import InputError, integer as _integer, require_memory

#: memory of a quarter turn of a compensated arc: its points, samples and pieces [bytes]
ARC_QUARTER_BYTES = 8 * COMPENSATION_BYTES
#: arcs of fewer whole turns than this need no check of the free memory (under 100 MB)
FEW_TURNS = 1000
#: an arc's end may lie this far off its start's circle [m] (about what controllers accept)
RADIUS_SLACK = 2e-6


@dataclass(frozen=True)
class Arc:
    """A desired helical move in a plane; angles in radians.

    Attributes
    ----------
    plane : tuple of int (i, j, k)
        Indices of the coordinates of the arc plane and of the linear third axis (-1 when the
        machine has none: a 2-axis lathe's arcs in Z and X).
    center : ndarray, shape (2,)
        Centre in the plane [m].
    radius : float
        Radius at the start [m].
    start_angle : float
        Angle of the start point about the centre [rad].
    sweep : float
        Signed swept angle [rad]: > 0 counter-clockwise.
    start : ndarray, shape (n_axes,)
        Full desired start [m, rad].
    end : ndarray, shape (n_axes,)
        Full desired end [m, rad].
    end_radius : float, optional
        Radius at the end [m], when the end lies slightly off the start's circle.
    """

    plane: tuple[int, int, int]
    center: np.ndarray
    radius: float
    start_angle: float
    sweep: float
    start: np.ndarray
    end: np.ndarray
    end_radius: float | None = None

    def point(self, k: np.ndarray) -> np.ndarray:
        """Points at fractions ``k`` of the move.

        A small mismatch of start and end radius (as programs written to 4 decimals have) is
        spread linearly over the sweep, as controllers do, so that the arc ends exactly at the
        programmed end point. Coordinates other than the plane's move linearly
        (:func:`arc_points`, for one arc).

        Parameters
        ----------
        k : float or ndarray, shape (M,)
            Fractions of the move, 0 (start) to 1 (end).

        Returns
        -------
        ndarray, shape (M, n_axes)
            Positions [m, rad].
        """
        k = np.atleast_1d(np.asarray(k, dtype=float))
        m = len(k)

        def rows(value):
            return np.broadcast_to(np.asarray(value), (m,) + np.shape(value))

        end_radius = self.radius if self.end_radius is None else self.end_radius
        return arc_points(rows(self.start), rows(self.end), rows(self.plane[:2]), rows(self.center),
                          np.full(m, self.radius), np.full(m, end_radius), np.full(m, self.start_angle),
                          np.full(m, self.sweep), k)


def arc_from_center(start: np.ndarray, end: np.ndarray, center: np.ndarray, plane: tuple[int, int, int],
                    clockwise: bool, full_turns: int = 0, radius_slack: float = RADIUS_SLACK) -> Arc:
    """The desired arc from ``start`` to ``end`` about ``center`` (in the plane).

    Parameters
    ----------
    start : ndarray, shape (n_axes,)
        Desired start [m, rad].
    end : ndarray, shape (n_axes,)
        Desired end [m, rad].
    center : ndarray, shape (2,)
        Centre in the plane [m].
    plane : tuple of int (i, j, k)
        Indices of the plane's axes and of the third (helical) axis (-1: none).
    clockwise : bool
        Sense of the move (G2 is clockwise).
    full_turns : int, default 0
        Additional full turns.
    radius_slack : float, default RADIUS_SLACK
        How far the start and end radii may differ [m] (an NC program's rounding may ask for
        more: :func:`~volerr_pin.compensation.gcode._arcs.read_arc`).

    Returns
    -------
    Arc
        The arc; a start and end on one point make a full circle.

    Raises
    ------
    InputError
        If a position or the centre is not finite, ``full_turns`` is not a whole number >= 0
        or more turns than the free memory can compensate, the radius is zero, or the start
        and end radii differ by more than ``radius_slack``.
    """
    full_turns = _integer("full_turns", full_turns, 0)
    # an arc is compensated in quarter turns, each a few compensated points and pieces (asked only
    # for many turns: reading the free memory costs more than a small arc's compensation)
    if full_turns >= FEW_TURNS:
        require_memory(4 * (full_turns + 1) * ARC_QUARTER_BYTES, f"an arc of {full_turns + 1:,} turns",
                       ("full_turns",))
    start, end, center = (np.asarray(v, dtype=float) for v in (start, end, center))
    # plain floats: this runs for every arc block read
    s, e, c = start.tolist(), end.tolist(), center.tolist()
    for name, value in (("start", s), ("end", e), ("center", c)):
        if not all(map(math.isfinite, value)):
            raise InputError(f"{name} of the arc is not finite: {value}", parameters=(name,))
    i, j, _ = plane
    a0 = math.atan2(s[j] - c[1], s[i] - c[0])
    a1 = math.atan2(e[j] - c[1], e[i] - c[0])
    sweep = sweep_of(a0, a1, clockwise)
    sweep += (-1 if clockwise else 1) * 2 * math.pi * full_turns
    r0 = math.hypot(s[i] - c[0], s[j] - c[1])
    r1 = math.hypot(e[i] - c[0], e[j] - c[1])
    if r0 == 0.0:
        raise InputError("the arc starts at its centre: a radius of zero")
    if abs(r0 - r1) > radius_slack:
        raise InputError(f"arc start radius {r0 * 1e3:.4f} mm and end radius {r1 * 1e3:.4f} mm differ "
                         f"by {abs(r0 - r1) * 1e6:.1f} um, more than the {radius_slack * 1e6:.2f} um allowed (at least 2 "
                         "um, or what rounding the numbers to their last digit may make)")
    return Arc(tuple(int(v) for v in plane), center.copy(), r0, a0, sweep, start.copy(), end.copy(), end_radius=r1)


def sweeps(a0: np.ndarray, a1: np.ndarray, ccw: np.ndarray) -> np.ndarray:
    """Signed angles from ``a0`` to ``a1`` turning counter-clockwise (> 0, at most a full turn)
    or clockwise (< 0); equal angles give a full turn.

    Parameters
    ----------
    a0, a1 : ndarray, shape (M,)
        Start and end angles [rad].
    ccw : ndarray of bool, shape (M,)
        Counter-clockwise (G3) rows.

    Returns
    -------
    ndarray, shape (M,)
        The swept angles [rad].
    """
    turn = 2 * math.pi
    up = np.mod(a1 - a0, turn)  # [0, 2 pi)
    down = np.mod(a0 - a1, turn)
    return np.where(ccw, np.where(up <= 0.0, turn, up), -np.where(down <= 0.0, turn, down))


def sweep_of(a0: float, a1: float, clockwise: bool) -> float:
    """:func:`sweeps` for one arc, on plain floats (it runs for every arc block read and every
    arc piece written).

    Parameters
    ----------
    a0, a1 : float
        Start and end angles [rad].
    clockwise : bool
        Clockwise (G2) rather than counter-clockwise (G3).

    Returns
    -------
    float
        The swept angle [rad] (< 0 clockwise; equal angles give a full turn).
    """
    turn = 2 * math.pi
    if clockwise:
        down = (a0 - a1) % turn
        return -(turn if down <= 0.0 else down)
    up = (a1 - a0) % turn
    return turn if up <= 0.0 else up


def circles_through(p1: np.ndarray, p2: np.ndarray, p3: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres and radii of the circles through three points of a plane, many at once.

    Parameters
    ----------
    p1, p2, p3 : ndarray, shape (M, 2)
        The points [m].

    Returns
    -------
    center : ndarray, shape (M, 2)
        Centres [m] (NaN where the points are collinear).
    radius : ndarray, shape (M,)
        Radii [m] (NaN where collinear).
    ok : ndarray of bool, shape (M,)
        The three points define a circle (they are not collinear to double precision).
    """
    # relative to p1, which keeps the arithmetic well conditioned far from the origin
    b = p2 - p1
    c = p3 - p1
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    scale = np.maximum(np.einsum("ij,ij->i", b, b), np.einsum("ij,ij->i", c, c))
    ok = np.abs(d) > 1e-12 * scale
    dd = np.where(ok, d, 1.0)
    bb, cc = np.einsum("ij,ij->i", b, b), np.einsum("ij,ij->i", c, c)
    ux = (c[:, 1] * bb - b[:, 1] * cc) / dd
    uy = (b[:, 0] * cc - c[:, 0] * bb) / dd
    center = p1 + np.column_stack([ux, uy])
    radius = np.hypot(ux, uy)
    center[~ok] = np.nan
    radius[~ok] = np.nan
    return center, radius, ok


def arc_points(start: np.ndarray, end: np.ndarray, plane: np.ndarray, center: np.ndarray, r0: np.ndarray,
               r1: np.ndarray, a0: np.ndarray, sweep: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Points of many helical arcs, one fraction per row.

    Parameters
    ----------
    start, end : ndarray, shape (M, n)
        Ends of each row's arc [m, rad].
    plane : ndarray of int, shape (M, 2)
        Indices of the two plane coordinates of each row.
    center : ndarray, shape (M, 2)
        Centres [m].
    r0, r1 : ndarray, shape (M,)
        Radius at the start and at the end (spread linearly over the sweep) [m].
    a0, sweep : ndarray, shape (M,)
        Start angle and signed sweep [rad].
    k : ndarray, shape (M,)
        Fraction of its arc for each row.

    Returns
    -------
    ndarray, shape (M, n)
        The points [m, rad].
    """
    out = start + k[:, None] * (end - start)
    ang = a0 + k * sweep
    r = r0 + k * (r1 - r0)
    rows = np.arange(len(k))
    out[rows, plane[:, 0]] = center[:, 0] + r * np.cos(ang)
    out[rows, plane[:, 1]] = center[:, 1] + r * np.sin(ang)
    return out


def arc_extent(center: np.ndarray, radius: np.ndarray, a0: np.ndarray, sweep: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the plane coordinates an arc passes through (exact: the ends
    and every quarter point of the circle inside the sweep).

    Parameters
    ----------
    center : ndarray, shape (M, 2)
        Centres [m].
    radius : ndarray, shape (M,)
        Radii [m] (the larger of start and end radius).
    a0, sweep : ndarray, shape (M,)
        Start angle and signed sweep [rad].

    Returns
    -------
    low, high : ndarray, shape (M, 2)
        Smallest and largest value of each plane coordinate along the arc [m].
    """
    a1 = a0 + sweep
    lo_a, hi_a = np.minimum(a0, a1), np.maximum(a0, a1)
    ends = np.stack([np.cos(a0), np.sin(a0), np.cos(a1), np.sin(a1)], axis=1)
    low = np.stack([np.minimum(ends[:, 0], ends[:, 2]), np.minimum(ends[:, 1], ends[:, 3])], axis=1)
    high = np.stack([np.maximum(ends[:, 0], ends[:, 2]), np.maximum(ends[:, 1], ends[:, 3])], axis=1)
    full = (hi_a - lo_a) >= 2 * math.pi - 1e-12
    for quarter, (axis, value) in enumerate(((0, 1.0), (1, 1.0), (0, -1.0), (1, -1.0))):
        angle = quarter * math.pi / 2
        # does an angle angle + 2 pi m lie in [lo_a, hi_a]?
        m = np.ceil((lo_a - angle) / (2 * math.pi))
        inside = full | (angle + 2 * math.pi * m <= hi_a)
        if value > 0:
            high[:, axis] = np.where(inside, 1.0, high[:, axis])
        else:
            low[:, axis] = np.where(inside, -1.0, low[:, axis])
    return center + radius[:, None] * low, center + radius[:, None] * high
