"""Least-squares geometry of measured points, as a CMM evaluates them: the circle (ISO 12181-1's
least-squares reference circle) and the line (ISO 12780's least-squares reference line)
through points of a plane."""

from __future__ import annotations

import numpy as np

from ..base.errors import InputError

__all__ = ["fit_circle", "fit_line"]


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
