"""Finding a part's features in its program and measuring them on the cut, as a CMM measures
them.

Features: a full circle of the program (arcs of one centre and radius in one plane, turning a
whole turn) is measured as a CMM measures it: the deviated points in the circle's plane, the
least-squares circle through them, the circularity (ISO 12181-1's roundness deviation about
the least-squares reference circle: largest minus smallest distance from its centre), the
diameter error (twice the fitted minus the nominal radius) and the centre error (the distance
of the fitted centre from the nominal one). A straight side (a cutting line in the contour
plane) gives its straightness, and within a contour (cutting moves between rapids) its corners
give squareness and its opposite sides parallelism; a contour a five-axis machine cuts with
the tool's flank gives a cone's sections (:func:`~volerr_pin.applications.part.measure_cones`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...base import UM_PER_M, InputError
from ...model import Machine
from ._features import CircleFeature, LineFeature, PairFeature, blocks_text
from ._path import CuttingPath
from ._sampling import Cut, cut_of
from ._cmm import fit_line, measure_round
from ._cone import find_cones, measure_cones

__all__ = ["Features", "contour_plane", "measure"]


def _full_circles(moves: CuttingPath) -> list[list[int]]:
    """Runs of consecutive arcs of one contour, plane, centre and radius turning at least a
    whole turn (indices among the cutting moves)."""
    words = moves.moves
    sweep = words.sweep.tolist()   # (summed as plain floats, in order)

    def same(a, b):   # one plane, centre and radius
        return (bool((words.plane[a] == words.plane[b]).all())
                and np.allclose(words.center[a], words.center[b], atol=1e-9)
                and abs(float(words.r0[a]) - float(words.r0[b])) <= 1e-9)

    runs = []
    for contour in moves.contours:
        current: list[int] = []
        for m in contour + [None]:
            arc = m is not None and bool(moves.arc[m])
            if arc and (not current or same(current[-1], m)):
                current.append(m)
                continue
            if current and abs(sum(sweep[c] for c in current)) >= 2 * np.pi - 1e-9:
                runs.append(current)
            current = [m] if arc else []
    return runs


def _reference_features(machine: Machine, moves: CuttingPath, plane: tuple[int, int], min_length: float,
                        notes: list):
    """The circles and sides a program defines: (circles, sides) as dicts of their nominal
    geometry in the workpiece frame and the indices of their moves among the cutting moves; a
    full circle in another plane is named in ``notes``."""
    i, j = plane
    third = ({0, 1, 2} - {i, j}).pop()
    words = moves.moves
    circles = []
    for run in _full_circles(moves):
        first = run[0]
        letters = [machine.axes[a] for a in words.plane[first, :2]]   # the arc's plane, by the axes' letters
        if not all(letter in "XYZ" for letter in letters) or {"XYZ".index(c) for c in letters} != {i, j}:
            other = "".join(sorted(c.lower() for c in letters))
            notes.append(f"the full circle of line {moves.line[first]} lies in the {other} plane, not in the "
                         f"contour plane {'xyz'[i] + 'xyz'[j]}: it is measured in a prediction of that plane")
            continue
        start = moves.tool_points(moves.axes(np.array([first]), np.zeros(1)))[0]
        if moves.tool_tip[first]:   # the words are the tool tip's coordinates
            at = dict(zip(("XYZ".index(c) for c in letters), words.center[first]))
            centre = np.array([at[i], at[j]])
        else:                       # the centre's axis positions, as a tool point
            q = words.w0[first].copy()
            q[words.plane[first, :2]] = words.center[first]
            centre = moves.tool_points(q[None, :])[0, [i, j]]
        circles.append({"lines": tuple(dict.fromkeys(int(moves.line[m]) for m in run)), "centre": centre,
                        "radius": float(np.linalg.norm(start[[i, j]] - centre)), "height": float(start[third]),
                        "moves": run})
    lines = np.flatnonzero(~moves.arc)
    ends = moves.tool_points(moves.axes(np.repeat(lines, 2), np.tile([0.0, 1.0], len(lines)))).reshape(-1, 2, 3)
    end_of = dict(zip(lines.tolist(), ends))
    sides = []
    for number, contour in enumerate(moves.contours):
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
    such plane (five-axis moves, a cone's turn) takes the two coordinates it spreads over most.

    Parameters
    ----------
    cut : Cut
        The cut surface (:func:`~volerr_pin.applications.part.cut_of`).

    Returns
    -------
    tuple of (int, int)
        The plane's two coordinates (0, 1, 2 for x, y, z), ascending: (0, 1) for xy.
    """
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


