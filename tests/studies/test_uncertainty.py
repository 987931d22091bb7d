"""Uncertainty studies: linear propagation and Monte Carlo side by side, on Dask.

Monte Carlo is held to the linear propagation where the model is linear (within its
sampling error), to the second-order closed form where it is not (a large rotary error),
and to itself across engines (bit-identical with one worker and a two-process cluster on the
loopback). The covariance sources are held to what they read and to an independent
simulation of the campaign they describe.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.studies import (Covariance, DaskEngine, Evaluator, InProcess, PortableMachine, covariance_from_campaign,
                                covariance_from_report, grid_points, make_points, run_monte_carlo)
from volerr_pin.studies._montecarlo import NormalSource, point_quantiles
from volerr_pin.studies._engine import chunk_rng
from volerr_pin.cli._common import in_cli_words
from volerr_pin.base import InputError
from volerr_pin.studies._uncertainty import (K95, compare_scalar, compensated_points, numerical_tolerance,
                                            study_uncertainty, table_compensation, z_family)
from volerr_pin.model import grid

ARM = "examples/data/two_link_arm.urdf"


@pytest.fixture(scope="module")
def engine(cluster):
    from distributed import Client

    client = Client(cluster)
    eng = DaskEngine(client, "test cluster", owned=(client,))
    yield eng
    eng.close()


def arm():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    return vp.load_machine(root / ARM, tool_frame="tool0", workpiece_frame="world")


# ------------------------------------------------------------------ building blocks


def test_chunk_streams_are_the_spawned_children_of_the_seed():
    for k in (0, 3, 17):
        child = np.random.SeedSequence(42).spawn(20)[k]
        assert np.array_equal(chunk_rng(42, k).random(5), np.random.default_rng(child).random(5))
    assert not np.array_equal(chunk_rng(42, 0).random(5), chunk_rng(42, 1).random(5))


@pytest.mark.parametrize("name", ["vmc500", "cgm4000", "gear_roller", "lathe_2axis"])
def test_the_evaluator_is_the_machine_s_volumetric_error(machines, name):
    """Many vectors in one kernel call, through the bases, equal one call per vector."""
    m = machines[name]
    q = grid(m, 3)
    rng = np.random.default_rng(1)
    thetas = m.theta + rng.normal(size=(7, len(m.theta))) * np.maximum(np.abs(m.theta), 1e-5)
    ev = Evaluator(m)
    assert ev.linear
    got = ev.errors(q, thetas, key="block")
    again = ev.errors(q, thetas, key="block")  # from the kept bases
    want = np.stack([m.volumetric_error(q, t)[:, :3] for t in thetas])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    assert np.array_equal(got, again)
    ev.linear = False  # the path of machines with non-linear coefficients
    np.testing.assert_allclose(ev.errors(q, thetas), want, rtol=0, atol=1e-15)


def test_a_machine_travels_to_other_processes_as_spec_and_urdf_text(machines):
    import pickle

    m = machines["cgm4000"].with_state()
    portable = pickle.loads(pickle.dumps(PortableMachine(m)))
    rebuilt = portable.machine()
    q = grid(m, 3)
    assert rebuilt is not m and np.array_equal(rebuilt.volumetric_error(q), m.volumetric_error(q))


def test_numerical_tolerance_is_gum_s1_7_9_2():
    # u = 1.2 um to two significant digits: 12 x 10^-1, delta = 0.05
    np.testing.assert_allclose(numerical_tolerance(1.234), 0.05)
    np.testing.assert_allclose(numerical_tolerance(0.0456), 0.0005)
    assert numerical_tolerance(0.0) == 0.0
    assert z_family(1) == pytest.approx(3.2905, abs=1e-4) and z_family(1000) > z_family(10)


def test_compare_scalar_agrees_on_a_normal_sample_and_not_on_a_shifted_one():
    rng = np.random.default_rng(0)
    draws = 10.0 + 0.5 * rng.standard_normal(200_000)
    assert compare_scalar(10.0, 0.5, draws, z_family(4)).agree
    assert not compare_scalar(10.0, 0.5, draws + 0.2, z_family(4)).agree
    assert not compare_scalar(10.0, 0.4, draws, z_family(4)).agree


# ------------------------------------------------------------------ Done when: linear case


def test_monte_carlo_matches_linear_propagation_where_the_model_is_linear(machines):
    """Small uncertainties (a 0.1 um instrument): every point's mean and standard deviation
    of dx, dy, dz, and the max and RMS intervals, agree within the sampling error."""
    m = machines["vmc500"]
    cov = covariance_from_campaign(m, 0.1e-6, points=100)
    n = 4000
    study = study_uncertainty(cov, grid(m, 4), samples=n, seed=5, interval_samples=1000)
    f = study.map
    u_lin, u_mc = f.linear.u[:, :3], f.mc_std[:, :3]
    z = z_family(6 * len(f.q))
    assert np.all(np.abs(u_mc / u_lin - 1) < z / math.sqrt(2 * (n - 1)))
    assert np.all(np.abs(f.mc_mean[:, :3] - f.estimate[:, :3]) < z * u_mc / math.sqrt(n))
    report = study.to_dict()["map"]
    assert report["agree"] and report["points_disagreeing"] == 0 and report["worst_disagreement"] is None
    # the interval per point: estimate +- 1.96 u within its sampling error (1000 draws)
    half = (f.interval[:, :3, 1] - f.interval[:, :3, 0]) / 2
    np.testing.assert_allclose(half / (K95 * u_lin), 1.0, atol=0.12)
    # the max over the points: a linear function at the worst point, so its u is that point's
    # uncertainty along the error
    worst = f.linear.worst
    assert f.linear.max_u == pytest.approx(f.linear.u[worst, 3], rel=1e-12)
    assert f.max.mc_std == pytest.approx(f.linear.max_u, rel=0.08)


# ------------------------------------------------------------------ Done when: non-linear case


def test_large_rotary_errors_make_monte_carlo_and_linear_propagation_disagree():
    """A 0.2 rad standard uncertainty of the shoulder's angular positioning: the tool point
    at radius r moves by (R(phi) - I) p. Monte Carlo finds the mean shifted towards the axis
    by r (1 - exp(-sigma^2 / 2)) and a radial spread r sqrt((1 + exp(-2 sigma^2)) / 2 - exp(-sigma^2)),
    which the linear propagation (mean 0, radial u 0, tangential r sigma) cannot see."""
    m = arm()
    sigma = 0.2
    k = m.parameter_names.index("EC_shoulder.c0")
    cov = Covariance(m, np.array([k]), np.array([[sigma**2]]), "test")
    q = grid(m, 4)
    n = 4000
    study = study_uncertainty(cov, q, samples=n, seed=2, interval_samples=500)
    f = study.map
    _, p = m.tool_poses(q, nominal=True)
    r = np.linalg.norm(p[:, :2], axis=1)
    radial = p[:, :2] / r[:, None]
    tangential = radial @ np.array([[0.0, 1.0], [-1.0, 0.0]])
    mean = f.mc_mean[:, :2]
    shift = -np.einsum("ij,ij->i", mean, radial)
    expected_shift = r * (1 - math.exp(-sigma**2 / 2))
    spread_radial = r * math.sqrt((1 + math.exp(-2 * sigma**2)) / 2 - math.exp(-sigma**2))
    spread_tangential = r * math.sqrt((1 - math.exp(-2 * sigma**2)) / 2)
    se_radial, se_tangential = spread_radial / math.sqrt(n), spread_tangential / math.sqrt(n)
    assert np.all(np.abs(shift - expected_shift) < 5 * se_radial)   # the closed form, within sampling
    assert np.all(shift > 20 * se_radial)                             # far beyond the sampling error
    assert np.all(np.abs(np.einsum("ij,ij->i", mean, tangential)) < 5 * se_tangential)
    # the linear propagation: no shift, no radial spread, tangential r sigma
    np.testing.assert_allclose(f.estimate[:, :3], 0.0, atol=1e-15)
    u_lin = f.linear.u[:, :2]
    np.testing.assert_allclose(np.sqrt(np.sum(u_lin**2, axis=1)), r * sigma, rtol=1e-9)
    # Monte Carlo's total spread is r sqrt(2 (1 - exp(-sigma^2 / 2))), below r sigma
    u_mc = np.sqrt(np.sum(f.mc_std[:, :2] ** 2, axis=1))
    np.testing.assert_allclose(u_mc, r * math.sqrt(2 * (1 - math.exp(-sigma**2 / 2))), rtol=0.05)
    assert f.disagree.all()
    report = study.to_dict()["map"]
    assert not report["agree"] and report["points_disagreeing"] == len(q)
    assert report["worst_disagreement"]["bias_um"] > 1000.0


# ------------------------------------------------------------------ Done when: engines


def test_one_worker_and_a_two_process_cluster_give_the_same_numbers(machines, engine):
    """The same seed in this process and on two worker processes on the loopback: every
    number bit-identical (draws per chunk, results folded in task order)."""
    m = machines["vmc500"]
    cov = covariance_from_campaign(m, 1e-6, points=60)
    source = NormalSource(m.theta, cov.factor(), 11)
    points = make_points(m, grid(m, 3))
    here = run_monte_carlo(m, source, points, 600, engine=InProcess(), block=10)
    there = run_monte_carlo(m, source, points, 600, engine=engine, block=10)
    assert engine.workers == 2
    for name in ("max", "argmax", "rms", "mean", "std"):
        assert np.array_equal(getattr(here, name), getattr(there, name)), name
    assert np.array_equal(point_quantiles(m, source, points, 100),
                          point_quantiles(m, source, points, 100, engine=engine))


# ------------------------------------------------------------------ covariance sources


def _report(machine, path, values, uncertainties, correlation=None):
    from volerr_pin.fit.identify import parameter_units

    units = parameter_units(machine)
    params = {}
    for name in machine.parameter_names:
        factor, unit = units[name]
        params[name] = {"value": values.get(name, 0.0), "uncertainty": uncertainties.get(name), "unit": unit,
                        "status": "fitted" if name in uncertainties else "held (not identifiable)"}
    report = {"machine": machine.name, "parameters": params}
    if correlation is not None:
        report["correlation"] = correlation
    path.write_text(json.dumps(report))
    return path


def test_an_identification_report_gives_values_uncertainties_and_correlations(machines, tmp_path):
    m = machines["vmc500"]
    path = _report(m, tmp_path / "id.json", {"EXX.n0": 2.0, "EC0Y.c0": 4.0}, {"EXX.n0": 0.5, "EC0Y.c0": 1.5})
    with pytest.warns(UserWarning, match="no correlations between its 2 coefficients' uncertainties"):
        cov = covariance_from_report(m, path)   # a report written before identify gave them
    k = [m.parameter_names.index("EXX.n0"), m.parameter_names.index("EC0Y.c0")]
    assert list(cov.indices) == sorted(k)
    np.testing.assert_allclose(cov.machine.theta[k], [2e-6, 4 * math.pi / 180 / 3600])
    np.testing.assert_allclose(np.sqrt(np.diag(cov.matrix)), [0.5e-6, 1.5 * math.pi / 180 / 3600])
    assert cov.matrix[0, 1] == 0.0 and "EXY.c0" in cov.not_propagated
    F = cov.factor()
    np.testing.assert_allclose((F @ F.T)[np.ix_(cov.indices, cov.indices)], cov.matrix, rtol=1e-12)
    corr = {"parameters": ["EC0Y.c0", "EXX.n0"], "matrix": [[1.0, -0.6], [-0.6, 1.0]]}
    cov = covariance_from_report(m, _report(m, tmp_path / "c.json", {}, {"EXX.n0": 0.5, "EC0Y.c0": 1.5}, corr))
    assert cov.matrix[0, 1] == pytest.approx(-0.6 * 0.5e-6 * 1.5 * math.pi / 180 / 3600)


@pytest.mark.parametrize("text, match", [
    ("{\"parameters\": {\n  \"EXX.n0\": {\"value\": 1,}}}", r"id.json:2:\d+: not JSON"),
    ("[1, 2]", "no 'parameters' object"),
    ("{\"parameters\": {\"EQQ.c0\": {\"value\": 1, \"uncertainty\": 1}}}", "parameters.EQQ.c0: not a coefficient"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1, \"unit\": \"mm\"}}}", "unit 'mm'"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": -1}}}", "expected a non-negative number"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": null}}}", "no coefficient has an uncertainty"),
    # issue 44: a report read back goes through a spec's rules
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1e300, \"uncertainty\": 1}}}",
     r"parameters.EXX.n0.value: 1e\+300 um is implausible"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1e300}}}",
     r"parameters.EXX.n0.uncertainty: 1e\+300 um is implausible"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 506, \"uncertainty\": 1, \"value\": 18}}}",
     r"key 'value' is given twice in one object \(506 and 18\)"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": NaN, \"uncertainty\": 1}}}", "NaN is not a JSON number"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1}},"
     " \"correlation\": {\"parameters\": [\"EXX.n0\", \"EQQ.c0\"], \"matrix\": [[1, 0.5], [0.5, 1]]}}",
     r"correlation.parameters\[1\]: 'EQQ.c0' is not a coefficient of vmc500"),
    ("{\"machine\": \"vmc700\", \"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1}}}",
     "the report is of 'vmc700', not of 'vmc500'"),
    # issue 61: a correlation of some of the uncertain coefficients took the others as uncorrelated
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1}, \"EYY.n0\": {\"value\": 1, "
     "\"uncertainty\": 2}}, \"correlation\": {\"parameters\": [\"EXX.n0\"], \"matrix\": [[1]]}}",
     r"correlation.parameters: EYY.n0 has an uncertainty but no correlation; a correlation is used in full"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1}, \"EYY.n0\": {\"value\": 1, "
     "\"uncertainty\": 2}}, \"correlation\": {\"parameters\": [\"EXX.n0\", \"EYY.n0\"], "
     "\"matrix\": [[true, false], [false, true]]}}",
     r"correlation.matrix\[0\]\[0\] \(EXX.n0, EXX.n0\): expected a number, got True"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1}, \"EYY.n0\": {\"value\": 1, "
     "\"uncertainty\": 2}}, \"correlation\": {\"parameters\": [\"EXX.n0\", \"EYY.n0\"], "
     "\"matrix\": [[1, \"0.52\"], [\"0.52\", 1]]}}",
     r"correlation.matrix\[0\]\[1\] \(EXX.n0, EYY.n0\): expected a number, got '0.52'"),
    ("{\"parameters\": {\"EXX.n0\": {\"value\": 1, \"uncertainty\": 1}}, \"correlation\": {\"parameters\": "
     "[\"EXX.n0\"], \"matrix\": [1]}}", r"correlation.matrix: expected 1 rows of 1 numbers"),
    ("[" * 50_000 + "]" * 50_000, "nested too deep"),
])
def test_a_bad_identification_report_is_refused_naming_the_file(machines, tmp_path, text, match):
    path = tmp_path / "id.json"
    path.write_text(text)
    with pytest.raises(vp.InputError, match=match):
        covariance_from_report(machines["vmc500"], path)


def test_the_campaign_covariance_is_the_spread_of_simulated_least_squares_fits(machines):
    """Refit the determined coefficients to many noisy simulated campaigns (the same poses,
    independent noise of sigma per coordinate): their covariance is the one stated."""
    from volerr_pin.model import sample

    m = machines["vmc700"]
    sigma = 2e-6
    cov = covariance_from_campaign(m, sigma, points=40, seed=3)
    q = sample(m, 40, seed=3)
    J = m.sensitivity(q)[:, :3, :].reshape(-1, len(m.theta))[:, cov.indices]
    rng = np.random.default_rng(7)
    noise = sigma * rng.standard_normal((3000, len(J)))
    fits = np.linalg.lstsq(J, noise.T, rcond=None)[0].T         # least squares, one column per campaign
    empirical = np.cov(fits.T)
    std = np.sqrt(np.diag(cov.matrix))
    np.testing.assert_allclose(np.sqrt(np.diag(empirical)) / std, 1.0, atol=0.1)
    corr = cov.matrix / np.outer(std, std)
    np.testing.assert_allclose(empirical / np.outer(std, std), corr, atol=0.1)
    assert len(cov.indices) + len(cov.not_propagated) == len(m.theta) and cov.not_propagated


# ------------------------------------------------------------------ compensation


def test_the_residual_of_a_compensation_is_the_error_at_its_commands(machines):
    m = machines["vmc500"]
    cov = covariance_from_campaign(m, 1e-6, points=60)
    q = grid(m, 3)
    study = study_uncertainty(cov, q, samples=300, seed=1, interval_samples=100, compensation=lambda qd: qd)
    # commanding the desired positions: the residual is the error map itself
    for name in ("estimate", "mc_mean", "mc_std", "interval"):
        np.testing.assert_allclose(getattr(study.compensated, name), getattr(study.map, name), rtol=0, atol=1e-15)
    point = study_uncertainty(cov, q, samples=300, seed=1, interval_samples=100, compensation="point")
    residual = point.compensated
    assert residual.estimate[:, 3].max() < 0.02e-6          # exact point compensation at the estimate
    # ... but the machine the commands go to is uncertain: the map's uncertainty stays
    np.testing.assert_allclose(residual.linear_u_position, point.map.linear_u_position, rtol=0.02)
    report = point.to_dict()
    assert report["compensation_method"] == "point"
    # a norm at zero has no derivative: no linear interval, the Monte Carlo result alone
    for key in ("max_error_um", "rms_error_um"):
        summary = report["compensation"][key]
        assert summary["linear"] == {"applicable": False, "u": None, "low": None, "high": None}
        assert summary["agree"] is None and summary["difference_low"] is None
        mc = summary["monte_carlo"]
        assert mc["mean"] < mc["upper"] < mc["high"]
        assert report["map"][key]["linear"]["applicable"] and report["map"][key]["agree"] is not None


def test_a_summary_s_linear_interval_applies_only_away_from_zero(machines):
    """The scales behind the rule, computed here from the machine's own sensitivities: the
    worst point's largest standard deviation, and that of all points' errors stacked over
    sqrt(N); a summary within 1.96 of its scale of zero gets no linear interval."""
    from volerr_pin.studies._uncertainty import linear_propagation

    m = machines["vmc500"]
    cov = covariance_from_campaign(m, 1e-6, points=60)
    q = grid(m, 3)
    points = make_points(cov.machine, q)
    lin = linear_propagation(cov.machine, cov, points)
    S = cov.machine.sensitivity(q, parameters=cov.indices)[:, :3, :]
    C = np.einsum("nip,pq,njq->nij", S, cov.matrix, S)
    assert lin.max_scale == pytest.approx(math.sqrt(np.linalg.eigvalsh(C[lin.worst])[-1]), rel=1e-9)
    stacked = S.reshape(-1, S.shape[2]) @ cov.matrix @ S.reshape(-1, S.shape[2]).T
    assert lin.rms_scale == pytest.approx(math.sqrt(np.linalg.eigvalsh(stacked)[-1] / len(q)), rel=1e-9)
    draws = np.random.default_rng(0).normal(1e-6, 0.1e-6, 500)
    near = compare_scalar(0.5e-6, 0.1e-6, draws, 3.0, scale=0.3e-6)   # 0.5 < 1.96 x 0.3
    far = compare_scalar(1e-6, 0.1e-6, draws, 3.0, scale=0.3e-6)
    assert (near.applicable, near.agree) == (False, None) and far.applicable and far.agree is not None


def test_a_controller_s_tables_leave_the_residual_the_export_simulates(machines):
    from volerr_pin.compensation.export import Points
    from volerr_pin.compensation.export._simulate import residuals

    m = machines["vmc500"]
    cov = covariance_from_campaign(m, 1e-6, points=60)
    q = grid(m, 3)
    study = study_uncertainty(cov, q, samples=200, seed=1, interval_samples=100, compensation="linuxcnc")
    assert study.to_dict()["compensation_method"] == "linuxcnc"
    # independently: the export's own simulation of the controller applying what it read back,
    # through the machine's actual tool poses rather than the study's error + nominal poses
    command = table_compensation(cov.machine, "linuxcnc")
    at = Points(q, np.ones_like(q), np.zeros(len(q)))
    np.testing.assert_allclose(study.compensated.estimate[:, :3], residuals(cov.machine, command.export.compensation, at),
                               rtol=0, atol=1e-12)
    # per-axis tables take out part of the error (not squareness and the other cross-axis errors),
    # never all of it as exact point compensation does
    worst = study.compensated.estimate[:, 3].max()
    assert 0.02e-6 < worst < 0.8 * study.map.estimate[:, 3].max()
    np.testing.assert_allclose(study.compensated.linear_u_position, study.map.linear_u_position, rtol=0.05)


def test_tables_applied_by_direction_need_the_approach_directions(machines):
    from volerr_pin.compensation.export import Points
    from volerr_pin.compensation.export._simulate import residuals
    from volerr_pin.model import add_terms

    m = add_terms(machines["vmc500"], {"EXX": {"kind": "backlash", "prefix": "b", "reversal_um": 6.0}})
    with pytest.raises(InputError, match="direction each axis moved.*in Machine.with_state .directions=") as err:
        table_compensation(m, "linuxcnc")
    assert "in --state (directions=" in in_cli_words(err.value)
    q = grid(m, 3)
    for d in ([1, 1, 1], [-1, 1, -1]):
        moved = m.with_state(directions=d)
        command = table_compensation(moved, "linuxcnc")
        at = Points(q, np.broadcast_to(np.array(d, float), q.shape), np.zeros(len(q)))
        cpoints = compensated_points(moved, q, command)
        np.testing.assert_allclose(cpoints.reference[:, :3], residuals(moved, command.export.compensation, at), rtol=0,
                                   atol=1e-12)
        # the half reversal (3 um, its sign by the direction) is taken out: the residual in x is that
        # of the machine without the backlash, to a fraction of it (inside the travel: at its ends an
        # axis arrives from one side only, so the fit has no points for the other column's end node)
        plain = machines["vmc500"].with_state(directions=d)
        without = compensated_points(plain, q, table_compensation(plain, "linuxcnc")).reference[:, 0]
        inside = (q[:, 0] > m.travel[0, 0]) & (q[:, 0] < m.travel[0, 1])
        assert inside.sum() == 9 and np.abs(cpoints.reference[inside, 0] - without[inside]).max() < 0.1e-6


# ------------------------------------------------------------------ bad input, command line


@pytest.mark.parametrize("kwargs, match", [
    ({"samples": 0}, "samples must be a whole number >= 2"),
    ({"samples": -5}, "samples must be"),
    ({"samples": 2.5}, "samples must be"),
    ({"samples": 10, "interval_samples": 20}, "interval_samples must be a whole number from 2 to samples"),
    ({"seed": -1}, "seed must be a non-negative"),
    ({"compensation": "table"}, "compensation must be 'point', a controller .* or a callable, got 'table'"),
])
def test_bad_study_arguments_are_refused_naming_the_parameter(machines, kwargs, match):
    m = machines["vmc500"]
    cov = covariance_from_campaign(m, 1e-6, points=30)
    with pytest.raises(vp.InputError, match=match):
        study_uncertainty(cov, grid(m, 2), **kwargs)


def test_bad_grids_and_sigmas_are_refused(machines):
    m = machines["vmc500"]
    with pytest.raises(vp.InputError, match=r"grid: give 1 or 3 counts"):
        grid_points(m, [3, 3])
    with pytest.raises(vp.InputError, match="a workspace of .* points needs about .*; reduce grid"):
        grid_points(m, [100_000])
    with pytest.raises(vp.InputError, match="instrument_sigma must be a positive"):
        covariance_from_campaign(m, 0.0)


def _cli(argv, capsys):
    from volerr_pin.cli import main

    try:
        code = main(argv)
    except SystemExit as stop:  # argparse's own refusals
        code = stop.code
    out, err = capsys.readouterr()
    return code, out, err


def test_volerr_uncertainty_json_csv_and_recording(tmp_path, capsys, monkeypatch):
    from pathlib import Path

    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    out, rrd = tmp_path / "field.csv", tmp_path / "u.rrd"
    code, text, err = _cli(["uncertainty", "vmc500", "--instrument-sigma", "1", "--campaign-points", "60",
                            "--samples", "4e2", "--grid", "3", "--compensation", "point", "--workers", "0",
                            "--out", str(out), "--rrd", str(rrd), "--json"], capsys)
    assert code == 0, err
    report = json.loads(text)
    assert report["samples"] == 400 and report["workers"] == 1 and report["interval_samples"] == 400
    assert report["engine"] == "this process"
    # a count is n_parameters, as in every report; "parameters" always names coefficients
    assert isinstance(report["n_parameters"], int) and "parameters" not in report
    assert set(report["map"]) >= {"max_error_um", "rms_error_um", "u_position_um", "agree", "points_disagreeing"}
    rows = out.read_text().splitlines()
    assert len(rows) == 1 + 2 * 27 and rows[0].startswith("field,x_mm,y_mm,z_mm,dx_um,")
    assert rrd.stat().st_size > 10_000
    # the recording holds the Monte Carlo uncertainty at every point
    import rerun as rr

    found = []
    for chunk in rr.chunk.RrdReader(str(rrd)).stream():
        if chunk.entity_path == "/uncertainty/map/points":
            batch = chunk.to_record_batch()
            for name in batch.schema.names:
                if name.endswith("u_um") and "linear" not in name:
                    found.append(np.concatenate(batch.column(name).to_pylist()))
    assert found and found[0].shape == (27,) and found[0].max() > 0.1


def test_volerr_uncertainty_with_a_controller_s_tables(capsys):
    args = ["uncertainty", "vmc500", "--instrument-sigma", "1", "--campaign-points", "60", "--samples", "100",
            "--grid", "3", "--compensation", "heidenhain", "--workers", "0"]
    code, text, err = _cli(args + ["--json"], capsys)
    assert code == 0, err
    report = json.loads(text)
    assert report["compensation_method"] == "heidenhain"
    assert 0 < report["compensation"]["max_error_um"]["value"] < report["map"]["max_error_um"]["value"]
    code, text, err = _cli(args, capsys)
    assert code == 0 and "residual after heidenhain compensation over 27 points" in text, err


@pytest.mark.slow
def test_volerr_uncertainty_from_an_identify_report_on_a_scheduler(cluster, tmp_path, capsys, monkeypatch):
    from pathlib import Path

    monkeypatch.chdir(Path(__file__).resolve().parents[2])
    code, text, err = _cli(["identify", "vmc500", "examples/data/vmc500_tracker.csv",
                            "examples/data/vmc500_x_positioning.csv", "--folds", "0", "--json"], capsys)
    assert code == 0, err
    report = tmp_path / "identify.json"
    report.write_text(text)
    code, text, err = _cli(["uncertainty", "vmc500", "--from", str(report), "--samples", "300", "--grid", "3",
                            "--scheduler", cluster.scheduler_address], capsys)
    assert code == 0, err
    assert "uncertainty from identification report" in text and "max |e|" in text
    assert f"on scheduler {cluster.scheduler_address}" in text


@pytest.mark.parametrize("argv, match", [
    (["--samples", "0"], "--samples: expected a positive whole number, got 0"),
    (["--samples", "-3"], "--samples: expected a positive whole number"),
    (["--grid", "3", "3"], "--grid: give 1 or 3 counts"),
    (["--interval-samples", "50", "--samples", "20"], "--interval-samples must be a whole number from 2 to --samples"),
    (["--samples", "1"], "--samples must be a whole number >= 2, got 1"),
    (["--seed", "-2"], "--seed: expected a non-negative whole number"),
    (["--samples", "1e13"], "a study of 10,000,000,000,000 draws needs about"),
    (["--workers", "100000"], "a cluster of 100000 worker processes needs about"),
    (["--grid", "5000"], "reduce --grid"),
    (["--interval-samples", "2000000", "--samples", "3000000"], "--interval-samples: 2,000,000 draws at one point"),
    (["--campaign-points", "1000000000"], "reduce --campaign-points"),
    pytest.param(["--scheduler", "tcp://127.0.0.1:9"], "--scheduler: no Dask scheduler answers at",
                 marks=pytest.mark.slow),  # waits for the connection timeout
])
def test_volerr_uncertainty_bad_input_is_one_line(tmp_path, capsys, argv, match):
    code, out, err = _cli(["uncertainty", "vmc500", "--instrument-sigma", "1", "--campaign-points", "30",
                           *argv, *([] if {"--workers", "--scheduler"} & set(argv) else ["--workers", "0"])],
                          capsys)
    assert code == 2 and out == ""
    last = err.rstrip("\n").splitlines()[-1]
    assert match in last
    if err.startswith("usage:"):  # argparse's refusals: its usage, then one line
        assert last.startswith("volerr uncertainty: error: argument ")
    else:                         # the library's: one line
        assert err.count("\n") == 1 and last.startswith("volerr: error: ")


def test_volerr_uncertainty_refuses_a_missing_report_before_any_work(capsys, tmp_path):
    code, out, err = _cli(["uncertainty", "vmc500", "--from", str(tmp_path / "none.json")], capsys)
    assert code == 2 and err.count("\n") == 1 and "none.json" in err


# ------------------------------------------------------------------ layout


STUDY_MODULES = ["_engine", "_distributions", "_tolerances", "_montecarlo", "_evaluator", "_covariance",
                 "_uncertainty", "_sobol", "_allocation", "_tolerance"]


@pytest.mark.parametrize("name", STUDY_MODULES)
def test_the_studies_document_their_public_api(name):
    """numpydoc with Parameters / Returns / Attributes (the checker of test_docstrings.py);
    a Protocol has no constructor to document."""
    import importlib
    import typing

    from test_docstrings import problems_of

    module = importlib.import_module(f"volerr_pin.studies.{name}")
    protocols = {n for n, obj in vars(module).items() if isinstance(obj, type) and getattr(obj, "_is_protocol", False)
                 and obj is not typing.Protocol}
    problems = [p for p in problems_of(module)
                if not any(p == f"{n}: no Parameters section for the constructor" for n in protocols)]
    assert not problems, "\n".join(problems)


def test_the_studies_load_neither_pictures_nor_dask_until_asked():
    """The library imports without Rerun, matplotlib or Dask: the engine loads Dask when a
    cluster is asked for, the pictures live in viz/."""
    import subprocess
    import sys

    code = ("import sys; " + "; ".join(f"import volerr_pin.studies.{m}" for m in STUDY_MODULES)
            + "; print(*[m in sys.modules for m in ('rerun', 'matplotlib', 'distributed', 'SALib')])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "False", "False"]


def test_the_text_report_says_what_its_table_means(capsys, tmp_path):
    """Where the linear interval of a norm does not apply the table says so and the Monte Carlo
    result is given in words with its one-sided bound; the per-point and summary verdicts are
    one sentence; the position figure is called what it is; a coarse agreement test says how
    coarse."""
    args = ["uncertainty", "vmc500", "--instrument-sigma", "1", "--campaign-points", "60", "--samples", "400",
            "--grid", "3", "--compensation", "point", "--workers", "0"]
    code, text, err = _cli(args + ["--json"], capsys)
    assert code == 0, err
    report = json.loads(text)
    png = tmp_path / "u.png"
    code, text, err = _cli(args + ["--png", str(png)], capsys)
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 30_000 and f"wrote {png}" in err
    flat = " ".join(text.split())
    comp = report["compensation"]["max_error_um"]
    assert "n/a not applicable" in flat
    assert (f"max |e| {comp['value']:.3f} um lies within the uncertainty of zero: a norm has no derivative there"
            in flat)
    assert f"by Monte Carlo it is {comp['monte_carlo']['mean']:.3f} +- {comp['monte_carlo']['u']:.3f} um, below " \
           f"{comp['monte_carlo']['upper']:.3f} um with 95 % probability" in flat
    assert "standard uncertainty of the position" not in flat
    assert "position uncertainty sqrt(u_x^2 + u_y^2 + u_z^2) (the root of the trace" in flat
    verdicts = [line for line in text.splitlines() if "Monte Carlo and linear propagation agree" in line]
    assert len(verdicts) == 2 and all("everywhere" not in line for line in verdicts)
    needed = max(report["map"][k]["draws_needed"] for k in ("max_error_um", "rms_error_um"))
    assert needed > 400 and f"about {needed:,} draws would resolve delta" in flat
