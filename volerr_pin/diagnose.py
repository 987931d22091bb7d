"""Find where model and measurements disagree, name the missing effect, add it, repeat.

The loop (:func:`diagnose`):

1. fit the base model to the data (:func:`volerr_pin.identify.identify`; with ``fixed`` the
   spec's values are kept);
2. look at the residuals against positions, time, temperatures, forces and approach
   directions (correlations, reversal steps, a periodogram over each linear axis);
3. build candidates from the catalogue for every axis, direction and sensor they can apply
   to - ``thermal_drift`` (time, each temperature), ``thermal_expansion``, ``backlash``,
   ``force_deflection``, ``periodic_pitch`` and the geometric terms the spec leaves out
   (``positioning``, ``straightness``, ``angular``, ``squareness``, ``location``) - and fit
   each jointly with the base model (linearised at the base fit, non-linear coefficients by
   grid search);
4. score them: BIC ranks them; the best is accepted only if (a) an F-test of its extra
   parameters is significant at ``alpha`` divided by the number of candidates (Bonferroni),
   and (b) it lowers the k-fold cross-validated RMS. The accepted effect is added to the
   model and everything is refitted;
5. repeat until no candidate passes, then estimate the noise floor (from repeated points if
   any, else from the final residual) and say whether the final model reaches it.

Effects whose effect at the tool is the same wherever they sit (a drift in x through any
axis of a Cartesian machine) are reported with ``axis`` None: the data cannot tell which.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np
from scipy import stats
from scipy.signal import lombscargle

from .errors import InputError
from .identify import Observations, _design, build_observations, identify, parameter_units
from .machine import Machine
from .spec import build_term, component_name, parse_component_name
from .specio import add_terms
from .terms import Context

UM = 1e6
LETTERS = "XYZABC"


@dataclass
class Candidate:
    """One effect that could be missing: where it goes and how it reads."""

    name: str                 # catalogue name
    axis: str | None
    direction: str | None     # "x", "y", "z" (rotations: about that axis)
    component: str
    table: dict               # spec term table (zero-valued) for add_terms
    driver: str | None = None  # covariate that drives it ("t", "T_spindle", "Fx", "dir_X", "q_X")
    label: str = ""

    def describe(self) -> str:
        where = f" on {self.axis}" if self.axis else ""
        d = f" in {self.direction}" if self.direction else ""
        by = f" driven by {self.driver}" if self.driver else ""
        return f"{self.name}{where}{d}{by} ({self.component})"


@dataclass
class Step:
    """One round: the scores of every candidate and the effect accepted, if any."""

    number: int
    rms_holdout_um: float
    candidates: list[dict]
    accepted: dict | None
    residual: np.ndarray = field(repr=False)            # (rows,) SI, before this round's effect
    machine: Machine | None = field(default=None, repr=False)


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`; :meth:`to_dict` gives the CONTRACT JSON."""

    machine: Machine
    base: Machine
    effects: list[dict]
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

    def to_dict(self) -> dict:
        return {
            "machine": self.machine.name,
            "rms_before_um": self.rms_before_um,
            "rms_after_um": self.rms_after_um,
            "rms_fit_um": self.rms_fit_um,
            "noise_floor_um": self.noise_floor_um,
            "noise_floor_source": self.noise_floor_source,
            "reaches_noise_floor": self.reaches_noise_floor,
            "effects": [{k: v for k, v in e.items() if not k.startswith("_")} for e in self.effects],
            "steps": [{"step": s.number, "rms_holdout_um": s.rms_holdout_um,
                       "accepted": None if s.accepted is None else s.accepted["label"],
                       "candidates": s.candidates[:10]} for s in self.steps],
            "test": f"F-test at alpha = {self.alpha:g} / number of candidates (Bonferroni) and a "
                    "lower k-fold cross-validated RMS; candidates ranked by BIC",
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
                                     {"kind": "legendre", f"coefficients_{unit}": coefs}, f"q_{axis}"))
        for d in ("ABC" if kind == "linear" else LETTERS):
            comp = component_name(d, axis, True)
            if comp not in present:
                unit, _ = unit_of(d)
                name = _geometric_name(d, axis, True, own.get(axis), kind == "linear")
                out.append(Candidate(name, axis, d.lower() if d in "XYZ" else "xyz"["ABC".index(d)], comp,
                                     {"kind": "constant", f"value_{unit}": 0.0}))
    for c in out:
        c.label = c.describe()
    return out


