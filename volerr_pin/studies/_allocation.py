"""Tolerance re-allocation at least cost, checked by re-simulation.

**Cost model.** The classic reciprocal one: holding component ``i`` to tolerance ``t_i``
costs ``w_i t0_i / t_i``, where ``t0_i`` is its present tolerance and ``w_i`` its cost
weight (the tolerance file's ``cost``, default 1). The present tolerances cost ``sum w_i``;
halving one tolerance doubles its share.

**Constraint.** ``P(max |e| over the grid <= T) >= p``.

**Method.** The probability is a Monte Carlo estimate over the exact kinematics; an
optimiser needs a smooth one. With the draws written as ``x_i = t_i xi_i`` (``xi`` the
standard variables, fixed: common random numbers), the error at point ``k`` is to first
order ``C_k (t * xi)`` (``C`` the exact component sensitivities at zero error), so
``Y_s(t) = max_k |C_k (t * xi_s)|`` over a set of candidate points (those where the
simulations found the worst error) and ``P(t) = mean_s Phi((T - Y_s(t)) / h)`` with
``h = 2 %`` of ``T`` are smooth, with exact gradients. SLSQP (scipy) minimises the cost
over ``log t_i`` within ``[lower, upper]`` times the present tolerances, from the uniform
scaling that meets the constraint. The suggestion is then **re-simulated** with the exact
kinematics on fresh draws; it is accepted when the one-sided 95 % Clopper-Pearson lower
bound of the simulated probability is at least ``p``. Otherwise the points where the
failing draws peaked join the candidates, the surrogate's target rises by the shortfall,
and it is solved again (at most ``rounds`` times).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize
from scipy.special import ndtr
from scipy.stats import beta

from ..base import InputError
from ..model import Machine, check_covariates, sensitivity
from ._engine import Engine, InProcess, plan_chunks
from ._montecarlo import SAMPLE_CHUNK, MonteCarlo, Points, run_monte_carlo
from ._shapes import LEFT_OUT, ShapedSource
from ._tolerances import Tolerances

__all__ = ["Reallocation", "lower_bound", "reallocate"]

#: confidence of the acceptance test
CONFIDENCE = 0.95
#: smoothing of the surrogate probability, as a fraction of the target
BANDWIDTH = 0.02
#: largest draws x candidate points x (components / 4) the surrogate holds (3 x 4 doubles each: at most 192 MB)
SURROGATE_SIZE = 2_000_000


def lower_bound(successes: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided Clopper-Pearson lower confidence bound of a probability.

    Parameters
    ----------
    successes : int
        Draws that met the target.
    n : int
        Draws.
    confidence : float, default 0.95
        Confidence level.

    Returns
    -------
    float
        The bound (0 when there is no success).
    """
    return 0.0 if successes == 0 else float(beta.ppf(1 - confidence, successes, n - successes + 1))


@dataclass(frozen=True)
class Reallocation:
    """A tolerance suggestion and its check by re-simulation.

    Attributes
    ----------
    tolerances : Tolerances
        The suggested tolerances.
    before : Tolerances
        The present ones.
    cost_before, cost_after : float
        Cost of the present and suggested tolerances (``sum w_i t0_i / t_i``).
    uniform_cost : float or None
        Cost of meeting the target by scaling every tolerance by one factor (surrogate);
        None when no factor within the bounds does.
    probability : float
        Re-simulated probability of meeting the target with the suggestion.
    probability_lower : float
        Its one-sided 95 % lower bound.
    samples : int
        Draws of the re-simulation.
    seed : int
        Seed of the re-simulation (independent of the study's).
    rounds : int
        Surrogate solutions tried.
    met : bool
        Whether ``probability_lower`` reaches the target probability.
    reasons : tuple of str
        Per component (the order of ``tolerances``), why it ends where it does when that is a
        bound of the search rather than the target (empty otherwise).
    """

    tolerances: Tolerances
    before: Tolerances
    cost_before: float
    cost_after: float
    uniform_cost: float | None
    probability: float
    probability_lower: float
    samples: int
    seed: int
    rounds: int
    met: bool
    reasons: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """The report fields.

        Returns
        -------
        dict
            ``cost_model``, ``cost_before``, ``cost_after``, ``uniform_cost``, ``probability``,
            ``probability_lower``, ``samples``, ``seed``, ``rounds``, ``met`` and
            ``tolerances``: per component ``component``, ``unit``, ``before``, ``after``,
            ``distribution`` and ``reason`` (why a bound, not the target, set it; empty otherwise).
        """
        reasons = self.reasons or ("",) * len(self.before.entries)
        return {"cost_model": "sum of cost * tolerance_before / tolerance",
                "cost_before": self.cost_before, "cost_after": self.cost_after, "uniform_cost": self.uniform_cost,
                "probability": self.probability, "probability_lower": self.probability_lower,
                "samples": self.samples, "seed": self.seed, "rounds": self.rounds, "met": self.met,
                "tolerances": [{"component": a.component, "unit": a.unit, "before": a.value / a.factor,
                                "after": b.value / b.factor, "distribution": b.distribution.name, "reason": why}
                               for a, b, why in zip(self.before.entries, self.tolerances.entries, reasons)]}


