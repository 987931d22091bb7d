"""The loop: fit the base model, score every candidate, accept the best that passes, refit,
repeat; then the final fit, which drops what is no longer significant, and the report.

Each round (:meth:`_Loop.round`) fits every candidate jointly with the present model
(:mod:`~volerr_pin.diagnose.scoring`) and accepts the best that passes all three tests: an
F-test at ``alpha`` over the number of candidates, a lower cross-validated RMS, and a size of
at least :data:`~volerr_pin.diagnose.results.SIGNIFICANCE` standard uncertainties after the
joint refit (:mod:`~volerr_pin.diagnose.changes`).
"""

from __future__ import annotations

import math
import time as _time
import warnings

import numpy as np

from ..checks import fraction, integer, positive
from ..errors import InputError
from ..identify import (Identification, Observations, build_observations, check_observations, conditioning_note,
                        identify, parameter_units, pose_folds, residual_rms)
from ..machine import Machine
from ..safeio import require_memory
from ..specio import add_terms
from .candidates import build_candidates
from .changes import apply_changes, remove_effect, size_of, tested_names, trim_raises
from .report import noise_floor, raised_summary, residual_analysis, twins_of
from .results import SIGNIFICANCE, Change, Diagnosis, Step
from .scoring import Columns, Projector, base_design, score

__all__ = ["diagnose"]


def diagnose(machine: Machine, measurements, *, fixed: bool = False, max_effects: int = 5,
             alpha: float = 0.01, folds: int = 5, seed: int = 0, sigma_um: float = 1.0,
             sigma_urad: float = 1.0, progress=None, keep_machines: bool = False,
             max_rounds: int | None = None) -> Diagnosis:
    """Find, name and add the effects the model is missing (see :mod:`volerr_pin.diagnose`).

    Parameters
    ----------
    machine : Machine
        The model to test (its spec's terms are the base model).
    measurements : list of measurement objects, or Observations
        Point measurements (or runs, tracker, ballbar files) as
        :func:`~volerr_pin.identify.build_observations` takes them, or observations built
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
    sigma_um : float, default 1.0
        Standard deviation of position observations [um]; only when ``measurements`` are
        not :class:`~volerr_pin.identify.Observations`.
    sigma_urad : float, default 1.0
        Standard deviation of rotation observations [urad]; likewise.
    progress : callable(str, int), optional
        Called with a stage name and a step count, for progress bars.
    keep_machines : bool, default False
        Keep the machine of every round in :attr:`Step.machine`.
    max_rounds : int, optional
        Rounds of the loop at most (default ``max_effects`` + 8: room for raising
        under-modelled components).

    Returns
    -------
    Diagnosis
        The final model, the effects found in order, the raised components, every round's
        scores, the held-out RMS before and after and the noise floor.

    Raises
    ------
    InputError
        If a parameter is out of its range above, the measurements are invalid (see
        :func:`~volerr_pin.identify.identify`), hold no position observations, are too few to
        over-determine the base model (it would pass through every point, leaving no
        residual), sit at too few distinct poses for ``folds``-fold cross-validation, or the
        diagnosis would need more memory than the machine has free.

    Warns
    -----
    UserWarning
        Once, when the final fit is ill-conditioned (see
        :attr:`~volerr_pin.identify.Identification.ill_conditioned`).
    """
    start = _time.perf_counter()
    max_effects = integer("max_effects", max_effects, 0)
    alpha = fraction("alpha", alpha)
    folds = integer("folds", folds, 2)
    seed = integer("seed", seed, 0)
    sigma_um, sigma_urad = positive("sigma_um", sigma_um), positive("sigma_urad", sigma_urad)
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
    require_memory(_memory_needed(machine, obs, folds),
                   f"diagnosing {obs.n_points} points ({len(obs.y)} observations)")
    loop = _Loop(machine, obs, split, fixed, alpha, max_effects, progress, keep_machines)
    max_rounds = max_effects + 8 if max_rounds is None else max_rounds
    for number in range(max_rounds + 1):
        if not loop.round(number, may_accept=number < max_rounds):
            break
    diagnosis, final = loop.finish()
    if final is not None and final.ill_conditioned:
        warnings.warn(conditioning_note(final.analysis, len(obs.y)), stacklevel=2)
    diagnosis.seconds = _time.perf_counter() - start
    return diagnosis


