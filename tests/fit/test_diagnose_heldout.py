"""diagnose on held-out sets built here with fixed seeds (issue 26): smooth off-spec geometry with
every covariate column and no, one or two hidden effects or one near the noise, on vmc500 and on
the five-axis cgm4000 (rotary backlash, periodic errors per revolution, rotary location drift);
the right names and nothing below practical significance among the findings; the real spindle's
16 sensors as one thermal finding."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from volerr_pin.fit.diagnosis import EVIDENCE_BIC, PRACTICAL_AMPLITUDE, PRACTICAL_GAIN, Alternative, diagnose
from volerr_pin.fit.identify import build_observations
from volerr_pin.measurements import heldout_set

NOISE = 0.3
FLOOR = np.sqrt(3) * NOISE

VMC = {
    "none": ({}, []),
    "backlash": ({"EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 4.0}}, [("backlash", "Y", "y")]),
    "force": ({"EZZ": {"kind": "force_deflection", "prefix": "h", "force": "z", "compliance_um_per_N": [0.02]}},
              [("force_deflection", None, "z")]),
    "pitch": ({"EXX": {"kind": "periodic_pitch", "prefix": "h", "period_mm": 20.0, "sine_um": [1.5],
                       "cosine_um": [1.0]}}, [("periodic_pitch", "X", "x")]),
    "two": ({"EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 4.0},
             "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [6.0],
                     "time_constants_min": [50.0]}}, [("backlash", "Y", "y"), ("thermal_drift", None, "z")]),
}

CGM = {
    "rotary_backlash": ({"EBB": {"kind": "backlash", "prefix": "h", "reversal_arcsec": 8.0}},
                        [("backlash", "B", "y")]),
    "once_per_revolution": ({"EBB": {"kind": "periodic_pitch", "prefix": "h", "period_deg": 360.0,
                                     "sine_arcsec": [5.0], "cosine_arcsec": [2.0]}}, [("periodic_rotary", "B", "y")]),
    "four_per_revolution": ({"EBB": {"kind": "periodic_pitch", "prefix": "h", "period_deg": 90.0,
                                     "sine_arcsec": [4.0], "cosine_arcsec": [0.0]}}, [("periodic_rotary", "B", "y")]),
    "rotary_location_drift": ({"EX0B": {"kind": "thermal_drift", "driver": "time", "prefix": "h",
                                        "amplitudes_um": [8.0], "time_constants_min": [60.0]}},
                              [("thermal_drift", None, "x")]),
}


def named(result):
    return sorted((e.name, e.axis, e.direction) for e in result.effects)


#: what a per-revolution finding's label must say (a period fitted freely once let a "3 times per
#: revolution" candidate settle at 302 deg on a hidden once-per-revolution error)
ORDER = {"once_per_revolution": "once per revolution", "four_per_revolution": "4 times per revolution"}


def check_order(kind, result):
    for e in result.effects:
        if e.name == "periodic_rotary":
            assert ORDER[kind] in e.label, e.label


ARCSEC = np.pi / 180 / 3600


def check_period(kind, truth, data, result):
    """A per-revolution finding repeats exactly n times per revolution: its period is 360/n deg,
    held (not estimated: no uncertainty), and its amplitude is within a factor 1.5 of what the
    true B holds at that order - the true EBB (off-spec geometry and the hidden error) fitted
    with the final model's form of EBB over the measured angles."""
    if kind not in ORDER:
        return
    (found,) = [e for e in result.effects if e.name == "periodic_rotary"]
    (period,) = [v for k, v in found.parameters.items() if k.endswith(".period")]
    hidden_deg = CGM[kind][0]["EBB"]["period_deg"]   # 360 / n
    assert period["value"] == pytest.approx(hidden_deg, abs=1e-9) and period["uncertainty"] is None, period
    fm = result.machine
    q = build_observations(truth, [data], sigma_um=NOISE).q
    names = [k for k in fm.parameter_names if k.startswith("EBB.") and not k.endswith(".period")]
    j = fm.components.index("EBB")
    at = fm.component_values(q, without_covariates=True)[:, j]
    columns = []
    for name in names:  # the component is linear in these coefficients
        theta = fm.theta.copy()
        theta[fm.parameter_names.index(name)] += 1e-6
        columns.append((fm.component_values(q, theta, without_covariates=True)[:, j] - at) / 1e-6)
    y = truth.component_values(q, without_covariates=True)[:, truth.components.index("EBB")]
    x = dict(zip(names, np.linalg.lstsq(np.column_stack(columns), y, rcond=None)[0]))
    pair = [k for k in found.parameters if k.endswith((".s1", ".c1"))]
    true_amplitude = np.hypot(*[x[k] / ARCSEC for k in pair])
    amplitude = np.hypot(*[found.parameters[k]["value"] for k in pair])
    assert true_amplitude / 1.5 <= amplitude <= 1.5 * true_amplitude, (amplitude, true_amplitude, found.parameters)