def _largest_gap(values: np.ndarray, period: float | None) -> float:
    """The largest gap between sorted values (around a circle of ``period``, or along a line
    between the first and the last value); the whole period (infinity along a line) for none."""
    if not len(values):
        return np.inf if period is None else float(period)
    v = np.sort(values)
    if period is None:
        return float(np.diff(v).max()) if len(v) > 1 else np.inf
    return float(np.diff(np.r_[v, v[0] + period]).max())


def _strays(what: str, gap: float, near: "_Near", path: np.ndarray, capture: float) -> str:
    """The note on a reference's feature the cut does not follow: the stretch of it with no
    cut within the capture, and how far the cut runs from it."""
    far = float(near.tree.query(path)[0].max())
    return (f"{what} of the reference is not measured: the cut does not follow it (it leaves the "
            f"{capture * 1e3:g} mm capture for {gap * 1e3:.3f} mm of it, and runs up to {far * 1e3:.3f} mm from it "
            "in the plane); is the reference the program this one was made from?")


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


def measure(machine: Machine, moves, reference=None, *, plane: tuple[int, int] | None = None,
            min_length: float = 5e-3, spacing: float = 0.25e-3, capture: float = 0.2e-3,
            tool_diameter: float = 0.0, cone_heights=(0.0,)) -> Features:
    """The features a CMM reports of the part a program cuts.

    The features are those of ``reference`` (default: the program itself): each full circle
    (arcs of one centre and radius in the contour plane turning a whole turn) and each
    straight side (a cutting line in the plane at least ``min_length`` long), within a contour
    (cutting moves between rapids) its corners' squareness and its opposite sides' parallelism
    (the earlier side the datum), and each contour that cuts a cone with the tool's flank (five-axis,
    :func:`volerr_pin.applications.part.find_cones`), in sections at ``cone_heights``. They are
    measured on the cut: the program's cutting moves sampled at most ``spacing`` apart, where
    the tool actually is, a point cut again at the same axis positions and covariates measured
    once (:meth:`Cut.distinct`). A sample measures a feature of its own move; with a reference (a
    compensated program against the program it was made from), a sample measures the feature
    it lies within ``capture`` of (in the plane and in height; a side's ends, 1 % of its
    length, left out; a cone: its tool point within ``capture`` of the circle the reference's
    tool points go round). A circle or side of the reference is measured only where the cut
    follows it: a stretch of it longer than twice ``spacing`` (the most two samples of a cut
    along it lie apart) with no sample within ``capture`` means the cut leaves it, and the
    feature is named in ``notes`` with that stretch and how far the cut runs from it.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict. The moves' plane coordinates are axis positions;
        features are measured in the same coordinates of the workpiece frame, which a machine
        whose linear axes are the frame's x, y, z (every bundled machining centre) follows.
    moves : MoveBatch or CuttingPath
        The program's moves (:func:`volerr_pin.compensation.gcode.interpret`).
    reference : MoveBatch or CuttingPath, optional
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
        If a program has no cutting move, a move leaves the travel (naming its line), a cone
        has no section at a height, or the cut follows none of the reference's circles and
        sides.
    """
    moves = CuttingPath.of(machine, moves)
    reference = None if reference is None else CuttingPath.of(machine, reference)
    defining = reference if reference is not None else moves
    cut = cut_of(machine, moves, spacing)
    plane = contour_plane(cut) if plane is None else tuple(plane)
    i, j = plane
    third = ({0, 1, 2} - {i, j}).pop()
    notes: list[str] = []
    strays: list[str] = []   # the notes on the reference's circles and sides the cut does not follow
    circles_ref, sides_ref = _reference_features(machine, defining, plane, min_length, notes)
    flat, height = cut.actual[:, [i, j]], cut.actual[:, third]
    near = _Near(flat, height) if reference is not None else None
    circles = []
    for ref in circles_ref:
        if reference is None:
            rows = cut.distinct(cut.rows(ref["moves"]))
        else:
            turn = np.linspace(0.0, 2 * np.pi, max(8, int(np.ceil(2 * np.pi * ref["radius"] / capture)) + 1))
            path = ref["centre"] + ref["radius"] * np.c_[np.cos(turn), np.sin(turn)]
            rows = near.along(path, capture, ref["height"])
            rows = rows[np.abs(np.linalg.norm(flat[rows] - ref["centre"], axis=1) - ref["radius"]) <= capture]
            around = flat[rows] - ref["centre"]
            gap = ref["radius"] * _largest_gap(np.arctan2(around[:, 1], around[:, 0]), 2 * np.pi)
            if gap > 2 * spacing:
                strays.append(_strays(f"the circle of lines {blocks_text(ref['lines'])}", gap, near, path, capture))
                notes.append(strays[-1])
                continue
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
            rows = cut.distinct(cut.rows(ref["moves"]))
        else:
            rows = near.along(_on_segment(ref["start"], ref["end"], capture), capture, ref["height"])
            along = (flat[rows] - ref["start"]) @ direction
            across = (flat[rows] - ref["start"]) @ np.array([-direction[1], direction[0]])
            close = np.abs(across) <= capture
            rows = rows[close & (along >= 0.01 * length) & (along <= 0.99 * length)]
            inside = np.clip(along[close], 0.01 * length, 0.99 * length)
            gap = _largest_gap(np.r_[0.01 * length, inside, 0.99 * length], None)
            if gap > 2 * spacing:
                strays.append(_strays(f"the side of line {blocks_text(ref['lines'])}", gap, near,
                                      _on_segment(ref["start"], ref["end"], capture), capture))
                notes.append(strays[-1])
                continue
        if len(rows) < 3:
            continue
        points = flat[rows]
        centre, _, normal = fit_line(points)
        sides.append(LineFeature(lines=ref["lines"], plane=plane, start=ref["start"], end=ref["end"],
                                 straightness_um=float(np.ptp((points - centre) @ normal) * UM_PER_M),
                                 contour=ref["contour"], measured=points, q=cut.q[rows],
                                 covariates=cut.at(rows)))
    if strays and len(strays) == len(circles_ref) + len(sides_ref):
        raise InputError(f"the cut follows none of the reference's {len(strays)} circles and sides: {strays[0]}",
                         parameters=("reference",))
    pairs = []
    for datum, other, kind in _pairs(sides):
        centre, along, across = fit_line(datum.measured)
        zone = (other.measured - centre) @ (across if kind == "parallelism" else along)
        pairs.append(PairFeature(kind=kind, datum=datum, toleranced=other, value_um=float(np.ptp(zone) * UM_PER_M)))
    defining_cut = cut if reference is None else cut_of(machine, defining, spacing)
    cones = find_cones(machine, defining.moves, defining.contours, defining_cut, tool_diameter / 2.0)
    if reference is None:
        rows = [cut.distinct(cut.rows(cone.moves)) for cone in cones]
    else:
        rows = [cone.near_tips(cut.nominal, capture) for cone in cones]
    sections = measure_cones(machine, cones, cut, cone_heights, rows, notes)
    return Features(circles, sides, pairs, sections, notes)