# ----------------------------------------------------------------------------- scoring
@dataclass
class _Base:
    machine: Machine
    theta_free: np.ndarray        # indices of the fitted coefficients
    A: np.ndarray                 # weighted design [nuisance | fitted coefficients]
    r: np.ndarray                 # weighted residual
    nuisance: np.ndarray


def _base_design(machine: Machine, obs: Observations, fitted: np.ndarray, nuisance: np.ndarray) -> _Base:
    # residual of the exact model; design of the first-order model (exact dependencies)
    pred, A = _design(machine, obs, machine.theta, fitted, first_order=True)
    r = (obs.y - pred - obs.nuisance @ nuisance) / obs.sigma
    J = np.hstack([obs.nuisance, A]) / obs.sigma[:, None]
    return _Base(machine, fitted, J, r, nuisance)


def _candidate_columns(machine: Machine, obs: Observations, E: np.ndarray, joints: list[str],
                       cand: Candidate, cov_obj, coefs_override=None):
    """Weighted columns (rows x p) of a candidate's coefficients, linearised at the base."""
    direction, location, owner = parse_component_name(cand.component)
    quantity = "length" if direction in "XYZ" else "angle"
    axis_index = machine.axes.index(owner) if owner in machine.axes else None
    travel = tuple(machine.travel[axis_index]) if axis_index is not None else None
    position_quantity = None if (location or axis_index is None) else (
        "length" if machine.axis_kinds[axis_index] == "linear" else "angle")
    tspec = build_term(dict(cand.table), f"candidate {cand.label}", quantity, position_quantity, travel)
    coefs = tspec.coefficients if coefs_override is None else coefs_override
    position = None if position_quantity is None else obs.q[:, axis_index]
    ctx = Context(position, travel, cov_obj, axis_index, cand.component)
    jac = tspec.term.jacobian(coefs, ctx)                       # (points, p)
    col = E[:, :, joints.index(cand.component)]                 # (points, 6)
    rows = np.einsum("rk,rk->r", obs.w, col[obs.point])          # (rows,)
    return rows[:, None] * jac[obs.point] / obs.sigma[:, None], tspec, coefs


