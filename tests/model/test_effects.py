"""Effect terms: closed forms, exact derivatives, and recovery from noisy simulated data."""

from __future__ import annotations

import math

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.model import Context, Covariates, ForceDeflection, add_terms, build_term, write_spec
from volerr_pin.fit.identify import identify
from volerr_pin.measurements import PointMeasurements

TRAVEL = (0.0, 0.5)
ARCSEC = math.pi / 180 / 3600


def ctx_for(n=25, seed=0, **kw):
    rng = np.random.default_rng(seed)
    q = rng.uniform(*TRAVEL, n)
    cov = Covariates(n, t=np.sort(rng.uniform(0, 7200, n)),
                     temperatures={"s1": rng.uniform(19, 26, n), "s2": rng.uniform(18, 22, n)},
                     forces=rng.normal(0, 50, (n, 3)),
                     directions=np.c_[rng.choice([-1.0, 1.0], n)])
    cov = Covariates(**{**cov.__dict__, **kw}) if kw else cov
    return Context(q, TRAVEL, cov, 0, "EXX")


TABLES = {
    "drift_time": ({"kind": "thermal_drift", "driver": "time", "amplitudes_um": [5.0, -2.0],
                    "time_constants_min": [20.0, 90.0], "stop_h": 1.5}, "length"),
    "drift_temp": ({"kind": "thermal_drift", "driver": "temperature", "sensors": ["s1", "s2"],
                    "coefficients_um_per_K": [1.5, -0.7], "reference_degC": [20.0, 20.0]}, "length"),
    "drift_tilt": ({"kind": "thermal_drift", "driver": "temperature", "sensors": ["s1"],
                    "coefficients_arcsec_per_K": [0.8]}, "angle"),
    "expansion_temp": ({"kind": "thermal_expansion", "driver": "temperature", "sensor": "s1",
                        "coefficient_ppm_per_K": 11.5, "reference_degC": 20.0, "origin_mm": 50.0}, "length"),
    "expansion_time": ({"kind": "thermal_expansion", "driver": "time", "strains_ppm": [20.0],
                        "time_constants_min": [45.0]}, "length"),
    "backlash": ({"kind": "backlash", "reversal_um": 4.0}, "length"),
    "force": ({"kind": "force_deflection", "force": "y", "compliance_um_per_N": [0.02, 0.01, -0.004]}, "length"),
    "pitch": ({"kind": "periodic_pitch", "period_mm": 10.0, "sine_um": [0.8, 0.2],
               "cosine_um": [-0.3, 0.1], "origin_mm": 0.0}, "length"),
}


def build(name):
    table, quantity = TABLES[name]
    return build_term(dict(table), f"test.{name}", quantity, "length", TRAVEL)


