"""The loop: fit the base model, score every candidate, accept the best that passes, refit,
repeat; then the final fit, which drops what is no longer significant, and the report.

Each round (:meth:`_Loop.round`) fits every candidate jointly with the present model
(:mod:`~volerr_pin.fit.diagnosis.scoring`) and accepts the best that passes all three tests: an
F-test at ``alpha`` over the number of candidates, a lower cross-validated RMS, and a size of
at least :data:`~volerr_pin.fit.diagnosis.results.SIGNIFICANCE` standard uncertainties after the
joint refit (:mod:`~volerr_pin.fit.diagnosis.changes`).
"""

from __future__ import annotations

import math
import time as _time
import warnings

import numpy as np

from ...base.checks import fraction, integer, measurement_sigma
from ...base.errors import InputError, SpecError
from ..identify import (Identification, Observations, build_observations, check_observations, conditioning_note,
                        identify, parameter_units, pose_folds, residual_rms)
from ..identify.design import by_halves
from ...model import Machine
from ...base.safeio import require_memory
from ...base.units import UM_PER_M
from ...model import Constant, TermSpec, check_covariates, check_values
from .candidates import display_unit
from .candidates import build_candidates
from .changes import apply_changes, remove_effect, size_of, tested_names, trim_raises, with_lag
from .report import (components_per_point, effect_amplitude, floor_verdict, group_findings, noise_floor,
                     raised_summary, residual_analysis, twins_of, undecided_rotary)
from .effects import PeriodicRotary, effect_kind
from .results import (PRACTICAL_AMPLITUDE, PRACTICAL_GAIN, SIGNIFICANCE, Change, Diagnosis, Role, Step,
                      ThermalModel, one_blas_thread)
from .projector import Columns, Projector, base_design
from .scoring import not_repeating, score

__all__ = ["LAGS_S", "PERIOD_WINDOW", "TIME_CHECK_SHARE", "diagnose"]

