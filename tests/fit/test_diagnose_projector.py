"""The projector's cross-validation (the held-out RMS every diagnosis decision rests on) against
a plain least-squares fit on each training set, done here from scratch: the base alone, the
base with a candidate, folds whose training set cannot determine a direction of the base or
sees it faintly, and a design whose weakest direction a training set's own SVD would cut."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from volerr_pin.fit.diagnosis._projector import SVD_RTOL, Projector

POINTS = 90
ROWS_PER_POINT = 4   # dx, dy, dz and one angle, as a point measured by a laser and a level


@pytest.fixture(autouse=True, params=["whole", "halves"])
def basis(request, monkeypatch):
    """Every test with the round's basis from the SVD of the whole design and from its two halves
    of rows (:func:`~volerr_pin.fit.diagnosis._projector._halves_basis`, from 1,000 rows by default)."""
    from volerr_pin.fit.diagnosis import _projector as projector

    monkeypatch.setattr(projector, "HALVES_MIN_ROWS", 10**9 if request.param == "whole" else 0)
    return request.param


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


def test_a_fold_takes_its_training_rows_of_the_basis_when_asked():
    """A fold fitted from the all-rows basis holds no copy of its training rows of it until a
    candidate's fit needs them (one the small products cannot give: a fold whose training set
    sees a direction faintly): the held-out RMS is the same to the last bit."""
    rng, obs, A, r, folds = _data(7)
    only = np.isin(obs.point, folds[2])
    A[:, 3] = np.where(only, A[:, 3], 3e-3 * rng.normal(size=len(r)) * np.abs(A[:, 3]).max())
    proj = Projector(A, r, obs, folds)
    C = rng.normal(size=(len(r), 2))
    kept = proj.cv(C)
    assert not proj.folds[2].gram and not proj.folds[2].own_basis   # the rows path
    for f in proj.folds:
        assert f.U is proj.Q and np.array_equal(f.X_T, proj.Q[f.T])
        f.rows = None
    assert proj.cv(C) == kept
    assert proj.folds[2].rows is not None   # taken for the rows path
    assert proj.folds[0].rows is None       # not needed by the small products


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


def _brute_fit(A: np.ndarray, C: np.ndarray, r: np.ndarray):
    """The joint least squares of [A | C] from scratch (unit columns, lstsq with the projector's
    cut on the rank): the residual sum of squares and C's coefficients."""
    J = np.hstack([A, C])
    norms = np.linalg.norm(J, axis=0)
    coef = np.linalg.lstsq(J / norms, r, rcond=1e-9)[0] / norms
    res = r - J @ coef
    return float(res @ res), coef[A.shape[1]:]


def _paths(monkeypatch) -> list:
    """Record, for every least squares of a candidate, whether the small products gave it."""
    from volerr_pin.fit.diagnosis import _projector as projector

    seen, gram = [], projector._gram_lstsq

    def spy(*args, **kwargs):
        out = gram(*args, **kwargs)
        seen.append(out is not None)
        return out

    monkeypatch.setattr(projector, "_gram_lstsq", spy)
    return seen


