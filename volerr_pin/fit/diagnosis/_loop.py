"""The loop: fit the base model, score every candidate, accept the best that passes, refit,
repeat; then the final fit, which drops what is no longer significant, and the report.

Each round (:meth:`_Loop.round`) fits every candidate jointly with the present model
(:mod:`~volerr_pin.fit.diagnosis`) and accepts the best that passes all three tests: an
F-test at ``alpha`` over the number of candidates, a lower cross-validated RMS, and a size of
at least :data:`~volerr_pin.fit.diagnosis.SIGNIFICANCE` standard uncertainties after the
joint refit (:mod:`~volerr_pin.fit.diagnosis`).
"""

from __future__ import annotations

import math
import time as _time
import warnings

import numpy as np

from ...base import UM_PER_M, InputError, fraction, integer, measurement_sigma, require_memory
from ...model import Machine, check_covariates
from ..identify import (FitPoints, Identification, Observations, build_observations, check_observations,
                        conditioning_note, pose_folds, residual_rms)
from ._candidates import build_candidates, offer
from ._changes import Refit, accept, quiet_identify, remove_effect, size_of, trim_raises, with_lag
from ._effects import effect_kind
from ._projector import Columns, Projector, base_design
from ._rivals import finding_parameters, rivals_of, weigh_rivals
from ._report import (components_per_point, effect_amplitude, floor_verdict, group_findings, noise_floor,
                     raised_summary, residual_analysis, undecided_rotary)
from ._results import PRACTICAL_AMPLITUDE, PRACTICAL_GAIN, SIGNIFICANCE, Change, Diagnosis, Role, Step, ThermalModel, \
    one_blas_thread
from ._scoring import score_round

__all__ = ["LAGS_S", "TIME_CHECK_SHARE", "diagnose"]

#: lags [s] tried for the temperature terms of a thermal drift
LAGS_S = (300.0, 600.0, 1200.0, 1800.0, 3600.0)
#: share of the run's time a thermal drift's check over time fits on (it predicts the rest)
TIME_CHECK_SHARE = 0.6


