"""diagnose: the hidden effect is named first, nothing is invented, results are written."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rerun as rr

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.fit.diagnosis import diagnose
from volerr_pin.measurements import campaign, off_model_geometry, write_points
from volerr_pin.model import add_terms, replace_terms

NOISE = 0.3
FLOOR = np.sqrt(3) * NOISE  # RMS of the 3D norm of the noise: 0.52 um

# hidden effect -> (name, axis or None when it acts the same through every axis, direction)
HIDDEN = {
    "drift_time": ({"EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [6.0],
                            "time_constants_min": [50.0]}}, ("thermal_drift", None, "z")),
    "drift_temperature": ({"EYZ": {"kind": "thermal_drift", "driver": "temperature", "prefix": "h",
                                   "sensors": ["column"], "coefficients_um_per_K": [2.0],
                                   "reference_degC": 21.0}}, ("thermal_drift", None, "y")),
    "expansion": ({"EXX": {"kind": "thermal_expansion", "driver": "temperature", "prefix": "h",
                           "sensor": "spindle", "coefficient_ppm_per_K": 2.0, "reference_degC": 22.0}},
                  ("thermal_expansion", "X", "x")),
    "backlash": ({"EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 4.0}}, ("backlash", "Y", "y")),
    "force": ({"EXZ": {"kind": "force_deflection", "prefix": "h", "force": "x", "compliance_um_per_N": [0.02]}},
              ("force_deflection", None, "x")),
    "pitch": ({"EXX": {"kind": "periodic_pitch", "prefix": "h", "period_mm": 25.0, "sine_um": [2.0],
                       "cosine_um": [1.0]}}, ("periodic_pitch", "X", "x")),
}
# geometric terms left out of the spec: the machine has them, the model does not
GEOMETRIC = {
    "positioning": ("EXX", ("positioning", "X", "x")),
    "angular": ("EBX", ("angular", "X", "y")),
    "straightness": ("EZX", ("straightness", "X", "z")),
}


def check_first(result, expected):
    name, axis, direction = expected
    assert result.effects, "no effect named"
    first = result.effects[0]
    assert first.name == name and first.direction == direction
    assert first.axis == axis
    assert result.rms_after_um < 1.5 * FLOOR


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("kind", list(HIDDEN))
def test_each_catalogue_effect_is_named_first(machines, kind, seed):
    m = machines["vmc500"]
    tables, expected = HIDDEN[kind]
    data = campaign(add_terms(m, tables), 400, NOISE, seed)
    check_first(diagnose(m, [data]), expected)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("kind", list(GEOMETRIC))
def test_geometric_terms_left_out_of_the_spec_are_named(machines, kind, seed):
    m = machines["vmc500"]
    component, expected = GEOMETRIC[kind]
    # the true machine has a smooth version of the component; the model lacks it entirely
    truth = replace_terms(m, {component: {"kind": "legendre", "coefficients_um" if component[1] in "XYZ"
                                          else "coefficients_arcsec": [0.0, 3.0, 2.0, -1.0][:4 if component[1] in "XYZ" else 3]}})
    base = m.with_spec(m.spec.without(component))
    check_first(diagnose(base, [campaign(truth, 400, NOISE, seed)]), expected)


@pytest.mark.slow
def test_no_effect_is_invented(machines):
    """Data from the model itself: no effect named in at least 19 of 20 seeds."""
    m = machines["vmc500"]
    named = [len(diagnose(m, [campaign(m, 400, NOISE, seed)]).effects) for seed in range(20)]
    assert sum(1 for n in named if n == 0) >= 19, named


def test_two_hidden_effects_are_both_found_the_larger_first(machines):
    m = machines["vmc500"]
    truth = add_terms(m, {**HIDDEN["backlash"][0], **HIDDEN["drift_time"][0]})  # 2 um vs 3.4 um RMS
    result = diagnose(m, [campaign(truth, 400, NOISE, 5)], sigma_um=NOISE)
    names = [(e.name, e.direction) for e in result.effects]
    assert names[:2] == [("backlash", "y"), ("thermal_drift", "z")]
    assert result.effects[0].rms_before_um > result.effects[1].rms_before_um
    assert result.rms_after_um < 1.5 * FLOOR and result.reaches_noise_floor


@pytest.mark.slow
@pytest.mark.parametrize("kind,tables,expected", [
    ("backlash", {"EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 0.9}}, ("backlash", "Y", "y")),
    ("drift", {"EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [0.9],
                       "time_constants_min": [50.0]}}, ("thermal_drift", None, "z")),
    ("force", {"EXZ": {"kind": "force_deflection", "prefix": "h", "force": "x",
                       "compliance_um_per_N": [0.0042]}}, ("force_deflection", None, "x")),
])
def test_effects_near_the_noise_are_found_correctly_or_not_at_all(machines, kind, tables, expected):
    """About 1.5x the noise (0.45 um RMS at the tool): whatever is named is the hidden effect."""
    m = machines["vmc500"]
    found = 0
    for seed in range(4):
        result = diagnose(m, [campaign(add_terms(m, tables), 400, NOISE, 100 + seed)])
        for e in result.effects[:1]:
            assert (e.name, e.axis, e.direction) == expected
            found += 1
    assert found >= 1  # and at this size it is usually found


def test_cli_contract_and_outputs(machines, tmp_path, capsys):
    m = machines["vmc500"]
    data = campaign(add_terms(m, HIDDEN["backlash"][0]), 300, NOISE, 7)
    path = tmp_path / "campaign.csv"
    write_points(data, m, path)
    spec, rrd, png = tmp_path / "out.toml", tmp_path / "d.rrd", tmp_path / "d.png"
    assert main(["diagnose", "vmc500", str(path), "--json", "--out", str(spec), "--rrd", str(rrd),
                 "--png", str(png), "--max-effects", "3"]) == 0
    r = json.loads(capsys.readouterr().out)
    for key in ("machine", "rms_before_um", "rms_after_um", "noise_floor_um", "effects"):
        assert key in r
    effect = r["effects"][0]
    assert {"name", "axis", "direction", "parameters", "rms_before_um", "rms_after_um"} <= set(effect)
    assert (effect["name"], effect["axis"], effect["direction"]) == ("backlash", "Y", "y")
    (name, p), = effect["parameters"].items()
    assert p["value"] == pytest.approx(4.0, abs=4 * p["uncertainty"]) and p["unit"] == "um"
    # the written spec reloads and carries the effect
    again = vp.load_machine(spec)
    assert name in again.parameter_names
    steps = {c.entity_path for c in rr.chunk.RrdReader(str(rrd)).stream()
             if c.entity_path.startswith("/residuals/step_") and c.entity_path.endswith("/arrows") and c.is_static}
    assert steps == {f"/residuals/step_{k}/arrows" for k in range(len(r["steps"]))} and len(steps) == 2
    assert png.stat().st_size > 30_000


def test_fixed_keeps_the_geometry_and_still_finds_the_effect(machines):
    m = machines["vmc500"]
    result = diagnose(m, [campaign(add_terms(m, HIDDEN["force"][0]), 300, NOISE, 8)], fixed=True)
    assert result.effects[0].name == "force_deflection"
    fitted = dict(zip(result.machine.parameter_names, result.machine.theta))
    np.testing.assert_array_equal([fitted[n] for n in m.parameter_names], m.theta)


def test_too_few_points_is_an_error(machines):
    m = machines["vmc500"]
    with pytest.raises(vp.InputError, match=r"6 points at 6 distinct poses: too few for folds = 5 \(k-fold "
                                            r"cross-validation needs at least 10\)"):
        diagnose(m, [campaign(m, 6, NOISE, 0)])


# ------------------------------------------------------------------ off-model geometry
# A real machine's geometry is never exactly the spec's: the true machine below has a random
# cubic polynomial (or a cubic spline through 7 uneven nodes) on every component, where the
# spec has quadratics, linear tables and cubic tables. The hidden effects ride on top.
def off_model_truth(m, seed, style, tables=()):
    truth = off_model_geometry(m, 1000 + seed, style, 1.0, 1.0)
    for t in tables:
        truth = add_terms(truth, t)
    return truth


SCENARIOS = {
    "none": ([], []),
    **{k: ([v[0]], [v[1]]) for k, v in HIDDEN.items()},
    "two": ([HIDDEN["backlash"][0], HIDDEN["drift_time"][0]], [HIDDEN["backlash"][1], HIDDEN["drift_time"][1]]),
}


def check_names(result, expected):
    """Exactly the hidden physical effects; every one significant; the rest of the residual
    explained by raising the spec's own components, down to the noise."""
    got = sorted((e.name, e.axis, e.direction) for e in result.effects)
    assert got == sorted(expected), [e.label for e in result.effects]
    for e in result.effects:
        sizes = [abs(p["value"]) / p["uncertainty"] for n, p in e.parameters.items()
                 if p["uncertainty"] and not n.endswith((".tau1", ".period"))]
        assert max(sizes) >= 3.0, e
    for u in result.under_modelled:
        assert u.component in result.base.components  # an existing component, raised
    assert result.rms_after_um < 1.3 * FLOOR


