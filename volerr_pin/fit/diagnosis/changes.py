"""Changes to the model, as typed edits of its spec (:class:`~volerr_pin.model.MachineSpec`) laid
out on the same Pinocchio model (:meth:`~volerr_pin.model.Machine.with_spec`): an accepted
effect added as a term, under-modelled components raised (starting from their present
function, so the base fit is reproduced exactly), an effect removed again, raises trimmed to
what the final fit finds significant; and the size of a change in standard uncertainties,
which decides whether it stays.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...model import Machine, TermSpec
from .candidates import geometric_term, raised_term
from .effects import effect_kind
from .results import SIGNIFICANCE, Change, Role, Score

__all__ = ["apply_changes", "raise_components", "remove_effect", "size_of", "tested_names", "trim_raises", "with_lag"]


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
    raised together).

    Parameters
    ----------
    machine : Machine
        The present model.
    batch : list of Score
        One effect's score, or the scores of under-modelled components raised together.

    Returns
    -------
    machine : Machine
        The new model.
    changes : list of Change
        What was added, one per score.
    """
    raises = [(s.candidate.component, s.candidate.by) for s in batch if s.candidate.kind == Role.RAISE]
    if raises:
        new = raise_components(machine, raises)
        records = []
        for score in batch:
            cand = score.candidate
            _, tspec = geometric_term(new, cand.component)
            records.append(Change(Role.UNDER_MODELLED, cand.label, cand.name, cand.component, cand.axis, cand.direction,
                                  cand.driver, score.p_value, score.bic_gain, by=cand.by,
                                  form_before=cand.change[0], form_after=cand.change[1],
                                  names=list(tspec.names(cand.component))))
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


def tested_names(machine: Machine, change: Change) -> list[str]:
    """The coefficients whose size decides whether a change stays: a raised polynomial's new
    coefficients, an effect's (or missing component's) own coefficients; none for a
    denser table (its F-test and cross-validation decide).

    Parameters
    ----------
    machine : Machine
        The model with the change.
    change : Change
        The change.

    Returns
    -------
    list of str
        Coefficient names.
    """
    if change.kind != Role.UNDER_MODELLED:
        return change.names
    _, tspec = geometric_term(machine, change.component)
    if tspec.term.kind == "table":
        return []
    return list(tspec.names(change.component)[-change.by:])


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
