"""Circle-point analysis: a joint's axis line from targets measured while it alone moves.

When one joint of a robot (or one rotary axis of a machine) turns and everything else
stands still, every target on the moving side runs on a circle about the joint's axis. From
a laser tracker's coordinates of those targets :func:`fit_axis` finds

- per target the best circle (a plane by orthogonal least squares, then the circle in that
  plane by geometric least squares): centre, radius, normal and the 3D distance of every
  point from it - the **per-axis fit residual**, tens of um on a good robot and tracker;
- the axis line: the normals' mean direction, oriented so that a positive joint motion
  turns the targets right-handed about it, through the least-squares point of the circle
  centres;
- the turned angle between the poses (the targets' mean, weighted by radius squared), against
  the commanded joint values: the **angle residual**, which holds joint angle transmission
  errors and a wrong joint scale.

:func:`axis_relation` gives the common normal of two axis lines: the angle between them and
their distance, the DH ``alpha`` and ``a`` of the link between them. Such axes are start
values for a kinematic model of the measured robot and a report of its geometry in their
own right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..base import InputError


@dataclass(frozen=True)
class Circle:
    """A fitted circle in 3D.

    ``centre`` (3,), unit ``normal`` (3,), ``radius``, and each point's 3D ``distance`` from
    the circle (same unit as the points).

    Attributes
    ----------
    centre : ndarray, shape (3,)
        Centre, in the unit of the points.
    normal : ndarray, shape (3,)
        Unit normal of the circle's plane (its sign is the SVD's).
    radius : float
        Radius, in the unit of the points.
    distance : ndarray, shape (n,)
        3D distance of each point from the circle, in the unit of the points.
    """

    centre: np.ndarray
    normal: np.ndarray
    radius: float
    distance: np.ndarray

    @property
    def rms(self) -> float:
        """RMS of the points' distances from the circle, in the unit of the points (float)."""
        return float(np.sqrt(np.mean(self.distance ** 2)))


def fit_circle(points: np.ndarray) -> Circle:
    """Best circle through 3D points (at least 3, not on one line).

    A plane by orthogonal least squares, then the circle in that plane by geometric least
    squares (an algebraic start, then Gauss-Newton).

    Parameters
    ----------
    points : array_like, shape (n, 3)
        The points, any length unit.

    Returns
    -------
    Circle
        The circle, in the unit of the points.

    Raises
    ------
    InputError
        If there are fewer than 3 distinct points or they lie on a line.
    """
    points = np.asarray(points, dtype=float)
    distinct = np.unique(np.round(points, 12), axis=0)
    if len(distinct) < 3:
        raise InputError(f"a circle needs at least 3 distinct points, got {len(distinct)}")
    mean = points.mean(axis=0)
    _, s, Vt = np.linalg.svd(points - mean)
    if s[1] < 1e-9 * max(s[0], 1e-300):
        raise InputError("the points lie on a line: no circle")
    u, v, normal = Vt
    xy = np.column_stack([(points - mean) @ u, (points - mean) @ v])
    # algebraic start (Kasa), then Gauss-Newton on the geometric distances
    A = np.column_stack([2 * xy, np.ones(len(xy))])
    c = np.linalg.lstsq(A, (xy ** 2).sum(axis=1), rcond=None)[0]
    centre2, radius = c[:2], math.sqrt(max(c[2] + c[:2] @ c[:2], 0.0))
    for _ in range(50):
        d = xy - centre2
        rho = np.linalg.norm(d, axis=1)
        r = rho - radius
        J = np.column_stack([-d / rho[:, None], -np.ones(len(xy))])
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        centre2, radius = centre2 + step[:2], radius + step[2]
        if np.abs(step).max() < 1e-15 * max(radius, 1.0):
            break
    in_plane = np.linalg.norm(xy - centre2, axis=1) - radius
    out_of_plane = (points - mean) @ normal
    return Circle(mean + centre2[0] * u + centre2[1] * v, normal, float(radius),
                  np.sqrt(in_plane ** 2 + out_of_plane ** 2))