def diagnose(machine: Machine, measurements, *, fixed: bool = False, max_effects: int = 5,
             alpha: float = 0.01, folds: int = 5, seed: int = 0, sigma_um: float | None = None,
             sigma_urad: float | None = None, progress=None, keep_machines: bool = False,
             max_rounds: int | None = None) -> Diagnosis:
    """Find, name and add the effects the model is missing (see :mod:`volerr_pin.fit.diagnosis`).

    Parameters
    ----------
    machine : Machine
        The model to test (its spec's terms are the base model).
    measurements : list of measurement objects, or Observations
        Point measurements (or runs, tracker, ballbar files) as
        :func:`~volerr_pin.fit.identify.build_observations` takes them, or observations built
        already.
    fixed : bool, default False
        Keep the spec's geometric values instead of identifying them first (a raised
        component then moves as a whole).
    max_effects : int, default 5
        Stop adding physical effects after this many (>= 0; 0 still raises under-modelled
        components).
    alpha : float, default 0.01
        Family-wise significance level of the F-test in each round (Bonferroni over the
        candidates of the round), between 0 and 1.
    folds : int, default 5
        k of the k-fold cross-validation over poses (>= 2; the points of one pose - several
        targets, repeats - stay in one fold).
    seed : int, default 0
        Seed of the shuffling of the poses into folds (>= 0).
    sigma_um : float, optional
        The noise of the position observations, as a standard deviation per component [um],
        when it is known: it weights observations read from measurements, and it is the noise
        the final residual is compared with. With :class:`~volerr_pin.fit.identify.Observations`,
        their own standard deviations weight them, and giving ``sigma_um`` (any value) states
        that those are the noise. Not given (default), the noise is not stated: measurements
        are weighted at 1 um, and without repeated points the noise floor is unknown - never
        reported reached (:attr:`~volerr_pin.fit.diagnosis.Diagnosis.reaches_noise_floor`
        is None).
    sigma_urad : float, optional
        The noise of rotation observations [urad]; weights them (default 1 urad).
    progress : callable(str, int), optional
        Called with a stage name and a step count, for progress bars.
    keep_machines : bool, default False
        Keep the machine of every round in :attr:`Step.machine`.
    max_rounds : int, optional
        Rounds that may accept a change, at most (default ``max_effects`` + 8: room for raising
        under-modelled components); one more scores what would still pass
        (:attr:`~volerr_pin.fit.diagnosis.Diagnosis.stopped`).

    Returns
    -------
    Diagnosis
        The final model, the effects found in order, the raised components, every round's
        scores, the held-out RMS before and after and the noise floor.

    Raises
    ------
    InputError
        If a parameter is out of its range above, the measurements are invalid (see
        :func:`~volerr_pin.fit.identify.identify`), hold no position observations, are too few to
        over-determine the base model (it would pass through every point, leaving no
        residual), sit at too few distinct poses for ``folds``-fold cross-validation, or the
        diagnosis would need more memory than the machine has free.

    Warns
    -----
    UserWarning
        Once, when the final fit is ill-conditioned (see
        :attr:`~volerr_pin.fit.identify.Identification.ill_conditioned`).
    """
    start = _time.perf_counter()
    max_effects = integer("max_effects", max_effects, 0)
    alpha = fraction("alpha", alpha)
    folds = integer("folds", folds, 2)
    seed = integer("seed", seed, 0)
    stated = sigma_um is not None
    sigma_um = measurement_sigma("sigma_um", 1.0 if sigma_um is None else sigma_um)
    sigma_urad = measurement_sigma("sigma_urad", 1.0 if sigma_urad is None else sigma_urad)
    if max_rounds is not None:
        max_rounds = integer("max_rounds", max_rounds, 0)
    obs = measurements if isinstance(measurements, Observations) else build_observations(
        machine, measurements, sigma_um=sigma_um, sigma_urad=sigma_urad)
    check_observations(obs)
    if obs.angular.all():
        raise InputError("diagnose compares position residuals, and the measurements hold no position "
                         "(dx, dy, dz) observations")
    split = pose_folds(obs, folds, seed)  # the points of one pose stay in one fold
    if split is None:
        poses = len(np.unique(obs.poses()))
        raise InputError(f"{obs.n_points} points at {poses} distinct {'pose' if poses == 1 else 'poses'}: too few "
                         f"for folds = {folds} (k-fold cross-validation needs at least {2 * folds})",
                         parameters=("folds",))
    require_memory(_memory_needed(machine, obs, folds), f"diagnosing {obs.n_points} points ({len(obs.y)} observations)")
    with one_blas_thread():   # BLAS threads cost more than they give on a diagnosis's small matrices
        loop = _Loop(machine, obs, split, fixed, alpha, max_effects, progress, keep_machines, stated)
        max_rounds = max_effects + 8 if max_rounds is None else max_rounds
        for number in range(max_rounds + 1):
            if not loop.round(number, may_accept=number < max_rounds):
                break
        diagnosis, final = loop.finish()
    diagnosis.stopped = _stopped(loop, max_rounds)
    if final is not None and final.ill_conditioned:
        warnings.warn(conditioning_note(final.analysis, len(obs.y)), stacklevel=2)
    diagnosis.seconds = _time.perf_counter() - start
    return diagnosis