class _Projector:
    """Least squares of a candidate jointly with the base design, by projection.

    The base design ``A`` (weighted rows x base coefficients) and residual ``r`` are fixed for
    a round; pseudo-inverses of the column-scaled design on all rows and on every
    cross-validation training set are computed once, so a candidate costs a few small
    products."""

    def __init__(self, A: np.ndarray, r: np.ndarray, obs: Observations, folds: list[np.ndarray]):
        self.obs = obs
        norms = np.linalg.norm(A, axis=0)
        keep = norms > 1e-12 * max(norms.max(initial=0.0), 1e-300)
        self.A = A[:, keep] / norms[keep] if keep.any() else np.zeros((len(r), 0))
        self.r = r
        self.P = np.linalg.pinv(self.A, rcond=1e-10) if self.A.shape[1] else np.zeros((0, len(r)))
        self.rank = _rank(self.A)
        self.folds = []
        pos = ~obs.angular
        for test in folds:
            V = np.isin(obs.point, test)
            T = ~V
            P_T = np.linalg.pinv(self.A[T], rcond=1e-10) if self.A.shape[1] else np.zeros((0, T.sum()))
            coef = P_T @ r[T]
            self.folds.append((T, V, P_T, r[T] - self.A[T] @ coef, r[V] - self.A[V] @ coef, pos[V]))
        self.cv_rms = self._cv(lambda f: np.zeros(f[4].shape))
        self.cv_max = self.last_max

    def _cv(self, correction) -> float:
        sq, count, peak = 0.0, 0, 0.0
        obs = self.obs
        for f in self.folds:
            T, V, P_T, r_T, e_V, pos_V = f
            res = (e_V - correction(f)) * obs.sigma[V]
            per_point = np.zeros(obs.n_points)
            np.add.at(per_point, obs.point[V][pos_V], res[pos_V] ** 2)
            used = np.unique(obs.point[V][pos_V])
            sq += per_point[used].sum()
            count += used.size
            peak = max(peak, float(np.sqrt(per_point[used].max())) if used.size else 0.0)
        self.last_max = peak * UM
        return float(np.sqrt(sq / count) * UM) if count else math.nan

    def fit(self, C: np.ndarray):
        """(extra rank, rss after, candidate coefficients in C's units, base correction)."""
        norms = np.linalg.norm(C, axis=0)
        norms[norms == 0] = 1.0
        Cs = C / norms
        G = Cs - self.A @ (self.P @ Cs) if self.A.shape[1] else Cs
        sv = np.linalg.svd(G, compute_uv=False) if G.size else np.zeros(0)
        extra = int(np.sum(sv > 1e-6))
        if extra == 0:
            return 0, float(self.r @ self.r), np.zeros(C.shape[1])
        gamma = np.linalg.lstsq(G, self.r, rcond=1e-6)[0]
        res = self.r - G @ gamma
        return extra, float(res @ res), gamma / norms

    def cv(self, C: np.ndarray) -> float:
        norms = np.linalg.norm(C, axis=0)
        norms[norms == 0] = 1.0
        Cs = C / norms

        def correction(f):
            T, V, P_T, r_T, e_V, pos_V = f
            B = P_T @ Cs[T] if self.A.shape[1] else np.zeros((0, Cs.shape[1]))
            G_T = Cs[T] - self.A[T] @ B
            gamma = np.linalg.lstsq(G_T, r_T, rcond=1e-6)[0]
            return (Cs[V] - self.A[V] @ B) @ gamma

        return self._cv(correction)


def _rank(A: np.ndarray) -> int:
    if A.shape[1] == 0:
        return 0
    norms = np.linalg.norm(A, axis=0)
    ok = norms > 0
    if not ok.any():
        return 0
    sv = np.linalg.svd(A[:, ok] / norms[ok], compute_uv=False)
    return int(np.sum(sv > 1e-9 * sv[0]))


def _periodogram_period(machine, obs, r, axis_index, letter):
    """Period of the strongest sinusoid in the residual along an axis' own direction."""
    rows = obs.w[:, "XYZ".index(letter)] > 0.5
    if rows.sum() < 20:
        return None
    x = obs.q[obs.point[rows], axis_index]
    y = r[rows] * obs.sigma[rows]
    y = y - np.polyval(np.polyfit(x, y, 3), x)
    lo, hi = machine.travel[axis_index]
    spacing = np.median(np.diff(np.sort(np.unique(x)))) if len(np.unique(x)) > 2 else (hi - lo) / 10
    periods = np.geomspace(max(4 * spacing, (hi - lo) / 2000), (hi - lo) / 3, 600)
    power = lombscargle(x, y - y.mean(), 2 * np.pi / periods)
    return float(periods[int(np.argmax(power))])