@dataclass(frozen=True)
class Axis:
    """A joint's axis line with the circles it came from.

    The line (``point``, unit ``direction``) and the angle residuals (turned minus
    commanded, rad) of every pose after the first.

    Attributes
    ----------
    point : ndarray, shape (3,)
        A point on the axis, in the unit of the targets (the least-squares point of the
        circle centres).
    direction : ndarray, shape (3,)
        Unit direction, oriented so that a positive joint motion turns the targets
        right-handed about it.
    circles : tuple of Circle
        The circle of every target that moved.
    angle_residual : ndarray, shape (n - 1,)
        Turned minus commanded angle of every pose after the first [rad], wrapped to
        [-pi, pi).
    angle_scale : float
        Turned / commanded, fitted over the poses.
    """

    point: np.ndarray
    direction: np.ndarray
    circles: tuple[Circle, ...]
    angle_residual: np.ndarray
    angle_scale: float            # turned / commanded, fitted over the poses

    @property
    def rms(self) -> float:
        """RMS 3D distance of all points from their circles, in the unit of the targets (float)."""
        return float(np.sqrt(np.mean(np.concatenate([c.distance ** 2 for c in self.circles]))))

    @property
    def max(self) -> float:
        """Largest 3D distance of a point from its circle, in the unit of the targets (float)."""
        return float(max(c.distance.max() for c in self.circles))