@pytest.mark.parametrize("style,kind,seed", [("cubic", "none", 0), ("spline", "backlash", 1),
                                             ("cubic", "pitch", 2), ("spline", "two", 3)])
def test_off_model_geometry_is_raised_not_blamed_on_an_effect(machines, style, kind, seed):
    m = machines["vmc500"]
    tables, expected = SCENARIOS[kind]
    result = diagnose(m, [campaign(off_model_truth(m, seed, style, tables), 400, NOISE, seed)])
    check_names(result, expected)
    assert result.under_modelled, "the geometry is off the spec's function space: say so"
    label = result.under_modelled[0].label
    assert label.startswith("geometric component E") and " under-modelled (" in label


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("kind", list(SCENARIOS))
@pytest.mark.parametrize("style", ["cubic", "spline"])
def test_off_model_geometry_sweep(machines, style, kind, seed):
    m = machines["vmc500"]
    tables, expected = SCENARIOS[kind]
    check_names(diagnose(m, [campaign(off_model_truth(m, seed, style, tables), 400, NOISE, 10 + seed)]),
                expected)


@pytest.mark.slow
@pytest.mark.parametrize("style", ["cubic", "spline"])
def test_off_model_effect_near_the_noise_is_found_correctly_or_not_at_all(machines, style):
    m = machines["vmc500"]
    tables = {"EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 0.9}}
    found = 0
    for seed in range(4):
        result = diagnose(m, [campaign(off_model_truth(m, seed, style, [tables]), 400, NOISE, 200 + seed)])
        assert [(e.name, e.axis, e.direction) for e in result.effects] in ([], [("backlash", "Y", "y")])
        found += len(result.effects)
    assert found >= 2


def test_a_long_wave_is_not_a_ball_screw(machines):
    """A 130 mm wave on a 400 mm axis is smooth geometry, not a pitch error: periodic
    candidates need a period in the ball-screw range and 4 periods inside the travel."""
    m = machines["vmc500"]
    x = np.linspace(0.0, 400.0, 41)
    truth = add_terms(m, {"EYY": {"kind": "table", "interpolation": "cubic", "prefix": "wave", "positions_mm": list(x),
                                  "values_um": list(2.0 * np.sin(2 * np.pi * x / 130.0))}})
    result = diagnose(m, [campaign(truth, 400, NOISE, 3)])
    assert [e.name for e in result.effects] == []
    assert any(u.component == "EYY" for u in result.under_modelled)


@pytest.mark.parametrize("component,by", [("EXX", 1), ("EYY", 1), ("EZZ", 2), ("EBX", 1), ("EBX", 2),
                                          ("ECZ", 1), ("EBY", 2)])
def test_a_raised_component_starts_from_the_same_function(machines, component, by):
    """Constant -> degree 1, polynomial + 1 or 2 degrees, table with a node between every
    two: the coarse function is inside the finer space, so nothing moves before the refit."""
    from volerr_pin.fit.diagnosis import geometric_term, raise_components

    m = machines["vmc500"]
    raised = raise_components(m, [(component, by)])
    q = np.random.default_rng(0).uniform(m.travel[:, 0], m.travel[:, 1], (200, 3))
    k = m.components.index(component)
    np.testing.assert_allclose(raised.component_values(q)[:, k], m.component_values(q)[:, k],
                               rtol=0, atol=1e-15)
    _, before = geometric_term(m, component)
    _, after = geometric_term(raised, component)
    if before.term.kind == "table":
        assert len(after.term.nodes) == 2 * len(before.term.nodes) - 1
    else:
        degree = 0 if before.term.kind == "constant" else before.term.degree
        assert after.term.degree == degree + by


def test_noise_floor_from_repeats_or_an_upper_bound(machines):
    m = machines["vmc500"]
    data = campaign(m, 200, NOISE, 4)
    result = diagnose(m, [data])
    assert result.noise_floor_upper_bound and "upper bound" in result.noise_floor_source
    # every point measured twice: the floor comes from the repeats, free of any model
    twice = campaign(m, 400, NOISE, 4)
    twice.q[200:] = twice.q[:200]
    for key in ("directions", "forces"):  # a repeat: same place, same approach, same load
        twice.covariates[key][200:] = twice.covariates[key][:200]
    twice.values[200:, :3] = m.volumetric_error(twice.q[200:], **{
        k: (v[200:] if not isinstance(v, dict) else {s: a[200:] for s, a in v.items()})
        for k, v in twice.covariates.items()})[:, :3] + np.random.default_rng(9).normal(0, NOISE * 1e-6, (200, 3))
    result = diagnose(m, [twice])
    assert not result.noise_floor_upper_bound and result.noise_floor_source == "repeated points (600 degrees of freedom)"
    assert result.noise_floor_um == pytest.approx(FLOOR, rel=0.15)
    assert result.to_dict()["noise_floor_upper_bound"] is False


# ------------------------------------------------------------------ bad or extreme inputs
@pytest.mark.parametrize("option, value, match", [
    ("sigma_um", 0, "sigma_um must be positive and finite, got 0"),
    ("sigma_um", float("nan"), "sigma_um must be positive and finite, got nan"),
    ("sigma_um", -1, "sigma_um must be positive and finite, got -1"),
    ("sigma_um", float("inf"), "sigma_um must be positive and finite, got inf"),
    ("sigma_urad", 0, "sigma_urad must be positive and finite, got 0"),
    ("folds", 0, "folds must be >= 2, got 0"),
    ("folds", 1, "folds must be >= 2, got 1"),
    ("alpha", 2, r"alpha must be a fraction between 0 and 1 \(both excluded\), got 2"),
    ("alpha", 0.0, "alpha must be a fraction between 0 and 1"),
    ("alpha", float("nan"), "alpha must be a fraction between 0 and 1"),
    ("max_effects", -1, "max_effects must be >= 0, got -1"),
    ("max_effects", 1.5, "max_effects must be a whole number, got 1.5"),
    ("seed", -1, "seed must be >= 0, got -1"),
    ("max_rounds", -2, "max_rounds must be >= 0, got -2"),
])
def test_bad_numeric_parameters_are_refused_naming_them(machines, option, value, match):
    m = machines["vmc500"]
    with pytest.raises(vp.InputError, match=match) as err:
        diagnose(m, [campaign(m, 30, NOISE, 0)], **{option: value})
    assert err.value.parameters == (option,)


def test_data_with_nothing_to_diagnose_are_refused(machines):
    """Rotations only (diagnose compares position residuals), or so few points that the base
    model passes through all of them (no residual: a held-out RMS of zero would be nonsense)."""
    m = machines["vmc500"]
    data = campaign(m, 40, NOISE, 0)
    data.values[:, :3], data.values[:, 3:] = np.nan, 1e-6
    with pytest.raises(vp.InputError, match="the measurements hold no position"):
        diagnose(m, [data])
    with pytest.raises(vp.InputError, match=r"30 observations at 10 points do not over-determine the base model "
                                            r"\(30 independent coefficients and nuisance terms\)"):
        diagnose(m, [campaign(m, 10, NOISE, 0)])
    same = campaign(m, 40, NOISE, 0)
    same.q[:] = same.q[0]
    with pytest.raises(vp.InputError, match="40 points at 1 distinct pose: too few for folds = 5") as err:
        diagnose(m, [same])
    assert err.value.parameters == ("folds",)


def test_a_diagnosis_too_large_for_the_memory_is_refused_before_it_starts(machines, monkeypatch):
    import volerr_pin.base._safeio as safeio

    m = machines["vmc500"]
    monkeypatch.setattr(safeio, "available_memory", lambda: 10_000_000)
    with pytest.raises(vp.InputError, match=r"diagnosing 300 points \(900 observations\) needs about .* MB of "
                                            r"memory, more than this machine can spare"):
        diagnose(m, [campaign(m, 300, NOISE, 0)])


def test_cli_diagnose_refuses_bad_options_in_one_line(machines, tmp_path, capsys):
    m = machines["vmc500"]
    path = tmp_path / "points.csv"
    write_points(campaign(m, 30, NOISE, 0), m, path)
    for argv, message in ((["--folds", "0"], "--folds must be >= 2, got 0"),
                          (["--alpha", "2"], "--alpha must be a fraction between 0 and 1"),
                          (["--max-effects", "-1"], "--max-effects must be >= 0, got -1"),
                          (["--sigma-um", "nan"], "--sigma-um must be positive and finite, got nan"),
                          (["--sigma-urad", "0"], "--sigma-urad must be positive and finite, got 0.0"),
                          (["--seed", "-1"], "--seed must be >= 0, got -1"),
                          (["--max-rounds", "-1"], "--max-rounds must be >= 0, got -1")):
        assert main(["diagnose", "vmc500", str(path), *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_evidence_and_terms_of_rounds_and_components_that_do_not_exist(machines):
    from types import SimpleNamespace

    from volerr_pin.fit.diagnosis import Step, evidence, geometric_term

    m = machines["vmc500"]
    result = SimpleNamespace(steps=[Step(0, 1.0, [], np.zeros(3))])   # one round, nothing accepted
    assert evidence(result, 0) is None
    with pytest.raises(vp.InputError, match="step: the diagnosis has rounds 0 to 0, not 3"):
        evidence(result, 3)
    with pytest.raises(vp.InputError, match="step must be >= 0, got -1"):
        evidence(result, -1)
    with pytest.raises(vp.InputError, match="component: 'EQQ' is not an error term of vmc500"):
        geometric_term(m, "EQQ")


def test_an_effect_kind_registered_as_a_plug_in_is_offered_named_and_written(machines, monkeypatch):
    """The loop asks the registry, not effect names: a new kind - a cutting load's deflection,
    offered only through the spindle body's site, with coefficients of its own prefix - replaces
    the catalogue's force deflection, is named for what it is and is written with its prefix,
    while the loop itself is untouched."""
    from volerr_pin.fit.diagnosis import EFFECTS, Candidate, EffectKind, effect_kind, register
    from volerr_pin.model import component_name

    class CuttingLoad(EffectKind):
        name, prefix = "cutting_load", "cut"

        def through_site(self, offer, site, letter):
            if site != "X":   # one site: a Cartesian machine's translation is the same through any
                return []
            return [Candidate(self.name, site, letter.lower(), component_name(letter, site),
                              {"kind": "force_deflection", "force": "xyz"[i], "compliance_um_per_N": [0.0]},
                              f"F{'xyz'[i]}") for i in offer.force_axes]

        def describe(self, cand):
            return f"cutting load along {cand.direction} from {cand.driver} ({cand.component})"

    registry = {k: v for k, v in EFFECTS.items() if k != "force_deflection"}
    monkeypatch.setattr("volerr_pin.fit.diagnosis._effects.EFFECTS", registry)
    monkeypatch.setattr("volerr_pin.fit.diagnosis._candidates.EFFECTS", registry)
    with pytest.raises(ValueError, match="a name of its own"):
        register(type("Again", (EffectKind,), {"name": "backlash"}))
    register(CuttingLoad)
    assert isinstance(effect_kind("cutting_load"), CuttingLoad)
    m = machines["vmc500"]
    result = diagnose(m, [campaign(add_terms(m, HIDDEN["force"][0]), 300, NOISE, 8)], fixed=True)
    first = result.effects[0]
    # the hidden deflection sits on Z (EXZ); through X it is the same at the tool
    assert (first.name, first.component, first.direction, first.driver) == ("cutting_load", "EXX", "x", "Fx")
    assert first.label == "cutting load along x from Fx (EXX)"
    assert first.names and all(n.startswith("EXX.cut.") for n in first.names)
    assert not any(e.name == "force_deflection" for e in result.effects + result.possible)