#: lags [s] tried for the temperature terms of a thermal drift
LAGS_S = (300.0, 600.0, 1200.0, 1800.0, 3600.0)
#: share of the run's time a thermal drift's check over time fits on (it predicts the rest)
TIME_CHECK_SHARE = 0.6
#: in the rounds a per-revolution error's period (free there) stays within this factor of 360/n
#: deg; a fit that takes an accepted one further is done again with it held at 360/n deg, and a
#: candidate whose own period goes further is not accepted (it no longer repeats about n times a
#: turn: off the spec's geometry periods were seen to wander to 5.9 deg with no amplitude left,
#: and to 1e8 deg, a slope the axis' polynomial already has, with cancelling amplitudes of
#: thousands of radians; the right ones settled within 0.79 to 1.0 of 360/n)
PERIOD_WINDOW = 1.5
#: what the note of a candidate too small in its joint refit says (before its size)
WEAK = "in the joint refit its size is"


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
        reported reached (:attr:`~volerr_pin.fit.diagnosis.results.Diagnosis.reaches_noise_floor`
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
        (:attr:`~volerr_pin.fit.diagnosis.results.Diagnosis.stopped`).

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
        self.machine, self.obs, self.split, self.fixed, self.alpha = machine, obs, split, fixed, alpha
        self.noise_stated = noise_stated
        self.max_effects, self.progress, self.keep_machines = max_effects, progress, keep_machines
        self.cov_obj = check_covariates(machine.model, obs.n_points, obs.covariates, machine.state)
        self.axis_index_of = {a: j for j, a in enumerate(machine.axes)}
        self.columns = Columns(obs, self.cov_obj)
        self.free_names: list[str] = []        # with ``fixed``: the coefficients that may move
        self.periods: dict[str, float] = {}     # accepted per-revolution errors: period name -> 2 pi / n
        self.held: set[str] = set()             # coefficients no fit moves (from the final fit on: the periods)
        self.current, self.fitted, self.nuisance, self.last_fit = self.fit(machine, self.free_names, initialise=True)
        self.base_machine = self.current
        self.steps: list[Step] = []
        self.effects: list[Change] = []
        self.raised: list[Change] = []
        self.previous: list[Change] = []
        self._last_holdout = None
        self.left_passing: list[str] = []       # what still passed when the round limit ended the rounds
        self.last_passing: list = []            # the last round's passing scores (notes: why refused)

    def fit(self, model: Machine, names: list[str], initialise: bool = False):
        """The model fitted (all coefficients; with ``fixed`` only ``names``): (machine,
        fitted indices, nuisance values, identification or None)."""
        if self.fixed and not names:
            return model, np.array([], dtype=int), np.zeros(self.obs.nuisance.shape[1]), None
        res = _quiet_identify(model, self.obs, free=_free(self, model, names), initialise=initialise)
        strayed = {n: p for n, p in self.periods.items() if n in res.machine.parameter_names
                   and n not in self.held and not _within_window(res.machine, n, p)}
        if strayed:
            # an accepted per-revolution error the fit took out of its window: fitted again
            # with its period held at 360/n deg (for this fit; the next starts from there)
            theta = model.theta.copy()
            for n, p in strayed.items():
                theta[model.parameter_names.index(n)] = p
            res = _quiet_identify(model.with_theta(theta, limits=False), self.obs, free=_free(self, model, names, set(strayed)),
                                  initialise=initialise)
        return res.machine, res.fitted, np.array(list(res.nuisance.values())), res

    def round(self, number: int, may_accept: bool) -> bool:
        """One round; whether it accepted a change."""
        obs = self.obs
        base = base_design(self.current, obs, self.fitted, self.nuisance)
        proj = Projector(base.A, base.r, obs, self.split)
        if number == 0 and len(obs.y) <= proj.rank:
            # the base model interpolates the data: no residual, and a held-out RMS of zero
            raise InputError(f"{len(obs.y)} observations at {obs.n_points} points do not over-determine the "
                             f"base model ({proj.rank} independent coefficients and nuisance terms): there is "
                             "no residual to diagnose; measure more points")
        for record in self.previous:
            record.rms_after_um, record.max_after_um = proj.cv_rms, proj.cv_max
        ranked, passing = self._scores(number, base, proj)
        accepted = self._accept(number, passing, proj) if may_accept else []
        self.last_passing, self.left_passing = passing, ([] if may_accept else [s.label for s in passing])
        self.steps.append(Step(number, proj.cv_rms, [s.summary() for s in ranked], base.r * obs.sigma,
                               self.current if self.keep_machines else None, accepted))
        if not accepted:
            return False
        for record in accepted:
            (self.raised if record.kind == Role.UNDER_MODELLED else self.effects).append(record)
        self.previous = accepted
        twins_of(accepted, passing, self.machine)
        return True

    def _scores(self, number: int, base, proj: Projector) -> tuple[list, list]:
        """Every candidate's score, best first, and those that pass the F-test and lower the
        cross-validated RMS."""
        obs = self.obs
        candidates, E, joints = _offered(self)

        def progress(done):
            if self.progress:
                self.progress(f"round {number + 1}: candidates", done)

        def one(cand):
            return score(base, proj, obs, E, joints, cand, self.cov_obj, self.axis_index_of, self.columns)

        scores = []
        for k, cand in enumerate(candidates):
            s = one(cand)
            progress(k + 1)
            if s is not None:
                scores.append(s)
        m = max(1, len(scores))
        ranked = sorted(scores, key=lambda s: -s.bic_gain)
        # cross-validate what could pass and what is shown
        shown = [s for k, s in enumerate(ranked) if s.cv_rms_um is None and (k < 10 or s.p_value < self.alpha / m)]
        for s in shown:
            s.cv_rms_um = proj.cv(s.columns)
        passing = [s for s in ranked if s.extra > 0 and s.p_value < self.alpha / m
                   and s.cv_rms_um is not None and s.cv_rms_um < proj.cv_rms * (1 - 1e-3)]
        return ranked, passing

    def _accept(self, number: int, passing: list, proj: Projector) -> list[Change]:
        """The first of the best three passing candidates whose size stays significant in the
        joint refit (a winning raise with the other raises that pass on their own); the model
        becomes the refit.

        A per-revolution error that does not repeat from one turn to the next is not accepted,
        and the raises of its component wait while anything else can be accepted: early on,
        other axes' unmodelled geometry clouds the repeat of a true error, and a raise over two
        turns would swallow it; once the rest of the model is in, the question is asked again."""
        first, allowed = _repeat_order(number, passing, proj, self.obs, self.axis_index_of)
        records = self._accept_first(number, first, passing, proj)
        if not records and len(first) < len(allowed):
            records = self._accept_first(number, allowed, passing, proj)
        return records

    def _accept_first(self, number: int, candidates: list, passing: list, proj: Projector) -> list[Change]:
        """The first of the best three of ``candidates`` that stays significant in the joint
        refit, accepted (raises come along from ``passing``); [] when none does."""
        for best in candidates[:3]:
            batch = [best]
            weak = {}   # id -> (score, size): below SIGNIFICANCE in the last joint refit it took part in
            if best.candidate.kind == Role.RAISE:
                # the other under-modelled components that pass on their own come along, except
                # those a physical effect passing this round would sit on: it gets its round first
                # (a raised EBB would swallow B's once-per-revolution error before it is tried)
                taken = {best.candidate.component}
                held = {s.candidate.component for s in passing if s.candidate.kind == Role.EFFECT}
                for s in passing:
                    c = s.candidate
                    if c.kind == Role.RAISE and c.component not in taken | held and s.bic_gain > 0:
                        batch.append(s)
                        taken.add(c.component)
            accepted = False
            while True:   # each retry refits a smaller batch: it ends
                new, records = apply_changes(self.current, batch)
                names = self.free_names + [n for r in records for n in r.names if n not in self.free_names]
                new_fit, new_fitted, new_nuisance, res = self.fit(new, names)
                unheld = _unheld_values(new_fit)
                if unheld:   # the next change could not be built on it, nor the result written
                    for s in batch:
                        s.note = unheld
                    break
                tested = [tested_names(new_fit, r) for r in records]
                sizes = [size_of(res, t) if res is not None and t else math.inf for t in tested]
                for k, (r, s) in enumerate(zip(records, batch)):
                    note = _strayed_note(new_fit, r, s) if effect_kind(r.name).per_revolution else None
                    if note:   # a per-revolution error whose period leaves its window is not that error
                        sizes[k], s.note = 0.0, note
                keep = [s for s, z in zip(batch, sizes) if z >= SIGNIFICANCE]
                # the size of the refit that decides (the last one a candidate took part in)
                weak.update({id(s): (s, z) for s, z in zip(batch, sizes)
                             if z < SIGNIFICANCE and (not s.note or WEAK in s.note)})
                if len(keep) == len(batch):
                    accepted = True
                    break
                if len(batch) == 1:
                    break
                # the ones significant in the joint refit, refitted without the others (until all
                # are); if none is (raises that explain the same residual share it, and each
                # looks insignificant), the best one alone
                batch = keep or [best]
            _note_weak(weak, batch if accepted else [], number)
            if not accepted:
                continue
            for record, z, s in zip(records, sizes, batch):
                record.rms_before_um, record.max_before_um, record.step = proj.cv_rms, proj.cv_max, number
                if effect_kind(record.name).per_revolution:
                    self.periods.update({n: math.radians(s.candidate.table["period_deg"])
                                         for n in record.names if n.endswith(".period")})
                if np.isfinite(z):
                    record.significance = z
            self.free_names = names
            self.current, self.fitted, self.nuisance, self.last_fit = new_fit, new_fitted, new_nuisance, res
            return records
        return []

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
        b = base_design(model, self.obs, fitted, nuisance)
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
            if not fitted and (not self.fixed or self.free_names):
                self.current, _, _, final = self.fit(self.current, self.free_names)
            trimmed = _judged_trim(self, final) if trim else None
            trim = fitted = trimmed is not None
            if trim:  # the trimmed model comes fitted as this loop would fit it: not fitted again
                self.current, res, self.free_names = trimmed
                final = res if res is not None else final
                continue
            weak = [(size_of(final, [n for n in e.names if n not in self.held]) if final is not None else 0.0, i)
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
        units = parameter_units(current)
        for e in self.effects + possible:
            params = {}
            for name in e.names:
                if name not in current.parameter_names:
                    continue
                k = current.parameter_names.index(name)
                factor, unit = units[name]
                u = final.uncertainty[k] if final is not None else math.nan
                params[name] = {"value": float(current.theta[k] / factor),
                                "uncertainty": None if math.isnan(u) else float(u / factor), "unit": unit}
            e.parameters = params
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
        return Diagnosis(current, self.base_machine, findings, self.steps, self.steps[0].rms_holdout_um,
                         last_proj.cv_rms, rms_fit, floor, source, reaches, self.alpha,
                         0.0, obs, analysis, raised, dropped, bound,
                         possible + undecided_rotary(self.last_passing, self.effects, current, obs, len(self.steps) - 1),
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


def _note_weak(weak: dict, taken: list, number: int) -> None:
    """Why a candidate that passed its round's tests was not taken: its size in the last joint
    refit it took part in (``weak``: id -> (score, size)); the notes of the ``taken`` ones go (a
    candidate too small beside an earlier best may be taken with a later one)."""
    for s, z in weak.values():
        if not any(s is t for t in taken):
            s.note = f"not accepted in round {number + 1}: {WEAK} {_below(z)} standard uncertainties, " \
                     f"below {SIGNIFICANCE:g}"
    for s in taken:
        if WEAK in s.note:
            s.note = ""


def _below(z: float) -> str:
    """A size below :data:`SIGNIFICANCE` in two digits, or more where two would round it up to
    the threshold."""
    text = f"{z:.2g}"
    return text if float(text) < SIGNIFICANCE else f"{math.floor(z * 1e6) / 1e6:.7g}"


def _stopped(loop: _Loop, max_rounds: int) -> dict:
    """Why the rounds ended (:attr:`~volerr_pin.fit.diagnosis.results.Diagnosis.stopped`)."""
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


def _repeat_order(number: int, passing: list, proj: Projector, obs: Observations,
                  axis_index_of: dict[str, int]) -> tuple[list, list]:
    """The passing candidates a round may accept first, and those it may accept when none of
    the first is: without the per-revolution errors that do not repeat from one turn to the
    next (:func:`~volerr_pin.fit.diagnosis.scoring.not_repeating`, whose reason becomes the
    score's ``note``), the first also without the raises of their components."""
    failing = set()
    for s in passing:
        c = s.candidate
        if effect_kind(c.name).per_revolution and s.columns is not None:
            note = not_repeating(proj, obs, s.columns, obs.q[:, axis_index_of[c.axis]], c, number)
            if note:
                s.note = note
                failing.add(s.label)
    waiting = {s.candidate.component for s in passing if s.label in failing}
    allowed = [s for s in passing if s.label not in failing]
    return [s for s in allowed if not (s.candidate.kind == Role.RAISE and s.candidate.component in waiting)], allowed


def _judged_trim(loop: _Loop, final) -> tuple | None:
    """The model with the raises' trailing coefficients that the final fit does not find
    significant trimmed (:func:`~volerr_pin.fit.diagnosis.changes.trim_raises`) and refitted
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


def _offered(loop: _Loop) -> tuple[list, np.ndarray, list[str]]:
    """The round's candidates, and the error-joint sensitivity at the points (with the components
    they would add, at zero) and its joints: a component's per-revolution error of an order
    already accepted is not offered again (a second term beside the first would only share it),
    and once ``max_effects`` effects are in only raises are."""
    accepted_orders = {(n.split(".")[0], round(2 * math.pi / p)) for n, p in loop.periods.items()}
    candidates = [c for c in build_candidates(loop.current, loop.obs) if not (
        effect_kind(c.name).per_revolution and (c.component, PeriodicRotary.order(c)) in accepted_orders)]
    if len(loop.effects) >= loop.max_effects:
        candidates = [c for c in candidates if c.kind == Role.RAISE]
    missing_loc = sorted({c.component for c in candidates if c.component not in loop.current.error_joints},
                         key=[c.component for c in candidates].index)
    probe = loop.current
    if missing_loc:
        spec = probe.spec
        for component in missing_loc:
            spec = spec.with_terms(component, TermSpec("probe", Constant(*display_unit(component[1])), np.zeros(1)))
        probe = probe.with_spec(spec)
    E = by_halves(loop.obs, lambda q, **cov: probe.error_joint_sensitivity(q, first_order=True, **cov),
                  "joint sensitivity")
    return candidates, E, list(probe.error_joints)


def _quiet_identify(machine: Machine, obs: Observations, **options) -> Identification:
    """A fit of the loop, without cross-validation; its conditioning is said once, for the
    final model, not for every trial."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="the fit is ill-conditioned")
        return identify(machine, obs, folds=0, **options)


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
            res = _quiet_identify(model, o_early, free=_free(loop, model, names), initialise=False)
        except InputError:
            return None  # the first part alone does not determine the model
        b = base_design(res.machine, o_late, res.fitted, np.array(list(res.nuisance.values())))
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


def _free(loop: _Loop, model: Machine, names: list[str], also_held: set[str] = frozenset()) -> list[int] | None:
    """The coefficients of ``model`` a fit of the loop moves: all (None) or, with ``fixed``,
    ``names``; never a held one (:func:`_hold_periods`, and ``also_held``)."""
    free = None if not loop.fixed else [model.parameter_names.index(n) for n in names]
    held = loop.held | set(also_held)
    if not held:
        return free
    return [k for k in (range(len(model.parameter_names)) if free is None else free)
            if model.parameter_names[k] not in held]


def _within_window(model: Machine, name: str, period: float) -> bool:
    """Whether ``model``'s period ``name`` lies within :data:`PERIOD_WINDOW` of ``period`` (rad)."""
    value = float(model.theta[model.parameter_names.index(name)])
    return period / PERIOD_WINDOW <= value <= period * PERIOD_WINDOW


def _unheld_values(model: Machine) -> str | None:
    """Why a refit is not accepted when a spec could not hold its values (None when it can)."""
    try:
        check_values(model)
    except SpecError as exc:
        return f"not accepted: the joint refit's values are beyond what a spec holds ({exc})"
    return None


def _strayed_note(model: Machine, record: Change, scored) -> str | None:
    """Why a per-revolution error is not accepted when the joint refit took its period out of
    its window (None when it did not)."""
    period_deg = scored.candidate.table["period_deg"]
    for name in record.names:
        if name.endswith(".period") and not _within_window(model, name, math.radians(period_deg)):
            value = math.degrees(float(model.theta[model.parameter_names.index(name)]))
            return (f"not accepted: in the joint refit its period went to {value:.4g} deg, outside "
                    f"{1 / PERIOD_WINDOW:.3g} to {PERIOD_WINDOW:g} times {period_deg:g} deg: it no longer "
                    "repeats as this error does")
    return None


def _hold_periods(loop: _Loop) -> None:
    """From the final fit on, an accepted per-revolution error repeats exactly n times per
    revolution: its period goes back to 360/n deg and no fit moves it. In the rounds it is free,
    and an error the data do not pin to a period is not accepted (its size is not determined);
    off the spec's geometry it can wander there (285 deg for once per revolution), which is not
    the error the label names."""
    names = loop.current.parameter_names
    held = {n: v for n, v in loop.periods.items() if n in names}
    if not held:
        return
    theta = loop.current.theta.copy()
    for n, v in held.items():
        theta[names.index(n)] = v
    loop.current = loop.current.with_theta(theta, limits=False)
    loop.held = set(held)