@pytest.mark.parametrize("name", list(TABLES))
def test_effect_derivatives_equal_finite_differences(name):
    spec = build(name)
    term, c = spec.term, spec.coefficients
    ctx = ctx_for()
    J = term.jacobian(c, ctx)
    for j in range(len(c)):
        h = 1e-6 * max(abs(c[j]), 1e-6)
        cp, cm = c.copy(), c.copy()
        cp[j] += h
        cm[j] -= h
        fd = (term.value(cp, ctx) - term.value(cm, ctx)) / (2 * h)
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-6, atol=1e-9 * np.abs(fd).max() + 1e-30,
                                   err_msg=term.local_names[j])
    h = 1e-7
    up = Context(ctx.position + h, TRAVEL, ctx.covariates, 0, "EXX")
    down = Context(ctx.position - h, TRAVEL, ctx.covariates, 0, "EXX")
    fd = (term.value(c, up) - term.value(c, down)) / (2 * h)
    np.testing.assert_allclose(term.position_slope(c, ctx), fd, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("name", list(TABLES))
def test_effect_round_trips_through_its_spec_table(name):
    spec = build(name)
    again = build_term(spec.term.to_spec(spec.coefficients), "again", TABLES[name][1], "length", TRAVEL)
    np.testing.assert_allclose(again.coefficients, spec.coefficients, rtol=1e-14)


def test_the_registry_reads_what_each_kind_writes():
    """One class per kind reads its table (from_spec) and writes it back (to_spec) with
    keys it accepts; the tables here cover every registered kind."""
    from volerr_pin.model._speckeys import stem_of
    from volerr_pin.model import KINDS, term_class

    geometric = [({"kind": "constant", "value_um": 1.0}, "length"),
                 ({"kind": "legendre", "coefficients_arcsec": [1.0, -2.0]}, "angle"),
                 ({"kind": "monomial", "over": "position", "coefficients_um": [1.0, 0.5]}, "length"),
                 ({"kind": "table", "positions_mm": [0, 100, 300, 500], "values_um": [0, 1, 3, 2]}, "length")]
    seen = set()
    for table, quantity in geometric + list(TABLES.values()):
        cls = term_class(table, "test")
        spec = build_term(dict(table), "test", quantity, "length", TRAVEL)
        assert type(spec.term) is cls and cls.from_spec.__func__ is not vp.model.Term.from_spec.__func__
        written = spec.term.to_spec(spec.coefficients)
        assert {stem_of(k) for k in written} <= cls.keys | {"kind", "prefix"}, written
        seen.add(table["kind"])
    assert seen == set(KINDS)
    with pytest.raises(vp.SpecError, match=r"test: unknown key\(s\) value_um for backlash \(allowed: kind, "):
        build_term({"kind": "backlash", "value_um": 1.0}, "test", "length", "length", TRAVEL)


def test_closed_forms():
    ctx = ctx_for()
    x, t, d = ctx.position, ctx.covariates.t, ctx.covariates.directions[:, 0]
    T1, T2, F = ctx.covariates.temperatures["s1"], ctx.covariates.temperatures["s2"], ctx.covariates.forces
    val = lambda name: build(name).term.value(build(name).coefficients, ctx)
    np.testing.assert_allclose(val("backlash"), 2e-6 * d)                        # +b/2, -b/2
    np.testing.assert_allclose(val("expansion_temp"), 11.5e-6 * (T1 - 20) * (x - 0.05))  # alpha dT x
    np.testing.assert_allclose(val("drift_temp"), 1.5e-6 * (T1 - 20) - 0.7e-6 * (T2 - 20))
    np.testing.assert_allclose(val("drift_tilt"), 0.8 * ARCSEC * (T1 - 20))
    u = 2 * x / 0.5 - 1
    np.testing.assert_allclose(val("force"), F[:, 1] * 1e-6 * (0.02 + 0.01 * u - 0.004 * (3 * u**2 - 1) / 2))
    ph = 2 * np.pi * x / 0.010
    np.testing.assert_allclose(val("pitch"), 1e-6 * (0.8 * np.sin(ph) - 0.3 * np.cos(ph) + 0.2 * np.sin(2 * ph)
                                                     + 0.1 * np.cos(2 * ph)), atol=1e-18)
    np.testing.assert_allclose(val("expansion_time"), 20e-6 * (1 - np.exp(-t / 2700)) * x)
    stop = 5400.0
    heat = lambda a, tau: a * (1 - np.exp(-np.minimum(t, stop) / tau))
    drift = heat(5e-6, 1200.0) + heat(-2e-6, 5400.0)
    cool = np.where(t > stop, np.exp(-(t - stop) / 1200.0), 1.0) * heat(5e-6, 1200.0) + \
        np.where(t > stop, np.exp(-(t - stop) / 5400.0), 1.0) * heat(-2e-6, 5400.0)
    np.testing.assert_allclose(val("drift_time"), np.where(t > stop, cool, drift), atol=1e-18)


def test_backlash_without_directions_is_the_mean():
    ctx = ctx_for(directions=None)
    spec = build("backlash")
    np.testing.assert_array_equal(spec.term.value(spec.coefficients, ctx), 0.0)


def test_missing_covariates_are_named():
    spec = build("drift_time")
    with pytest.raises(vp.InputError, match=r"EXX: its thermal_drift term needs the covariate t"):
        spec.term.value(spec.coefficients, ctx_for(t=None))
    spec = build("force")
    with pytest.raises(vp.InputError, match="needs the covariate forces"):
        spec.term.value(spec.coefficients, ctx_for(forces=None))
    spec = build("drift_temp")
    with pytest.raises(vp.InputError, match="needs the temperature of sensor 's1'"):
        spec.term.value(spec.coefficients, ctx_for(temperatures={}))


def test_seed004_beam_and_torsion_models():
    """Deflection F b (L^2 - b^2)^1.5 / (9 sqrt3 E I L) and torsion 32 F e a / (G pi d^4)."""
    beam = build_term({"kind": "force_deflection", "force": "x", "model": "beam", "E_GPa": 210.0,
                       "d_mm": 60.0, "L_mm": 400.0, "b_mm": 150.0}, "beam", "length", "length", TRAVEL)
    E, d, L, b = 210e9, 0.06, 0.4, 0.15
    I = math.pi * d**4 / 64
    assert beam.coefficients[0] == pytest.approx(b * (L**2 - b**2) ** 1.5 / (9 * math.sqrt(3) * E * I * L), rel=1e-14)
    torsion = build_term({"kind": "force_deflection", "force": "x", "model": "torsion", "G_GPa": 80.0,
                          "d_mm": 60.0, "e_mm": 20.0, "a_mm": 150.0}, "t", "angle", "length", TRAVEL)
    assert torsion.coefficients[0] == pytest.approx(32 * 0.02 * 0.15 / (80e9 * math.pi * 0.06**4), rel=1e-14)
    assert isinstance(beam.term, ForceDeflection) and beam.term.to_spec(beam.coefficients)["model"] == "beam"


@pytest.mark.parametrize("table,match", [
    ({"kind": "thermal_drift", "amplitudes_um": [1.0], "time_constants_s": [1.0]}, "needs driver"),
    ({"kind": "thermal_drift", "driver": "time", "amplitudes_um": [1.0], "time_constants_s": [-1.0]},
     "time constants must be positive"),
    ({"kind": "thermal_drift", "driver": "time", "amplitudes_um": [1.0], "time_constants_days": [1.0]},
     "unknown key"),
    ({"kind": "backlash", "reversal": 3.0}, "needs a unit suffix"),
    ({"kind": "periodic_pitch", "period_mm": 0.0, "sine_um": [1.0], "cosine_um": [0.0]}, "must be positive"),
    ({"kind": "force_deflection", "force": "w", "compliance_um_per_N": [1.0]}, "must be 'x', 'y' or 'z'"),
    ({"kind": "force_deflection", "force": "x", "compliance_arcsec_per_N": [1.0]}, "angle unit"),
    # issue 22: strings and booleans where numbers belong, rates the key does not take, keys
    # that would not be used, repeated sensors, impossible times and temperatures
    ({"kind": "thermal_drift", "driver": "time", "amplitudes_um": ["5"], "time_constants_s": [1.0]},
     r"bad\.amplitudes_um: expected a number, got a string '5'"),
    ({"kind": "thermal_drift", "driver": "time", "amplitudes_um": [1.0], "time_constants_s": [1.0], "stop_s": -5},
     r"bad\.stop_s: heating stops at or after t = 0"),
    ({"kind": "thermal_drift", "driver": "temperature", "sensors": ["a"], "coefficients_um": [1.0]},
     r"bad\.coefficients_um: unit 'um' does not fit; write it as e\.g\. coefficients_um_per_K"),
    ({"kind": "thermal_drift", "driver": "temperature", "sensors": ["a"], "coefficients_um_per_N": [1.0]},
     r"bad\.coefficients_um_per_N: unit 'um_per_N' does not fit"),
    ({"kind": "thermal_drift", "driver": "temperature", "sensors": ["a", "a"], "coefficients_um_per_K": [1.0, 2.0]},
     r"bad\.sensors: sensor 'a' is listed twice"),
    ({"kind": "thermal_drift", "driver": "temperature", "sensors": ["a"], "coefficients_um_per_K": [1.0],
      "reference_degC": -300.0}, r"bad\.reference_degC: -300 degC is implausible: a temperature lies within -273\.15"),
    ({"kind": "thermal_drift", "driver": "temperature", "sensors": ["a"], "coefficients_um_per_K": [1.0],
      "lag_s": "5"}, r"bad\.lag_s: expected a number, got a string"),
    ({"kind": "thermal_expansion", "driver": "temperature", "sensor": "a", "coefficient_ppm_per_K": True},
     r"bad\.coefficient_ppm_per_K: expected a number, got a boolean"),
    ({"kind": "thermal_expansion", "driver": "temperature", "sensor": "a", "coefficient_per_K": 5.0},
     r"bad\.coefficient_per_K: 5\.0 is implausible"),
    ({"kind": "thermal_expansion", "driver": "time", "time_constants_s": [1.0]}, r"bad: missing 'strains_ppm'"),
    ({"kind": "thermal_expansion", "driver": "time", "strains_ppm": [20.0], "time_constants_s": [0.0]},
     r"bad\.time_constants_s: time constants must be positive"),
    ({"kind": "force_deflection", "force": "x", "compliance_um": [1.0]},
     r"bad\.compliance_um: unit 'um' does not fit; write it as e\.g\. compliance_um_per_N"),
    ({"kind": "force_deflection", "force": "x", "model": "beam", "E_GPa": "210", "L_mm": 300, "b_mm": 150,
      "d_mm": 60}, r"bad\.E_GPa: expected a number, got a string '210'"),
    ({"kind": "force_deflection", "force": "x", "model": "beam", "L_mm": 300, "b_mm": 150, "d_mm": 60},
     r"bad: the beam model needs E_GPa"),
    ({"kind": "force_deflection", "force": "x", "model": "beam", "E_GPa": 210, "L_mm": 300, "b_mm": 150,
      "d_mm": 60, "I_mm4": 6e5}, r"bad: give either I_mm4 or the diameter d, not both"),
    ({"kind": "force_deflection", "force": "x", "model": "beam", "E_GPa": 210, "L_mm": 300, "b_mm": 150,
      "d_mm": 60, "compliance_um_per_N": [1.0]}, r"bad: compliance_um_per_N not used by the beam model"),
    ({"kind": "force_deflection", "force": "x", "compliance_um_per_N": [1.0], "E_GPa": 210},
     r"bad: E_GPa not used by a compliance \(no model\)"),
    ({"kind": "periodic_pitch", "period_mm": 10.0, "sine_um": [1e300], "cosine_um": [0.0]},
     r"bad\.sine_um: 1e\+300 um is implausible"),
    ({"kind": "periodic_pitch", "period_mm": 10.0, "sine_um": [1.0], "cosine_um": [0.0], "origin_mm": True},
     r"bad\.origin_mm: expected a number, got a boolean"),
    ({"kind": "backlash", "reversal_um": 3.0, "reversal": 3.0}, r"bad: both reversal_um and reversal given"),
    ({"kind": "periodic_pitch", "period_mm": 10.0, "sine_um": [0.0] * 51, "cosine_um": [0.0] * 51},
     r"bad\.sine_um: 51 harmonics; give 1 to 50"),
    ({"kind": "thermal_drift", "driver": "time", "amplitudes_um": [], "time_constants_s": []},
     r"bad\.amplitudes_um: 0 amplitudes; give 1 to 50"),
])
def test_bad_effect_tables(table, match):
    with pytest.raises(vp.SpecError, match=match):
        build_term(table, "bad", "length", "length", TRAVEL)


def with_effects(machine):
    return add_terms(machine, {
        "EXX": [{"kind": "backlash", "reversal_um": 3.0},
                {"kind": "periodic_pitch", "prefix": "lead", "period_mm": 20.0, "sine_um": [0.6],
                 "cosine_um": [0.2]}],
        "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "drift", "amplitudes_um": [8.0],
                "time_constants_min": [40.0]},
        "EXZ": {"kind": "force_deflection", "force": "x", "prefix": "load", "compliance_um_per_N": [0.02, 0.01]},
        "EYY": {"kind": "thermal_expansion", "driver": "temperature", "prefix": "exp", "sensor": "screw",
                "coefficient_ppm_per_K": 11.5}})


