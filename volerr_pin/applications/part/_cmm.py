"""Least-squares geometry of measured points, as a CMM evaluates them: the circle (ISO 12181-1's
least-squares reference circle) and the line (ISO 12780's least-squares reference line)
through points of a plane, and what a CMM reports of a round feature (:class:`RoundFeature`,
which a program's circle and a cone's section both are)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...base import UM_PER_M, InputError

__all__ = ["fit_circle", "fit_line", "RoundFeature", "measure_round"]


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


@dataclass(frozen=True, kw_only=True)
class RoundFeature:
    """A round feature as a CMM reports it: measured points about their least-squares circle.

    Attributes
    ----------
    radius : float
        Nominal radius [m].
    circularity_um, diameter_error_um, centre_error_um : float
        Roundness deviation about the least-squares circle (ISO 12181-1), fitted minus nominal
        diameter, and the distance of the fitted centre from the nominal one [um].
    fitted_centre : ndarray, shape (2,)
        Least-squares centre, in the feature's plane coordinates [m].
    angle : ndarray, shape (M,)
        Angle of each measured point about the nominal centre [rad].
    radial_um : ndarray, shape (M,)
        Each measured point's distance from the least-squares centre minus the least-squares
        radius [um].
    q : ndarray, shape (M, n_axes)
        Axis positions of the measured points [m, rad].
    covariates : dict
        Their covariates the path sets (the axes' directions, for a machine that reads them).
    """

    radius: float
    circularity_um: float
    diameter_error_um: float
    centre_error_um: float
    fitted_centre: np.ndarray
    angle: np.ndarray
    radial_um: np.ndarray
    q: np.ndarray
    covariates: dict = field(default_factory=dict)

    def less_circle(self, radial: np.ndarray) -> np.ndarray:
        """A radial profile (M,) at the measured points, or several as columns (M, C), less its
        least-squares circle, to first order (its mean and first harmonics in :attr:`angle`).

        Parameters
        ----------
        radial : ndarray, shape (M,) or (M, C)
            Radial values at the measured points (any unit), one profile per column.

        Returns
        -------
        ndarray, shape as ``radial``
            The residual of each profile after a least-squares fit of ``1, cos(angle),
            sin(angle)``, in the unit of ``radial``.
        """
        basis = np.c_[np.ones_like(self.angle), np.cos(self.angle), np.sin(self.angle)]
        coefficients, *_ = np.linalg.lstsq(basis, radial, rcond=None)
        return radial - basis @ coefficients


def measure_round(points: np.ndarray, centre: np.ndarray, radius: float) -> dict:
    """What a CMM reports of a round feature's measured points (N, 2) against its nominal
    ``centre`` (2,) and ``radius`` [m]: the :class:`RoundFeature` fields ``radius``,
    ``circularity_um``, ``diameter_error_um``, ``centre_error_um``, ``fitted_centre`` and
    ``radial_um``.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        The measured points in the feature's plane [m].
    centre : ndarray, shape (2,)
        The nominal centre [m].
    radius : float
        The nominal radius [m].

    Returns
    -------
    dict
        Those fields (``angle``, ``q`` and ``covariates`` are the caller's to add).
    """
    fitted_centre, fitted = fit_circle(points)
    deviation = np.linalg.norm(points - fitted_centre, axis=1) - fitted
    return {"radius": float(radius), "circularity_um": float(np.ptp(deviation) * UM_PER_M),
            "diameter_error_um": float(2 * (fitted - radius) * UM_PER_M),
            "centre_error_um": float(np.linalg.norm(fitted_centre - centre) * UM_PER_M),
            "fitted_centre": fitted_centre, "radial_um": deviation * UM_PER_M}
