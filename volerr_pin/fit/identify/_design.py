"""The weighted design of a fit, built in chunks of points: predictions of the observation
rows, their sensitivities to the coefficients, and the triangular factor that every
least-squares quantity of the fit is computed from (the design itself is never held whole).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from dataclasses import dataclass

from ...base import UM_PER_M, URAD_PER_RAD, InputError
from ...model import Covariates, Model, check_covariates, check_q, sensitivity, volumetric_error
from ._observations import Observations, data_names

__all__ = ["CHUNK_BYTES", "SPLIT_POINTS", "FitPoints", "by_halves", "column_scale", "default_rcond", "point_chunks",
           "predict_observations", "reduce_design", "refuse_non_finite", "rows_of", "stacked_factor", "typical_sizes",
           "weighted_residual"]


@dataclass(frozen=True)
class FitPoints:
    """Observations with their points checked once for a model: the positions within its
    travel and the covariates as its algorithms take them (the machine's state filling in what
    the data do not give, lagged temperatures added). Every evaluation of a fit reads them.

    Attributes
    ----------
    model : Model
        The model the points were checked for.
    obs : Observations
        The observations.
    q : ndarray, shape (N, n_axes)
        Their points' positions [m, rad], checked.
    cov : Covariates
        Their points' covariates, checked.
    """

    model: Model
    obs: Observations
    q: np.ndarray
    cov: Covariates

    @classmethod
    def of(cls, model: Model, obs: Observations, state: dict | None = None) -> "FitPoints":
        """The observations' points checked for a model and a machine's state.

        Parameters
        ----------
        model : Model
            The model (``machine.model``).
        obs : Observations
            The observations.
        state : dict, optional
            The machine's state (``machine.state``): the covariates the data do not give.

        Returns
        -------
        FitPoints
            The checked points.

        Raises
        ------
        InputError
            If a position leaves the travel or a covariate is invalid (:func:`~volerr_pin.model.check_inputs`).
        """
        return cls(model, obs, check_q(model, obs.q), check_covariates(model, obs.n_points, obs.covariates, state))

    def subset(self, points: np.ndarray) -> "FitPoints":
        """The checked points of some points, with their observations (:meth:`Observations.subset`).

        Parameters
        ----------
        points : ndarray of int, shape (M,)
            The points, in the order the new points take.

        Returns
        -------
        FitPoints
            Their observations and checked points.
        """
        return FitPoints(self.model, self.obs.subset(points), self.q[points], self.cov.take(points))


def predict_observations(points: FitPoints, theta: np.ndarray, free: np.ndarray,
                         first_order: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Prediction of every observation row and its Jacobian with respect to the free coefficients.

    Parameters
    ----------
    points : FitPoints
        The observations and their checked points.
    theta : ndarray, shape (P,)
        Coefficients (SI).
    free : ndarray of int, shape (F,)
        Indices of the coefficients to differentiate by.
    first_order : bool, default False
        The Jacobian of the first-order model, where dependencies are exact.

    Returns
    -------
    pred : ndarray, shape (rows,)
        ``w . e(q_point)`` of every row [m or rad] (without the nuisance terms).
    A : ndarray, shape (rows, F)
        d pred / d theta[free] [m or rad per SI unit of the coefficient].
    """
    obs = points.obs
    error, S = error_and_sensitivity(points.model, points.q, theta, free, points.cov, first_order)
    return rows_of(obs.w, obs.point, error, S)


