"""Fitting and scoring a candidate: jointly with the base model, linearised at the base fit,
by projection on an orthonormal basis of the base design computed once per round on all rows
(each cross-validation training fit comes from its rows); non-linear coefficients by grid search,
a pitch's period from a periodogram. A candidate's score is its F-test p-value, its BIC gain
and, for those that could pass, its k-fold cross-validated RMS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats
from scipy.linalg import lapack
from scipy.signal import lombscargle

from .. import lockstep
from ..identify import Observations, point_squares, predict_observations
from ..machine import Machine
from ..spec import build_term, parse_component_name
from ..terms import Context, Covariates
from ..units import ARCSEC, UM_PER_M
from .candidates import MIN_PERIODS, PITCH_PERIOD_MM, smoother_table
from .results import Candidate, Score, parallel_map

__all__ = ["FOLD_SEEN", "GRAM_FOLD_SEEN", "GRAM_MIN", "GRAM_ZERO", "HALVES_MIN_ROWS", "PERIODOGRAM_POINTS",
           "REPEAT_MIN_POINTS", "REPEAT_RATIO", "REPEAT_SIGMAS", "SURVIVES", "SVD_RTOL", "Base", "Columns", "Projector",
           "base_design", "not_repeating", "periodogram_period", "repeat_check", "score", "table_interpolation"]

PERIODOGRAM_POINTS = 1500       # points a periodogram looks at, at most
#: singular values of a column-scaled design below this share of the largest are rounding: cut
SVD_RTOL = 1e-10
#: a round's basis is computed from two halves of the design's rows from this many rows
HALVES_MIN_ROWS = 1000
#: a cross-validation fold's training rows hold at least this share of every direction of the
#: base (of its unit norm squared over all rows), or the fold is factored on its own: then its
#: fit from the basis of all rows would amplify rounding by more than the inverse of this share
FOLD_SEEN = 1e-6
#: a candidate's least squares against the base come from small products (Gram matrices of its
#: unit columns, less those of their projection on the base) where every direction it adds
#: keeps at least this share of its unit norm squared, and its fit leaves at least this share
#: of the residual: there the products' rounding (about 1e-15) stays below 1e-7 of what they
#: give. Elsewhere - a direction nearly in the base's span, or a fit that explains almost all
#: the residual - they are formed from the rows, as every candidate's were before ...
GRAM_MIN = 1e-8
#: ... except for directions the products put below this (in the base's span to rounding: the
#: fit from the rows cuts below 1e-12, and the products' rounding is far below the gap)
GRAM_ZERO = 1e-13
#: ... and a cross-validation fold's training fit comes from those products when its training
#: rows hold at least this share of every direction of the base (the products' rounding grows
#: with the inverse of that share)
GRAM_FOLD_SEEN = 1e-2
#: a per-revolution error of an axis measured over more than one turn is checked for repeating
#: from one turn to the next when each turn holds at least this many points ...
REPEAT_MIN_POINTS = 20
#: ... and it does not repeat when its coefficients fitted on each turn apart differ by more than
#: this share of the common amplitude (true errors of the held-out sets, once the other axes'
#: geometry is in: 0.01 to 0.16; a smooth shape of B over its two turns: 0.70 to 3.0) ...
REPEAT_RATIO = 0.5
#: ... and by more than this many standard uncertainties of the difference (a chi with as many
#: degrees of freedom as coefficients; true errors: 0.1 to 1.3, smooth shapes: 2.6 to 7.7)
REPEAT_SIGMAS = 2.0
#: a periodic error of an axis is not its table's interpolation when, beside the table made
#: richer between its nodes, its amplitude stays within this share of what it was and its
#: inverse: the interpolation's residual falls at least four-fold, a screw's error stays (to its
#: uncertainty), and a sinusoid that the richer table can take as well is no longer determined
SURVIVES = 0.5


@dataclass
class Base:
    """The base model of a round, linearised.

    Attributes
    ----------
    machine : Machine
        The base model.
    A : ndarray, shape (rows, n_nuisance + F)
        Weighted design [nuisance | fitted coefficients] of the first-order model.
    r : ndarray, shape (rows,)
        Weighted residual of the exact model.
    """

    machine: Machine
    A: np.ndarray
    r: np.ndarray


def base_design(machine: Machine, obs: Observations, fitted: np.ndarray, nuisance: np.ndarray) -> Base:
    """The residual of the exact model and the design of the first-order model (exact
    dependencies) at the base fit.

    Parameters
    ----------
    machine : Machine
        The fitted base model.
    obs : Observations
        The observations.
    fitted : ndarray of int
        The coefficients that were fitted.
    nuisance : ndarray, shape (n_nuisance,)
        Fitted nuisance values (SI).

    Returns
    -------
    Base
        Design and residual, weighted.
    """
    pred, A = predict_observations(machine, obs, machine.theta, fitted, first_order=True)
    r = (obs.y - pred - obs.nuisance @ nuisance) / obs.sigma
    J = np.hstack([obs.nuisance, A]) / obs.sigma[:, None]
    return Base(machine, J, r)


class Columns:
    """Weighted columns of a candidate's coefficients, linearised at the base.

    The term's own Jacobian depends only on the positions and covariates, which stay the
    same through the diagnosis: it is computed once per (candidate table, non-linear
    value) and kept.

    Parameters
    ----------
    obs : Observations
        The observations.
    cov_obj : Covariates
        Their covariates, checked.
    """

    def __init__(self, obs: Observations, cov_obj: Covariates):
        self.obs, self.cov_obj = obs, cov_obj
        self.cache: dict = {}
        self.weights: dict = {}   # (round's E, component) -> weighted row factors

    def term(self, machine: Machine, cand: Candidate) -> tuple:
        """The candidate's term and where it is evaluated.

        Parameters
        ----------
        machine : Machine
            The present model.
        cand : Candidate
            The candidate.

        Returns
        -------
        tuple of (TermSpec, Context)
            The zero-valued term and its context at the observations' points.
        """
        direction, location, owner = parse_component_name(cand.component)
        quantity = "length" if direction in "XYZ" else "angle"
        axis_index = machine.axes.index(owner) if owner in machine.axes else None
        travel = tuple(machine.travel[axis_index]) if axis_index is not None else None
        position_quantity = None if (location or axis_index is None) else (
            "length" if machine.axis_kinds[axis_index] == "linear" else "angle")
        tspec = build_term(dict(cand.table), f"candidate {cand.label}", quantity, position_quantity, travel)
        position = None if position_quantity is None else self.obs.q[:, axis_index]
        ctx = Context(position, travel, self.cov_obj, axis_index, cand.component)
        return tspec, ctx

    def __call__(self, machine: Machine, E: np.ndarray, joints: list[str], cand: Candidate,
                 coefs=None, columns=None):
        """The candidate's weighted columns.

        Parameters
        ----------
        machine : Machine
            The present model.
        E : ndarray, shape (N, 6, n_error_joints)
            First-order sensitivity of the error to every error joint.
        joints : list of str
            The error joints, in the order of ``E``.
        cand : Candidate
            The candidate.
        coefs : ndarray, optional
            Coefficients at which to linearise (default: the term's, zero).
        columns : list of int, optional
            Which coefficients' columns (default all).

        Returns
        -------
        tuple of (ndarray, TermSpec, ndarray)
            The columns (rows, k), the term and the coefficients used.
        """
        obs = self.obs
        key = (cand.component, repr(sorted(cand.table.items())),
               None if coefs is None else tuple(np.round(coefs, 15)))
        entry = self.cache.get(key)
        if entry is None:
            tspec, ctx = self.term(machine, cand)
            c = tspec.coefficients if coefs is None else coefs
            entry = self.cache[key] = (tspec, c, tspec.term.jacobian(c, ctx)[obs.point])
        tspec, c, jac = entry
        jac = jac if columns is None else jac[:, columns]
        return self.gain(E, joints, cand.component)[:, None] * jac, tspec, c

    def gain(self, E: np.ndarray, joints: list[str], component: str) -> np.ndarray:
        """Each row's weighted first-order sensitivity to a component's error joint.

        Parameters
        ----------
        E : ndarray, shape (N, 6, n_error_joints)
            First-order sensitivity of the error to every error joint.
        joints : list of str
            The error joints, in the order of ``E``.
        component : str
            The component.

        Returns
        -------
        ndarray, shape (rows,)
            ``w . E[point, :, component] / sigma`` of every row.
        """
        key = (id(E), component)
        weight = self.weights.get(key)  # threads score candidates at once: read once
        if weight is None:
            if len(self.weights) > 256:
                self.weights = {}
            obs = self.obs
            col = E[:, :, joints.index(component)]                 # (points, 6)
            weight = self.weights[key] = np.einsum("rk,rk->r", obs.w, col[obs.point]) / obs.sigma
        return weight


def _scaled(A: np.ndarray) -> np.ndarray:
    """A's non-negligible columns scaled to unit norm."""
    if A.shape[1] == 0:
        return A
    norms = np.linalg.norm(A, axis=0)
    ok = norms > 1e-12 * max(norms.max(), 1e-300)
    return A[:, ok] / norms[ok]


def _svd(A: np.ndarray, rtol: float = SVD_RTOL):
    """(U, s, Vt) of A truncated to the singular values above ``rtol`` of the largest."""
    if A.shape[1] == 0:
        return np.zeros((A.shape[0], 0)), np.zeros(0), np.zeros((0, 0))
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    keep = s > rtol * s[0] if s.size and s[0] > 0 else np.zeros(s.size, bool)
    return U[:, keep], s[keep], Vt[keep]


def _halves_basis(A: np.ndarray, rtol: float = SVD_RTOL):
    """(U, s) of :func:`_svd`, from the two halves of A's rows: each half's QR factor (with its
    orthonormal Q), the SVD of the two factors stacked, and each half's rows of U as its Q times
    its block of that SVD's left vectors. The halves are computed by the two processes of a
    diagnosis run in step (:mod:`volerr_pin.lockstep`), else one after the other; both ways give
    the same basis to the last bit (one process: 0.94 to 0.96 of the time of ``numpy.linalg.svd``
    on 12,000 x 130). Too few rows for halves of at least A's columns: :func:`_svd`."""
    m, n = A.shape
    if n == 0 or m < max(2 * n, HALVES_MIN_ROWS):
        return _svd(A, rtol)[:2]
    halves = [A[:m // 2], A[m // 2:]]
    group = lockstep.active()
    run = group.map if group is not None else (lambda fn, items, tag: [fn(x) for x in items])
    q = {}   # each half's Q, kept by the process that factored it

    def factor(k):
        # a copy (asfortranarray of one column's rows is a view, which geqrf would overwrite)
        qr, tau, _, info = lapack.dgeqrf(np.array(halves[k], order="F"), overwrite_a=1)
        if info != 0:  # pragma: no cover - only for arguments this function never passes
            raise RuntimeError(f"LAPACK geqrf failed (info {info})")
        R = np.triu(qr[:n])
        q[k] = lapack.dorgqr(qr, tau, overwrite_a=1)[0]
        return R

    U2, s, _ = np.linalg.svd(np.vstack(run(factor, [0, 1], "basis factors")), full_matrices=False)
    keep = s > rtol * s[0] if s[0] > 0 else np.zeros(s.size, bool)
    U2, s = U2[:, keep], s[keep]
    def rows(k):
        if k not in q:   # the other process of a group ended before its half's rows: factored here
            factor(k)
        return q[k] @ U2[k * n:(k + 1) * n]

    return np.vstack(run(rows, [0, 1], "basis rows")), s


def _small_lstsq(G: np.ndarray, r: np.ndarray, tol: float = 1e-6, covariance: bool = False):
    """Least squares with few columns through the eigen-decomposition of G^T G: (rank with
    singular values above ``tol`` (G's columns have unit norm), coefficients, rss), and with
    ``covariance`` the coefficients' covariance for a unit variance of ``r`` last (that of the
    minimum-norm solution when the rank is below G's columns)."""
    w, V = np.linalg.eigh(G.T @ G)
    keep = w > tol**2
    b = V.T @ (G.T @ r)
    gamma = V[:, keep] @ (b[keep] / w[keep])
    res = r - G @ gamma
    out = int(keep.sum()), gamma, float(res @ res)
    if covariance:
        out += ((V[:, keep] / w[keep]) @ V[:, keep].T,)
    return out


def _gram_lstsq(GtG: np.ndarray, Gtr: np.ndarray, rr: float | None = None, covariance: bool = False):
    """:func:`_small_lstsq` from ``G^T G``, ``G^T r`` and ``r^T r`` (the rss is ``r^T r`` less
    what the fit explains), without G. Each eigenvalue of ``G^T G`` must be either at least
    :data:`GRAM_MIN` (a direction the candidate adds) or below :data:`GRAM_ZERO` (one in the
    base's span, which :func:`_small_lstsq` cuts too), and (with ``rr``) the fit must leave at
    least :data:`GRAM_MIN` of ``r^T r``; else None: the products cannot tell."""
    w, V = np.linalg.eigh(GtG)
    if np.any((w >= GRAM_ZERO) & (w < GRAM_MIN)):
        return None
    keep = w >= GRAM_MIN
    w, V = w[keep], V[:, keep]
    b = V.T @ Gtr
    gamma = V @ (b / w)
    if rr is None:
        return gamma
    rss = rr - float(b @ (b / w))
    if rss < GRAM_MIN * rr:
        return None
    out = w.size, gamma, rss
    if covariance:
        out += ((V / w) @ V.T,)
    return out


def _unit_columns(C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """C's columns scaled to unit norm, and their norms (1 for a zero column)."""
    norms = np.linalg.norm(C, axis=0)
    norms[norms == 0] = 1.0
    return C / norms, norms


@dataclass
class _Fold:
    """One cross-validation fold of a round's projector.

    Attributes
    ----------
    T, V : ndarray of bool, shape (rows,)
        Its training and validation rows.
    rows : ndarray, shape (rows in T, rank), or None
        The basis its training fit is in, on the training rows (``X_T``); None for a fold
        fitted from the all-rows basis ``U`` until ``X_T`` is first asked for.
    X_V : ndarray, shape (rows in V, rank)
        That basis on the validation rows.
    W : ndarray, shape (rank, rank), or None
        ``(X_T^T X_T)^-1`` when ``X_T`` is rows of the all-rows basis; None when the fold is
        factored on its own (``X_T`` orthonormal).
    pos_V : ndarray of bool
        Which validation rows are position rows.
    e_T, e_V : ndarray
        The base residual less the training fit, on the training and the validation rows.
    coef : ndarray
        The training fit of the base residual, in ``X_T``'s coordinates.
    gram : bool
        Whether a candidate's training fit comes from products over all rows less those over
        the validation rows (:data:`GRAM_FOLD_SEEN`; only for a fold fitted from the all-rows
        basis).
    Xe : ndarray
        ``X_T^T e_T`` (zero but for rounding), for those products.
    U : ndarray, shape (rows, rank), or None
        The all-rows basis, for a fold fitted from it.
    """

    T: np.ndarray
    V: np.ndarray
    rows: np.ndarray | None   # X_T, or None: the training rows of ``U``, taken when first asked for
    X_V: np.ndarray
    W: np.ndarray | None
    pos_V: np.ndarray
    e_T: np.ndarray | None = None
    e_V: np.ndarray | None = None
    coef: np.ndarray | None = None
    gram: bool = False
    Xe: np.ndarray | None = None
    U: np.ndarray | None = None

    @property
    def X_T(self) -> np.ndarray:
        """The basis of the training fit on the training rows; a fold fitted from the all-rows
        basis ``U`` takes its rows of it when first asked (a copy of rows x rank per fold that the
        small products of most candidates never need)."""
        if self.rows is None:
            self.rows = self.U[self.T]
        return self.rows

    @property
    def own_basis(self) -> bool:
        """Whether the fold is factored on its own rather than fitted from the all-rows basis."""
        return self.W is None

    def coordinates(self, Y: np.ndarray) -> np.ndarray:
        """The training fit of ``Y``'s training rows (one column or several) in ``X_T``'s
        coordinates: ``W X_T^T Y``."""
        B = self.X_T.T @ Y
        return B if self.W is None else self.W @ B


class Projector:
    """Least squares of a candidate jointly with the base design, by projection.

    The base design ``A`` (weighted rows x base coefficients) and residual ``r`` are fixed for
    a round; an orthonormal basis of the design on all rows, and from its rows every
    cross-validation training fit, are computed once, so a candidate costs a few small products.

    Parameters
    ----------
    A : ndarray, shape (rows, n)
        The base design, weighted.
    r : ndarray, shape (rows,)
        The base residual, weighted.
    obs : Observations
        The observations.
    folds : list of ndarray of int
        The points held out in each fold.
    """

    def __init__(self, A: np.ndarray, r: np.ndarray, obs: Observations, folds: list[np.ndarray]):
        self.obs = obs
        self.r = r
        A = _scaled(A)
        pos = ~obs.angular
        self.Q, s_all = _halves_basis(A)   # the basis candidates are fitted on (all rows)
        U = self.Q
        self.rank = U.shape[1]
        held = [np.isin(obs.point, test) for test in folds]
        rows_of_basis = {}   # U[T] of the folds this process solved

        def solve(k):
            # a training fit predicts the validation rows as X_V W X_T^T r[T], and its own rows
            # as X_T W X_T^T r[T]: from the rows of the basis of all rows (X = U, W = (U_T^T
            # U_T)^-1, which needs no factorisation of the training set), or - when the training
            # rows barely see a direction - from the training set's own truncated SVD (X_T = its
            # basis, X_V = A[V] pinv(A[T]) X_T, W = I), as every fold was fitted before. The
            # first is taken only where the second would keep every direction of U: A[T]'s
            # singular values are at least sqrt(w_min) s_min and at most s_max, so none falls
            # below the SVD's cut (SVD_RTOL of the largest). The fold's fit of the base residual
            # is made here too. What is returned travels between the processes of a diagnosis in
            # step: W and the fit, not U's rows
            V = held[k]
            T = ~V
            X_T = rows_of_basis[k] = U[T]
            w, Z = np.linalg.eigh(X_T.T @ X_T)
            if w.size and w[0] >= FOLD_SEEN and math.sqrt(w[0]) * s_all[-1] >= SVD_RTOL * s_all[0]:
                W, gram, X_V, own = (Z / w) @ Z.T, bool(w[0] >= GRAM_FOLD_SEEN), U[V], None
            else:
                del rows_of_basis[k]
                X_T, s, Vt = _svd(A[T])
                W, gram, X_V = None, False, A[V] @ (Vt.T / s) if s.size else np.zeros((int(V.sum()), 0))
                own = X_T, X_V
            coef = X_T.T @ r[T] if W is None else W @ (X_T.T @ r[T])
            e_T = r[T] - X_T @ coef
            return W, gram, own, coef, e_T, r[V] - X_V @ coef, X_T.T @ e_T

        def fold(k, solved):
            W, gram, own, coef, e_T, e_V, Xe = solved
            V = held[k]
            if own is not None:
                X_T, X_V = own
            else:   # the training rows of U: those this process took in solving it, or when asked for
                X_T, X_V = rows_of_basis.pop(k, None), U[V]
            return _Fold(~V, V, X_T, X_V, W, pos[V], e_T=e_T, e_V=e_V, coef=coef, gram=gram, Xe=Xe, U=U)

        group = lockstep.active()
        solved = (group.map(solve, range(len(folds)), "folds") if group is not None
                  else parallel_map(solve, range(len(folds))))
        self.folds = [fold(k, x) for k, x in enumerate(solved)]
        # Q^T row by row: its products with a candidate's few columns took 1.3 to 2 times as long
        # through the transposed view
        self.QT = np.ascontiguousarray(self.Q.T)
        self.Qr, self.rr = self.QT @ r, float(r @ r)
        self.cv_rms = self._cv(lambda f: np.zeros(f.e_V.shape))
        self.cv_max = self.last_max

    def _cv(self, correction) -> float:
        sq, count, peak = 0.0, 0, 0.0
        obs = self.obs
        for f in self.folds:
            V, pos_V = f.V, f.pos_V
            res = (f.e_V - correction(f)) * obs.sigma[V]
            per_point = point_squares(obs.point[V][pos_V], res[pos_V])
            sq += per_point.sum()
            count += per_point.size
            peak = max(peak, float(np.sqrt(per_point.max())) if per_point.size else 0.0)
        self.last_max = peak * UM_PER_M
        return float(np.sqrt(sq / count) * UM_PER_M) if count else math.nan

    def _against_base(self, C: np.ndarray, covariance: bool = False):
        """Least squares of C's columns, scaled to unit norm, less their projection on the base
        design (:func:`_small_lstsq`'s result) and the norms they were scaled by: from small
        products where they give it (:func:`_gram_lstsq`), else from the rows."""
        Cs, norms = _unit_columns(C)
        B = self.QT @ Cs
        out = _gram_lstsq(Cs.T @ Cs - B.T @ B, Cs.T @ self.r - B.T @ self.Qr, self.rr, covariance)
        if out is None:
            out = _small_lstsq(Cs - self.Q @ B, self.r, covariance=covariance)
        return out, norms

    def fit(self, C: np.ndarray) -> tuple[int, float, np.ndarray]:
        """Least squares of the candidate's columns jointly with the base.

        Parameters
        ----------
        C : ndarray, shape (rows, k)
            The candidate's weighted columns.

        Returns
        -------
        tuple of (int, float, ndarray)
            The rank it adds, the residual sum of squares after, and its coefficients in C's
            units.
        """
        (extra, gamma, rss), norms = self._against_base(C)
        if extra == 0:
            return 0, self.rr, np.zeros(C.shape[1])
        return extra, rss, gamma / norms

    def covariance(self, C: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, int]:
        """Least squares of the candidate's columns jointly with the base, with the
        covariance of its coefficients.

        Parameters
        ----------
        C : ndarray, shape (rows, k)
            The candidate's weighted columns.

        Returns
        -------
        tuple of (ndarray, ndarray, float, int)
            Its coefficients (k,) in C's units, their covariance (k, k) for a unit variance of
            the weighted residual (multiply by the residual variance), the residual sum of
            squares after and the rank it adds (the covariance is that of the minimum-norm
            solution when the rank is below k).
        """
        (extra, gamma, rss, cov), norms = self._against_base(C, covariance=True)
        return gamma / norms, cov / np.outer(norms, norms), rss, extra

    def cv(self, C: np.ndarray) -> float:
        """k-fold cross-validated RMS with the candidate.

        Parameters
        ----------
        C : ndarray, shape (rows, k)
            The candidate's weighted columns.

        Returns
        -------
        float
            RMS over held-out points of the position residual norm [um].
        """
        Cs, norms = _unit_columns(C)
        P, CC, Cr = self.QT @ Cs, Cs.T @ Cs, Cs.T @ self.r

        def correction(f):
            Cs_V = Cs[f.V]
            if f.gram:
                # the training rows' products are all rows' less the validation rows' (X_T, X_V
                # are rows of Q): no pass over the training rows
                P_T = P - f.X_V.T @ Cs_V
                B = f.W @ P_T
                gamma = _gram_lstsq(CC - Cs_V.T @ Cs_V - P_T.T @ B,
                                    Cr - Cs_V.T @ self.r[f.V] - P_T.T @ f.coef - B.T @ f.Xe)
                if gamma is not None:
                    return Cs_V @ gamma - f.X_V @ (B @ gamma)
            B = f.coordinates(Cs[f.T])
            G_T = Cs[f.T] - f.X_T @ B   # the candidate less its training fit by the base
            _, gamma, _ = _small_lstsq(G_T, f.e_T)
            return (Cs_V - f.X_V @ B) @ gamma

        return self._cv(correction)


def repeat_check(proj: Projector, obs: Observations, C: np.ndarray, angle: np.ndarray) -> dict | None:
    """Whether an error periodic in a rotary axis' angle repeats from one turn to the next.

    A true per-revolution error has the same value at an angle and one turn later; a smooth
    function over more than one turn does not, though it has content at the same period. The
    candidate's columns are fitted again split by turn (separate coefficients for the points
    in the first turn of the measured span, ``angle < min + 2 pi``, and for the rest) jointly
    with the base, and the per-turn coefficients are compared: the error does not repeat when
    their difference is both larger than :data:`REPEAT_RATIO` times the common amplitude and
    larger than :data:`REPEAT_SIGMAS` standard uncertainties of the difference (a chi with
    as many degrees of freedom as coefficients; the variance from the split fit's residual,
    which holds what the model still misses).

    Parameters
    ----------
    proj : Projector
        The round's projector.
    obs : Observations
        The observations.
    C : ndarray, shape (rows, k)
        The candidate's weighted columns (the sine and cosine of a periodic error).
    angle : ndarray, shape (N,)
        The axis' angle at every point [rad].

    Returns
    -------
    dict or None
        None when the span is one turn or less, or a turn holds fewer than
        :data:`REPEAT_MIN_POINTS` points (nothing to compare); else ``repeats`` (bool),
        ``amplitude`` (the common fit's amplitude, the norm of its coefficients, SI),
        ``turns`` (the per-turn coefficients, (2, k), SI), ``difference`` (the norm of their
        difference, SI), ``ratio`` (difference / amplitude) and ``sigmas`` (the difference in
        standard uncertainties).
    """
    lo = float(angle.min())
    if np.ptp(angle) <= 2 * np.pi * (1 + 1e-9):
        return None
    first = angle < lo + 2 * np.pi
    if min(first.sum(), (~first).sum()) < REPEAT_MIN_POINTS:
        return None
    k = C.shape[1]
    rows = first[obs.point][:, None]
    common = proj.fit(C)[2]
    gamma, cov, rss, extra = proj.covariance(np.hstack([C * rows, C * ~rows]))
    dof = len(proj.r) - proj.rank - extra
    if extra < 2 * k or dof <= 0:
        return None  # the turns cannot be told apart with this base
    variance = rss / dof
    diff = gamma[:k] - gamma[k:]
    cov_diff = variance * (cov[:k, :k] + cov[k:, k:] - cov[:k, k:] - cov[k:, :k])
    chi2 = float(diff @ np.linalg.solve(cov_diff, diff))
    amplitude = float(np.linalg.norm(common))
    difference = float(np.linalg.norm(diff))
    ratio = difference / amplitude if amplitude > 0 else math.inf
    sigmas = math.sqrt(max(chi2, 0.0))
    return {"repeats": not (ratio > REPEAT_RATIO and sigmas > REPEAT_SIGMAS), "amplitude": amplitude,
            "turns": np.stack([gamma[:k], gamma[k:]]), "difference": difference, "ratio": ratio,
            "sigmas": sigmas}


def not_repeating(proj: Projector, obs: Observations, C: np.ndarray, angle: np.ndarray, cand: Candidate,
                  number: int) -> str | None:
    """Why an error periodic in a rotary axis' angle is not a per-revolution error, when it
    does not repeat from one turn to the next (:func:`repeat_check`).

    Parameters
    ----------
    proj : Projector
        The round's projector.
    obs : Observations
        The observations.
    C : ndarray, shape (rows, k)
        The candidate's weighted columns.
    angle : ndarray, shape (N,)
        The axis' angle at every point [rad].
    cand : Candidate
        The candidate (a ``periodic_rotary`` one).
    number : int
        The round (from 0).

    Returns
    -------
    str or None
        The reason, with the per-turn coefficients [arcsec]; None when it repeats or the data
        cannot tell (one turn or less, too few points on a turn).
    """
    check = repeat_check(proj, obs, C, angle)
    if check is None or check["repeats"]:
        return None
    turns = ", ".join(f"turn {k + 1}: " + "/".join(f"{v / ARCSEC:.2f}" for v in t)
                      for k, t in enumerate(check["turns"]))
    return (f"not accepted in round {number + 1}: it does not repeat from one turn of {cand.axis} to the next "
            f"(sine/cosine fitted on each turn apart, {turns} arcsec, differ by "
            f"{check['difference'] / ARCSEC:.2f} arcsec: {check['ratio']:.2f} of the common amplitude of "
            f"{check['amplitude'] / ARCSEC:.2f} arcsec and {check['sigmas']:.1f} standard uncertainties), "
            f"so it is a smooth shape of {cand.component} over the turns, which raising it models")


def periodogram_period(obs: Observations, r: np.ndarray, gain: np.ndarray, axis_index: int
                       ) -> tuple[float, float] | None:
    """Period of the strongest sinusoid along an axis in the residual that an error of the
    axis' own motion leaves, among the plausible ones (:data:`PITCH_PERIOD_MM`, at least
    :data:`MIN_PERIODS` periods in the measured span, at least two points per period on
    average), and the number of independent periods searched (for the look-elsewhere
    correction).

    A positioning error ``p(x)`` of the axis moves the tool along the axis' own direction at
    the tool, which turns with every rotary axis between the axis and the workpiece; a row of
    the observations sees it as ``gain * p(x)``, where ``gain`` is the row's weighted
    sensitivity to the component (its direction in the row's measured direction). So each
    point's rows give one least-squares value of ``p`` at the point, weighted by the sum of
    the squared gains, and the weighted Lomb-Scargle periodogram (floating mean) of those
    values picks the period. (A component named by the axis letter in the workpiece frame is
    the pitch only while nothing turns the workpiece: over a turn of a table under it, it
    holds the pitch times the cosine of the angle, which averages out.)

    Parameters
    ----------
    obs : Observations
        The observations.
    r : ndarray, shape (rows,)
        The weighted residual.
    gain : ndarray, shape (rows,)
        Each row's weighted sensitivity to the component whose period is sought (its first-order
        sensitivity to the component's error joint, dotted with the row's direction, over its
        standard deviation).
    axis_index : int
        The axis.

    Returns
    -------
    tuple of (float, float) or None
        The period [m] and the independent periods searched; None when no period is plausible
        for these data.
    """
    n = obs.n_points
    weight = np.bincount(obs.point, weights=gain * gain, minlength=n)
    seen = weight > 1e-12 * max(float(weight.max(initial=0.0)), 1e-300)
    if seen.sum() < 20:
        return None
    # each point's least-squares value of the error along the axis' own direction [m]
    y = (np.bincount(obs.point, weights=gain * r, minlength=n)[seen] / weight[seen])
    x, weight = obs.q[seen, axis_index], weight[seen]
    if x.size > PERIODOGRAM_POINTS:  # enough to pick the period; the fit then uses every point
        keep = np.random.default_rng(0).choice(x.size, PERIODOGRAM_POINTS, replace=False)
        x, y, weight = x[keep], y[keep], weight[keep]
    span = float(np.ptp(x))
    if span <= 0:
        return None
    u = 2 * (x - x.min()) / span - 1
    y = y - np.polynomial.legendre.legval(u, np.polynomial.legendre.legfit(u, y, 5, w=np.sqrt(weight)))
    shortest = max(PITCH_PERIOD_MM[0] * 1e-3, 2 * span / len(np.unique(x)))
    longest = min(PITCH_PERIOD_MM[1] * 1e-3, span / MIN_PERIODS)
    if shortest >= longest:
        return None
    independent = max(1.0, span * (1 / shortest - 1 / longest))

    def power(f):
        return lombscargle(x, y, 2 * np.pi * f, weights=weight, floating_mean=True)

    # one frequency per independent period, then a finer look around the strongest
    f = np.linspace(1 / longest, 1 / shortest, int(min(2000, independent)) + 2)
    k = int(np.argmax(power(f)))
    fine = np.linspace(f[max(k - 1, 0)], f[min(k + 1, len(f) - 1)], 17)
    return float(1.0 / fine[int(np.argmax(power(fine)))]), independent


def table_interpolation(base: Base, proj: Projector, E: np.ndarray, joints: list[str], cand: Candidate,
                        C: np.ndarray, gamma: np.ndarray, columns: Columns) -> str | None:
    """Why a periodic error of an axis is its component's table's interpolation, when it is.

    A table leaves, between its nodes, the residual of a smooth function, which repeats at the
    node spacing and its harmonics; a ball screw's error does neither. So the periodic error is
    fitted again beside the table one step richer between its nodes
    (:func:`~volerr_pin.diagnose.candidates.smoother_table`), jointly with the base: the
    table's residual goes into the richer table, a screw's error stays. The periodic error is
    the table's unless its amplitude stays within :data:`SURVIVES` of what it was and its
    inverse (a sinusoid the richer table can take as well is no longer determined beside it,
    and its amplitude wanders).

    Parameters
    ----------
    base : Base
        The round's base.
    proj : Projector
        Its projector.
    E : ndarray, shape (N, 6, n_error_joints)
        First-order sensitivity of the error to every error joint.
    joints : list of str
        The error joints, in the order of ``E``.
    cand : Candidate
        The periodic error (its period set).
    C : ndarray, shape (rows, k)
        Its weighted columns (sine and cosine).
    gamma : ndarray, shape (k,)
        Its coefficients in the joint fit with the base (SI).
    columns : Columns
        The cache of candidate columns.

    Returns
    -------
    str or None
        The reason, with both amplitudes [um]; None when the error survives, the component has
        no table, or the table cannot be made richer.
    """
    smoother = smoother_table(base.machine, cand.component)
    if smoother is None:
        return None
    table, how = smoother
    richer = Candidate(cand.name, cand.axis, cand.direction, cand.component, table,
                       label=f"{cand.component} richer between its nodes", kind="raise")
    C_table = columns(base.machine, E, joints, richer)[0]
    before = float(np.linalg.norm(gamma))
    after = float(np.linalg.norm(proj.fit(np.hstack([C_table, C]))[2][-C.shape[1]:]))
    if SURVIVES * before <= after <= before / SURVIVES:
        return None
    why = ("its amplitude falls" if after < before else
           "the richer table takes the same shape: its amplitude is no longer determined, and goes")
    return (f"the interpolation of {cand.component}'s table, not a screw's error: beside the table made richer "
            f"between its nodes ({how}) {why} from {before * UM_PER_M:.3f} to {after * UM_PER_M:.3f} um; "
            "the table's raise refines it")


def score(base: Base, proj: Projector, obs: Observations, E: np.ndarray, joints: list[str], cand: Candidate,
          cov_obj: Covariates, axis_index_of: dict[str, int], columns: Columns) -> Score | None:
    """Fit the candidate jointly with the base (linearised) and score it.

    Parameters
    ----------
    base : Base
        The round's base.
    proj : Projector
        Its projector.
    obs : Observations
        The observations.
    E : ndarray, shape (N, 6, n_error_joints)
        First-order sensitivity of the error to every error joint.
    joints : list of str
        The error joints, in the order of ``E``.
    cand : Candidate
        The candidate (a pitch's period is set here, from the periodogram).
    cov_obj : Covariates
        The checked covariates (grids of non-linear coefficients span them).
    axis_index_of : dict of str to int
        Axis name -> index.
    columns : Columns
        The cache of candidate columns.

    Returns
    -------
    Score or None
        Its score; None for a pitch with no plausible period.
    """
    n = len(base.r)
    searched = 1.0
    if cand.name == "periodic_pitch" and cand.kind == "effect":
        found = periodogram_period(obs, base.r, columns.gain(E, joints, cand.component), axis_index_of[cand.axis])
        if found is None:
            return None
        period, searched = found
        cand.table = dict(cand.table, period_mm=period * 1e3)
    _, tspec, coefs = columns(base.machine, E, joints, cand)
    nonlinear = [tspec.term.local_names.index(k) for k in tspec.term.nonlinear]
    lin = [i for i in range(len(coefs)) if i not in nonlinear]
    full = np.array([np.nan])
    if nonlinear and cand.name not in ("periodic_pitch", "periodic_rotary"):  # periods: periodogram, revolution
        full = np.asarray(tspec.term.search_grid(tspec.term.local_names[nonlinear[0]], coefs, cov_obj))
    tried: dict = {}

    def trial(k):
        if k not in tried:
            value = full[k]
            c = coefs.copy()
            if not np.isnan(value):
                c[nonlinear[0]] = value
            # columns of the linear coefficients at this value of the non-linear one
            C, _, _ = columns(base.machine, E, joints, cand, None if np.isnan(value) else c, lin)
            extra, rss1, gamma = proj.fit(C)
            tried[k] = (extra, rss1, gamma, c, C)
        return tried[k]

    # a coarse pass over every third grid value, then the values around the best one
    coarse = range(0, len(full), 3) if len(full) > 6 else range(len(full))
    best = min(coarse, key=lambda k: trial(k)[1])
    best = min(range(max(0, best - 2), min(len(full), best + 3)), key=lambda k: trial(k)[1])
    extra, rss1, gamma, c, C = tried[best]
    rss0 = float(base.r @ base.r)
    if extra == 0 or rss1 <= 0:
        return Score(cand.label, 0, 1.0, 0.0, proj.cv_rms, 0.0, cand)
    k = extra + len(nonlinear)
    dof = n - proj.rank - k
    F = ((rss0 - rss1) / k) / (rss1 / dof) if dof > 0 else 0.0
    p_value = min(1.0, float(stats.f.sf(F, k, dof)) * searched) if dof > 0 else 1.0
    bic_gain = n * math.log(rss0 / rss1) - k * math.log(n) - 2 * math.log(searched)
    values = c.copy()
    values[lin] = gamma
    out = Score(cand.label, int(extra), p_value, float(bic_gain), None, (rss0 - rss1) / rss0 if rss0 > 0 else 0.0,
                cand, tspec, values, C)
    if cand.name == "periodic_pitch" and cand.kind == "effect":
        note = table_interpolation(base, proj, E, joints, cand, C, gamma, columns)
        if note:   # the table's, not a screw's: its raise refines the table
            return Score(cand.label, 0, 1.0, 0.0, proj.cv_rms, 0.0, cand, note=note)
    return out