class _Loop:
    """The state of a diagnosis between rounds: the present model and its fit, the free
    coefficients (with ``fixed``), what was accepted so far, and the caches of the rounds."""

    def __init__(self, machine: Machine, obs: Observations, split: list[np.ndarray], fixed: bool, alpha: float,
                 max_effects: int, progress, keep_machines: bool, noise_stated: bool = False):
        self.machine, self.obs, self.split, self.alpha = machine, obs, split, alpha
        self.noise_stated = noise_stated
        self.max_effects, self.progress, self.keep_machines = max_effects, progress, keep_machines
        self.cov_obj = check_covariates(machine.model, obs.n_points, obs.covariates, machine.state)
        self.axis_index_of = {a: j for j, a in enumerate(machine.axes)}
        self.columns = Columns(obs, self.cov_obj)
        self.free_names: list[str] = []        # with ``fixed``: the coefficients that may move
        self.fit = Refit(obs, fixed)            # how models are fitted (the accepted periods, the held names)
        self.current, self.fitted, self.nuisance, self.last_fit = self.fit(machine, self.free_names, initialise=True)
        self.base_machine = self.current
        self.steps: list[Step] = []
        self.effects: list[Change] = []
        self.raised: list[Change] = []
        self.previous: list[Change] = []
        self._last_holdout = None
        self.left_passing: list[str] = []       # what still passed when the round limit ended the rounds
        self.last_passing: list = []            # the last round's passing scores (notes: why refused)
        self.rivals: list = []                  # named candidates and raises that explain the same residual
        self.turns = {a: float(np.ptp(obs.q[:, j])) / (2 * math.pi) if obs.n_points else 0.0
                      for j, (a, k) in enumerate(zip(machine.axes, machine.axis_kinds)) if k != "linear"}

    def round(self, number: int, may_accept: bool) -> bool:
        """One round, a pipeline: the candidates offered on the present model
        (:mod:`~volerr_pin.fit.diagnosis`), scored against its base design
        (:mod:`~volerr_pin.fit.diagnosis`), the best that stays significant accepted
        and refitted (:mod:`~volerr_pin.fit.diagnosis`); whether it accepted a change."""
        obs, current = self.obs, self.current
        base = base_design(FitPoints.of(current.model, obs, current.state), current.theta, self.fitted, self.nuisance)
        proj = Projector(base.A, base.r, obs, self.split)
        if number == 0 and len(obs.y) <= proj.rank:
            # the base model interpolates the data: no residual, and a held-out RMS of zero
            raise InputError(f"{len(obs.y)} observations at {obs.n_points} points do not over-determine the "
                             f"base model ({proj.rank} independent coefficients and nuisance terms): there is "
                             "no residual to diagnose; measure more points")
        for record in self.previous:
            record.rms_after_um, record.max_after_um = proj.cv_rms, proj.cv_max
        accepted_orders = {(n.split(".")[0], round(2 * math.pi / p)) for n, p in self.fit.periods.items()}
        offered = offer(current, obs, accepted_orders, raises_only=len(self.effects) >= self.max_effects)
        ranked, passing = score_round(number, base, proj, obs, offered, self.alpha, self.cov_obj, self.axis_index_of,
                                      self.columns, self.progress)
        limit = self.alpha / max(1, len(ranked))
        done = accept(current, number, passing, proj, self.axis_index_of, self.fit, self.free_names) if may_accept \
            else None
        if done is not None:
            for rival in rivals_of(number, ranked, passing, done.records, proj, limit, self.turns):
                rival.before = current   # the model of the round, before its change
                self.rivals.append(rival)
            self.free_names = done.free_names
            self.current, self.fitted, self.nuisance, self.last_fit = done.machine, done.fitted, done.nuisance, done.fit
        accepted = done.records if done is not None else []
        self.last_passing, self.left_passing = passing, ([] if may_accept else [s.label for s in passing])
        self.steps.append(Step(number, proj.cv_rms, [s.summary() for s in ranked], base.r * obs.sigma,
                               self.current if self.keep_machines else None, accepted))
        if not accepted:
            return False
        for record in accepted:
            (self.raised if record.kind == Role.UNDER_MODELLED else self.effects).append(record)
        self.previous = accepted
        return True

    def _refit(self, model: Machine):
        """``model`` fitted like the loop's models (with ``fixed`` only the free names it keeps)."""
        names = [n for n in self.free_names if n in set(model.parameter_names)]
        fitted_model, _, _, res = self.fit(model, names)
        return fitted_model, res, names

    def holdout(self, model: Machine, fit) -> tuple[Projector, np.ndarray]:
        """The projector of a fitted model (its ``cv_rms`` is the held-out RMS [um]) and its
        residual (rows, SI); the last one is kept (the final model's is asked for again)."""
        last = self._last_holdout
        if last is not None and last[0] is model and last[1] is fit:
            return last[2]
        fitted = fit.fitted if fit is not None else np.array([], dtype=int)
        nuisance = (np.array(list(fit.nuisance.values())) if fit is not None
                    else np.zeros(self.obs.nuisance.shape[1]))
        b = base_design(FitPoints.of(model.model, self.obs, model.state), model.theta, fitted, nuisance)
        out = Projector(b.A, b.r, self.obs, self.split), b.r * self.obs.sigma
        self._last_holdout = (model, fit, out)
        return out

    def holdout_without(self, members: list[Change]) -> float:
        """The held-out RMS [um] of the present model without these effects, refitted."""
        model, res, _ = self.without(members)
        return self.holdout(model, res)[0].cv_rms

    def without(self, members: list[Change]):
        """The present model without these effects, refitted: (machine, fit, free names)."""
        model = self.current
        for m in members:
            model = remove_effect(model, m)
        return self._refit(model)

    def _final_fit(self, final) -> tuple[Identification | None, list[Change]]:
        """Refit until every accepted effect is significant and raised polynomials keep only
        significant coefficients: the final fit and the dropped effects.

        Collinear terms are judged jointly: an effect whose own size is below
        :data:`SIGNIFICANCE` standard uncertainties (its coefficient shares what it explains
        with a collinear one) stays when removing it makes the held-out RMS worse by more
        than :data:`PRACTICAL_GAIN` of it; else the weakest goes and the model is refitted. So
        are the raises' trailing coefficients (:func:`_judged_trim`); once a trim is refused,
        no further trim is tried in this final fit (even after a weak effect goes)."""
        dropped: list[Change] = []
        kept_jointly: set[str] = set()
        trim, fitted = True, False
        while True:
            if not fitted and (not self.fit.fixed or self.free_names):
                self.current, _, _, final = self.fit(self.current, self.free_names)
            trimmed = _judged_trim(self, final) if trim else None
            trim = fitted = trimmed is not None
            if trim:  # the trimmed model comes fitted as this loop would fit it: not fitted again
                self.current, res, self.free_names = trimmed
                final = res if res is not None else final
                continue
            weak = [(size_of(final, [n for n in e.names if n not in self.fit.held]) if final is not None else 0.0, i)
                    for i, e in enumerate(self.effects)]
            weak = [(z, i) for z, i in weak if z < SIGNIFICANCE and self.effects[i].label not in kept_jointly]
            if not weak:
                return final, dropped
            _, i = min(weak)
            gone = self.effects[i]
            # the present model's held-out RMS (asked for again)
            with_rms = self.holdout(self.current, final)[0].cv_rms
            without_rms = self.holdout_without([gone])
            if without_rms > with_rms * (1 + PRACTICAL_GAIN):
                kept_jointly.add(gone.label)
                gone.kept_jointly = (
                    f"below {SIGNIFICANCE:g} standard uncertainties alone (collinear with other terms), kept: "
                    f"without it the held-out RMS rises from {with_rms:.3f} to {without_rms:.3f} um")
                continue
            model, res, names = self.without([gone])
            self.effects.pop(i)
            gone.note = (f"accepted in round {gone.step + 1}, dropped after the final fit: its size is "
                         f"below {SIGNIFICANCE:g} standard uncertainties and without it the held-out RMS is "
                         f"{without_rms:.3f} um (with it {with_rms:.3f} um)")
            dropped.append(gone)
            self.current, self.free_names = model, names
            if res is not None:
                final = res

    def _practical(self, final) -> list[Change]:
        """Findings below practical significance, taken out of the model (which is refitted):
        a held-out RMS gain below :data:`PRACTICAL_GAIN` of the held-out RMS before, or an
        amplitude below :data:`PRACTICAL_AMPLITUDE` of the noise per component."""
        groups = [members for _, members in group_findings(self.effects)]
        # the present model's held-out RMS (the final model's is asked for again), and the refits
        # without each finding
        proj, residual = self.holdout(self.current, final)
        cv_rms, floor = proj.cv_rms, noise_floor(self.obs, residual, proj.rank)[0]
        befores = [self.holdout_without(members) for members in groups]
        noise_pc = floor / math.sqrt(components_per_point(self.obs))
        below = []
        for members, before in zip(groups, befores):
            gain = before - cv_rms
            amplitude = effect_amplitude(self.current, self.obs, [n for m in members for n in m.names])
            for m in members:
                m.gain_um, m.amplitude_um = gain, amplitude
            if gain < PRACTICAL_GAIN * before or amplitude < PRACTICAL_AMPLITUDE * noise_pc:
                why = []
                if gain < PRACTICAL_GAIN * before:
                    why.append(f"held-out RMS gain {gain:.3f} um < {PRACTICAL_GAIN:.0%} of {before:.3f} um")
                if amplitude < PRACTICAL_AMPLITUDE * noise_pc:
                    why.append(f"amplitude {amplitude:.3f} um < {PRACTICAL_AMPLITUDE:g} x the noise of "
                               f"{noise_pc:.3f} um per component")
                for m in members:
                    m.note = "possible, below practical significance: " + "; ".join(why)
                    m.rms_before_um, m.rms_after_um = before, cv_rms
                below += members
        if below:
            self.effects = [e for e in self.effects if e not in below]
            self.current, _, self.free_names = self.without(below)
        return below

    def finish(self) -> tuple[Diagnosis, Identification | None]:
        """The final fit and the diagnosis (its ``seconds`` left at 0), with the final fit."""
        obs = self.obs
        _hold_periods(self)
        final, dropped = self._final_fit(self.last_fit)
        final, rivals, replaced, changed = weigh_rivals(self, final)
        dropped += replaced
        if changed:
            final, more = self._final_fit(final)
            dropped += more
        possible = self._practical(final)
        if possible:
            final, more = self._final_fit(final)
            dropped += more
        thermal = {}
        for finding, members in group_findings(self.effects):
            if effect_kind(finding.name).over_time and "t" in obs.covariates and np.ptp(obs.covariates["t"]) > 0:
                final, thermal[members[0].label] = self._thermal(members, final)
        current = self.current
        raised = raised_summary(self.raised, self.base_machine, current)
        for e in self.effects + possible + [r for r in rivals if r.details.in_model == "named"]:
            e.parameters = finding_parameters(current, final, e.names)
        last_proj, residual = self.holdout(current, final)
        rms_fit = residual_rms(obs, residual)
        floor, source, bound, reaches, stated = floor_verdict(obs, residual, last_proj, self.noise_stated)
        analysis = residual_analysis(current, obs, self.steps[0].residual)
        findings = []
        for finding, members in group_findings(self.effects):
            if len(members) > 1:
                finding.rms_before_um = last_proj.cv_rms + (members[0].gain_um or 0.0)
                finding.rms_after_um = last_proj.cv_rms
            if members[0].label in thermal:
                finding.details = thermal[members[0].label]
            findings.append(finding)
        # a per-revolution error the last round refused for what it is (it does not repeat ...)
        # is said with the plan that separates it; a rival reading of the same error gives way
        undecided = undecided_rotary(self.last_passing, self.effects, current, obs, len(self.steps) - 1)
        taken = {u.label for u in undecided}
        rivals = [r for r in rivals if r.label not in taken or r.details.in_model == "named"]
        undecided = [u for u in undecided if u.label not in {r.label for r in rivals}]
        return Diagnosis(current, self.base_machine, findings, self.steps, self.steps[0].rms_holdout_um,
                         last_proj.cv_rms, rms_fit, floor, source, reaches, self.alpha,
                         0.0, obs, analysis, raised, dropped, bound, possible + rivals + undecided,
                         stated, residual), final

    def _thermal(self, members: list[Change], final) -> tuple:
        """A thermal drift's sensors and why, its lag (the temperature terms' common lag that
        gives the lowest held-out RMS, kept when it lowers it by at least 1 %), and its check
        over time: the final model fitted on the first :data:`TIME_CHECK_SHARE` of the run
        predicts the rest, with and without the drift. The final fit (lagged or not) and the
        details."""
        sensors = [m.driver[2:] for m in members if m.driver and m.driver.startswith("T_")]
        steps = "; ".join(f"{m.driver} (round {m.step + 1}, held-out RMS {m.rms_before_um:.3f} -> "
                          f"{m.rms_after_um:.3f} um)" for m in members
                          if m.rms_before_um is not None and m.rms_after_um is not None)
        details = ThermalModel(sensors, [m.driver for m in members],
                               "stepwise forward selection on the held-out RMS: each round every sensor and time "
                               "were candidates; a term entered when it passed the F-test and lowered the k-fold "
                               "held-out RMS, collinear terms kept when removing one made the held-out RMS "
                               "worse: " + steps)
        lag, tried = 0.0, {}
        if sensors:
            current = self.current

            def lagged(lag_s):
                if not lag_s:
                    return self.holdout(current, final)[0].cv_rms
                fitted_model, res, _ = self._refit(with_lag(current, members, lag_s))
                return self.holdout(fitted_model, res)[0].cv_rms

            lags = (0.0, *LAGS_S)
            tried = {lag_s: lagged(lag_s) for lag_s in lags}
            base_rms = tried[0.0]
            best_rms, best_lag = min((rms, lag_s) for lag_s, rms in tried.items() if lag_s)
            if best_rms < 0.99 * base_rms:
                lag = best_lag
                self.current, final, self.free_names = self._refit(with_lag(current, members, lag))
        details.lag_s = lag
        details.lags_tried = [{"lag_s": k, "rms_holdout_um": v} for k, v in tried.items()]
        details.time_check = _time_check(self, members, final)
        return final, details


