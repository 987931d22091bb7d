"""The repeat check of a per-revolution error on an axis measured over two turns (issue 26): a
true periodic error has the same coefficients on each turn, a smooth shape over 720 deg that has
content at once per revolution does not."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import volerr_pin.fit.diagnosis._loop as diagnose_loop
from volerr_pin.fit.diagnosis import _changes as diagnose_changes
from volerr_pin.fit.diagnosis._changes import PERIOD_WINDOW
from volerr_pin.fit.diagnosis._scoring import REPEAT_MIN_POINTS, REPEAT_RATIO, REPEAT_SIGMAS, repeat_check
from volerr_pin.fit.diagnosis._projector import Projector
from volerr_pin.fit.identify import build_observations, pose_folds
from volerr_pin.measurements import heldout_set
from volerr_pin.model import add_terms

N = 400
NOISE = 0.3e-6                 # [m], the held-out sets' noise
ARCSEC = np.pi / 180 / 3600
LEVER = 0.2                    # [m]: an angle error of B seen at the tool


def _setup(seed: int, turns: float = 2.0):
    """Points over ``turns`` turns of B, a base design (nuisance offset and a degree-3 Legendre
    polynomial of B, as a spec's own EBB), the candidate's columns (sine and cosine of B) and
    the folds."""
    rng = np.random.default_rng(seed)
    half = turns * np.pi
    b = rng.uniform(-half, half, N)
    u = b / half
    base = np.polynomial.legendre.legvander(u, 3) * LEVER
    C = np.column_stack([np.sin(b), np.cos(b)]) * LEVER
    obs = SimpleNamespace(point=np.arange(N), angular=np.zeros(N, bool), sigma=np.full(N, NOISE))
    folds = np.array_split(rng.permutation(N), 5)
    return rng, b, base, C, obs, folds


def _check(y, base, C, obs, folds, b):
    proj = Projector(base / NOISE, y / NOISE, obs, folds)
    return proj, repeat_check(proj, obs, C / NOISE, b)


def _smooth(rng, b, size_arcsec=5.0):
    """A cubic spline through 7 random values at uneven positions over the span, as the
    held-out sets' off-spec geometry."""
    u = np.linspace(0.0, 1.0, 7)
    u[1:-1] += rng.uniform(-0.25, 0.25, 5) / 6
    lo, hi = b.min(), b.max()
    return CubicSpline(lo + (hi - lo) * u, rng.normal(0.0, size_arcsec, 7))(b) * ARCSEC


@pytest.mark.parametrize("seed", range(5))
def test_a_true_periodic_error_repeats_over_two_turns(seed):
    """5 and 2 arcsec once per revolution (the held-out sets' error) beside smooth geometry the
    base does not hold (a spline through values of 0.5 arcsec; with 1 arcsec the check turns
    away 3 of 40 seeds' true errors: geometry of B that differs between the turns clouds the
    repeat, which is why the loop lets such a candidate wait rather than drop it): the per-turn
    coefficients agree and the common fit recovers the hidden ones."""
    rng, b, base, C, obs, folds = _setup(seed)
    hidden = np.array([5.0, 2.0]) * ARCSEC
    y = base @ rng.normal(0, 1e-6, 4) + C @ hidden + LEVER * _smooth(rng, b, 0.5) + rng.normal(0, NOISE, N)
    _, check = _check(y, base, C, obs, folds, b)
    assert check is not None and check["repeats"], check
    assert np.linalg.norm(check["turns"].mean(axis=0) - hidden) < 0.25 * np.linalg.norm(hidden)
    assert check["amplitude"] == pytest.approx(np.linalg.norm(hidden), rel=0.25)


@pytest.mark.parametrize("seed", range(5))
def test_an_error_growing_over_two_turns_does_not_repeat(seed):
    """A once-per-revolution shape whose amplitude grows smoothly over the 720 deg (3 arcsec at
    the middle): a common sine and cosine pick it up - they lower the held-out RMS - but the
    second turn wants three times the first turn's coefficients."""
    rng, b, base, C, obs, folds = _setup(seed)
    y = base @ rng.normal(0, 1e-6, 4) + (C @ [3 * ARCSEC, 0.0]) * (1 + b / (2 * np.pi)) + rng.normal(0, NOISE, N)
    proj, check = _check(y, base, C, obs, folds, b)
    assert proj.cv(C / NOISE) < 0.98 * proj.cv_rms  # the candidate predicts better: a real question
    assert check is not None and not check["repeats"], check
    assert check["ratio"] > REPEAT_RATIO and check["sigmas"] > REPEAT_SIGMAS
    first, second = check["turns"][:, 0]
    assert second / first == pytest.approx(3.0, rel=0.25)


def test_smooth_shapes_over_two_turns_mostly_do_not_repeat():
    """Splines through 7 random values over the 720 deg (the held-out sets' off-spec geometry, 2
    arcsec) beside a degree-3 base: a common sine and cosine lower the held-out RMS for all but
    a few, and the repeat check turns most of those away."""
    better = failed = 0
    for seed in range(40):
        rng, b, base, C, obs, folds = _setup(seed)
        y = base @ rng.normal(0, 1e-6, 4) + LEVER * _smooth(rng, b, 2.0) + rng.normal(0, NOISE, N)
        proj, check = _check(y, base, C, obs, folds, b)
        if proj.cv(C / NOISE) < proj.cv_rms:
            better += 1
            failed += not check["repeats"]
    assert better >= 35 and failed >= 0.8 * better, (better, failed)


def test_no_check_over_one_turn_or_with_too_few_points_on_a_turn():
    rng, b, base, C, obs, folds = _setup(0, turns=1.0)
    y = C @ [5 * ARCSEC, 0.0] + rng.normal(0, NOISE, N)
    assert _check(y, base, C, obs, folds, b)[1] is None
    for first in (REPEAT_MIN_POINTS - 1, REPEAT_MIN_POINTS):
        # ``first`` points on the first turn (-360..0 deg), the rest on the second
        b = np.r_[np.linspace(-2 * np.pi, -0.1, first), np.linspace(0.0, 2 * np.pi, N - first)]
        base = np.polynomial.legendre.legvander(b / (2 * np.pi), 3) * LEVER
        C = np.column_stack([np.sin(b), np.cos(b)]) * LEVER
        y = C @ [5 * ARCSEC, 0.0] + rng.normal(0, NOISE, N)
        check = _check(y, base, C, obs, folds, b)[1]
        assert (check is None) == (first < REPEAT_MIN_POINTS)


def test_the_reason_names_the_axis_and_the_per_turn_coefficients():
    from volerr_pin.fit.diagnosis import Candidate
    from volerr_pin.fit.diagnosis._scoring import not_repeating

    cand = Candidate("periodic_rotary", "B", "y", "EBB", {"kind": "periodic_pitch", "period_deg": 360.0})
    rng, b, base, C, obs, folds = _setup(0)
    grow = (C @ [3 * ARCSEC, 0.0]) * (1 + b / (2 * np.pi)) + rng.normal(0, NOISE, N)
    proj, check = _check(grow, base, C, obs, folds, b)
    note = not_repeating(proj, obs, C / NOISE, b, cand, 3)
    first, second = check["turns"][:, 0] / ARCSEC
    assert note.startswith("not accepted in round 4: it does not repeat from one turn of B to the next")
    assert f"turn 1: {first:.2f}/" in note and f"turn 2: {second:.2f}/" in note and "EBB" in note
    true = C @ [5 * ARCSEC, 2 * ARCSEC] + rng.normal(0, NOISE, N)
    proj, _ = _check(true, base, C, obs, folds, b)
    assert not_repeating(proj, obs, C / NOISE, b, cand, 3) is None


ONCE = {"kind": "periodic_pitch", "period_deg": 360.0, "sine_arcsec": [0.0], "cosine_arcsec": [0.0], "origin_deg": 0.0}


@pytest.fixture(scope="module")
def once_per_revolution_loop(machines):
    """A diagnosis loop on cgm4000 (120 points, a hidden once-per-revolution error of B) and its
    model with that error's term added at the error's size, as a round's refit starts it."""
    m = machines["cgm4000"]
    _, data = heldout_set(m, {"EBB": dict(ONCE, prefix="h", sine_arcsec=[5.0], cosine_arcsec=[2.0])}, 120, 0.3, 601)
    obs = build_observations(m, [data], sigma_um=0.3)
    loop = diagnose_loop._Loop(m, obs, pose_folds(obs, 5, 0), False, 0.05, 5, None, False)
    return loop, add_terms(loop.current, {"EBB": dict(ONCE, prefix="rotary", sine_arcsec=[5.0], cosine_arcsec=[2.0])})


@pytest.mark.parametrize("factor", [1 / (1.01 * PERIOD_WINDOW), 1.01 * PERIOD_WINDOW, 1e6])
def test_an_accepted_period_a_fit_takes_out_of_its_window_is_fitted_again_held(once_per_revolution_loop, monkeypatch,
                                                                                 factor):
    """Off the spec's geometry a per-revolution error's free period was seen to wander to 5.9 deg
    and to 1e8 deg (a slope, with cancelling amplitudes of thousands of radians), and the next
    change's spec then refused it (a crash). A fit that takes an accepted period out of its
    window is done again with the period held at 360/n deg and nothing else held."""
    import dataclasses

    loop, model = once_per_revolution_loop
    name = "EBB.rotary.period"
    k = model.parameter_names.index(name)
    monkeypatch.setattr(loop.fit, "periods", {name: 2 * np.pi})
    calls, original = [], diagnose_changes.quiet_identify

    def straying(machine, obs, **options):
        calls.append((machine.theta[k], options.get("free")))
        res = original(machine, obs, **options)
        if len(calls) == 1:   # the free fit: its period wanders off
            theta = res.machine.theta.copy()
            theta[k] = 2 * np.pi * factor
            res = dataclasses.replace(res, machine=res.machine.with_theta(theta, limits=False))  # as a fit makes it
        return res

    monkeypatch.setattr(diagnose_changes, "quiet_identify", straying)
    fitted, _, _, res = loop.fit(model, [])
    assert len(calls) == 2 and calls[0][1] is None
    start, free = calls[1]
    assert start == 2 * np.pi and sorted(free) == [j for j in range(len(model.parameter_names)) if j != k]
    assert fitted.theta[k] == 2 * np.pi and res.machine is fitted


def test_a_period_within_its_window_is_fitted_once(once_per_revolution_loop, monkeypatch):
    loop, model = once_per_revolution_loop
    name = "EBB.rotary.period"
    monkeypatch.setattr(loop.fit, "periods", {name: 2 * np.pi})
    calls, original = [], diagnose_changes.quiet_identify
    monkeypatch.setattr(diagnose_changes, "quiet_identify",
                        lambda machine, obs, **options: calls.append(options.get("free")) or original(machine, obs, **options))
    fitted, *_ = loop.fit(model, [])
    period = fitted.theta[model.parameter_names.index(name)]
    assert calls == [None] and 2 * np.pi / PERIOD_WINDOW < period < 2 * np.pi * PERIOD_WINDOW and period != 2 * np.pi
