"""Seed 003's thermal methods, grey models and thermal-fit (on synthetic series only)."""

from __future__ import annotations

import json
import re

import numpy as np

NOISE = 0.3
import pytest

from volerr_pin.cli import main
from volerr_pin.model import check_covariates
from volerr_pin.applications.thermal import GM11, GM1N, feed_axis_six_point, spindle_five_point
from volerr_pin.measurements import SeriesData, read_series
from volerr_pin.applications.thermalfit import thermal_fit


def test_gm11_reproduces_a_worked_example_to_the_printed_digits():
    """A worked GM(1,1) exercise (homework Q&A, method after a widely copied CSDN tutorial):
    x0 = 57.55 63.32 76.4 71.31 85.55 98.04 115.59, forecasts for k = 7..19 printed as
    125.73657 141.55648 ... 521.28995 (5 decimals)."""
    model = GM11.fit([57.55, 63.32, 76.4, 71.31, 85.55, 98.04, 115.59])
    printed = [125.73657, 141.55648, 159.36681, 179.41801, 201.99201, 227.40621, 256.01799,
               288.22963, 324.49407, 365.32123, 411.28518, 463.03222, 521.28995]
    np.testing.assert_array_equal(np.round(model.predict(20)[7:], 5), printed)


def test_gm11_recovers_an_exact_exponential():
    """For x0(k) = C e^{r k}, GM(1,1)'s least squares fit is exact: a = -2 tanh(r/2)... and the
    forecast follows the geometric series closely."""
    k = np.arange(8)
    x0 = 3.0 * np.exp(0.1 * k)
    model = GM11.fit(x0)
    assert model.a == pytest.approx(-2 * np.tanh(0.05), rel=1e-10)
    np.testing.assert_allclose(model.predict(12)[8:], 3.0 * np.exp(0.1 * np.arange(8, 12)), rtol=2e-3)


def test_gm1n_recovers_its_own_coefficients():
    rng = np.random.default_rng(0)
    n = 40
    X = np.cumsum(rng.uniform(0.0, 1.0, (n, 2)), axis=0) / 10
    a, b, lam = 0.3, np.array([0.8, -0.2]), 0.5
    model = GM1N(a, b, lam)
    y = model.simulate(0.5, X)
    fitted = GM1N.fit(y, X)
    assert fitted.a == pytest.approx(a, rel=1e-9)
    np.testing.assert_allclose(fitted.b, b, rtol=1e-9)
    np.testing.assert_allclose(fitted.one_step(y, X), y, rtol=1e-9)
    # the variable weight: on noisy data the chosen background weight predicts one step
    # ahead at least as well as the classic 0.5 (lam and a, b trade off exactly without noise)
    noisy = y + rng.normal(0, 0.05, n)
    err = lambda m: np.sqrt(np.mean((m.one_step(noisy, X)[1:] - noisy[1:]) ** 2))
    vw, classic = GM1N.fit(noisy, X, lam=None), GM1N.fit(noisy, X)
    assert 0.0 <= vw.lam <= 1.0 and err(vw) <= err(classic) + 1e-15


def test_spindle_five_point_method():
    """A mandrel shifted by (dx, dy) at the tool and tilted by (kx, ky), read at l and l + l1."""
    l, l1, l2 = 0.1, 0.05, 0.04
    dx, dy, kx, ky, growth = 3.0, -1.5, 20.0, -10.0, 7.0   # um, um/m
    s1, s3 = dx + kx * l, dx + kx * (l + l1)
    s2, s4 = dy + ky * l, dy + ky * (l + l2)
    r = spindle_five_point(s1, s2, s3, s4, -growth, l, l1, l2)
    assert r["dx"] == pytest.approx(dx) and r["dy"] == pytest.approx(dy) and r["dz"] == pytest.approx(growth)
    assert r["tilt_x"] == pytest.approx(kx) and r["tilt_y"] == pytest.approx(ky)
    assert r["tilt_share_x"] == pytest.approx((s3 - s1) * l / l1)     # the paper's printed form
    with pytest.raises(ValueError, match="l1 > 0"):
        spindle_five_point(0, 0, 0, 0, 0, 0.1, 0.0, 0.1)


def test_feed_axis_six_point_method():
    r = feed_axis_six_point(s6=2.0, s7=5.0, s8=9.0, s9=1.0, s10=4.0, s11=0.5)
    assert (r["dx"], r["dy"], r["dz"]) == (8.0, 1.5, 1.0)