def _wrap(angle):
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def fit_axis(targets: list[np.ndarray], joint_values: np.ndarray) -> Axis:
    """The axis of a joint from targets measured while it alone moves (see the module docstring).

    Parameters
    ----------
    targets : list of ndarray, each shape (n, 3)
        One target's positions at the n poses, per target, any one length unit (a target
        that does not move is left out).
    joint_values : ndarray, shape (n,)
        The commanded joint values [rad].

    Returns
    -------
    Axis
        The axis line, its circles and the angle residuals.

    Raises
    ------
    InputError
        If no target moved, or a target's points do not make a circle (see :func:`fit_circle`).
    """
    q = np.asarray(joint_values, dtype=float)
    spread = [float(np.linalg.norm(np.asarray(t) - np.mean(t, axis=0), axis=1).max()) for t in targets]
    # a target on the axis does not move: it says nothing about the axis and is left out
    targets = [np.asarray(t, dtype=float) for t, s in zip(targets, spread) if s > 1e-9 * max(spread, default=0.0)]
    if not targets or max(spread, default=0.0) == 0.0:
        raise InputError("no target moved: no axis")
    circles = [fit_circle(t) for t in targets]
    normals = np.array([c.normal for c in circles])
    normals *= np.sign(normals @ normals[0])[:, None]
    direction = normals.mean(axis=0)
    direction /= np.linalg.norm(direction)
    order = np.argsort(q)
    # right-handed about the axis for increasing joint values
    first = targets[0]
    turn = 0.0
    for a, b in zip(order[:-1], order[1:]):
        if q[b] - q[a] > 1e-12:
            va, vb = first[a] - circles[0].centre, first[b] - circles[0].centre
            turn += float(np.cross(va, vb) @ direction) * (1 if abs(q[b] - q[a]) < np.pi else 0)
    if turn < 0:
        direction = -direction
    # the point on the axis nearest to all circle centres
    P = np.eye(3) - np.outer(direction, direction)
    centres = np.array([c.centre for c in circles])
    point = np.linalg.lstsq(np.tile(P, (len(centres), 1)), (centres @ P.T).ravel(), rcond=None)[0]
    point = point - (point @ direction) * direction + (centres.mean(axis=0) @ direction) * direction
    # turned angle of each pose from the first, averaged over the targets
    e1 = np.cross(direction, [1.0, 0.0, 0.0])
    if np.linalg.norm(e1) < 0.1:
        e1 = np.cross(direction, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(direction, e1)
    # weighted by radius^2 (the least-squares angle of a rigid turn): a target near the axis
    # hardly says how far it turned
    sin_sum, cos_sum = 0.0, 0.0
    for t, c in zip(targets, circles):
        d = t - c.centre
        phase = np.arctan2(d @ e2, d @ e1) - math.atan2(d[0] @ e2, d[0] @ e1)
        sin_sum = sin_sum + c.radius ** 2 * np.sin(phase)
        cos_sum = cos_sum + c.radius ** 2 * np.cos(phase)
    turned = np.arctan2(sin_sum, cos_sum)
    commanded = q - q[0]
    # scale: turned ~ s * commanded (modulo full turns)
    s = float(commanded @ (commanded + _wrap(turned - commanded)) / max(commanded @ commanded, 1e-300))
    residual = _wrap(turned - commanded)[1:]
    return Axis(point, direction, tuple(circles), residual, s)


PARALLEL = 0.01  # rad: below it (or within it of 180 deg) the common normal is ill-defined


def axis_relation(a: Axis, b: Axis) -> dict:
    """Angle between two axis lines and their distance along the common normal.

    The DH alpha and a of the link between them. For (nearly) parallel axes the common
    normal runs off to infinity with the slightest tilt: then ``parallel`` is true and the
    distance is that of ``b.point`` from the line of ``a`` (the points are the centres'
    least-squares points, near the measured targets).

    Parameters
    ----------
    a, b : Axis
        The two axes.

    Returns
    -------
    dict
        ``angle`` (float, rad, 0..pi), ``distance`` (float, unit of the axes' points) and
        ``parallel`` (bool: the sine of the angle is below 0.01, parallel or antiparallel).
    """
    cross = np.cross(a.direction, b.direction)
    sine = float(np.linalg.norm(cross))
    angle = math.atan2(sine, float(a.direction @ b.direction))
    gap = b.point - a.point
    parallel = sine < PARALLEL
    if parallel:
        distance = float(np.linalg.norm(gap - (gap @ a.direction) * a.direction))
    else:
        distance = float(abs(gap @ cross) / sine)
    return {"angle": angle, "distance": distance, "parallel": parallel}


def _frame(point: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """A frame at ``point`` whose z is ``direction`` (x chosen from the world axes)."""
    z = direction / np.linalg.norm(direction)
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - (ref @ z) * z
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = point
    return T


def axes_to_urdf(axes: list[Axis], names: list[str], limits: list[tuple[float, float]], *,
                 name: str = "measured", base: str = "world", tool: str = "tool0") -> tuple[str, np.ndarray]:
    """A URDF of the serial chain whose revolute joints turn about the measured ``axes``.

    All measured in one configuration, the reference, in the ``base`` frame: joint value 0
    is that reference configuration.

    Parameters
    ----------
    axes : list of Axis
        The axes, base to tool, with points in m.
    names : list of str
        Joint names, one per axis.
    limits : list of tuple of (float, float)
        Lower and upper joint limits [rad], one pair per axis.
    name : str, default "measured"
        Robot name.
    base : str, default "world"
        Name of the base link.
    tool : str, default "tool0"
        Name of the tool link (fixed to the last joint's link).

    Returns
    -------
    text : str
        The URDF.
    tool_pose : ndarray, shape (4, 4)
        The tool frame's pose in the reference configuration (base frame, m): at the last
        axis, z along it.

    Raises
    ------
    InputError
        If ``axes``, ``names`` and ``limits`` differ in length.
    """
    from .dh import urdf_origin

    if not len(axes) == len(names) == len(limits):
        raise InputError(f"axes, names and limits must have one entry per joint; got {len(axes)}, {len(names)} "
                         f"and {len(limits)}", parameters=("axes", "names", "limits"))
    frames = [_frame(a.point, a.direction) for a in axes]
    lines = ['<?xml version="1.0"?>', f'<robot name="{name}">', f'  <link name="{base}"/>']
    parent, previous = base, np.eye(4)
    for frame, joint, (lower, upper) in zip(frames, names, limits):
        link = f"{joint}_link"
        lines += [f'  <link name="{link}"/>', f'  <joint name="{joint}" type="revolute">',
                  f'    <parent link="{parent}"/><child link="{link}"/>',
                  f"    {urdf_origin(np.linalg.inv(previous) @ frame)}", '    <axis xyz="0 0 1"/>',
                  f'    <limit lower="{lower!r}" upper="{upper!r}"/>', "  </joint>"]
        parent, previous = link, frame
    lines += [f'  <link name="{tool}"/>', f'  <joint name="{tool}_fixed" type="fixed">',
              f'    <parent link="{parent}"/><child link="{tool}"/>', '    <origin xyz="0 0 0" rpy="0 0 0"/>',
              "  </joint>", "</robot>", ""]
    return "\n".join(lines), frames[-1]
