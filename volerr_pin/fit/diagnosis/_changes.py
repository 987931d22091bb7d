"""Changes to the model, as typed edits of its spec (:class:`~volerr_pin.model.MachineSpec`) laid
out on the same Pinocchio model (:meth:`~volerr_pin.model.Machine.with_spec`): an accepted
effect added as a term, under-modelled components raised (starting from their present
function, so the base fit is reproduced exactly), an effect removed again, raises trimmed to
what the final fit finds significant; and the size of a change in standard uncertainties,
which decides whether it stays.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ...base import SpecError
from ..identify import Identification, Observations, identify
from ...model import GEOMETRIC, Machine, Model, TermSpec, check_values
from ._candidates import geometric_term, raised_term
from ._effects import effect_kind
from ._projector import Projector
from ._report import twins_of
from ._results import SIGNIFICANCE, Change, Role, Score
from ._scoring import f_test, not_repeating

__all__ = ["PERIOD_WINDOW", "WEAK", "Accepted", "Refit", "absorbed", "accept", "apply_changes", "physical",
           "raise_components", "remove_effect", "size_of", "tested_names", "trim_raises", "with_lag"]

#: in the rounds a per-revolution error's period (free there) stays within this factor of 360/n
#: deg; a fit that takes an accepted one further is done again with it held at 360/n deg, and a
#: candidate whose own period goes further is not accepted (it no longer repeats about n times a
#: turn: off the spec's geometry periods were seen to wander to 5.9 deg with no amplitude left,
#: and to 1e8 deg, a slope the axis' polynomial already has, with cancelling amplitudes of
#: thousands of radians; the right ones settled within 0.79 to 1.0 of 360/n)
PERIOD_WINDOW = 1.5
#: what the note of a candidate too small in its joint refit says (before its size)
WEAK = "in the joint refit its size is"


def _unique_prefix(machine: Machine, component: str, stem: str) -> str:
    used = {n.split(".")[1] for n in machine.parameter_names if n.startswith(component + ".")
            and n.count(".") == 2}
    if stem not in used:
        return stem
    k = 2
    while f"{stem}{k}" in used:
        k += 1
    return f"{stem}{k}"


def _with_term(spec, component: str, index: int, tspec: TermSpec):
    """``spec`` with ``component``'s term ``index`` replaced by ``tspec``."""
    terms = list(spec.component(component).terms)
    terms[index] = tspec
    return spec.with_component(component, *terms)


def raise_components(machine: Machine, components: list[tuple[str, int]]) -> Machine:
    """The machine with these components' geometric terms raised, each starting from its
    present function (an exact reproduction for tables and polynomials alike).

    Parameters
    ----------
    machine : Machine
        The machine.
    components : list of tuple of (str, int)
        (component, degrees to add) pairs.

    Returns
    -------
    Machine
        The machine with the raised terms.
    """
    spec = machine.spec
    for component, by in components:
        index, tspec = geometric_term(machine, component)
        _, raised, _ = raised_term(machine, component, tspec.coefficients, by)
        spec = _with_term(spec, component, index, raised)
    return machine.with_spec(spec)


def remove_effect(machine: Machine, effect: Change) -> Machine:
    """The machine without an accepted effect's terms.

    Parameters
    ----------
    machine : Machine
        The machine.
    effect : Change
        An effect accepted earlier.

    Returns
    -------
    Machine
        The machine without the terms holding ``effect.names``.
    """
    component = effect.component
    names = set(effect.names)
    spec = machine.spec
    keep = [t for t in spec.component(component).terms if not names & set(t.names(component))]
    return machine.with_spec(spec.with_component(component, *keep) if keep else spec.without(component))


