"""Sampling a machine's workspace and summarising its volumetric error there."""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

from .errors import InputError
from .machine import Machine

M_TO_UM = 1e6
RAD_TO_ARCSEC = 180.0 / np.pi * 3600.0


def grid(machine: Machine, points_per_axis: int | tuple[int, ...] = 5) -> np.ndarray:
    """(N, n_axes) full-factorial grid over the travels, ends included.

    Parameters
    ----------
    points_per_axis : int or tuple of int
        Points along each axis (one value for all axes, or one per axis).
    """
    counts = np.broadcast_to(np.asarray(points_per_axis, dtype=int), (len(machine.axes),))
    if np.any(counts < 1):
        raise InputError(f"points_per_axis must be >= 1, got {points_per_axis}")
    travel = _bounded_travel(machine)
    axes = [np.linspace(lo, hi, n) if n > 1 else np.array([(lo + hi) / 2])
            for (lo, hi), n in zip(travel, counts)]
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1)


def sample(machine: Machine, n: int, seed: int = 0) -> np.ndarray:
    """(n, n_axes) scrambled Sobol' space-filling design over the travels (seeded)."""
    if n < 1:
        raise InputError(f"number of points must be >= 1, got {n}")
    travel = _bounded_travel(machine)
    sobol = qmc.Sobol(d=len(machine.axes), scramble=True, seed=seed)
    m = int(np.ceil(np.log2(n)))
    unit = sobol.random_base2(m)[:n]
    return qmc.scale(unit, travel[:, 0], travel[:, 1]) if n else unit


def _bounded_travel(machine: Machine) -> np.ndarray:
    travel = machine.travel
    unbounded = ~np.isfinite(travel)
    if unbounded.any():  # continuous joints: one turn
        travel = np.where(unbounded, np.array([-np.pi, np.pi]), travel)
    return travel


def error_summary(machine: Machine, q: np.ndarray, theta=None, **covariates) -> dict:
    """Summary of the volumetric error over the points ``q``.

    Returns a dict with ``points``, ``max_position_um`` and ``rms_position_um`` (the
    Euclidean norm of dx, dy, dz), ``max_abs_um`` per direction, ``max_orientation_arcsec``
    (norm of rx, ry, rz), and ``worst_q`` (the NC position of the largest position error,
    in mm / deg).
    """
    error = machine.volumetric_error(q, theta, **covariates)
    norm = np.linalg.norm(error[:, :3], axis=1)
    rot = np.linalg.norm(error[:, 3:], axis=1)
    worst = int(np.argmax(norm))
    return {
        "points": int(len(q)),
        "max_position_um": float(norm.max() * M_TO_UM),
        "rms_position_um": float(np.sqrt(np.mean(norm**2)) * M_TO_UM),
        "max_abs_um": {k: float(np.abs(error[:, i]).max() * M_TO_UM) for i, k in enumerate("xyz")},
        "max_orientation_arcsec": float(rot.max() * RAD_TO_ARCSEC),
        "worst_q": to_engineering(machine, q[worst]).tolist(),
    }


def to_engineering(machine: Machine, q: np.ndarray) -> np.ndarray:
    """NC positions from SI (m, rad) to engineering units (mm, deg)."""
    factors = np.array([1e3 if k == "linear" else 180.0 / np.pi for k in machine.axis_kinds])
    return np.asarray(q) * factors


def from_engineering(machine: Machine, q: np.ndarray) -> np.ndarray:
    """NC positions from engineering units (mm, deg) to SI (m, rad)."""
    factors = np.array([1e-3 if k == "linear" else np.pi / 180.0 for k in machine.axis_kinds])
    return np.asarray(q, dtype=float) * factors
