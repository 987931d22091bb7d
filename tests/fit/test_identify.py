"""Identification: ground-truth recovery, honest identifiability, write-back, runs, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.fit.identify import identify
from volerr_pin.measurements import PointMeasurements, read_runs
from volerr_pin.model import sample, write_spec


def tool_points(machine, truth, n, noise, seed):
    q = sample(machine, n, seed=seed)
    rng = np.random.default_rng(seed)
    values = np.full((n, 6), np.nan)
    values[:, :3] = truth.volumetric_error(q)[:, :3] + rng.normal(0.0, noise, (n, 3))
    return PointMeasurements(f"simulated {machine.name}", q, values, {}, np.arange(n))


def identifiable_truth(machine, n, seed):
    """A truth that differs from the prior only in coefficients the data can determine."""
    probe = identify(machine, [tool_points(machine, machine, n, 0.0, seed)], folds=0)
    rng = np.random.default_rng(seed + 100)
    theta = machine.theta.copy()
    k = probe.fitted
    theta[k] += rng.normal(0.0, 1.0, len(k)) * np.maximum(np.abs(theta[k]), 1e-6) * 0.5
    return machine.with_theta(theta), probe


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_noiseless_recovery_of_every_identifiable_coefficient(machines, name):
    m = machines[name]
    truth, probe = identifiable_truth(m, 600, seed=1)
    res = identify(m, [tool_points(m, truth, 600, 0.0, seed=1)], folds=0, sigma_um=1e-3)
    k = res.fitted
    np.testing.assert_array_equal(k, probe.fitted)
    rel = np.abs(res.machine.theta[k] - truth.theta[k]) / np.abs(truth.theta[k]).max()
    assert rel.max() < 1e-9
    assert res.rms_fit_um < 1e-6


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_noisy_recovery_within_three_standard_uncertainties(machines, name):
    m = machines[name]
    truth, _ = identifiable_truth(m, 800, seed=2)
    noise = 0.3e-6
    res = identify(m, [tool_points(m, truth, 800, noise, seed=3)], folds=3, sigma_um=0.3)
    k = res.fitted
    z = (res.machine.theta[k] - truth.theta[k]) / res.uncertainty[k]
    assert np.all(np.abs(z) < 3.5) and np.mean(np.abs(z) < 3) > 0.97
    # RMS of the 3D residual at the noise level: sqrt(3) * 0.3 um = 0.52 um
    expected = np.sqrt(3) * 0.3
    assert res.rms_fit_um == pytest.approx(expected, rel=0.1)
    assert res.rms_holdout_um == pytest.approx(expected, rel=0.15)
    assert res.residual_sigma == pytest.approx(1.0, rel=0.1)


def test_vmc500_tool_only_data_name_angular_terms_they_cannot_separate(machines):
    """Tool-point data (one tool length) cannot tell the yaw of X from the straightness of X in
    y (its lever arm is X itself): the report names them, and the fit is still exact at the
    tool, also at points it never saw."""
    m = machines["vmc500"]
    rng = np.random.default_rng(4)
    truth = m.with_theta(m.theta * (1 + 0.5 * rng.normal(size=len(m.theta))))
    res = identify(m, [tool_points(m, truth, 600, 0.0, seed=4)], folds=0, sigma_um=1e-3)
    groups = [set(g.parameters) for g in res.groups]
    assert any({"ECX.c1"} <= g and any(p.startswith("EYX") for p in g) for g in groups)
    assert any({"EAZ.c0", "EYZ.c0"} <= g for g in groups)    # tool length lever: EAZ ~ EYZ
    assert {"ECZ.c0"} in groups                              # roll of Z: no effect at the tool
    held = {m.parameter_names[k] for k in res.held}
    assert {"ECX.c1", "ECZ.c0"} <= held
    np.testing.assert_array_equal(res.machine.theta[res.held], m.theta[res.held])  # at their priors
    q_new = sample(m, 300, seed=99)
    gap = np.abs(res.machine.volumetric_error(q_new)[:, :3] - truth.volumetric_error(q_new)[:, :3])
    assert gap.max() < 1e-10  # exact to first order; second-order remainder ~ angle^2 x lever
    assert res.to_dict()["parameters"]["ECX.c1"]["status"] == "held (not identifiable)"


def test_min_norm_convention_fits_the_same_predictions(machines):
    m = machines["vmc500"]
    rng = np.random.default_rng(5)
    truth = m.with_theta(m.theta * (1 + 0.3 * rng.normal(size=len(m.theta))))
    data = [tool_points(m, truth, 400, 0.0, seed=5)]
    a = identify(m, data, folds=0, sigma_um=1e-3)
    b = identify(m, data, folds=0, sigma_um=1e-3, convention="min-norm")
    q_new = sample(m, 100, seed=7)
    np.testing.assert_allclose(a.machine.volumetric_error(q_new)[:, :3],
                               b.machine.volumetric_error(q_new)[:, :3], atol=1e-10)
    assert b.to_dict()["convention"] == "min-norm"
    # the rank is what the data determine, whatever the convention does with the rest
    assert b.to_dict()["rank"] == a.to_dict()["rank"] < b.to_dict()["n_parameters"]


def test_the_report_carries_the_fits_covariance_and_uncertainty_propagates_it(machines, tmp_path):
    """The report's correlations and uncertainties give back s^2 (J^T J)^-1 computed here from
    the machine's own sensitivities at the fitted values (GUM 5.2); the reader of reports
    propagates them, and a report without them is read with a warning."""
    from volerr_pin.cli._common import dumps
    from volerr_pin.studies import covariance_from_report

    m = machines["vmc500"]
    truth, _ = identifiable_truth(m, 300, seed=12)
    data = tool_points(m, truth, 300, 0.3e-6, seed=12)
    res = identify(m, [data], folds=0, sigma_um=0.3)
    k = res.fitted
    J = res.machine.sensitivity(data.q)[:, :3, :][:, :, k].reshape(-1, len(k)) / 0.3e-6
    r = (data.values[:, :3] - res.machine.volumetric_error(data.q)[:, :3]).ravel() / 0.3e-6
    s2 = r @ r / (len(r) - len(k))
    expected = s2 * np.linalg.inv(J.T @ J)
    report = res.to_dict()
    corr = report["correlation"]
    assert corr["parameters"] == [m.parameter_names[i] for i in k]
    assert min(min(row) for row in corr["matrix"]) < -0.9   # a component's polynomial coefficients
    path = tmp_path / "report.json"
    path.write_text(dumps(report))
    cov = covariance_from_report(m, path)
    np.testing.assert_array_equal(cov.indices, k)
    scale = np.sqrt(np.outer(np.diag(expected), np.diag(expected)))
    np.testing.assert_allclose(cov.matrix / scale, expected / scale, rtol=0, atol=1e-6)
    del report["correlation"]
    path.write_text(dumps(report))
    with pytest.warns(UserWarning, match=r"no correlations between its 44 coefficients' uncertainties; they are "
                                         r"propagated as uncorrelated"):
        plain = covariance_from_report(m, path)
    np.testing.assert_allclose(plain.matrix, np.diag(np.diag(cov.matrix)), rtol=1e-12, atol=0)


def test_written_spec_reproduces_the_fitted_predictions(machines, tmp_path):
    m = machines["cgm4000"]
    truth, _ = identifiable_truth(m, 500, seed=6)
    res = identify(m, [tool_points(m, truth, 500, 0.2e-6, seed=6)], folds=0)
    path = write_spec(res.machine, tmp_path / "fitted.toml", {"data": ["simulated"], "rms_fit_um": res.rms_fit_um})
    again = vp.load_machine(path)
    q = sample(m, 300, seed=8)
    np.testing.assert_allclose(again.volumetric_error(q), res.machine.volumetric_error(q), rtol=0, atol=1e-12)
    text = path.read_text()
    assert "[provenance]" in text and "rms_fit_um" in text and "written" in text


def write_run(path, machine, truth, axis, column, targets, at, value, offset=0.0, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    j = machine.axes.index(axis)
    lines = [f"# axis: {axis}", "# at: " + ", ".join(f"{k}={v}" for k, v in at.items()),
             f"target_mm,cycle,direction,{column}"]
    base = {a: v * 1e-3 for a, v in at.items()}
    for cycle in (1, 2):
        for t in targets:
            q = np.array([[base.get(a, 0.0) for a in machine.axes]])
            q[0, j] = t * 1e-3
            v = value(truth.volumetric_error(q)[0]) + offset + rng.normal(0, noise)
            lines.append(f"{t},{cycle},1,{v:.9f}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_runs_and_points_together(machines, tmp_path):
    """A positioning run of X, a straightness run of X in y and tool points: the instrument
    zero (and the straightness alignment) are nuisance terms, not machine errors."""
    m = machines["vmc500"]
    truth, _ = identifiable_truth(m, 300, seed=9)
    targets = list(range(0, 501, 50))
    at = {"Y": 200, "Z": 200}
    pos = write_run(tmp_path / "x_pos.csv", m, truth, "X", "deviation_um", targets, at,
                    lambda e: e[0] * 1e6, offset=3.0)
    straight = write_run(tmp_path / "x_str.csv", m, truth, "X", "EYX_um", targets, at,
                         lambda e: e[1] * 1e6 + 0.0, offset=-1.0)
    data = [read_runs(pos), read_runs(straight), tool_points(m, truth, 300, 0.0, seed=9)]
    res = identify(m, data, folds=0, sigma_um=1e-3)
    d = res.to_dict()
    assert d["nuisance"][f"offset[positioning run {pos}]"]["value"] == pytest.approx(3.0, abs=1e-6)
    assert any(name.startswith("slope[EYX run") for name in d["nuisance"])
    assert res.rms_fit_um < 1e-6
    assert d["n_points"] == 300 + 2 * 2 * len(targets)


def test_the_runs_other_axes_are_placed_by_at_in_si_as_by_the_files_at_line(machines, tmp_path):
    """A run written at Y 200, Z 200 mm without saying so in the file: at (m) places it there as
    the file's own '# at:' line does, to the last bit; at naming no axis, or in mm, is refused."""
    m = machines["vmc500"]
    truth, _ = identifiable_truth(m, 300, seed=9)
    targets = list(range(0, 501, 50))
    at = {"Y": 200, "Z": 200}
    said = write_run(tmp_path / "said.csv", m, truth, "X", "deviation_um", targets, at, lambda e: e[0] * 1e6)
    lines = said.read_text().splitlines()
    unsaid = tmp_path / "unsaid.csv"
    unsaid.write_text("\n".join(line for line in lines if not line.startswith("# at:")) + "\n")
    points = tool_points(m, truth, 300, 0.0, seed=9)
    ref = identify(m, [read_runs(said), points], folds=0, sigma_um=1e-3).machine.theta
    got = identify(m, [read_runs(unsaid), points], folds=0, sigma_um=1e-3, at={"Y": 0.2, "Z": 0.2}).machine.theta
    np.testing.assert_array_equal(got, ref)
    with pytest.raises(vp.InputError, match="at names 'Q', not an axis of vmc500"):
        identify(m, [points], folds=0, at={"Q": 0.2})
    with pytest.raises(vp.InputError, match="Y = 200000 mm is outside its travel"):
        identify(m, [read_runs(unsaid), points], folds=0, at={"Y": 200.0})   # mm given where m is meant