def _stopped(loop: _Loop, max_rounds: int) -> dict:
    """Why the rounds ended (:attr:`~volerr_pin.fit.diagnosis.Diagnosis.stopped`)."""
    rounds = len(loop.steps)
    if loop.left_passing:
        labels = loop.left_passing
        return {"reason": "round_limit", "rounds": rounds, "max_rounds": max_rounds, "still_passing": labels,
                "label": (f"stopped at the round limit ({max_rounds} rounds that may accept a change) with "
                          f"{len(labels)} candidate{'s' if len(labels) != 1 else ''} still passing the F-test and "
                          f"the cross-validation, the best: {labels[0]}; a larger max_rounds "
                          "lets the diagnosis go on")}
    return {"reason": "nothing_passes", "rounds": rounds, "max_rounds": max_rounds, "still_passing": [],
            "label": f"stopped after {rounds} round{'s' if rounds != 1 else ''}: no further change passes"}


def _judged_trim(loop: _Loop, final) -> tuple | None:
    """The model with the raises' trailing coefficients that the final fit does not find
    significant trimmed (:func:`~volerr_pin.fit.diagnosis._changes.trim_raises`) and refitted
    (:meth:`_Loop._refit`: machine, fit, free names), unless that makes the held-out RMS worse
    by more than :data:`PRACTICAL_GAIN`: collinear terms share what they explain, and each may
    look insignificant alone (a raised EBB beside B's once-per-revolution error). None when
    there is nothing to trim or the trim is refused."""
    trimmed = trim_raises(loop.current, final, loop.base_machine, {r.component for r in loop.raised})
    if trimmed is None:
        return None
    before = loop.holdout(loop.current, final)[0].cv_rms
    refit = loop._refit(trimmed)
    model, res, _ = refit
    after = loop.holdout(model, res)[0].cv_rms
    return refit if after <= before * (1 + PRACTICAL_GAIN) else None


