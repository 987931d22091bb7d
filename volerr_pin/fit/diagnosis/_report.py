"""What a diagnosis reports beside its changes: the residual against every driver, the noise
floor, effects that are the same at the tool through several sites, the raised components from
the spec's form to the final one, and the evidence of each change for pictures.
"""

from __future__ import annotations

import math

import numpy as np

from ...base import ARCSEC, AXIS_UNIT, UM_PER_M, InputError, axis_scale, integer
from ..identify import Observations
from ...model import Machine
from ._candidates import form_of
from ._projector import Projector
from ._effects import effect_kind
from ._results import (STATED_NOISE_FACTOR, Change, Diagnosis, DriftSeries, Evidence, Raise, Role, Score, Separation,
                      ThermalModel)

__all__ = ["components_per_point", "drift_series", "driver_values", "effect_amplitude", "evidence", "floor_verdict",
           "group_findings", "stated_noise", "noise_floor", "raised_summary", "residual_analysis", "twins_of",
           "undecided_rotary"]


def residual_analysis(machine: Machine, obs: Observations, r_si: np.ndarray) -> dict:
    """Residual structure against positions and covariates: for every driver, the share of
    the residual variance a straight line in it explains (R^2), per error direction; the
    mean reversal step per axis.

    Parameters
    ----------
    machine : Machine
        The machine.
    obs : Observations
        The observations.
    r_si : ndarray, shape (rows,)
        The residual of every row [m or rad].

    Returns
    -------
    dict
        Per error direction ("dx", "dy", "dz"), the six strongest relations: driver ->
        R^2, and ``step_dir_<axis>_um`` -> mean reversal step [um].
    """
    out = {}
    cov = obs.covariates
    drivers = {f"q_{a}": obs.q[:, j] for j, a in enumerate(machine.axes)}
    if "t" in cov:
        drivers["t"] = cov["t"]
    for s, v in (cov.get("temperatures") or {}).items():
        drivers[f"T_{s}"] = v
    if cov.get("forces") is not None:
        for i, c in enumerate("xyz"):
            drivers[f"F{c}"] = cov["forces"][:, i]
    for k, letter in enumerate("xyz"):
        rows = obs.w[:, k] > 0.5
        if rows.sum() < 5:
            continue
        y = r_si[rows]
        entry = {}
        for name, values in drivers.items():
            x = values[obs.point[rows]]
            if np.ptp(x) > 0:
                entry[name] = float(np.corrcoef(x, y)[0, 1] ** 2)
        if cov.get("directions") is not None:
            for j, a in enumerate(machine.axes):
                d = cov["directions"][obs.point[rows], j]
                if len(np.unique(d)) == 2:
                    entry[f"step_dir_{a}_um"] = float((y[d > 0].mean() - y[d < 0].mean()) * UM_PER_M)
        out[f"d{letter}"] = dict(sorted(entry.items(), key=lambda kv: -abs(kv[1]))[:6])
    return out


def noise_floor(obs: Observations, r_si: np.ndarray, n_params: int) -> tuple[float, str, bool]:
    """(floor, source, upper bound?): from repeated observations when there are enough, else
    from the final residual - an upper bound, since whatever the model still misses is in it.

    Observations repeat when they measure the same quantity (direction ``w``) at the same
    positions with the same approach directions and forces - a ballbar's clockwise and
    counter-clockwise passes meet at every angle but differ by the backlash, which is not
    noise. Their scatter is taken from the final residuals, so that instrument offsets of
    different files cancel.

    Parameters
    ----------
    obs : Observations
        The observations.
    r_si : ndarray, shape (rows,)
        The final residual of every row [m or rad].
    n_params : int
        Independent coefficients and nuisance terms of the final model.

    Returns
    -------
    tuple of (float, str, bool)
        The floor [um] (in the measure of the RMS values), where it comes from, and whether it
        is only an upper bound.
    """
    pos = ~obs.angular
    cov = obs.covariates
    extra = [np.asarray(cov[k]) for k in ("directions", "forces") if cov.get(k) is not None]
    rows = np.flatnonzero(pos)
    points = obs.point[rows]
    # one key per row: positions, direction, approach directions and forces, rounded (+ 0.0 makes
    # -0.0 the same key as 0.0)
    key = np.hstack([np.round(obs.q[points], 12), np.round(obs.w[rows], 9),
                     *(np.round(x.reshape(len(x), -1)[points], 9) for x in extra)]) + 0.0
    comps = max(1.0, pos.sum() / max(1, len(np.unique(points))))
    ss, dof = 0.0, 0
    if rows.size:
        _, group = np.unique(key, axis=0, return_inverse=True)
        group = group.ravel()
        count = np.bincount(group)
        r = r_si[rows]
        mean = np.bincount(group, weights=r) / count
        ss = float(((r - mean[group]) ** 2).sum())
        dof = int((count - 1).sum())
    if dof >= 5:
        return (float(np.sqrt(ss / dof * comps) * UM_PER_M), f"repeated points ({dof} degrees of freedom)", False)
    dof = int(pos.sum()) - n_params
    sigma = math.sqrt(float((r_si[pos] ** 2).sum()) / max(dof, 1))
    return (float(sigma * math.sqrt(comps) * UM_PER_M),
            "upper bound from the final residual (n - p degrees of freedom): no repeated points "
            "separate the noise from what the model still misses", True)


