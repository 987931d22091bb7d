"""Rival readings: a named candidate and raises of an axis' own components that explain the
same residual.

A round's F-test and BIC compare each candidate with the round's base, one at a time; two of
them may explain the same thing. When the round accepts raises that swallow a named candidate
which also passed (a once-per-revolution error of C soaked up by C's angular polynomial raised
four degrees), or accepts a named effect that a raise passing beside it would swallow, the two
are rivals (:func:`rivals_of`). After the rounds each rivalry is weighed once more
(:func:`weigh_rivals`): both readings refitted on every observation, their BIC compared.
Within :data:`~volerr_pin.fit.diagnosis.EVIDENCE_BIC` the data cannot tell them apart and the
finding is listed as possible, with both readings and where at the tool they differ most; a
named reading better by more than that replaces the raises, and a raise better by more than
that replaces the named effect.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ...base import AXIS_UNIT, UM_PER_M, InputError, axis_scale
from ...model import Machine, check_covariates, volumetric_error
from ..identify import parameter_units
from ._candidates import geometric_term
from ._changes import WEAK, _with_term, absorbed, apply_changes, physical, quiet_identify, raise_components, remove_effect
from ._effects import effect_kind
from ._projector import Projector
from ._results import EVIDENCE_BIC, Alternative, Change, Role, Score

__all__ = ["RIVALS_PER_ROUND", "SWEEP_POINTS", "Rival", "finding_parameters", "rivals_of", "weigh_rivals"]

#: positions of the swept axis where the two readings are compared (the other axes at the
#: lowest, middle and highest of their measured positions)
SWEEP_POINTS = 73
#: named rivals kept per round, best BIC first (each costs a refit after the rounds)
RIVALS_PER_ROUND = 3


@dataclass
class Rival:
    """A named candidate and the raises it competes with.

    Attributes
    ----------
    effect : Score
        The named candidate's score.
    raises : list of Score
        The raises' scores.
    before : Machine or None
        The model of the round, before its change (the loop sets it).
    number : int
        The round (from 0).
    in_model : str
        What the round accepted: ``"raise"`` or ``"named"``.
    record : Change or None
        With ``"named"``: the accepted effect's record.
    """

    effect: Score
    raises: list
    before: Machine | None
    number: int
    in_model: str
    record: Change | None = None


def rivals_of(number: int, ranked: list[Score], passing: list[Score], records: list[Change], proj: Projector,
              limit: float, turns: dict[str, float]) -> list[Rival]:
    """The rivalries a round's accepted change leaves.

    Accepted raises and a named candidate that passed too are rivals when, beside the raises,
    the named candidate fails its F-test (:func:`~volerr_pin.fit.diagnosis._changes.absorbed`;
    the raises that swallow it alone, else all of them; the best :data:`RIVALS_PER_ROUND`
    named candidates), unless the round refused it for what it is (its note: it does not
    repeat from one turn to the next, its period strays, it is a table's interpolation; a
    candidate too small in its joint refit stays a rival). An accepted named effect and a raise
    are rivals when beside the raise the effect fails its F-test - the best such raise among
    those that passed and the raises of the effect's own component, passing or not (a 3-per-
    revolution error accepted over one turn of a table, which its own component raised by four
    degrees follows as well) - unless the effect is a per-revolution error of an axis measured
    over more than one turn: it was accepted because it repeats from one turn to the next,
    which a smooth raise does not. The
    round's linearised BIC gains are no verdict (10.1 apart in a round where the refitted
    readings were 3.0 apart): the readings are weighed refitted after the rounds
    (:func:`weigh_rivals`).

    Parameters
    ----------
    number : int
        The round (from 0).
    ranked : list of Score
        The round's scores, best first.
    passing : list of Score
        The round's passing scores, best first.
    records : list of Change
        What the round accepted.
    proj : Projector
        The round's projector.
    limit : float
        The round's p-value threshold.
    turns : dict of str to float
        Rotary axis -> the turns its data span.

    Returns
    -------
    list of Rival
        Their ``before`` left None: the loop gives them the model of the round (so the machine
        goes through a round's stages once, as the rounds' route test holds).
    """
    labels = {r.label for r in records}
    taken = [s for s in passing if s.label in labels]
    raises = [s for s in taken if s.candidate.kind == Role.RAISE and s.columns is not None]
    out = []
    if raises:
        given = np.hstack([s.columns for s in raises])
        for s in passing:
            if not physical(s) or s.label in labels or not absorbed(proj, given, s, limit):
                continue
            if s.note and WEAK not in s.note:
                continue   # refused for what it is (it does not repeat turn to turn, its period strays ...)
            # the raises that swallow it alone, else the batch (the round's linearised BIC is
            # no verdict: the readings are weighed refitted after the rounds)
            alone = [r for r in raises if absorbed(proj, r.columns, s, limit)]
            out.append(Rival(s, alone or raises, None, number, "raise"))
        return out[:RIVALS_PER_ROUND]
    named = [s for s in taken if physical(s)]
    if len(named) != 1 or named[0].columns is None:
        return out
    effect = named[0]
    if effect_kind(effect.candidate.name).per_revolution and turns.get(effect.candidate.axis, 0.0) > 1 + 1e-9:
        return out   # it repeated from one turn to the next when accepted: a raise does not
    record = next(r for r in records if r.label == effect.label)
    passed = {id(s) for s in passing}
    for s in ranked:
        own = s.candidate is not None and s.candidate.component == effect.candidate.component
        if (s.candidate is not None and s.candidate.kind == Role.RAISE and s.columns is not None
                and (id(s) in passed or own) and absorbed(proj, s.columns, effect, limit)):
            return [Rival(effect, [s], None, number, "named", record)]
    return out


def weigh_rivals(loop, final):
    """Each rivalry of the rounds weighed on the final model: the reading it does not hold
    built from it (the raises' components taken back to their form before the round and the
    named effect added, or the named effect removed and the raise made), refitted on every
    observation, and the two BIC compared.

    Parameters
    ----------
    loop : _Loop
        The diagnosis after its rounds and final fit (its model, findings and raises are
        updated where a reading is replaced).
    final : Identification or None
        The final fit of ``loop.current``.

    Returns
    -------
    final : Identification or None
        The final fit (of the new model when a reading was replaced).
    possible : list of Change
        The findings the data cannot tell from raises, each with ``details`` an
        :class:`~volerr_pin.fit.diagnosis.Alternative` and a ``note`` that starts "possible,
        cannot be told apart".
    dropped : list of Change
        Named effects a raise explains better by more than :data:`EVIDENCE_BIC`.
    changed : bool
        Whether a reading was replaced (the model changed).
    """
    possible, dropped, seen, changed = [], [], set(), False
    for rival in loop.rivals:
        key = (rival.effect.label, tuple(sorted(s.candidate.component for s in rival.raises)))
        if key in seen or final is None:
            continue
        seen.add(key)
        outcome = _weigh(loop, final, rival)
        if outcome is None:
            continue
        kind, change, final = outcome
        changed |= kind != "possible"
        (possible if kind == "possible" else dropped if kind == "dropped" else []).append(change)
    # of the named readings one set of raises explains as well, the best (once and twice per
    # revolution beside a raise of B over two turns): one finding, not a list of every order
    # (the others are named in its note, not dropped without a word)
    groups: dict = {}
    for change in possible:
        groups.setdefault((change.details.in_model, change.details.readings[1]), []).append(change)
    kept = []
    for members in groups.values():
        best = max(members, key=lambda c: c.details.bic_difference)
        others = [c for c in members if c is not best]
        if others:
            best.note += "; " + ", ".join(f"{c.label} (BIC {c.details.bic_difference:+.1f} against the raise)"
                                          for c in others) + " read the data alike too"
        kept.append(best)
    return final, kept, dropped, changed


def _bic(loop, model: Machine, fit) -> float:
    """BIC of a fitted model on every observation (weighted residual, its rank of free
    coefficients and nuisance terms)."""
    proj = loop.holdout(model, fit)[0]
    n = len(proj.r)
    rss = float(proj.r @ proj.r)
    return n * math.log(max(rss, 1e-300) / n) + proj.rank * math.log(n)


def _fitted(loop, model: Machine, names: list[str], periods: dict | None = None):
    """``model`` fitted as the loop fits its models, a per-revolution period held at 360/n deg
    (the loop's and ``periods``: coefficient -> 2 pi / n, for this fit only): (machine, fit), or
    None when the data do not determine it."""
    periods = {**loop.fit.periods, **(periods or {})}
    held = {n for n in model.parameter_names if n in periods or n in loop.fit.held}
    theta = model.theta.copy()
    for n in held:
        if n in periods:
            theta[model.parameter_names.index(n)] = periods[n]
    model = model.with_theta(theta, limits=False)
    if loop.fit.fixed and not names:
        return model, None
    try:
        res = quiet_identify(model, loop.obs, free=loop.fit.free(model, names, held), initialise=False)
    except InputError:
        return None
    return res.machine, res


def _weigh(loop, final, rival: Rival):
    """One rivalry weighed: ("possible" | "dropped" | "replaced", change, final fit) or None
    when the model holds the better reading by more than :data:`EVIDENCE_BIC`, or the
    rivalry no longer applies."""
    effect, cand = rival.effect, rival.effect.candidate
    components = {s.candidate.component for s in rival.raises}
    current = loop.current
    if not components <= set(current.components):
        return None
    if rival.in_model == "raise":
        if effect.label in {e.label for e in loop.effects}:
            return None   # accepted in a later round after all
        spec = current.spec
        for c in sorted(components):
            index, _ = geometric_term(current, c)
            _, old = geometric_term(rival.before, c)
            spec = _with_term(spec, c, index, old)
        try:
            alt, records = apply_changes(current.with_spec(spec), [effect])
        except (InputError, ValueError):
            return None
        record = records[0]
        periods = ({n: math.radians(cand.table["period_deg"]) for n in record.names if n.endswith(".period")}
                   if effect_kind(record.name).per_revolution else {})
        names = loop.free_names + [n for n in record.names if n not in loop.free_names]
        fitted = _fitted(loop, alt, names, periods)
        if fitted is None:
            return None
        named_model, named_fit = fitted
        raise_model, raise_fit = current, final
    else:
        record = rival.record
        if record not in loop.effects:
            return None
        r = rival.raises[0].candidate
        try:
            alt = raise_components(remove_effect(current, record), [(r.component, r.by)])
        except (InputError, ValueError):
            return None
        names = [n for n in loop.free_names if n in set(alt.parameter_names)]
        names += [n for n in alt.parameter_names if n.startswith(r.component + ".") and n not in names]
        fitted = _fitted(loop, alt, names)
        if fitted is None:
            return None
        raise_model, raise_fit = fitted
        named_model, named_fit = current, final
    difference = _bic(loop, raise_model, raise_fit) - _bic(loop, named_model, named_fit)
    raise_labels = " and ".join(s.label for s in rival.raises)
    axis = rival.raises[0].candidate.axis
    where = _separate_at(loop, named_model, raise_model, axis)
    if abs(difference) < EVIDENCE_BIC:
        held = "the raise" if rival.in_model == "raise" else "it"
        details = Alternative([effect.label, raise_labels], "raise" if rival.in_model == "raise" else "named",
                              float(difference), where)
        if rival.in_model == "raise":
            change = Change(Role.EFFECT, effect.label, cand.name, cand.component,
                            cand.axis if cand.axis in current.axes else None, cand.direction, cand.driver,
                            effect.p_value, effect.bic_gain, step=rival.number, names=list(record.names))
            change.parameters = finding_parameters(named_model, named_fit, record.names)
        else:
            change = record
            loop.effects.remove(record)
        raising = "raising " + " and ".join(sorted(components))
        change.note = (f"possible, cannot be told apart from {axis}'s own geometry: it and {raising} explain "
                       f"the data alike (their BIC differ by {abs(difference):.1f} in favour of "
                       f"{'it' if difference > 0 else raising}, under the {EVIDENCE_BIC:g} that would count as "
                       f"evidence) and the model holds {held}; "
                       f"to tell them apart, {where['advice']}")
        change.details = details
        return "possible", change, final
    if difference >= EVIDENCE_BIC and rival.in_model == "raise":
        # the named reading explains the data better than the raises: it replaces them
        record.step = rival.number
        record.p_value, record.bic_gain = effect.p_value, effect.bic_gain
        record.details = Alternative([effect.label, raise_labels], "named", float(difference), where)
        loop.current, loop.free_names = named_model, names
        loop.effects.append(record)
        loop.raised = [x for x in loop.raised if not (x.component in components and x.step >= rival.number)]
        loop.fit.periods.update(periods)
        loop.fit.held |= set(periods)
        return "replaced", record, named_fit
    if difference <= -EVIDENCE_BIC and rival.in_model == "named":
        r = rival.raises[0].candidate
        loop.current, loop.free_names = raise_model, names
        loop.effects.remove(record)
        record.note = (f"accepted in round {record.step + 1}, replaced after the rounds by {rival.raises[0].label}: "
                       f"that explains the data better (BIC {-difference:.1f} lower)")
        loop.raised.append(Change(Role.UNDER_MODELLED, r.label, r.name, r.component, r.axis, r.direction, r.driver,
                                  rival.raises[0].p_value, rival.raises[0].bic_gain, step=rival.number, by=r.by,
                                  form_before=r.change[0], form_after=r.change[1],
                                  names=[n for n in raise_model.parameter_names if n.startswith(r.component + ".")]))
        return "dropped", record, raise_fit
    return None


def finding_parameters(model: Machine, fit, names) -> dict:
    """A finding's coefficients in a fitted model, as the report gives them.

    Parameters
    ----------
    model : Machine
        The fitted model.
    fit : Identification or None
        Its fit (None: no uncertainties).
    names : iterable of str
        The finding's coefficients (those the model lacks are left out).

    Returns
    -------
    dict
        Coefficient -> {"value", "uncertainty" (None where the fit gives none), "unit"}, in
        display units.
    """

    units = parameter_units(model)
    out = {}
    for name in names:
        if name not in model.parameter_names:
            continue
        k = model.parameter_names.index(name)
        factor, unit = units[name]
        u = fit.uncertainty[k] if fit is not None else math.nan
        out[name] = {"value": float(model.theta[k] / factor),
                     "uncertainty": None if not np.isfinite(u) else float(u / factor), "unit": unit}
    return out


def _separate_at(loop, a: Machine, b: Machine, axis: str) -> dict:
    """Where two fitted readings differ most at the tool within the travel: ``axis`` swept
    over its travel (a full turn for an endless rotary axis), every other axis at the lowest,
    middle and highest of its measured positions, the covariates at their medians."""
    obs = loop.obs
    j = a.axes.index(axis)
    travel = a.travel
    lo, hi = travel[j]
    if not (np.isfinite(lo) and np.isfinite(hi)):
        lo, hi = -math.pi, math.pi
    levels = [np.linspace(lo, hi, SWEEP_POINTS) if k == j else
              np.unique(np.percentile(obs.q[:, k], [0, 50, 100])) for k in range(len(a.axes))]
    q = np.array(list(itertools.product(*levels)))
    covariates = {k: np.full(len(q), float(np.median(v))) for k, v in obs.covariates.items()
                  if np.ndim(v) == 1}
    rotary = a.axis_kinds[j] != "linear"
    more = (f"or measure over a turn and a half of {axis}" if rotary and hi - lo >= 3 * math.pi else
            "or measure again in a second set-up (another tool length, or the part moved)")
    try:
        da, db = (volumetric_error(m.model, q, m.theta, check_covariates(m.model, len(q), covariates, m.state))[:, :3]
                  for m in (a, b))
    except (InputError, TypeError, ValueError):
        return {"positions": None, "difference_um": None,
                "advice": f"measure {axis} over its whole travel with the other axes at several positions, {more}"}
    gap = np.linalg.norm(da - db, axis=1)
    k = int(np.argmax(gap))
    positions = {name: round(float(q[k, i] / axis_scale(kind)), 1)
                 for i, (name, kind) in enumerate(zip(a.axes, a.axis_kinds))}
    text = ", ".join(f"{name} {v:g} {AXIS_UNIT[kind]}" for (name, v), kind in zip(positions.items(), a.axis_kinds))
    difference = float(gap[k] * UM_PER_M)
    return {"positions": positions, "difference_um": difference,
            "advice": f"measure at {text}, where the two readings differ by {difference:.2f} um at the tool, {more}"}