class _Surrogate:
    """``Y_s(t) = max_k |C_k (t[owner] * xi_s)|`` and the smoothed probability of ``Y <= T``
    (``owner``: the component, among the active ones, of each coefficient column of ``C``).

    Each component's part at unit tolerance, ``B[s, k, :, d] = C_k[:, cols_d] xi_s[cols_d]``,
    is summed once, so that every evaluation is ``F = B t`` over components, not coefficients."""

    def __init__(self, C: np.ndarray, xi: np.ndarray, t0: np.ndarray, target: float, owner: np.ndarray):
        self.t0, self.target = t0, target
        self.h = BANDWIDTH * target
        self.B = np.stack([np.einsum("kcp,sp->skc", C[:, :, owner == d], xi[:, owner == d])
                           for d in range(len(t0))], axis=-1)

    def worst(self, x: np.ndarray):
        t = self.t0 * np.exp(x)
        F = self.B @ t
        n2 = np.einsum("skc,skc->sk", F, F)
        j = np.argmax(n2, axis=1)
        rows = np.arange(len(j))
        Y = np.sqrt(n2[rows, j])
        return t, F[rows, j], j, Y

    def probability(self, x: np.ndarray) -> float:
        return float(np.mean(ndtr((self.target - self.worst(x)[3]) / self.h)))

    def gradient(self, x: np.ndarray) -> np.ndarray:
        t, f, j, Y = self.worst(x)
        direction = f / np.maximum(Y, 1e-300)[:, None]
        dY = np.einsum("sc,scd->sd", direction, self.B[np.arange(len(j)), j]) * t   # d Y / d log t
        z = (self.target - Y) / self.h
        weight = np.exp(-0.5 * z * z) / math.sqrt(2 * math.pi) / self.h
        return -np.mean(weight[:, None] * dY, axis=0)


def _solve(s: _Surrogate, w: np.ndarray, p: float, lo: float, hi: float) -> tuple[np.ndarray, float | None]:
    """Least-cost ``log(t / t0)`` meeting the surrogate probability ``p``, and the cost of the uniform scaling."""
    D = len(w)
    bounds = (math.log(lo), math.log(hi))
    if s.probability(np.full(D, bounds[0])) < p:
        return np.full(D, bounds[0]), None
    a, b = bounds
    if s.probability(np.full(D, b)) >= p:
        a = b
    else:
        for _ in range(60):  # the largest uniform scale that meets p (Y scales with it)
            mid = (a + b) / 2
            a, b = (mid, b) if s.probability(np.full(D, mid)) >= p else (a, mid)
    x0 = np.full(D, a)
    uniform = float(np.sum(w * np.exp(-x0)))
    res = minimize(lambda x: float(np.sum(w * np.exp(-x))), x0, jac=lambda x: -w * np.exp(-x), method="SLSQP",
                   bounds=[bounds] * D, constraints=[{"type": "ineq", "fun": lambda x: s.probability(x) - p,
                                                      "jac": s.gradient}],
                   options={"maxiter": 200, "ftol": 1e-9})
    x = np.clip(res.x, *bounds)
    if s.probability(x) < p - 1e-6 or np.sum(w * np.exp(-x)) > uniform:
        x = x0
    return x, uniform


