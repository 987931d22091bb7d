"""Where and when every flank point is generated: how the machine's spindles mesh at the
nominal configuration, the flank points of both flanks of every tooth on the line of action, and
the configurations that generate them (nominal geometry only, the same for every error).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ...base import MM, InputError, axis_scale, require_memory
from ...model import Machine, check_q, to_engineering, tool_poses
from ._geometry import GearPair

__all__ = ["BYTES_PER_FLANK_POINT", "FlankGrid", "Generation", "Mesh", "flank_grid", "generation_of", "mesh_of"]


#: memory a study holds per flank point (measured: about 780 bytes for all sources of gear_roller)
BYTES_PER_FLANK_POINT = 1000


@dataclass(frozen=True)
class Mesh:
    """How the machine's spindles mesh at the nominal configuration (all from nominal poses).

    Attributes
    ----------
    q0 : ndarray, shape (n_axes,)
        The nominal configuration [m, rad].
    work, tool : int
        Columns of the workpiece and the wheel spindle in ``q``.
    psi0 : float
        Polar angle of the pitch point in the workpiece frame at ``q0`` [rad].
    z0 : float
        Its axial position in the workpiece frame [m].
    kappa : float
        +1 or -1: d(psi) / d(workpiece spindle).
    ratio : float
        d(wheel spindle) / d(workpiece spindle) for rolling without slip.
    feed : int, optional
        Column of the feed axis (through rolling).
    feed_rate : float, default 1.0
        d(tool point's axial position) / d(feed axis), +1 or -1.
    """

    q0: np.ndarray
    work: int
    tool: int
    psi0: float
    z0: float
    kappa: float
    ratio: float
    feed: int | None = None
    feed_rate: float = 1.0


def mesh_of(machine: Machine, gear: GearPair, spindles: Sequence[str], at: Mapping | None,
            feed: str | None = None) -> Mesh:
    """How the spindles mesh, checked against the gear: the tool point on the pitch circle, the
    workpiece spindle turning about the gear axis, the wheel's spindle on its pitch radius.

    Parameters
    ----------
    machine : Machine
        The rolling machine.
    gear : GearPair
        The gear pair.
    spindles : sequence of str
        The workpiece and the wheel spindle.
    at : mapping of str to float, optional
        The nominal configuration (other axes at 0) [m, rad].
    feed : str, optional
        The feed axis of through rolling.

    Returns
    -------
    Mesh
        The mesh.

    Raises
    ------
    InputError
        Naming ``spindles``, ``at``, ``module``, ``teeth``, ``tool_teeth`` or ``feed`` when the
        machine does not roll this gear there.
    """
    axes = machine.axes
    if len(spindles) != 2:
        raise InputError(f"spindles must name the workpiece and the wheel spindle, got {spindles!r}",
                         parameters=("spindles",))
    cols = []
    for name in spindles:
        if name not in axes:
            raise InputError(f"spindle {name!r} is not an axis of {machine.name} (axes: {', '.join(axes)})",
                             parameters=("spindles",))
        if machine.axis_kinds[axes.index(name)] != "rotary":
            raise InputError(f"spindle {name!r} of {machine.name} is not a rotary axis", parameters=("spindles",))
        cols.append(axes.index(name))
    work, tool = cols
    if work == tool:
        raise InputError("spindles: the workpiece and the wheel spindle must differ", parameters=("spindles",))
    q0 = np.zeros(len(axes))
    for name, value in (at or {}).items():
        if name not in axes:
            raise InputError(f"at: {name!r} is not an axis of {machine.name} (axes: {', '.join(axes)})",
                             parameters=("at",))
        q0[axes.index(name)] = float(value)
    if machine.outside_travel(q0[None]).any():
        shown = ", ".join(f"{a}={v:g}" for a, v in zip(axes, to_engineering(machine, q0)))
        raise InputError(f"at: the nominal configuration ({shown}; mm, deg) is outside the travel of "
                         f"{machine.name}; give the other axes' positions", parameters=("at",))

    eps = 1e-6
    probe = np.repeat(q0[None], 3, axis=0)
    probe[1, work] += eps
    probe[2, tool] += eps
    _, p = tool_poses(machine.model, check_q(machine.model, probe, extrapolate=True), nominal=True)
    r = float(np.hypot(p[0, 0], p[0, 1]))
    if abs(r - gear.pitch_radius) > 1e-6:
        raise InputError(f"the tool point of {machine.name} is {r / MM:.4f} mm from the workpiece axis (the "
                         f"workpiece frame's z axis) at the nominal configuration; the gear's pitch radius "
                         f"(module x teeth / 2) is {gear.pitch_radius / MM:.4f} mm", parameters=("module", "teeth"))
    psi = np.arctan2(p[:, 1], p[:, 0])
    kappa = float(np.angle(np.exp(1j * (psi[1] - psi[0]))) / eps)
    if abs(abs(kappa) - 1) > 1e-3 or abs(p[1, 2] - p[0, 2]) > 1e-3 * eps * r:
        raise InputError(f"spindle {spindles[0]!r} of {machine.name} does not turn the workpiece about the "
                         f"workpiece frame's z axis", parameters=("spindles",))
    d_work, d_tool = p[1] - p[0], p[2] - p[0]
    tool_radius = float(np.linalg.norm(d_tool) / eps)
    if abs(tool_radius - gear.tool_pitch_radius) > 1e-3 * gear.tool_pitch_radius or abs(d_tool[2]) > 1e-3 * eps * r:
        raise InputError(f"spindle {spindles[1]!r} of {machine.name} turns the tool point on a radius of "
                         f"{tool_radius / MM:.3f} mm; the wheel's pitch radius (module x tool_teeth / 2) is "
                         f"{gear.tool_pitch_radius / MM:.3f} mm", parameters=("module", "tool_teeth"))
    if np.linalg.norm(np.cross(d_work, d_tool)) > 1e-6 * np.linalg.norm(d_work) * np.linalg.norm(d_tool):
        raise InputError(f"the tool point of {machine.name} is not on the line of centres: the two spindles move it "
                         f"in different directions, so the wheel cannot roll on the gear there")
    # rolling without slip: the wheel's pitch point does not move relative to the workpiece
    ratio = float(-np.dot(d_work, d_tool) / np.dot(d_tool, d_tool))
    mesh = Mesh(q0, work, tool, float(psi[0]), float(p[0, 2]), float(np.sign(kappa)), ratio)
    if feed is None:
        return mesh
    if feed not in axes or machine.axis_kinds[axes.index(feed)] != "linear":
        raise InputError(f"feed {feed!r} is not a linear axis of {machine.name} (axes: {', '.join(axes)})",
                         parameters=("feed",))
    column = axes.index(feed)
    probe = np.repeat(q0[None], 2, axis=0)
    probe[1, column] += eps
    _, p = tool_poses(machine.model, probe, nominal=True)   # at the configuration checked above
    step = (p[1] - p[0]) / eps
    if abs(abs(step[2]) - 1) > 1e-6 or np.hypot(step[0], step[1]) > 1e-6:
        raise InputError(f"feed axis {feed!r} of {machine.name} does not move the tool along the gear axis",
                         parameters=("feed",))
    return dataclasses.replace(mesh, feed=column, feed_rate=float(np.sign(step[2])))


@dataclass(frozen=True)
class FlankGrid:
    """The flank points of both flanks of every tooth and the configurations that generate them.

    Attributes
    ----------
    q : ndarray, shape (M, n_axes)
        The configuration generating each point [m, rad].
    point : ndarray, shape (M, 3)
        Nominal contact point, workpiece frame [m].
    normal : ndarray, shape (M, 3)
        Outward flank normal, workpiece frame.
    shape : tuple of int
        (2 flanks, teeth, profile points, face points): M points in this order.
    roll : ndarray, shape (n_u,)
        Positions on the line of action [m].
    face : ndarray, shape (n_s,)
        Face positions from mid face [m].
    teeth : ndarray of int, shape (n_t,)
        Tooth numbers.
    """

    q: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    shape: tuple
    roll: np.ndarray
    face: np.ndarray
    teeth: np.ndarray


def flank_grid(machine: Machine, gear: GearPair, mesh: Mesh, profile_points: int, face_points: int,
               tooth_numbers: Sequence[int] | None) -> FlankGrid:
    """The flank points of the chosen teeth and the configurations that generate them.

    Parameters
    ----------
    machine : Machine
        The rolling machine.
    gear : GearPair
        The gear pair.
    mesh : Mesh
        How its spindles mesh.
    profile_points, face_points : int
        Points along the profile and the face width (odd, >= 3).
    tooth_numbers : sequence of int or None
        The teeth (default all).

    Returns
    -------
    FlankGrid
        The points.

    Raises
    ------
    InputError
        Naming ``profile_points``, ``face_points`` or ``tooth_numbers``, for invalid counts or
        teeth, or a study larger than the free memory.
    """
    for name, value in (("profile_points", profile_points), ("face_points", face_points)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 3 or value % 2 == 0:
            raise InputError(f"{name} must be an odd integer >= 3 (the middle point is the pitch circle or "
                             f"the mid face), got {value!r}", parameters=(name,))
    z = gear.teeth
    chosen = tooth_numbers
    tooth_numbers = np.arange(z) if chosen is None else np.asarray(chosen)
    if tooth_numbers.ndim != 1 or tooth_numbers.size == 0 or not np.issubdtype(tooth_numbers.dtype, np.integer) \
            or (tooth_numbers < 0).any() or (tooth_numbers >= z).any() or len(set(tooth_numbers.tolist())) != tooth_numbers.size:
        raise InputError(f"tooth_numbers must be distinct tooth numbers 0..{z - 1}, got {chosen!r}",
                         parameters=("tooth_numbers",))
    tooth_numbers = np.sort(tooth_numbers)      # adjacent teeth next to each other (pitch)
    require_memory(BYTES_PER_FLANK_POINT * 2 * tooth_numbers.size * profile_points * face_points,
                   f"a study of {2 * tooth_numbers.size * profile_points * face_points:,} flank points",
                   ("profile_points", "face_points", "tooth_numbers"))
    alpha, rb = gear.pressure_angle, gear.base_radius
    # the profile: the active part of the line of action, with the pitch point in the middle
    half = (profile_points - 1) // 2
    roll = np.concatenate([np.linspace(gear.roll_start, 0.0, half + 1)[:-1], [0.0],
                           np.linspace(0.0, gear.roll_end, half + 1)[1:]])
    face = np.linspace(-gear.face_width / 2, gear.face_width / 2, face_points)
    # the generation frame G is the workpiece frame at q0: pitch point P on e_r, e_t = z x e_r
    e_r = np.array([np.cos(mesh.psi0), np.sin(mesh.psi0), 0.0])
    e_t = np.array([-e_r[1], e_r[0], 0.0])
    # teeth numbered from the one centred on the pitch point at q0, counted towards +e_t, and
    # taken symmetric about it so that the spindle stays near q0
    offset = np.where(tooth_numbers <= z // 2, tooth_numbers, tooth_numbers - z)
    points, normals, qs = [], [], []
    for sigma in (1, -1):               # right (clockwise side), left
        line = -sigma * np.cos(alpha) * e_t + np.sin(alpha) * e_r          # line of action = outward normal
        # polar angle (workpiece frame) at which the flank crosses the pitch circle
        theta = 2 * np.pi * offset / z - sigma * np.pi / (2 * z)
        # the workpiece turns by -kappa*beta in G; the contact moves along the line at kappa*sigma*rb
        beta = mesh.kappa * theta[:, None] + mesh.kappa * sigma * roll[None, :] / rb     # (n_t, n_u)
        contact = gear.pitch_radius * e_r + roll[:, None] * line                          # (n_u, 3) in G
        angle = mesh.kappa * beta                                                         # G -> workpiece
        c, s = np.cos(angle), np.sin(angle)
        px = c * contact[None, :, 0] - s * contact[None, :, 1]                        # (n_t, n_u)
        py = s * contact[None, :, 0] + c * contact[None, :, 1]
        nx = c * line[0] - s * line[1]
        ny = s * line[0] + c * line[1]
        shape = beta.shape + (face.size,)
        p = np.stack([np.broadcast_to(px[..., None], shape), np.broadcast_to(py[..., None], shape),
                      np.broadcast_to(mesh.z0 + face, shape)], axis=-1)
        n = np.stack([np.broadcast_to(nx[..., None], shape), np.broadcast_to(ny[..., None], shape),
                      np.zeros(shape)], axis=-1)
        q = np.broadcast_to(mesh.q0, shape + (mesh.q0.size,)).copy()
        q[..., mesh.work] += beta[..., None]
        q[..., mesh.tool] += mesh.ratio * beta[..., None]
        if mesh.feed is not None:       # each section finished in the wheel's mid plane
            q[..., mesh.feed] += face / mesh.feed_rate
        points.append(p.reshape(-1, 3))
        normals.append(n.reshape(-1, 3))
        qs.append(q.reshape(-1, mesh.q0.size))
    return FlankGrid(np.concatenate(qs), np.concatenate(points), np.concatenate(normals),
                 (2, tooth_numbers.size, roll.size, face.size), roll, face, tooth_numbers)


@dataclass(frozen=True)
class Generation:
    """Where and when every flank point is generated: nominal geometry only, the same for
    every error the machine may have.

    Attributes
    ----------
    grid : FlankGrid
        The flank points and configurations.
    local : ndarray, shape (M, 3)
        The wheel's contact points in the tool frame [m].
    """

    grid: FlankGrid
    local: np.ndarray


def generation_of(machine: Machine, gear: GearPair, spindles: Sequence[str] = ("B", "A"), at: Mapping | None = None,
                  feed: str | None = None, profile_points: int = 21, face_points: int = 11,
                  tooth_numbers: Sequence[int] | None = None) -> Generation:
    """Where and when every flank point is generated.

    Parameters
    ----------
    machine : Machine
        The rolling machine.
    gear : GearPair
        The gear pair.
    spindles : sequence of str, default ("B", "A")
        The workpiece and the wheel spindle.
    at : mapping of str to float, optional
        The nominal configuration [m, rad].
    feed : str, optional
        The feed axis of through rolling.
    profile_points, face_points : int
        Points along the profile and the face width.
    tooth_numbers : sequence of int, optional
        The teeth (default all).

    Returns
    -------
    Generation
        The generation.

    Raises
    ------
    InputError
        As :func:`mesh_of` and :func:`flank_grid`; naming ``at`` when generating needs positions
        beyond the travel.
    """
    mesh = mesh_of(machine, gear, spindles, at, feed)
    grid = flank_grid(machine, gear, mesh, profile_points, face_points, tooth_numbers)
    outside = machine.outside_travel(grid.q).any(axis=0)
    if outside.any():
        travel = machine.travel
        parts = []
        for j in np.flatnonzero(outside):
            factor = axis_scale(machine.axis_kinds[j])
            unit = "mm" if factor == MM else "deg"
            parts.append(f"{machine.axes[j]} from {grid.q[:, j].min() / factor:.6g} to {grid.q[:, j].max() / factor:.6g} "
                         f"{unit} (travel {travel[j, 0] / factor:.6g} to {travel[j, 1] / factor:.6g})")
        raise InputError(f"at: generating the gear needs {'; '.join(parts)}; move the nominal configuration",
                         parameters=("at",))
    R0, p0 = tool_poses(machine.model, grid.q, nominal=True)
    return Generation(grid, np.einsum("nji,nj->ni", R0, grid.point - p0))
