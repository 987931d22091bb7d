"""The projector's cross-validation (the held-out RMS every diagnosis decision rests on) against
a plain least-squares fit on each training set, done here from scratch: the base alone, the
base with a candidate, folds whose training set cannot determine a direction of the base or
sees it faintly, and a design whose weakest direction a training set's own SVD would cut."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from volerr_pin.diagnose.scoring import SVD_RTOL, Projector

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
    by lstsq on A's columns scaled to unit norm (over all rows, as the diagnosis scales them),
    singular values below SVD_RTOL of the largest cut (a direction the training set does not
    see predicts nothing)."""
    norms = np.linalg.norm(A, axis=0)
    A = A[:, norms > 0] / norms[norms > 0]
    total, count = 0.0, 0
    for test in folds:
        V = np.isin(obs.point, test)
        T = ~V
        coef = np.linalg.lstsq(A[T], r[T], rcond=SVD_RTOL)[0]
        res = (r[V] - A[V] @ coef) * obs.sigma[V]
        pos = ~obs.angular[V]
        for p in np.unique(obs.point[V][pos]):
            total += float(np.sum(res[pos][obs.point[V][pos] == p] ** 2))
            count += 1
    return float(np.sqrt(total / count) * 1e6)


def _own_svd(proj: Projector) -> list[bool]:
    """Which folds were factored on their own (the others come from the all-rows basis)."""
    return [f.own_basis for f in proj.folds]


@pytest.mark.parametrize("seed", range(4))
def test_the_held_out_rms_is_that_of_a_fit_on_each_training_set(seed):
    rng, obs, A, r, folds = _data(seed)
    proj = Projector(A, r, obs, folds)
    assert not any(_own_svd(proj))
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
    assert _own_svd(proj) == [False, False, True, False, False]
    assert proj.cv_rms == pytest.approx(_brute_cv(A, r, obs, folds), rel=1e-9)
    C = rng.normal(size=(len(r), 2))
    assert proj.cv(C) == pytest.approx(_brute_cv(np.hstack([A, C]), r, obs, folds), rel=1e-9)


@pytest.mark.parametrize("faint, own", [(1e-6, True), (3e-3, False), (3e-2, False)])
def test_a_direction_the_training_set_sees_faintly(faint, own):
    """The same column at ``faint`` of its size outside one fold's held-out points: at 1e-6 (a
    share of 1e-11 of its squared norm) the fold is factored on its own; at 3e-3 and 3e-2
    (shares of about 1e-5 and 1e-3) it comes from the all-rows basis, where rounding is
    amplified most (by the inverse share), and still agrees with lstsq to 1e-8."""
    rng, obs, A, r, folds = _data(7)
    only = np.isin(obs.point, folds[2])
    A[:, 3] = np.where(only, A[:, 3], faint * rng.normal(size=len(r)) * np.abs(A[:, 3]).max())
    proj = Projector(A, r, obs, folds)
    assert _own_svd(proj) == [False, False, own, False, False]
    assert proj.cv_rms == pytest.approx(_brute_cv(A, r, obs, folds), rel=1e-8)
    C = rng.normal(size=(len(r), 2))
    assert proj.cv(C) == pytest.approx(_brute_cv(np.hstack([A, C]), r, obs, folds), rel=1e-8)


def test_a_weak_direction_a_training_set_would_cut_is_cut():
    """A design whose weakest direction (5e-10 of the largest singular value, above the cut on
    all rows) lies mostly on one fold's held-out points: that training set sees it at 1e-2 of
    its squared norm, so its own SVD cuts it (5e-11 < SVD_RTOL), and the held-out RMS must be
    that of the cut fit, not of one from the all-rows basis that keeps it."""
    rng = np.random.default_rng(1)
    _, obs, _, r, folds = _data(1, columns=8)
    held = np.isin(obs.point, folds[0])
    u = held / np.linalg.norm(held)
    t = rng.normal(size=len(r)) * ~held
    u = np.sqrt(0.99) * u + np.sqrt(0.01) * t / np.linalg.norm(t)
    Q = np.linalg.qr(np.column_stack([u, rng.normal(size=(len(r), 7))]))[0]
    s = np.array([5e-10, *np.ones(7)])
    A = (Q * s) @ np.linalg.qr(rng.normal(size=(8, 8)))[0].T
    proj = Projector(A, r, obs, folds)
    assert proj.rank == 8 and _own_svd(proj)[0]
    assert proj.cv_rms == pytest.approx(_brute_cv(A, r, obs, folds), rel=1e-8)
    C = rng.normal(size=(len(r), 2))
    assert proj.cv(C) == pytest.approx(_brute_cv(np.hstack([A, C]), r, obs, folds), rel=1e-8)