def reallocate(machine: Machine, tolerances: Tolerances, points: Points, source: ShapedSource,
               target: float, probability: float, first: MonteCarlo, *, samples: int, seed: int,
               engine: Engine | None = None, bounds: tuple[float, float] = (0.1, 10.0), rounds: int = 5,
               surrogate_samples: int = 10_000, progress=None, left_out=()) -> Reallocation:
    """Least-cost tolerances meeting ``P(max error <= target) >= probability``, re-simulated.

    Parameters
    ----------
    machine : Machine
        The study's machine (every component as its shape, all zero).
    tolerances : Tolerances
        The present tolerances.
    points : Points
        The grid.
    source : ShapedSource
        The study's draws (its shapes and distributions; the standard values are reused).
    target : float
        Largest admissible position error [m] (> 0).
    probability : float
        Probability to meet it with (0 < p < 1).
    first : MonteCarlo
        The study's run at the present tolerances (its worst points seed the candidates).
    samples : int
        Draws of each re-simulation.
    seed : int
        The study's seed (the re-simulations use seeds derived from it).
    engine : Engine, optional
        Where the re-simulations run.
    bounds : (float, float), default (0.1, 10)
        Smallest and largest factor on a present tolerance.
    rounds : int, default 5
        Surrogate solutions at most.
    surrogate_samples : int, default 10000
        Draws in the surrogate (fewer when there are many candidate points).
    progress : callable(stage, done, total), optional
        Called as re-simulation tasks finish.
    left_out : sequence of int, default ()
        Components a work offset removes: not drawn, and kept at their tolerance.

    Returns
    -------
    Reallocation
        The suggestion, its cost and its re-simulated probability.

    Raises
    ------
    InputError
        If ``target`` or ``probability`` is out of range, or no component has a tolerance.
    """
    if not (math.isfinite(target) and target > 0):
        raise InputError(f"target must be a positive length, got {target!r}", parameters=("target",))
    if not 0 < probability < 1:
        raise InputError(f"target_probability must lie between 0 and 1, got {probability!r}",
                         parameters=("target_probability",))
    lo, hi = bounds
    if not 0 < lo <= 1 <= hi:
        raise InputError(f"bounds must satisfy 0 < lower <= 1 <= upper, got {bounds!r}", parameters=("bounds",))
    engine = engine or InProcess()
    values = tolerances.values
    skip = np.zeros(len(values), dtype=bool)
    skip[list(left_out)] = True
    active = np.flatnonzero((values > 0) & ~skip)
    if not active.size:
        raise InputError("no component has a tolerance above zero: nothing to re-allocate")
    t0, w = values[active], tolerances.costs[active]
    cols = np.concatenate([source.columns[k] for k in active])
    owner = np.concatenate([np.full(len(source.columns[k]), j) for j, k in enumerate(active)])
    candidates = set(int(k) for k in np.unique(first.argmax))
    n_s = min(samples, surrogate_samples)
    xi = np.concatenate([source.standard(k, a, b) for k, a, b in plan_chunks(n_s, SAMPLE_CHUNK)])[:, cols]
    margin = 1.645 * math.sqrt(probability * (1 - probability) / samples)
    goal = min(probability + margin, 1 - 0.5 / n_s)
    x, uniform, mc, verify_seed = np.zeros(len(active)), None, None, seed
    model, theta = machine.model, machine.theta
    cov = check_covariates(model, points.n, None, machine.state)
    for round_ in range(1, rounds + 1):
        cand = np.array(sorted(candidates))
        C = sensitivity(model, points.q[cand], theta, cov.take(cand), first_order=True)[:, :3, cols]
        keep = max(1, min(n_s, SURROGATE_SIZE // (len(cand) * max(1, len(active) // 4))))
        surrogate = _Surrogate(C, xi[:keep], t0, target, owner)
        x, uniform = _solve(surrogate, w, goal, lo, hi)
        scale = np.where(skip, values, 0.0)
        scale[active] = t0 * np.exp(x)
        drawn = np.where(skip, 0.0, scale)
        verify_seed = int(np.random.SeedSequence([seed, 1, round_]).generate_state(1)[0])
        report = (lambda done, total: progress(f"re-allocation, check {round_}", done, total)) if progress else None
        mc = run_monte_carlo(machine, source.with_tolerance(drawn, verify_seed), points, samples, engine=engine,
                             per_point=False, progress=report)
        met_count = int(np.sum(mc.max <= target))
        low = lower_bound(met_count, samples)
        if low >= probability or uniform is None:
            break
        candidates.update(int(k) for k in np.unique(mc.argmax[mc.max > target]))
        goal = min(goal + (probability - low) + margin / 2, 1 - 0.5 / n_s)
    suggested = tolerances.with_values(scale, "re-allocation")
    met_count = int(np.sum(mc.max <= target))
    return Reallocation(suggested, tolerances, float(np.sum(w)), float(np.sum(w * t0 / scale[active])),
                        uniform, met_count / samples, lower_bound(met_count, samples), samples, verify_seed, round_,
                        lower_bound(met_count, samples) >= probability,
                        _reasons(len(values), active, x, C, owner, lo, hi, skip))


def _reasons(n: int, active: np.ndarray, x: np.ndarray, C: np.ndarray, owner: np.ndarray, lo: float, hi: float,
             skip: np.ndarray) -> tuple[str, ...]:
    """Why each component ends at a bound of the search (log factors ``x`` on the active ones,
    ``C`` their coefficients' sensitivities at the candidate points, ``owner`` the active
    component of each column; ``skip`` the components left out)."""
    out = [f"not re-allocated: {LEFT_OUT}" if skip[k] else "no tolerance: not re-allocated" for k in range(n)]
    column = np.abs(C).max(axis=(0, 1)) if C.size else np.zeros(len(owner))
    reach = np.array([column[owner == j].max(initial=0.0) for j in range(len(active))])
    for j, k in enumerate(active):
        factor = math.exp(x[j])
        if factor >= hi * (1 - 1e-6):
            out[k] = (f"at the largest factor allowed ({hi:g} x): it moves no point where the largest error "
                      "occurs, so the target does not limit it" if reach[j] <= 1e-12 * max(reach.max(), 1e-300) else
                      f"at the largest factor allowed ({hi:g} x): its part in the largest error is small enough "
                      "that this bound, not the target, stops it")
        elif factor <= lo * (1 + 1e-6):
            out[k] = f"at the smallest factor allowed ({lo:g} x): the target needs it as tight as the search may go"
        else:
            out[k] = ""
    return tuple(out)
