"""Compensation: commanded positions that put the actual tool where the nominal one should be.

**Points.** For desired NC positions ``q_d`` the target is the nominal tool pose at ``q_d``;
the compensated command ``q_c`` makes the *actual* pose match it.

- ``method="recursive"``: seed 002's scheme, ``Xc(n) = Xd - sum_{i<n} e(i)`` with
  ``e(i) = X_actual(Xc(i)) - Xd`` (eqs. 15-21), generalised to any machine by mapping the
  position error through the nominal axis Jacobian (the identity on a Cartesian machine,
  where it is exactly the paper's recursion). It corrects positions only.
- ``method="newton"``: Gauss-Newton on the exact axis Jacobian of the actual machine. On
  machines with rotary axes it also corrects the tool axis (position rows plus the tool-axis
  direction weighted by ``lever`` metres per radian), which is the pose compensation of a
  5-axis head. Points whose solution leaves the travel are reported as unreachable.

**Paths** (seed 002). Rapid moves compensate their end point. Linear moves compensate both
ends, evaluate the residual along the commanded straight line (the controller interpolates in
axis space) against the desired path at the same parameter, split at the point of maximum
residual, and recurse until every point is within tolerance. Helical (and circular) moves
compensate start, middle and end, put a helical arc through the three compensated points
(circle through their projections, linear in the third axis: eqs. 25-29), and split likewise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .machine import Machine
from .units import UM_PER_M, URAD_PER_RAD
from .safeio import require_memory
from .workspace import _integer, _positive

#: deepest split of a move: 2^-60 of it is below double precision, and the recursion stays far
#: from Python's limit
MAX_DEPTH = 60
#: memory of one point compensated by :func:`compensate_points` (measured: 1.4-2.1 kB) [bytes]
COMPENSATION_BYTES = 2500
#: memory of a quarter turn of a compensated arc: its points, samples and pieces [bytes]
ARC_QUARTER_BYTES = 8 * COMPENSATION_BYTES



@dataclass
class PointCompensation:
    """Result of :func:`compensate_points` (SI).

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        Compensated commands [m, rad].
    residual : ndarray, shape (N,)
        Position residual ``|p_actual(q) - p_nominal(q_d)|`` [m].
    axis_residual : ndarray, shape (N,)
        Tool-axis residual (sine of the angle between actual and desired tool axes) [rad]; 0
        where the tool axis is not corrected.
    before : ndarray, shape (N,)
        Position error without compensation [m].
    axis_before : ndarray, shape (N,)
        Tool-axis error without compensation [rad].
    iterations : ndarray of int, shape (N,)
        Iterations used.
    converged : ndarray of bool, shape (N,)
        Within tolerance, or at the least-squares optimum.
    reachable : ndarray of bool, shape (N,)
        The compensated command lies within the travel.
    within_tolerance : ndarray of bool, shape (N,)
        Residuals below the tolerances.
    history : list of ndarray
        Recursive scheme: the position residual vectors, shape (N, 3) [m], per step; empty
        for Newton.
    """

    q: np.ndarray            # (N, n_axes) compensated commands
    residual: np.ndarray     # (N,) position residual |p_actual(q) - p_nominal(q_d)| [m]
    axis_residual: np.ndarray  # (N,) tool-axis residual [rad] (0 where not corrected)
    before: np.ndarray       # (N,) position error without compensation [m]
    axis_before: np.ndarray  # (N,) tool-axis error without compensation [rad]
    iterations: np.ndarray   # (N,) iterations used
    converged: np.ndarray    # (N,) bool: within tolerance, or at the least-squares optimum
    reachable: np.ndarray    # (N,) bool: within travel
    within_tolerance: np.ndarray  # (N,) bool: residuals below the tolerances
    history: list = field(default_factory=list)  # recursive scheme: residual vectors per step


def _tool_axis(R: np.ndarray) -> np.ndarray:
    return R[:, :, 2]


def _has_rotary(machine: Machine) -> bool:
    return any(k == "rotary" for k in machine.axis_kinds)


def compensate_points(machine: Machine, q_desired, *, method: str = "newton", tol_um: float = 0.01,
                      tol_urad: float = 0.1, max_iter: int = 30, orientation: bool | None = None,
                      lever: float = 0.1, **covariates) -> PointCompensation:
    """Compensated commands for the desired NC positions ``q_desired``, SI.

    The target is the nominal tool pose at ``q_desired``; the command makes the actual pose
    match it (see the module docstring for the two methods). Iterations stop when the position
    residual is below ``tol_um`` (and the tool-axis residual below ``tol_urad``), when the
    command stops moving (the least-squares optimum of a machine with fewer axes than error
    directions), or after ``max_iter``.

    Parameters
    ----------
    machine : Machine
        The machine (its errors, and a state set by :meth:`Machine.with_state`).
    q_desired : array_like, shape (N, n_axes)
        Desired NC positions [m, rad], within the travel.
    method : "newton" or "recursive", default "newton"
        Gauss-Newton on the exact axis Jacobian, or seed 002's recursion (positions only).
    tol_um : float, default 0.01
        Position tolerance [um]: iterations stop below it.
    tol_urad : float, default 0.1
        Tool-axis tolerance [urad] (when the tool axis is corrected).
    max_iter : int, default 30
        Iteration limit.
    orientation : bool, optional
        Also correct the tool axis (default: when the machine has rotary axes; never with
        ``method="recursive"``).
    lever : float, default 0.1
        Weight of the tool-axis direction against the position [m per rad]; also the column
        scale of rotary axes.
    **covariates
        As for :meth:`Machine.volumetric_error` (None values are dropped).

    Returns
    -------
    PointCompensation
        The commands, residuals before and after, and per-point status.

    Raises
    ------
    InputError
        If ``method`` is unknown, ``tol_um``, ``tol_urad`` or ``lever`` is not a positive
        finite number, ``max_iter`` is not a whole number >= 0, ``q_desired`` or the
        covariates are invalid, or ``q_desired`` holds more points than the free memory can
        compensate at once.
    """
    if method not in ("newton", "recursive"):
        raise InputError(f"method must be 'newton' or 'recursive', got {method!r}", parameters=("method",))
    tol_um, tol_urad, lever = _positive("tol_um", tol_um), _positive("tol_urad", tol_urad), _positive("lever", lever)
    max_iter = _integer("max_iter", max_iter, 0)
    q_d = machine.check_q(q_desired)
    # poses, Jacobians and the batched solve of every point at once
    require_memory(len(q_d) * COMPENSATION_BYTES, f"compensating {len(q_d):,} positions", ("q_desired",))
    n = len(q_d)
    orientation = _has_rotary(machine) if orientation is None else orientation
    if method == "recursive":
        orientation = False
    R_d, p_d = machine.tool_poses(q_d, nominal=True)
    a_d = _tool_axis(R_d)
    cov = {k: v for k, v in covariates.items() if v is not None}
    R0, p0 = machine.tool_poses(q_d, extrapolate=True, **cov)
    before = np.linalg.norm(p0 - p_d, axis=1)
    axis_before = np.linalg.norm(np.cross(_tool_axis(R0), a_d), axis=1)
    q = q_d.copy()
    iterations = np.zeros(n, dtype=int)
    done = np.zeros(n, dtype=bool)
    stationary = np.zeros(n, dtype=bool)
    history = []
    nominal_J = None
    # column scale: a radian of a rotary axis counts as ``lever`` metres
    scale = np.where(np.array(machine.axis_kinds) == "rotary", lever, 1.0)
    for it in range(max_iter + 1):
        R, p = machine.tool_poses(q, extrapolate=True, **cov)
        e = p - p_d
        a_err = np.linalg.norm(np.cross(_tool_axis(R), a_d), axis=1) if orientation else np.zeros(n)
        if method == "recursive":
            history.append(e.copy())
        res = np.linalg.norm(e, axis=1)
        within = (res < tol_um * 1e-6) & (a_err < tol_urad * 1e-6)
        done = within | stationary
        if done.all() or it == max_iter:
            break
        active = ~done
        iterations[active] += 1
        if method == "recursive":
            if nominal_J is None:
                nominal_J = machine.axis_jacobian(q_d, nominal=True, extrapolate=True)[:, :3, :]
            dq = _solve(nominal_J[active], e[active], scale, damping=1e-9)
        else:
            J = machine.axis_jacobian(q[active], extrapolate=True, **_take(cov, active))
            rows = [J[:, :3, :]]
            rhs = [e[active]]
            if orientation:
                a = _tool_axis(R[active])
                # d a / d q = omega x a = -[a]x omega
                rows.append(-np.einsum("nij,njk->nik", _skew(a), J[:, 3:, :]) * lever)
                rhs.append((a - a_d[active]) * lever)
            dq = _solve(np.concatenate(rows, axis=1), np.concatenate(rhs, axis=1), scale)
        q[active] -= dq
        # a machine with fewer axes than error directions (a 2-axis lathe) stops at the
        # least-squares optimum: the part of the error no axis can move is left
        stationary[active] = np.max(np.abs(dq) * scale, axis=1) < 1e-13
    reachable = ~machine.outside_travel(q).any(axis=1)
    return PointCompensation(q, res, a_err, before, axis_before, iterations, done, reachable, within, history)


def _take(cov: dict, mask: np.ndarray) -> dict:
    out = {}
    for k, v in cov.items():
        out[k] = {s: a[mask] for s, a in v.items()} if isinstance(v, dict) else np.asarray(v)[mask]
    return out


def _skew(a: np.ndarray) -> np.ndarray:
    S = np.zeros((len(a), 3, 3))
    S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -a[:, 2], a[:, 1], -a[:, 0]
    S[:, 1, 0], S[:, 2, 0], S[:, 2, 1] = a[:, 2], -a[:, 1], a[:, 0]
    return S


def _solve(J: np.ndarray, r: np.ndarray, scale: np.ndarray, damping: float = 0.05) -> np.ndarray:
    """Batched damped least squares ``J dq = r`` in scaled columns (``dq = x / scale``).

    The corrections sought are micrometres; near a singular pose (a rotary axis parallel to
    the tool axis) an undamped step would be huge. With damping ``lambda`` the scaled step
    in a direction of singular value ``s`` is ``s r / (s^2 + lambda^2)``, at most
    ``|r| / (2 lambda)``: well-conditioned directions converge as Newton, singular ones
    stay put (and the residual there is reported, not hidden)."""
    Js = J / scale[None, None, :]
    JT = np.swapaxes(Js, 1, 2)
    A = JT @ Js + damping**2 * np.eye(J.shape[2])[None]
    x = np.linalg.solve(A, np.einsum("nij,nj->ni", JT, r)[..., None])[..., 0]
    return x / scale[None, :]


# ------------------------------------------------------------------------------ paths
@dataclass
class Piece:
    """One commanded piece of a compensated path (SI).

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
        Max residual along the piece [m].
    k0, k1 : float
        Parameter range on the original move (0 to 1).
    limited : bool
        The tolerance cannot be reached here by any command.
    """

    kind: str                 # "line" or "arc"
    start: np.ndarray         # compensated command at the start (n_axes,)
    end: np.ndarray           # compensated command at the end
    center: np.ndarray | None = None   # arc centre in the plane (2,), compensated
    clockwise: bool = False
    turns: float = 0.0        # signed swept angle [rad]
    residual: float = 0.0     # max residual along the piece [m]
    k0: float = 0.0           # parameter range on the original move
    k1: float = 1.0
    limited: bool = False     # the tolerance cannot be reached here by any command


@dataclass
class PathCompensation:
    """The compensated pieces of one programmed move.

    Attributes
    ----------
    pieces : list of Piece
        The commanded pieces, in order.
    max_residual : float
        Largest residual along the compensated pieces [m].
    max_before : float
        Largest residual along the uncompensated move [m].
    samples : int
        Samples per piece used to find the maximum residual (1 for a rapid move).
    """
    pieces: list[Piece]
    max_residual: float       # [m]
    max_before: float         # [m] along the uncompensated move
    samples: int

    @property
    def limited(self) -> bool:
        """True if any piece could not reach the tolerance (bool)."""
        return any(p.limited for p in self.pieces)


@dataclass(frozen=True)
class Arc:
    """A desired helical move in a plane; angles in radians.

    Attributes
    ----------
    plane : tuple of int (i, j, k)
        Indices of the machine axes of the arc plane and of the linear third axis.
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
    center: np.ndarray        # (2,) in the plane
    radius: float
    start_angle: float
    sweep: float              # signed: > 0 counter-clockwise
    start: np.ndarray         # (n_axes,) full desired start
    end: np.ndarray           # (n_axes,) full desired end
    end_radius: float | None = None  # when the end lies slightly off the start's circle

    def point(self, k: np.ndarray) -> np.ndarray:
        """Points at fractions ``k`` of the move.

        A small mismatch of start and end radius (as programs written to 4 decimals have) is
        spread linearly over the sweep, as controllers do, so that the arc ends exactly at the
        programmed end point. Axes other than the plane's move linearly.

        Parameters
        ----------
        k : float or ndarray, shape (M,)
            Fractions of the move, 0 (start) to 1 (end).

        Returns
        -------
        ndarray, shape (M, n_axes)
            NC positions [m, rad].
        """
        k = np.atleast_1d(k)
        i, j, l = self.plane
        out = self.start + np.outer(k, self.end - self.start)  # other axes linear
        ang = self.start_angle + k * self.sweep
        r = self.radius if self.end_radius is None else self.radius + k * (self.end_radius - self.radius)
        out[:, i] = self.center[0] + r * np.cos(ang)
        out[:, j] = self.center[1] + r * np.sin(ang)
        return out


