"""What the path compensation of one machine state and programming mode works with."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._programming import Programming
from ._smoothness import Smoothness
from ._solver import PointSolver, PoseMetric

__all__ = ["EPS", "Context", "segment_max"]

#: the share of the tolerance left to what may hide between samples
EPS = 0.1


@dataclass
class Context:
    """The tools of path compensation in one machine state and programming mode.

    Attributes
    ----------
    metric : PoseMetric
        Poses and residual measure.
    solver : PointSolver
        Compensated commands of points.
    programming : Programming
        Program coordinates to axis positions.
    smooth : Smoothness
        Curvature and slope bounds.
    tol : float
        Tolerance of the residual along a path [m].
    samples : int
        Most samples of one piece per round of splitting.
    max_depth : int
        Deepest split of a move.
    """

    metric: PoseMetric
    solver: PointSolver
    programming: Programming
    smooth: Smoothness
    tol: float
    samples: int
    max_depth: int

    def samples_for(self, bend: np.ndarray, most: int | None = None) -> np.ndarray:
        """Interior samples that keep what may hide between them within :data:`EPS` of the
        tolerance: ``bend / (8 (n + 1)^2) <= EPS tol``.

        Parameters
        ----------
        bend : ndarray, shape (P,)
            ``M``, the bound of the residual's second derivative over each piece [m].
        most : int, optional
            Cap (default :attr:`samples`).

        Returns
        -------
        ndarray of int, shape (P,)
            Samples per piece, 0 where the bound alone keeps the tolerance.
        """
        most = self.samples if most is None else most
        need = np.ceil(np.sqrt(np.maximum(bend, 0.0) / (8 * EPS * self.tol))) - 1
        return np.clip(need, 0, most).astype(np.int64)

    def poses(self, words: np.ndarray, nominal: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Tool axes and points at program coordinates.

        Parameters
        ----------
        words : ndarray, shape (N, n_axes)
            Program coordinates [m, rad].
        nominal : bool, default False
            The nominal machine (else the actual one).

        Returns
        -------
        a, p : ndarray, shape (N, 3)
            Tool axes and points [m].
        """
        q = self.programming.to_axes(words)
        return self.metric.nominal(q) if nominal else self.metric.actual(q)


def segment_max(values: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Maximum of each segment of an array and the place of its first occurrence.

    Parameters
    ----------
    values : ndarray, shape (N,)
        The values, segment after segment.
    starts : ndarray of int, shape (S,)
        Where each segment starts (ascending; segments are not empty and run to the next start,
        the last to the end).

    Returns
    -------
    worst : ndarray, shape (S,)
        Maximum of each segment.
    where : ndarray of int, shape (S,)
        Index of the maximum within its segment.
    """
    worst = np.maximum.reduceat(values, starts)
    seg = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, len(values))))
    hit = values == worst[seg]
    first = np.full(len(starts), len(values))
    np.minimum.at(first, seg[hit], np.flatnonzero(hit))
    return worst, first - starts