def _score(base: _Base, proj: _Projector, obs: Observations, E, joints, cand: Candidate, cov_obj,
           axis_index_of):
    """Fit the candidate jointly with the base (linearised) and score it."""
    n = len(base.r)
    if cand.name == "periodic_pitch":
        period = _periodogram_period(base.machine, obs, base.r, axis_index_of[cand.axis], cand.component[1])
        if period is None:
            return None
        cand.table = dict(cand.table, period_mm=period * 1e3)
    _, tspec, coefs = _candidate_columns(base.machine, obs, E, joints, cand, cov_obj)
    nonlinear = [tspec.term.local_names.index(k) for k in tspec.term.nonlinear]
    lin = [i for i in range(len(coefs)) if i not in nonlinear]
    grid = [None]
    if nonlinear and cand.name != "periodic_pitch":  # periods come from the periodogram
        grid = list(tspec.term.search_grid(tspec.term.local_names[nonlinear[0]], coefs, cov_obj))
    best = None
    for value in grid:
        c = coefs.copy()
        if value is not None:
            c[nonlinear[0]] = value
        # columns of the linear coefficients at this value of the non-linear one
        C, _, _ = _candidate_columns(base.machine, obs, E, joints, cand, cov_obj, c)
        C = C[:, lin]
        extra, rss1, gamma = proj.fit(C)
        if best is None or rss1 < best[1]:
            best = (extra, rss1, gamma, c, C)
    extra, rss1, gamma, c, C = best
    rss0 = float(base.r @ base.r)
    if extra == 0 or rss1 <= 0:
        return {"label": cand.label, "extra": 0, "p_value": 1.0, "bic_gain": 0.0,
                "cv_rms_um": proj.cv_rms, "rss_drop": 0.0}
    k = extra + len(nonlinear)
    dof = n - proj.rank - k
    F = ((rss0 - rss1) / k) / (rss1 / dof) if dof > 0 else 0.0
    p_value = float(stats.f.sf(F, k, dof)) if dof > 0 else 1.0
    bic_gain = n * math.log(rss0 / rss1) - k * math.log(n)
    values = c.copy()
    values[lin] = gamma
    return {"label": cand.label, "extra": int(extra), "p_value": p_value, "bic_gain": float(bic_gain),
            "cv_rms_um": proj.cv(C), "rss_drop": (rss0 - rss1) / rss0 if rss0 > 0 else 0.0,
            "_coefs": values, "_tspec": tspec}


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
                    entry[f"step_dir_{a}_um"] = float((y[d > 0].mean() - y[d < 0].mean()) * UM)
        out[f"d{letter}"] = dict(sorted(entry.items(), key=lambda kv: -abs(kv[1]))[:6])
    return out


def _noise_floor(obs: Observations, r_si: np.ndarray, n_params: int) -> tuple[float, str]:
    """From repeated points (same positions and covariates) if there are, else the residual."""
    pos = ~obs.angular
    keys = {}
    for i in range(obs.n_points):
        key = tuple(np.round(obs.q[i], 12))
        keys.setdefault(key, []).append(i)
    groups = [g for g in keys.values() if len(g) > 1]
    comps = max(1.0, pos.sum() / max(1, len(np.unique(obs.point[pos]))))
    if groups:
        ss, dof = 0.0, 0
        for g in groups:
            for k in range(6):
                rows = np.isin(obs.point, g) & (obs.w[:, k] > 0.5) & pos
                if rows.sum() > 1:
                    ss += float(((obs.y[rows] - obs.y[rows].mean()) ** 2).sum())
                    dof += int(rows.sum()) - 1
        if dof >= 5:
            return float(np.sqrt(ss / dof * comps) * UM), f"repeated points ({dof} degrees of freedom)"
    dof = int(pos.sum()) - n_params
    sigma = math.sqrt(float((r_si[pos] ** 2).sum()) / max(dof, 1))
    return float(sigma * math.sqrt(comps) * UM), "final residual (n - p degrees of freedom)"


