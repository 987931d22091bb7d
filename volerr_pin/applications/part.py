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

Conventions: positions in m, deviations in um in the reports; programs in axes programming
(axis positions), as ``compensate`` reads them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..base.errors import InputError
from ..base.units import UM_PER_M
from ..model.machine import Machine

__all__ = ["PathDeviation", "CircleFeature", "LineFeature", "PairFeature", "deviation_along", "fit_circle",
           "fit_line", "circle_features", "side_features", "feature_ranking", "normal_part"]

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

    @property
    def max_um(self) -> float:
        """The largest normal deviation over the path [um]."""
        return float(np.linalg.norm(self.normal, axis=1).max() * UM_PER_M) if len(self.normal) else 0.0


def _tool_points(machine: Machine, q: np.ndarray) -> np.ndarray:
    return machine.tool_poses(q, nominal=True, extrapolate=True)[1]   # tangent steps may touch the ends


def _evaluate(machine: Machine, segment, k: np.ndarray):
    q = _positions(segment, k)
    point = _tool_points(machine, q)
    ahead = np.clip(k + TANGENT_STEP, 0.0, 1.0)
    behind = np.clip(k - TANGENT_STEP, 0.0, 1.0)
    step = _tool_points(machine, _positions(segment, ahead)) - _tool_points(machine, _positions(segment, behind))
    length = np.linalg.norm(step, axis=1)
    moving = length > 1e-12 * max(1.0, float(np.abs(point).max(initial=0.0)))
    tangent = np.zeros_like(step)
    tangent[moving] = step[moving] / length[moving, None]
    error = machine.volumetric_error(q)[:, :3]
    return q, point, tangent, error, normal_part(error, tangent)


def _check_travel(machine: Machine, segment, q: np.ndarray) -> None:
    """A move that leaves the travel is refused, naming its line: the model is not extrapolated
    into a part."""
    outside = machine.outside_travel(q)
    if outside.any():
        row, axis = np.argwhere(outside)[0]
        unit, scale = ("deg", 180.0 / np.pi) if machine.axis_kinds[axis] == "rotary" else ("mm", 1e3)
        low, high = machine.travel[axis] * scale
        raise InputError(f"line {segment.line}: the move takes {machine.axes[axis]} to {q[row, axis] * scale:.4f} "
                         f"{unit}, outside its travel {low:g} .. {high:g} {unit}", parameters=("segments",))


def _positions(segment, k: np.ndarray) -> np.ndarray:
    if segment.kind == "arc":
        return segment.arc.point(k)
    return segment.start + np.outer(k, segment.end - segment.start)


def deviation_along(machine: Machine, segments, tolerance: float = 0.01e-6, *,
                    max_points: int = 2_000_000) -> PathDeviation:
    """The deviation of the tool from the programmed path along the cutting moves.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict (:meth:`Machine.with_state`: the part cold or
        warm, under load, with the axes' directions).
    segments : sequence of volerr_pin.compensation.gcode.Segment
        The program's moves (:func:`volerr_pin.compensation.gcode.interpret`); rapids are
        left out, as they cut nothing.
    tolerance : float, default 0.01e-6
        Sampling tolerance [m]: each move's samples are doubled until the normal deviation,
        interpolated linearly between neighbours, is within it of the model at every midpoint.
    max_points : int, default 2,000,000
        The most samples in all; more is refused, naming ``tolerance``.

    Returns
    -------
    PathDeviation

    Raises
    ------
    InputError
        If ``tolerance`` is not a positive number, a move is not in axes programming or leaves
        the travel (naming its line), or the samples would exceed ``max_points``.
    """
    if not (isinstance(tolerance, (int, float)) and np.isfinite(tolerance) and tolerance > 0):
        raise InputError(f"tolerance must be a positive number of metres, got {tolerance!r}", parameters=("tolerance",))
    cutting = [s for s in segments if s.kind in ("line", "arc")]
    parts = {name: [] for name in ("line", "move", "fraction", "q", "point", "tangent", "error", "normal")}
    total = 0
    for index, segment in enumerate(cutting):
        if segment.programming != "axes":
            raise InputError(f"line {segment.line}: the part is predicted for programs in axes programming; this "
                             "move is in tool-tip programming", parameters=("segments",))
        n = 3
        while True:
            k = np.linspace(0.0, 1.0, n)
            _check_travel(machine, segment, _positions(segment, k))
            values = _evaluate(machine, segment, k)
            mid = (k[:-1] + k[1:]) / 2.0
            at_mid = _evaluate(machine, segment, mid)[4]
            between = (values[4][:-1] + values[4][1:]) / 2.0
            if float(np.abs(at_mid - between).max(initial=0.0)) <= tolerance:
                break
            if total + 2 * n > max_points:
                raise InputError(f"line {segment.line}: sampling the path to {tolerance * UM_PER_M:g} um takes more "
                                 f"than {max_points:,} points; give a larger tolerance", parameters=("tolerance",))
            n = 2 * n - 1
        total += n
        for name, value in zip(("q", "point", "tangent", "error", "normal"), values):
            parts[name].append(value)
        parts["line"].append(np.full(n, segment.line))
        parts["move"].append(np.full(n, index))
        parts["fraction"].append(k)
    if not cutting:
        raise InputError("the program has no cutting move (lines or arcs)", parameters=("segments",))
    joined = {name: np.concatenate(values) for name, values in parts.items()}
    return PathDeviation(tolerance=float(tolerance), **joined)