def _memory_needed(machine: Machine, obs: Observations, folds: int) -> float:
    """Peak memory of a diagnosis [bytes], as measured: the weighted columns of every
    candidate (non-linear ones at several grid values) and the base design with its basis and
    that basis's rows in every training and held-out set, per observation row."""
    candidates = build_candidates(machine, obs)
    columns = sum(max(1, c.term.term.size if c.table is None else
                      sum(len(v) for v in c.table.values() if isinstance(v, list))) for c in candidates)
    base = obs.nuisance.shape[1] + len(machine.parameter_names)
    return 8.0 * len(obs.y) * (6 * columns + (folds + 4) * base)


def _time_check(loop: _Loop, members: list[Change], final) -> dict | None:
    """Fit on the first part of the run, predict the rest (position RMS [um] of the
    predicted points, with the drift and without it)."""
    obs = loop.obs
    t = obs.covariates["t"]
    cut = t.min() + TIME_CHECK_SHARE * np.ptp(t)
    early, late = np.flatnonzero(t <= cut), np.flatnonzero(t > cut)
    if len(early) < 2 or len(late) < 1:
        return None
    out = {"fit_share": TIME_CHECK_SHARE, "fit_until_h": float(cut / 3600.0), "fit_points": int(len(early)),
           "predicted_points": int(len(late))}
    k = "xyz".index(members[0].direction) if members[0].direction in ("x", "y", "z") else None
    model_without = loop.current
    for m in members:
        model_without = remove_effect(model_without, m)
    o_early, o_late = obs.subset(early), obs.subset(late)

    def predicted(key, model):
        names = [n for n in loop.free_names if n in set(model.parameter_names)]
        try:
            res = quiet_identify(model, o_early, free=loop.fit.free(model, names), initialise=False)
        except InputError:
            return None  # the first part alone does not determine the model
        fitted_model = res.machine
        b = base_design(FitPoints.of(fitted_model.model, o_late, fitted_model.state), fitted_model.theta, res.fitted,
                        np.array(list(res.nuisance.values())))
        residual = b.r * o_late.sigma
        part = {f"rms_predicted{key}_um": residual_rms(o_late, residual)}
        if k is not None:
            rows = (o_late.w[:, k] > 0.5) & ~o_late.angular
            part[f"rms_predicted_along{key}_um"] = float(np.sqrt(np.mean(residual[rows] ** 2)) * UM_PER_M)
        return part

    parts = [predicted(key, model) for key, model in (("", loop.current), ("_without", model_without))]
    if any(part is None for part in parts):
        return None
    for part in parts:
        out.update(part)
    return out


def _hold_periods(loop: _Loop) -> None:
    """From the final fit on, an accepted per-revolution error repeats exactly n times per
    revolution: its period goes back to 360/n deg and no fit moves it. In the rounds it is free,
    and an error the data do not pin to a period is not accepted (its size is not determined);
    off the spec's geometry it can wander there (285 deg for once per revolution), which is not
    the error the label names."""
    names = loop.current.parameter_names
    held = {n: v for n, v in loop.fit.periods.items() if n in names}
    if not held:
        return
    theta = loop.current.theta.copy()
    for n, v in held.items():
        theta[names.index(n)] = v
    loop.current = loop.current.with_theta(theta, limits=False)
    loop.fit.held = set(held)
