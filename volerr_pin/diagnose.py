"""Find where model and measurements disagree, name the missing effect, add it, repeat.

The loop (:func:`diagnose`):

1. fit the base model to the data (:func:`volerr_pin.identify.identify`; with ``fixed`` the
   spec's values are kept);
2. look at the residuals against positions, time, temperatures, forces and approach
   directions (correlations, reversal steps, a periodogram over each linear axis);
3. build candidates for every axis, direction and sensor they can apply to: the catalogue
   effects - ``thermal_drift`` (time, each temperature), ``thermal_expansion``,
   ``backlash``, ``force_deflection``, ``periodic_pitch`` - the geometric terms the spec
   leaves out (``positioning``, ``straightness``, ``angular``, ``squareness``,
   ``location``), and the base model's own adequacy: every polynomial component one degree
   higher, every table with twice the nodes. Each is fitted jointly with the base model
   (linearised at the base fit, non-linear coefficients by grid search or periodogram);
4. score them: BIC ranks them; the best is accepted only if (a) an F-test of its extra
   parameters is significant at ``alpha`` divided by the number of candidates (Bonferroni;
   a period found by searching a periodogram is further divided by the number of independent
   periods searched), (b) it lowers the k-fold cross-validated RMS, and (c) after the
   joint refit its size is significant: the largest |value| / standard uncertainty of its
   linear coefficients is at least 3 (for a raised degree: the new top coefficient). A
   winning under-modelled component is accepted together with the other components that
   pass on their own (they are checked one by one after the refit);
5. repeat until no candidate passes; refit; drop any effect whose size is no longer
   significant; estimate the noise floor (from repeated points if any, else an upper bound
   from the final residual) and say whether the final model reaches it.

A real machine's geometry is never exactly the spec's. A smooth residual that a higher
degree of an existing component explains as well as an effect does is reported as
"geometric component X under-modelled (degree n -> m)" in :attr:`Diagnosis.under_modelled`,
not as a physical effect. A periodic pitch must have a period in the ball-screw range
(:data:`PITCH_PERIOD_MM`) and at least :data:`MIN_PERIODS` periods inside the measured
travel.

Effects whose effect at the tool is the same wherever they sit (a drift in x through any
axis of a Cartesian machine) are reported with ``axis`` None: the data cannot tell which.
"""

from __future__ import annotations

import math
import time as _time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import stats
from scipy.signal import lombscargle

from .errors import InputError
from .identify import (Observations, conditioning_note, build_observations, check_observations, identify,
                       parameter_units, point_squares, pose_folds, predict_observations, residual_rms)
from .machine import Machine
from .safeio import require_memory
from .spec import build_term, component_name, parse_component_name
from .specio import add_terms, remove_components, replace_terms, term_tables
from .termkinds import GEOMETRIC
from .terms import Context, Covariates
from .units import AXIS_UNIT, UM_PER_M, axis_scale
from .checks import fraction, integer, positive

LETTERS = "XYZABC"
PITCH_PERIOD_MM = (1.0, 50.0)   # ball-screw leads
MIN_PERIODS = 4                 # periods of a pitch error inside the measured travel
SIGNIFICANCE = 3.0              # |value| / standard uncertainty of an accepted effect's size
MAX_DEGREE = 12                 # a polynomial component is not raised beyond this degree
MAX_NODES = 65                  # nor a table beyond this many nodes
PERIODOGRAM_POINTS = 1500       # points a periodogram looks at, at most
RAISE_BY = (1, 2, 4)            # degrees a polynomial may gain in one round


@dataclass
class Candidate:
    """One thing the model could be missing: where it goes and how it reads.

    ``kind`` is "effect" (a catalogue effect), "missing" (a geometric component the spec
    leaves out) or "raise" (an existing component with ``by`` degrees more / twice the nodes;
    ``change`` says from what to what)."""

    name: str                 # catalogue name
    axis: str | None
    direction: str | None     # "x", "y", "z" (rotations: about that axis)
    component: str
    table: dict               # spec term table (zero-valued) for add_terms
    driver: str | None = None  # covariate that drives it ("t", "T_spindle", "Fx", "dir_X", "q_X")
    label: str = ""
    kind: str = "effect"
    change: tuple[str, str] | None = None
    by: int = 1

    def describe(self) -> str:
        if self.kind == "raise":
            return f"geometric component {self.component} under-modelled ({self.change[0]} -> {self.change[1]})"
        where = f" on {self.axis}" if self.axis else ""
        d = f" in {self.direction}" if self.direction else ""
        by = f" driven by {self.driver}" if self.driver else ""
        return f"{self.name}{where}{d}{by} ({self.component})"


@dataclass
class Score:
    """How well one candidate explains the residual of a round.

    Attributes
    ----------
    label : str
        The candidate's label.
    extra : int
        Independent columns it adds to the base model (0: nothing new).
    p_value : float
        F-test p-value, Bonferroni-corrected for periods searched in a periodogram.
    bic_gain : float
        Decrease of the Bayesian information criterion.
    cv_rms_um : float or None
        k-fold cross-validated RMS with the candidate [um]; None where not computed.
    rss_drop : float
        Fraction of the base residual sum of squares it removes.
    candidate, term, coefficients, columns
        The candidate, its term with the fitted coefficients (SI, shape (term.size,)) and its
        design columns (shape (rows, extra)); None when it adds nothing.
    """

    label: str
    extra: int
    p_value: float
    bic_gain: float
    cv_rms_um: float | None
    rss_drop: float
    candidate: Candidate | None = field(default=None, repr=False)
    term: object = field(default=None, repr=False)
    coefficients: np.ndarray | None = field(default=None, repr=False)
    columns: np.ndarray | None = field(default=None, repr=False)

    def summary(self) -> "Score":
        """The score without its term and design columns (what a :class:`Step` keeps: the
        columns are rows x extra numbers for every candidate of every round)."""
        return replace(self, term=None, coefficients=None, columns=None)

    def to_dict(self) -> dict:
        return {"label": self.label, "extra": self.extra, "p_value": self.p_value, "bic_gain": self.bic_gain,
                "cv_rms_um": self.cv_rms_um, "rss_drop": self.rss_drop}


