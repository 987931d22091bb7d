"""The part a program cuts: the tool's deviation from the programmed path, and the features a
CMM reports of it.

The path is read by the NC reader ``compensate`` uses (:func:`volerr_pin.compensation.gcode.interpret`:
every mode it follows, every refusal it makes) and sampled along each cutting move (lines and
arcs; rapids cut nothing). At each sample the model gives the tool point's error ``e`` (actual
minus nominal, in the workpiece frame). What the cut surface keeps is the part of ``e`` normal to
the path: the part along the path only shifts when the tool passes, so

    d = e - (e . t) t,

with ``t`` the unit tangent of the nominal tool path. Where the tool point does not move (a
rotary axis turning about it) there is no path direction, and the whole error is kept.

The samples are refined until the deviation, interpolated linearly between neighbours, is
within ``tolerance`` of the model at every midpoint (a stated sampling tolerance, checked, not
assumed).

Features (:func:`circle_features`): a full circle of the program (arcs of one centre and
radius in one plane, turning a whole turn) is measured as a CMM measures it: the deviated
points in the circle's plane, the least-squares circle through them, the circularity (ISO
12181-1's roundness deviation about the least-squares reference circle: largest minus smallest
distance from its centre), the diameter error (twice the fitted minus the nominal radius) and
the centre error (the distance of the fitted centre from the nominal one).

The path sets what the machine's state cannot: for a machine whose errors depend on the axes'
directions (backlash), each axis' direction at each sample is the sign of its commanded motion
into the sample, kept while the axis stands still, rapids included, as a controller takes it;
the state's ``directions`` only say how the axes arrived before the program.

Conventions: positions in m, deviations in um in the reports; programs in axes or tool-tip
programming, as ``compensate`` reads them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..base.errors import InputError
from ..base.units import UM_PER_M
from ..model import Machine
from .cone import ConeSection, find_cones, measure_cones
from ..base.chunks import CHUNK, in_chunks
from .cmm import RoundFeature, fit_circle, fit_line, measure_round

__all__ = ["PathDeviation", "Cut", "Features", "CircleFeature", "LineFeature", "PairFeature", "PartPrediction", "blocks_text", "deviation_along",
           "cut_of", "contour_plane", "fit_circle", "fit_line", "measure", "feature_ranking", "normal_part", "predict",
           "contouring_test_piece"]

#: the parameter step, as a fraction of a move, of the nominal tangent's finite difference
TANGENT_STEP = 1e-6


def normal_part(error: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """The part of ``error`` (N, 3) normal to the unit ``tangent`` (N, 3); where the tangent is
    zero (no path direction), the whole error."""
    along = np.sum(error * tangent, axis=1)
    return error - along[:, None] * tangent


@dataclass(frozen=True)
class PathDeviation:
    """The tool's deviation from the programmed path, at the samples of the cutting moves.

    Attributes
    ----------
    line : ndarray, shape (M,)
        Line of the block each sample belongs to.
    move : ndarray, shape (M,)
        Index of the move (in the program's cutting moves) each sample belongs to.
    fraction : ndarray, shape (M,)
        Where on its move the sample is, 0 (start) to 1 (end).
    q : ndarray, shape (M, n_axes)
        Axis positions [m, rad].
    point : ndarray, shape (M, 3)
        Nominal tool point in the workpiece frame [m].
    tangent : ndarray, shape (M, 3)
        Unit tangent of the nominal tool path (zero where the tool point does not move).
    error : ndarray, shape (M, 3)
        Tool point error, actual minus nominal [m].
    normal : ndarray, shape (M, 3)
        Its part normal to the path [m]: what the cut surface keeps.
    tolerance : float
        The sampling tolerance [m] the samples meet.
    """

    line: np.ndarray
    move: np.ndarray
    fraction: np.ndarray
    q: np.ndarray
    point: np.ndarray
    tangent: np.ndarray
    error: np.ndarray
    normal: np.ndarray
    tolerance: float

    def per_block(self) -> dict[int, float]:
        """Largest normal deviation per block line [um]."""
        size = np.linalg.norm(self.normal, axis=1) * UM_PER_M
        out: dict[int, float] = {}
        for line, value in zip(self.line.tolist(), size.tolist()):
            out[line] = max(out.get(line, 0.0), value)
        return out

    def runs(self) -> list[np.ndarray]:
        """Each move's rows, in order (the samples run move by move)."""
        return np.split(np.arange(len(self.move)), np.flatnonzero(np.diff(self.move)) + 1)

    @property
    def max_um(self) -> float:
        """The largest normal deviation over the path [um]."""
        return float(np.linalg.norm(self.normal, axis=1).max() * UM_PER_M) if len(self.normal) else 0.0


def _tool_points(machine: Machine, q: np.ndarray) -> np.ndarray:
    # tangent steps may touch the ends of the travel
    return in_chunks(machine.tool_poses, q, nominal=True, extrapolate=True)[1]


class _Moves:
    """A program's cutting moves (lines and arcs; rapids cut nothing), whose positions at any
    fractions are asked for in one batch: program coordinates along each move (straight, or on
    its arc), turned into axis positions (tool-tip programming through the nominal machine, as
    the controller does)."""

    def __init__(self, machine: Machine, segments):
        self.machine = machine
        segments = list(segments)
        self.segments = [s for s in segments if s.kind in ("line", "arc")]
        self.rapids = [(n, s) for n, s in enumerate(segments) if s.kind == "rapid"]
        self.order = np.array([n for n, s in enumerate(segments) if s.kind in ("line", "arc")])   # place in the program
        if not self.segments:
            raise InputError("the program has no cutting move (lines or arcs)", parameters=("segments",))
        self.start = np.array([s.start for s in self.segments], dtype=float)
        self.end = np.array([s.end for s in self.segments], dtype=float)
        self.line = np.array([s.line for s in self.segments])
        self.arc = np.array([s.kind == "arc" for s in self.segments])
        # every arc's circle, to place points on all of them at once
        arcs = [s.arc if s.kind == "arc" else None for s in self.segments]
        self._plane = np.array([a.plane[:2] if a is not None else (0, 0) for a in arcs], dtype=int)
        self._circle = np.array([(a.center[0], a.center[1], a.radius,
                                  a.radius if a.end_radius is None else a.end_radius, a.start_angle, a.sweep)
                                 if a is not None else (0.0,) * 6 for a in arcs], dtype=float)
        self.tool_tip = np.array([s.programming == "tool-tip" for s in self.segments])
        self.contours = _contours(segments)
        self._tip = None
        self.uses_directions = "directions" in machine.covariates_used
        self._carry = None

    def __len__(self) -> int:
        return len(self.segments)

    @classmethod
    def of(cls, machine: Machine, segments) -> "_Moves":
        """``segments`` as moves: a program's moves are read once however many steps ask."""
        return segments if isinstance(segments, cls) else cls(machine, segments)

    def words(self, move: np.ndarray, k: np.ndarray) -> np.ndarray:
        """Program coordinates of moves ``move`` at fractions ``k`` (both (M,))."""
        out = self.start[move] + k[:, None] * (self.end[move] - self.start[move])
        rows = np.flatnonzero(self.arc[move])
        if len(rows):   # as Arc.point: the radius runs from the start's to the end's over the sweep
            on = move[rows]
            cx, cy, r0, r1, a0, sweep = self._circle[on].T
            angle = a0 + k[rows] * sweep
            radius = r0 + k[rows] * (r1 - r0)
            out[rows, self._plane[on, 0]] = cx + radius * np.cos(angle)
            out[rows, self._plane[on, 1]] = cy + radius * np.sin(angle)
        return out

    def axes(self, move: np.ndarray, k: np.ndarray) -> np.ndarray:
        """Axis positions of moves ``move`` at fractions ``k`` [m, rad]."""
        out = self.words(move, k)
        tip = self.tool_tip[move]
        if tip.any():
            out[tip] = in_chunks(self._tool_tip_mode().to_axes, out[tip], chunk=CHUNK // 4)   # 4 poses a point
        return out

    def _tool_tip_mode(self):
        if self._tip is None:
            from ..compensation.programming import programming_for

            self._tip = programming_for("tool-tip", self.machine)
        return self._tip

    def check_travel(self, move: np.ndarray, q: np.ndarray) -> None:
        """A move that leaves the travel is refused, naming its line: the model is not
        extrapolated into a part."""
        machine = self.machine
        outside = machine.outside_travel(q)
        if outside.any():
            row, axis = np.argwhere(outside)[0]
            unit, scale = ("deg", 180.0 / np.pi) if machine.axis_kinds[axis] == "rotary" else ("mm", 1e3)
            low, high = machine.travel[axis] * scale
            raise InputError(f"line {self.line[move[row]]}: the move takes {machine.axes[axis]} to "
                             f"{q[row, axis] * scale:.4f} {unit}, outside its travel {low:g} .. {high:g} {unit}",
                             parameters=("segments",))

    def evaluate(self, move: np.ndarray, k: np.ndarray):
        """At moves ``move``, fractions ``k``: axis positions, nominal tool point, unit tangent
        of the nominal path (a central difference in the fraction; zero where the tool point
        does not move), the error and its part normal to the path."""
        q = self.axes(move, k)
        self.check_travel(move, q)
        point = _tool_points(self.machine, q)
        ahead = self.axes(move, np.clip(k + TANGENT_STEP, 0.0, 1.0))
        behind = self.axes(move, np.clip(k - TANGENT_STEP, 0.0, 1.0))
        step = _tool_points(self.machine, ahead) - _tool_points(self.machine, behind)
        length = np.linalg.norm(step, axis=1)
        moving = length > 1e-12 * max(1.0, float(np.abs(point).max(initial=0.0)))
        tangent = np.zeros_like(step)
        tangent[moving] = step[moving] / length[moving, None]
        error = in_chunks(self.machine.volumetric_error, q, self.covariates(move, k, q))[:, :3]
        return q, point, tangent, error, normal_part(error, tangent)

    def _motion(self, move: np.ndarray, k: np.ndarray, q: np.ndarray, toward: float) -> np.ndarray:
        """Signs of each axis' motion within the move next to fraction ``k``: over the step
        ``TANGENT_STEP`` before ``k`` (``toward`` -1) or after it (+1), or, where an axis barely
        moves there (at the top of an arc), over a thousandth of the move; 0 where it stands."""
        signs = np.zeros_like(q)
        for step in (TANGENT_STEP, 1e-3):
            other = self.axes(move, np.clip(k + toward * step, 0.0, 1.0))
            found = _signs(toward * (other - q))
            signs = np.where(signs != 0, signs, found)
            if (signs != 0).all():
                break
        return signs

    def _carry_in(self) -> np.ndarray:
        """Each axis' direction as each move starts (n_moves, n_axes): the sign of its last motion
        before it, rapids included; before the program, the machine state's directions (+1
        without)."""
        if self._carry is None:
            n, index = len(self), np.arange(len(self))
            total = max(int(self.order.max()) if n else -1, max((r for r, _ in self.rapids), default=-1)) + 1
            last = np.zeros((total, self.start.shape[1]))
            last[self.order] = self._motion(index, np.ones(n), self.axes(index, np.ones(n)), -1.0)
            for row, rapid in self.rapids:   # straight in axis positions; a start not known moves nothing
                ends = np.vstack([rapid.start, rapid.end]).astype(float)
                if rapid.programming == "tool-tip" and np.isfinite(ends).all():
                    ends = self._tool_tip_mode().to_axes(ends)
                last[row] = np.nan_to_num(_signs(ends[1] - ends[0]))
            start = self.machine.state.get("directions")
            start = np.ones(last.shape[1]) if start is None else np.sign(np.asarray(start, dtype=float))
            # forward fill: an axis standing still keeps the direction it had
            seen = np.where(last != 0, np.arange(total)[:, None], -1)
            latest = np.maximum.accumulate(seen, axis=0)
            filled = np.where(latest >= 0, np.take_along_axis(last, np.maximum(latest, 0), axis=0), start)
            before = self.order - 1
            self._carry = np.where((before >= 0)[:, None], filled[np.maximum(before, 0)], start)
        return self._carry

    def covariates(self, move: np.ndarray, k: np.ndarray, q: np.ndarray) -> dict:
        """The covariates the path itself sets: for a machine whose errors depend on the axes'
        directions (backlash), each axis' direction at each point of a move as a controller
        takes it: the sign of the move's motion into the point (at the move's start, of its
        first motion: the move is followed in its own directions, and a reversal at its start
        steps the path between the move before and it); while the axis stands still, the
        direction it had."""
        if not self.uses_directions:
            return {}
        signs = self._motion(move, k, q, -1.0)
        first = k <= 0.0
        if first.any():
            signs[first] = self._motion(move[first], k[first], q[first], 1.0)
        return {"directions": np.where(signs != 0, signs, self._carry_in()[move])}


def _signs(step: np.ndarray) -> np.ndarray:
    """Signs of axis steps, rounding below 1e-13 (m or rad: an axis that stands still) to 0."""
    return np.where(np.abs(step) > 1e-13, np.sign(step), 0.0)


#: the shortest interval between samples, as a fraction of a move: where the deviation steps (an
#: axis with backlash reversing inside an arc) no number of samples meets the tolerance, and the
#: step is left between two samples this close
SHORTEST = 2.0 ** -30


def deviation_along(machine: Machine, segments, tolerance: float = 0.01e-6, *,
                    max_points: int = 2_000_000) -> PathDeviation:
    """The deviation of the tool from the programmed path along the cutting moves.

    Every move starts with 3 samples. The midpoint of every interval still open is evaluated
    (all the moves' in one batch); where the normal deviation interpolated linearly between the
    interval's ends is further than ``tolerance`` from the model's, the midpoint joins the
    samples and the two halves stay open, else the interval is closed; until none is open. An
    interval shorter than :data:`SHORTEST` of its move is closed as it is: a step of the
    deviation (an axis with backlash reversing inside an arc) stays between its two samples.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict (:meth:`Machine.with_state`: the part cold or
        warm, under load).
    segments : sequence of volerr_pin.compensation.gcode.Segment
        The program's moves (:func:`volerr_pin.compensation.gcode.interpret`), in axes or
        tool-tip programming; rapids are left out, as they cut nothing.
    tolerance : float, default 0.01e-6
        Sampling tolerance [m].
    max_points : int, default 2,000,000
        The most samples in all; more is refused, naming ``tolerance``.

    Returns
    -------
    PathDeviation

    Raises
    ------
    InputError
        If ``tolerance`` is not a positive number, the program has no cutting move, a move
        leaves the travel (naming its line), or the samples would exceed ``max_points``.
    """
    if not (isinstance(tolerance, (int, float)) and np.isfinite(tolerance) and tolerance > 0):
        raise InputError(f"tolerance must be a positive number of metres, got {tolerance!r}", parameters=("tolerance",))
    moves = _Moves.of(machine, segments)
    n = len(moves)
    names = ("q", "point", "tangent", "error", "normal")
    first = np.repeat(np.arange(n), 3)
    k0 = np.tile([0.0, 0.5, 1.0], n)
    values = moves.evaluate(first, k0)
    fraction = [k0[3 * m:3 * m + 3] for m in range(n)]
    kept = [{name: v[3 * m:3 * m + 3] for name, v in zip(names, values)} for m in range(n)]
    open_: dict[int, np.ndarray] = {}   # per move still refined, which of its intervals are open
    total = 3 * n

    def refine(m: int, w: np.ndarray, mid_k: np.ndarray, mid: tuple) -> None:
        """Move ``m``'s open intervals ``w`` against their midpoints ``mid`` (at ``mid_k``)."""
        nonlocal total
        normal = kept[m]["normal"]
        split = np.abs(mid[4] - (normal[w] + normal[w + 1]) / 2.0).max(axis=1) > tolerance
        if not split.any():
            open_.pop(m, None)
            return
        at = w[split]
        total += len(at)
        if total > max_points:
            raise InputError(f"line {moves.line[m]}: sampling the path to {tolerance * UM_PER_M:g} um takes more "
                             f"than {max_points:,} points; give a larger tolerance", parameters=("tolerance",))
        fraction[m] = np.insert(fraction[m], at + 1, mid_k[split])
        kept[m] = {name: np.insert(kept[m][name], at + 1, v[split], axis=0) for name, v in zip(names, mid)}
        # the halves of a split interval stay open, unless they are as short as sampling goes
        halves = np.zeros(len(normal) - 1, dtype=bool)
        halves[at] = True
        still = np.repeat(halves, 1 + halves) & (np.diff(fraction[m]) > SHORTEST)
        if still.any():
            open_[m] = still
        else:
            open_.pop(m, None)

    # the first round for every move at once: most moves meet the tolerance with their 3 samples
    mid_k = np.tile([0.25, 0.75], n)
    mid = moves.evaluate(np.repeat(np.arange(n), 2), mid_k)
    normal = values[4].reshape(n, 3, 3)
    off = np.abs(mid[4].reshape(n, 2, 3) - (normal[:, :-1] + normal[:, 1:]) / 2.0).max(axis=2)
    for m in np.flatnonzero((off > tolerance).any(axis=1)).tolist():
        rows = slice(2 * m, 2 * m + 2)
        refine(m, np.arange(2), mid_k[rows], tuple(v[rows] for v in mid))
    while open_:
        pending = list(open_)
        where = [np.flatnonzero(open_[m]) for m in pending]
        which = np.repeat(pending, [len(w) for w in where])
        mid_k = np.concatenate([(fraction[m][w] + fraction[m][w + 1]) / 2.0 for m, w in zip(pending, where)])
        mid = moves.evaluate(which, mid_k)
        bounds = np.concatenate([[0], np.cumsum([len(w) for w in where])])
        for m, w, a, b in zip(pending, where, bounds[:-1], bounds[1:]):
            refine(m, w, mid_k[a:b], tuple(v[a:b] for v in mid))
    joined = {name: np.concatenate([kept[m][name] for m in range(n)]) for name in names}
    counts = [len(f) for f in fraction]
    return PathDeviation(line=np.repeat(moves.line, counts), move=np.repeat(np.arange(n), counts),
                         fraction=np.concatenate(fraction), tolerance=float(tolerance), **joined)


@dataclass(frozen=True)
class Cut:
    """The surface a program cuts: samples of every cutting move, where the tool actually is.

    Attributes
    ----------
    move : ndarray, shape (M,)
        Index of the sample's move among the program's cutting moves.
    q : ndarray, shape (M, n_axes)
        Axis positions [m, rad].
    nominal, actual : ndarray, shape (M, 3)
        The tool point in the workpiece frame as programmed and as the machine puts it [m].
    covariates : dict
        Per sample, the covariates the path sets (``directions``, for a machine that reads
        them), given to the model with the machine's state.
    """

    move: np.ndarray
    q: np.ndarray
    nominal: np.ndarray
    actual: np.ndarray
    covariates: dict = field(default_factory=dict)

    def at(self, rows) -> dict:
        """The covariates of samples ``rows``."""
        return {name: value[rows] for name, value in self.covariates.items()}

    def rows(self, moves: list[int]) -> np.ndarray:
        """The rows of the samples of ``moves`` (the samples run move by move)."""
        if not len(moves):
            return np.zeros(0, dtype=int)
        if max(moves) - min(moves) + 1 == len(moves):   # a run of moves: one range of rows
            return np.arange(np.searchsorted(self.move, min(moves), "left"),
                             np.searchsorted(self.move, max(moves), "right"))
        return np.flatnonzero(np.isin(self.move, moves))


def cut_of(machine: Machine, segments, spacing: float = 0.25e-3) -> Cut:
    """Samples of the cutting moves at most ``spacing`` apart along the nominal tool path (at
    least 3 per move; a move's end is the next one's start, so ends are not sampled twice). A
    move that turns a rotary axis in axes programming curves: its length is taken from 16
    chords, short of the curve's by up to 0.2 % (a half turn), and its samples as much further
    apart."""
    moves = _Moves.of(machine, segments)
    n = len(moves)
    index = np.arange(n)
    ends = _tool_points(machine, moves.axes(np.repeat(index, 2), np.tile([0.0, 1.0], n))).reshape(n, 2, 3)
    length = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    # a move that turns a rotary axis in axes programming takes the tool point along a curve: its
    # length from 16 chords (a tool-tip move's tip goes straight, an arc's length is its own)
    rotary = np.array(machine.axis_kinds) == "rotary"
    curved = np.flatnonzero(~moves.arc & ~moves.tool_tip & (moves.start[:, rotary] != moves.end[:, rotary]).any(axis=1))
    if len(curved):
        k = np.linspace(0.0, 1.0, 17)
        points = _tool_points(machine, moves.axes(np.repeat(curved, 17), np.tile(k, len(curved)))).reshape(-1, 17, 3)
        length[curved] = np.linalg.norm(np.diff(points, axis=1), axis=2).sum(axis=1)
    for m in np.flatnonzero(moves.arc):
        arc = moves.segments[m].arc
        length[m] = abs(arc.sweep) * max(arc.radius, 1e-9)
    counts = np.maximum(3, np.ceil(length / spacing).astype(int))
    move = np.repeat(index, counts)
    k = (np.arange(len(move)) - np.repeat(np.cumsum(counts) - counts, counts)) / np.repeat(counts, counts)
    q = moves.axes(move, k)
    moves.check_travel(move, q)
    nominal = _tool_points(machine, q)
    covariates = moves.covariates(move, k, q)
    return Cut(move, q, nominal, nominal + in_chunks(machine.volumetric_error, q, covariates)[:, :3], covariates)


@dataclass(frozen=True, kw_only=True)
class CircleFeature(RoundFeature):
    """A full circle of the program, as a CMM reports it (the fields of
    :class:`~volerr_pin.applications.cmm.RoundFeature`, in the contour plane, and these).

    Attributes
    ----------
    lines : tuple of int
        The blocks it comes from (of the reference program, when one is given).
    plane : tuple of int
        The workpiece-frame coordinates of its plane (0, 1: xy).
    centre : ndarray, shape (2,)
        Nominal centre in the plane [m].
    """

    lines: tuple[int, ...]
    plane: tuple[int, int]
    centre: np.ndarray

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um)."""
        return {"kind": "circle", "name": "roundness, diameter and centre of a circle (ISO 12181-1, least squares)",
                "blocks": list(self.lines), "plane": "xyz"[self.plane[0]] + "xyz"[self.plane[1]],
                "centre_mm": (self.centre * 1e3).tolist(), "diameter_mm": 2e3 * self.radius,
                "circularity_um": self.circularity_um, "diameter_error_um": self.diameter_error_um,
                "centre_error_um": self.centre_error_um}

    def profiles(self, parts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each source's radial deviation (in-plane errors ``parts`` at the measured points)
        less its least-squares circle, to first order."""
        radial = np.c_[np.cos(self.angle), np.sin(self.angle)]
        profiles = self.less_circle(np.stack([np.sum(p * radial, axis=1) for p in parts.values()], axis=1))
        return dict(zip(parts, profiles.T))


@dataclass(frozen=True)
class LineFeature:
    """A straight side of the program (a cutting line in the contour plane), as a CMM reports it.

    Attributes
    ----------
    lines : tuple of int
        The block it comes from (of the reference program, when one is given).
    plane : tuple of int
        The workpiece-frame coordinates of the contour plane.
    start, end : ndarray, shape (2,)
        Nominal ends in the plane [m].
    straightness_um : float
        ISO 12780: the range of the side's deviation about its least-squares line [um].
    contour : int
        Index of the contour (a run of cutting moves between rapids) it belongs to.
    measured : ndarray, shape (M, 2)
        The measured points in the plane [m].
    q : ndarray, shape (M, n_axes)
        Their axis positions [m, rad].
    covariates : dict
        Their covariates the path sets (the axes' directions, for a machine that reads them).
    """

    lines: tuple[int, ...]
    plane: tuple[int, int]
    start: np.ndarray
    end: np.ndarray
    straightness_um: float
    contour: int
    measured: np.ndarray
    q: np.ndarray
    covariates: dict = field(default_factory=dict)

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.end - self.start))

    @property
    def direction(self) -> np.ndarray:
        return (self.end - self.start) / self.length

    @property
    def across(self) -> np.ndarray:
        return np.array([-self.direction[1], self.direction[0]])

    def along(self) -> np.ndarray:
        """Each measured point's distance from the nominal start along the side [m]."""
        return (self.measured - self.start) @ self.direction

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um)."""
        return {"kind": "straightness", "name": "straightness of a side (ISO 12780, least squares)",
                "blocks": list(self.lines), "plane": "xyz"[self.plane[0]] + "xyz"[self.plane[1]],
                "start_mm": (self.start * 1e3).tolist(), "end_mm": (self.end * 1e3).tolist(),
                "length_mm": self.length * 1e3, "straightness_um": self.straightness_um}

    def profiles(self, parts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each source's deviation across the side less its least-squares line, to first order."""
        along = self.along()
        basis = np.c_[np.ones_like(along), along]
        return dict(zip(parts, _without(np.stack([p @ self.across for p in parts.values()], axis=1), basis).T))


