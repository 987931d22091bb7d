"""The solver of a fit: damped Gauss-Newton on the exact sensitivities, start values of the
non-linear coefficients by grid search, and standard uncertainties from the triangular
factor of the weighted design (see :mod:`~volerr_pin.fit.identify`).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ...model import search_grid, sensitivity, volumetric_error
from .._identifiability import Analysis, analyse
from ._design import (FitPoints, column_scale, default_rcond, point_chunks, reduce_design,
                     refuse_non_finite, rows_of, stacked_factor, typical_sizes, weighted_residual)

__all__ = ["CONDITION_LIMIT", "conditioning_note", "ill_conditioned", "initialise_nonlinear", "solve",
           "standard_uncertainties"]

#: above this condition number of the column-scaled design, rounding (about condition x 2.2e-16
#: of the coefficients' scale) reaches 1e-4: fewer than four of double precision's sixteen
#: digits are left along the weakest direction, and a fit says so
CONDITION_LIMIT = 1e12


def solve(points: FitPoints, theta0: np.ndarray, free: np.ndarray,
          columns: np.ndarray | None, convention: str, max_iter: int, tol: float,
          step: Callable[[int], None] | None = None) -> tuple:
    """Gauss-Newton on [nuisance | free[columns]], damped (Levenberg-Marquardt, growing
    damping) when a full step does not lower the residual or would make a time constant or
    period non-positive.

    Parameters
    ----------
    points : FitPoints
        The observations and their points checked for the model.
    theta0 : ndarray, shape (P,)
        Start values (SI); the nuisance terms start at 0 (they are linear).
    free : ndarray of int, shape (F,)
        The coefficients that may move.
    columns : ndarray of int, optional
        Which of ``free`` are fitted (the identifiable ones); None: all, min-norm steps.
    convention : str
        "prior" or "min-norm" (the singular-value cut of the steps).
    max_iter : int
        Iteration limit.
    tol : float
        Convergence threshold on a full step, in standard deviations (column-scaled).
    step : callable(int), optional
        Called after every accepted step with its number.

    Returns
    -------
    tuple
        ``theta`` (P,), ``nuisance`` (n_nuisance,), ``R_J`` (the triangular factor of the
        weighted design, see :func:`~volerr_pin.fit.identify._design.reduce_design`), ``r``
        (rows,) the weighted residual, the iterations, and the status: "converged" (the
        linearised model cannot lower the residual; a full Gauss-Newton step, or three damped
        ones running, lower the weighted RSS by less than 0.001 or 1e-10 of itself; or the
        step is below ``tol``), "stalled" (no step, however damped, lowers the residual
        although the linearised model says one should: the model is far from linear there, or
        badly conditioned) or "iteration limit".
    """
    obs, model = points.obs, points.model
    theta = theta0.copy()
    n_nu = obs.nuisance.shape[1]
    nuisance = np.zeros(n_nu)
    use = np.arange(len(free)) if columns is None else columns
    positive = np.array([k in set(model.nonlinear_parameters) for k in free[use]], dtype=bool)
    n_cols = n_nu + len(use)
    rcond = 1e-9 if convention == "min-norm" else default_rcond(len(obs.y), n_cols)
    it = 0
    status = "iteration limit"
    flat = 0
    reduced = None  # the residual and factor at the present theta, once computed
    for it in range(1, max_iter + 1):
        r, R = reduced = reduce_design(points, theta, free[use], nuisance)
        z = R[:, -1]
        scale, Rs = column_scale(R[:, :-1], typical=typical_sizes(model, theta, free[use], n_nu))
        step_scaled = np.linalg.lstsq(Rs, z, rcond=rcond)[0]
        delta = step_scaled / scale
        rss = float(r @ r)
        predicted = z - Rs @ step_scaled
        gain = float(z @ z) - float(predicted @ predicted)
        if gain <= 1e-12 * rss:
            status = "converged"  # the linearised model cannot lower the residual
            break
        # Gauss-Newton first; if its step does not lower the residual (far from linear, or
        # nearly singular directions that passed the rank test), Levenberg-Marquardt steps
        # with growing damping on the column-scaled problem, down to gradient-descent ones
        accepted = None
        for damping in (0.0, *(10.0 ** k for k in range(-6, 7))):
            if damping:
                augmented = np.vstack([Rs, math.sqrt(damping) * np.eye(Rs.shape[1])])
                step_scaled = np.linalg.lstsq(augmented, np.concatenate([z, np.zeros(Rs.shape[1])]),
                                              rcond=default_rcond(len(obs.y) + n_cols, n_cols))[0]
                delta = step_scaled / scale
            trial_theta = theta.copy()
            trial_theta[free[use]] += delta[n_nu:]
            trial_nu = nuisance + delta[:n_nu]
            if not np.all(trial_theta[free[use]][positive] > 0):
                continue
            trial_r = weighted_residual(points, trial_theta, trial_nu)
            if float(trial_r @ trial_r) <= rss * (1 + 1e-12) + 1e-300:
                accepted = damping
                break
        if accepted is None:
            # no step decreases the residual: at the minimum to rounding when the promised
            # gain is at the rounding level, otherwise stuck
            status = "converged" if gain <= 1e-6 * rss else "stalled"
            break
        theta, nuisance, reduced = trial_theta, trial_nu, None
        if step:
            step(it)
        flat = flat + 1 if rss - float(trial_r @ trial_r) <= max(1e-10 * rss, 1e-3) else 0
        if (accepted == 0.0 and flat) or flat >= 3:
            # chi-square (weighted RSS) moved by less than 0.001 in a full step, or in three
            # damped ones running: the parameters move by far less than their uncertainties -
            # a flat valley is being crawled, not descended
            status = "converged"
            break
        # step size in units of the observations' standard deviations
        if accepted == 0.0 and np.abs(delta * scale).max(initial=0.0) < tol:
            status = "converged"
            break
    # the loop ends at the theta of its last design (no step taken) or after a step
    r, R = reduced if reduced is not None else reduce_design(points, theta, free[use], nuisance)
    return theta, nuisance, R[:, :-1], r, it, status


def initialise_nonlinear(points: FitPoints, theta: np.ndarray, free: np.ndarray,
                         rtol: float = 1e-9, progress=None) -> np.ndarray:
    """Variable projection by grid search: for each free non-linear coefficient (time
    constant, period), try the candidates of its term's grid (and the prior value), fitting
    the identifiable linear coefficients and nuisance terms for each, and keep the best. The
    Gauss-Newton fit then refines all of them together. Every candidate's design is reduced
    to its triangular factor in one pass over chunks of points (see
    :func:`~volerr_pin.fit.identify._design.reduce_design`).

    Parameters
    ----------
    points : FitPoints
        The observations and their points checked for the model.
    theta : ndarray, shape (P,)
        Present coefficients (SI).
    free : ndarray of int
        The coefficients that may move.
    rtol : float, default 1e-9
        Relative tolerance of the identifiability test of the linear coefficients.
    progress : callable(str, int), optional
        Called with a stage name and a step count.

    Returns
    -------
    ndarray, shape (P,)
        ``theta`` with the best grid value of every free non-linear coefficient (and the
        linear ones fitted with it).
    """
    obs, model = points.obs, points.model
    theta = theta.copy()
    nonlinear = [k for k in model.nonlinear_parameters if k in set(free.tolist())]
    if not nonlinear:
        return theta
    linear = np.array([k for k in free if k not in set(nonlinear)], dtype=int)
    n_nu = obs.nuisance.shape[1]
    _, R = reduce_design(points, theta, linear, np.zeros(n_nu), first_order=True)
    kept = analyse(R[:, :-1], [""] * (R.shape[1] - 1), protected=n_nu, rtol=rtol,
                   typical=typical_sizes(model, theta, linear, n_nu), rows=len(obs.y)).kept
    lin_cols = np.array([c - n_nu for c in kept if c >= n_nu], dtype=int)
    for step, k in enumerate(nonlinear):
        # the columns of the other terms hardly depend on this coefficient: computed once per chunk
        term = next(p for p in model.term_spans() if p.start <= k < p.stop)
        own = np.array([i for i in range(term.start, term.stop) if i in set(linear[lin_cols].tolist())], dtype=int)
        others = np.array([i for i in linear[lin_cols] if i not in set(own.tolist())], dtype=int)
        grid = np.r_[theta[k], search_grid(model, k, theta, points.cov)]
        factors = [np.zeros((0, n_nu + len(others) + len(own) + 1)) for _ in grid]
        for chunk, rows in point_chunks(obs, len(others) + len(own)):
            part = slice(chunk[0], chunk[-1] + 1) if len(chunk) else slice(0, 0)   # consecutive points
            q, cov = points.q[part], points.cov.take(part)
            w, local, sigma = obs.w[rows], obs.point[rows] - part.start, obs.sigma[rows, None]
            # the other terms' columns once per chunk, for every grid value
            error = volumetric_error(model, q, theta, cov)
            _, A_other = rows_of(w, local, error, sensitivity(model, q, theta, cov, columns=others))
            for g, value in enumerate(grid):
                trial = theta.copy()
                trial[k] = value
                error = volumetric_error(model, q, trial, cov)
                pred, A_own = rows_of(w, local, error, sensitivity(model, q, trial, cov, columns=own))
                factors[g] = stacked_factor(factors[g], [obs.nuisance[rows], A_other, A_own, obs.y[rows] - pred],
                                            sigma[:, 0], lambda block: refuse_non_finite(
                                                obs, {"residuals or sensitivities": block}))
        best, best_rss = theta.copy(), math.inf
        for value, R in zip(grid, factors):
            J, z = R[:, :-1], R[:, -1]
            scale, Js = column_scale(J)  # linear coefficients only: SI sizes are typical
            delta = np.linalg.lstsq(Js, z, rcond=default_rcond(len(obs.y), J.shape[1]))[0] / scale
            rss = float(np.sum((z - J @ delta) ** 2))
            if rss < best_rss:
                best_rss = rss
                best = theta.copy()
                best[k] = value
                best[others] += delta[n_nu:n_nu + len(others)]
                best[own] += delta[n_nu + len(others):]
        theta = best
        if progress:
            progress("non-linear start values", step + 1)
    return theta


def standard_uncertainties(R: np.ndarray, rows: int, typical: np.ndarray, covariance: bool = False) -> tuple:
    """Standard uncertainties of the columns of a design from its triangular factor ``R``
    (unit weighted-residual scale), by the SVD of the column-scaled factor (the normal
    matrix would square its condition), and whether directions below rounding were cut: the
    columns they involve are not determined (infinite uncertainty). With ``covariance``, also
    their covariance ``(R^T R)^-1`` from the same SVD.

    Parameters
    ----------
    R : ndarray, shape (m, n)
        Triangular factor of the weighted design.
    rows : int
        Rows of the full design.
    typical : ndarray, shape (n,)
        Typical size of each column's coefficient (see
        :func:`~volerr_pin.fit.identify.typical_sizes`).
    covariance : bool, default False
        Return the covariance too.

    Returns
    -------
    std : ndarray, shape (n,)
        Standard uncertainties per unit weighted-residual scale (inf where not determined).
    cut : bool
        Whether directions below rounding were cut.
    cov : ndarray, shape (n, n)
        Only with ``covariance``: the covariance per unit weighted-residual scale (NaN in the
        rows and columns of the columns not determined).
    """
    scale, Rs = column_scale(R, typical=typical)
    if Rs.size == 0:
        return (np.zeros(R.shape[1]), False) + ((np.zeros((R.shape[1],) * 2),) if covariance else ())
    _, s, Vt = np.linalg.svd(Rs, full_matrices=False)
    keep = s > s[0] * default_rcond(rows, Rs.shape[1]) if s.size and s[0] > 0 else np.zeros(s.size, bool)
    var = (Vt[keep] ** 2 / s[keep, None] ** 2).sum(axis=0)
    undetermined = np.zeros(Rs.shape[1], bool)
    if Vt.shape[0] < Rs.shape[1] or not keep.all():
        # directions of no effect (cut, or beyond the factor's rank): the columns in them
        basis = Vt[keep]
        undetermined = 1.0 - (basis ** 2).sum(axis=0) > 1e-12
    var[undetermined] = np.inf
    out = (np.sqrt(var) / scale, bool(undetermined.any()))
    if not covariance:
        return out
    W = Vt[keep] / s[keep, None]
    cov = (W.T @ W) / np.outer(scale, scale)
    cov[undetermined, :] = np.nan
    cov[:, undetermined] = np.nan
    return out + (cov,)


def ill_conditioned(singular_values: np.ndarray, rows: int) -> bool:
    """Whether a column-scaled design with these singular values is numerically
    rank-deficient (the smallest at rounding level of the largest) or conditioned beyond
    :data:`CONDITION_LIMIT`.

    Parameters
    ----------
    singular_values : ndarray
        Singular values, largest first.
    rows : int
        Rows of the full design.

    Returns
    -------
    bool
        True when ill-conditioned.
    """
    sv = np.asarray(singular_values)
    if sv.size == 0:
        return False
    return bool(sv[-1] <= sv[0] * default_rcond(rows, sv.size) or sv[0] > CONDITION_LIMIT * sv[-1])


def conditioning_note(analysis: Analysis, rows: int) -> str:
    """What an ill-conditioned fit says, in one sentence.

    Parameters
    ----------
    analysis : Analysis
        The identifiability analysis of the fit's design.
    rows : int
        Rows of the full design.

    Returns
    -------
    str
        The note (a warning of :func:`~volerr_pin.fit.identify.identify` and of diagnose).
    """
    sv = analysis.singular_values
    what = (f"condition number {analysis.condition:.3g}" if sv.size and sv[-1] > sv[0] * default_rcond(rows, sv.size)
            else "numerically rank-deficient")
    return (f"the fit is ill-conditioned: its column-scaled design ({analysis.rank} columns kept) is "
            f"{what}, beyond what double precision resolves (limit {CONDITION_LIMIT:.0e}); "
            "the fitted values along its weakest directions are rounding noise: fit fewer terms or lower "
            "degrees, or add data that separate them")