def floor_verdict(obs: Observations, r_si: np.ndarray, proj: Projector, noise_stated: bool
                  ) -> tuple[float, str, bool, bool | None, float]:
    """The noise floor and whether the final model reaches it.

    From repeated points the floor is measured, and the model reaches it when its held-out RMS
    is within 1.2 times the floor. Otherwise the floor is only an upper bound from the final
    residual, and that bound cannot say by itself whether the model reaches the noise:
    against a stated noise, it is reached only while the bound is within
    :data:`STATED_NOISE_FACTOR` of it; with no noise stated it is unknown (None). A default
    weighting is not a statement.

    Parameters
    ----------
    obs : Observations
        The observations.
    r_si : ndarray, shape (rows,)
        The final residual of every row [m or rad].
    proj : Projector
        The final model's projector (its rank and held-out RMS).
    noise_stated : bool
        Whether the observations' standard deviations are a stated noise.

    Returns
    -------
    tuple of (float, str, bool, bool or None, float)
        The floor [um], where it comes from, whether it is only an upper bound, whether the
        model reaches it (None: cannot be told), and the stated noise [um] (NaN: none).
    """
    floor, source, bound = noise_floor(obs, r_si, proj.rank)
    stated = stated_noise(obs) if noise_stated else math.nan
    reaches = bool(proj.cv_rms <= 1.2 * floor)
    if bound and floor > STATED_NOISE_FACTOR * stated:
        reaches = False
        source += (f"; it is {floor / stated:.1f} times the noise the observations state ({stated:.3f} um), "
                   "so the model still misses something")
    elif bound and not noise_stated:
        reaches = None
        source += ("; no noise was stated (sigma_um) and no repeated points measure it, so the floor is "
                   "unknown and whether the model reaches it cannot be told")
    return floor, source, bound, reaches, stated


def twins_of(accepted: list[Change], passing: list[Score]) -> None:
    """An accepted effect whose effect at the tool is the same through other sites (a drift
    in x through X, Y or Z of a Cartesian machine) is labelled as such, with ``axis`` None:
    the data cannot tell which site carries it.

    Parameters
    ----------
    accepted : list of Change
        The changes of a round (updated in place).
    passing : list of Score
        The round's passing scores.
    """
    for record in accepted:
        if record.kind != Role.EFFECT:
            continue
        best = next(s for s in passing if s.candidate.label == record.label)
        cand = best.candidate
        twins = [s.candidate for s in passing if s is not best and s.candidate.name == cand.name
                 and s.candidate.kind == Role.EFFECT
                 and s.candidate.driver == cand.driver and s.candidate.direction == cand.direction
                 and abs(s.bic_gain - best.bic_gain) <= 1e-4 * abs(best.bic_gain)]
        if twins:
            by = f" driven by {cand.driver}" if cand.driver else ""
            record.label = (f"{cand.name} in {cand.direction}{by} (as {cand.component}; the same at the tool "
                            f"through {', '.join(t.component for t in twins)})")
            record.axis = None
            record.same_at_tool_as = [t.component for t in twins]


def raised_summary(records: list[Change], base: Machine, final: Machine) -> list[Raise]:
    """One entry per raised component, from the spec's form to the final one (components
    whose raise the final fit did not keep are left out).

    Parameters
    ----------
    records : list of Change
        Every raise accepted, in order.
    base : Machine
        The base model.
    final : Machine
        The final model.

    Returns
    -------
    list of Raise
        The raised components.
    """
    out: dict[str, Raise] = {}
    for r in records:
        entry = out.setdefault(r.component, Raise(
            "", r.name, r.component, r.axis, r.direction, form_of(base, r.component), "", [], r.rms_before_um,
            r.rms_after_um, r.p_value))
        entry.rounds.append(r.step + 1)
        entry.p_value = min(entry.p_value, r.p_value)
    kept = []
    for component, entry in out.items():
        entry.form_after = form_of(final, component)
        if entry.form_after == entry.form_before or entry.form_after == "degree 0":
            continue
        entry.label = f"geometric component {component} under-modelled ({entry.form_before} -> {entry.form_after})"
        kept.append(entry)
    return kept


