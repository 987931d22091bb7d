"""The cone frustum of NAS 979 (ISO 10791-7:2020): found in a program, measured as a CMM
measures it, and written as a test piece.

A five-axis machine cuts the frustum with the flank of an end mill: the tool's axis lies along
a generator of the cone, and the tool's side touches the cone along the whole generator while
the tip goes round. So the programmed tool axes of such a contour are all generators of one
cone (the *axis cone*, coaxial with the part, offset by the tool's radius): they meet in its
apex, and they make one angle with its axis. :func:`find_cones` finds contours whose tool
axes do, and takes the part from them: the axis ``c`` (pointing to the spindle's side), the
half-angle ``alpha``, and whether the part is a boss (the apex above the tip: the tool is
outside the cone) or a bore.

Where the tool cuts. At each sample of the contour the tool touches the part on the line of
its flank nearest the cone's axis (a boss; the farthest for a bore): the points
``P(s) = T -+ r m + s w`` with ``T`` the tool point, ``w`` the tool axis (from the tip into the
spindle), ``m`` the unit normal of ``w`` pointing away from the cone's axis in the plane of the
two, and ``r`` the tool's radius. The point of that line at a section's height is a point of
the tool's body: where the machine puts it is the actual tool pose applied to its place in the
tool frame, ``P_act = R_act R_nom^T (P - T) + p_act``, the tool's orientation error included.

A section at height ``h`` (along ``c`` from the plane the tool's end cuts in) is measured as a
CMM measures it: each actual point's distance ``rho`` from the nominal axis, moved along the
cone's slope to the section's plane (``rho + kappa tan(alpha) (a_h - a)``, ``a`` the point's
axial coordinate from the apex, ``a_h`` the section's, ``kappa`` the sign of ``a_h``), at its
angle about the axis; the least-squares circle through these points; the circularity (ISO
12181-1, about the least-squares circle), the diameter error (fitted minus nominal) and the
centre error (the fitted centre's distance from the nominal axis). To first order the section
keeps what the surface keeps: the error normal to the cone, divided by ``cos(alpha)``; the
error along the surface (along the path, along the generator) moves no section.

Conventions: positions in m, angles in rad, deviations in um in the reports.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...base import InputError, feed_rate, integer
from ...model import Machine, check_covariates, outside_travel, tool_poses
from ._cmm import RoundFeature, measure_round
from ._testpiece import feed_word

__all__ = ["Cone", "ConeSection", "find_cones", "measure_cones", "cone_frustum_test_piece", "section_heights"]

#: how far the programmed tool axes of a cone may pass from its apex, and how much their angle
#: with its axis may differ [m, cos]: the program's words are rounded (0.1 um, 1e-4 deg)
APEX_TOLERANCE = 10e-6
ANGLE_TOLERANCE = 1e-5


@dataclass(frozen=True)
class Cone:
    """A cone the program cuts with the flank of its tool.

    Attributes
    ----------
    apex : ndarray, shape (3,)
        The part's apex in the workpiece frame [m] (the axis cone's, moved along the axis by the
        tool's radius).
    axis : ndarray, shape (3,)
        Unit axis, pointing to the spindle's side.
    half_angle : float
        [rad].
    boss : bool
        True for a boss (the tool outside the cone), False for a bore.
    bottom : float
        Axial coordinate (from the apex, along ``axis``) of the plane the tool's end cuts in [m].
    lines : tuple of int
        The blocks of the contour.
    moves : list of int
        The contour's moves among the program's cutting moves.
    tool_radius : float
        The tool's radius the part was taken with [m].
    tips : tuple of float
        Where the tool points go round: their mean axial coordinate from the apex and distance
        from the axis [m].
    """

    apex: np.ndarray
    axis: np.ndarray
    half_angle: float
    boss: bool
    bottom: float
    lines: tuple[int, ...]
    moves: list
    tool_radius: float
    tips: tuple[float, float] = (0.0, 0.0)

    def near_tips(self, points: np.ndarray, capture: float) -> np.ndarray:
        """Which tool points (N, 3) lie within ``capture`` of the circle this cone's tool points
        go round (axially and radially).

        Parameters
        ----------
        points : ndarray, shape (N, 3)
            Tool points in the workpiece frame [m].
        capture : float
            The largest axial and radial distance from the circle of :attr:`tips` [m].

        Returns
        -------
        ndarray of bool, shape (N,)
            True for the points within ``capture`` of it both axially and radially.
        """
        d = points - self.apex
        along = d @ self.axis
        radial = np.linalg.norm(d - np.outer(along, self.axis), axis=1)
        return (np.abs(along - self.tips[0]) <= capture) & (np.abs(radial - self.tips[1]) <= capture)

    def radius_at(self, height: float) -> float:
        """The part's nominal radius at ``height`` above the bottom [m].

        Parameters
        ----------
        height : float
            Height along the axis above the plane the tool's end cuts in [m].

        Returns
        -------
        float
            ``|bottom + height| tan(half_angle)`` [m].
        """
        return abs(self.bottom + height) * np.tan(self.half_angle)

    def basis(self) -> np.ndarray:
        """Two unit vectors normal to the axis, (2, 3): the section's coordinates.

        Returns
        -------
        ndarray, shape (2, 3)
            Orthonormal rows ``e1``, ``e2 = axis x e1`` in the workpiece frame.
        """
        helper = np.eye(3)[int(np.argmin(np.abs(self.axis)))]
        e1 = np.cross(self.axis, helper)
        e1 /= np.linalg.norm(e1)
        return np.vstack([e1, np.cross(self.axis, e1)])


@dataclass(frozen=True, kw_only=True)
class ConeSection(RoundFeature):
    """A section of a cone at a height, as a CMM reports it (the fields of
    :class:`~volerr_pin.applications.part.RoundFeature`, in the section's coordinates
    :meth:`Cone.basis` about the nominal axis, and these).

    Attributes
    ----------
    radius, circularity_um, diameter_error_um, centre_error_um, fitted_centre, angle, radial_um, q, covariates
        As in :class:`~volerr_pin.applications.part.RoundFeature`, in the section's coordinates.
    cone : Cone
    height : float
        Above the plane the tool's end cuts in, along the axis [m].
    arm : ndarray, shape (M, 3)
        The measured points' offsets from the tool point, nominal, workpiece frame [m].
    direction : ndarray, shape (M, 3)
        What a point's error counts in the section: its radial change per metre of error.
    """

    cone: Cone
    height: float
    arm: np.ndarray
    direction: np.ndarray

    @property
    def lines(self) -> tuple[int, ...]:
        """The blocks of the cone's contour."""
        return self.cone.lines

    def to_dict(self) -> dict:
        """The feature in the report's terms (ISO name, um).

        Returns
        -------
        dict
            JSON-ready: ``kind`` ("cone"), ``name``, ``blocks``, ``form`` ("boss" or "bore"),
            ``height_mm``, ``diameter_mm``, ``half_angle_deg``, ``axis``, ``tool_diameter_mm``,
            ``circularity_um``, ``diameter_error_um`` and ``centre_error_um``.
        """
        cone = self.cone
        return {"kind": "cone", "name": "roundness, diameter and centre of a cone's section at a height "
                                        "(ISO 12181-1, least squares)",
                "blocks": list(self.lines), "form": "boss" if cone.boss else "bore",
                "height_mm": round(self.height * 1e3, 9), "diameter_mm": float(2e3 * self.radius),
                "half_angle_deg": float(np.degrees(cone.half_angle)), "axis": cone.axis.tolist(),
                "tool_diameter_mm": 2e3 * cone.tool_radius,
                "circularity_um": self.circularity_um, "diameter_error_um": self.diameter_error_um,
                "centre_error_um": self.centre_error_um}

    def profiles(self, parts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each source's radial deviation in the section (``parts``: its first-order pose error
        (M, 6) at the measured points: dx, dy, dz, rx, ry, rz) less its least-squares circle.

        Parameters
        ----------
        parts : dict of str to ndarray, shape (M, 6)
            Per error source (component), its first-order pose error of the tool at the
            measured points [m, rad].

        Returns
        -------
        dict of str to ndarray, shape (M,)
            Per source, in the order of ``parts``, its profile [m].
        """
        moment = np.cross(self.arm, self.direction)
        radial = np.stack([np.sum(p[:, :3] * self.direction, axis=1) + np.sum(p[:, 3:] * moment, axis=1)
                           for p in parts.values()], axis=1)
        return dict(zip(parts, self.less_circle(radial).T))


def _fit(tips: np.ndarray, axes: np.ndarray):
    """The cone whose generators the tool axes are: (apex, unit axis, cos of the half-angle),
    or None when they are not (parallel, not through one point, not at one angle)."""
    spread = np.ptp(axes, axis=0).max()
    if spread < 1e-6:
        return None
    # the point nearest every line in the least-squares sense: sum (I - w w^T) (x - T) = 0
    normal = len(axes) * np.eye(3) - axes.T @ axes
    if np.linalg.cond(normal) > 1e8:
        return None
    along = np.sum(axes * tips, axis=1)
    apex = np.linalg.solve(normal, tips.sum(axis=0) - axes.T @ along)
    d = apex - tips
    off = np.linalg.norm(d - np.sum(d * axes, axis=1)[:, None] * axes, axis=1)
    if off.max() > APEX_TOLERANCE:
        return None
    _, vectors = np.linalg.eigh(np.cov((axes - axes.mean(axis=0)).T))
    axis = vectors[:, 0] * np.sign(vectors[:, 0] @ axes.mean(axis=0) or 1.0)
    cosine = axes @ axis
    if np.ptp(cosine) > ANGLE_TOLERANCE or cosine.mean() > 1.0 - 1e-9:
        return None
    return apex, axis, float(cosine.mean())


def _around(points: np.ndarray, apex: np.ndarray, axis: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Angles of points about the axis."""
    d = points - apex
    return np.arctan2(d @ basis[1], d @ basis[0])


