"""The fit: :func:`identify` checks its options, builds the observations, analyses what they
can determine, solves, estimates uncertainties and cross-validates over poses."""

from __future__ import annotations

import math
import warnings

import numpy as np

from ...base import InputError, fraction, integer, measurement_sigma, positive, require_memory
from .._identifiability import analyse
from ...model import Machine
from . import _design as design
from ._crossval import cross_validate, holdout_split
from ._design import FitPoints, reduce_design, refuse_non_finite, typical_sizes
from ._observations import Observations, build_observations, check_observations, data_names, residual_rms
from ._result import Identification
from ._solver import conditioning_note, ill_conditioned, initialise_nonlinear, solve, standard_uncertainties

__all__ = ["identify"]


def identify(machine: Machine, data, *, terms=None, free=None, convention: str = "prior", folds: int = 5,
             holdout: float | None = None, seed: int = 0, max_iter: int = 50, tol: float = 1e-8,
             sigma_um: float = 1.0, sigma_urad: float = 1.0, run_axis: str | None = None,
             at: dict | None = None, rtol: float = 1e-9, progress=None,
             initialise: bool = True) -> Identification:
    """Fit the machine's coefficients to measurements.

    Parameters
    ----------
    machine : Machine
        The machine: its coefficients are the prior and the start values.
    data : list of measurement objects, or an :class:`Observations`
        Measurement objects as :func:`build_observations` takes them (point measurements,
        runs, tracker, ballbar), or observations built already.
    terms : list of component names, optional
        Components whose coefficients may move (default: all); the rest stay as given.
    free : array of coefficient indices, optional
        The coefficients that may move, one by one (overrides ``terms``).
    convention : "prior" or "min-norm"
        What to do with what the data cannot determine (see the module docstring).
    folds : int, default 5
        k-fold cross-validation over poses (``folds`` >= 2; the points at one pose are held
        out together); ``folds=0`` skips it.
    holdout : float, optional
        One random split keeping the fraction ``holdout`` (0 to 1) of the poses out
        (overrides ``folds``).
    seed : int, default 0
        Seed of the cross-validation's shuffling of the poses.
    max_iter : int, default 50
        Gauss-Newton iteration limit.
    tol : float, default 1e-8
        Convergence threshold on the largest component of a full Gauss-Newton step, in units of
        the observations' standard deviations (column-scaled).
    sigma_um : float, default 1.0
        Standard deviation of position observations [um] (weights); only when ``data`` is
        not an :class:`Observations`.
    sigma_urad : float, default 1.0
        Standard deviation of rotation observations [urad] (weights); likewise.
    run_axis : str, optional
        Moving axis of runs that do not name it (see :func:`build_observations`).
    at : dict of str to float, optional
        Positions of the other axes during runs [m, rad] (see :func:`build_observations`).
    rtol : float, default 1e-9
        Relative tolerance of the identifiability tests (:func:`~volerr_pin.fit.analyse`).
    progress : callable(str, int), optional
        Called with a stage name and a step count, for progress bars.
    initialise : bool, default True
        Start the non-linear coefficients (time constants, periods) from a grid search
        (default); False starts them from the machine's values, for callers that already
        have good ones.

    Returns
    -------
    Identification
        The fitted machine, the identifiability analysis, uncertainties, residual RMS values
        and the held-out RMS.

    Raises
    ------
    InputError
        If ``convention`` is invalid, ``sigma_um`` or ``sigma_urad``, ``tol`` or ``rtol`` is
        not a positive finite number (``rtol`` below 1), ``folds`` is not 0 or >= 2,
        ``holdout`` is not a fraction between 0 and 1 or leaves no pose to fit, ``seed`` is
        negative, ``max_iter`` is below 1, ``terms`` names an unknown component or ``free``
        an index that is not a coefficient's, there is nothing to fit, the data are invalid
        (see :func:`~volerr_pin.fit.identify.build_observations`; observations that are not finite, or whose squares
        overflow), or the fit comes out non-finite (values too large to fit).

    Warns
    -----
    UserWarning
        When the column-scaled design is numerically rank-deficient or its condition number
        exceeds :data:`~volerr_pin.fit.identify.CONDITION_LIMIT` (also :attr:`Identification.ill_conditioned`).
    """
    if convention not in ("prior", "min-norm"):
        raise InputError(f"convention must be 'prior' or 'min-norm', got {convention!r}",
                         parameters=("convention",))
    folds = integer("folds", folds, 2, also=(0,), what=" (0: no cross-validation)")
    if holdout is not None:
        holdout = fraction("holdout", holdout)
    seed = integer("seed", seed, 0)
    max_iter = integer("max_iter", max_iter, 1)
    tol = positive("tol", tol)
    rtol = positive("rtol", rtol)
    if rtol >= 1:
        raise InputError(f"rtol must be below 1, got {rtol}", parameters=("rtol",))
    obs = data if isinstance(data, Observations) else build_observations(
        machine, data, sigma_um=sigma_um, sigma_urad=sigma_urad, run_axis=run_axis, at=at)
    if isinstance(data, Observations):
        measurement_sigma("sigma_um", sigma_um), measurement_sigma("sigma_urad", sigma_urad)
    check_observations(obs)
    require_memory(_memory_needed(obs, folds if holdout is None else 1),
                   f"fitting {obs.n_points} points ({len(obs.y)} observations) of {data_names(obs)}")
    free = _free(machine, terms, free)
    if free.size == 0 and obs.nuisance.shape[1] == 0:
        raise InputError(f"{machine.name} has no coefficients to fit")
    if holdout is not None:
        holdout_split(obs, holdout, seed)  # refuses a split that leaves nothing to fit, before the fit
    points = FitPoints.of(machine.model, obs, machine.state)   # the data's points, checked once for this model
    theta0 = (initialise_nonlinear(points, machine.theta, free, rtol, progress) if initialise
              else machine.theta.copy())
    # identifiability of the first-order model: exact dependencies, untouched by second-order
    # differences that the errors' own size brings in
    n_nu = obs.nuisance.shape[1]
    _, R0 = reduce_design(points, theta0, free, np.zeros(n_nu), first_order=True)
    names = obs.nuisance_names + [machine.parameter_names[k] for k in free]
    analysis = analyse(R0[:, :-1], names, protected=n_nu, rtol=rtol, what="these measurements",
                       typical=typical_sizes(machine.model, theta0, free, n_nu), rows=len(obs.y))
    kept_theta = np.array([c - n_nu for c in analysis.kept if c >= n_nu], dtype=int)
    held = np.array(sorted(set(range(len(free))) - set(kept_theta.tolist())), dtype=int)
    columns = kept_theta if convention == "prior" else None
    tick = (lambda i: progress("fit", i)) if progress else None
    theta, nuisance, R, r, iterations, solver = solve(points, theta0, free, columns, convention,
                                                      max_iter, tol, tick)
    dof = len(r) - R.shape[1] if convention == "prior" else len(r) - analysis.rank
    residual_sigma = float(np.sqrt(r @ r / dof)) if dof > 0 else math.nan
    uncertainty = np.full(len(theta), np.nan)
    covariance = None
    ill = ill_conditioned(analysis.singular_values, len(r))
    if convention == "prior" and dof > 0:
        std, rank_deficient, cov = standard_uncertainties(
            R, len(r), typical_sizes(machine.model, theta, free[kept_theta], n_nu), covariance=True)
        uncertainty[free[kept_theta]] = std[n_nu:] * residual_sigma
        # the machine's coefficients' block: the nuisance terms marginalised out
        covariance = cov[n_nu:, n_nu:] * residual_sigma ** 2
        ill = ill or rank_deficient
    residual_si = r * obs.sigma
    fitted_machine = machine.with_theta(theta, limits=False)
    rms_fit = residual_rms(obs, residual_si)
    rms_fit_rot = residual_rms(obs, residual_si, angular=True)
    fitted_idx = free[kept_theta] if convention == "prior" else free
    refuse_non_finite(obs, {"coefficients": theta[fitted_idx], "nuisance terms": nuisance,
                            "residual RMS": [rms_fit or 0.0, rms_fit_rot or 0.0],
                            "residual standard deviation": [0.0 if dof <= 0 else residual_sigma],
                            # infinite where the design is rank-deficient (then flagged and said)
                            "uncertainties": [] if ill or convention != "prior" or dof <= 0
                            else uncertainty[fitted_idx]})
    if ill:
        warnings.warn(conditioning_note(analysis, len(r)), stacklevel=2)
    rms_holdout, how = None, "none"
    if holdout is not None or folds >= 2:
        rms_holdout, how = cross_validate(points, theta0, free, columns, convention, folds,
                                          holdout, seed, max_iter, tol, progress)
        refuse_non_finite(obs, {"held-out RMS": [rms_holdout or 0.0]})
    held_idx = free[held] if convention == "prior" else np.array([], dtype=int)
    groups = [g for g in analysis.groups]
    return Identification(
        fitted_machine, machine, free, analysis, fitted_idx, held_idx, uncertainty,
        dict(zip(obs.nuisance_names, (float(v) for v in nuisance))), rms_fit or 0.0, rms_fit_rot,
        rms_holdout, how, obs.n_points, len(obs.y), iterations, convention, residual_sigma, groups,
        frozenset(n for n, angular in zip(obs.nuisance_names, obs.nuisance_angular) if angular), solver, ill,
        covariance)