@pytest.mark.parametrize("case", ["apart", "half_in_span", "nearly_in_span", "explains_all"])
def test_a_candidates_joint_fit_is_that_of_lstsq_whichever_way_it_is_computed(case, monkeypatch):
    """The joint fit of a candidate with the base comes from small products (the candidate's
    Gram matrix less that of its projection on the base) where they are precise, and from the
    rows elsewhere; both must agree with lstsq on [A | C]: a candidate apart from the base and
    one with a column in the base's span (products), one with a column 1e-5 from the span and
    one that explains the residual to 1e-7 of it (rows)."""
    rng, obs, A, r, folds = _data(3)
    C = rng.normal(size=(len(r), 2)) * np.array([1e-2, 1e3])
    if case == "half_in_span":
        C[:, 1] = A[:, :3] @ rng.normal(size=3)
    elif case == "nearly_in_span":
        C[:, 1] = A[:, :3] @ rng.normal(size=3)
        C[:, 1] += 1e-5 * np.linalg.norm(C[:, 1]) / np.sqrt(len(r)) * rng.normal(size=len(r))
    elif case == "explains_all":
        # a base residual (orthogonal to the base, as a fitted one is) that the candidate explains
        r = C @ np.array([30.0, -2e-3]) + 1e-6 * rng.normal(size=len(r))
        r = r - A @ np.linalg.lstsq(A, r, rcond=None)[0]
    proj = Projector(A, r, obs, folds)
    seen = _paths(monkeypatch)
    extra, rss, coef = proj.fit(C)
    assert seen == [case in ("apart", "half_in_span")]
    base_rss = _brute_fit(A, np.zeros((len(r), 0)), r)[0]
    joint_rss, joint_coef = _brute_fit(A, C, r)
    # what the candidate explains beyond the base (the projector's rss keeps what the base would)
    rr = float(r @ r)
    assert rr - rss == pytest.approx(base_rss - joint_rss, rel=1e-8, abs=1e-12 * rr)
    if case == "explains_all":
        assert joint_rss < 1e-6 * rr
        assert rss == pytest.approx(joint_rss, rel=1e-6)
    assert extra == (1 if case == "half_in_span" else 2)
    if case == "half_in_span":   # a direction in the span: the coefficients are the minimum-norm ones
        return
    assert coef == pytest.approx(joint_coef, rel=1e-6)
    gamma, cov, rss2, extra2 = proj.covariance(C)
    assert extra2 == extra and rss2 == pytest.approx(rss, rel=1e-12) and gamma == pytest.approx(coef, rel=1e-12)
    # the candidate's covariance (unit variance) is its block of the joint inverse Gram matrix,
    # from the singular values of the unit columns (the Gram matrix itself squares their
    # condition number: 1e10 for a column 1e-5 from the span, so its inverse is good to 1e-6)
    J = np.hstack([A, C])
    norms = np.linalg.norm(J, axis=0)
    _, s, vt = np.linalg.svd(J / norms, full_matrices=False)
    full = (vt.T / s**2) @ vt / np.outer(norms, norms)
    assert cov == pytest.approx(full[-2:, -2:], rel=1e-6)


@pytest.mark.parametrize("seed", range(3))
def test_the_held_out_rms_of_a_candidate_partly_in_the_base_span(seed, monkeypatch):
    """A candidate with a column in the base's span (a raised polynomial holds the degrees the
    base has): each training fit comes from the small products, which put that direction at zero
    as lstsq's cut does."""
    rng, obs, A, r, folds = _data(seed)
    proj = Projector(A, r, obs, folds)
    C = np.column_stack([A[:, :4] @ rng.normal(size=4), rng.normal(size=len(r)), rng.normal(size=len(r)) ** 2])
    seen = _paths(monkeypatch)
    assert proj.cv(C) == pytest.approx(_brute_cv(np.hstack([A, C]), r, obs, folds), rel=1e-9)
    assert seen == [True] * len(folds)


@pytest.mark.parametrize("case", ["random", "zero_in_a_half", "rank_deficient", "few_rows"])
def test_the_basis_from_two_halves_is_that_of_the_whole_svd(case):
    """The same span, singular values and cut as numpy's SVD of the whole design, orthonormal
    columns."""
    from volerr_pin.fit.diagnosis._projector import _halves_basis, _svd

    rng = np.random.default_rng(7)
    rows = {"few_rows": 30}.get(case, 1201)
    A = rng.normal(size=(rows, 20)) * np.logspace(-4, 4, 20)
    if case == "zero_in_a_half":   # a ballbar run's centre: nothing in the other run's rows
        A[: rows // 2, 3] = 0.0
        A[rows // 2:, 5] = 0.0
    if case == "rank_deficient":
        A[:, 7] = A[:, 2] * 3.0 - A[:, 9]
    U, s = _halves_basis(A)
    U1, s1, _ = _svd(A)
    assert U.shape == U1.shape and s.shape == s1.shape
    assert np.allclose(s, s1, rtol=1e-12, atol=1e-13 * s1[0])
    assert np.allclose(U.T @ U, np.eye(U.shape[1]), atol=1e-13)
    assert np.allclose(U @ (U.T @ A), A, rtol=0, atol=1e-12 * np.abs(A).max())
    assert np.allclose(U @ U.T, U1 @ U1.T, atol=1e-12)