@dataclass
class Change:
    """A change the diagnosis made to the model: an effect (or a missing geometric
    component) added, or an existing component raised.

    Attributes
    ----------
    kind : {"effect", "under_modelled"}
    label, name, component : str
        What was found, the catalogue name and the component error it is modelled as.
    axis, direction, driver : str or None
        Where it sits (None when the same at the tool through several axes), the tool
        direction it moves, and the covariate that drives it.
    p_value, bic_gain : float
        Its score in the round it was accepted in.
    same_at_tool_as : list of str
        Other components it cannot be told apart from at the tool.
    step : int
        The round (from 0) it was accepted in.
    names : list of str
        The coefficients it added (a raised component: all of the component's).
    by : int
        Raises: degrees (or node doublings) gained.
    form_before, form_after : str or None
        Raises: the component's form before and after ("degree 2", "table of 9 nodes").
    rms_before_um, max_before_um, rms_after_um, max_after_um : float or None
        Held-out RMS and largest residual before and after it [um].
    significance : float or None
        Its size in standard uncertainties in the refit.
    parameters : dict
        Effects: coefficient -> {"value", "uncertainty", "unit"} after the final fit.
    note : str
        Dropped effects: why.
    """

    kind: str
    label: str
    name: str
    component: str
    axis: str | None
    direction: str | None
    driver: str | None
    p_value: float
    bic_gain: float
    same_at_tool_as: list[str] = field(default_factory=list)
    step: int = 0
    names: list[str] = field(default_factory=list)
    by: int = 0
    form_before: str | None = None
    form_after: str | None = None
    rms_before_um: float | None = None
    max_before_um: float | None = None
    rms_after_um: float | None = None
    max_after_um: float | None = None
    significance: float | None = None
    parameters: dict = field(default_factory=dict)
    note: str = ""

    def to_dict(self) -> dict:
        out = {"label": self.label, "name": self.name, "component": self.component,
               "same_at_tool_as": list(self.same_at_tool_as), "direction": self.direction, "driver": self.driver,
               "p_value": self.p_value, "bic_gain": self.bic_gain, "kind": self.kind, "axis": self.axis}
        if self.kind == "under_modelled":
            out.update({"from": self.form_before, "to": self.form_after})
        out.update(rms_before_um=self.rms_before_um, max_before_um=self.max_before_um)
        if self.significance is not None:
            out["significance"] = self.significance
        out.update(rms_after_um=self.rms_after_um, max_after_um=self.max_after_um)
        if self.kind == "effect" and not self.note:  # a dropped effect has no final values
            out["parameters"] = self.parameters
        if self.note:
            out["note"] = self.note
        return out


@dataclass
class Raise:
    """An existing geometric component the diagnosis raised, from the spec's form to the
    final one (``form_before`` / ``form_after``, e.g. "degree 2" -> "degree 4"), over the
    ``rounds`` (from 1) it was raised in; held-out RMS before the first raise and after the
    last [um]; the smallest p-value of its raises."""

    label: str
    name: str
    component: str
    axis: str | None
    direction: str | None
    form_before: str
    form_after: str
    rounds: list[int]
    rms_before_um: float | None
    rms_after_um: float | None
    p_value: float

    def to_dict(self) -> dict:
        return {"label": self.label, "name": self.name, "component": self.component, "axis": self.axis,
                "direction": self.direction, "from": self.form_before, "to": self.form_after,
                "rounds": list(self.rounds), "rms_before_um": self.rms_before_um,
                "rms_after_um": self.rms_after_um, "p_value": self.p_value}