def covariates(n, seed):
    rng = np.random.default_rng(seed)
    return {"t": np.sort(rng.uniform(0, 4 * 3600, n)), "temperatures": {"screw": rng.uniform(20, 25, n)},
            "forces": np.c_[rng.uniform(-100, 100, n), np.zeros((n, 2))],
            "directions": rng.choice([-1.0, 1.0], (n, 3))}


def test_machine_sensitivity_with_covariates_equals_finite_differences(machines):
    m = with_effects(machines["vmc500"])
    rng = np.random.default_rng(3)
    q = rng.uniform(m.travel[:, 0], m.travel[:, 1], (15, 3))
    cov = covariates(15, 3)
    S = m.sensitivity(q, **cov)
    theta = m.theta
    for name in ("EXX.b", "EXX.lead.period", "EXX.lead.s1", "EZZ.drift.tau1", "EXZ.load.c1", "EYY.exp.alpha"):
        j = m.parameter_names.index(name)
        # linear coefficients: a large step (no curvature); non-linear ones: a small one
        h = (1e-5 if j in m.nonlinear_parameters else 1e-3) * max(abs(theta[j]), 1e-9)
        tp, tm = theta.copy(), theta.copy()
        tp[j] += h
        tm[j] -= h
        fd = (m.volumetric_error(q, tp, **cov) - m.volumetric_error(q, tm, **cov)) / (2 * h)
        np.testing.assert_allclose(S[:, :, j], fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max(), err_msg=name)
    Jq = m.axis_jacobian(q, **cov)
    h = 1e-7
    for j in range(3):
        qp, qm = q.copy(), q.copy()
        qp[:, j] += h
        qm[:, j] -= h
        fd = (m.tool_poses(qp, **cov)[1] - m.tool_poses(qm, **cov)[1]) / (2 * h)
        np.testing.assert_allclose(Jq[:, :3, j], fd, rtol=1e-6, atol=1e-9)


