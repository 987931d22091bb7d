"""Plan a measurement campaign: choose the units, say what they will and will not
determine, and compare with a grid and random units of the same count.

:func:`plan` builds the weighted design of a pool of candidate units (scrambled Sobol'
points of the zone, those out of an instrument's sight left out), finds what no selection
from the pool can separate (the identifiability groups of the whole pool: the coefficients no
plan with this instrument, these targets and this zone can tell apart, with the reason),
chooses ``budget`` units by D-optimality over the rest (:func:`~volerr_pin.studies.plan._design.d_optimal`),
orders them into a short path, and predicts the standard uncertainty of every coefficient
and of the volumetric error over the zone at the instrument's noise
(:mod:`~volerr_pin.studies.plan`). With ``compare``, a grid and random units of the same
count are assessed the same way, predicted and simulated.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...base import UM_PER_M, InputError, axis_scales, integer, measurement_sigma, positive, require_memory, sensible
from ...fit.identify import parameter_units
from ...model import check_covariates, sensitivity, tool_poses, volumetric_error
from ._assess import predicted, rigid_basis, simulated, without_rigid, zone_summary
from ._design import UnitDesign, d_optimal, unit_design
from ._poses import pose_candidates
from ._protocol import Setup

__all__ = ["MOST_REPEATS", "Plan", "free_coefficients", "make_setup", "plan", "visiting_order"]


def make_setup(machine, instrument, *, zone=None, sigma_um: float | None = None, targets=None, station=None,
               acceptance_deg: float = 30.0) -> Setup:
    """A checked :class:`~volerr_pin.studies.plan.Setup`.

    Parameters
    ----------
    machine : Machine
        The machine.
    instrument : Instrument
        The instrument (its stated noise is the default).
    zone : array_like, shape (n_axes, 2), optional
        Lower and upper NC position of each axis [m, rad], inside the travel (default: the
        travel; a rotary axis that turns further than once: one turn, -pi to pi).
    sigma_um : float, optional
        Standard uncertainty of one observed value [um] (default: the instrument's).
    targets : array_like, shape (k, 3), optional
        Target offsets from the tool point in the tool frame [m] (default one at the tool point).
    station : array_like, shape (3,), optional
        Tracker position in the workpiece frame [m].
    acceptance_deg : float, default 30.0
        Half-angle of a reflector's acceptance cone [deg].

    Returns
    -------
    Setup
        The set-up (SI).

    Raises
    ------
    InputError
        If the zone is not (n_axes, 2) of finite increasing ranges inside the travel, a noise
        or the acceptance angle is not positive (the angle below 90 deg), the targets are not
        (k, 3) finite, or the station is not 3 finite numbers.
    """
    travel = np.array(machine.travel, dtype=float)
    travel = np.where(np.isfinite(travel), travel, np.array([-np.pi, np.pi]))
    if zone is None:   # a rotary axis that turns further than once: one turn, -pi to pi, holds every pose
        turns = np.array([k == "rotary" for k in machine.axis_kinds]) & (travel[:, 1] - travel[:, 0] > 2 * np.pi)
        zone = np.where(turns[:, None], np.array([-np.pi, np.pi]), travel)
    zone = np.asarray(zone, dtype=float)
    if zone.shape != (len(machine.axes), 2) or not np.all(np.isfinite(zone)) or np.any(zone[:, 1] < zone[:, 0]):
        raise InputError(f"zone must give a lower and upper position (lower <= upper) for each of the "
                         f"{len(machine.axes)} axes", parameters=("zone",))
    outside = np.flatnonzero((zone[:, 0] < travel[:, 0] - 1e-12) | (zone[:, 1] > travel[:, 1] + 1e-12))
    if outside.size:
        raise InputError(f"zone: axis {machine.axes[outside[0]]} leaves its travel", parameters=("zone",))
    sigma = measurement_sigma("sigma_um", instrument.default_sigma_um if sigma_um is None else sigma_um) * 1e-6
    targets = np.zeros((1, 3)) if targets is None else np.asarray(targets, dtype=float).reshape(-1, 3)
    if not len(targets) or not np.all(np.isfinite(targets)):
        raise InputError("targets must be finite (x, y, z) offsets", parameters=("targets",))
    sensible("targets", targets, "position_length", "mm", 1e-3)
    if station is not None:
        station = np.asarray(station, dtype=float)
        if station.shape != (3,) or not np.all(np.isfinite(station)):
            raise InputError("station must be 3 finite coordinates", parameters=("station",))
        sensible("station", station, "position_length", "mm", 1e-3)
    angle = positive("acceptance_deg", acceptance_deg)
    if angle >= 90:
        raise InputError(f"acceptance_deg must be below 90, got {angle}", parameters=("acceptance_deg",))
    return Setup(zone, sigma, targets, station, float(np.radians(angle)))


def size_pool(machine, setup: Setup, count: int, free) -> None:
    """Refuse a pool of ``count`` candidate units whose design would not fit in the free memory,
    before any is drawn: per unit, three rows per target of a sensitivity to every free
    coefficient, the axes and the instrument's own unknowns (a lower bound of what the design
    holds).

    Raises
    ------
    InputError
        Naming ``candidates``.
    """
    rows = 3 * max(1, len(setup.targets))
    require_memory(8 * count * rows * (len(free) + len(machine.axes) + 6), f"a pool of {count:,} candidate units",
                   ("candidates",))


def free_coefficients(machine, terms=None) -> np.ndarray:
    """Indices of the coefficients of ``terms`` (component names; default all).

    Parameters
    ----------
    machine : Machine
        The machine.
    terms : list of str, optional
        Components whose coefficients are to be identified.

    Returns
    -------
    ndarray of int
        Coefficient indices.

    Raises
    ------
    InputError
        If a name is not a component of the machine.
    """
    if terms is None:
        return np.arange(len(machine.parameter_names))
    unknown = [t for t in terms if t not in machine.components]
    if unknown:
        raise InputError(f"terms: {unknown[0]!r} is not a component of {machine.name}", parameters=("terms",))
    wanted = set(terms)
    return np.array([k for k, n in enumerate(machine.parameter_names) if n.split(".")[0] in wanted], dtype=int)


def visiting_order(machine, q: np.ndarray) -> np.ndarray:
    """A short path through the poses: nearest neighbour from the pose nearest the zone's
    lower corner, distances in mm and deg.

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (n, n_axes)
        Poses [m, rad].

    Returns
    -------
    ndarray of int, shape (n,)
        The order.
    """
    x = np.asarray(q) / axis_scales(machine.axis_kinds)
    left = list(range(len(x)))
    order = [left.pop(int(np.argmin(np.linalg.norm(x - x.min(axis=0), axis=1))))]
    while left:
        d = np.linalg.norm(x[left] - x[order[-1]], axis=1)
        order.append(left.pop(int(np.argmin(d))))
    return np.array(order, dtype=int)


@dataclass
class Plan:
    """A planned campaign (:func:`plan`).

    Attributes
    ----------
    machine : Machine
        The machine.
    instrument : Instrument
        The instrument.
    setup : Setup
        Zone, noise, targets, station.
    units : list
        The chosen units, in the order they are measured.
    identifiable : list of str
        Coefficients the candidate pool identifies (the criterion's columns).
    not_separable : list of IdentifiabilityGroup
        What no plan with this instrument separates, with the reasons.
    std : dict of str to float
        Predicted standard uncertainty of every identifiable coefficient [SI].
    zone_um : dict
        ``zone_rms_um`` and ``zone_max_um``: predicted uncertainty of the volumetric error
        over the zone [um]; ``error_rms_um`` and ``error_max_um``: the error the model
        predicts there, which the campaign is meant to resolve [um].
    candidates : int
        Number of candidate units the plan chose from.
    comparison : dict
        By design ("plan", "grid", "random"): predicted and simulated figures (see :meth:`to_dict`).
    notes : list of str
        What the plan cannot do with its budget (coefficients it leaves undetermined).
    """

    machine: object
    instrument: object
    setup: Setup
    units: list
    identifiable: list
    not_separable: list
    std: dict
    zone_um: dict
    candidates: int
    comparison: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)

    def stands_for(self) -> dict[str, list[str]]:
        """The identified coefficients that stand for a combination: each with the coefficients
        of its inseparable group (:attr:`not_separable`) that are held at their priors. Its
        estimate absorbs their errors, so its predicted uncertainty is the combination's, and it
        holds for the coefficient itself only when those sit at their priors.

        Returns
        -------
        dict of str to list of str
            Identified coefficient -> the held coefficients it stands for with.
        """
        identified = set(self.identifiable)
        machine_names = set(self.machine.parameter_names)
        out: dict[str, list[str]] = {}
        for group in self.not_separable:
            if group.kind == "zero":
                continue
            held = [n for n in group.parameters if n in machine_names and n not in identified]
            for name in group.parameters:
                if name in identified and held:
                    out.setdefault(name, [])
                    out[name] += [h for h in held if h not in out[name]]
        return out

    def to_dict(self) -> dict:
        """The JSON report (docs/reports.md, ``volerr plan``).

        Returns
        -------
        dict
            ``machine``, ``instrument``, ``budget``, ``poses`` (axis positions in mm / deg of
            every stop, in order),
            ``predicted``, ``not_separable``, ``comparison``, ``candidates``, ``sigma_um``, ``notes``.
        """
        units = parameter_units(self.machine)
        scale = axis_scales(self.machine.axis_kinds)
        visits = self.instrument.visits(self.machine, self.units)
        coefficients = {}
        stands_for = self.stands_for()
        for name, value in self.std.items():
            factor, unit = units.get(name, (1.0, "SI"))
            coefficients[name] = {"std": value / factor, "unit": unit}
            if name in stands_for:
                coefficients[name]["stands_for"] = stands_for[name]
        return {
            "machine": self.machine.name, "instrument": self.instrument.name, "budget": len(self.units),
            "unit": self.instrument.unit, "sigma_um": self.setup.sigma * UM_PER_M, "candidates": self.candidates,
            "poses": [dict(zip(self.machine.axes, (float(v) for v in row / scale))) for row in visits],
            "predicted": {**self.zone_um, "n_identifiable": len(self.identifiable), "coefficients": coefficients},
            "not_separable": [g.to_dict() for g in self.not_separable],
            "comparison": self.comparison, "notes": list(self.notes),
        }


#: random designs drawn to compare a plan with: the median one is simulated, the spread reported
RANDOM_SETS = 21
#: a plan resolves the error it is meant to when its predicted uncertainty over the zone is at most
#: this share of the error there (three standard uncertainties, the significance the fits ask for)
RESOLVES = 1.0 / 3.0
#: the most simulated campaigns per design: the RMS of R campaigns is known to about
#: 1 / sqrt(2 R) of itself, 0.7 % at this many; more only takes longer
MOST_REPEATS = 10_000


def _weak(u: float | None, e: float, what: str = "") -> str | None:
    """Why a plan cannot resolve the error it is meant to (None when it can): its predicted
    uncertainty ``u`` against the error ``e`` (RMS over the zone [um]) of the map ``what`` says."""
    if u is None or e <= 0 or u <= RESOLVES * e:
        return None
    return (f"weak plan: its predicted uncertainty over the zone (RMS {u:.3g} um) is {u / e:.0%} of the error the "
            f"model predicts there{what} (RMS {e:.3g} um); a plan resolves it at a third of it or less (three "
            "standard uncertainties): raise the budget, or use an instrument with less noise")


def plan(machine, instrument, budget: int, setup: Setup | None = None, *, terms=None, candidates: int = 1024,
         seed: int = 0, compare: bool = False, repeats: int = 5, zone_points: int = 512, criterion: str = "D") -> Plan:
    """Plan ``budget`` units of measurement with ``instrument`` (see the module docstring).

    Parameters
    ----------
    machine : Machine
        The machine; its coefficients are the truth of the simulations.
    instrument : Instrument
        The instrument (:func:`volerr_pin.studies.plan.instrument`).
    budget : int
        Number of units (poses) to measure (>= 1).
    setup : Setup, optional
        Zone, noise, targets, station (default :func:`make_setup` of the instrument).
    terms : list of str, optional
        Components to identify (default all); the others are held as given.
    candidates : int, default 1024
        Candidate units the plan chooses from (scrambled Sobol' points of the zone).
    seed : int, default 0
        Seed of the candidates, the random comparison and the simulations' noise.
    compare : bool, default False
        Also assess a grid and random units of the same count, predicted and simulated.
    repeats : int, default 5
        Simulated campaigns per design when comparing (at most :data:`MOST_REPEATS`).
    zone_points : int, default 512
        Points of the zone the volumetric error's uncertainty is summarised over.
    criterion : str, default "D"
        "D": D-optimal (log det of the information over the identifiable coefficients);
        "I": I-optimal (the mean predicted variance of the volumetric error over the zone's
        points).

    Returns
    -------
    Plan
        The plan, its predictions and, with ``compare``, the comparison.

    Raises
    ------
    InputError
        If ``budget``, ``candidates``, ``repeats`` or ``zone_points`` is not a whole number
        >= 1 (``seed`` >= 0), ``repeats`` is above :data:`MOST_REPEATS`, ``criterion`` is not "D" or "I", ``budget`` exceeds the candidates (or those left in sight), ``terms`` names an unknown
        component, or no candidate is left in the zone and in sight.
    """
    budget = integer("budget", budget, 1)
    if criterion not in ("D", "I"):
        raise InputError(f"criterion must be 'D' or 'I', got {criterion!r}", parameters=("criterion",))
    candidates = integer("candidates", candidates, 1)
    seed = integer("seed", seed, 0)
    repeats = integer("repeats", repeats, 1)
    if repeats > MOST_REPEATS:
        raise InputError(f"repeats {repeats:,} is above {MOST_REPEATS:,}: the RMS of that many simulated campaigns "
                         f"is known to {100 / np.sqrt(2 * MOST_REPEATS):.1f} % of itself already",
                         parameters=("repeats",))
    zone_points = integer("zone_points", zone_points, 1)
    if budget > candidates:
        raise InputError(f"budget {budget} exceeds the {candidates} candidates to choose from",
                         parameters=("budget", "candidates"))
    setup = setup or make_setup(machine, instrument)
    free = free_coefficients(machine, terms)
    size_pool(machine, setup, candidates, free)
    pool = instrument.candidates(machine, setup, candidates, "sobol", seed)
    design = unit_design(machine, instrument, setup, pool, free)
    analysis = design.analyse()
    columns = np.array(analysis.kept, dtype=int)
    zone_q = pose_candidates(setup.zone, machine.axis_kinds, zone_points, "sobol", seed + 1)   # within the travel
    model, coefficients = machine.model, machine.theta
    zone_cov = check_covariates(model, len(zone_q), None, machine.state)
    S_zone = sensitivity(model, zone_q, coefficients, zone_cov, columns=free, first_order=True)[:, :3, :]
    # an instrument that registers itself (a tracker) cannot determine a rigid motion of the whole
    # map: what it determines, and what the plan optimises and compares, is the map less that
    P = rigid_basis(tool_poses(model, zone_q, nominal=True)[1]) if getattr(instrument, "registers", False) else None
    S_fit = S_zone if P is None else without_rigid(S_zone, P)
    weight = None
    if criterion == "I":
        weight = np.zeros((len(zone_q), 3, len(columns)))
        theta = columns >= design.n_global
        weight[:, :, theta] = S_fit[:, :, columns[theta] - design.n_global]
    chosen = d_optimal(design, columns, budget, zone=weight)
    mine = predicted(design, chosen, columns, S_zone)
    units = [pool[u] for u in chosen]
    order = visiting_order(machine, np.array([instrument.visits(machine, [u])[0] for u in units]))  # by first stop
    units = [units[i] for i in order]
    theta_cols = columns[columns >= design.n_global]
    names = [design.names[c] for c in theta_cols]
    std = {n: float(s) for n, s in zip(names, mine["std"][columns >= design.n_global])}
    notes = []
    lost = [n for n in mine["lost"] if n in names]
    if lost:
        notes.append(f"{budget} {instrument.unit}s leave {len(lost)} of the {len(names)} coefficients the candidates "
                     f"identify undetermined ({', '.join(lost[:5])}{', ...' if len(lost) > 5 else ''}): raise the "
                     "budget")
    zone_um = zone_summary(mine["zone"])
    e = volumetric_error(model, zone_q, coefficients, zone_cov)[:, :3]
    error = np.linalg.norm(e, axis=1) * UM_PER_M
    zone_um.update(error_rms_um=float(np.sqrt(np.mean(error ** 2))), error_max_um=float(error.max()))
    u, e_rms, what = zone_um["zone_rms_um"], zone_um["error_rms_um"], ""
    if P is not None:
        det = zone_summary(predicted(design, chosen, columns, S_fit)["zone"])
        e_det = np.linalg.norm(without_rigid(e, P), axis=1) * UM_PER_M
        u, e_rms, what = det["zone_rms_um"], float(np.sqrt(np.mean(e_det ** 2))), " less its best rigid fit"
        zone_um.update(determinable_rms_um=u, determinable_max_um=det["zone_max_um"], determinable_error_rms_um=e_rms,
                       rigid_rms_um=(None if u is None or zone_um["zone_rms_um"] is None else
                                     float(np.sqrt(max(0.0, zone_um["zone_rms_um"] ** 2 - u ** 2)))))
    weak = _weak(u, e_rms, what)
    if weak:
        notes.append(weak)
    result = Plan(machine, instrument, setup, units, names, list(analysis.groups), std, zone_um,
                  len(pool), notes=notes)
    if compare:
        result.comparison = _compare(machine, instrument, setup, design, columns, units, budget, free, zone_q,
                                     S_fit, repeats, seed, P)
    return result


def _compare(machine, instrument, setup, design: UnitDesign, columns, units, budget, free, zone_q, S_zone,
             repeats, seed, rigid=None) -> dict:
    """Predicted and simulated figures of the plan, a grid and random units of the same count
    (of the map less its best rigid fit where ``rigid``, the basis of rigid motions, is given)."""
    theta_mask = columns >= design.n_global
    identified = design.free[columns[theta_mask] - design.n_global]

    def assess(chosen):
        own = unit_design(machine, instrument, setup, chosen, design.free)
        own = UnitDesign(own.rows, own.starts, design.names, design.n_global, design.free, design.typical) \
            if own.n_global == design.n_global else own
        if own.n_global != design.n_global:   # fewer shared nuisance columns (cannot happen for one tracker file)
            raise InputError("the comparison designs differ in their nuisance terms")
        return predicted(own, np.arange(own.n_units), columns, S_zone)

    # random units are one draw of many: the plan is compared with the median of RANDOM_SETS draws
    # (ranked by predicted zone uncertainty, a draw that leaves coefficients undetermined last),
    # and the spread of the draws is reported
    draws = [instrument.candidates(machine, setup, budget, "random", seed + 7 + k) for k in range(RANDOM_SETS)]
    assessed = [assess(d) for d in draws]
    zones = [zone_summary(a["zone"])["zone_rms_um"] for a in assessed]
    rank = sorted(range(RANDOM_SETS), key=lambda k: (zones[k] is None, zones[k] or 0.0, k))
    median = rank[RANDOM_SETS // 2]
    determined = np.array([z for z in zones if z is not None])
    grid = instrument.candidates(machine, setup, budget, "grid", seed + 7)
    out = {}
    for label, chosen, p in (("plan", units, assess(units)), ("grid", grid, assess(grid)),
                             ("random", draws[median], assessed[median])):
        lost = [n for n in p["lost"] if n in design.names[design.n_global:]]
        # a coefficient this design does not determine is held at its prior, as identify holds what
        # its data cannot tell (fitting it anyway gives any value: 1.7 mm +- 3.8 mm on a 4-level grid)
        kept = np.array([design.names[design.n_global + i] not in lost for i in columns[theta_mask] - design.n_global])
        s = simulated(machine, instrument, setup, chosen, identified[kept], zone_q, repeats, seed + 100, rigid)
        sim = np.full(len(identified), np.inf)
        sim[kept] = s["std"]
        std_p = p["std"][theta_mask]
        out[label] = {"units": len(chosen), **zone_summary(p["zone"]), "not_identified": lost,
                      "std_geomean": _geomean(std_p), "simulated_zone_rms_um": s["zone_rms"] * UM_PER_M,
                      "simulated_std_geomean": _geomean(sim), "_std": std_p, "_sim": sim}
    for label in ("grid", "random"):
        ref, mine = out[label], out["plan"]
        # a design that does not determine what the plan does is no yardstick of the map: no ratio
        # of map or mean figures (against nothing they read as a thousand-fold win), the reason
        comparable = not ref["not_identified"]

        def ratio(key):
            return _ratio(mine[key], ref[key]) if comparable else None

        out[label]["ratios"] = {
            "predicted_zone_rms": ratio("zone_rms_um"), "simulated_zone_rms": ratio("simulated_zone_rms_um"),
            "predicted_std_geomean": ratio("std_geomean"), "simulated_std_geomean": ratio("simulated_std_geomean"),
            "predicted_lower_share": float(np.mean(mine["_std"] < ref["_std"])),
            "simulated_lower_share": float(np.mean(mine["_sim"] < ref["_sim"])),
        }
        if not comparable:
            out[label]["not_comparable"] = (f"the {label} leaves {len(ref['not_identified'])} of the plan's "
                                            f"{len(identified)} coefficients undetermined")
    for v in out.values():
        v.pop("_std"), v.pop("_sim")
    plan_zone = out["plan"]["zone_rms_um"]
    spread = ({"p10": float(np.quantile(determined, 0.1)), "median": float(np.median(determined)),
               "p90": float(np.quantile(determined, 0.9))} if len(determined) else None)
    out["random"]["sets"] = {
        "count": RANDOM_SETS, "median_seed": seed + 7 + median, "not_determining": int(RANDOM_SETS - len(determined)),
        "predicted_zone_rms_um": spread,
        "plan_over_p10": _ratio(plan_zone, spread["p10"]) if spread else None,
        "plan_over_p90": _ratio(plan_zone, spread["p90"]) if spread else None}
    return out


def _geomean(values: np.ndarray) -> float | None:
    """Geometric mean, None when a value is infinite (a coefficient not identified)."""
    values = np.asarray(values, dtype=float)
    if not values.size or not np.all(np.isfinite(values)) or np.any(values <= 0):
        return None
    return float(np.exp(np.mean(np.log(values))))


def _ratio(a, b) -> float | None:
    """a / b, None when either is undetermined (0 when b is: the reference does not determine it)."""
    if a is None:
        return None
    if b is None:
        return 0.0
    return float(a / b) if b > 0 else None