def write_series(path, n=300, seed=0, noise=0.05):
    """A spindle-like run: sensors heat with different time constants, the target follows."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    T = np.c_[20 + 8 * (1 - np.exp(-t / 60)), 20 + 3 * (1 - np.exp(-t / 150)), 20 + rng.normal(0, 0.2, n)]
    y = 1.5 * (T[:, 0] - 20) - 0.8 * (T[:, 1] - 20) + rng.normal(0, noise, n)
    lines = ["\ufeffgrowth um,T_bearing,T_housing,T_ambient"] + [
        f"{y[i]:.6f},{T[i, 0]:.6f},{T[i, 1]:.6f},{T[i, 2]:.6f}" for i in range(n)]
    path.write_text("\n".join(lines) + "\n")
    return y, T


def test_static_linear_model_equals_least_squares(tmp_path):
    write_series(tmp_path / "run.csv")
    data = read_series(tmp_path / "run.csv")
    r = thermal_fit(data, "growth um", lag=0)
    y = data.columns["growth um"]
    X = np.c_[np.ones(len(y)), data.columns["T_bearing"], data.columns["T_housing"], data.columns["T_ambient"]]
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ coef
    assert r["residual_se"] == pytest.approx(np.sqrt(res @ res / (len(y) - 4)), rel=1e-10)
    assert r["r2"] == pytest.approx(1 - res @ res / ((y - y.mean()) ** 2).sum(), rel=1e-12)
    assert r["coefficients"]["T_bearing"] == pytest.approx(1.5, abs=0.02)
    assert [s["sensor"] for s in r["sensor_ranking"][:2]] == ["T_bearing", "T_housing"]
    assert r["n_fit"] == 300 and r["residual_se"] == pytest.approx(0.05, rel=0.15)


def test_one_step_model_and_holdout(tmp_path):
    y, T = write_series(tmp_path / "run.csv")
    r = thermal_fit(read_series(tmp_path / "run.csv"), "growth um", lag=2, holdout=0.25)
    assert r["n_fit"] == 225 - 2 and r["n_holdout"] == 75
    # one-step predictions of the held-out rows use the measured history
    assert r["rmse_holdout"] == pytest.approx(0.05 * np.sqrt(1 + 0.1), rel=0.3)
    assert "growth um(t-2)" in r["coefficients"]


def test_batches_and_test_files(tmp_path):
    for i in range(3):
        write_series(tmp_path / f"b{i}.csv", seed=i)
    train = read_series([tmp_path / "b0.csv", tmp_path / "b1.csv"])
    r = thermal_fit(train, "growth um", lag=1, test=read_series(tmp_path / "b2.csv"))
    assert r["n_fit"] == 2 * 299 and r["n_holdout"] == 299  # lags do not cross batches
    for method in ("gm1n", "vwgm1n", "gm11"):
        kw = {"holdout": 0.2} if method == "gm11" else {"test": read_series(tmp_path / "b2.csv")}
        sensors = None if method == "gm11" else ["T_bearing", "T_housing"]   # gm11: the target alone
        out = thermal_fit(train if method != "gm11" else read_series(tmp_path / "b0.csv"), "growth um",
                          sensors, method=method, **kw)
        assert np.isfinite(out["rmse_holdout"]) and out["lag"] is None
        assert out["sensors"] == (sensors or []) and out["left_out"] == []


def test_thermal_fit_errors(tmp_path):
    write_series(tmp_path / "run.csv")
    data = read_series(tmp_path / "run.csv")
    with pytest.raises(ValueError, match="no column 'dL'"):
        thermal_fit(data, "dL")
    with pytest.raises(ValueError, match="cannot also be a sensor"):
        thermal_fit(data, "growth um", ["growth um"])
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n3,x\n")
    with pytest.raises(ValueError, match=r"bad\.csv:3:2: column 'b': 'x' is not a number"):
        read_series(tmp_path / "bad.csv")


def test_thermal_fit_cli_contract(tmp_path, capsys):
    write_series(tmp_path / "run.csv")
    png = tmp_path / "fit.png"
    assert main(["thermal-fit", str(tmp_path / "run.csv"), "--target", "growth um", "--lag", "1",
                 "--holdout", "0.2", "--json", "--png", str(png)]) == 0
    r = json.loads(capsys.readouterr().out)
    for key in ("target", "method", "sensors", "lag", "n_fit", "r2", "residual_se", "n_holdout", "rmse_holdout"):
        assert key in r
    assert r["sensors"] == ["T_bearing", "T_housing", "T_ambient"] and png.stat().st_size > 20_000
    assert main(["thermal-fit", str(tmp_path / "run.csv"), "--target", "nope"]) == 2


# ---------------------------------------------------------------- sensors that cannot be fitted (issue 22)

def series(tmp_path, extra: dict, n=120, name="s.csv"):
    """growth = 1.5 (T_a - 20) - 0.8 (T_b - 20) + noise, plus the ``extra`` columns."""
    rng = np.random.default_rng(7)
    t = np.arange(n)
    cols = {"growth": None, "T_a": 20 + 8 * (1 - np.exp(-t / 30)), "T_b": 20 + 3 * (1 - np.exp(-t / 90))}
    cols["growth"] = 1.5 * (cols["T_a"] - 20) - 0.8 * (cols["T_b"] - 20) + rng.normal(0, 0.02, n)
    cols.update({k: v(cols) if callable(v) else v for k, v in extra.items()})
    path = tmp_path / name
    path.write_text(",".join(cols) + "\n" + "".join(
        ",".join(repr(float(np.broadcast_to(v, (n,))[i])) for v in cols.values()) + "\n" for i in range(n)))
    return read_series(path)


@pytest.mark.parametrize("extra, sensor, reason", [
    ({"T_c": 21.0}, "T_c", r"constant \(21 in every fitted row\)"),
    ({"T_a2": lambda c: c["T_a"]}, "T_a2", r"the same as 'T_a' in every fitted row"),
    ({"T_c": lambda c: 2 * c["T_a"] - c["T_b"] + 1.0}, "T_c", r"a linear combination of a constant and 'T_a', 'T_b'"),
])
def test_an_unfittable_sensor_is_refused_by_name_and_left_out_with_a_note_by_default(tmp_path, extra, sensor,
                                                                                     reason):
    data = series(tmp_path, extra)
    with pytest.raises(ValueError, match=rf"sensors: '{sensor}' is {reason}; it has no coefficient of its own"):
        thermal_fit(data, "growth", ["T_a", "T_b", sensor], lag=0)
    r = thermal_fit(data, "growth", lag=0)
    assert r["sensors"] == ["T_a", "T_b"] and [n["sensor"] for n in r["left_out"]] == [sensor]
    assert re.fullmatch(reason, r["left_out"][0]["reason"])
    assert r["coefficients"]["T_a"] == pytest.approx(1.5, abs=0.01)       # not split over two columns
    for method in ("gm1n", "vwgm1n"):
        assert thermal_fit(data, "growth", method=method)["left_out"] == r["left_out"]


def test_a_sensor_collinear_to_rounding_in_the_file_is_reported(tmp_path):
    data = series(tmp_path, {"T_c": lambda c: np.round(2 * c["T_a"] - c["T_b"], 6)})
    assert thermal_fit(data, "growth", lag=0)["left_out"][0]["sensor"] == "T_c"


@pytest.mark.parametrize("kwargs, match", [
    ({"lag": 1.5}, r"lag must be a whole number of rows, got 1\.5"),
    ({"lag": True}, r"lag must be a whole number of rows, got True"),
    ({"lag": -1}, r"lag must be >= 0, got -1"),
    ({"rank_top": -1}, r"rank_top must be an integer >= 0"),
    ({"holdout": float("nan")}, r"holdout must be a fraction in \[0, 1\), got nan"),
    ({"holdout": 0.995}, r"holdout 0\.995 leaves 1 of 120 rows to fit"),
    ({"sensors": ["T_a", "T_a"]}, r"sensors: 'T_a' is listed twice"),
    ({"sensors": ["T_a"], "method": "gm11"}, r"sensors: gm11 models the target alone"),
    ({"lag": 200}, r"0 usable rows for 203 coefficients; reduce lag"),
    ({"holdout": 0.98, "method": "gm11"}, r"2 fitted rows; gm11 needs at least 4; reduce holdout"),
])
def test_bad_thermal_fit_arguments_name_the_parameter(tmp_path, kwargs, match):
    with pytest.raises(ValueError, match=match) as err:
        thermal_fit(series(tmp_path, {}), "growth", **kwargs)
    assert err.value.parameters


def test_a_constant_target_or_no_sensor_left_is_refused(tmp_path):
    data = series(tmp_path, {"flat": 0.0, "T_c": 21.0})
    with pytest.raises(ValueError, match=r"target: 'flat' is 0 in every fitted row; a constant has nothing to model"):
        thermal_fit(data, "flat")
    only_constant = SeriesData(data.sources, {k: data.columns[k] for k in ("T_a", "T_c")}, data.batch)
    with pytest.raises(ValueError, match=r"sensors: no sensor to model 'T_a' from \(left out: T_c\)"):
        thermal_fit(only_constant, "T_a", lag=0)
    assert thermal_fit(only_constant, "T_a", lag=1)["left_out"][0]["sensor"] == "T_c"   # its own lag is enough


def test_implausible_series_values_are_refused(tmp_path):
    (tmp_path / "s.csv").write_text("y,a\n1,2\n1e300,3\n")
    with pytest.raises(ValueError, match=r"s\.csv:3:1: column 'y': 1e\+300 is implausible: a reading in any unit "
                                         r"lies within \+-1e\+15"):
        read_series(tmp_path / "s.csv")


def test_cli_refuses_a_named_constant_sensor_with_one_line(tmp_path, capsys):
    series(tmp_path, {"T_c": 21.0})
    assert main(["thermal-fit", str(tmp_path / "s.csv"), "--target", "growth", "--sensors", "T_a", "T_c",
                 "--lag", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'T_c' is constant" in err and "--sensors" in err


def test_a_file_read_twice_or_tested_on_itself_is_refused(tmp_path):
    series(tmp_path, {})
    path = tmp_path / "s.csv"
    with pytest.raises(ValueError, match=r"s\.csv: given twice \(as .*s\.csv\); each batch is one file, read once"):
        read_series([path, tmp_path / "." / "s.csv"])
    data = read_series(path)
    with pytest.raises(ValueError, match=r"^test: .*s\.csv is also a data file") as err:
        thermal_fit(data, "growth", test=read_series(path))
    assert err.value.parameters == ("test",)


def test_a_file_of_one_row_is_named(tmp_path):
    (tmp_path / "one.csv").write_text("y,a\n1,2\n")
    with pytest.raises(ValueError, match=r"one\.csv: 1 row\(s\) of data; a model needs more"):
        thermal_fit(read_series(tmp_path / "one.csv"), "y")


def test_one_sensor_may_be_given_as_a_string(tmp_path):
    r = thermal_fit(series(tmp_path, {}), "growth", "T_a", lag=0)
    assert r["sensors"] == ["T_a"] and set(r["coefficients"]) == {"constant", "T_a"}


def test_a_lag_reads_each_file_along_its_own_record(machines):
    """Issue 44: a temperature drift with lag_s = 600 identified from two files whose t each
    starts at 0 gave -0.10 um/K for a true 2.00 (each file alone: 2.00): the lag reached into the
    other day. Each file is its own time series, and a subset of the points (a fold, a half, a
    chunk) reads the lagged temperature from the whole record, not from itself alone."""
    from volerr_pin.fit.identify import build_observations, identify
    from volerr_pin.fit.identify._observations import take_covariates
    from volerr_pin.measurements import campaign
    from volerr_pin.model import add_terms

    m = machines["vmc500"]
    term = {"kind": "thermal_drift", "driver": "temperature", "prefix": "h", "sensors": ["spindle"],
            "coefficients_um_per_K": [2.0], "reference_degC": 22.0, "lag_s": 600.0}
    truth = add_terms(m, {"EZZ": term})
    model = add_terms(m, {"EZZ": dict(term, coefficients_um_per_K=[0.0])})
    days = []
    for seed, course in ((1, lambda t: 21.0 + 3.0 * (1 - np.exp(-t / 3000.0))),
                         (2, lambda t: 25.0 - 4.0 * np.sin(t / 1500.0)), (3, lambda t: 23.0 + t / 7200.0)):
        day = campaign(truth, 150, NOISE, seed)
        day.covariates["temperatures"]["spindle"] = course(day.covariates["t"])
        day.values[:, :3] = truth.volumetric_error(day.q, **day.covariates)[:, :3] + np.random.default_rng(
            seed).normal(0.0, NOISE * 1e-6, (150, 3))
        days.append(day)
    obs = build_observations(model, days, sigma_um=NOISE)
    lagged = check_covariates(model.model, obs.n_points, obs.covariates).temperatures["spindle@600s"]
    for k, day in enumerate(days):
        alone = check_covariates(model.model, 150, day.covariates).temperatures["spindle@600s"]
        np.testing.assert_array_equal(lagged[150 * k:150 * (k + 1)], alone)
    some = np.arange(0, obs.n_points, 7)
    part = check_covariates(model.model, some.size, take_covariates(obs.covariates, some)).temperatures["spindle@600s"]
    np.testing.assert_array_equal(part, lagged[some])
    k = identify(model, days, sigma_um=NOISE)
    assert k.machine.theta[k.machine.parameter_names.index("EZZ.h.k_spindle")] == pytest.approx(2e-6, rel=0.02)


@pytest.mark.parametrize("unit, to_file", [("degC", lambda c: c), ("K", lambda c: c + 273.15),
                                           ("degF", lambda c: c * 9.0 / 5.0 + 32.0)])
def test_a_temperature_column_in_kelvin_or_fahrenheit_is_converted_to_degC(machines, tmp_path, unit, to_file):
    """Issue 44: T_spindle_degF was read as a sensor 'spindle_degF' in degC (-0.3897 um/K for a
    true -0.7015) and T_spindle_K took the 20 degC reference in kelvin. The units the reader
    knows are converted as the column is read, so the fit finds the truth whichever the file
    uses, and the sensor keeps its name."""
    from volerr_pin.fit.identify import identify
    from volerr_pin.measurements._points import read_points
    from volerr_pin.measurements import campaign, write_points
    from volerr_pin.model import add_terms

    m = machines["vmc500"]
    term = {"kind": "thermal_drift", "driver": "temperature", "prefix": "h", "sensors": ["spindle"],
            "coefficients_um_per_K": [-0.7015], "reference_degC": 20.0}
    truth = add_terms(m, {"EZZ": term})
    model = add_terms(m, {"EZZ": dict(term, coefficients_um_per_K=[0.0])})
    day = campaign(truth, 120, NOISE, 5)
    celsius = day.covariates["temperatures"]["spindle"] = 15.0 + 25.0 * np.random.default_rng(5).random(120)
    day.values[:, :3] = truth.volumetric_error(day.q, **day.covariates)[:, :3] + np.random.default_rng(
        6).normal(0.0, NOISE * 1e-6, (120, 3))
    write_points(day, m, tmp_path / "c.csv")
    lines = (tmp_path / "c.csv").read_text().splitlines()
    header = lines[0].split(",")
    col = header.index("T_spindle")
    header[col] = f"T_spindle_{unit}"
    rows = [ln.split(",") for ln in lines[1:]]
    for row, c in zip(rows, celsius):
        row[col] = repr(float(to_file(c)))
    (tmp_path / "f.csv").write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n")
    read = read_points(tmp_path / "f.csv", m)
    assert "spindle" in read.covariates["temperatures"] and not any("_" in s for s in read.covariates["temperatures"])
    np.testing.assert_allclose(read.covariates["temperatures"]["spindle"], celsius, rtol=0, atol=1e-9)
    fit = identify(model, [read], sigma_um=NOISE)
    k = fit.machine.theta[fit.machine.parameter_names.index("EZZ.h.k_spindle")]
    assert k == pytest.approx(-0.7015e-6, rel=0.01), k


def test_a_time_column_is_the_clock_not_a_sensor(tmp_path):
    """The sample file's t [s] is each row's time: not a sensor unless named, and the picture's x axis."""
    from pathlib import Path

    from volerr_pin.applications.thermalfit import thermal_fit
    from volerr_pin.measurements import read_series
    from volerr_pin.viz import thermal_fit_png

    data = read_series(Path(__file__).resolve().parents[2] / "examples" / "data" / "vmc500_spindle_thermal.csv")
    assert "t" in data.columns
    r = thermal_fit(data, "dz_um", lag=0, holdout=0.25)
    assert r["sensors"] == ["T_bearing", "T_housing", "T_column", "T_ambient"]
    assert "t" in thermal_fit(data, "dz_um", ["t", "T_housing"], lag=0)["sensors"]   # named: a sensor after all
    import matplotlib.pyplot as plt

    seen = {}
    save = plt.Figure.savefig

    def spy(fig, *args, **kwargs):
        seen["xlabel"] = fig.axes[0].get_xlabel()
        seen["xmax"] = fig.axes[0].get_xlim()[1]
        return save(fig, *args, **kwargs)

    plt.Figure.savefig = spy
    try:
        thermal_fit_png(r, data, tmp_path / "t.png")
    finally:
        plt.Figure.savefig = save
    assert seen["xlabel"] == "time [h] (column t)" and 8.0 <= seen["xmax"] < 9.0    # eight hours