def check_final_model(result):
    """The final fit (trims, dropped and below-practical effects) keeps the model the rounds
    built: its held-out RMS, the headline, is within 10 % of the last round's."""
    assert result.rms_after_um <= 1.1 * result.steps[-1].rms_holdout_um, (
        result.rms_after_um, [round(s.rms_holdout_um, 3) for s in result.steps])


def check_practical(result):
    """Every finding is above the stated practical thresholds; what is below them is listed apart."""
    noise_pc = result.noise_floor_um / np.sqrt(3)
    for e in result.effects:
        assert e.gain_um >= PRACTICAL_GAIN * (result.rms_after_um + e.gain_um) - 1e-12, e.label
        assert e.amplitude_um >= PRACTICAL_AMPLITUDE * noise_pc * 0.999, e.label
    for e in result.possible:
        assert e.note.startswith(("possible, below practical significance", "possible: cannot be told from",
                                  "possible, cannot be told apart")), e.note
        if e.note.startswith("possible, cannot be told apart"):   # a rival reading: both said, and the evidence
            assert isinstance(e.details, Alternative) and abs(e.details.bic_difference) < EVIDENCE_BIC


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("kind", list(VMC))
def test_vmc500_held_out_sets_name_what_is_hidden(machines, kind, seed):
    m = machines["vmc500"]
    hidden, expected = VMC[kind]
    _, data = heldout_set(m, hidden, 400, NOISE, 300 + seed)
    result = diagnose(m, [data])
    assert named(result) == sorted(expected), [e.label for e in result.effects]
    check_practical(result)
    assert result.rms_after_um < 1.3 * FLOOR
    assert result.off_spec()["count"] == len(result.under_modelled) > 0


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_no_effect_and_many_points_invents_nothing(machines, seed):
    """The issue's case: 1,500 points, no effect; a period at a table's node spacing is the
    table's interpolation, and nothing below practical significance is found."""
    m = machines["vmc500"]
    _, data = heldout_set(m, {}, 1500, NOISE, 400 + seed)
    result = diagnose(m, [data])
    assert named(result) == [], [e.label for e in result.effects]
    check_practical(result)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_an_effect_near_the_noise_is_named_correctly_or_not_at_all(machines, seed):
    m = machines["vmc500"]
    _, data = heldout_set(m, {"EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 0.9}}, 400, NOISE, 500 + seed)
    result = diagnose(m, [data])
    assert named(result) in ([], [("backlash", "Y", "y")])
    check_practical(result)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(2))
@pytest.mark.parametrize("kind", list(CGM))
def test_five_axis_held_out_sets(machines, kind, seed):
    m = machines["cgm4000"]
    hidden, expected = CGM[kind]
    truth, data = heldout_set(m, hidden, 400, NOISE, 600 + seed)
    result = diagnose(m, [data], sigma_um=NOISE)
    assert named(result) == sorted(expected), [e.label for e in result.effects]
    check_practical(result)
    check_final_model(result)
    check_order(kind, result)
    check_period(kind, truth, data, result)
    # the floor is claimed only when the residual is near the stated noise
    assert not result.reaches_noise_floor or result.rms_after_um < 1.2 * 2 * result.noise_stated_um


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["rotary_backlash", "four_per_revolution"])
def test_five_axis_third_seed(machines, kind):
    """Seed 2, where B's smooth off-spec geometry over its two turns has content at once per
    revolution: before the repeat check a once-per-revolution error of B was named beside the
    hidden backlash and beside the hidden 4-per-revolution error."""
    m = machines["cgm4000"]
    hidden, expected = CGM[kind]
    truth, data = heldout_set(m, hidden, 400, NOISE, 602)
    result = diagnose(m, [data], sigma_um=NOISE)
    assert named(result) == sorted(expected), [e.label for e in result.effects]
    check_practical(result)
    check_final_model(result)
    check_order(kind, result)
    check_period(kind, truth, data, result)
    # the report says why B's once-per-revolution candidate was not taken
    notes = [c["note"] for step in result.to_dict()["steps"] for c in step["candidates"] if "note" in c]
    assert any("does not repeat from one turn of B to the next" in n for n in notes), notes


@pytest.mark.slow
def test_what_the_data_cannot_tell_from_geometry_is_said(machines, capsys):
    """Seed 2's hidden once-per-revolution error of B: B's own off-spec geometry differs between
    its two turns at once per revolution almost as much as the error, and in the rounds a raise
    of B's radial component EZB swallowed it. Weighed after the rounds against that raise, both
    refitted, the named reading explains the data better by more than EVIDENCE_BIC: it is named,
    in place of the raise, and says so (once this set was listed as undecided with a plan). A
    possible per-revolution error's plan (Separation) is a command the planning command takes as
    written."""
    import shlex

    from volerr_pin.cli import main
    from volerr_pin.cli._diagnose import plan_argv

    m = machines["cgm4000"]
    _, data = heldout_set(m, CGM["once_per_revolution"][0], 400, NOISE, 602)
    result = diagnose(m, [data], sigma_um=NOISE)
    assert named(result) == [("periodic_rotary", "B", "y")]
    check_practical(result)
    (found,) = result.effects
    assert isinstance(found.details, Alternative) and found.details.in_model == "named"
    assert found.details.bic_difference > EVIDENCE_BIC and "EZB" in found.details.readings[1]
    assert "EZB" not in {u.component for u in result.under_modelled if u.rounds == [found.step + 1]}
    plan = {"instrument": "tracker", "budget": 48, "zone": {"X": 2000.0, "Y": 1250.0, "Z": 300.0, "A": -10.0},
            "terms": ["EBB"]}
    argv = plan_argv("cgm4000", plan)
    assert shlex.join(argv) == ("volerr plan cgm4000 --instrument tracker --budget 48 --zone X=2000 Y=1250 Z=300 "
                                "A=-10 --terms EBB")
    assert main(argv[1:]) == 0
    assert "tracker poses planned" in capsys.readouterr().out