def find_cones(machine: Machine, moves, contours: list[list[int]], cut, tool_radius: float = 0.0) -> list[Cone]:
    """The contours that cut a cone with the tool's flank, and their cones.

    Parameters
    ----------
    machine : Machine
        The machine.
    moves : MoveBatch
        The program's cutting moves (their ``line`` names a cone's blocks).
    contours : list of list of int
        Its contours (runs of cutting moves between rapids), as move indices.
    cut : volerr_pin.applications.part.Cut
        The cut's samples (its axis positions, within the travel).
    tool_radius : float, default 0
        The tool's radius [m]: the part is the axis cone offset by it.

    Returns
    -------
    list of Cone
        A contour is a cone's when the tool axes of its moves that turn the tool (that move a
        rotary axis; leads in and out at a fixed orientation are left out) are, at every sample, generators of one cone
        (within :data:`APEX_TOLERANCE` and :data:`ANGLE_TOLERANCE`) and its tool points go
        round the cone's axis (no gap above 10 degrees).

    Raises
    ------
    InputError
        If the tool's radius is too large for a cone's flank to be cut (naming
        ``tool_diameter``).
    """
    cones = []
    rotary = np.array(machine.axis_kinds) == "rotary"
    if not rotary.any():
        return cones   # the tool axis never turns
    # the moves that turn the tool (a lead-in or lead-out at a fixed orientation cuts no cone): those
    # whose rotary axes move over their samples (the cut's samples run move by move)
    starts = np.flatnonzero(np.r_[True, np.diff(cut.move) != 0])
    turned = cut.q[:, rotary]
    spread = (np.maximum.reduceat(turned, starts) - np.minimum.reduceat(turned, starts)).max(axis=1)
    turns = np.zeros(int(cut.move.max()) + 1, dtype=bool)
    turns[cut.move[starts]] = spread > 1e-12
    for contour in contours:
        turning = [m for m in contour if turns[m]]
        rows = cut.rows(turning)
        if len(rows) < 8:
            continue
        R, tips = tool_poses(machine.model, cut.q[rows], nominal=True)
        w = R[:, :, 2]
        contour = turning
        fitted = _fit(tips, w)
        if fitted is None:
            continue
        apex, axis, cosine = fitted
        helper = Cone(apex, axis, 0.0, True, 0.0, (), [], 0.0)
        angles = np.sort(_around(tips, apex, axis, helper.basis()))
        gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
        if gaps.max() > np.radians(10.0):
            continue
        below = (tips - apex) @ axis
        boss = bool(np.median(below) < 0.0)
        away = _away(tips, w, apex, axis)
        contact = tips - (1.0 if boss else -1.0) * tool_radius * away
        # the part: the axis cone offset by the tool's radius (towards the axis for a boss, away from
        # it for a bore), a cone of the same axis and angle whose apex is r / sin(alpha) lower in both
        part_apex = apex - tool_radius / np.sin(np.arccos(cosine)) * axis
        bottom = float(np.mean((contact - part_apex) @ axis))
        lines = tuple(dict.fromkeys(int(moves.line[m]) for m in contour))
        if (bottom >= 0.0) == boss:   # the tool's end beyond the apex: no frustum
            raise InputError(f"a tool diameter of {2e3 * tool_radius:g} mm cannot cut the cone of lines {lines[0]}.."
                             f"{lines[-1]} with its flank: the cone its flank would cut has its apex "
                             f"{abs(bottom) * 1e3:.3f} mm {'below' if boss else 'above'} the plane the tool's end "
                             "cuts in (give the cutter's diameter)", parameters=("tool_diameter",))
        d = tips - part_apex
        along = d @ axis
        radial = np.linalg.norm(d - np.outer(along, axis), axis=1)
        cones.append(Cone(part_apex, axis, float(np.arccos(cosine)), boss, bottom, lines, list(contour),
                          float(tool_radius), (float(along.mean()), float(radial.mean()))))
    return cones