def test_effects_written_back_reload(machines, tmp_path):
    m = with_effects(machines["vmc500"])
    again = vp.load_machine(write_spec(m, tmp_path / "e.toml"))
    q = np.random.default_rng(4).uniform(m.travel[:, 0], m.travel[:, 1], (20, 3))
    cov = covariates(20, 4)
    np.testing.assert_allclose(again.volumetric_error(q, **cov), m.volumetric_error(q, **cov), atol=1e-15)


def simulate(machine, truth, n, noise, seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(machine.travel[:, 0], machine.travel[:, 1], (n, 3))
    cov = covariates(n, seed)
    values = np.full((n, 6), np.nan)
    values[:, :3] = truth.volumetric_error(q, **cov)[:, :3] + rng.normal(0, noise, (n, 3))
    return PointMeasurements("simulated", q, values, cov, np.arange(n))


def test_recovery_of_a_time_constant_and_a_period_from_noisy_data(machines):
    """Start far from the truth (time constant 10 min vs 40, period 21 mm vs 20, amplitudes
    zero): the grid search and Gauss-Newton recover them within 3 standard uncertainties."""
    base = machines["vmc500"]
    truth = with_effects(base)
    model = truth.with_theta(truth.theta)
    names = list(truth.parameter_names)
    start = truth.theta.copy()
    start[names.index("EZZ.drift.tau1")] = 600.0
    start[names.index("EZZ.drift.a1")] = 0.0
    start[names.index("EXX.lead.period")] = 0.021
    start[names.index("EXX.lead.s1")] = start[names.index("EXX.lead.c1")] = 0.0
    start[names.index("EXX.b")] = 0.0
    model = truth.with_theta(start)
    terms = ["EXX", "EZZ"]
    data = simulate(model, truth, 900, 0.3e-6, seed=5)
    res = identify(model, [data], terms=terms, folds=0, sigma_um=0.3)
    for name in ("EZZ.drift.tau1", "EZZ.drift.a1", "EXX.lead.period", "EXX.lead.s1", "EXX.b"):
        j = names.index(name)
        assert abs(res.machine.theta[j] - truth.theta[j]) < 3 * res.uncertainty[j], name
    assert res.rms_fit_um == pytest.approx(np.sqrt(3) * 0.3, rel=0.1)


def test_geometry_drift_and_backlash_together_fit_to_the_noise_level(machines):
    base = machines["vmc500"]
    truth = add_terms(base, {
        "EXX": {"kind": "backlash", "reversal_um": 4.0},
        "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "drift", "amplitudes_um": [10.0],
                "time_constants_min": [30.0]}})
    rng = np.random.default_rng(6)
    truth = truth.with_theta(truth.theta * (1 + 0.3 * rng.normal(size=len(truth.theta))))
    prior = add_terms(base, {
        "EXX": {"kind": "backlash", "reversal_um": 0.0},
        "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "drift", "amplitudes_um": [0.0],
                "time_constants_min": [60.0]}})
    data = simulate(prior, truth, 800, 0.3e-6, seed=7)
    res = identify(prior, [data], folds=4, sigma_um=0.3)
    assert res.rms_fit_um == pytest.approx(np.sqrt(3) * 0.3, rel=0.1)
    assert res.rms_holdout_um == pytest.approx(np.sqrt(3) * 0.3, rel=0.15)
    # without the effects in the model the same data are far from the noise level
    plain = identify(base, [simulate(prior, truth, 800, 0.3e-6, seed=7)], folds=0, sigma_um=0.3)
    assert plain.rms_fit_um > 3 * res.rms_fit_um