@pytest.mark.slow
def test_five_axis_per_revolution_periods_stay_in_their_window(machines):
    """Seed 610, a hidden once-per-revolution error of B: B's off-spec geometry took the free
    period of the accepted error to 5.9 deg (its amplitude gone), a second once-per-revolution
    term of B was accepted beside it, its period went to 1e8 deg (a slope, with an amplitude of
    3,000 rad), and the next change's spec refused that value: the diagnosis stopped with an
    error. Now every round's model holds at most one per-revolution term of an order per
    component, within its window, and the result names the error or nothing."""
    from volerr_pin.fit.diagnosis._effects import ROTARY_ORDERS
    from volerr_pin.fit.diagnosis._changes import PERIOD_WINDOW
    from volerr_pin.model import check_values

    m = machines["cgm4000"]
    hidden, expected = CGM["once_per_revolution"]
    _, data = heldout_set(m, hidden, 400, NOISE, 610)
    result = diagnose(m, [data], sigma_um=NOISE, keep_machines=True)
    assert named(result) in ([], sorted(expected)), [e.label for e in result.effects]
    check_practical(result)
    for step in result.steps:
        model = step.machine
        orders = []
        for name, value in zip(model.parameter_names, model.theta):
            if ".rotary" in name and name.endswith(".period"):
                (n,) = [n for n in ROTARY_ORDERS if 2 * np.pi / n / PERIOD_WINDOW <= value <= 2 * np.pi / n * PERIOD_WINDOW][:1]
                orders.append((name.split(".")[0], n))
        assert len(orders) == len(set(orders)), orders
    check_values(result.machine)   # the final model's spec holds its values
    result.machine.with_spec(result.machine.spec)


def _real_data() -> Path:
    """Real data are read in place (never copied): ``$VOLERR_REAL_DATA`` or ``shared/real-data``
    beside the repository."""
    import os

    root = os.environ.get("VOLERR_REAL_DATA")
    return Path(root) if root else Path(__file__).resolve().parents[3] / "shared" / "real-data"


SPINDLE = _real_data() / "sjtu_spindle_thermal" / "spindle_thermal_original.csv"


@pytest.mark.slow
@pytest.mark.skipif(not SPINDLE.exists(), reason="the real spindle data are not on this machine")
def test_real_spindle_sensors_are_one_thermal_finding(machines):
    """The real spindle's thermal elongation (16 sensors, 78 h at 1 min; every 10th minute kept)
    hidden in simulated off-spec geometry: one thermal drift in z, checked over time, the
    headline the final model's."""
    import csv

    from volerr_pin.measurements import PointMeasurements
    from volerr_pin.measurements import off_model_geometry

    with open(SPINDLE, encoding="utf-8-sig") as f:
        rows = list(csv.reader(f))
    header = [h.strip() for h in rows[0]]
    table = np.array([[float(x) for x in r] for r in rows[1:] if r and all(x.strip() for x in r)])[::10]
    sensors = header[1:]                                    # the first column is the elongation
    m = machines["vmc500"]
    truth = off_model_geometry(m, 11, "spline")
    n = table.shape[0]
    rng = np.random.default_rng(11)
    q = rng.uniform(m.travel[:, 0], m.travel[:, 1], (n, 3))
    cov = {"t": np.arange(n, dtype=float) * 600.0,
           "temperatures": {s: table[:, header.index(s)] for s in sensors}}
    values = np.full((n, 6), np.nan)
    values[:, :3] = truth.volumetric_error(q)[:, :3] + rng.normal(0, NOISE * 1e-6, (n, 3))
    values[:, 2] += (table[:, 0] - table[0, 0]) * 1e-6       # delta L [um], in z
    result = diagnose(m, [PointMeasurements("spindle", q, values, cov, np.arange(n))])
    thermal = [e for e in result.effects if e.name == "thermal_drift"]
    assert len(thermal) == 1 and thermal[0].direction == "z", [e.label for e in result.effects]
    assert thermal[0].details.sensors and thermal[0].details.time_check is not None
    assert thermal[0].rms_after_um == pytest.approx(result.rms_after_um)
    assert result.rms_after_um < 0.5 * result.rms_before_um