def _memory_needed(obs: Observations, folds: int) -> float:
    """Peak memory of a fit [bytes]: the observations copied into training and test sets,
    residual vectors and per-point evaluations, and the chunk buffers of :func:`reduce_design` (the
    design itself is never held whole)."""
    per_row = 8 * (12 + obs.nuisance.shape[1]) * (2 if folds >= 2 else 1)
    per_point = 8 * (obs.q.shape[1] + 6) * 3
    return per_row * len(obs.y) + per_point * obs.n_points + 4 * design.CHUNK_BYTES


def _free(machine: Machine, terms, free) -> np.ndarray:
    """The indices of the coefficients that may move: ``free`` checked, else those of ``terms``,
    else all."""
    n_params = len(machine.parameter_names)
    if free is not None:
        try:
            free = np.unique(np.asarray(free, dtype=int).ravel())
        except (TypeError, ValueError):
            raise InputError(f"free must hold coefficient indices (integers), got {free!r}",
                             parameters=("free",)) from None
        if free.size and (free[0] < 0 or free[-1] >= n_params):
            bad = free[0] if free[0] < 0 else free[-1]
            raise InputError(f"free: {bad} is not the index of a coefficient of {machine.name} "
                             f"(0 to {n_params - 1})", parameters=("free",))
    elif terms:
        terms = [terms] if isinstance(terms, str) else list(terms)  # one name, not its letters
        unknown = sorted(set(terms) - set(machine.components))
        if unknown:
            raise InputError(f"terms: {', '.join(unknown)} not among the error terms of "
                             f"{machine.name} ({', '.join(machine.components)})", parameters=("terms",))
        free = np.array([k for k, n in enumerate(machine.parameter_names)
                         if n.split(".", 1)[0] in set(terms)], dtype=int)
    else:
        free = np.arange(n_params)
    return free