def apply_changes(machine: Machine, batch: list[Score]) -> tuple[Machine, list[Change]]:
    """The machine with scored candidates added (one effect, or under-modelled components
    raised together, each from the present function its candidate carries).

    Parameters
    ----------
    machine : Machine
        The present model (the one the candidates were offered on).
    batch : list of Score
        One effect's score, or the scores of under-modelled components raised together.

    Returns
    -------
    machine : Machine
        The new model.
    changes : list of Change
        What was added, one per score.
    """
    raises = [s.candidate for s in batch if s.candidate.kind == Role.RAISE]
    if raises:
        spec = machine.spec
        for cand in raises:
            present = spec.component(cand.component).terms
            index = next(i for i, t in enumerate(present) if t.term.kind in GEOMETRIC)
            spec = _with_term(spec, cand.component, index, cand.term.with_coefficients(cand.start))
        new = machine.with_spec(spec)
        records = []
        for score in batch:
            cand = score.candidate
            records.append(Change(Role.UNDER_MODELLED, cand.label, cand.name, cand.component, cand.axis, cand.direction,
                                  cand.driver, score.p_value, score.bic_gain, by=cand.by,
                                  form_before=cand.change[0], form_after=cand.change[1],
                                  names=list(cand.term.names(cand.component))))
        return new, records
    (score,) = batch
    cand = score.candidate
    before = set(machine.parameter_names)
    stem = effect_kind(cand.name).prefix   # None: a geometric term ("geom" beside others, none alone)
    prefix = _unique_prefix(machine, cand.component, stem or "geom")
    if not (stem is not None or cand.component in machine.components):
        prefix = ""
    term = TermSpec(prefix, score.term.term, score.coefficients)
    new = machine.with_spec(machine.spec.with_terms(cand.component, term))
    return new, [Change(Role.EFFECT, cand.label, cand.name, cand.component,
                        cand.axis if cand.axis in machine.axes else None, cand.direction, cand.driver,
                        score.p_value, score.bic_gain, names=[n for n in new.parameter_names if n not in before])]


def trim_raises(machine: Machine, fit, base: Machine, components) -> Machine | None:
    """Raised polynomials lose their trailing coefficients that the final fit does not find
    significant (a component raised by 4 where 1 was enough).

    Parameters
    ----------
    machine : Machine
        The final model.
    fit : Identification or None
        Its fit (None: nothing to trim).
    base : Machine
        The base model (the components' forms before the raises).
    components : set of str
        The raised components.

    Returns
    -------
    Machine or None
        The trimmed model; None when nothing changes.
    """
    if fit is None:
        return None
    spec, trimmed = machine.spec, False
    for component in sorted(components):
        index, tspec = geometric_term(machine, component)
        if tspec.term.kind not in ("legendre", "monomial"):
            continue
        _, original = geometric_term(base, component)
        start = 0 if original.term.kind == "constant" else original.term.degree
        names = tspec.names(component)
        z = []
        for name in names:
            k = machine.parameter_names.index(name)
            u = fit.uncertainty[k]
            z.append(abs(machine.theta[k]) / u if np.isfinite(u) and u > 0 else 0.0)
        keep = max([start] + [d for d in range(start + 1, len(names)) if z[d] >= SIGNIFICANCE])
        if keep >= tspec.term.degree:
            continue
        shorter = TermSpec(tspec.prefix, replace(tspec.term, degree=keep), tspec.coefficients[:keep + 1])
        spec, trimmed = _with_term(spec, component, index, shorter), True
    return machine.with_spec(spec) if trimmed else None


def tested_names(change: Change, candidate) -> list[str]:
    """The coefficients whose size decides whether a change stays: a raised polynomial's new
    coefficients, an effect's (or missing component's) own coefficients; none for a
    denser table (its F-test and cross-validation decide).

    Parameters
    ----------
    change : Change
        The change.
    candidate : Candidate
        The candidate it was made from.

    Returns
    -------
    list of str
        Coefficient names.
    """
    if change.kind != Role.UNDER_MODELLED:
        return change.names
    if candidate.term.term.kind == "table":
        return []
    return list(change.names[-change.by:])


def size_of(res, names: list[str]) -> float:
    """Largest |value| / standard uncertainty over the linear coefficients ``names`` of a
    fit; 0 when a non-linear one (time constant, period) is not determined or no linear
    one is.

    Parameters
    ----------
    res : Identification
        The fit.
    names : list of str
        Coefficient names.

    Returns
    -------
    float
        The size in standard uncertainties.
    """
    machine = res.machine
    nonlinear = set(machine.nonlinear_parameters)
    z = 0.0
    for name in names:
        k = machine.parameter_names.index(name)
        u = res.uncertainty[k]
        if k in nonlinear:
            if not np.isfinite(u):
                return 0.0
            continue
        if np.isfinite(u) and u > 0:
            z = max(z, abs(float(machine.theta[k])) / float(u))
    return z