def arc_from_center(start: np.ndarray, end: np.ndarray, center: np.ndarray, plane: tuple[int, int, int],
                    clockwise: bool, full_turns: int = 0) -> Arc:
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
        Indices of the plane's axes and of the third (helical) axis.
    clockwise : bool
        Sense of the move (G2 is clockwise).
    full_turns : int, default 0
        Additional full turns.

    Returns
    -------
    Arc
        The arc; a start and end on one point make a full circle.

    Raises
    ------
    InputError
        If a position or the centre is not finite, ``full_turns`` is not a whole number >= 0
        or more turns than the free memory can compensate, the radius is zero, or the start
        and end radii differ by more than 2 um (about what controllers accept).
    """
    full_turns = _integer("full_turns", full_turns, 0)
    # an arc is compensated in quarter turns, each a few compensated points and pieces
    require_memory(4 * (full_turns + 1) * ARC_QUARTER_BYTES, f"an arc of {full_turns + 1:,} turns", ("full_turns",))
    start, end, center = (np.asarray(v, dtype=float) for v in (start, end, center))
    for name, value in (("start", start), ("end", end), ("center", center)):
        if not np.all(np.isfinite(value)):
            raise InputError(f"{name} of the arc is not finite: {value}", parameters=(name,))
    i, j, _ = plane
    a0 = math.atan2(start[j] - center[1], start[i] - center[0])
    a1 = math.atan2(end[j] - center[1], end[i] - center[0])
    sweep = a1 - a0
    if clockwise:
        while sweep >= 0:
            sweep -= 2 * math.pi
    else:
        while sweep <= 0:
            sweep += 2 * math.pi
    sweep += (-1 if clockwise else 1) * 2 * math.pi * full_turns
    r0 = math.hypot(start[i] - center[0], start[j] - center[1])
    r1 = math.hypot(end[i] - center[0], end[j] - center[1])
    if r0 == 0.0:
        raise InputError("the arc starts at its centre: a radius of zero")
    if abs(r0 - r1) > 2e-6:  # 2 um, about what controllers accept
        raise InputError(f"arc start radius {r0 * 1e3:.4f} mm and end radius {r1 * 1e3:.4f} mm differ "
                         f"by {abs(r0 - r1) * 1e6:.1f} um")
    return Arc(plane, np.asarray(center, float), r0, a0, sweep, np.asarray(start, float), np.asarray(end, float),
               end_radius=r1)


def _circle_through(p1, p2, p3):
    """Centre and radius of the circle through three 2D points (None if collinear)."""
    ax, ay = p1
    bx, by = p2
    cx, cy = p3
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(d) < 1e-18:
        return None
    ux = ((ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) + (cx**2 + cy**2) * (ay - by)) / d
    uy = ((ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) + (cx**2 + cy**2) * (bx - ax)) / d
    return np.array([ux, uy]), math.hypot(ax - ux, ay - uy)


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
        Samples per piece when searching the maximum residual.
    max_depth : int, default 14
        Deepest recursive split.
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
        self.orientation = _has_rotary(machine)
        # tool-axis tolerance (default 10 urad per um): the tool-axis angle counts as
        # ``lever`` x angle against the position tolerance
        self.tol_urad = 10.0 * tol_um if tol_urad is None else tol_urad
        self.lever = tol_um / self.tol_urad

    # point helpers -----------------------------------------------------------------
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
        """
        res = compensate_points(self.machine, q_d, method=self.method,
                                tol_um=min(0.01, self.tol * 1e6 / 20), tol_urad=min(0.1, self.tol_urad / 20),
                                lever=self.lever)
        return res.q

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
        """
        return self.points(q_d[None, :])[0]

    def _floor(self, c: np.ndarray, q_d: np.ndarray) -> float:
        return float(self._residual(c[None, :], q_d[None, :])[0])

    def _residual(self, commanded: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """Pose residual of the actual tool at ``commanded`` against the nominal tool at
        ``desired``: position [m]; on machines with rotary axes the larger of that and the
        tool-axis angle times ``lever`` (0.1 m: 1 um of tolerance per 10 urad)."""
        m = self.machine
        R, p = m.tool_poses(commanded, extrapolate=True)
        R_d, p_d = m.tool_poses(desired, nominal=True, extrapolate=True)
        res = np.linalg.norm(p - p_d, axis=1)
        if self.orientation:
            axis_err = np.linalg.norm(np.cross(R[:, :, 2], R_d[:, :, 2]), axis=1)
            res = np.maximum(res, axis_err * self.lever)
        return res

    def _max_along(self, commanded_of_k, desired_of_k, k0, k1):
        """Maximum residual over [k0, k1] (dense samples, then a local refinement)."""
        k = np.linspace(k0, k1, self.samples + 1)
        r = self._residual(commanded_of_k(k), desired_of_k(k))
        i = int(np.argmax(r))
        lo, hi = k[max(i - 1, 0)], k[min(i + 1, len(k) - 1)]
        kk = np.linspace(lo, hi, 17)
        rr = self._residual(commanded_of_k(kk), desired_of_k(kk))
        j = int(np.argmax(rr))
        return (rr[j], kk[j]) if rr[j] > r[i] else (r[i], k[i])

    # moves -------------------------------------------------------------------------
    def screen_lines(self, starts: np.ndarray, ends: np.ndarray, c0: np.ndarray, c1: np.ndarray):
        """Screen many straight moves at once.

        The sampled maximum residual along each commanded line ``c0 -> c1`` against the desired
        ``starts -> ends``, and along the desired line run uncompensated (two batched evaluations
        instead of two per move). Moves whose sampled maximum is well inside the tolerance need no
        splitting.

        Parameters
        ----------
        starts, ends : ndarray, shape (M, n_axes)
            Desired start and end of each move [m, rad].
        c0, c1 : ndarray, shape (M, n_axes)
            Compensated commands at the start and end [m, rad].

        Returns
        -------
        after : ndarray, shape (M,)
            Sampled maximum residual along each commanded line [m].
        before : ndarray, shape (M,)
            Sampled maximum residual along each desired line, uncompensated [m].
        """
        n = len(starts)
        k = np.linspace(0.0, 1.0, self.samples + 1)
        desired = (starts[:, None, :] + k[None, :, None] * (ends - starts)[:, None, :]).reshape(-1, starts.shape[1])
        commanded = (c0[:, None, :] + k[None, :, None] * (c1 - c0)[:, None, :]).reshape(-1, starts.shape[1])
        after = self._residual(commanded, desired).reshape(n, -1).max(axis=1)
        before = self._residual(desired, desired).reshape(n, -1).max(axis=1)
        return after, before

    def accept_line(self, q_start, q_end, c0, c1, residual: float, before: float) -> PathCompensation:
        """One piece for a move :meth:`screen_lines` found inside the tolerance.

        Parameters
        ----------
        q_start, q_end : ndarray, shape (n_axes,)
            Desired start and end [m, rad] (not used: the piece runs ``c0 -> c1``).
        c0, c1 : ndarray, shape (n_axes,)
            Compensated commands at the start and end [m, rad].
        residual : float
            The screened residual after compensation [m].
        before : float
            The screened residual without compensation [m].

        Returns
        -------
        PathCompensation
            A single line piece over the whole move.
        """
        piece = Piece("line", c0, c1, residual=float(residual), k0=0.0, k1=1.0)
        return PathCompensation([piece], float(residual), float(before), self.samples)

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
        """
        end = self.point(q_end) if end_c is None else end_c
        r = self._floor(end, q_end)
        before = self._floor(q_end, q_end)
        start = q_start.copy() if start_c is None else start_c
        return PathCompensation([Piece("line", start, end, residual=r, limited=r > self.tol)], r, before, 1)

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
        """
        desired = lambda k: q_start + np.outer(np.atleast_1d(k), q_end - q_start)
        before, _ = self._max_along(desired, desired, 0.0, 1.0)
        pieces: list[Piece] = []
        sc = self.point(q_start) if start_c is None else start_c
        self._line(desired, 0.0, 1.0, sc, self.point(q_end) if end_c is None else end_c, pieces, 0)
        return PathCompensation(pieces, max(p.residual for p in pieces), float(before), self.samples)

    def _split_point(self, desired_at, worst, k_split, k0, k1, depth):
        """The compensated command at the split point, or None when the piece is accepted:
        within tolerance, too deep, or the split point itself cannot be brought closer
        (singular pose): splitting there would not help."""
        if worst <= self.tol or depth >= self.max_depth or k_split in (k0, k1):
            return None
        q_d = desired_at(k_split)
        cm = self.point(q_d)
        if self._floor(cm, q_d) > 0.9 * worst:
            return None
        return cm

    def _line(self, desired, k0, k1, c0, c1, pieces, depth):
        commanded = lambda k: c0 + np.outer((np.atleast_1d(k) - k0) / (k1 - k0), c1 - c0)
        worst, k_split = self._max_along(commanded, desired, k0, k1)
        cm = self._split_point(lambda k: desired(k)[0], worst, k_split, k0, k1, depth)
        if cm is None:
            pieces.append(Piece("line", c0, c1, residual=float(worst), k0=k0, k1=k1,
                                limited=bool(worst > self.tol)))
            return
        self._line(desired, k0, k_split, c0, cm, pieces, depth + 1)
        self._line(desired, k_split, k1, cm, c1, pieces, depth + 1)

    @staticmethod
    def arc_sections(arc: Arc) -> np.ndarray:
        """Parameters of the quarter-turn sections an arc starts with.

        Parameters
        ----------
        arc : Arc
            The desired arc.

        Returns
        -------
        ndarray, shape (n + 1,)
            Fractions 0 to 1 bounding n sections of at most a quarter turn each.
        """
        n = max(1, math.ceil(abs(arc.sweep) / (math.pi / 2) - 1e-9))
        return np.linspace(0.0, 1.0, n + 1)

    def arc_points(self, arc: Arc) -> np.ndarray:
        """Parameters whose compensated commands the first level of :meth:`arc` needs.

        Section ends and middles, so that a caller can compensate many arcs in a batch.

        Parameters
        ----------
        arc : Arc
            The desired arc.

        Returns
        -------
        ndarray, shape (2 n - 1,)
            The inner section ends, then the section middles (fractions of the move).
        """
        ks = self.arc_sections(arc)
        return np.concatenate([ks[1:-1], 0.5 * (ks[:-1] + ks[1:])])

    def arc(self, arc: Arc, start_c: np.ndarray | None = None, end_c: np.ndarray | None = None,
            known: dict | None = None) -> PathCompensation:
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
        known : dict of float to ndarray, optional
            Compensated commands at fractions of the move already computed (see :meth:`arc_points`).

        Returns
        -------
        PathCompensation
            The arc (or, where degenerate, line) pieces.
        """
        before, _ = self._max_along(arc.point, arc.point, 0.0, 1.0)
        pieces: list[Piece] = []
        sc = self.point(arc.start) if start_c is None else start_c
        # a circle through three compensated points is well-posed only when they are well
        # apart: arcs of more than a quarter turn (full circles included) start as quarters
        self._known = dict(known or {})
        ks = self.arc_sections(arc)
        for k0, k1 in zip(ks[:-1], ks[1:]):
            if k1 == 1.0:
                ec = self.point(arc.end) if end_c is None else end_c
            else:
                ec = self._arc_point(arc, k1)
            self._arc(arc, k0, k1, sc, ec, pieces, 0)
            sc = ec
        self._known = {}
        return PathCompensation(pieces, max(p.residual for p in pieces), float(before), self.samples)

    def _arc_point(self, arc: Arc, k: float) -> np.ndarray:
        known = getattr(self, "_known", {})
        if k in known:
            return known[k]
        return self.point(arc.point(k)[0])

    def _arc(self, arc: Arc, k0, k1, c0, c1, pieces, depth):
        i, j, _ = arc.plane
        cm = self._arc_point(arc, 0.5 * (k0 + k1))
        fit = _circle_through(c0[[i, j]], cm[[i, j]], c1[[i, j]])
        if fit is None:  # degenerate: a straight piece
            self._line(arc.point, k0, k1, c0, c1, pieces, depth)
            return
        center, radius = fit
        a0 = math.atan2(c0[j] - center[1], c0[i] - center[0])
        am = math.atan2(cm[j] - center[1], cm[i] - center[0])
        a1 = math.atan2(c1[j] - center[1], c1[i] - center[0])
        ccw = arc.sweep > 0
        sweep = _sweep(a0, a1, ccw)
        mid = _sweep(a0, am, ccw)
        if abs(mid) > abs(sweep):  # the compensated middle does not lie between: fall back
            self._line(arc.point, k0, k1, c0, c1, pieces, depth)
            return

        def commanded(k):
            u = (np.atleast_1d(k) - k0) / (k1 - k0)
            out = c0 + np.outer(u, c1 - c0)
            ang = a0 + u * sweep
            out[:, i] = center[0] + radius * np.cos(ang)
            out[:, j] = center[1] + radius * np.sin(ang)
            return out

        worst, k_split = self._max_along(commanded, arc.point, k0, k1)
        cs = self._split_point(lambda k: arc.point(k)[0], worst, k_split, k0, k1, depth)
        if cs is None:
            pieces.append(Piece("arc", c0, c1, center=center, clockwise=not ccw, turns=sweep,
                                residual=float(worst), k0=k0, k1=k1, limited=bool(worst > self.tol)))
            return
        self._arc(arc, k0, k_split, c0, cs, pieces, depth + 1)
        self._arc(arc, k_split, k1, cs, c1, pieces, depth + 1)


