"""Cross-validation over poses: the points of one pose (several tracker targets, repeats, an
instrument's set-up) are held out together, so none of them is predicted from the others.
"""

from __future__ import annotations

import numpy as np

from ...base import UM_PER_M, InputError, integer
from ...model import volumetric_error
from ._design import FitPoints
from ._observations import Observations, point_squares
from ._solver import solve

__all__ = ["cross_validate", "holdout_split", "pose_folds"]


def _poses(obs: Observations, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Pose index of every point (the same positions: several targets, or repeats) and the
    poses shuffled by ``seed``."""
    seed = integer("seed", seed, 0)
    group = obs.poses()
    return group, np.random.default_rng(seed).permutation(int(group.max()) + 1 if group.size else 0)


def pose_folds(obs: Observations, folds: int, seed: int) -> list[np.ndarray] | None:
    """Groups of point indices for cross-validation, keeping the points at one pose in one group.

    A held-out pose must not be half in the fit.

    Parameters
    ----------
    obs : Observations
        The observations (poses: points with the same positions, to 1e-12).
    folds : int
        Number of groups.
    seed : int
        Seed of the shuffling of the poses.

    Returns
    -------
    list of ndarray of int, or None
        ``folds`` arrays of point indices; None when there are fewer than 2 x ``folds`` poses.

    Raises
    ------
    InputError
        If ``folds`` is not a whole number >= 1 or ``seed`` is negative.
    """
    folds = integer("folds", folds, 1)
    group, order = _poses(obs, seed)
    if len(order) < 2 * folds:
        return None
    return [np.flatnonzero(np.isin(group, part)) for part in np.array_split(order, folds)]


def holdout_split(obs: Observations, holdout: float, seed: int) -> tuple[list[np.ndarray], str]:
    """The points held out by a random split of the poses, and how.

    Parameters
    ----------
    obs : Observations
        The observations.
    holdout : float
        Fraction of the poses held out (0 to 1).
    seed : int
        Seed of the shuffling of the poses.

    Returns
    -------
    splits : list of ndarray of int
        One array: the points held out.
    how : str
        The split in words, for reports.

    Raises
    ------
    InputError
        Naming ``holdout``, when it would hold out every pose.
    """
    group, order = _poses(obs, seed)
    n_out = max(1, int(round(holdout * len(order))))
    if n_out >= len(order):
        raise InputError(f"holdout {holdout:g} of {len(order)} {'pose' if len(order) == 1 else 'poses'} holds out "
                         f"{n_out}: none is left to fit "
                         f"(give a smaller fraction, or data at more poses)", parameters=("holdout",))
    splits = [np.flatnonzero(np.isin(group, order[:n_out]))]
    how = (f"random split, {n_out} of {len(order)} poses ({splits[0].size} of {obs.n_points} points) "
           f"held out (seed {seed})")
    return splits, how


def cross_validate(points: FitPoints, theta0: np.ndarray, free: np.ndarray, columns, convention: str,
                   folds: int, holdout: float | None, seed: int, max_iter: int, tol: float, progress=None
                   ) -> tuple[float | None, str]:
    """Held-out RMS of the position residual: each split's points predicted by a fit to the others.

    Parameters
    ----------
    points : FitPoints
        The observations and their points checked for the model.
    theta0 : ndarray, shape (P,)
        Start values (SI).
    free : ndarray of int
        The coefficients that may move.
    columns : ndarray of int or None
        As for :func:`~volerr_pin.fit.identify._solver.solve`.
    convention : str
        "prior" or "min-norm".
    folds : int
        k of k-fold cross-validation over poses (without ``holdout``).
    holdout : float or None
        Fraction of the poses of one random split (overrides ``folds``).
    seed : int
        Seed of the shuffling of the poses.
    max_iter : int
        Iteration limit of each fit.
    tol : float
        Convergence threshold of each fit.
    progress : callable(str, int), optional
        Called after each split.

    Returns
    -------
    rms : float or None
        RMS over held-out points of the position residual norm [um]; None without position rows
        or with too few poses.
    how : str
        The splits in words, for reports.
    """
    obs = points.obs
    if holdout is not None:
        splits, how = holdout_split(obs, holdout, seed)
    else:
        splits = pose_folds(obs, folds, seed)
        if splits is None:
            return None, f"too few poses for {folds}-fold cross-validation"
        how = f"{folds}-fold cross-validation over poses (seed {seed})"
    sq_pos, count = 0.0, 0
    for k, test in enumerate(splits):
        train = np.setdiff1d(np.arange(obs.n_points), test)
        fit_points, test_points = points.subset(train), points.subset(np.sort(test))
        theta, nuisance, *_ = solve(fit_points, theta0, free, columns, convention, max_iter, tol)
        test_obs = test_points.obs
        error = volumetric_error(points.model, test_points.q, theta, test_points.cov)
        pred = np.einsum("rk,rk->r", test_obs.w, error[test_obs.point]) + test_obs.nuisance @ nuisance
        res = test_obs.y - pred
        pos = ~test_obs.angular
        per_point = point_squares(test_obs.point[pos], res[pos])
        sq_pos += per_point.sum()
        count += per_point.size
        if progress:
            progress("cross-validation", k + 1)
    return (float(np.sqrt(sq_pos / count) * UM_PER_M) if count else None), how