def fit_circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares circle through points of a plane (Gauss-Newton on the geometric
    distances, from the algebraic fit).

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Points [m], N >= 3, not on one line.

    Returns
    -------
    centre : ndarray, shape (2,)
    radius : float
        The circle minimising the sum of squared distances of the points from it.
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 3:
        raise InputError(f"fit_circle needs (N >= 3, 2) points, got shape {points.shape}", parameters=("points",))
    shift = points.mean(axis=0)
    x = points - shift
    design = np.c_[2 * x, np.ones(len(x))]
    solution, *_ = np.linalg.lstsq(design, np.sum(x ** 2, axis=1), rcond=None)
    centre = solution[:2]
    radius = float(np.sqrt(solution[2] + centre @ centre))
    for _ in range(50):
        offset = x - centre
        r = np.linalg.norm(offset, axis=1)
        jacobian = np.c_[-offset / r[:, None], -np.ones(len(x))]
        step, *_ = np.linalg.lstsq(jacobian, -(r - radius), rcond=None)
        centre, radius = centre + step[:2], radius + float(step[2])
        if np.abs(step).max() < 1e-15 * max(1.0, radius):
            break
    return centre + shift, radius


@dataclass(frozen=True)
class CircleFeature:
    """A full circle of the program, as a CMM reports it.

    Attributes
    ----------
    lines : tuple of int
        The blocks it comes from.
    plane : tuple of int
        The workpiece-frame coordinates of its plane (0, 1: xy).
    centre : ndarray, shape (2,)
        Nominal centre in the plane [m].
    radius : float
        Nominal radius [m].
    circularity_um, diameter_error_um, centre_error_um : float
        Roundness deviation about the least-squares circle, fitted minus nominal diameter, and
        the distance of the fitted centre from the nominal one [um].
    fitted_centre : ndarray, shape (2,)
        Least-squares centre [m].
    angle : ndarray, shape (M,)
        Angle of each sample about the nominal centre [rad].
    radial_um : ndarray, shape (M,)
        Each measured point's distance from the least-squares centre minus the least-squares
        radius [um].
    turn : float
        The angle the arcs turn through [rad] (a whole turn or more).
    """

    lines: tuple[int, ...]
    plane: tuple[int, int]
    centre: np.ndarray
    radius: float
    circularity_um: float
    diameter_error_um: float
    centre_error_um: float
    fitted_centre: np.ndarray
    angle: np.ndarray
    radial_um: np.ndarray
    turn: float

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um)."""
        return {"kind": "circle", "name": "roundness, diameter and centre of a circle (ISO 12181-1, least squares)",
                "lines": list(self.lines), "plane": "xyz"[self.plane[0]] + "xyz"[self.plane[1]],
                "centre_mm": (self.centre * 1e3).tolist(), "diameter_mm": 2e3 * self.radius,
                "circularity_um": self.circularity_um, "diameter_error_um": self.diameter_error_um,
                "centre_error_um": self.centre_error_um}


def _full_circles(segments) -> list[list]:
    """Runs of consecutive arcs of one plane, centre and radius turning at least a whole turn."""
    runs, current = [], []

    def same(a, b):
        return (a.plane == b.plane and np.allclose(a.center, b.center, atol=1e-9)
                and abs(a.radius - b.radius) <= 1e-9)

    for segment in [s for s in segments if s.kind in ("line", "arc")] + [None]:
        arc = getattr(segment, "arc", None) if segment is not None else None
        if arc is not None and segment.kind == "arc" and (not current or same(current[-1].arc, arc)):
            current.append(segment)
            continue
        if current and abs(sum(s.arc.sweep for s in current)) >= 2 * np.pi - 1e-9:
            runs.append(current)
        current = [segment] if arc is not None and segment.kind == "arc" else []
    return runs


def circle_features(machine: Machine, segments, points_per_turn: int = 3600) -> list[CircleFeature]:
    """The full circles of a program, measured on the predicted part.

    Each circle is measured at ``points_per_turn`` points evenly spread over its turn (as a
    CMM scans it; the path's own samples are spaced for its tolerance, not for a fit).

    Parameters
    ----------
    machine : Machine
        The machine. The arcs' plane coordinates are axis positions; the circle is measured in
        the same coordinates of the workpiece frame, which a machine whose linear axes are the
        frame's x, y, z (every bundled 3- and 5-axis machining centre) follows.
    segments : sequence of Segment
        The program's moves (:func:`volerr_pin.compensation.gcode.interpret`).
    points_per_turn : int, default 3600
        Measured points per whole turn.

    Returns
    -------
    list of CircleFeature
        One per run of arcs of one centre and radius turning a whole turn, in program order.
    """
    out = []
    for run in _full_circles(segments):
        turn = sum(abs(s.arc.sweep) for s in run)
        nominal, cut = [], []
        for segment in run:
            n = max(3, int(round(points_per_turn * abs(segment.arc.sweep) / (2 * np.pi))))
            k = np.arange(n) / n   # the end is the next arc's start (or the first point again)
            _, point, _, _, normal = _evaluate(machine, segment, k)
            i, j, _ = segment.arc.plane
            nominal.append(point[:, [i, j]])
            cut.append(point[:, [i, j]] + normal[:, [i, j]])
        nominal, cut = np.concatenate(nominal), np.concatenate(cut)
        i, j, _ = run[0].arc.plane
        centre_nominal = _centre_in_frame(machine, run[0])
        centre, radius = fit_circle(cut)
        radial = np.linalg.norm(cut - centre, axis=1) - radius
        around = nominal - centre_nominal
        nominal_radius = float(np.median(np.linalg.norm(around, axis=1)))
        out.append(CircleFeature(
            lines=tuple(dict.fromkeys(s.line for s in run)), plane=(i, j), centre=centre_nominal,
            radius=nominal_radius, circularity_um=float(np.ptp(radial) * UM_PER_M),
            diameter_error_um=float(2 * (radius - nominal_radius) * UM_PER_M),
            centre_error_um=float(np.linalg.norm(centre - centre_nominal) * UM_PER_M), fitted_centre=centre,
            angle=np.arctan2(around[:, 1], around[:, 0]), radial_um=radial * UM_PER_M, turn=float(turn)))
    return out


def _centre_in_frame(machine: Machine, segment) -> np.ndarray:
    """The arc's centre as a nominal tool point in the workpiece frame, in its plane."""
    i, j, _ = segment.arc.plane
    q = segment.arc.start.copy()
    q[i], q[j] = segment.arc.center
    return _tool_points(machine, q[None, :])[0, [i, j]]


def fit_line(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The least-squares line through points of a plane (orthogonal distances).

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Points [m], N >= 2, not all equal.

    Returns
    -------
    centre : ndarray, shape (2,)
        The points' centroid, on the line.
    direction : ndarray, shape (2,)
        Unit direction of the line.
    normal : ndarray, shape (2,)
        Unit normal (the direction turned +90 degrees).
    """
    points = np.asarray(points, dtype=float)
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    direction = vt[0]
    return centre, direction, np.array([-direction[1], direction[0]])


@dataclass(frozen=True)
class LineFeature:
    """A straight side of the program (a cutting line in the contour plane), as a CMM reports it.

    Attributes
    ----------
    lines : tuple of int
        The block it comes from.
    plane : tuple of int
        The workpiece-frame coordinates of the contour plane.
    start, end : ndarray, shape (2,)
        Nominal ends in the plane [m].
    straightness_um : float
        ISO 12780: the range of the side's deviation about its least-squares line [um].
    contour : int
        Index of the contour (a run of cutting moves between rapids) it belongs to.
    """

    lines: tuple[int, ...]
    plane: tuple[int, int]
    start: np.ndarray
    end: np.ndarray
    straightness_um: float
    contour: int
    points: np.ndarray
    measured: np.ndarray
    q: np.ndarray
    tangent: np.ndarray

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.end - self.start))

    @property
    def direction(self) -> np.ndarray:
        return (self.end - self.start) / self.length

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um)."""
        return {"kind": "straightness", "name": "straightness of a side (ISO 12780, least squares)",
                "lines": list(self.lines), "plane": "xyz"[self.plane[0]] + "xyz"[self.plane[1]],
                "start_mm": (self.start * 1e3).tolist(), "end_mm": (self.end * 1e3).tolist(),
                "length_mm": self.length * 1e3, "straightness_um": self.straightness_um}


@dataclass(frozen=True)
class PairFeature:
    """Squareness or parallelism of one side to another of the same contour (ISO 1101).

    The datum is the first side's least-squares line; the value is the width of the zone,
    perpendicular to (squareness) or parallel to (parallelism) the datum, that holds every
    point of the second side [um].

    Attributes
    ----------
    kind : str
        "squareness" or "parallelism".
    datum, toleranced : int
        Indices of the two sides in :func:`side_features`' list.
    lines : tuple of int
        The blocks of the datum and of the toleranced side.
    value_um : float
        The zone's width [um].
    """

    kind: str
    datum: int
    toleranced: int
    lines: tuple[int, ...]
    value_um: float

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um)."""
        return {"kind": self.kind, "name": f"{self.kind} of a side to a datum side (ISO 1101)",
                "lines": list(self.lines), "datum_line": self.lines[0], f"{self.kind}_um": self.value_um}


def _contours(segments) -> list[list]:
    """The program's cutting moves grouped in contours: runs between rapids."""
    runs, current = [], []
    for segment in segments:
        if segment.kind == "rapid":
            if current:
                runs.append(current)
            current = []
        elif segment.kind in ("line", "arc"):
            current.append(segment)
    if current:
        runs.append(current)
    return runs


def side_features(machine: Machine, segments, plane: tuple[int, int] = (0, 1), min_length: float = 5e-3,
                  points_per_mm: float = 2.0) -> tuple[list[LineFeature], list[PairFeature]]:
    """The straight sides of a program and the squareness and parallelism of each pair of
    sides of one contour, measured on the predicted part.

    A side is a cutting line in the contour plane (its third coordinate constant) at least
    ``min_length`` long, measured at ``points_per_mm`` points per millimetre (at least 50).
    Pairs are taken within a contour (a run of cutting moves between rapids), the earlier side
    the datum: perpendicular sides give squareness, parallel ones parallelism; sides at other
    angles give neither.

    Parameters
    ----------
    machine : Machine
        The machine (see :func:`circle_features` for the coordinates).
    segments : sequence of Segment
        The program's moves.
    plane : tuple of int, default (0, 1)
        The contour plane's coordinates (0, 1: xy).
    min_length : float, default 5e-3
        The shortest side measured [m].
    points_per_mm : float, default 2.0
        Measured points per millimetre of a side.

    Returns
    -------
    sides : list of LineFeature
    pairs : list of PairFeature
    """
    i, j = plane
    third = ({0, 1, 2} - {i, j}).pop()
    sides: list[LineFeature] = []
    for number, contour in enumerate(_contours(segments)):
        for segment in contour:
            if segment.kind != "line":
                continue
            ends = _tool_points(machine, np.vstack([segment.start, segment.end]))
            length = float(np.linalg.norm(ends[1, [i, j]] - ends[0, [i, j]]))
            if length < min_length or abs(ends[1, third] - ends[0, third]) > 1e-9:
                continue
            n = max(50, int(np.ceil(length * 1e3 * points_per_mm)) + 1)
            k = np.linspace(0.0, 1.0, n)
            _check_travel(machine, segment, _positions(segment, k))
            q, point, tangent, _, normal = _evaluate(machine, segment, k)
            measured = point[:, [i, j]] + normal[:, [i, j]]
            centre, _, across = fit_line(measured)
            sides.append(LineFeature(
                lines=(segment.line,), plane=plane, start=ends[0, [i, j]], end=ends[1, [i, j]],
                straightness_um=float(np.ptp((measured - centre) @ across) * UM_PER_M), contour=number,
                points=point, measured=measured, q=q, tangent=tangent))
    pairs = []
    for a, datum in enumerate(sides):
        for b in range(a + 1, len(sides)):
            other = sides[b]
            if other.contour != datum.contour:
                continue
            cross = datum.direction[0] * other.direction[1] - datum.direction[1] * other.direction[0]
            if abs(cross) < 1e-9:
                kind = "parallelism"
            elif abs(datum.direction @ other.direction) < 1e-9:
                kind = "squareness"
            else:
                continue
            centre, along, across = fit_line(datum.measured)
            zone = (other.measured - centre) @ (across if kind == "parallelism" else along)
            pairs.append(PairFeature(kind=kind, datum=a, toleranced=b, lines=datum.lines + other.lines,
                                     value_um=float(np.ptp(zone) * UM_PER_M)))
    return sides, pairs


def _component_columns(machine: Machine) -> dict[str, list[int]]:
    """Each component's coefficient columns, in the machine's order."""
    out: dict[str, list[int]] = {}
    for term in machine.assembly.term_info():
        out.setdefault(term["component"], []).extend(machine.parameter_names.index(n) for n in term["parameters"])
    return out


def _contributions(machine: Machine, q: np.ndarray, tangent: np.ndarray, plane) -> dict[str, np.ndarray]:
    """Each component's first-order part of the normal deviation at ``q``, in the plane
    (M, 2) [m]: its coefficients times the exact sensitivities."""
    sensitivity = machine.sensitivity(q)[:, :3, :]
    theta = machine.theta
    out = {}
    for component, cols in _component_columns(machine).items():
        part = sensitivity[:, :, cols] @ theta[cols]
        out[component] = normal_part(part, tangent)[:, list(plane)]
    return out


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


def feature_ranking(machine: Machine, feature, sides: list[LineFeature] | None = None,
                    points_per_turn: int = 3600, segments=None) -> list[dict]:
    """Which error sources decide a feature: per component, the feature's profile it causes
    alone (to first order, from the exact sensitivities) and its share.

    The profile is what the feature's value is the range of: a circle's radial deviation less
    its least-squares circle, a side's deviation across it less its least-squares line, a pair's
    zone coordinate with the datum's least-squares line. Per component, ``alone_um`` is the
    range of its own profile (the feature if it acted alone) and ``share`` its share of the sum
    of the profiles' squares, as ``rank``'s share is of the tool point's mean square.

    Parameters
    ----------
    machine : Machine
        The machine.
    feature : CircleFeature, LineFeature or PairFeature
        The feature.
    sides : list of LineFeature, optional
        The sides, for a :class:`PairFeature`.
    points_per_turn : int, default 3600
        For a circle: as in :func:`circle_features`.
    segments : sequence of Segment, optional
        For a circle: the program's moves.

    Returns
    -------
    list of dict
        ``component``, ``alone_um``, ``share``; largest share first.
    """
    if isinstance(feature, CircleFeature):
        run = next(r for r in _full_circles(segments) if tuple(dict.fromkeys(s.line for s in r)) == feature.lines)
        q, tangent, point = [], [], []
        for segment in run:
            n = max(3, int(round(points_per_turn * abs(segment.arc.sweep) / (2 * np.pi))))
            values = _evaluate(machine, segment, np.arange(n) / n)
            q.append(values[0]), point.append(values[1]), tangent.append(values[2])
        q, point, tangent = np.concatenate(q), np.concatenate(point), np.concatenate(tangent)
        around = point[:, list(feature.plane)] - feature.centre
        radial = around / np.linalg.norm(around, axis=1)[:, None]
        angle = np.arctan2(around[:, 1], around[:, 0])
        basis = np.c_[np.ones_like(angle), np.cos(angle), np.sin(angle)]
        parts = _contributions(machine, q, tangent, feature.plane)
        return _rows({c: _without(np.sum(p * radial, axis=1), basis) for c, p in parts.items()})
    if isinstance(feature, LineFeature):
        along = (feature.points[:, list(feature.plane)] - feature.start) @ feature.direction
        across = np.array([-feature.direction[1], feature.direction[0]])
        basis = np.c_[np.ones_like(along), along]
        parts = _contributions(machine, feature.q, feature.tangent, feature.plane)
        return _rows({c: _without(p @ across, basis) for c, p in parts.items()})
    datum, other = sides[feature.datum], sides[feature.toleranced]
    u0 = datum.direction
    n0 = np.array([-u0[1], u0[0]])
    s = (datum.points[:, list(datum.plane)] - datum.start) @ u0
    s_other = other.points[:, list(other.plane)] - datum.start
    datum_parts = _contributions(machine, datum.q, datum.tangent, datum.plane)
    other_parts = _contributions(machine, other.q, other.tangent, other.plane)
    profiles = {}
    for c in datum_parts:
        slope = np.polyfit(s, datum_parts[c] @ n0, 1)[0]   # the datum line's turn, to first order
        if feature.kind == "parallelism":
            value = other_parts[c] @ n0 - slope * (s_other @ u0)
        else:
            value = other_parts[c] @ u0 + slope * (s_other @ n0)
        profiles[c] = value - value.mean()
    return _rows(profiles)