def _sweep(a0: float, a1: float, ccw: bool) -> float:
    s = a1 - a0
    if ccw:
        while s <= 0:
            s += 2 * math.pi
    else:
        while s >= 0:
            s -= 2 * math.pi
    return s


def evaluate_compensation(machine: Machine, q: np.ndarray, **covariates) -> dict:
    """Predicted tool position error over ``q`` without and with point compensation.

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (N, n_axes)
        Desired NC positions [m, rad].
    **covariates
        Passed to :func:`compensate_points` (covariates, or its keyword options).

    Returns
    -------
    dict
        ``points``, ``reachable``, ``max_before_um``, ``rms_before_um``, ``max_after_um``,
        ``rms_after_um`` (over the reachable points; None if there are none) [um],
        ``reduction_percent`` (100 (1 - RMS after / RMS before) over the reachable points;
        None when there are none or they have no error) and
        ``max_iterations``; on machines with rotary axes also the tool-axis error
        ``max_axis_before_urad``, ``rms_axis_before_urad``, ``max_axis_after_urad``,
        ``rms_axis_after_urad`` [urad] and ``not_within_tolerance`` (count).

    Raises
    ------
    InputError
        If ``q`` holds no points, or ``q`` or the covariates are invalid.
    """
    res = compensate_points(machine, q, **covariates)
    if len(res.q) == 0:
        raise InputError("q holds no points: there is nothing to compensate", parameters=("q",))
    before, after = res.before * UM_PER_M, res.residual * UM_PER_M
    ok = res.reachable
    out = {"points": int(len(q)), "reachable": int(ok.sum()),
           "max_before_um": float(before.max()), "rms_before_um": float(np.sqrt(np.mean(before**2))),
           "max_after_um": float(after[ok].max()) if ok.any() else None,
           "rms_after_um": float(np.sqrt(np.mean(after[ok] ** 2))) if ok.any() else None,
           "reduction_percent": float(100 * (1 - np.sqrt(np.mean(after[ok] ** 2)) / np.sqrt(np.mean(before[ok] ** 2))))
           if ok.any() and np.any(before[ok] > 0) else None,
           "max_iterations": int(res.iterations.max()) if len(q) else 0}
    if _has_rotary(machine):
        axis_before = res.axis_before * URAD_PER_RAD
        out["max_axis_before_urad"] = float(axis_before.max())
        axis_after = (res.axis_residual * URAD_PER_RAD)[ok]
        out["rms_axis_before_urad"] = float(np.sqrt(np.mean(axis_before**2)))
        out["max_axis_after_urad"] = float(axis_after.max()) if ok.any() else None
        out["rms_axis_after_urad"] = float(np.sqrt(np.mean(axis_after**2))) if ok.any() else None
        out["not_within_tolerance"] = int((~res.within_tolerance).sum())
    return out
