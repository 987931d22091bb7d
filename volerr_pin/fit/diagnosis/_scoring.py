"""Scoring a candidate: fitted jointly with the base model on the round's projector
(:mod:`~volerr_pin.fit.diagnosis`), non-linear coefficients by grid search, a pitch's
period from a periodogram of the residual its own error leaves, asked whether it is a table's
interpolation, and a per-revolution error asked whether it repeats from one turn to the next.
A candidate's score is its F-test p-value, its BIC gain and, for those that could pass, its
k-fold cross-validated RMS.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats
from scipy.signal import lombscargle

from ..identify import Observations
from ...model import Covariates
from ...base import ARCSEC, UM_PER_M
from ._candidates import PITCH_PERIOD_MM, Offered
from ._effects import MIN_PERIODS, effect_kind
from ._projector import Base, Columns, Projector
from ._results import Candidate, Role, Score

__all__ = ["PERIODOGRAM_POINTS", "REPEAT_MIN_POINTS", "REPEAT_RATIO", "REPEAT_SIGMAS", "SURVIVES", "not_repeating",
           "f_test", "periodogram_period", "repeat_check", "score", "score_round", "table_interpolation"]

PERIODOGRAM_POINTS = 1500       # points a periodogram looks at, at most
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
                        C: np.ndarray, gamma: np.ndarray, columns: Columns, smoother) -> str | None:
    """Why a periodic error of an axis is its component's table's interpolation, when it is.

    A table leaves, between its nodes, the residual of a smooth function, which repeats at the
    node spacing and its harmonics; a ball screw's error does neither. So the periodic error is
    fitted again beside the table one step richer between its nodes
    (:func:`~volerr_pin.fit.diagnosis._candidates.smoother_term`), jointly with the base: the
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
    smoother : tuple of (TermSpec, str) or None
        The component's table one step richer between its nodes, and how, in words
        (:func:`~volerr_pin.fit.diagnosis._candidates.smoother_term`); None when it has none.

    Returns
    -------
    str or None
        The reason, with both amplitudes [um]; None when the error survives, the component has
        no table, or the table cannot be made richer.
    """
    if smoother is None:
        return None
    term, how = smoother
    richer = Candidate(cand.name, cand.axis, cand.direction, cand.component, None,
                       label=f"{cand.component} richer between its nodes", kind=Role.RAISE, term=term)
    C_table = columns(base.model, E, joints, richer)[0]
    before = float(np.linalg.norm(gamma))
    after = float(np.linalg.norm(proj.fit(np.hstack([C_table, C]))[2][-C.shape[1]:]))
    if SURVIVES * before <= after <= before / SURVIVES:
        return None
    why = ("its amplitude falls" if after < before else
           "the richer table takes the same shape: its amplitude is no longer determined, and goes")
    return (f"the interpolation of {cand.component}'s table, not a screw's error: beside the table made richer "
            f"between its nodes ({how}) {why} from {before * UM_PER_M:.3f} to {after * UM_PER_M:.3f} um; "
            "the table's raise refines it")


def f_test(rss0: float, rss1: float, k: int, dof: int) -> float:
    """The p-value of an F-test of ``k`` added coefficients that take the residual sum of
    squares from ``rss0`` to ``rss1``, with ``dof`` degrees of freedom left (1 when none are).

    Parameters
    ----------
    rss0, rss1 : float
        Residual sums of squares without and with the coefficients (weighted).
    k : int
        The coefficients added (> 0).
    dof : int
        Degrees of freedom of the model with them.

    Returns
    -------
    float
    """
    if dof <= 0:
        return 1.0
    return float(stats.f.sf(((rss0 - rss1) / k) / (rss1 / dof), k, dof))


def score(base: Base, proj: Projector, obs: Observations, offered: Offered, cand: Candidate,
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
    offered : Offered
        The round's offer: the sensitivity of the error to every error joint, and the tables
        made richer.
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
    E, joints = offered.E, offered.joints
    searched = 1.0
    kind = effect_kind(cand.name)
    if kind.periodogram and cand.kind == Role.EFFECT:
        found = periodogram_period(obs, base.r, columns.gain(E, joints, cand.component), axis_index_of[cand.axis])
        if found is None:
            return None
        period, searched = found
        cand.table = dict(cand.table, period_mm=period * 1e3)
    _, tspec, coefs = columns(base.model, E, joints, cand)
    nonlinear = [tspec.term.local_names.index(k) for k in tspec.term.nonlinear]
    lin = [i for i in range(len(coefs)) if i not in nonlinear]
    full = np.array([np.nan])
    if nonlinear and not kind.period_given:  # a period from a periodogram or the revolution is not searched
        full = np.asarray(tspec.term.search_grid(tspec.term.local_names[nonlinear[0]], coefs, cov_obj))
    tried: dict = {}

    def trial(k):
        if k not in tried:
            value = full[k]
            c = coefs.copy()
            if not np.isnan(value):
                c[nonlinear[0]] = value
            # columns of the linear coefficients at this value of the non-linear one
            C, _, _ = columns(base.model, E, joints, cand, None if np.isnan(value) else c, lin)
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
    p_value = min(1.0, f_test(rss0, rss1, k, dof) * searched)
    bic_gain = n * math.log(rss0 / rss1) - k * math.log(n) - 2 * math.log(searched)
    values = c.copy()
    values[lin] = gamma
    out = Score(cand.label, int(extra), p_value, float(bic_gain), None, (rss0 - rss1) / rss0 if rss0 > 0 else 0.0,
                cand, tspec, values, C)
    if kind.periodogram and cand.kind == Role.EFFECT:
        note = table_interpolation(base, proj, E, joints, cand, C, gamma, columns, offered.smoother.get(cand.component))
        if note:   # the table's, not a screw's: its raise refines the table
            return Score(cand.label, 0, 1.0, 0.0, proj.cv_rms, 0.0, cand, note=note)
    return out


def score_round(number: int, base: Base, proj: Projector, obs: Observations, offered: Offered, alpha: float,
                cov_obj: Covariates, axis_index_of: dict[str, int], columns: Columns, progress=None) -> tuple:
    """Every candidate of a round scored, best first, and those that pass: the F-test at
    ``alpha`` over the number of candidates scored (Bonferroni) and a lower cross-validated RMS.

    Parameters
    ----------
    number : int
        The round (0 first).
    base : Base
        The round's base.
    proj : Projector
        Its projector.
    obs : Observations
        The observations.
    offered : Offered
        The round's offer.
    alpha : float
        The family-wise significance level.
    cov_obj : Covariates
        The checked covariates.
    axis_index_of : dict of str to int
        Axis name -> index.
    columns : Columns
        The cache of candidate columns.
    progress : callable(str, int), optional
        Called after every candidate.

    Returns
    -------
    ranked : list of Score
        Every score, best BIC gain first.
    passing : list of Score
        Those that pass, in the same order.
    """
    scores = []
    for k, cand in enumerate(offered.candidates):
        s = score(base, proj, obs, offered, cand, cov_obj, axis_index_of, columns)
        if progress:
            progress(f"round {number + 1}: candidates", k + 1)
        if s is not None:
            scores.append(s)
    m = max(1, len(scores))
    ranked = sorted(scores, key=lambda s: -s.bic_gain)
    # cross-validate what could pass and what is shown
    shown = [s for k, s in enumerate(ranked) if s.cv_rms_um is None and (k < 10 or s.p_value < alpha / m)]
    for s in shown:
        s.cv_rms_um = proj.cv(s.columns)
    passing = [s for s in ranked if s.extra > 0 and s.p_value < alpha / m
               and s.cv_rms_um is not None and s.cv_rms_um < proj.cv_rms * (1 - 1e-3)]
    return ranked, passing