def driver_values(diagnosis: Diagnosis, driver: str | None) -> tuple[np.ndarray, str] | None:
    """Per-point values of an effect's driver and a label with its unit.

    Parameters
    ----------
    diagnosis : Diagnosis
        The diagnosis.
    driver : str or None
        The driver ("t", "T_spindle", "Fx", "dir_X", "q_X").

    Returns
    -------
    tuple of (ndarray, str) or None
        Values (N,) (time in h, temperatures in degC, forces in N, directions +1/-1,
        positions in mm / deg) and the label; None without a driver.
    """
    obs, machine = diagnosis.observations, diagnosis.machine
    cov = obs.covariates
    if driver is None:
        return None
    if driver == "t":
        return cov["t"] / 3600.0, "time [h]"
    if driver.startswith("T_"):
        return cov["temperatures"][driver[2:]], f"{driver} [degC]"
    if driver.startswith("F"):
        return cov["forces"][:, "xyz".index(driver[1])], f"{driver} [N]"
    if driver.startswith("dir_"):
        j = machine.axes.index(driver[4:])
        return cov["directions"][:, j], f"approach direction of {driver[4:]}"
    if driver.startswith("q_"):
        j = machine.axes.index(driver[2:])
        kind = machine.axis_kinds[j]
        return obs.q[:, j] / axis_scale(kind), f"{driver[2:]} [{AXIS_UNIT[kind]}]"
    return None


def evidence(diagnosis: Diagnosis, step: int) -> Evidence | None:
    """For the change accepted in round ``step`` (a :class:`Change`'s
    ``step``): its driver per point and the residual along the error direction that changed
    most, before and after it was added (um).

    Parameters
    ----------
    diagnosis : Diagnosis
        The diagnosis.
    step : int
        The round.

    Returns
    -------
    Evidence or None
        None when nothing was accepted in that round, or it was the last.

    Raises
    ------
    InputError
        If ``step`` is not the number of a round of the diagnosis.
    """
    step = integer("step", step, 0)
    if step >= len(diagnosis.steps):
        raise InputError(f"step: the diagnosis has rounds 0 to {len(diagnosis.steps) - 1}, not {step}",
                         parameters=("step",))
    record = diagnosis.steps[step].accepted
    if record is None or step + 1 >= len(diagnosis.steps):
        return None
    before = diagnosis.steps[step].residual
    after = diagnosis.steps[step + 1].residual
    found = driver_values(diagnosis, record.driver)
    obs = diagnosis.observations
    best = None
    for j in range(3):
        rows = (obs.w[:, j] > 0.5) & ~obs.angular
        if rows.sum() == 0:
            continue
        drop = float(np.mean(before[rows] ** 2) - np.mean(after[rows] ** 2))
        if best is None or drop > best[0]:
            best = (drop, j, rows)
    if best is None:
        return None
    _, j, rows = best
    points = obs.point[rows]
    x, label = found if found is not None else (np.arange(obs.n_points, dtype=float), "point")
    return Evidence(x[points], label, before[rows] * UM_PER_M, after[rows] * UM_PER_M, "xyz"[j], record.label)


def components_per_point(obs: Observations) -> float:
    """Position components measured per point, on average (3 for dx, dy, dz).

    Parameters
    ----------
    obs : Observations
        The observations.

    Returns
    -------
    float
        Position rows per point with position rows (at least 1).
    """
    pos = ~obs.angular
    return max(1.0, pos.sum() / max(1, len(np.unique(obs.point[pos]))))


def stated_noise(obs: Observations) -> float:
    """The noise the observations state, as the RMS of the norm of a point's position noise:
    the median standard deviation of the position rows times the root of the components per
    point [um].

    Parameters
    ----------
    obs : Observations
        The observations.

    Returns
    -------
    float
        The stated noise [um] (NaN without position rows).
    """
    pos = ~obs.angular
    if not pos.any():
        return math.nan
    return float(np.median(obs.sigma[pos]) * math.sqrt(components_per_point(obs)) * UM_PER_M)


