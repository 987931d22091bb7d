"""The projector's cross-validation (the held-out RMS every diagnosis decision rests on) against
a plain least-squares fit on each training set, done here from scratch: the base alone, the
base with a candidate, and folds whose training set cannot determine a direction of the base."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from volerr_pin.diagnose.scoring import Projector

POINTS = 90
ROWS_PER_POINT = 4   # dx, dy, dz and one angle, as a point measured by a laser and a level


def _data(seed: int, columns: int = 9):
    rng = np.random.default_rng(seed)
    point = np.repeat(np.arange(POINTS), ROWS_PER_POINT)
    angular = np.tile([False, False, False, True], POINTS)
    sigma = np.where(angular, 2e-6, 0.5e-6) * rng.uniform(0.5, 2.0, point.size)
    obs = SimpleNamespace(point=point, angular=angular, sigma=sigma)
    # columns of very different sizes, as the SI columns of a design are
    A = rng.normal(size=(point.size, columns)) * np.logspace(-3, 3, columns)
    r = rng.normal(size=point.size) * 3.0
    folds = np.array_split(rng.permutation(POINTS), 5)
    return rng, obs, A, r, folds


def _brute_cv(A: np.ndarray, r: np.ndarray, obs, folds) -> float:
    """k-fold RMS [um] of the position residual norm per held-out point, each training set fitted
    by lstsq (minimum norm: a direction the training set does not see predicts nothing)."""
    total, count = 0.0, 0
    for test in folds:
        V = np.isin(obs.point, test)
        T = ~V
        coef = np.linalg.lstsq(A[T], r[T], rcond=1e-10)[0]
        res = (r[V] - A[V] @ coef) * obs.sigma[V]
        pos = ~obs.angular[V]
        for p in np.unique(obs.point[V][pos]):
            total += float(np.sum(res[pos][obs.point[V][pos] == p] ** 2))
            count += 1
    return float(np.sqrt(total / count) * 1e6)


@pytest.mark.parametrize("seed", range(4))
def test_the_held_out_rms_is_that_of_a_fit_on_each_training_set(seed):
    rng, obs, A, r, folds = _data(seed)
    proj = Projector(A, r, obs, folds)
    assert proj.cv_rms == pytest.approx(_brute_cv(A, r, obs, folds), rel=1e-9)
    for k in (1, 2, 3):
        C = rng.normal(size=(len(r), k)) * 10.0 ** rng.uniform(-4, 4, k)
        assert proj.cv(C) == pytest.approx(_brute_cv(np.hstack([A, C]), r, obs, folds), rel=1e-9)
    # a candidate inside the base's span adds nothing: the base's RMS
    assert proj.cv(A[:, :2] @ rng.normal(size=(2, 1))) == pytest.approx(proj.cv_rms, rel=1e-9)


def test_a_direction_only_the_held_out_points_carry_predicts_nothing():
    """A base column that is non-zero only on one fold's held-out points: that training set
    cannot determine it (the fit leaves it at zero) and the other folds can."""
    rng, obs, A, r, folds = _data(7)
    only = np.isin(obs.point, folds[2])
    A[:, 3] = np.where(only, A[:, 3], 0.0)
    proj = Projector(A, r, obs, folds)
    assert proj.cv_rms == pytest.approx(_brute_cv(A, r, obs, folds), rel=1e-9)
    C = rng.normal(size=(len(r), 2))
    assert proj.cv(C) == pytest.approx(_brute_cv(np.hstack([A, C]), r, obs, folds), rel=1e-9)
    # and one the training set sees only faintly (a millionth of its size there: the training
    # fit is a million times worse conditioned, and rounding shows at 1e-9)
    A[:, 3] = np.where(only, A[:, 3], 1e-6 * rng.normal(size=len(r)) * np.abs(A[:, 3]).max())
    proj = Projector(A, r, obs, folds)
    assert proj.cv_rms == pytest.approx(_brute_cv(A, r, obs, folds), rel=1e-7)
    assert proj.cv(C) == pytest.approx(_brute_cv(np.hstack([A, C]), r, obs, folds), rel=1e-7)