def with_lag(machine: Machine, effects: list[Change], lag_s: float) -> Machine:
    """The machine with the temperature-driven drift terms of ``effects`` reading their
    sensors ``lag_s`` seconds late (the other terms unchanged).

    Parameters
    ----------
    machine : Machine
        The machine.
    effects : list of Change
        Accepted thermal drifts.
    lag_s : float
        The lag [s] (0: none).

    Returns
    -------
    Machine
        The machine with the lagged terms, their coefficients kept.
    """
    spec, changed = machine.spec, False
    for effect in effects:
        names = set(effect.names)
        comp = spec.component(effect.component)
        terms = [TermSpec(t.prefix, replace(t.term, lag=float(lag_s)), t.coefficients)
                 if names & set(t.names(effect.component)) and hasattr(t.term, "lag") else t for t in comp.terms]
        spec, changed = spec.with_component(effect.component, *terms), True
    return machine.with_spec(spec) if changed else machine


# ----------------------------------------------------------------------------- how models are fitted
class Refit:
    """How a diagnosis fits its models: every coefficient (or, with ``fixed``, only the names a
    call gives), never a held one, and an accepted per-revolution error that a fit takes out of
    its window fitted again with its period held at 360/n deg.

    Parameters
    ----------
    obs : Observations
        The observations.
    fixed : bool
        Keep the spec's geometric values: only the names a call gives move.

    Attributes
    ----------
    periods : dict of str to float
        Accepted per-revolution errors: period coefficient -> 2 pi / n [rad].
    held : set of str
        Coefficients no fit moves (from the final fit on: the periods).
    """

    def __init__(self, obs: Observations, fixed: bool):
        self.obs, self.fixed = obs, fixed
        self.periods: dict[str, float] = {}
        self.held: set[str] = set()

    def __call__(self, model: Machine, names: list[str], initialise: bool = False):
        """``model`` fitted: (machine, fitted indices, nuisance values, identification or None).

        Parameters
        ----------
        model : Machine
            The model.
        names : list of str
            With ``fixed``: the coefficients that move.
        initialise : bool, default False
            Start non-linear coefficients from a grid search.

        Returns
        -------
        tuple
            The fitted machine, the fitted coefficients' indices, the nuisance values and the fit.
        """
        if self.fixed and not names:
            return model, np.array([], dtype=int), np.zeros(self.obs.nuisance.shape[1]), None
        res = quiet_identify(model, self.obs, free=self.free(model, names), initialise=initialise)
        fitted = dict(zip(res.machine.parameter_names, res.machine.theta))
        strayed = {n: p for n, p in self.periods.items() if n in fitted and n not in self.held
                   and not within_window(fitted[n], p)}
        if strayed:
            # an accepted per-revolution error the fit took out of its window: fitted again
            # with its period held at 360/n deg (for this fit; the next starts from there)
            theta = model.theta.copy()
            for n, p in strayed.items():
                theta[model.parameter_names.index(n)] = p
            res = quiet_identify(model.with_theta(theta, limits=False), self.obs,
                                 free=self.free(model, names, set(strayed)), initialise=initialise)
        return res.machine, res.fitted, np.array(list(res.nuisance.values())), res

    def free(self, model: Machine, names: list[str], also_held: set[str] = frozenset()) -> list[int] | None:
        """The coefficients of ``model`` a fit moves: all (None) or, with ``fixed``, ``names``;
        never a held one (:attr:`held`, and ``also_held``).

        Parameters
        ----------
        model : Machine
            The model.
        names : list of str
            With ``fixed``: the coefficients that move.
        also_held : set of str, optional
            More coefficients held for this fit.

        Returns
        -------
        list of int or None
            Indices into ``model``'s coefficients; None: all.
        """
        free = None if not self.fixed else [model.parameter_names.index(n) for n in names]
        held = self.held | set(also_held)
        if not held:
            return free
        return [k for k in (range(len(model.parameter_names)) if free is None else free)
                if model.parameter_names[k] not in held]