def effect_amplitude(machine: Machine, obs: Observations, names: list[str]) -> float:
    """Half the range of what the coefficients ``names`` add to the position observations,
    in the direction where it is largest [um]: the amplitude of a periodic error, half a
    backlash's reversal, half a drift's excursion over the run.

    Parameters
    ----------
    machine : Machine
        The fitted model.
    obs : Observations
        The observations.
    names : list of str
        The effect's coefficients (non-linear ones - periods, time constants - stay as they are).

    Returns
    -------
    float
        The amplitude [um]; 0 when there are no position rows.
    """
    contribution = _contribution(machine, obs, names)
    best = 0.0
    for k in range(3):
        rows = (obs.w[:, k] > 0.5) & ~obs.angular
        if rows.any():
            best = max(best, 0.5 * float(np.ptp(contribution[rows])))
    return best * UM_PER_M


def undecided_rotary(passing: list[Score], effects: list[Change], machine: Machine, obs: Observations,
                     number: int) -> list[Change]:
    """Per-revolution errors the data hold but cannot tell from the axis' own geometry.

    A per-revolution candidate of the last round that passed the F-test and the held-out test
    but was refused - it does not repeat from one turn to the next, its period strays in its
    joint refit, or its size there falls below significance - is content at that order which
    the axis' smooth geometry over the measured turns can hold as well. It is listed as
    possible, with why, and with the measurement that would separate the two: the axis alone
    over its travel, the other axes held at mid travel (so their geometry does not cloud the
    repeat), as :func:`volerr_pin.studies.plan.plan` plans it (``details["separate_by"]``: its
    ``instrument``, ``budget``, ``zone`` - the held axes in mm / deg - and ``terms``), or more
    turns.

    Parameters
    ----------
    passing : list of Score
        The last round's candidates that passed the F-test and the held-out test (their notes
        say why they were refused).
    effects : list of Change
        The effects found (a per-revolution error found is not undecided).
    machine : Machine
        The final model.
    obs : Observations
        The observations.
    number : int
        The last round (from 0).

    Returns
    -------
    list of Change
        One per undecided error, its ``note`` starting "possible: cannot be told from".
    """
    found = {e.label for e in effects}
    out = []
    for s in passing:
        c = s.candidate
        if c is None or not effect_kind(c.name).per_revolution or not s.note or c.label in found:
            continue
        j = machine.axes.index(c.axis)
        turns = float(np.ptp(obs.q[:, j])) / (2 * np.pi)
        held = {a: float(v / axis_scale(k)) for a, k, v in zip(machine.axes, machine.axis_kinds, machine.mid_travel)
                if a != c.axis}
        plan = {"instrument": "tracker", "budget": max(24, math.ceil(turns * 24)), "zone": held,
                "terms": [c.component]}
        at = ", ".join(f"{a} {v:g} {AXIS_UNIT[k]}" for (a, v), k in zip(held.items(), (
            machine.axis_kinds[machine.axes.index(a)] for a in held)))
        why = s.note.split(": ", 1)[1] if s.note.startswith("not accepted") else s.note
        note = (f"possible: cannot be told from {c.axis}'s geometry with these data ({why}); to tell them apart, "
                f"measure {c.axis} alone over its travel with the other axes held at {at} (a {plan['instrument']} "
                f"plan of {plan['budget']} poses for {c.component}: separate_by), or over more turns than the "
                f"{turns:.3g} it was measured over, and diagnose again with both files")
        amplitude = None
        if s.coefficients is not None and s.term is not None:
            local = list(s.term.term.local_names)
            amplitude = float(np.hypot(*(s.coefficients[local.index(k)] for k in ("s1", "c1")))) / ARCSEC
        out.append(Change(Role.EFFECT, c.label, c.name, c.component, c.axis, c.direction, c.driver, s.p_value,
                          s.bic_gain, step=number, note=note, details=Separation(amplitude, plan)))
    return out


def group_findings(effects: list[Change]) -> list[tuple[Change, list[Change]]]:
    """The physical findings among the accepted effects: thermal drifts in one direction
    (through time and any temperature sensors, accepted round by round) are one finding, a
    multi-sensor linear model; every other effect is a finding of its own.

    Parameters
    ----------
    effects : list of Change
        The accepted effects, in order.

    Returns
    -------
    list of tuple of (Change, list of Change)
        Each finding and the accepted effects it groups (itself for a single one), in the
        order of their first round.
    """
    out: list[tuple[Change, list[Change]]] = []
    over_time: dict[tuple, list[Change]] = {}
    for e in effects:
        if effect_kind(e.name).over_time and e.kind == Role.EFFECT:
            key = (e.name, e.direction)
            if key not in over_time:
                over_time[key] = []
                out.append((None, over_time[key]))  # placeholder, filled below
            over_time[key].append(e)
        else:
            out.append((e, [e]))
    result = []
    for finding, members in out:
        if finding is None:
            finding = members[0] if len(members) == 1 else _grouped(members)
        result.append((finding, members))
    return result