@dataclass
class Step:
    """One round: the scores of every candidate, best first, and what was accepted, if
    anything (``accepted`` is the first of ``accepted_all``, which holds more than one when
    several under-modelled components were raised together)."""

    number: int
    rms_holdout_um: float
    candidates: list[Score]
    residual: np.ndarray = field(repr=False)            # (rows,) SI, before this round's change
    machine: Machine | None = field(default=None, repr=False)
    accepted_all: list[Change] = field(default_factory=list)

    @property
    def accepted(self) -> Change | None:
        return self.accepted_all[0] if self.accepted_all else None


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`; :meth:`to_dict` gives the JSON report.

    ``effects`` are the physical effects (and missing geometric components) found, in order;
    ``under_modelled`` the existing components whose degree or table density was raised;
    ``dropped`` effects accepted in a round whose size was no longer significant at the end.
    """

    machine: Machine
    base: Machine
    effects: list[Change]
    steps: list[Step]
    rms_before_um: float
    rms_after_um: float
    rms_fit_um: float
    noise_floor_um: float
    noise_floor_source: str
    reaches_noise_floor: bool
    alpha: float
    seconds: float
    observations: Observations = field(repr=False)
    residual_analysis: dict = field(default_factory=dict)
    under_modelled: list[Raise] = field(default_factory=list)
    dropped: list[Change] = field(default_factory=list)
    noise_floor_upper_bound: bool = False

    def to_dict(self) -> dict:
        return {
            "machine": self.machine.name,
            "rms_before_um": self.rms_before_um,
            "rms_after_um": self.rms_after_um,
            "rms_fit_um": self.rms_fit_um,
            "noise_floor_um": self.noise_floor_um,
            "noise_floor_source": self.noise_floor_source,
            "noise_floor_upper_bound": self.noise_floor_upper_bound,
            "reaches_noise_floor": self.reaches_noise_floor,
            "effects": [e.to_dict() for e in self.effects],
            "under_modelled": [u.to_dict() for u in self.under_modelled],
            "dropped": [e.to_dict() for e in self.dropped],
            "steps": [{"step": s.number, "rms_holdout_um": s.rms_holdout_um,
                       "accepted": [a.label for a in s.accepted_all] or None,
                       "candidates": [c.to_dict() for c in s.candidates[:10]]} for s in self.steps],
            "test": f"F-test at alpha = {self.alpha:g} / number of candidates (Bonferroni; periods "
                    "searched in a periodogram also / number of periods), a lower k-fold "
                    f"cross-validated RMS, and |value| >= {SIGNIFICANCE:g} standard uncertainties "
                    "after the refit; candidates ranked by BIC",
            "residual_analysis": self.residual_analysis,
            "seconds": self.seconds,
        }


# ----------------------------------------------------------------------------- candidates
def axis_directions(machine: Machine) -> dict[str, str]:
    """Axis -> the error direction letter of its own motion (X for an x slide, C for a
    spindle turning about z), read off the nominal axis Jacobian at mid travel."""
    q = machine.mid_travel
    J = machine.axis_jacobian(q[None, :], nominal=True)[0]
    out = {}
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        v = J[:3, j] if kind == "linear" else J[3:, j]
        k = int(np.argmax(np.abs(v)))
        if abs(v[k]) > 0.999 * np.linalg.norm(v):
            out[axis] = ("XYZ" if kind == "linear" else "ABC")[k]
    return out


def _geometric_name(direction: str, owner: str, location: bool, own: str | None, linear: bool) -> str:
    if location:
        return "squareness" if (direction in "ABC" and linear) else "location"
    if direction in "ABC":
        return "angular"
    return "positioning" if direction == own else "straightness"


def build_candidates(machine: Machine, obs: Observations) -> list[Candidate]:
    """Every catalogue effect the data's covariates allow, on every axis and direction."""
    cov = obs.covariates
    own = axis_directions(machine)
    out: list[Candidate] = []
    sites = [a for a in machine.axes] + [b.name for b in machine.spec.bodies]
    has_t = "t" in cov and np.ptp(cov["t"]) > 0
    sensors = [s for s, v in (cov.get("temperatures") or {}).items() if np.ptp(v) > 0]
    forces = cov.get("forces")
    force_axes = [i for i in range(3) if forces is not None and np.ptp(forces[:, i]) > 0]
    directions = cov.get("directions")

    def unit_of(direction):
        return ("um", "length") if direction in "XYZ" else ("arcsec", "angle")

    # position-independent translations: drift and deflection, through every site
    for site in sites:
        for d in "XYZ":
            comp = component_name(d, site)
            if has_t:
                out.append(Candidate("thermal_drift", site, d.lower(), comp,
                                     {"kind": "thermal_drift", "driver": "time", "amplitudes_um": [0.0],
                                      "time_constants_min": [60.0]}, "t"))
            for s in sensors:
                ref = float(np.mean(cov["temperatures"][s]))
                out.append(Candidate("thermal_drift", site, d.lower(), comp,
                                     {"kind": "thermal_drift", "driver": "temperature", "sensors": [s],
                                      "coefficients_um_per_K": [0.0], "reference_degC": ref}, f"T_{s}"))
            for i in force_axes:
                out.append(Candidate("force_deflection", site, d.lower(), comp,
                                     {"kind": "force_deflection", "force": "xyz"[i],
                                      "compliance_um_per_N": [0.0]}, f"F{'xyz'[i]}"))
    # axis-bound effects on the positioning component
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        letter = own.get(axis)
        if letter is None:
            continue
        comp = component_name(letter, axis)
        lo, hi = machine.travel[j]
        if directions is not None and len(np.unique(directions[:, j])) == 2:
            unit = "um" if kind == "linear" else "arcsec"
            out.append(Candidate("backlash", axis, letter.lower(), comp,
                                 {"kind": "backlash", f"reversal_{unit}": 0.0}, f"dir_{axis}"))
        if kind != "linear":
            continue
        for s in sensors:
            ref = float(np.mean(cov["temperatures"][s]))
            out.append(Candidate("thermal_expansion", axis, letter.lower(), comp,
                                 {"kind": "thermal_expansion", "driver": "temperature", "sensor": s,
                                  "coefficient_ppm_per_K": 0.0, "reference_degC": ref,
                                  "origin_mm": float(lo * 1e3)}, f"T_{s}"))
        if has_t:
            out.append(Candidate("thermal_expansion", axis, letter.lower(), comp,
                                 {"kind": "thermal_expansion", "driver": "time", "strains_ppm": [0.0],
                                  "time_constants_min": [60.0], "origin_mm": float(lo * 1e3)}, "t"))
        out.append(Candidate("periodic_pitch", axis, letter.lower(), comp,
                             {"kind": "periodic_pitch", "period_mm": 0.0, "sine_um": [0.0], "cosine_um": [0.0],
                              "origin_mm": float(lo * 1e3)}, f"q_{axis}"))
    # geometric terms the spec leaves out
    present = set(machine.components)
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        for d in LETTERS:
            comp = component_name(d, axis)
            if comp not in present:
                unit, _ = unit_of(d)
                name = _geometric_name(d, axis, False, own.get(axis), kind == "linear")
                # degrees: positioning 5 (interferometer tables bend), straightness 3, angular 2
                coefs = [0.0] * (6 if name == "positioning" else 4 if d in "XYZ" else 3)
                out.append(Candidate(name, axis, d.lower() if d in "XYZ" else "xyz"["ABC".index(d)], comp,
                                     {"kind": "legendre", f"coefficients_{unit}": coefs}, f"q_{axis}",
                                     kind="missing"))
        for d in ("ABC" if kind == "linear" else LETTERS):
            comp = component_name(d, axis, True)
            if comp not in present:
                unit, _ = unit_of(d)
                name = _geometric_name(d, axis, True, own.get(axis), kind == "linear")
                out.append(Candidate(name, axis, d.lower() if d in "XYZ" else "xyz"["ABC".index(d)], comp,
                                     {"kind": "constant", f"value_{unit}": 0.0}, kind="missing"))
    out += adequacy_candidates(machine, own)
    for c in out:
        c.label = c.describe()
    return out


def geometric_term(machine: Machine, component: str):
    """(index, TermSpec) of the component's geometric term (constant, polynomial, table);
    (None, None) when it has none. An unknown component is an :class:`InputError`."""
    comp = next((c for c in machine.spec.components if c.name == component), None)
    if comp is None:
        raise InputError(f"component: {component!r} is not an error term of {machine.name}", parameters=("component",))
    for i, tspec in enumerate(comp.terms):
        if tspec.term.kind in GEOMETRIC:
            return i, tspec
    return None, None


def raised_table(machine: Machine, component: str, values: np.ndarray | None = None, by: int = 1):
    """The component's geometric term richer, as a spec table, and (from, to).

    A constant becomes a Legendre polynomial of degree ``by``, a polynomial gains ``by``
    degrees (two are offered because an odd or even part alone may be what is missing),
    a table gains a node between every two (the coarser function space is inside the finer
    one, so the base fit is reproduced exactly; ``by`` is ignored). With ``values`` (the
    term's coefficients, SI) the table starts from the present function; else it is
    zero-valued. None when the term would pass :data:`MAX_DEGREE` / :data:`MAX_NODES` or
    there is no geometric term."""
    index, tspec = geometric_term(machine, component)
    if tspec is None:
        return None
    term = tspec.term
    zero = np.zeros(term.size) if values is None else np.asarray(values, float)
    table = term.to_spec(zero)
    if term.kind in ("constant", "legendre", "monomial"):
        degree = 0 if term.kind == "constant" else term.degree
        if degree + by > MAX_DEGREE:
            return None
        if term.kind == "constant":
            unit = term.unit
            table = {"kind": "legendre", f"coefficients_{unit}": [table[f"value_{unit}"]] + [0.0] * by}
        else:
            key = f"coefficients_{term.unit}"
            table[key] = list(table[key]) + [0.0] * by
        change = ("constant" if term.kind == "constant" else f"degree {degree}", f"degree {degree + by}")
    elif by != 1:
        return None
    else:
        nodes = term.nodes
        if 2 * len(nodes) - 1 > MAX_NODES:
            return None
        fine = np.sort(np.r_[nodes, 0.5 * (nodes[1:] + nodes[:-1])])
        ctx = Context(fine, None, Covariates(len(fine)))
        table[f"positions_{term.position_unit}"] = [float(x / term.position_scale) for x in fine]
        table[f"values_{term.unit}"] = [float(v / term.unit_scale) for v in term.value(zero, ctx)]
        change = (f"table of {len(nodes)} nodes", f"{len(fine)} nodes")
    if tspec.prefix:
        table["prefix"] = tspec.prefix
    return index, table, change


def adequacy_candidates(machine: Machine, own: dict[str, str]) -> list[Candidate]:
    """Every component error of an axis with its geometric term one step richer."""
    out = []
    for comp in machine.spec.components:
        direction, location, owner = parse_component_name(comp.name)
        if location or owner not in machine.axes:
            continue
        j = machine.axes.index(owner)
        if not np.all(np.isfinite(machine.travel[j])):
            continue  # a polynomial over the travel needs a finite travel
        for by in RAISE_BY:
            raised = raised_table(machine, comp.name, by=by)
            if raised is None:
                continue
            _, table, change = raised
            name = _geometric_name(direction, owner, False, own.get(owner), machine.axis_kinds[j] == "linear")
            out.append(Candidate(name, owner, direction.lower() if direction in "XYZ"
                                 else "xyz"["ABC".index(direction)], comp.name, table, f"q_{owner}",
                                 kind="raise", change=change, by=by))
    return out


def raise_components(machine: Machine, components: list[tuple[str, int]]) -> Machine:
    """The machine with these components' geometric terms raised, each starting from its
    present function (an exact reproduction for tables and polynomials alike)."""
    theta = dict(zip(machine.parameter_names, machine.theta))
    present = term_tables(machine)
    tables = {}
    for component, by in components:
        index, tspec = geometric_term(machine, component)
        values = np.array([theta[n] for n in tspec.names(component)])
        _, table, _ = raised_table(machine, component, values, by)
        tables[component] = present[component]
        tables[component][index] = table
    return replace_terms(machine, tables)


def _remove_effect(machine: Machine, effect: Change) -> Machine:
    """The machine without an accepted effect's terms."""
    component = effect.component
    names = set(effect.names)
    comp = next(c for c in machine.spec.components if c.name == component)
    keep = [i for i, t in enumerate(comp.terms) if not names & set(t.names(component))]
    if not keep:
        return remove_components(machine, [component])
    tables = term_tables(machine)[component]
    return replace_terms(machine, {component: [tables[i] for i in keep]})


# ----------------------------------------------------------------------------- scoring
@dataclass
class _Base:
    machine: Machine
    A: np.ndarray                 # weighted design [nuisance | fitted coefficients]
    r: np.ndarray                 # weighted residual


def _base_design(machine: Machine, obs: Observations, fitted: np.ndarray, nuisance: np.ndarray) -> _Base:
    # residual of the exact model; design of the first-order model (exact dependencies)
    pred, A = predict_observations(machine, obs, machine.theta, fitted, first_order=True)
    r = (obs.y - pred - obs.nuisance @ nuisance) / obs.sigma
    J = np.hstack([obs.nuisance, A]) / obs.sigma[:, None]
    return _Base(machine, J, r)


class _Columns:
    """Weighted columns of a candidate's coefficients, linearised at the base.

    The term's own Jacobian depends only on the positions and covariates, which stay the
    same through the diagnosis: it is computed once per (candidate table, non-linear
    value) and kept."""

    def __init__(self, obs: Observations, cov_obj: Covariates):
        self.obs, self.cov_obj = obs, cov_obj
        self.cache: dict = {}
        self.weights: dict = {}   # (round's E, component) -> weighted row factors

    def term(self, machine: Machine, cand: Candidate):
        direction, location, owner = parse_component_name(cand.component)
        quantity = "length" if direction in "XYZ" else "angle"
        axis_index = machine.axes.index(owner) if owner in machine.axes else None
        travel = tuple(machine.travel[axis_index]) if axis_index is not None else None
        position_quantity = None if (location or axis_index is None) else (
            "length" if machine.axis_kinds[axis_index] == "linear" else "angle")
        tspec = build_term(dict(cand.table), f"candidate {cand.label}", quantity, position_quantity, travel)
        position = None if position_quantity is None else self.obs.q[:, axis_index]
        ctx = Context(position, travel, self.cov_obj, axis_index, cand.component)
        return tspec, ctx

    def __call__(self, machine: Machine, E: np.ndarray, joints: list[str], cand: Candidate,
                 coefs=None, columns=None):
        obs = self.obs
        key = (cand.component, repr(sorted(cand.table.items())),
               None if coefs is None else tuple(np.round(coefs, 15)))
        if key not in self.cache:
            tspec, ctx = self.term(machine, cand)
            c = tspec.coefficients if coefs is None else coefs
            self.cache[key] = (tspec, c, tspec.term.jacobian(c, ctx)[obs.point])
        tspec, c, jac = self.cache[key]
        weight_key = (id(E), cand.component)
        if weight_key not in self.weights:
            if len(self.weights) > 256:
                self.weights.clear()
            col = E[:, :, joints.index(cand.component)]                 # (points, 6)
            self.weights[weight_key] = (np.einsum("rk,rk->r", obs.w, col[obs.point]) / obs.sigma)[:, None]
        jac = jac if columns is None else jac[:, columns]
        return self.weights[weight_key] * jac, tspec, c


def _scaled(A: np.ndarray) -> np.ndarray:
    """A's non-negligible columns scaled to unit norm."""
    if A.shape[1] == 0:
        return A
    norms = np.linalg.norm(A, axis=0)
    ok = norms > 1e-12 * max(norms.max(), 1e-300)
    return A[:, ok] / norms[ok]


def _svd(A: np.ndarray, rtol: float = 1e-10):
    """(U, s, Vt) of A truncated to the singular values above ``rtol`` of the largest."""
    if A.shape[1] == 0:
        return np.zeros((A.shape[0], 0)), np.zeros(0), np.zeros((0, 0))
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    keep = s > rtol * s[0] if s.size and s[0] > 0 else np.zeros(s.size, bool)
    return U[:, keep], s[keep], Vt[keep]


def _small_lstsq(G: np.ndarray, r: np.ndarray, tol: float = 1e-6):
    """Least squares with few columns through the eigen-decomposition of G^T G: (rank with
    singular values above ``tol`` (G's columns have unit norm), coefficients, rss)."""
    w, V = np.linalg.eigh(G.T @ G)
    keep = w > tol**2
    b = V.T @ (G.T @ r)
    gamma = V[:, keep] @ (b[keep] / w[keep])
    res = r - G @ gamma
    return int(keep.sum()), gamma, float(res @ res)


class _Projector:
    """Least squares of a candidate jointly with the base design, by projection.

    The base design ``A`` (weighted rows x base coefficients) and residual ``r`` are fixed for
    a round; orthonormal bases of the design on all rows and on every cross-validation
    training set are computed once, so a candidate costs a few small products."""

    def __init__(self, A: np.ndarray, r: np.ndarray, obs: Observations, folds: list[np.ndarray]):
        self.obs = obs
        self.r = r
        A = _scaled(A)
        self.Q = _svd(A)[0]
        self.rank = self.Q.shape[1]
        self.folds = []
        pos = ~obs.angular
        for test in folds:
            V = np.isin(obs.point, test)
            T = ~V
            Q_T, s, Vt = _svd(A[T])
            # a training fit predicts the validation rows as A[V] pinv(A[T]) r[T] = M Q_T^T r[T]
            M = A[V] @ (Vt.T / s) if s.size else np.zeros((int(V.sum()), 0))
            e_T = r[T] - Q_T @ (Q_T.T @ r[T])
            e_V = r[V] - M @ (Q_T.T @ r[T])
            self.folds.append((T, V, Q_T, M, e_T, e_V, pos[V]))
        self.cv_rms = self._cv(lambda f: np.zeros(f[5].shape))
        self.cv_max = self.last_max

    def _cv(self, correction) -> float:
        sq, count, peak = 0.0, 0, 0.0
        obs = self.obs
        for f in self.folds:
            T, V, Q_T, M, e_T, e_V, pos_V = f
            res = (e_V - correction(f)) * obs.sigma[V]
            per_point = point_squares(obs.point[V][pos_V], res[pos_V])
            sq += per_point.sum()
            count += per_point.size
            peak = max(peak, float(np.sqrt(per_point.max())) if per_point.size else 0.0)
        self.last_max = peak * UM_PER_M
        return float(np.sqrt(sq / count) * UM_PER_M) if count else math.nan

    def fit(self, C: np.ndarray):
        """(extra rank, rss after, candidate coefficients in C's units)."""
        norms = np.linalg.norm(C, axis=0)
        norms[norms == 0] = 1.0
        Cs = C / norms
        G = Cs - self.Q @ (self.Q.T @ Cs)
        extra, gamma, rss = _small_lstsq(G, self.r)
        if extra == 0:
            return 0, float(self.r @ self.r), np.zeros(C.shape[1])
        return extra, rss, gamma / norms

    def cv(self, C: np.ndarray) -> float:
        norms = np.linalg.norm(C, axis=0)
        norms[norms == 0] = 1.0
        Cs = C / norms

        def correction(f):
            T, V, Q_T, M, e_T, e_V, pos_V = f
            B = Q_T.T @ Cs[T]
            G_T = Cs[T] - Q_T @ B
            _, gamma, _ = _small_lstsq(G_T, e_T)
            return (Cs[V] - M @ B) @ gamma

        return self._cv(correction)


def _periodogram_period(machine, obs, r, axis_index, letter):
    """Period of the strongest sinusoid in the residual along an axis' own direction, among
    the plausible ones (:data:`PITCH_PERIOD_MM`, at least :data:`MIN_PERIODS` periods in the
    measured span, at least two points per period on average), and the number of
    independent periods searched (for the look-elsewhere correction). None when no period
    is plausible for these data."""
    rows = obs.w[:, "XYZ".index(letter)] > 0.5
    if rows.sum() < 20:
        return None
    x = obs.q[obs.point[rows], axis_index]
    y = r[rows] * obs.sigma[rows]
    if x.size > PERIODOGRAM_POINTS:  # enough to pick the period; the fit then uses every point
        keep = np.random.default_rng(0).choice(x.size, PERIODOGRAM_POINTS, replace=False)
        x, y = x[keep], y[keep]
    span = float(np.ptp(x))
    if span <= 0:
        return None
    u = 2 * (x - x.min()) / span - 1
    y = y - np.polynomial.legendre.legval(u, np.polynomial.legendre.legfit(u, y, 5))
    shortest = max(PITCH_PERIOD_MM[0] * 1e-3, 2 * span / len(np.unique(x)))
    longest = min(PITCH_PERIOD_MM[1] * 1e-3, span / MIN_PERIODS)
    if shortest >= longest:
        return None
    independent = max(1.0, span * (1 / shortest - 1 / longest))
    # one frequency per independent period, then a finer look around the strongest
    f = np.linspace(1 / longest, 1 / shortest, int(min(2000, independent)) + 2)
    y = y - y.mean()
    k = int(np.argmax(lombscargle(x, y, 2 * np.pi * f)))
    fine = np.linspace(f[max(k - 1, 0)], f[min(k + 1, len(f) - 1)], 17)
    return float(1.0 / fine[int(np.argmax(lombscargle(x, y, 2 * np.pi * fine)))]), independent


def _score(base: _Base, proj: _Projector, obs: Observations, E, joints, cand: Candidate, cov_obj,
           axis_index_of, columns: _Columns):
    """Fit the candidate jointly with the base (linearised) and score it."""
    n = len(base.r)
    searched = 1.0
    if cand.name == "periodic_pitch" and cand.kind == "effect":
        found = _periodogram_period(base.machine, obs, base.r, axis_index_of[cand.axis], cand.component[1])
        if found is None:
            return None
        period, searched = found
        cand.table = dict(cand.table, period_mm=period * 1e3)
    _, tspec, coefs = columns(base.machine, E, joints, cand)
    nonlinear = [tspec.term.local_names.index(k) for k in tspec.term.nonlinear]
    lin = [i for i in range(len(coefs)) if i not in nonlinear]
    full = np.array([np.nan])
    if nonlinear and cand.name != "periodic_pitch":  # periods come from the periodogram
        full = np.asarray(tspec.term.search_grid(tspec.term.local_names[nonlinear[0]], coefs, cov_obj))
    tried: dict = {}

    def trial(k):
        if k not in tried:
            value = full[k]
            c = coefs.copy()
            if not np.isnan(value):
                c[nonlinear[0]] = value
            # columns of the linear coefficients at this value of the non-linear one
            C, _, _ = columns(base.machine, E, joints, cand, None if np.isnan(value) else c, lin)
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
    F = ((rss0 - rss1) / k) / (rss1 / dof) if dof > 0 else 0.0
    p_value = min(1.0, float(stats.f.sf(F, k, dof)) * searched) if dof > 0 else 1.0
    bic_gain = n * math.log(rss0 / rss1) - k * math.log(n) - 2 * math.log(searched)
    values = c.copy()
    values[lin] = gamma
    return Score(cand.label, int(extra), p_value, float(bic_gain), None, (rss0 - rss1) / rss0 if rss0 > 0 else 0.0,
                 cand, tspec, values, C)


def _table_with(tspec, coefs, prefix):
    table = tspec.term.to_spec(coefs)
    table["prefix"] = prefix
    return table


def _unique_prefix(machine: Machine, component: str, stem: str) -> str:
    used = {n.split(".")[1] for n in machine.parameter_names if n.startswith(component + ".")
            and n.count(".") == 2}
    if stem not in used:
        return stem
    k = 2
    while f"{stem}{k}" in used:
        k += 1
    return f"{stem}{k}"


PREFIX = {"thermal_drift": "drift", "thermal_expansion": "expansion", "backlash": "reversal",
          "force_deflection": "load", "periodic_pitch": "pitch"}


def residual_analysis(machine: Machine, obs: Observations, r_si: np.ndarray) -> dict:
    """Residual structure against positions and covariates: for every driver, the share of
    the residual variance a straight line in it explains (R^2), per error direction; the
    mean reversal step per axis; the strongest period along each linear axis."""
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


def _noise_floor(obs: Observations, r_si: np.ndarray, n_params: int) -> tuple[float, str, bool]:
    """(floor, source, upper bound?): from repeated observations when there are enough, else
    from the final residual - an upper bound, since whatever the model still misses is in it.

    Observations repeat when they measure the same quantity (direction ``w``) at the same
    positions with the same approach directions and forces - a ballbar's clockwise and
    counter-clockwise passes meet at every angle but differ by the backlash, which is not
    noise. Their scatter is taken from the final residuals, so that instrument offsets of
    different files cancel."""
    pos = ~obs.angular
    cov = obs.covariates
    extra = [np.asarray(cov[k]) for k in ("directions", "forces") if cov.get(k) is not None]
    groups: dict = {}
    for row in np.flatnonzero(pos):
        i = obs.point[row]
        key = (tuple(np.round(obs.q[i], 12)), tuple(np.round(obs.w[row], 9)),
               *(tuple(np.round(np.atleast_1d(x[i]), 9)) for x in extra))
        groups.setdefault(key, []).append(row)
    comps = max(1.0, pos.sum() / max(1, len(np.unique(obs.point[pos]))))
    ss, dof = 0.0, 0
    for rows in groups.values():
        if len(rows) > 1:
            r = r_si[rows]
            ss += float(((r - r.mean()) ** 2).sum())
            dof += len(rows) - 1
    if dof >= 5:
        return (float(np.sqrt(ss / dof * comps) * UM_PER_M), f"repeated points ({dof} degrees of freedom)", False)
    dof = int(pos.sum()) - n_params
    sigma = math.sqrt(float((r_si[pos] ** 2).sum()) / max(dof, 1))
    return (float(sigma * math.sqrt(comps) * UM_PER_M),
            "upper bound from the final residual (n - p degrees of freedom): no repeated points "
            "separate the noise from what the model still misses", True)


def _size(res, names: list[str]) -> float:
    """Largest |value| / standard uncertainty over the linear coefficients ``names`` of a
    fit; 0 when a non-linear one (time constant, period) is not determined or no linear
    one is."""
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


def _tested_names(machine: Machine, change: Change) -> list[str]:
    """The coefficients whose size decides whether a change stays: a raised polynomial's new
    coefficients, an effect's (or missing component's) own coefficients; none for a
    denser table (its F-test and cross-validation decide)."""
    if change.kind != "under_modelled":
        return change.names
    _, tspec = geometric_term(machine, change.component)
    if tspec.term.kind == "table":
        return []
    return list(tspec.names(change.component)[-change.by:])


def _describe(machine: Machine, component: str) -> str:
    _, tspec = geometric_term(machine, component)
    term = tspec.term
    if term.kind == "table":
        return f"table of {len(term.nodes)} nodes"
    return "constant" if term.kind == "constant" else f"degree {term.degree}"


def _trim_raises(machine: Machine, fit, base: Machine, components) -> Machine | None:
    """Raised polynomials lose their trailing coefficients that the final fit does not find
    significant (a component raised by 4 where 1 was enough); None when nothing changes."""
    if fit is None:
        return None
    tables = {}
    present = None
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
        present = present or term_tables(machine)
        terms = present[component]
        key = f"coefficients_{tspec.term.unit}"
        terms[index] = dict(terms[index], **{key: list(terms[index][key])[:keep + 1]})
        tables[component] = terms
    return replace_terms(machine, tables) if tables else None


def _raised_summary(records: list[Change], base: Machine, final: Machine) -> list[Raise]:
    """One entry per raised component, from the spec's form to the final one (components
    whose raise the final fit did not keep are left out)."""
    out: dict[str, Raise] = {}
    for r in records:
        entry = out.setdefault(r.component, Raise(
            "", r.name, r.component, r.axis, r.direction, _describe(base, r.component), "", [], r.rms_before_um,
            r.rms_after_um, r.p_value))
        entry.rounds.append(r.step + 1)
        entry.p_value = min(entry.p_value, r.p_value)
    kept = []
    for component, entry in out.items():
        entry.form_after = _describe(final, component)
        if entry.form_after == entry.form_before or entry.form_after == "degree 0":
            continue
        entry.label = f"geometric component {component} under-modelled ({entry.form_before} -> {entry.form_after})"
        kept.append(entry)
    return kept


def _apply(machine: Machine, batch: list[Score]) -> tuple[Machine, list[Change]]:
    """The machine with scored candidates added (one effect, or under-modelled components
    raised together); the accepted changes."""
    raises = [(s.candidate.component, s.candidate.by) for s in batch if s.candidate.kind == "raise"]
    if raises:
        new = raise_components(machine, raises)
        records = []
        for score in batch:
            cand = score.candidate
            _, tspec = geometric_term(new, cand.component)
            records.append(Change("under_modelled", cand.label, cand.name, cand.component, cand.axis, cand.direction,
                                  cand.driver, score.p_value, score.bic_gain, by=cand.by,
                                  form_before=cand.change[0], form_after=cand.change[1],
                                  names=list(tspec.names(cand.component))))
        return new, records
    (score,) = batch
    cand = score.candidate
    before = set(machine.parameter_names)
    prefix = _unique_prefix(machine, cand.component, PREFIX.get(cand.name, "geom"))
    table_spec = _table_with(score.term, score.coefficients, prefix)
    if not (cand.name in PREFIX or cand.component in machine.components):
        table_spec.pop("prefix", None)
    new = add_terms(machine, {cand.component: table_spec})
    return new, [Change("effect", cand.label, cand.name, cand.component,
                        cand.axis if cand.axis in machine.axes else None, cand.direction, cand.driver,
                        score.p_value, score.bic_gain, names=[n for n in new.parameter_names if n not in before])]


def diagnose(machine: Machine, measurements, *, fixed: bool = False, max_effects: int = 5,
             alpha: float = 0.01, folds: int = 5, seed: int = 0, sigma_um: float = 1.0,
             sigma_urad: float = 1.0, progress=None, keep_machines: bool = False,
             max_rounds: int | None = None) -> Diagnosis:
    """Find, name and add the effects the model is missing (see the module docstring).

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
        k of the k-fold cross-validation over poses (>= 2; points at the same positions -
        several targets, repeats - stay in one fold).
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
    split = pose_folds(obs, folds, seed)  # the points at one pose stay in one fold
    if split is None:
        poses = len(np.unique(np.round(obs.q, 12), axis=0))
        raise InputError(f"{obs.n_points} points at {poses} distinct {'pose' if poses == 1 else 'poses'}: too few "
                         f"for folds = {folds} (k-fold cross-validation needs at least {2 * folds})",
                         parameters=("folds",))
    require_memory(_memory_needed(machine, obs, folds),
                   f"diagnosing {obs.n_points} points ({len(obs.y)} observations)")
    cov_obj = machine.check_covariates(obs.n_points, obs.covariates)
    axis_index_of = {a: j for j, a in enumerate(machine.axes)}
    columns = _Columns(obs, cov_obj)
    max_rounds = max_effects + 8 if max_rounds is None else max_rounds

    def fit(model: Machine, names: list[str], initialise: bool = False):
        if fixed and not names:
            return model, np.array([], dtype=int), np.zeros(obs.nuisance.shape[1]), None
        free = None if not fixed else [model.parameter_names.index(n) for n in names]
        res = _quiet_identify(model, obs, free=free, initialise=initialise)
        return res.machine, res.fitted, np.array(list(res.nuisance.values())), res

    free_names: list[str] = []        # with ``fixed``: the coefficients that may move
    current, fitted, nuisance, last_fit = fit(machine, free_names, initialise=True)
    base_machine = current
    steps: list[Step] = []
    effects: list[Change] = []
    raised: list[Change] = []
    previous: list[Change] = []
    for number in range(max_rounds + 1):
        base = _base_design(current, obs, fitted, nuisance)
        proj = _Projector(base.A, base.r, obs, split)
        if number == 0 and len(obs.y) <= proj.rank:
            # the base model interpolates the data: no residual, and a held-out RMS of zero
            raise InputError(f"{len(obs.y)} observations at {obs.n_points} points do not over-determine the "
                             f"base model ({proj.rank} independent coefficients and nuisance terms): there is "
                             "no residual to diagnose; measure more points")
        base_cv = proj.cv_rms
        for record in previous:
            record.rms_after_um, record.max_after_um = base_cv, proj.cv_max
        candidates = build_candidates(current, obs)
        if len(effects) >= max_effects:
            candidates = [c for c in candidates if c.kind == "raise"]
        missing_loc = {c.component: {"kind": "constant", "prefix": "probe",
                                     f"value_{'um' if c.component[1] in 'XYZ' else 'arcsec'}": 0.0}
                       for c in candidates if c.component not in current.error_joints}
        probe = add_terms(current, missing_loc) if missing_loc else current
        E = probe.error_joint_sensitivity(obs.q, first_order=True, **obs.covariates)
        joints = list(probe.error_joints)
        scores = []
        for k, cand in enumerate(candidates):
            s = _score(base, proj, obs, E, joints, cand, cov_obj, axis_index_of, columns)
            if s is None:
                continue
            scores.append(s)
            if progress:
                progress(f"round {number + 1}: candidates", k + 1)
        m = max(1, len(scores))
        ranked = sorted(scores, key=lambda s: -s.bic_gain)
        for k, s in enumerate(ranked):  # cross-validate what could pass and what is shown
            if s.cv_rms_um is None and (k < 10 or s.p_value < alpha / m):
                s.cv_rms_um = proj.cv(s.columns)
        passing = [s for s in ranked if s.extra > 0 and s.p_value < alpha / m
                   and s.cv_rms_um is not None and s.cv_rms_um < base_cv * (1 - 1e-3)]
        accepted: list[Change] = []
        for best in (passing[:3] if number < max_rounds else []):
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
                new, records = _apply(current, batch)
                names = free_names + [n for r in records for n in r.names if n not in free_names]
                new_fit, new_fitted, new_nuisance, res = fit(new, names)
                tested = [_tested_names(new_fit, r) for r in records]
                sizes = [_size(res, t) if res is not None and t else math.inf for t in tested]
                keep = [s for s, z in zip(batch, sizes) if z >= SIGNIFICANCE]
                if len(keep) == len(batch) or (not keep and len(batch) == 1):
                    break
                # the ones significant in the joint refit; if none is (raises that explain the
                # same residual share it, and each looks insignificant), the best one alone
                batch = keep or [best]
            if len(keep) != len(batch) or not keep:
                continue
            for record, z in zip(records, sizes):
                record.rms_before_um, record.max_before_um, record.step = base_cv, proj.cv_max, number
                if np.isfinite(z):
                    record.significance = z
            accepted = records
            free_names = names
            current, fitted, nuisance, last_fit = new_fit, new_fitted, new_nuisance, res
            break
        steps.append(Step(number, base_cv, [s.summary() for s in ranked], base.r * obs.sigma, current if keep_machines else None,
                          accepted))
        if not accepted:
            break
        for record in accepted:
            (raised if record.kind == "under_modelled" else effects).append(record)
        previous = accepted
        twins_of(accepted, passing, machine)
    # the final fit: every accepted effect must still be significant, else it is dropped
    dropped: list[Change] = []
    final = last_fit
    while True:
        if not fixed or free_names:
            free = None if not fixed else [current.parameter_names.index(n) for n in free_names]
            final = _quiet_identify(current, obs, free=free, initialise=False)
            current = final.machine
        trimmed = _trim_raises(current, final, base_machine, {r.component for r in raised})
        if trimmed is not None:
            current = trimmed
            free_names = [n for n in free_names if n in set(current.parameter_names)]
            continue
        weak = [(_size(final, e.names) if final is not None else 0.0, i) for i, e in enumerate(effects)]
        weak = [(z, i) for z, i in weak if z < SIGNIFICANCE]
        if not weak:
            break
        _, i = min(weak)
        gone = effects.pop(i)
        gone.note = (f"accepted in round {gone.step + 1}, dropped after the final fit: its size is "
                     f"below {SIGNIFICANCE:g} standard uncertainties")
        dropped.append(gone)
        current = _remove_effect(current, gone)
        free_names = [n for n in free_names if n in set(current.parameter_names)]
    raised = _raised_summary(raised, base_machine, current)
    units = parameter_units(current)
    for e in effects:
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
    last = _base_design(current, obs, fitted_final, nuisance_final)
    last_proj = _Projector(last.A, last.r, obs, split)
    rms_fit = residual_rms(obs, last.r * obs.sigma)
    floor, source, bound = _noise_floor(obs, last.r * obs.sigma, last_proj.rank)
    analysis = residual_analysis(current, obs, steps[0].residual)
    if final is not None and final.ill_conditioned:
        warnings.warn(conditioning_note(final.analysis, len(obs.y)), stacklevel=2)
    return Diagnosis(current, base_machine, effects, steps, steps[0].rms_holdout_um, last_proj.cv_rms, rms_fit,
                     floor, source, bool(last_proj.cv_rms <= 1.2 * floor), alpha,
                     _time.perf_counter() - start, obs, analysis, raised, dropped, bound)


def _quiet_identify(machine: Machine, obs: Observations, **options):
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


def twins_of(accepted: list[Change], passing: list[Score], machine: Machine) -> None:
    """An accepted effect whose effect at the tool is the same through other sites (a drift
    in x through X, Y or Z of a Cartesian machine) is labelled as such, with ``axis`` None:
    the data cannot tell which site carries it."""
    for record in accepted:
        if record.kind != "effect":
            continue
        best = next(s for s in passing if s.candidate.label == record.label)
        cand = best.candidate
        twins = [s.candidate for s in passing if s is not best and s.candidate.name == cand.name
                 and s.candidate.kind == "effect"
                 and s.candidate.driver == cand.driver and s.candidate.direction == cand.direction
                 and abs(s.bic_gain - best.bic_gain) <= 1e-4 * abs(best.bic_gain)]
        if twins:
            by = f" driven by {cand.driver}" if cand.driver else ""
            record.label = (f"{cand.name} in {cand.direction}{by} (as {cand.component}; the same at the tool "
                            f"through {', '.join(t.component for t in twins)})")
            record.axis = None
            record.same_at_tool_as = [t.component for t in twins]


def driver_values(diagnosis: Diagnosis, driver: str | None) -> tuple[np.ndarray, str] | None:
    """Per-point values of an effect's driver and a label with its unit."""
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


@dataclass
class Evidence:
    """What a change did, for pictures: the residual along one error direction against
    the change's driver, before and after it (um); ``x`` and both residuals have shape
    (rows,), ``x_label`` names the driver with its unit."""

    x: np.ndarray
    x_label: str
    before_um: np.ndarray
    after_um: np.ndarray
    direction: str
    label: str


def evidence(diagnosis: Diagnosis, step: int) -> Evidence | None:
    """For the change accepted in round ``step`` (a :class:`Change`'s
    ``step``): its driver per point and the residual along the error direction that changed
    most, before and after it was added (um).

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