def error_and_sensitivity(model: Model, q: np.ndarray, theta: np.ndarray, columns, cov: Covariates,
                          first_order: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The error at points and its sensitivity to some coefficients, by the model's algorithms.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad], checked.
    theta : ndarray, shape (P,)
        Coefficients (SI).
    columns : ndarray of int, shape (F,)
        Indices of the coefficients to differentiate by.
    cov : Covariates
        The points' covariates, checked.
    first_order : bool, default False
        The sensitivity of the first-order model.

    Returns
    -------
    error : ndarray, shape (N, 6)
        The error [m, rad].
    S : ndarray, shape (N, 6, F)
        d error / d theta[columns].
    """
    columns = np.asarray(columns, dtype=int)
    return (volumetric_error(model, q, theta, cov),
            sensitivity(model, q, theta, cov, columns=columns, first_order=first_order))


def by_halves(points: FitPoints, fn) -> np.ndarray:
    """``fn(q, cov)`` of every point (one row per point), over the two halves of the points
    from :data:`SPLIT_POINTS` points, else over all of them, one after the other (the halves
    keep every result as it was computed: a point's error computed among other points may
    differ from it computed among all of them in the last bit, as vectorised loops start
    elsewhere).

    Parameters
    ----------
    points : FitPoints
        The checked points.
    fn : callable
        The function of the positions and covariates (:class:`~volerr_pin.model.Covariates`)
        of some points.

    Returns
    -------
    ndarray
        ``fn``'s results of the halves, concatenated.
    """
    def part(rows: slice):
        return fn(points.q[rows], points.cov.take(rows))

    n = len(points.q)
    if n < SPLIT_POINTS:
        return part(slice(0, n))
    halves = [slice(0, (n + 1) // 2), slice((n + 1) // 2, n)]
    return np.concatenate([part(half) for half in halves])


def rows_of(w: np.ndarray, point: np.ndarray, error: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``w . e`` and ``w . S`` of every row from per-point errors and sensitivities, one error
    direction at a time: gathering S for every row would take six times the memory of the result.

    Parameters
    ----------
    w : ndarray, shape (rows, 6)
        Weights of each row.
    point : ndarray of int, shape (rows,)
        The point of each row (indices into ``error`` and ``S``).
    error : ndarray, shape (N, 6)
        The error at the points [m, rad].
    S : ndarray, shape (N, 6, F)
        Its sensitivities to F coefficients.

    Returns
    -------
    pred : ndarray, shape (rows,)
        ``w . e(q_point)`` of every row.
    A : ndarray, shape (rows, F)
        ``w . S(q_point)`` of every row.
    """
    pred = np.einsum("rk,rk->r", w, error[point])
    direction = np.argmax(np.abs(w), axis=1)
    if np.array_equal(w, np.eye(6)[direction]):  # each row one error direction (point measurements)
        return pred, S[point, direction, :]
    A = np.zeros((len(point), S.shape[2]))
    for k in range(6):
        if np.any(w[:, k]):
            A += w[:, k, None] * S[point, k, :]
    return pred, A


def column_scale(J: np.ndarray, rtol: float = 1e-9, typical: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Column norms for scaling, and the columns scaled to unit norm; columns whose effect
    (norm x ``typical`` size of the coefficient, default 1) is negligible against the
    median (below ``rtol`` of it: rounding noise) are zeroed, not blown up.

    Parameters
    ----------
    J : ndarray, shape (rows, n)
        A design (or its triangular factor).
    rtol : float, default 1e-9
        Effects below this fraction of the median effect are rounding noise.
    typical : ndarray, shape (n,), optional
        Typical size of each column's coefficient (default 1: the SI unit).

    Returns
    -------
    scale : ndarray, shape (n,)
        The column norms (1 for zeroed columns).
    scaled : ndarray, shape (rows, n)
        ``J / scale``, with negligible columns zero.
    """
    norms = np.linalg.norm(J, axis=0)
    effect = norms if typical is None else norms * typical
    positive = effect[effect > 0]
    floor = rtol * (np.median(positive) if positive.size else 1.0)
    ok = effect > floor
    scale = np.where(ok, norms, 1.0)
    scaled = np.where(ok, J / scale, 0.0)
    return scale, scaled


def weighted_residual(points: FitPoints, theta: np.ndarray, nuisance: np.ndarray) -> np.ndarray:
    """Weighted residual of every row: (y - model - nuisance) / sigma.

    Parameters
    ----------
    points : FitPoints
        The observations and their checked points.
    theta : ndarray, shape (P,)
        Coefficients (SI).
    nuisance : ndarray, shape (n_nuisance,)
        Nuisance values (SI).

    Returns
    -------
    ndarray, shape (rows,)
        The residuals in standard deviations.
    """
    obs, model = points.obs, points.model
    error = by_halves(points, lambda q, cov: volumetric_error(model, q, theta, cov))
    pred = np.einsum("rk,rk->r", obs.w, error[obs.point])
    return (obs.y - pred - obs.nuisance @ nuisance) / obs.sigma


#: the design is reduced over chunks of points whose sensitivities take about this much memory
CHUNK_BYTES = 48 << 20
#: from this many points the design is reduced in two halves (see :func:`point_chunks`)
SPLIT_POINTS = 256


def point_chunks(obs: Observations, n_columns: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Chunks of points whose sensitivities (6 x ``n_columns`` each, a few copies) take about
    :data:`CHUNK_BYTES`.

    Parameters
    ----------
    obs : Observations
        The observations.
    n_columns : int
        Coefficients differentiated by.

    The chunks' sizes differ by one point at most; from :data:`SPLIT_POINTS` points on they are
    an even number, so that the design reduces in two halves of equal work (:func:`reduce_design`).

    Returns
    -------
    list of tuple of (ndarray, ndarray)
        Per chunk: its point indices (consecutive) and the indices of their observation rows.
    """
    n = obs.n_points
    size = max(64, CHUNK_BYTES // (6 * 8 * 4 * max(n_columns, 1)))
    count = -(-n // size)
    if n >= SPLIT_POINTS:
        count = max(2, count)
        count += count % 2
    starts = [k * n // count for k in range(count + 1)] if count else [0]
    order = np.argsort(obs.point, kind="stable")
    bounds = np.searchsorted(obs.point[order], starts)
    return [(np.arange(starts[k], starts[k + 1]), order[bounds[k]:bounds[k + 1]]) for k in range(count)]


def stacked_factor(R: np.ndarray, parts: list[np.ndarray], sigma: np.ndarray, non_finite=None) -> np.ndarray:
    """The triangular factor of ``[R; [parts...] / sigma]`` (that of its QR decomposition):
    the blocks are written once into a column-major array that LAPACK's ``geqrf`` factors in
    place (``numpy.linalg.qr`` copies its input and took 1.3 to 2 times as long on a fit's
    chunks of 8,000 rows and 93 to 130 columns, with the same factor to the last bit).

    Parameters
    ----------
    R : ndarray, shape (k, n)
        The factor so far (k may be 0).
    parts : list of ndarray
        Blocks of the new rows, side by side (each (rows, n_i) or (rows,); the n_i add up to n).
    sigma : ndarray, shape (rows,)
        What every new row is divided by.
    non_finite : callable(ndarray), optional
        Called with the new rows (divided) when one of their values is not finite (it raises).

    Returns
    -------
    ndarray, shape (min(k + rows, n), n)
        The upper-triangular factor.
    """
    k, n = R.shape
    M = np.empty((k + len(sigma), n), order="F")
    M[:k] = R
    col = 0
    for part in parts:
        part = part[:, None] if part.ndim == 1 else part
        np.divide(part, sigma[:, None], out=M[k:, col:col + part.shape[1]])
        col += part.shape[1]
    if col != n:
        raise ValueError(f"the blocks have {col} columns, the factor {n}")
    if non_finite is not None and not np.all(np.isfinite(M[k:])):
        non_finite(M[k:])
    if M.shape[0] == 0:
        return M
    factor, _, _, info = lapack.dgeqrf(M, overwrite_a=1)
    if info != 0:  # pragma: no cover - only for arguments this function never passes
        raise RuntimeError(f"LAPACK geqrf failed (info {info})")
    return np.triu(factor[:min(M.shape)])


def reduce_design(points: FitPoints, theta: np.ndarray, columns: np.ndarray,
                  nuisance: np.ndarray, first_order: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The weighted residual and the triangular factor of the weighted design, built chunk by
    chunk so that neither the design nor the sensitivities are ever held for every point.

    With ``J = [obs.nuisance | d pred / d theta[columns]] / sigma`` (rows x n) and ``r`` the
    weighted residual, ``[J | r] = Q R`` with Q orthonormal: every least-squares quantity of J
    and r follows from ``R = [R_J | z]`` (``J^T J = R_J^T R_J``, ``|r - J x| = |z - R_J x|``,
    equal column norms and inner products), so the fit and the identifiability analysis work
    on R, whose size does not grow with the data.

    Parameters
    ----------
    points : FitPoints
        The observations and their checked points.
    theta : ndarray, shape (P,)
        Coefficients (SI) at which to linearise.
    columns : ndarray of int, shape (n_columns,)
        Indices of the coefficients of the design.
    nuisance : ndarray, shape (n_nuisance,)
        Nuisance values (SI).
    first_order : bool, default False
        The sensitivities of the first-order model (exact dependencies).

    Returns
    -------
    r : ndarray, shape (rows,)
        The weighted residual (y - model - nuisance) / sigma.
    R : ndarray, shape (min(rows, n + 1), n + 1)
        Upper-triangular factor of ``[J | r]``.
    """
    obs, model = points.obs, points.model
    width = obs.nuisance.shape[1] + len(columns) + 1
    chunks = point_chunks(obs, len(columns))
    halves = [chunks[:len(chunks) // 2], chunks[len(chunks) // 2:]] if len(chunks) > 1 else [chunks]

    def reduce(half):
        # the factor of one half's rows, and its weighted residual
        R = np.zeros((0, width))
        r = []
        for chunk, rows in half:
            part = slice(chunk[0], chunk[-1] + 1) if len(chunk) else slice(0, 0)   # consecutive points
            error, S = error_and_sensitivity(model, points.q[part], theta, columns, points.cov.take(part), first_order)
            pred, A = rows_of(obs.w[rows], obs.point[rows] - part.start, error, S)
            sigma = obs.sigma[rows]
            misfit = obs.y[rows] - pred - obs.nuisance[rows] @ nuisance
            r.append(misfit / sigma)
            R = stacked_factor(R, [obs.nuisance[rows], A, misfit], sigma, lambda block: refuse_non_finite(
                obs, {"residuals or sensitivities": block}))
        return R, r

    reduced = map(reduce, halves)
    r = np.empty(len(obs.y))
    factors = []
    for half, (R, parts) in zip(halves, reduced):
        factors.append(R)
        for (_, rows), values in zip(half, parts):
            r[rows] = values
    if len(factors) == 1:
        return r, factors[0]
    # the two halves' factors stacked and factored again: that of all rows
    return r, stacked_factor(factors[0], [factors[1]], np.ones(len(factors[1])))


def default_rcond(rows: int, columns: int) -> float:
    """What ``lstsq(rcond=None)`` cuts on the full design, for the same cut on its triangular factor.

    Parameters
    ----------
    rows, columns : int
        The full design's size.

    Returns
    -------
    float
        Relative singular-value cut.
    """
    return float(np.finfo(float).eps * max(rows, columns))


def typical_sizes(model: Model, theta: np.ndarray, free: np.ndarray, n_nuisance: int) -> np.ndarray:
    """Typical size of each column's coefficient for the zero test of
    :func:`~volerr_pin.fit.analyse`: 1 (the SI unit) for nuisance and linear
    coefficients, the present value for non-linear ones (time constants, periods), whose effect
    per SI unit can be tiny.

    Parameters
    ----------
    model : Model
        The model (or a machine): which coefficients are non-linear.
    theta : ndarray, shape (P,)
        Present coefficients (SI).
    free : ndarray of int, shape (F,)
        The design's coefficients.
    n_nuisance : int
        Nuisance columns before them.

    Returns
    -------
    ndarray, shape (n_nuisance + F,)
        Typical sizes (SI).
    """
    nonlinear = set(model.nonlinear_parameters)
    out = np.ones(n_nuisance + len(free))
    for c, k in enumerate(free):
        if k in nonlinear and theta[k] != 0:
            out[n_nuisance + c] = abs(theta[k])
    return out


def refuse_non_finite(obs: Observations, results: dict) -> None:
    """A fit that comes out non-finite is refused, naming the data and its largest value.

    Parameters
    ----------
    obs : Observations
        The observations fitted.
    results : dict of str to array_like
        What the fit gave, by name for the message.

    Raises
    ------
    InputError
        If a result is not finite.
    """
    bad = [what for what, values in results.items() if not np.all(np.isfinite(np.asarray(values, dtype=float)))]
    if not bad:
        return
    weighted = np.abs(obs.y / obs.sigma)
    i = int(np.argmax(np.where(np.isfinite(weighted), weighted, np.inf)))
    unit, factor = ("urad", URAD_PER_RAD) if obs.angular[i] else ("um", UM_PER_M)
    raise InputError(f"the fit to {data_names(obs)} gives non-finite {' and '.join(bad)}: the data hold "
                     f"values too large to fit (the largest against its sigma: {obs.y[i] * factor:.6g} {unit} at "
                     f"{obs.sources[i]}:{obs.lines[i]})")