def _grouped(members: list[Change]) -> Change:
    """One thermal drift from several accepted drift terms."""
    first = members[0]
    sensors = [m.driver[2:] for m in members if m.driver and m.driver.startswith("T_")]
    timed = any(m.driver == "t" for m in members)
    what = f"sensors {{{', '.join(sensors)}}}" if sensors else ""
    what += (" and time" if sensors else "time") if timed else ""
    sites = sorted({m.component for m in members})
    axes = {m.axis for m in members}
    label = (f"{first.name} in {first.direction} from {what} (a multi-sensor linear model; as "
             f"{', '.join(sites)})")
    params: dict = {}
    for m in members:
        params.update(m.parameters)
    same = sorted({c for m in members for c in m.same_at_tool_as})
    significance = [m.significance for m in members if m.significance is not None]
    return Change(Role.EFFECT, label, first.name, first.component, axes.pop() if len(axes) == 1 else None,
                  first.direction, first.driver, min(m.p_value for m in members),
                  sum(m.bic_gain for m in members), same, first.step, [n for m in members for n in m.names],
                  rms_before_um=first.rms_before_um, max_before_um=first.max_before_um,
                  rms_after_um=members[-1].rms_after_um, max_after_um=members[-1].max_after_um,
                  significance=max(significance) if significance else None, parameters=params,
                  amplitude_um=first.amplitude_um, gain_um=first.gain_um,
                  members=[m.label for m in members])


def _contribution(machine: Machine, obs: Observations, names: list[str]) -> np.ndarray:
    """What the linear coefficients ``names`` add to every observation row [m or rad]."""
    from ..identify import FitPoints, predict_observations

    nonlinear = set(machine.nonlinear_parameters)
    theta0 = machine.theta.copy()
    for name in names:
        k = machine.parameter_names.index(name)
        if k not in nonlinear:
            theta0[k] = 0.0
    none = np.array([], dtype=int)
    points = FitPoints.of(machine.model, obs, machine.state)
    return predict_observations(points, machine.theta, none)[0] - predict_observations(points, theta0, none)[0]


def drift_series(diagnosis: Diagnosis) -> list[DriftSeries]:
    """Every thermal drift found, over the run: measured against the model, per driver.

    Parameters
    ----------
    diagnosis : Diagnosis
        The diagnosis (with its final ``residual``).

    Returns
    -------
    list of DriftSeries
        One per thermal drift finding (none without time or a residual).
    """
    obs, machine = diagnosis.observations, diagnosis.machine
    cov = obs.covariates
    if diagnosis.residual is None or "t" not in cov:
        return []
    out = []
    for e in diagnosis.effects:
        if not effect_kind(e.name).over_time or e.direction not in ("x", "y", "z"):
            continue
        k = "xyz".index(e.direction)
        rows = (obs.w[:, k] > 0.5) & ~obs.angular
        points = obs.point[rows]
        order = np.argsort(cov["t"][points], kind="stable")
        rows_idx = np.flatnonzero(rows)[order]
        points = points[order]
        names = [n for n in e.names if n in machine.parameter_names]
        model = _contribution(machine, obs, names)[rows_idx]
        shares = {}
        for name in names:
            driver = name.split(".")[-1]
            key = f"T_{driver[2:]}" if driver.startswith("k_") else "t"
            shares[key] = shares.get(key, 0.0) + _contribution(machine, obs, [name])[rows_idx] * UM_PER_M
        model_of = e.details if isinstance(e.details, ThermalModel) else None
        temps = {s: np.asarray(cov["temperatures"][s])[points] for s in (model_of.sensors if model_of else [])
                 if s in (cov.get("temperatures") or {})}
        check = (model_of.time_check if model_of else None) or {}
        out.append(DriftSeries(e.label, e.direction, cov["t"][points] / 3600.0,
                               (diagnosis.residual[rows_idx] + model) * UM_PER_M, model * UM_PER_M, shares, temps,
                               check.get("fit_until_h")))
    return out