@dataclass(frozen=True)
class PairFeature:
    """Squareness or parallelism of one side to another of the same contour (ISO 1101).

    The datum is the first side's least-squares line; the value is the width of the zone,
    perpendicular to (squareness) or parallel to (parallelism) the datum, that holds every
    measured point of the second side [um].

    Attributes
    ----------
    kind : str
        "squareness" or "parallelism".
    datum, toleranced : LineFeature
        The two sides.
    value_um : float
        The zone's width [um].
    """

    kind: str
    datum: LineFeature
    toleranced: LineFeature
    value_um: float

    @property
    def lines(self) -> tuple[int, ...]:
        return self.datum.lines + self.toleranced.lines

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um)."""
        return {"kind": self.kind, "name": f"{self.kind} of a side to a datum side (ISO 1101)",
                "blocks": list(self.lines), "datum_line": self.datum.lines[0], f"{self.kind}_um": self.value_um}


def _contours(segments) -> list[list[int]]:
    """The program's cutting moves grouped in contours (runs between rapids), as indices among
    its cutting moves."""
    runs, current, index = [], [], 0
    for segment in segments:
        if segment.kind == "rapid":
            if current:
                runs.append(current)
            current = []
        elif segment.kind in ("line", "arc"):
            current.append(index)
            index += 1
    if current:
        runs.append(current)
    return runs


def _full_circles(moves: _Moves, contours: list[list[int]]) -> list[list[int]]:
    """Runs of consecutive arcs of one contour, plane, centre and radius turning at least a
    whole turn (indices among the cutting moves)."""
    def same(a, b):
        return (a.plane == b.plane and np.allclose(a.center, b.center, atol=1e-9)
                and abs(a.radius - b.radius) <= 1e-9)

    runs = []
    for contour in contours:
        current: list[int] = []
        for m in contour + [None]:
            arc = moves.segments[m].arc if m is not None and moves.arc[m] else None
            if arc is not None and (not current or same(moves.segments[current[-1]].arc, arc)):
                current.append(m)
                continue
            if current and abs(sum(moves.segments[c].arc.sweep for c in current)) >= 2 * np.pi - 1e-9:
                runs.append(current)
            current = [m] if arc is not None else []
    return runs


def _reference_features(machine: Machine, segments, plane: tuple[int, int], min_length: float, notes: list):
    """The circles and sides a program defines: (circles, sides) as dicts of their nominal
    geometry in the workpiece frame and the indices of their moves among the cutting moves; a
    full circle in another plane is named in ``notes``."""
    i, j = plane
    third = ({0, 1, 2} - {i, j}).pop()
    moves = _Moves.of(machine, segments)
    contours = moves.contours
    circles = []
    for run in _full_circles(moves, contours):
        arc = moves.segments[run[0]].arc
        letters = [machine.axes[a] for a in arc.plane[:2]]   # the arc's plane, by the axes' letters
        if not all(letter in "XYZ" for letter in letters) or {"XYZ".index(c) for c in letters} != {i, j}:
            other = "".join(sorted(c.lower() for c in letters))
            notes.append(f"the full circle of line {moves.line[run[0]]} lies in the {other} plane, not in the "
                         f"contour plane {'xyz'[i] + 'xyz'[j]}: it is measured in a prediction of that plane")
            continue
        start = _tool_points(machine, moves.axes(np.array([run[0]]), np.zeros(1)))[0]
        if moves.tool_tip[run[0]]:   # the words are the tool tip's coordinates
            at = dict(zip(("XYZ".index(c) for c in letters), np.asarray(arc.center, dtype=float)))
            centre = np.array([at[i], at[j]])
        else:                        # the centre's axis positions, as a tool point
            q = arc.start.copy()
            q[list(arc.plane[:2])] = arc.center
            centre = _tool_points(machine, q[None, :])[0, [i, j]]
        circles.append({"lines": tuple(dict.fromkeys(int(moves.line[m]) for m in run)), "centre": centre,
                        "radius": float(np.linalg.norm(start[[i, j]] - centre)), "height": float(start[third]),
                        "moves": run})
    lines = np.flatnonzero(~moves.arc)
    ends = _tool_points(machine, moves.axes(np.repeat(lines, 2), np.tile([0.0, 1.0], len(lines)))).reshape(-1, 2, 3)
    end_of = dict(zip(lines.tolist(), ends))
    sides = []
    for number, contour in enumerate(contours):
        for m in contour:
            if m not in end_of:
                continue
            ends = end_of[m]
            length = float(np.linalg.norm(ends[1, [i, j]] - ends[0, [i, j]]))
            if length < min_length or abs(ends[1, third] - ends[0, third]) > 1e-9:
                continue
            sides.append({"lines": (int(moves.line[m]),), "start": ends[0, [i, j]], "end": ends[1, [i, j]],
                          "height": float(ends[0, third]), "contour": number, "moves": [m]})
    return circles, sides


def contour_plane(cut: Cut) -> tuple[int, int]:
    """The plane of a part's contours: the workpiece-frame plane (two coordinates, in the order
    x, y, z) that holds the most cutting length: a move counts in the plane it lies in (its
    third coordinate constant), half in each of two when it runs along one axis (a plunge along
    z lies in xz and yz, a side along x in xy and xz); xy for a milled contour, xz for a lathe's
    profile; ties go to xy, then xz. A cut whose moves mostly lie in no
    such plane (five-axis moves, a cone's turn) takes the two coordinates it spreads over most."""
    starts = np.flatnonzero(np.r_[True, np.diff(cut.move) != 0])
    spread = np.maximum.reduceat(cut.nominal, starts) - np.minimum.reduceat(cut.nominal, starts)
    steps = np.linalg.norm(np.diff(cut.nominal, axis=0), axis=1)
    steps[np.diff(cut.move) != 0] = 0.0   # no length between moves
    length = np.add.reduceat(np.r_[steps, 0.0], starts)
    inside = spread <= 1e-9                       # per move, the coordinates it keeps constant
    share = length / np.maximum(inside.sum(axis=1), 1)   # a move along one axis lies in two planes: half each
    held = [float(share[inside[:, c]].sum()) for c in (2, 1, 0)]   # normal z, y, x
    if float(length[inside.any(axis=1)].sum()) >= 0.5 * float(length.sum()) and max(held) > 0:
        normal = (2, 1, 0)[int(np.argmax(held))]
        i, j = sorted({0, 1, 2} - {normal})
        return int(i), int(j)
    i, j = sorted(np.argsort(-np.ptp(cut.nominal, axis=0), kind="stable")[:2].tolist())
    return int(i), int(j)


class _Near:
    """Samples near a feature (a k-d tree of the plane's points, so that a feature looks at its
    neighbourhood only)."""

    def __init__(self, flat: np.ndarray, height: np.ndarray):
        from scipy.spatial import cKDTree

        self.tree, self.height = cKDTree(flat), height

    def along(self, path: np.ndarray, capture: float, level: float) -> np.ndarray:
        """The samples within about ``capture`` of a path (P, 2) in the plane, its points at most
        ``capture`` apart (a ball of 1.2 ``capture`` at each), and of ``level`` in height."""
        hits = self.tree.query_ball_point(path, 1.2 * capture)
        rows = np.unique(np.concatenate([np.asarray(h, dtype=int) for h in hits] + [np.zeros(0, dtype=int)]))
        return rows[np.abs(self.height[rows] - level) <= capture]


def _on_segment(start: np.ndarray, end: np.ndarray, step: float) -> np.ndarray:
    """Points of a segment at most ``step`` apart, its ends included."""
    n = max(2, int(np.ceil(np.linalg.norm(end - start) / step)) + 1)
    return start + np.outer(np.linspace(0.0, 1.0, n), end - start)


def _pairs(sides: list) -> list[tuple]:
    """The pairs of sides a CMM report gives, within a contour, in its order: each side's
    squareness to the side before it when the two are perpendicular (a corner; the last side to
    the first too, closing the contour), and its parallelism to the nearest earlier side
    parallel to it (the opposite side). A square gives its four corners and two pairs of
    opposite sides; a contour of n sides at most 2 n pairs."""
    out = []
    by_contour: dict[int, list] = {}
    for side in sides:
        by_contour.setdefault(side.contour, []).append(side)

    def kind_of(a, b):
        cross = a.direction[0] * b.direction[1] - a.direction[1] * b.direction[0]
        if abs(cross) < 1e-9:
            return "parallelism"
        return "squareness" if abs(a.direction @ b.direction) < 1e-9 else None

    for run in by_contour.values():
        last_of: dict[float, object] = {}   # the latest side of each direction (mod 180 deg)
        for k, side in enumerate(run):
            if k and kind_of(run[k - 1], side) == "squareness":
                out.append((run[k - 1], side, "squareness"))
            key = round(float(np.arctan2(side.direction[1], side.direction[0]) % np.pi), 9) % round(np.pi, 9)
            if key in last_of:
                out.append((last_of[key], side, "parallelism"))
            last_of[key] = side
        if len(run) > 2 and kind_of(run[0], run[-1]) == "squareness" and np.allclose(run[-1].end, run[0].start,
                                                                                     atol=1e-9):
            out.append((run[0], run[-1], "squareness"))
    return out


class Features(NamedTuple):
    """The features of a part (:func:`measure`), and ``notes`` on those not measured."""

    circles: list
    sides: list
    pairs: list
    cones: list
    notes: list


def measure(machine: Machine, segments, reference=None, *, plane: tuple[int, int] | None = None,
            min_length: float = 5e-3, spacing: float = 0.25e-3, capture: float = 0.2e-3,
            tool_diameter: float = 0.0, cone_heights=(0.0,)) -> Features:
    """The features a CMM reports of the part a program cuts.

    The features are those of ``reference`` (default: the program itself): each full circle
    (arcs of one centre and radius in the contour plane turning a whole turn) and each
    straight side (a cutting line in the plane at least ``min_length`` long), within a contour
    (cutting moves between rapids) its corners' squareness and its opposite sides' parallelism
    (the earlier side the datum), and each contour that cuts a cone with the tool's flank (five-axis,
    :func:`volerr_pin.applications.cone.find_cones`), in sections at ``cone_heights``. They are
    measured on the cut: the program's cutting moves sampled at most ``spacing`` apart, where
    the tool actually is. A sample measures a feature of its own move; with a reference (a
    compensated program against the program it was made from), a sample measures the feature
    it lies within ``capture`` of (in the plane and in height; a side's ends, 1 % of its
    length, left out; a cone: its tool point within ``capture`` of the circle the reference's
    tool points go round).

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict. The moves' plane coordinates are axis positions;
        features are measured in the same coordinates of the workpiece frame, which a machine
        whose linear axes are the frame's x, y, z (every bundled machining centre) follows.
    segments : sequence of Segment
        The program's moves (:func:`volerr_pin.compensation.gcode.interpret`).
    reference : sequence of Segment, optional
        The moves of the program that defines the features.
    plane : tuple of int, optional
        The contour plane's coordinates in the workpiece frame (0, 1: xy; 0, 2: xz, a lathe's).
        Default: the plane that holds the most cutting length (:func:`contour_plane`).
    min_length : float, default 5e-3
        The shortest side measured [m].
    spacing : float, default 0.25e-3
        The largest distance between measured points along a move [m].
    capture : float, default 0.2e-3
        With a reference: how far from a feature a sample may lie and still measure it [m].
    tool_diameter : float, default 0
        The tool's diameter [m]: a cone cut by the flank is offset by its radius from the
        tool's axis.
    cone_heights : sequence of float, default (0,)
        A cone's sections: heights along its axis above the plane the tool's end cuts in [m].

    Returns
    -------
    Features
        ``circles`` (CircleFeature), ``sides`` (LineFeature), ``pairs`` (PairFeature),
        ``cones`` (ConeSection, each cone's at every height), and ``notes``: why a feature the
        program defines is not measured (a full circle in another plane; a cone the cut does
        not go all round).

    Raises
    ------
    InputError
        If a move leaves the travel (naming its line), or a cone has no section at a height.
    """
    segments = _Moves.of(machine, segments)
    reference = None if reference is None else _Moves.of(machine, reference)
    cut = cut_of(machine, segments, spacing)
    plane = contour_plane(cut) if plane is None else tuple(plane)
    i, j = plane
    third = ({0, 1, 2} - {i, j}).pop()
    notes: list[str] = []
    circles_ref, sides_ref = _reference_features(machine, reference if reference is not None else segments,
                                                 plane, min_length, notes)
    flat, height = cut.actual[:, [i, j]], cut.actual[:, third]
    near = _Near(flat, height) if reference is not None else None
    circles = []
    for ref in circles_ref:
        if reference is None:
            rows = cut.rows(ref["moves"])
        else:
            turn = np.linspace(0.0, 2 * np.pi, max(8, int(np.ceil(2 * np.pi * ref["radius"] / capture)) + 1))
            rows = near.along(ref["centre"] + ref["radius"] * np.c_[np.cos(turn), np.sin(turn)], capture, ref["height"])
            rows = rows[np.abs(np.linalg.norm(flat[rows] - ref["centre"], axis=1) - ref["radius"]) <= capture]
        if len(rows) < 3:
            continue
        points = flat[rows]
        around = cut.nominal[rows][:, [i, j]] - ref["centre"] if reference is None else points - ref["centre"]
        circles.append(CircleFeature(
            lines=ref["lines"], plane=plane, centre=ref["centre"], **measure_round(points, ref["centre"], ref["radius"]),
            angle=np.arctan2(around[:, 1], around[:, 0]), q=cut.q[rows], covariates=cut.at(rows)))
    sides = []
    for ref in sides_ref:
        length = float(np.linalg.norm(ref["end"] - ref["start"]))
        direction = (ref["end"] - ref["start"]) / length
        if reference is None:
            rows = cut.rows(ref["moves"])
        else:
            rows = near.along(_on_segment(ref["start"], ref["end"], capture), capture, ref["height"])
            along = (flat[rows] - ref["start"]) @ direction
            across = (flat[rows] - ref["start"]) @ np.array([-direction[1], direction[0]])
            rows = rows[(np.abs(across) <= capture) & (along >= 0.01 * length) & (along <= 0.99 * length)]
        if len(rows) < 3:
            continue
        points = flat[rows]
        centre, _, normal = fit_line(points)
        sides.append(LineFeature(lines=ref["lines"], plane=plane, start=ref["start"], end=ref["end"],
                                 straightness_um=float(np.ptp((points - centre) @ normal) * UM_PER_M),
                                 contour=ref["contour"], measured=points, q=cut.q[rows],
                                 covariates=cut.at(rows)))
    pairs = []
    for datum, other, kind in _pairs(sides):
        centre, along, across = fit_line(datum.measured)
        zone = (other.measured - centre) @ (across if kind == "parallelism" else along)
        pairs.append(PairFeature(kind=kind, datum=datum, toleranced=other, value_um=float(np.ptp(zone) * UM_PER_M)))
    defining = _Moves.of(machine, reference if reference is not None else segments)
    defining_cut = cut if reference is None else cut_of(machine, defining, spacing)
    cones = find_cones(machine, defining, defining.contours, defining_cut, tool_diameter / 2.0)
    if reference is None:
        rows = [cut.rows(cone.moves) for cone in cones]
    else:
        rows = [cone.near_tips(cut.nominal, capture) for cone in cones]
    sections = measure_cones(machine, cones, cut, cone_heights, rows, notes)
    return Features(circles, sides, pairs, sections, notes)


def _component_columns(machine: Machine) -> dict[str, list[int]]:
    """Each component's coefficient columns, in the machine's order."""
    out: dict[str, list[int]] = {}
    for term in machine.model.term_info():
        out.setdefault(term["component"], []).extend(machine.parameter_names.index(n) for n in term["parameters"])
    return out


def _contributions(machine: Machine, q: np.ndarray, covariates: dict | None = None) -> dict[str, np.ndarray]:
    """Each component's first-order part of the tool's pose error at ``q`` (M, 6: dx, dy, dz
    [m], rx, ry, rz [rad]): its coefficients times the exact sensitivities."""
    sensitivity = machine.sensitivity(q, **(covariates or {}))[:, :6, :]
    theta = machine.theta
    return {component: sensitivity[:, :, cols] @ theta[cols] for component, cols in _component_columns(machine).items()}


def _in_plane(parts: dict[str, np.ndarray], plane) -> dict[str, np.ndarray]:
    return {c: p[:, list(plane)] for c, p in parts.items()}


def _without(values: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """``values`` less their least-squares fit on the columns of ``basis``."""
    coefficients, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return values - basis @ coefficients


def _rows(profiles: dict[str, np.ndarray]) -> list[dict]:
    energy = {c: float(np.sum(p ** 2)) for c, p in profiles.items()}
    total = sum(energy.values()) or 1.0
    rows = [{"component": c, "alone_um": float(np.ptp(p) * UM_PER_M), "share": energy[c] / total}
            for c, p in profiles.items()]
    return sorted(rows, key=lambda r: -r["share"])


def feature_ranking(machine: Machine, feature, *, cache: dict | None = None) -> list[dict]:
    """Which error sources decide a feature: per component, the feature's profile it causes
    alone (to first order, from the exact sensitivities) and its share.

    The profile is what the feature's value is the range of: a circle's radial deviation less
    its least-squares circle, a side's deviation across it less its least-squares line, a pair's
    zone coordinate with the datum's least-squares line, a cone's section's radial deviation
    (from the error of the tool's position and orientation at the cutting point) less its
    least-squares circle. Per component, ``alone_um`` is the
    range of its own profile (the feature if it acted alone) and ``share`` its share of the sum
    of the profiles' squares, as ``rank``'s share is of the tool point's mean square.

    Parameters
    ----------
    machine : Machine
        The machine the feature was measured on.
    feature : CircleFeature, LineFeature, PairFeature or ConeSection
        The feature (:func:`measure`).
    cache : dict, optional
        Each feature's sources, kept between calls (a side is in its own straightness and in
        every pair it belongs to): pass the same dict for the features of one measurement.

    Returns
    -------
    list of dict
        ``component``, ``alone_um``, ``share``; largest share first.
    """
    def parts(f):   # in its plane for a circle or a side; the whole pose error for a cone's section
        if cache is None or id(f) not in cache:
            found = _contributions(machine, f.q, f.covariates)
            found = found if isinstance(f, ConeSection) else _in_plane(found, f.plane)
            if cache is None:
                return found
            cache[id(f)] = (f, found)   # f kept beside: its id stays its own
        return cache[id(f)][1]

    if isinstance(feature, (CircleFeature, LineFeature, ConeSection)):
        return _rows(feature.profiles(parts(feature)))
    datum, other = feature.datum, feature.toleranced
    u0, n0 = datum.direction, datum.across
    s = datum.along()
    relative = other.measured - datum.start
    datum_parts, other_parts = parts(datum), parts(other)
    # per component (columns), the datum line's turn to first order, and the zone coordinate
    slope = np.polyfit(s, np.stack([p @ n0 for p in datum_parts.values()], axis=1), 1)[0]
    if feature.kind == "parallelism":
        value = np.stack([p @ n0 for p in other_parts.values()], axis=1) - np.outer(relative @ u0, slope)
    else:
        value = np.stack([p @ u0 for p in other_parts.values()], axis=1) + np.outer(relative @ n0, slope)
    value -= value.mean(axis=0)
    return _rows(dict(zip(other_parts, value.T)))


def blocks_text(blocks: list[int]) -> str:
    """A feature's block lines for a table: all of up to four, else the first and the last."""
    return ",".join(map(str, blocks)) if len(blocks) <= 4 else f"{blocks[0]}..{blocks[-1]}"


@dataclass
class PartPrediction:
    """What a program cuts on a machine: the deviation along the path and the features.

    Attributes
    ----------
    machine : Machine
    source : str
        The program's name.
    reference : str or None
        The name of the program that defines the features, when not the program itself.
    deviation : PathDeviation
        Along the program's own path (normal to it).
    circles, sides, pairs, cones : list
        The features (:func:`measure`).
    notes : list of str
        Why a feature the program defines is not measured.
    rankings : list of list of dict
        Per feature (circles, sides, pairs, cones' sections in that order),
        :func:`feature_ranking`; empty with
        a reference, where what is left is the compensation's, not an error source's.
    """

    machine: Machine
    source: str
    reference: str | None
    deviation: PathDeviation
    circles: list
    sides: list
    pairs: list
    rankings: list
    cones: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    @property
    def features(self) -> list:
        return [*self.circles, *self.sides, *self.pairs, *self.cones]

    def to_dict(self, top: int = 5) -> dict:
        """The report: the largest deviation and its block, every block's, and the features
        with the ``top`` error sources of each, its ``drivers`` (JSON: ``features``)."""
        blocks = self.deviation.per_block()
        worst = max(blocks, key=blocks.get)
        features = []
        for feature, ranking in zip(self.features, self.rankings):
            row = feature.to_dict()
            row["drivers"] = ranking[:top]
            features.append(row)
        return {"machine": self.machine.name, "program": self.source, "reference": self.reference,
                "state": self.machine.state, "tolerance_um": self.deviation.tolerance * UM_PER_M,
                "samples": int(len(self.deviation.line)), "max_normal_deviation_um": self.deviation.max_um,
                "max_line": int(worst),
                "blocks": [{"line": int(line), "max_um": value} for line, value in blocks.items()],
                "features": features, "notes": list(self.notes)}


def predict(machine: Machine, text: str, source: str = "<program>", *, reference: str | None = None,
            reference_source: str = "<reference>", tolerance: float = 0.01e-6, start=None, origin=None,
            plane: tuple[int, int] | None = None, tool_diameter: float = 0.0, cone_heights=(0.0,)) -> PartPrediction:
    """Predict the part a program cuts: the deviation along its path and its features with the
    error sources that decide them.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict (:meth:`Machine.with_state`).
    text : str
        The program (read as ``compensate`` reads it).
    source : str, default "<program>"
        Its name, for messages and the report.
    reference : str, optional
        The program that defines the part (for a compensated program: the program it was
        made from): its features are measured on the cut of ``text`` (:func:`measure`).
    reference_source : str, default "<reference>"
        Its name.
    tolerance : float, default 0.01e-6
        Sampling tolerance of the path [m] (:func:`deviation_along`).
    start, origin : array_like, optional
        Where the axes stand when it starts, and the program zero [m, rad]
        (:func:`volerr_pin.compensation.gcode.interpret`).
    plane : tuple of int, optional
        The contour plane of the features (default: :func:`contour_plane` of the cut).
    tool_diameter : float, default 0
        The tool's diameter [m]: a cone cut by the tool's flank is offset by its radius from
        the tool's axis (0: the cone the tool's axis sweeps).
    cone_heights : sequence of float, default (0,)
        A cone's sections: heights along its axis above the plane the tool's end cuts in [m].

    Returns
    -------
    PartPrediction
    """
    from ..compensation.gcode import interpret

    segments = _Moves(machine, interpret(machine, text, source, start=start, origin=origin))
    defining = None if reference is None else interpret(machine, reference, reference_source, start=start,
                                                         origin=origin)
    deviation = deviation_along(machine, segments, tolerance)
    found = measure(machine, segments, defining, plane=plane, tool_diameter=tool_diameter, cone_heights=cone_heights)
    # with a reference (a compensated program), what is left is the compensation's (its tolerance,
    # the written numbers' rounding), not an error source's: the sources' profiles cancel
    cache: dict = {}
    rankings = [feature_ranking(machine, f, cache=cache) if reference is None else []
                for f in [*found.circles, *found.sides, *found.pairs, *found.cones]]
    return PartPrediction(machine, source, None if reference is None else reference_source, deviation, found.circles,
                          found.sides, found.pairs, rankings, found.cones, found.notes)


def contouring_test_piece(machine: Machine, size: float | None = None, feed: float = 500.0) -> str:
    """A program of the contouring test piece's finishing contours, in the form of ISO 10791-7's:
    a square, a diamond (the square turned 45 degrees, inside it) and a circle (inside the
    diamond), each a closed contour at one height, in the middle of the machine's travel.

    Parameters
    ----------
    machine : Machine
        The machine: its first three axes must be linear X, Y, Z (the rotary ones, if any, stay
        at 0 or mid travel).
    size : float, optional
        The square's side [m]; default 160 mm, or less to keep 20 % of the smaller of the X and
        Y travels on either side.
    feed : float, default 500
        Feed rate [mm/min].

    Returns
    -------
    str
        The program (G17 G90 G21, mm), its contours separated by rapids, the size stated in a
        comment.

    Raises
    ------
    InputError
        If the machine has no linear X, Y and Z, or the square does not fit its travel.
    """
    axes = machine.axes
    if axes[:3] != ("X", "Y", "Z") or any(k != "linear" for k in machine.axis_kinds[:3]):
        raise InputError(f"{machine.name}: the contouring test piece needs linear X, Y, Z as the first axes, "
                         f"got {', '.join(axes)}", parameters=("machine",))
    travel = machine.travel[:3] * 1e3
    span = min(travel[0, 1] - travel[0, 0], travel[1, 1] - travel[1, 0])
    side = size * 1e3 if size is not None else min(160.0, np.floor(0.6 * span / 10.0) * 10.0)
    if not (np.isfinite(side) and side > 0) or side > span:
        raise InputError(f"the square's side {side:g} mm does not fit {machine.name}'s travel ({span:g} mm across)",
                         parameters=("size",))
    cx, cy, z = (travel[:, 0] + travel[:, 1]) / 2.0
    half, tip, radius = side / 2.0, 0.45 * side, 0.3 * side
    others = "".join(f" {a}{(0.0 if 0.0 >= lo and 0.0 <= hi else (lo + hi) / 2):.4f}"
                     for a, (lo, hi) in zip(axes[3:], np.degrees(machine.travel[3:]) if len(axes) > 3 else []))
    lines = [f"(contouring test piece for {machine.name}: square {side:g} mm, diamond {2 * tip:g} mm across, "
             f"circle {2 * radius:g} mm, at Z {z:g})", "G17 G90 G21", f"G0 Z{z + 50:.4f}{others}",
             "(square)", f"G0 X{cx - half:.4f} Y{cy - half:.4f}", f"G0 Z{z:.4f}",
             f"G1 X{cx + half:.4f} F{feed:g}", f"G1 Y{cy + half:.4f}", f"G1 X{cx - half:.4f}", f"G1 Y{cy - half:.4f}",
             f"G0 Z{z + 50:.4f}", "(diamond)", f"G0 X{cx:.4f} Y{cy - tip:.4f}", f"G0 Z{z:.4f}",
             f"G1 X{cx + tip:.4f} Y{cy:.4f} F{feed:g}", f"G1 X{cx:.4f} Y{cy + tip:.4f}", f"G1 X{cx - tip:.4f} Y{cy:.4f}",
             f"G1 X{cx:.4f} Y{cy - tip:.4f}", f"G0 Z{z + 50:.4f}",
             "(circle)", f"G0 X{cx - radius:.4f} Y{cy:.4f}", f"G0 Z{z:.4f}",
             f"G2 X{cx - radius:.4f} Y{cy:.4f} I{radius:.4f} J0 F{feed:g}", f"G0 Z{z + 50:.4f}", "M30"]
    return "\n".join(lines) + "\n"
