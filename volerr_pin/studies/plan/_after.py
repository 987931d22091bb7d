"""After a diagnosis: the few extra measurements that settle what it could not tell apart.

A diagnosis report (:meth:`volerr_pin.fit.diagnosis.Diagnosis.to_dict`, the JSON ``volerr diagnose``
prints) names, for each effect it found, the components it cannot tell
apart from it at the tool (``same_at_tool_as``), and lists the components it raised
(``under_modelled``). :func:`after_diagnosis` takes the coefficients of those components
(the model given must hold them: the spec diagnose wrote), asks which of them the
instrument (with its targets, in the zone) can separate at all - what no measurement with it
can separate is said with the reason, as in :func:`~volerr_pin.studies.plan.plan` - and chooses
``budget`` units D-optimal for the separable ones, the other coefficients held as known.

It then shows by simulation that they do: the machine's coefficients of those components
are set to a known truth (each one to about ten of its own predicted standard uncertainties,
random signs, fixed seed), the chosen units are simulated with the instrument's noise and
identified with :func:`volerr_pin.fit.identify.identify` (those components free): a coefficient
is separated when identify keeps it (no identifiability group names it) and recovers it
within three predicted standard uncertainties.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ...base import InputError, integer
from ...fit.identify import check_report_machine, identify, parameter_units
from ...model import check_covariates, volumetric_error
from ._assess import predicted
from ._campaign import size_pool
from ._design import d_optimal, unit_design

__all__ = ["AfterPlan", "after_diagnosis", "components_to_settle"]


def components_to_settle(report: dict, source: str = "diagnosis") -> list[tuple[str, ...]]:
    """The groups of components a diagnosis report leaves open: each effect (or raised
    component) with the components it is the same as at the tool, and each raised component.

    Parameters
    ----------
    report : dict
        The diagnosis report (the JSON object ``volerr diagnose`` prints).
    source : str
        Its file, for messages.

    Returns
    -------
    list of tuple of str
        Component groups, in the report's order (a raised component alone is a group of one).

    Raises
    ------
    InputError
        If the report is not a diagnosis (no ``effects`` list) or an entry lacks its component.
    """
    if not isinstance(report, dict) or not isinstance(report.get("effects"), list):
        raise InputError(f"{source}: not a diagnosis report (no 'effects' list): give the JSON that "
                         "volerr diagnose prints as JSON", parameters=("after",))
    groups: list[tuple[str, ...]] = []
    for key in ("effects", "under_modelled"):
        for i, item in enumerate(report.get(key) or []):
            if not isinstance(item, dict) or not isinstance(item.get("component"), str):
                raise InputError(f"{source}: {key}[{i}] has no 'component'", parameters=("after",))
            twins = [c for c in item.get("same_at_tool_as") or [] if isinstance(c, str)]
            if twins or key == "under_modelled":
                group = tuple(dict.fromkeys([item["component"], *twins]))
                if group not in groups:
                    groups.append(group)
    return groups


@dataclass
class AfterPlan:
    """Extra measurements after a diagnosis (:func:`after_diagnosis`).

    Attributes
    ----------
    groups : list of tuple of str
        The component groups the diagnosis left open.
    units : list
        The chosen units (empty when nothing is separable).
    not_separable : list of IdentifiabilityGroup
        Coefficients of those components that no measurement with this instrument separates.
    simulation : dict
        Coefficient -> ``truth``, ``identified``, ``std`` (predicted), ``unit``, ``separated``.
    separated : bool
        Whether every separable coefficient was separated in the simulation.
    """

    groups: list
    units: list
    not_separable: list
    simulation: dict
    separated: bool

    def to_dict(self) -> dict:
        """The ``after`` section of the JSON report (docs/reports.md).

        Returns
        -------
        dict
            ``groups``, ``extra`` (number of units), ``not_separable``, ``simulation``, ``separated``.
        """
        return {"groups": [list(g) for g in self.groups], "extra": len(self.units),
                "not_separable": [g.to_dict() for g in self.not_separable], "simulation": self.simulation,
                "separated": self.separated}


def after_diagnosis(machine, instrument, setup, report: dict, budget: int, *, candidates: int = 1024, seed: int = 0,
                    source: str = "diagnosis") -> AfterPlan:
    """Choose ``budget`` extra units that separate what a diagnosis left open (module docstring).

    Parameters
    ----------
    machine : Machine
        The diagnosed model (holding the components the report names).
    instrument : Instrument
        The instrument.
    setup : Setup
        Zone, noise, targets, station.
    report : dict
        The diagnosis report (the JSON ``volerr diagnose`` prints).
    budget : int
        Number of extra units (>= 1).
    candidates : int, default 1024
        Candidate units chosen from.
    seed : int, default 0
        Seed of the candidates, the simulated truth and its noise.
    source : str
        The report's file, for messages.

    Returns
    -------
    AfterPlan
        The units, what stays inseparable, and the simulation.

    Raises
    ------
    InputError
        If the report is not a diagnosis, is of another machine, names a component the model
        lacks, or ``budget`` exceeds the candidates.
    """
    budget = integer("budget", budget, 1)
    groups = components_to_settle(report, source)
    check_report_machine(report, machine, source, "diagnosis")
    wanted = [c for g in groups for c in g]
    missing = [c for c in dict.fromkeys(wanted) if c not in machine.components]
    if missing:
        raise InputError(f"{source} names {', '.join(missing)}, not components of {machine.name}'s model: plan with "
                         "the spec diagnose wrote", parameters=("after",))
    if not groups:
        return AfterPlan([], [], [], {}, True)
    names = set(wanted)
    free = np.array([k for k, n in enumerate(machine.parameter_names) if n.split(".")[0] in names], dtype=int)
    candidates = integer("candidates", candidates, 1)
    if budget > candidates:
        raise InputError(f"budget {budget} exceeds the {candidates} candidates to choose from",
                         parameters=("budget", "candidates"))
    size_pool(machine, setup, candidates, free)
    pool = instrument.candidates(machine, setup, candidates, "sobol", seed)
    design = unit_design(machine, instrument, setup, pool, free)
    analysis = design.analyse()
    columns = np.array(analysis.kept, dtype=int)
    chosen = d_optimal(design, columns, budget)
    theta_cols = columns[columns >= design.n_global]
    if not theta_cols.size:
        return AfterPlan(groups, [], list(analysis.groups), {}, False)
    zone = np.zeros((1, 3, len(free)))
    std = predicted(design, chosen, columns, zone)["std"][columns >= design.n_global]
    kept_free = free[theta_cols - design.n_global]
    units = [pool[u] for u in chosen]
    simulation, ok = _simulate(machine, instrument, setup, units, kept_free, std, seed)
    return AfterPlan(groups, units, list(analysis.groups), simulation, ok)


def _simulate(machine, instrument, setup, units, free, std, seed) -> tuple[dict, bool]:
    """Truth about ten predicted uncertainties per coefficient; identify from the simulated units."""
    rng = np.random.default_rng(seed)
    truth = machine.theta.copy()
    truth[free] = np.where(np.isfinite(std), 10.0 * std, 0.0) * rng.choice([-1.0, 1.0], len(free))
    from ...fit.identify import stack_blocks
    from ...fit.identify import rows_of
    from ...measurements import ObservationOptions

    sigma_um = setup.sigma * 1e6
    measurements, _ = instrument.measurements(machine, setup, units)
    obs = stack_blocks([m.observations(machine, ObservationOptions(sigma_um, sigma_um)) for m in measurements], machine)
    # a simulated truth (no spec limit applies) at the positions of the chosen units
    error = volumetric_error(machine.model, obs.q, truth,
                             check_covariates(machine.model, obs.n_points, obs.covariates, machine.state))
    rows, _ = rows_of(obs.w, obs.point, error, np.zeros((obs.n_points, 6, 0)))
    values = rows + rng.normal(0.0, setup.sigma, len(rows))
    data, _ = instrument.measurements(machine, setup, units, values)
    prior_theta = truth.copy()
    prior_theta[free] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(machine.with_theta(prior_theta, limits=False), data, free=free, folds=0, sigma_um=sigma_um,
                       sigma_urad=sigma_um, initialise=False)
    grouped = {n for g in fit.groups for n in g.parameters}
    units_of = parameter_units(machine)
    out, ok = {}, True
    for k, s in zip(free, std):
        name = machine.parameter_names[k]
        factor, unit = units_of.get(name, (1.0, "SI"))
        err = abs(fit.machine.theta[k] - truth[k])
        separated = bool(name not in grouped and np.isfinite(s) and err <= 3.0 * s)
        ok = ok and separated
        out[name] = {"truth": float(truth[k] / factor), "identified": float(fit.machine.theta[k] / factor),
                     "std": float(s / factor),
                     "unit": unit, "separated": separated}
    return out, ok