def _away(points: np.ndarray, w: np.ndarray, apex: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Unit normals of the tool axes ``w`` pointing away from the cone's axis, in the plane of
    the two."""
    d = points - apex
    radial = d - np.outer(d @ axis, axis)
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    m = radial - np.sum(radial * w, axis=1)[:, None] * w
    return m / np.linalg.norm(m, axis=1)[:, None]


def measure_cones(machine: Machine, cones: list[Cone], cut, cone_heights, rows=None,
                  notes: list | None = None) -> list[ConeSection]:
    """Each cone's sections at ``cone_heights``, measured on the cut (:class:`ConeSection`).

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict.
    cones : list of Cone
        :func:`find_cones`.
    cut : volerr_pin.applications.part.Cut
        The cut's samples (nominal axis positions).
    cone_heights : sequence of float
        Heights above the plane the tool's end cuts in, along the cone's axis [m].
    rows : list of ndarray, optional
        Per cone, the samples of the cut that measure it, as a mask or as rows (default: those
        of its moves).
    notes : list, optional
        Where to say why a cone is not measured: its samples do not go all round it (a gap
        above 10 degrees, or fewer than 3 samples; a compensated program whose cut strays more
        than the capture from its reference's cone).

    Returns
    -------
    list of ConeSection

    Raises
    ------
    InputError
        If a height is negative or not below a boss's apex (naming ``cone_heights``).
    """
    for cone in cones:
        for height in cone_heights:
            if height < 0 or (cone.boss and cone.bottom + height >= 0.0):
                raise InputError(f"the cone of lines {cone.lines[0]}..{cone.lines[-1]} has no section at "
                                 f"{height * 1e3:g} mm: cone_heights run from 0 (where the tool's end cuts) to "
                                 f"{-cone.bottom * 1e3:.4g} mm (its apex)" if cone.boss else
                                 f"the cone of lines {cone.lines[0]}..{cone.lines[-1]} has no section at a negative "
                                 f"height ({height * 1e3:g} mm) of cone_heights", parameters=("cone_heights",))
    sections = []
    model, theta, state = machine.model, machine.theta, machine.state
    for number, cone in enumerate(cones):
        taken = cut.rows(cone.moves) if rows is None else rows[number]
        q, covariates = cut.q[taken], cut.at(taken)
        R, tips = tool_poses(model, q, nominal=True)
        basis = cone.basis()
        around = np.sort(_around(tips, cone.apex, cone.axis, basis)) if len(q) else np.zeros(0)
        gap = float(np.degrees(np.diff(np.r_[around, around[:1] + 2 * np.pi]).max())) if len(q) else 360.0
        if len(q) < 3 or gap > 10.0:
            if notes is not None:
                notes.append(f"the cone of lines {cone.lines[0]}..{cone.lines[-1]} is not measured: the cut has "
                             f"{len(q):,} points on it, not all round it (a gap of {gap:.1f} deg)")
            continue
        R_act, p_act = tool_poses(model, q, theta, check_covariates(model, len(q), covariates, state=state))
        w = R[:, :, 2]
        sign = 1.0 if cone.boss else -1.0
        contact = tips - sign * cone.tool_radius * _away(tips, w, cone.apex, cone.axis)
        for height in cone_heights:
            target = cone.bottom + height
            s = (target - (contact - cone.apex) @ cone.axis) / (w @ cone.axis)
            nominal = contact + s[:, None] * w
            arm = nominal - tips
            actual = np.einsum("nij,nkj,nk->ni", R_act, R, arm) + p_act
            d = actual - cone.apex
            along = d @ cone.axis
            radial = d - np.outer(along, cone.axis)
            kappa = np.sign(target)
            rho = np.linalg.norm(radial, axis=1) + kappa * np.tan(cone.half_angle) * (target - along)
            angle = np.arctan2(radial @ basis[1], radial @ basis[0])
            points = rho[:, None] * np.c_[np.cos(angle), np.sin(angle)]
            unit = np.cos(angle)[:, None] * basis[0] + np.sin(angle)[:, None] * basis[1]
            sections.append(ConeSection(
                cone=cone, height=float(height), **measure_round(points, np.zeros(2), cone.radius_at(height)),
                angle=angle, q=q, covariates=covariates, arm=arm,
                direction=unit - kappa * np.tan(cone.half_angle) * cone.axis))
    return sections


def _tool_axis(machine: Machine, q: np.ndarray) -> np.ndarray:
    """The nominal tool axis at axis positions (the grid and probes of :func:`_orient`, which
    may step past the travel's ends)."""
    return tool_poses(machine.model, q, nominal=True)[0][:, :, 2]


def _orient(machine: Machine, rotary: list[int], base: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Rotary axis positions that point the nominal tool axis along each target (N, 3), in
    order, each solved by Gauss-Newton from the one before (the first from the best of a grid
    over the travel), so that the axes move continuously."""
    travel = machine.travel[rotary]
    grid = np.stack(np.meshgrid(*[np.linspace(lo, hi, 73) for lo, hi in travel], indexing="ij"), -1).reshape(-1, 2)
    q = np.repeat(base[None], len(grid), axis=0)
    q[:, rotary] = grid
    guess = grid[int(np.argmin(np.linalg.norm(_tool_axis(machine, q) - targets[0], axis=1)))]
    out = np.empty((len(targets), 2))
    step = 1e-7
    for n, target in enumerate(targets):
        angles = guess.copy()
        for _ in range(30):
            probe = np.repeat(base[None], 5, axis=0)
            probe[:, rotary] = angles + np.array([[0, 0], [step, 0], [-step, 0], [0, step], [0, -step]])
            axes = _tool_axis(machine, probe)
            residual = axes[0] - target
            jacobian = np.c_[(axes[1] - axes[2]) / (2 * step), (axes[3] - axes[4]) / (2 * step)]
            delta, *_ = np.linalg.lstsq(jacobian, -residual, rcond=None)
            angles = angles + delta
            if np.abs(delta).max() < 1e-13:
                break
        probe = base.copy()
        probe[rotary] = angles
        if np.linalg.norm(_tool_axis(machine, probe[None])[0] - target) > 1e-9:
            raise InputError(f"{machine.name}'s rotary axes cannot point the tool along "
                             f"{np.round(target, 4).tolist()} (a generator of the cone frustum)")
        out[n] = guess = angles
    return out


#: the shortest move of the cone's turn [m]: ten units of the 4 decimals (of mm) a program writes
SHORTEST_MOVE = 1e-6
#: the test piece's height, and its sections' heights, as fractions of its base diameter and height
HEIGHT = 0.25
SECTIONS = (0.1, 0.5, 0.9)


def section_heights(size: float = 80e-3) -> list[float]:
    """Where the test piece of base diameter ``size`` [m] is measured: heights above its base [m].

    Parameters
    ----------
    size : float, default 80e-3
        The test piece's base diameter [m].

    Returns
    -------
    list of float
        The heights of its three sections, 10 %, 50 % and 90 % of its height (a quarter of
        ``size``) [m].
    """
    return [f * HEIGHT * size for f in SECTIONS]


def cone_frustum_test_piece(machine: Machine, size: float | None = None, tool_diameter: float = 20e-3,
                            feed: float = 500.0, steps: int = 1440, form: str = "boss") -> str:
    """A program of the cone frustum test piece's finishing cut, in the form of NAS 979 (ISO
    10791-7:2020): a cone of half-angle 15 degrees whose axis is tilted 10 degrees towards +X,
    its base ``size`` across and a quarter of that high, cut in one turn by the flank of an end
    mill whose axis lies along the cone's generators, in tool-tip programming (G43.4).

    The cone stands where the tool point is at mid travel with the rotary axes at 0, lowered by
    the frustum's height. The turn is ``steps`` straight moves of the tool tip (1440: a chord
    error of 0.1 um on an 80 mm base), the rotary axes found by Gauss-Newton on the nominal
    machine so that they move continuously.

    Parameters
    ----------
    machine : Machine
        A machine with linear X, Y, Z and two rotary axes that can point the tool along the
        cone's generators.
    size : float, optional
        Base diameter [m], default 80 mm.
    tool_diameter : float, default 20 mm
        The end mill's diameter [m].
    feed : float, default 500
        Feed rate [mm/min].
    steps : int, default 1440
        Moves in the turn.
    form : {"boss", "bore"}, default "boss"
        The frustum (a boss, narrowing upwards, the tool outside), or a conical bore of the same
        angles widening upwards from a bottom ``size`` across (the tool inside).

    Returns
    -------
    str
        The program; its first comment gives the geometry, its second the cutter's diameter and
        the three heights to measure it at (:func:`section_heights`).

    Raises
    ------
    InputError
        If the machine has not two rotary axes, cannot point the tool so, or the cut leaves
        its travel, the feed is not a feed rate, or the turn's moves are shorter than
        :data:`SHORTEST_MOVE`.
    """
    from ...compensation import programming_for

    rotary = [k for k, kind in enumerate(machine.axis_kinds) if kind == "rotary"]
    if len(rotary) != 2:
        raise InputError(f"{machine.name}: the cone frustum needs a five-axis machine (two rotary axes), it has "
                         f"{len(rotary)}")
    if form not in ("boss", "bore"):
        raise InputError(f"form must be 'boss' or 'bore', got {form!r}", parameters=("form",))
    feed = feed_rate("feed", feed)
    steps = integer("steps", steps, 8)
    diameter = 80e-3 if size is None else float(size)
    if not (np.isfinite(diameter) and diameter > 0):
        raise InputError(f"size (the base diameter) must be a positive length, got {diameter * 1e3:g} mm",
                         parameters=("size",))
    if np.pi * diameter / steps < SHORTEST_MOVE:
        raise InputError(f"a cone of {diameter * 1e3:g} mm base diameter in {steps} moves makes moves shorter than "
                         f"{SHORTEST_MOVE * 1e3:g} mm, which the program's 4 decimals cannot write (give a larger "
                         "size)",
                         parameters=("size",))
    if not (np.isfinite(tool_diameter) and 0 <= tool_diameter < diameter):
        raise InputError(f"tool_diameter must be a length from 0 to the base diameter ({diameter * 1e3:g} mm), got "
                         f"{tool_diameter * 1e3:g} mm", parameters=("tool_diameter",))
    alpha, tilt = np.radians(15.0), np.radians(10.0)
    height = diameter * HEIGHT
    base = np.where(np.array(machine.axis_kinds) == "rotary", 0.0, machine.mid_travel)
    for k in rotary:
        lo, hi = machine.travel[k]
        base[k] = 0.0 if lo <= 0.0 <= hi else (lo + hi) / 2.0
    origin = tool_poses(machine.model, base[None], nominal=True)[1][0] - np.array([0.0, 0.0, height])   # (mid travel)
    axis = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    e1 = np.cross([0.0, 1.0, 0.0], axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = np.linspace(0.0, 2 * np.pi, steps + 1)
    u = np.outer(np.cos(phi), e1) + np.outer(np.sin(phi), e2)
    side = 1.0 if form == "boss" else -1.0   # the radius narrows (boss) or widens (bore) upwards
    generator = np.cos(alpha) * axis - side * np.sin(alpha) * u
    outward = side * np.sin(alpha) * axis + np.cos(alpha) * u     # away from the axis, normal to the cone
    radius = tool_diameter / 2.0
    tips = origin + (diameter / 2.0) * u + side * radius * outward   # the tool on the side away from the material
    angles = _orient(machine, rotary, base, generator)
    words = np.repeat(base[None], len(phi), axis=0)
    words[:, rotary] = angles
    words[:, :3] = tips
    tip_mode = programming_for("tool-tip", machine)
    q = tip_mode.to_axes(words)
    outside = outside_travel(machine.model, q)
    if outside.any():
        axis_index = int(np.argwhere(outside)[0][1])
        if machine.axis_kinds[axis_index] == "rotary":   # the angles are the piece's, whatever its size
            raise InputError(f"{machine.name}: the cone frustum's tool axis, up to 25 deg from its Z, takes "
                             f"{machine.axes[axis_index]} outside its travel")
        raise InputError(f"{machine.name}: the cone frustum of size {diameter * 1e3:g} mm (base diameter) takes "
                         f"{machine.axes[axis_index]} outside its travel", parameters=("size",))
    names = [machine.axes[k] for k in rotary]
    heights = ", ".join(f"{h * 1e3:g}" for h in section_heights(diameter))

    def block(row, code):
        def word(value):
            return f"{round(float(value), 4) + 0.0:.4f}"   # + 0.0: no "-0.0000"

        rot = " ".join(f"{n}{word(np.degrees(a))}" for n, a in zip(names, row[rotary]))
        return f"{code} X{word(row[0] * 1e3)} Y{word(row[1] * 1e3)} Z{word(row[2] * 1e3)} {rot}"

    clear = words[0].copy()
    clear[:3] = tips[0] + 30e-3 * generator[0] + side * 5e-3 * outward[0]
    what = (f"cone frustum test piece for {machine.name} in the form of NAS 979: base {diameter * 1e3:g} mm across"
            if form == "boss" else f"conical bore for {machine.name}: bottom {diameter * 1e3:g} mm across")
    lines = [f"({what}, {height * 1e3:g} mm high, half-angle 15 deg, axis tilted 10 deg towards +X; flank cut by a "
             f"{tool_diameter * 1e3:g} mm end mill, tool tip programmed)",
             f"(measure it with the cutter's diameter {tool_diameter * 1e3:g} mm, at heights {heights} mm)",
             "G17 G90 G21", "G43.4 H1", block(clear, "G0"), block(words[0], "G1") + f" F{feed_word(feed)}"]
    lines += [block(row, "G1") for row in words[1:]]
    lines += [block(clear, "G0"), "G49", "M30"]
    return "\n".join(lines) + "\n"