class _Loop:
    """The state of a diagnosis between rounds: the present model and its fit, the free
    coefficients (with ``fixed``), what was accepted so far, and the caches of the rounds."""

    def __init__(self, machine: Machine, obs: Observations, split: list[np.ndarray], fixed: bool, alpha: float,
                 max_effects: int, progress, keep_machines: bool):
        self.machine, self.obs, self.split, self.fixed, self.alpha = machine, obs, split, fixed, alpha
        self.max_effects, self.progress, self.keep_machines = max_effects, progress, keep_machines
        self.cov_obj = machine.check_covariates(obs.n_points, obs.covariates)
        self.axis_index_of = {a: j for j, a in enumerate(machine.axes)}
        self.columns = Columns(obs, self.cov_obj)
        self.free_names: list[str] = []        # with ``fixed``: the coefficients that may move
        self.current, self.fitted, self.nuisance, self.last_fit = self.fit(machine, self.free_names, initialise=True)
        self.base_machine = self.current
        self.steps: list[Step] = []
        self.effects: list[Change] = []
        self.raised: list[Change] = []
        self.previous: list[Change] = []

    def fit(self, model: Machine, names: list[str], initialise: bool = False):
        """The model fitted (all coefficients; with ``fixed`` only ``names``): (machine,
        fitted indices, nuisance values, identification or None)."""
        if self.fixed and not names:
            return model, np.array([], dtype=int), np.zeros(self.obs.nuisance.shape[1]), None
        free = None if not self.fixed else [model.parameter_names.index(n) for n in names]
        res = _quiet_identify(model, self.obs, free=free, initialise=initialise)
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
        self.steps.append(Step(number, proj.cv_rms, [s.summary() for s in ranked], base.r * obs.sigma,
                               self.current if self.keep_machines else None, accepted))
        if not accepted:
            return False
        for record in accepted:
            (self.raised if record.kind == "under_modelled" else self.effects).append(record)
        self.previous = accepted
        twins_of(accepted, passing, self.machine)
        return True

    def _scores(self, number: int, base, proj: Projector) -> tuple[list, list]:
        """Every candidate's score, best first, and those that pass the F-test and lower the
        cross-validated RMS."""
        obs = self.obs
        candidates = build_candidates(self.current, obs)
        if len(self.effects) >= self.max_effects:
            candidates = [c for c in candidates if c.kind == "raise"]
        missing_loc = {c.component: {"kind": "constant", "prefix": "probe",
                                     f"value_{'um' if c.component[1] in 'XYZ' else 'arcsec'}": 0.0}
                       for c in candidates if c.component not in self.current.error_joints}
        probe = add_terms(self.current, missing_loc) if missing_loc else self.current
        E = probe.error_joint_sensitivity(obs.q, first_order=True, **obs.covariates)
        joints = list(probe.error_joints)
        scores = []
        for k, cand in enumerate(candidates):
            s = score(base, proj, obs, E, joints, cand, self.cov_obj, self.axis_index_of, self.columns)
            if s is None:
                continue
            scores.append(s)
            if self.progress:
                self.progress(f"round {number + 1}: candidates", k + 1)
        m = max(1, len(scores))
        ranked = sorted(scores, key=lambda s: -s.bic_gain)
        for k, s in enumerate(ranked):  # cross-validate what could pass and what is shown
            if s.cv_rms_um is None and (k < 10 or s.p_value < self.alpha / m):
                s.cv_rms_um = proj.cv(s.columns)
        passing = [s for s in ranked if s.extra > 0 and s.p_value < self.alpha / m
                   and s.cv_rms_um is not None and s.cv_rms_um < proj.cv_rms * (1 - 1e-3)]
        return ranked, passing

    def _accept(self, number: int, passing: list, proj: Projector) -> list[Change]:
        """The first of the best three passing candidates whose size stays significant in the
        joint refit (a winning raise with the other raises that pass on their own); the model
        becomes the refit."""
        for best in passing[:3]:
            batch = [best]
            if best.candidate.kind == "raise":
                # the other under-modelled components that pass on their own come along
                taken = {best.candidate.component}
                for s in passing:
                    c = s.candidate
                    if c.kind == "raise" and c.component not in taken and s.bic_gain > 0:
                        batch.append(s)
                        taken.add(c.component)
            for attempt in range(2):
                new, records = apply_changes(self.current, batch)
                names = self.free_names + [n for r in records for n in r.names if n not in self.free_names]
                new_fit, new_fitted, new_nuisance, res = self.fit(new, names)
                tested = [tested_names(new_fit, r) for r in records]
                sizes = [size_of(res, t) if res is not None and t else math.inf for t in tested]
                keep = [s for s, z in zip(batch, sizes) if z >= SIGNIFICANCE]
                if len(keep) == len(batch) or (not keep and len(batch) == 1):
                    break
                # the ones significant in the joint refit; if none is (raises that explain the
                # same residual share it, and each looks insignificant), the best one alone
                batch = keep or [best]
            if len(keep) != len(batch) or not keep:
                continue
            for record, z in zip(records, sizes):
                record.rms_before_um, record.max_before_um, record.step = proj.cv_rms, proj.cv_max, number
                if np.isfinite(z):
                    record.significance = z
            self.free_names = names
            self.current, self.fitted, self.nuisance, self.last_fit = new_fit, new_fitted, new_nuisance, res
            return records
        return []

    def _final_fit(self) -> tuple[Identification | None, list[Change]]:
        """Refit until every accepted effect is significant (dropping the weakest that is not)
        and raised polynomials keep only significant coefficients: the final fit and the
        dropped effects."""
        dropped: list[Change] = []
        final = self.last_fit
        while True:
            if not self.fixed or self.free_names:
                free = None if not self.fixed else [self.current.parameter_names.index(n) for n in self.free_names]
                final = _quiet_identify(self.current, self.obs, free=free, initialise=False)
                self.current = final.machine
            trimmed = trim_raises(self.current, final, self.base_machine, {r.component for r in self.raised})
            if trimmed is not None:
                self.current = trimmed
                self.free_names = [n for n in self.free_names if n in set(self.current.parameter_names)]
                continue
            weak = [(size_of(final, e.names) if final is not None else 0.0, i) for i, e in enumerate(self.effects)]
            weak = [(z, i) for z, i in weak if z < SIGNIFICANCE]
            if not weak:
                return final, dropped
            _, i = min(weak)
            gone = self.effects.pop(i)
            gone.note = (f"accepted in round {gone.step + 1}, dropped after the final fit: its size is "
                         f"below {SIGNIFICANCE:g} standard uncertainties")
            dropped.append(gone)
            self.current = remove_effect(self.current, gone)
            self.free_names = [n for n in self.free_names if n in set(self.current.parameter_names)]

    def finish(self) -> tuple[Diagnosis, Identification | None]:
        """The final fit and the diagnosis (its ``seconds`` left at 0), with the final fit."""
        obs = self.obs
        final, dropped = self._final_fit()
        current = self.current
        raised = raised_summary(self.raised, self.base_machine, current)
        units = parameter_units(current)
        for e in self.effects:
            params = {}
            for name in e.names:
                k = current.parameter_names.index(name)
                factor, unit = units[name]
                u = final.uncertainty[k] if final is not None else math.nan
                params[name] = {"value": float(current.theta[k] / factor),
                                "uncertainty": None if math.isnan(u) else float(u / factor), "unit": unit}
            e.parameters = params
        fitted_final = final.fitted if final is not None else np.array([], dtype=int)
        nuisance_final = (np.array(list(final.nuisance.values())) if final is not None
                          else np.zeros(obs.nuisance.shape[1]))
        last = base_design(current, obs, fitted_final, nuisance_final)
        last_proj = Projector(last.A, last.r, obs, self.split)
        rms_fit = residual_rms(obs, last.r * obs.sigma)
        floor, source, bound = noise_floor(obs, last.r * obs.sigma, last_proj.rank)
        analysis = residual_analysis(current, obs, self.steps[0].residual)
        return Diagnosis(current, self.base_machine, self.effects, self.steps, self.steps[0].rms_holdout_um,
                         last_proj.cv_rms, rms_fit, floor, source, bool(last_proj.cv_rms <= 1.2 * floor), self.alpha,
                         0.0, obs, analysis, raised, dropped, bound), final


def _quiet_identify(machine: Machine, obs: Observations, **options) -> Identification:
    """A fit of the loop, without cross-validation; its conditioning is said once, for the
    final model, not for every trial."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="the fit is ill-conditioned")
        return identify(machine, obs, folds=0, **options)


def _memory_needed(machine: Machine, obs: Observations, folds: int) -> float:
    """Peak memory of a diagnosis [bytes], as measured: the weighted columns of every
    candidate (non-linear ones at several grid values) and the base design with its bases on
    every training set, per observation row."""
    candidates = build_candidates(machine, obs)
    columns = sum(max(1, sum(len(v) for v in c.table.values() if isinstance(v, list))) for c in candidates)
    base = obs.nuisance.shape[1] + len(machine.parameter_names)
    return 8.0 * len(obs.y) * (6 * columns + (folds + 4) * base)