def test_cli_identify_contract_and_write_back(machines, tmp_path, capsys):
    m = machines["vmc500"]
    truth, _ = identifiable_truth(m, 200, seed=10)
    data = tool_points(m, truth, 200, 0.3e-6, seed=10)
    path = tmp_path / "points.csv"
    rows = ["x,y,z,dx,dy,dz"] + [",".join(f"{v:.6f}" for v in np.r_[q * 1e3, e[:3] * 1e6])
                                 for q, e in zip(data.q, data.values)]
    path.write_text("\n".join(rows) + "\n")
    out = tmp_path / "fitted.toml"
    assert main(["identify", "vmc500", str(path), "--json", "--out", str(out), "--sigma-um", "0.3"]) == 0
    r = json.loads(capsys.readouterr().out)
    for key in ("machine", "n_points", "rank", "n_parameters", "unidentifiable", "rms_fit_um",
                "rms_holdout_um", "parameters"):
        assert key in r
    assert r["n_points"] == 200 and r["rank"] < r["n_parameters"] == 67
    assert 0.4 < r["rms_fit_um"] < 0.65 and r["rms_holdout_um"] > r["rms_fit_um"]
    assert r["parameters"]["EC0Y.c0"]["unit"] == "arcsec"
    assert vp.load_machine(out).name == "vmc500"
    assert main(["identify", "vmc500", str(path), "--terms", "EXX", "EZZ", "--degree", "3", "--folds", "0"]) == 0
    text = capsys.readouterr().out
    assert "EXX.c3" in text and "coefficients" in text


