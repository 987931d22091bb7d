"""The projector of a round: the base model linearised at its fit, an orthonormal basis of
its design computed once per round on all rows, and from its rows every cross-validation
training fit, so that a candidate's joint least squares with the base, its covariance and its
k-fold held-out RMS cost a few small products (:class:`Projector`); a candidate's weighted
columns, cached across rounds (:class:`Columns`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import lapack

from ..identify import FitPoints, Observations, point_squares, predict_observations
from ...model import Context, Covariates, Model, build_term, parse_component_name
from ...base import UM_PER_M
from ._results import Candidate

__all__ = ["FOLD_SEEN", "GRAM_FOLD_SEEN", "GRAM_MIN", "GRAM_ZERO", "HALVES_MIN_ROWS", "SVD_RTOL", "Base", "Columns",
           "Projector", "base_design"]

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


@dataclass
class Base:
    """The base model of a round, linearised.

    Attributes
    ----------
    model : Model
        The base model.
    A : ndarray, shape (rows, n_nuisance + F)
        Weighted design [nuisance | fitted coefficients] of the first-order model.
    r : ndarray, shape (rows,)
        Weighted residual of the exact model.
    """

    model: Model
    A: np.ndarray
    r: np.ndarray


def base_design(points: FitPoints, theta: np.ndarray, fitted: np.ndarray, nuisance: np.ndarray) -> Base:
    """The residual of the exact model and the design of the first-order model (exact
    dependencies) at the base fit.

    Parameters
    ----------
    points : FitPoints
        The observations and their points checked for the base model.
    theta : ndarray, shape (P,)
        The fitted base model's coefficients (SI).
    fitted : ndarray of int
        The coefficients that were fitted.
    nuisance : ndarray, shape (n_nuisance,)
        Fitted nuisance values (SI).

    Returns
    -------
    Base
        Design and residual, weighted.
    """
    obs = points.obs
    pred, A = predict_observations(points, theta, fitted, first_order=True)
    r = (obs.y - pred - obs.nuisance @ nuisance) / obs.sigma
    J = np.hstack([obs.nuisance, A]) / obs.sigma[:, None]
    return Base(points.model, J, r)


class Columns:
    """Weighted columns of a candidate's coefficients, linearised at the base.

    The term's own Jacobian depends only on the positions and covariates, which stay the
    same through the diagnosis: it is computed once per (candidate term, non-linear
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

    def term(self, model: Model, cand: Candidate) -> tuple:
        """The candidate's term and where it is evaluated.

        Parameters
        ----------
        model : Model
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
        axis_index = model.axes.index(owner) if owner in model.axes else None
        travel = tuple(model.travel[axis_index]) if axis_index is not None else None
        position_quantity = None if (location or axis_index is None) else (
            "length" if model.axis_kinds[axis_index] == "linear" else "angle")
        tspec = cand.term if cand.table is None else build_term(
            dict(cand.table), f"candidate {cand.label}", quantity, position_quantity, travel)
        position = None if position_quantity is None else self.obs.q[:, axis_index]
        ctx = Context(position, travel, self.cov_obj, axis_index, cand.component)
        return tspec, ctx

    def __call__(self, model: Model, E: np.ndarray, joints: list[str], cand: Candidate,
                 coefs=None, columns=None):
        """The candidate's weighted columns.

        Parameters
        ----------
        model : Model
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
        what = (repr(sorted(cand.table.items())) if cand.table is not None
                else (repr(cand.term.term), tuple(cand.term.coefficients)))
        key = (cand.component, what, None if coefs is None else tuple(np.round(coefs, 15)))
        entry = self.cache.get(key)
        if entry is None:
            tspec, ctx = self.term(model, cand)
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
    its block of that SVD's left vectors, one half after the other (0.94 to 0.96 of the time of
    ``numpy.linalg.svd`` on 12,000 x 130). Too few rows for halves of at least A's columns: :func:`_svd`."""
    m, n = A.shape
    if n == 0 or m < max(2 * n, HALVES_MIN_ROWS):
        return _svd(A, rtol)[:2]
    halves = [A[:m // 2], A[m // 2:]]
    q = []   # each half's Q

    def factor(half):
        # a copy (asfortranarray of one column's rows is a view, which geqrf would overwrite)
        qr, tau, _, info = lapack.dgeqrf(np.array(half, order="F"), overwrite_a=1)
        if info != 0:  # pragma: no cover - only for arguments this function never passes
            raise RuntimeError(f"LAPACK geqrf failed (info {info})")
        R = np.triu(qr[:n])
        q.append(lapack.dorgqr(qr, tau, overwrite_a=1)[0])
        return R

    U2, s, _ = np.linalg.svd(np.vstack([factor(half) for half in halves]), full_matrices=False)
    keep = s > rtol * s[0] if s[0] > 0 else np.zeros(s.size, bool)
    U2, s = U2[:, keep], s[keep]
    return np.vstack([q[k] @ U2[k * n:(k + 1) * n] for k in range(2)]), s


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

        def fold(k):
            # a training fit predicts the validation rows as X_V W X_T^T r[T], and its own rows
            # as X_T W X_T^T r[T]: from the rows of the basis of all rows (X = U, W = (U_T^T
            # U_T)^-1, which needs no factorisation of the training set), or - when the training
            # rows barely see a direction - from the training set's own truncated SVD (X_T = its
            # basis, X_V = A[V] pinv(A[T]) X_T, W = I), as every fold was fitted before. The
            # first is taken only where the second would keep every direction of U: A[T]'s
            # singular values are at least sqrt(w_min) s_min and at most s_max, so none falls
            # below the SVD's cut (SVD_RTOL of the largest). The fold's fit of the base residual
            # is made here too
            V = held[k]
            T = ~V
            X_T = U[T]
            w, Z = np.linalg.eigh(X_T.T @ X_T)
            if w.size and w[0] >= FOLD_SEEN and math.sqrt(w[0]) * s_all[-1] >= SVD_RTOL * s_all[0]:
                W, gram, X_V = (Z / w) @ Z.T, bool(w[0] >= GRAM_FOLD_SEEN), U[V]
            else:
                X_T, s, Vt = _svd(A[T])
                W, gram, X_V = None, False, A[V] @ (Vt.T / s) if s.size else np.zeros((int(V.sum()), 0))
            coef = X_T.T @ r[T] if W is None else W @ (X_T.T @ r[T])
            e_T = r[T] - X_T @ coef
            # (a fold fitted from the all-rows basis keeps no copy of its training rows of it: they
            # are taken again where a candidate's fit needs them)
            return _Fold(~V, V, X_T if W is None else None, X_V, W, pos[V], e_T=e_T, e_V=r[V] - X_V @ coef,
                         coef=coef, gram=gram, Xe=X_T.T @ e_T, U=U)

        self.folds = [fold(k) for k in range(len(folds))]
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
