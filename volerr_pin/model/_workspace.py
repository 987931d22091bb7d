"""Sampling a machine's workspace and summarising its volumetric error there."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from ..base import (ARCSEC_PER_RAD, UM_PER_M, InputError, axis_scales, axis_values_to_si, integer, require_memory,
                    whole_numbers)
from ._machine import Machine


def _size_of_grid(counts) -> int:
    return math.prod(int(c) for c in counts)


#: bytes per point that a grid or sample takes while it is made: its columns, the mesh and a copy
POINT_BYTES = 8 * 4


def grid(machine: Machine, points_per_axis: int | tuple[int, ...] = 5) -> np.ndarray:
    """Full-factorial grid of NC positions over the travels, ends included.

    Parameters
    ----------
    machine : Machine
        The machine whose travels the grid spans (an endless axis spans one turn, -pi to pi).
    points_per_axis : int or tuple of int, default 5
        Points along each axis (one value for all axes, or one per axis). An axis with one
        point sits at the middle of its travel.

    Returns
    -------
    ndarray, shape (N, n_axes)
        NC positions [m, rad], N the product of the counts; the last axis varies fastest.

    Raises
    ------
    InputError
        If a count is not a whole number >= 1, there is neither one count nor one per axis,
        or the grid would not fit in the free memory.
    """
    counts = whole_numbers("points_per_axis", points_per_axis, 1)
    if counts.ndim == 1 and counts.size not in (1, len(machine.axes)):
        raise InputError(f"points_per_axis: give 1 or {len(machine.axes)} counts (axes {', '.join(machine.axes)}), "
                         f"got {counts.size}", parameters=("points_per_axis",))
    counts = np.broadcast_to(counts, (len(machine.axes),))
    n = _size_of_grid(counts)
    require_memory(n * POINT_BYTES * len(machine.axes), f"a grid of {' x '.join(map(str, counts))} = {n:,} points",
                   ("points_per_axis",))
    travel = _bounded_travel(machine)
    axes = [np.linspace(lo, hi, n) if n > 1 else np.array([(lo + hi) / 2])
            for (lo, hi), n in zip(travel, counts)]
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1)


def sample(machine: Machine, points: int, seed: int = 0) -> np.ndarray:
    """Scrambled Sobol' space-filling design over the travels (seeded).

    Parameters
    ----------
    machine : Machine
        The machine whose travels the points fill (an endless axis spans one turn, -pi to pi).
    points : int
        Number of points (the first ``points`` of a 2^m Sobol' sequence).
    seed : int, default 0
        Seed of the scrambling (>= 0).

    Returns
    -------
    ndarray, shape (points, n_axes)
        NC positions [m, rad].

    Raises
    ------
    InputError
        If ``points`` is not a whole number >= 1 or would not fit in the free memory, or
        ``seed`` is not a whole number >= 0.
    """
    n = integer("points", points, 1)
    seed = integer("seed", seed, 0)
    # the Sobol' sequence is drawn to the next power of two
    require_memory(2 * n * POINT_BYTES * len(machine.axes), f"a sample of {n:,} positions", ("points",))
    travel = _bounded_travel(machine)
    sobol = qmc.Sobol(d=len(machine.axes), scramble=True, seed=seed)
    m = int(np.ceil(np.log2(n)))
    unit = sobol.random_base2(m)[:n]
    return qmc.scale(unit, travel[:, 0], travel[:, 1])


def _bounded_travel(machine: Machine) -> np.ndarray:
    travel = machine.travel
    unbounded = ~np.isfinite(travel)
    if unbounded.any():  # continuous joints: one turn
        travel = np.where(unbounded, np.array([-np.pi, np.pi]), travel)
    return travel


def error_summary(machine: Machine, q: np.ndarray, theta=None, **covariates) -> dict:
    """Summary of the volumetric error over the points ``q``.

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : array_like, shape (P,), optional
        Coefficients (SI); defaults to the machine's.
    **covariates
        As for :meth:`Machine.volumetric_error`.

    Returns
    -------
    dict
        ``points``, ``max_position_um`` and ``rms_position_um`` (the Euclidean norm of dx,
        dy, dz) [um], ``max_abs_um`` per direction (``x``, ``y``, ``z``) [um],
        ``max_orientation_arcsec`` (norm of rx, ry, rz) [arcsec], and ``worst_q`` (the NC
        position of the largest position error, in mm / deg).

    Raises
    ------
    InputError
        For invalid ``q`` (or one without points), ``theta`` or covariates.
    """
    error = machine.volumetric_error(q, theta, **covariates)
    if len(error) == 0:
        raise InputError("q holds no points: there is no error to summarise", parameters=("q",))
    norm = np.linalg.norm(error[:, :3], axis=1)
    rot = np.linalg.norm(error[:, 3:], axis=1)
    worst = int(np.argmax(norm))
    return {
        "points": int(len(q)),
        "max_position_um": float(norm.max() * UM_PER_M),
        "rms_position_um": float(np.sqrt(np.mean(norm**2)) * UM_PER_M),
        "max_abs_um": {k: float(np.abs(error[:, i]).max() * UM_PER_M) for i, k in enumerate("xyz")},
        "max_orientation_arcsec": float(rot.max() * ARCSEC_PER_RAD),
        "worst_q": to_engineering(machine, q[worst]).tolist(),
    }


def to_engineering(machine: Machine, q: np.ndarray) -> np.ndarray:
    """NC positions from SI (m, rad) to engineering units (mm, deg).

    Parameters
    ----------
    machine : Machine
        The machine (its axis kinds choose the unit of each column).
    q : array_like, shape (..., n_axes)
        NC positions [m, rad].

    Returns
    -------
    ndarray, shape (..., n_axes)
        The positions [mm, deg].
    """
    return np.asarray(q) / axis_scales(machine.axis_kinds)


def from_engineering(machine: Machine, q: np.ndarray) -> np.ndarray:
    """NC positions from engineering units (mm, deg) to SI (m, rad).

    Parameters
    ----------
    machine : Machine
        The machine (its axis kinds choose the unit of each column).
    q : array_like, shape (..., n_axes)
        NC positions [mm, deg].

    Returns
    -------
    ndarray, shape (..., n_axes)
        The positions as floats [m, rad].
    """
    return np.asarray(q, dtype=float) * axis_scales(machine.axis_kinds)


# ------------------------------------------------------------------ fields for pictures

def field_grid(machine: Machine, counts=None, config: dict[str, float] | None = None,
               points: int = 1000) -> np.ndarray:
    """NC positions of a field: a grid over the linear axes, the other axes fixed.

    A machine without linear axes gets ``points`` seeded Sobol' configurations instead.

    Parameters
    ----------
    machine : Machine
        The machine.
    counts : sequence of int, optional
        Points per linear axis: one count for all of them or one per linear axis (default 9).
    config : dict of str to float, optional
        Positions of the other axes, axis name -> SI value [m, rad] (default: mid travel for
        linear, 0 or mid for rotary; see :func:`default_config`).
    points : int, default 1000
        Number of points for a machine without linear axes.

    Returns
    -------
    ndarray, shape (N, n_axes)
        NC positions [m, rad].

    Raises
    ------
    InputError
        If ``counts`` has neither one nor one-per-linear-axis entries or a count that is not
        a whole number >= 1, the grid (or ``points``) would not fit in the free memory, or
        ``config`` names an unknown axis or a position outside the travel.
    """
    base = default_config(machine, config)
    linear = [j for j, k in enumerate(machine.axis_kinds) if k == "linear"]
    if not linear:
        points = integer("points", points, 1)
        require_memory(2 * points * POINT_BYTES * len(machine.axes), f"a field of {points:,} configurations",
                       ("points",))
        return sample(machine, points, seed=0)
    counts = [9] if counts is None else [int(c) for c in whole_numbers("counts", counts, 1).reshape(-1)]
    if len(counts) == 1:
        counts = counts * len(linear)
    if len(counts) != len(linear):
        raise InputError(f"counts: give 1 or {len(linear)} counts (linear axes "
                         f"{', '.join(machine.axes[j] for j in linear)}), got {len(counts)}", parameters=("counts",))
    full = [1] * len(machine.axes)
    for j, n in zip(linear, counts):
        full[j] = n
    n = _size_of_grid(full)
    require_memory(n * POINT_BYTES * len(machine.axes), f"a field grid of {' x '.join(map(str, counts))} = {n:,} points",
                   ("counts",))
    q = grid(machine, tuple(full))
    fixed = [j for j in range(len(machine.axes)) if j not in linear]
    q[:, fixed] = base[fixed]
    return q


def config_from_file(machine: Machine, positions: dict[str, float], where: str) -> np.ndarray:
    """:func:`default_config` with axis positions given in file units (mm / deg).

    As a file's ``# at:`` or ``# centre:`` line gives them.

    Parameters
    ----------
    machine : Machine
        The machine.
    positions : dict of str to float
        Axis name -> position [mm, deg].
    where : str
        Names the file and line for errors.

    Returns
    -------
    ndarray, shape (n_axes,)
        The configuration [m, rad].

    Raises
    ------
    InputError
        If a name is not an axis of the machine or a position is outside the travel.
    """
    return default_config(machine, axis_values_to_si(machine.axes, machine.axis_kinds, positions, where,
                                                     machine.name))


def default_config(machine: Machine, config: dict[str, float] | None = None) -> np.ndarray:
    """A displayable configuration: mid travel, rotary axes at 0 when 0 is in travel.

    Parameters
    ----------
    machine : Machine
        The machine.
    config : dict of str to float, optional
        Axis name -> SI value [m, rad] overriding the default, checked against the travel.

    Returns
    -------
    ndarray, shape (n_axes,)
        The configuration [m, rad] (an endless axis at 0).

    Raises
    ------
    InputError
        If ``config`` names an unknown axis or a value outside the travel.
    """
    travel = machine.travel
    q = machine.mid_travel
    for j, kind in enumerate(machine.axis_kinds):
        if kind == "rotary" and travel[j, 0] <= 0.0 <= travel[j, 1]:
            q[j] = 0.0
    for name, value in (config or {}).items():
        if name not in machine.axes:
            raise InputError(f"config: '{name}' is not an axis of {machine.name} "
                             f"(axes: {', '.join(machine.axes)})")
        j = machine.axes.index(name)
        lo, hi = travel[j]
        if not lo <= value <= hi:
            shown = to_engineering(machine, np.eye(len(machine.axes))[j] * np.array([value, lo, hi])[:, None])[:, j]
            unit = "mm" if machine.axis_kinds[j] == "linear" else "deg"
            raise InputError(f"config: {name} = {shown[0]:g} {unit} is outside its travel "
                             f"[{shown[1]:g}, {shown[2]:g}] {unit}")
        q[j] = value
    return q


def nice_scale(error_um_max: float, extent_m: float) -> float:
    """A round magnification (1, 2 or 5 x 10^k) making the largest arrow about 8 % of the workspace extent.

    Parameters
    ----------
    error_um_max : float
        The largest position error [um].
    extent_m : float
        The workspace extent [m].

    Returns
    -------
    float
        The magnification: the largest power-of-ten multiple of 5, 2 or 1 not above
        0.08 x extent / error; 1.0 when either input is not a positive finite number.
    """
    if not (0 < error_um_max < math.inf and 0 < extent_m < math.inf):
        return 1.0
    raw = 0.08 * extent_m / (error_um_max / UM_PER_M)
    exponent = math.floor(math.log10(raw))
    for step in (5, 2, 1):
        if step * 10**exponent <= raw:
            return float(step * 10**exponent)
    return float(10**exponent)


@dataclass(frozen=True)
class FieldData:
    """An evaluated error field: where (workpiece frame) and how large.

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    positions : ndarray, shape (N, 3)
        Nominal tool points in the workpiece frame [m].
    error : ndarray, shape (N, 6)
        Volumetric error: dx, dy, dz [m], rx, ry, rz [rad].
    scale : float
        Arrow magnification (dimensionless).
    """

    q: np.ndarray          # (N, n_axes) NC positions, SI
    positions: np.ndarray  # (N, 3) nominal tool points in the workpiece frame, m
    error: np.ndarray      # (N, 6) volumetric error, SI
    scale: float           # arrow magnification


def evaluate_field(machine: Machine, q: np.ndarray, scale: float | None = None,
                   **covariates) -> FieldData:
    """Volumetric error at ``q`` (with the given covariates) and the nominal tool points it belongs to.

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    scale : float, optional
        Arrow magnification; default from :func:`nice_scale` over the field's extent (1 m for
        a single point).
    **covariates
        As for :meth:`Machine.volumetric_error`.

    Returns
    -------
    FieldData
        The positions, the error and the scale.

    Raises
    ------
    InputError
        If ``scale`` is not a positive finite number, or ``q`` or the covariates are invalid.
    """
    error = machine.volumetric_error(q, **covariates)
    _, positions = machine.tool_poses(q, nominal=True)
    if scale is None:
        extent = float(np.ptp(positions, axis=0).max()) if len(positions) > 1 else 1.0
        largest = float(np.linalg.norm(error[:, :3], axis=1).max(initial=0.0) * UM_PER_M)
        scale = nice_scale(largest, extent)  # 1 for an empty field
    if not (scale > 0 and math.isfinite(scale)):
        raise InputError(f"scale must be a positive number, got {scale}")
    return FieldData(q, positions, error, float(scale))