def test_cli_identify_bad_input(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text("x,y,z,dx\n1,2,3,0\n1,2,oops,0\n")
    assert main(["identify", "vmc500", str(path)]) == 2
    assert "bad.csv:3:3: column 'z': 'oops' is not a number" in capsys.readouterr().err
    path.write_text("x,y,z,dx\n1,2,3,0\n")
    assert main(["identify", "vmc500", str(path), "--terms", "EQQ"]) == 2
    assert "EQQ not among the error terms" in capsys.readouterr().err


def test_a_time_constant_in_seconds_is_not_taken_for_no_effect(machines):
    """cgm4000's angular coefficients move the tool by metres per radian, a time constant by
    nanometres per second: the zero test compares typical changes, not SI units."""
    from volerr_pin.measurements import campaign
    from volerr_pin.model import add_terms

    m = machines["cgm4000"]
    drift = {"EZX": {"kind": "thermal_drift", "driver": "time", "prefix": "d", "amplitudes_um": [6.0],
                     "time_constants_min": [50.0]}}
    truth = add_terms(m, drift)
    data = campaign(truth, 300, 0.3, 1)
    start = add_terms(m, {"EZX": dict(drift["EZX"], time_constants_min=[30.0])})
    res = identify(start, [data], folds=0)
    k = start.parameter_names.index("EZX.d.tau1")
    assert k in res.fitted and np.isfinite(res.uncertainty[k])
    assert res.machine.theta[k] == pytest.approx(3000.0, abs=3 * res.uncertainty[k])


def test_a_fit_that_did_not_converge_is_not_called_fitted(machines):
    """One Gauss-Newton step on a drift whose time constant starts far off: the report says
    where it stopped, and no coefficient is called fitted."""
    from volerr_pin.measurements import campaign
    from volerr_pin.model import add_terms

    m = machines["vmc500"]
    drift = {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [6.0],
             "time_constants_min": [50.0]}
    truth = add_terms(m, {"EZZ": drift})
    model = add_terms(m, {"EZZ": {**drift, "amplitudes_um": [1.0], "time_constants_min": [5.0]}})
    names = list(model.parameter_names)
    free = [names.index("EZZ.h.a1"), names.index("EZZ.h.tau1")]
    data = [campaign(truth, 200, 0.3, seed=2)]
    once = identify(model, data, free=free, folds=0, max_iter=1)
    assert once.solver == "iteration limit" and not once.converged
    statuses = {once.to_dict()["parameters"][n]["status"] for n in ("EZZ.h.a1", "EZZ.h.tau1")}
    assert statuses == {"not fitted: the fit stopped at the iteration limit before converging"}
    full = identify(model, data, free=free, folds=0)
    assert full.solver == "converged"
    assert full.to_dict()["parameters"]["EZZ.h.tau1"]["status"] == "fitted"
    assert full.to_dict()["parameters"]["EZZ.h.tau1"]["value"] == pytest.approx(50.0, rel=0.05)


def test_coefficients_the_data_cannot_determine_are_marked(machines):
    """Thirty points with 50 mm of noise: the fit runs, but its uncertainties exceed anything
    a machine's error could be, and the report says so instead of calling them fitted."""
    m = machines["vmc500"]
    report = identify(m, [tool_points(m, m, 30, 50e-3, seed=3)], folds=0).to_dict()
    statuses = [p["status"] for p in report["parameters"].values()]
    assert "fitted, not determined (its uncertainty exceeds any plausible value)" in statuses
    good = identify(m, [tool_points(m, m, 400, 0.3e-6, seed=3)], folds=0).to_dict()
    assert not any(p["status"].startswith("fitted, not") for p in good["parameters"].values())


def test_per_point_rms_is_the_rms_of_point_error_norms(machines):
    """One helper gives every per-point RMS: the norm of each point's position residual
    (its x, y, z rows together), then the RMS over the points that have such rows."""
    from volerr_pin.fit.identify import build_observations, point_squares, residual_rms
    from volerr_pin.measurements import PointMeasurements

    m = machines["vmc500"]
    rng = np.random.default_rng(3)
    q = rng.uniform(m.travel[:, 0], m.travel[:, 1], (7, 3))
    values = np.full((7, 6), np.nan)
    values[:, :3] = rng.normal(0, 1e-6, (7, 3))
    values[2, 1] = np.nan                      # a point with two components only
    values[:4, 3] = rng.normal(0, 1e-6, 4)     # rotations at four points
    obs = build_observations(m, [PointMeasurements("t", q, values, {}, np.arange(7))])
    r = rng.normal(0, 1e-6, len(obs.y))
    norms = [np.sqrt(sum(r[k] ** 2 for k in range(len(r)) if obs.point[k] == i and not obs.angular[k]))
             for i in range(7)]
    assert residual_rms(obs, r) == pytest.approx(np.sqrt(np.mean(np.square(norms))) * 1e6, rel=1e-12)
    rot = [abs(r[k]) for k in range(len(r)) if obs.angular[k]]
    assert residual_rms(obs, r, angular=True) == pytest.approx(np.sqrt(np.mean(np.square(rot))) * 1e6, rel=1e-12)
    np.testing.assert_allclose(point_squares(np.array([5, 2, 5]), np.array([1.0, 2.0, 3.0])), [4.0, 10.0])


# ------------------------------------------------------------------ bad or extreme inputs
@pytest.fixture(scope="module")
def small_points(machines):
    m = machines["vmc500"]
    return tool_points(m, m, 40, 0.3e-6, seed=21)


@pytest.mark.parametrize("option, value, match", [
    ("sigma_um", 0, "sigma_um must be positive and finite, got 0"),
    ("sigma_um", -1, "sigma_um must be positive and finite, got -1"),
    ("sigma_um", float("nan"), "sigma_um must be positive and finite, got nan"),
    ("sigma_um", float("inf"), "sigma_um must be positive and finite, got inf"),
    ("sigma_urad", 0, "sigma_urad must be positive and finite, got 0"),
    ("sigma_urad", float("nan"), "sigma_urad must be positive and finite, got nan"),
    ("folds", 1, r"folds must be 0 or >= 2 \(0: no cross-validation\), got 1"),
    ("folds", -3, "folds must be 0 or >= 2"),
    ("folds", 2.5, "folds must be a whole number, got 2.5"),
    ("holdout", 0.0, "holdout must be a fraction between 0 and 1"),
    ("holdout", 1.0, "holdout must be a fraction between 0 and 1"),
    ("holdout", float("nan"), "holdout must be a fraction between 0 and 1"),
    ("seed", -1, "seed must be >= 0, got -1"),
    ("max_iter", 0, "max_iter must be >= 1, got 0"),
    ("tol", 0.0, "tol must be positive and finite"),
    ("rtol", float("inf"), "rtol must be positive and finite"),
    ("rtol", 2.0, "rtol must be below 1"),
    ("free", [10_000], "free: 10000 is not the index of a coefficient of vmc500"),
    ("free", [-1], "free: -1 is not the index of a coefficient"),
    ("convention", "least", "convention must be 'prior' or 'min-norm'"),
])
def test_bad_numeric_parameters_are_refused_naming_them(machines, small_points, option, value, match):
    with pytest.raises(vp.InputError, match=match) as err:
        identify(machines["vmc500"], [small_points], **{option: value})
    assert err.value.parameters == (option,)


def test_a_holdout_that_leaves_no_pose_to_fit_is_refused(machines, small_points):
    """Forty points: a split holding out 99.9 % of the poses keeps none to fit."""
    with pytest.raises(vp.InputError, match="holdout 0.999 of 40 poses holds out 40: none is left to fit"):
        identify(machines["vmc500"], [small_points], holdout=0.999)


def test_observations_a_fit_cannot_use_are_refused_naming_the_line(machines, small_points):
    from volerr_pin.fit.identify import build_observations

    m = machines["vmc500"]
    values = small_points.values.copy()
    values[3, 0] = np.inf
    bad = PointMeasurements("pts.csv", small_points.q, values, {}, np.arange(2, 42))
    with pytest.raises(vp.InputError, match="pts.csv:5: observation value is not a finite number"):
        identify(m, [bad])
    obs = build_observations(m, [small_points])
    obs.sigma[4] = 0.0
    with pytest.raises(vp.InputError, match="observation standard deviation is not a positive finite number"):
        identify(m, obs)


def test_data_too_large_to_fit_are_refused_and_a_fit_is_never_non_finite(machines, small_points):
    """A deviation of 1e300 um made a fit report an infinite RMS and write 1e296 into a spec.
    Such a value is refused naming its line; anything below the limit gives a finite fit."""
    m = machines["vmc500"]
    values = small_points.values.copy()
    values[5, 0] = 1e294
    data = PointMeasurements("pts.csv", small_points.q, values, {}, np.arange(40))
    with pytest.raises(vp.InputError, match=r"pts.csv:5: observation 1e\+300 um is too large to fit"):
        identify(m, [data])
    values[5, 0] = 1e90   # 1e96 standard deviations: still fitted (far from linear), every number finite
    res = identify(m, [PointMeasurements("pts.csv", small_points.q, values, {}, np.arange(40))], folds=2,
                   max_iter=3)
    d = res.to_dict()
    numbers = [d["rms_fit_um"], d["rms_holdout_um"], d["residual_sigma"]] + [
        v for p in d["parameters"].values() for v in (p["value"], p["uncertainty"]) if v is not None]
    assert np.all(np.isfinite(numbers)) and d["rms_fit_um"] > 1e90


def test_an_ill_conditioned_fit_says_so(machines):
    """With the identifiability tolerance turned off (rtol 1e-30) the fit keeps coefficients the
    tool point cannot separate: its design is numerically rank-deficient, which a warning and
    the report say, and the coefficients it cannot separate are marked as not determined."""
    m = machines["vmc500"]
    data = [tool_points(m, m, 100, 0.3e-6, seed=1)]
    with pytest.warns(UserWarning, match=r"the fit is ill-conditioned: its column-scaled design .* is "
                                         r"numerically rank-deficient, beyond what double precision resolves"):
        res = identify(m, data, folds=0, rtol=1e-30, sigma_um=0.3)
    d = res.to_dict()
    assert res.ill_conditioned and d["ill_conditioned"] is True
    assert any(p["status"].startswith("fitted, not determined") for p in d["parameters"].values())
    assert identify(m, data, folds=0).to_dict()["ill_conditioned"] is False


def test_one_point_one_pose_and_one_object(machines, small_points):
    """The smallest inputs give an honest report: one point fits (no degrees of freedom, so no
    residual sigma), points all at one pose cannot be cross-validated, and a single
    measurement object is taken as a list of one."""
    m = machines["vmc500"]
    one = PointMeasurements("one", small_points.q[:1], small_points.values[:1], {}, np.arange(1))
    res = identify(m, one)
    assert res.n_points == 1 and np.isnan(res.residual_sigma) and res.rms_holdout_um is None
    assert res.holdout == "too few poses for 5-fold cross-validation"
    same = PointMeasurements("same", np.repeat(small_points.q[:1], 12, axis=0),
                             np.repeat(small_points.values[:1], 12, axis=0), {}, np.arange(12))
    assert identify(m, [same]).rms_holdout_um is None
    with pytest.raises(vp.InputError, match="holdout 0.5 of 1 pose holds out 1: none is left to fit"):
        identify(m, [same], holdout=0.5)


def test_chunked_design_gives_the_fit_of_the_whole_design(machines, monkeypatch):
    """The fit reduces its design chunk by chunk (so it never holds every point's
    sensitivities); chunks of 64 points give the one-chunk result to rounding."""
    import volerr_pin.fit.identify._design as design

    m = machines["cgm4000"]
    truth, _ = identifiable_truth(m, 300, seed=5)
    data = [tool_points(m, truth, 300, 0.3e-6, seed=5)]
    whole = identify(m, data, folds=0, sigma_um=0.3)
    monkeypatch.setattr(design, "CHUNK_BYTES", 1)
    chunked = identify(m, data, folds=0, sigma_um=0.3)
    np.testing.assert_array_equal(chunked.fitted, whole.fitted)
    k = whole.fitted
    np.testing.assert_allclose(chunked.machine.theta[k], whole.machine.theta[k], rtol=1e-9,
                               atol=1e-9 * np.abs(whole.machine.theta[k]).max())
    np.testing.assert_allclose(chunked.uncertainty[k], whole.uncertainty[k], rtol=1e-8)
    assert chunked.rms_fit_um == pytest.approx(whole.rms_fit_um, rel=1e-10)


def test_cli_identify_refuses_bad_options_in_one_line(tmp_path, capsys):
    path = tmp_path / "points.csv"
    path.write_text("x,y,z,dx,dy,dz\n" + "".join(f"{10 * i},{5 * i},{2 * i},0.1,0.2,0.3\n" for i in range(12)))
    for argv, message in ((["--sigma-um", "0"], "--sigma-um must be positive and finite, got 0.0"),
                          (["--sigma-um", "nan"], "--sigma-um must be positive and finite, got nan"),
                          (["--sigma-urad", "-1"], "--sigma-urad must be positive and finite, got -1.0"),
                          (["--folds", "1"], "--folds must be 0 or >= 2"),
                          (["--holdout", "2"], "--holdout must be a fraction between 0 and 1"),
                          (["--seed", "-4"], "--seed must be >= 0, got -4")):
        assert main(["identify", "vmc500", str(path), *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_one_term_given_as_a_string_is_that_term(machines, small_points):
    m = machines["vmc500"]
    one = identify(m, [small_points], terms="EXX", folds=0)
    listed = identify(m, [small_points], terms=["EXX"], folds=0)
    np.testing.assert_array_equal(one.free, listed.free)
    assert {m.parameter_names[k].split(".")[0] for k in one.free} == {"EXX"}


def test_observations_built_by_hand_must_be_consistent(machines, small_points):
    from volerr_pin.fit.identify import build_observations

    m = machines["vmc500"]
    obs = build_observations(m, [small_points])
    obs.point = obs.point.copy()
    obs.point[0] = 99
    with pytest.raises(vp.InputError, match="obs.point refers to points outside 0 to 39"):
        identify(m, obs)
    obs = build_observations(m, [small_points])
    obs.sigma = obs.sigma[:-1]
    with pytest.raises(vp.InputError, match=r"obs.sigma has shape \(119,\); expected \(120,\)"):
        identify(m, obs)


def test_cli_says_an_ill_conditioned_fit_in_one_note_and_the_report(tmp_path, capsys, monkeypatch):
    """The limit lowered to 1 makes any fit ill-conditioned: the command prints the warning as
    one note and the JSON report carries the flag."""
    import volerr_pin.fit.identify._solver as solver

    monkeypatch.setattr(solver, "CONDITION_LIMIT", 1.0)
    path = tmp_path / "points.csv"
    path.write_text("x,y,z,dx,dy,dz\n" + "".join(f"{10 * i},{5 * i},{2 * i},0.1,0.2,0.3\n" for i in range(12)))
    assert main(["identify", "vmc500", str(path), "--json", "--folds", "0"]) == 0
    captured = capsys.readouterr()
    notes = [line for line in captured.err.splitlines() if "ill-conditioned" in line]
    assert len(notes) == 1 and notes[0].startswith("volerr: note: the fit is ill-conditioned: its column-scaled design")
    assert json.loads(captured.out)["ill_conditioned"] is True


@pytest.mark.parametrize("noise", [0.0, 0.3e-6])
def test_the_solver_returns_the_factor_at_its_coefficients_reducing_each_design_once(machines, monkeypatch, noise):
    """The triangular factor and residual a fit returns (its uncertainties and residual RMS)
    are those of the returned coefficients, and no design is reduced twice at the same
    coefficients (a fit that stops without a step reuses the last one)."""
    import volerr_pin.fit.identify._solver as solver
    from volerr_pin.fit.identify import FitPoints, build_observations
    from volerr_pin.fit.identify._design import reduce_design

    m = machines["vmc500"]
    truth, probe = identifiable_truth(m, 300, seed=7)
    obs = build_observations(m, [tool_points(m, truth, 300, noise, seed=7)], sigma_um=0.3)
    points = FitPoints.of(m.model, obs)
    seen = []

    def counted(points_, theta, columns, nuisance, first_order=False):
        seen.append(np.concatenate([theta, nuisance]))
        return reduce_design(points_, theta, columns, nuisance, first_order)

    monkeypatch.setattr(solver, "reduce_design", counted)
    start = m.theta.copy()
    for run in range(2):  # from the prior (it stops after a step), then from its own solution
        seen.clear()
        theta, nuisance, R, r, iterations, status = solver.solve(points, start, probe.fitted, None, "prior", 50,
                                                                 1e-8)
        assert status == "converged"
        assert len(seen) == len({v.tobytes() for v in seen})       # never twice at one point
        r_again, R_again = reduce_design(points, theta, probe.fitted, nuisance)
        np.testing.assert_array_equal(r, r_again)
        np.testing.assert_array_equal(R, R_again[:, :-1])
        start = theta
    assert iterations == 1                                         # no step from the solution


def test_the_stacked_factor_is_that_of_the_whole_weighted_design():
    """Blocks factored one after another on top of the factor so far give the factor of the
    whole design divided row by row by sigma (R^T R = J^T J; |R| as numpy's QR gives it, to
    rounding), whatever the sizes: more rows than columns, fewer, none."""
    from volerr_pin.fit.identify._design import stacked_factor

    rng = np.random.default_rng(5)
    n = 7
    R = np.zeros((0, n))
    blocks = []
    for rows in (3, 40, 0, 500):
        parts = [rng.normal(size=(rows, 2)) * 1e3, rng.normal(size=(rows, 4)) * 1e-4, rng.normal(size=rows)]
        sigma = rng.uniform(0.5, 2.0, rows) * 1e-6
        blocks.append(np.column_stack(parts) / sigma[:, None])
        R = stacked_factor(R, parts, sigma)
        J = np.vstack(blocks)
        assert R.shape == (min(len(J), n), n)
        assert np.allclose(np.tril(R, -1), 0.0)
        assert R.T @ R == pytest.approx(J.T @ J, rel=1e-12, abs=1e-12 * np.abs(J.T @ J).max())
        if len(J):
            assert np.abs(R) == pytest.approx(np.abs(np.linalg.qr(J, mode="r")), rel=1e-9, abs=1e-9 * np.abs(R).max())
    with pytest.raises(ValueError, match="6 columns, the factor 7"):
        stacked_factor(R, [np.ones((2, 6))], np.ones(2))
    seen = []
    stacked_factor(R, [np.ones((2, 6)), np.array([1.0, np.inf])], np.ones(2), seen.append)
    assert len(seen) == 1 and not np.isfinite(seen[0]).all() and seen[0].shape == (2, 7)


def test_the_design_reduced_in_two_halves_is_the_whole_designs(machines, monkeypatch):
    """From SPLIT_POINTS points the design is reduced in two halves whose factors are factored
    again: the same residual and the same factor to rounding as one pass over every chunk
    (R^T R = J^T J, the design built here row by row). Not to the last bit: a point's
    prediction may round differently in a batch of another length (the compiled kernels'
    vector loops and their remainders), and nothing exchanges halves any more."""
    from volerr_pin.fit.identify import FitPoints, build_observations
    from volerr_pin.fit.identify import _design as design
    from volerr_pin.fit.identify import predict_observations
    from volerr_pin.fit.identify._design import reduce_design

    m = machines["vmc500"]
    truth, probe = identifiable_truth(m, 300, seed=7)
    data = tool_points(m, truth, 300, 0.3e-6, seed=7)
    obs = build_observations(m, [data], sigma_um=0.3)
    points = FitPoints.of(m.model, obs)
    theta, nuisance, columns = truth.theta, np.zeros(obs.nuisance.shape[1]), probe.fitted
    r, R = reduce_design(points, theta, columns, nuisance)
    assert len(design.point_chunks(obs, len(columns))) == 2
    pred, A = predict_observations(points, theta, columns)
    J = np.column_stack([obs.nuisance, A, obs.y - pred - obs.nuisance @ nuisance]) / obs.sigma[:, None]
    assert R.T @ R == pytest.approx(J.T @ J, rel=1e-10, abs=1e-12 * np.abs(J.T @ J).max())
    scale = np.abs(J[:, -1]).max()
    np.testing.assert_allclose(r, J[:, -1], rtol=1e-12, atol=1e-14 * scale)
    monkeypatch.setattr(design, "SPLIT_POINTS", 10**9)   # one chunk, one pass
    r_one, R_one = reduce_design(points, theta, columns, nuisance)
    np.testing.assert_allclose(r, r_one, rtol=1e-12, atol=1e-14 * scale)
    assert np.abs(R) == pytest.approx(np.abs(R_one), rel=1e-9, abs=1e-9 * np.abs(R).max())
    monkeypatch.undo()