def quiet_identify(machine: Machine, obs: Observations, **options) -> Identification:
    """A fit of a diagnosis, without cross-validation; its conditioning is said once, for the
    final model, not for every trial.

    Parameters
    ----------
    machine : Machine
        The model.
    obs : Observations
        The observations.
    **options
        Passed to :func:`~volerr_pin.fit.identify.identify`.

    Returns
    -------
    Identification
        The fit.
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="the fit is ill-conditioned")
        return identify(machine, obs, folds=0, **options)


def within_window(value: float, period: float) -> bool:
    """Whether a fitted period lies within :data:`PERIOD_WINDOW` of the revolution's.

    Parameters
    ----------
    value : float
        The fitted period [rad].
    period : float
        360/n deg [rad].

    Returns
    -------
    bool
        Whether it lies within the window.
    """
    return period / PERIOD_WINDOW <= float(value) <= period * PERIOD_WINDOW


# ----------------------------------------------------------------------------- accepting a change
@dataclass
class Accepted:
    """What a round accepted: its records and the refit model.

    Attributes
    ----------
    records : list of Change
        The changes, one per accepted candidate.
    machine : Machine
        The refit model.
    fitted : ndarray of int
        Its fitted coefficients.
    nuisance : ndarray
        Its nuisance values.
    fit : Identification or None
        Its fit.
    free_names : list of str
        With ``fixed``: the coefficients that move from now on.
    """

    records: list
    machine: Machine
    fitted: np.ndarray
    nuisance: np.ndarray
    fit: object
    free_names: list


def physical(score: Score) -> bool:
    """Whether a scored candidate names something (an effect, or a geometric component the spec
    leaves out, such as a location error) rather than raising a component the spec has.

    Parameters
    ----------
    score : Score
        A round's score.

    Returns
    -------
    bool
    """
    return score.candidate is not None and score.candidate.kind != Role.RAISE


def absorbed(proj: Projector, given: np.ndarray, score: Score, limit: float) -> bool:
    """Whether a candidate that passed its round's F-test no longer does beside other columns:
    what it explains, they explain (raises of an axis' components that soak up its
    once-per-revolution error, or an offset of the axis it carries).

    Parameters
    ----------
    proj : Projector
        The round's projector.
    given : ndarray, shape (rows, k)
        The other candidates' weighted columns.
    score : Score
        The candidate's score (its ``columns``).
    limit : float
        The round's p-value threshold (``alpha`` over the number of candidates).

    Returns
    -------
    bool
        True when its F-test beside ``given`` fails the threshold.
    """
    if score.columns is None or given.shape[1] == 0:
        return False
    extra0, rss0, _ = proj.fit(given)
    extra1, rss1, _ = proj.fit(np.hstack([given, score.columns]))
    k = extra1 - extra0
    dof = len(proj.r) - proj.rank - extra1
    if k <= 0 or dof <= 0 or rss1 <= 0:
        return True
    return f_test(rss0, rss1, k, dof) >= limit


def accept(current: Machine, number: int, passing: list[Score], proj: Projector, axis_index_of: dict[str, int],
           refit: Refit, free_names: list[str]) -> Accepted | None:
    """The first of the best three passing candidates whose size stays significant in the
    joint refit (a winning raise with the other raises that pass on their own), refitted.

    A per-revolution error that does not repeat from one turn to the next is not accepted,
    and the raises of its component wait while anything else can be accepted: early on,
    other axes' unmodelled geometry clouds the repeat of a true error, and a raise over two
    turns would swallow it; once the rest of the model is in, the question is asked again.

    Parameters
    ----------
    current : Machine
        The present model (fitted).
    number : int
        The round (0 first).
    passing : list of Score
        The round's passing scores, best first.
    proj : Projector
        The round's projector.
    axis_index_of : dict of str to int
        Axis name -> index.
    refit : Refit
        How models are fitted; an accepted per-revolution error's period joins its ``periods``.
    free_names : list of str
        With ``fixed``: the coefficients that move so far.

    Returns
    -------
    Accepted or None
        What was accepted; None when nothing stays significant. The notes of the scores say
        why a candidate was not taken.
    """
    first, allowed = _repeat_order(number, passing, proj, refit.obs, axis_index_of)
    done = _accept_first(current, number, first, passing, proj, refit, free_names)
    if done is None and len(first) < len(allowed):
        done = _accept_first(current, number, allowed, passing, proj, refit, free_names)
    if done is not None:
        twins_of(done.records, passing)
    return done


def _accept_first(current: Machine, number: int, candidates: list, passing: list, proj: Projector, refit: Refit,
                  free_names: list[str]) -> Accepted | None:
    """The first of the best three of ``candidates`` that stays significant in the joint
    refit, accepted (raises come along from ``passing``); None when none does."""
    for best in candidates[:3]:
        batch = [best]
        weak = {}   # id -> (score, size): below SIGNIFICANCE in the last joint refit it took part in
        if best.candidate.kind == Role.RAISE:
            # the other under-modelled components that pass on their own come along, except
            # those a physical effect passing this round would sit on: it gets its round first
            # (a raised EBB would swallow B's once-per-revolution error before it is tried); a
            # named candidate the batch swallows all the same (two raises of C's radial
            # components together take an offset of the A axis it carries) is its rival, and
            # the two readings are weighed after the rounds (_rivals)
            taken = {best.candidate.component}
            held = {s.candidate.component for s in passing if s.candidate.kind == Role.EFFECT}
            for s in passing:
                c = s.candidate
                if c.kind == Role.RAISE and c.component not in taken | held and s.bic_gain > 0:
                    batch.append(s)
                    taken.add(c.component)
        accepted = False
        while True:   # each retry refits a smaller batch: it ends
            new, records = apply_changes(current, batch)
            names = free_names + [n for r in records for n in r.names if n not in free_names]
            new_fit, new_fitted, new_nuisance, res = refit(new, names)
            unheld = _unheld_values(new_fit.model, new_fit.theta)
            if unheld:   # the next change could not be built on it, nor the result written
                for s in batch:
                    s.note = unheld
                break
            tested = [tested_names(r, s.candidate) for r, s in zip(records, batch)]
            sizes = [size_of(res, t) if res is not None and t else math.inf for t in tested]
            for k, (r, s) in enumerate(zip(records, batch)):
                note = (_strayed_note(dict(zip(new_fit.parameter_names, new_fit.theta)), r, s)
                        if effect_kind(r.name).per_revolution else None)
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
                refit.periods.update({n: math.radians(s.candidate.table["period_deg"])
                                      for n in record.names if n.endswith(".period")})
            if np.isfinite(z):
                record.significance = z
        return Accepted(records, new_fit, new_fitted, new_nuisance, res, names)
    return None


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


def _repeat_order(number: int, passing: list, proj: Projector, obs: Observations,
                  axis_index_of: dict[str, int]) -> tuple[list, list]:
    """The passing candidates a round may accept first, and those it may accept when none of
    the first is: without the per-revolution errors that do not repeat from one turn to the
    next (:func:`~volerr_pin.fit.diagnosis._scoring.not_repeating`, whose reason becomes the
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


def _unheld_values(model: Model, theta: np.ndarray) -> str | None:
    """Why a refit is not accepted when a spec could not hold its values (None when it can)."""
    try:
        check_values(model, theta)
    except SpecError as exc:
        return f"not accepted: the joint refit's values are beyond what a spec holds ({exc})"
    return None


def _strayed_note(values: dict[str, float], record: Change, scored) -> str | None:
    """Why a per-revolution error is not accepted when the joint refit (its ``values`` by name)
    took its period out of its window (None when it did not)."""
    period_deg = scored.candidate.table["period_deg"]
    for name in record.names:
        if name.endswith(".period") and not within_window(values[name], math.radians(period_deg)):
            value = math.degrees(float(values[name]))
            return (f"not accepted: in the joint refit its period went to {value:.4g} deg, outside "
                    f"{1 / PERIOD_WINDOW:.3g} to {PERIOD_WINDOW:g} times {period_deg:g} deg: it no longer "
                    "repeats as this error does")
    return None