def diagnose(machine: Machine, measurements, *, fixed: bool = False, max_effects: int = 5,
             alpha: float = 0.01, folds: int = 5, seed: int = 0, sigma_um: float = 1.0,
             sigma_urad: float = 1.0, progress=None, keep_machines: bool = False) -> Diagnosis:
    """Find, name and add the effects the model is missing (see the module docstring).

    Parameters
    ----------
    measurements : list of PointMeasurements (or runs), or Observations
    fixed : bool
        Keep the spec's geometric values instead of identifying them first.
    max_effects : int
        Stop after this many accepted effects.
    alpha : float
        Family-wise significance level of the F-test in each round (Bonferroni over the
        candidates of the round).
    """
    start = _time.perf_counter()
    obs = measurements if isinstance(measurements, Observations) else build_observations(
        machine, measurements, sigma_um=sigma_um, sigma_urad=sigma_urad)
    rng = np.random.default_rng(seed)
    order = rng.permutation(obs.n_points)
    if obs.n_points < 2 * folds:
        raise InputError(f"{obs.n_points} points are too few for {folds}-fold cross-validation")
    split = np.array_split(order, folds)
    cov_obj = machine.check_covariates(obs.n_points, obs.covariates)
    axis_index_of = {a: j for j, a in enumerate(machine.axes)}

    def fit(model: Machine, free_names: list[str] | None):
        if fixed and not free_names:
            return model, np.array([], dtype=int), np.zeros(obs.nuisance.shape[1])
        free = None if not fixed else [model.parameter_names.index(n) for n in free_names]
        res = identify(model, obs, free=free, folds=0)
        return res.machine, res.fitted, np.array(list(res.nuisance.values()))

    effect_params: list[str] = []
    current, fitted, nuisance = fit(machine, effect_params)
    base_machine = current
    steps: list[Step] = []
    effects: list[dict] = []
    first_cv = None
    for number in range(max_effects + 1):
        base = _base_design(current, obs, fitted, nuisance)
        proj = _Projector(base.A, base.r, obs, split)
        base_cv = proj.cv_rms
        if first_cv is None:
            first_cv = base_cv
        candidates = build_candidates(current, obs)
        missing_loc = {c.component: {"kind": "constant", "prefix": "probe",
                                     f"value_{'um' if c.component[1] in 'XYZ' else 'arcsec'}": 0.0}
                       for c in candidates if c.component not in current.error_joints}
        probe = add_terms(current, missing_loc) if missing_loc else current
        E = probe.error_joint_sensitivity(obs.q, first_order=True, **obs.covariates)
        joints = list(probe.error_joints)
        scores = []
        for k, cand in enumerate(candidates):
            s = _score(base, proj, obs, E, joints, cand, cov_obj, axis_index_of)
            if s is None:
                continue
            s["_candidate"] = cand
            scores.append(s)
            if progress:
                progress(f"round {number + 1}: candidates", k + 1)
        m = max(1, len(scores))
        passing = [s for s in scores if s["extra"] > 0 and s["p_value"] < alpha / m
                   and s["cv_rms_um"] < base_cv * (1 - 1e-3)]
        ranked = sorted(scores, key=lambda s: -s["bic_gain"])
        table = [{k: v for k, v in s.items() if not k.startswith("_")} for s in ranked]
        accepted = None
        if passing and number < max_effects:
            best = max(passing, key=lambda s: s["bic_gain"])
            cand = best["_candidate"]
            twins = [s["_candidate"] for s in passing if s is not best and s["_candidate"].name == cand.name
                     and s["_candidate"].driver == cand.driver and s["_candidate"].direction == cand.direction
                     and abs(s["bic_gain"] - best["bic_gain"]) <= 1e-4 * abs(best["bic_gain"])]
            prefix = _unique_prefix(current, cand.component, PREFIX.get(cand.name, "geom"))
            table_spec = _table_with(best["_tspec"], best["_coefs"], prefix)
            if cand.name in PREFIX or cand.component in current.components:
                new = add_terms(current, {cand.component: table_spec})
            else:
                table_spec.pop("prefix", None)
                new = add_terms(current, {cand.component: table_spec})
            new_names = [n for n in new.parameter_names if n not in set(current.parameter_names)]
            effect_params += new_names
            before_cv = base_cv
            new_fit, fitted, nuisance = fit(new, effect_params)
            after_base = _base_design(new_fit, obs, fitted, nuisance)
            after = _Projector(after_base.A, after_base.r, obs, split)
            label = cand.label
            if twins:
                by = f" driven by {cand.driver}" if cand.driver else ""
                label = (f"{cand.name} in {cand.direction}{by} (as {cand.component}; the same at the tool "
                         f"through {', '.join(t.component for t in twins)})")
            accepted = {"label": label, "name": cand.name,
                        "axis": None if twins else (cand.axis if cand.axis in machine.axes else None),
                        "direction": cand.direction, "component": cand.component, "driver": cand.driver,
                        "p_value": best["p_value"], "bic_gain": best["bic_gain"],
                        "rms_before_um": before_cv, "rms_after_um": after.cv_rms,
                        "max_before_um": proj.cv_max, "max_after_um": after.cv_max,
                        "_names": new_names, "_residual_before": base.r * obs.sigma}
            current = new_fit
        steps.append(Step(number, base_cv, table, accepted, base.r * obs.sigma,
                          current if keep_machines else None))
        if accepted is None:
            break
        effects.append(accepted)
    # parameters and uncertainties of the accepted effects, from a final fit
    final_free = None if not fixed else [current.parameter_names.index(n) for n in effect_params]
    final = identify(current, obs, free=final_free, folds=0) if (not fixed or effect_params) else None
    units = parameter_units(current)
    for e in effects:
        params = {}
        for name in e["_names"]:
            k = current.parameter_names.index(name)
            factor, unit = units[name]
            u = final.uncertainty[k] if final is not None else math.nan
            params[name] = {"value": float(current.theta[k] / factor),
                            "uncertainty": None if math.isnan(u) else float(u / factor), "unit": unit}
        e["parameters"] = params
    last = _base_design(current, obs, fitted, nuisance)
    final_cv = _Projector(last.A, last.r, obs, split).cv_rms
    pos = ~obs.angular
    per_point = np.zeros(obs.n_points)
    np.add.at(per_point, obs.point[pos], (last.r[pos] * obs.sigma[pos]) ** 2)
    rms_fit = float(np.sqrt(per_point[np.unique(obs.point[pos])].mean()) * UM)
    floor, source = _noise_floor(obs, last.r * obs.sigma, _rank(last.A))
    analysis = residual_analysis(current, obs, steps[0].residual)
    return Diagnosis(current, base_machine, effects, steps, first_cv, final_cv, rms_fit, floor, source,
                     bool(final_cv <= 1.2 * floor), alpha, _time.perf_counter() - start, obs, analysis)


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
        scale = 1e3 if machine.axis_kinds[j] == "linear" else 180 / math.pi
        return obs.q[:, j] * scale, f"{driver[2:]} [{'mm' if scale == 1e3 else 'deg'}]"
    return None


def evidence(diagnosis: Diagnosis, k: int) -> dict | None:
    """For the k-th accepted effect: its driver per point and the residual along the error
    direction that changed most, before and after it was added (um)."""
    e = diagnosis.effects[k]
    step = diagnosis.steps[k]
    after = diagnosis.steps[k + 1].residual
    found = driver_values(diagnosis, e["driver"])
    obs = diagnosis.observations
    best = None
    for j in range(3):
        rows = (obs.w[:, j] > 0.5) & ~obs.angular
        if rows.sum() == 0:
            continue
        drop = float(np.mean(step.residual[rows] ** 2) - np.mean(after[rows] ** 2))
        if best is None or drop > best[0]:
            best = (drop, j, rows)
    if best is None:
        return None
    _, j, rows = best
    points = obs.point[rows]
    x, label = found if found is not None else (np.arange(obs.n_points, dtype=float), "point")
    return {"x": x[points], "x_label": label, "before_um": step.residual[rows] * UM,
            "after_um": after[rows] * UM, "direction": "xyz"[j], "label": e["label"]}
