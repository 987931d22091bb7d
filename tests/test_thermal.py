"""Seed 003's thermal methods, grey models and thermal-fit (on synthetic series only)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from volerr_pin.cli import main
from volerr_pin.thermal import GM11, GM1N, feed_axis_six_point, spindle_five_point
from volerr_pin.thermalfit import read_series, thermal_fit


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
        out = thermal_fit(train if method != "gm11" else read_series(tmp_path / "b0.csv"), "growth um",
                          ["T_bearing", "T_housing"], method=method, **kw)
        assert np.isfinite(out["rmse_holdout"]) and out["lag"] is None


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
                 "--holdout", "0.2", "--json", "--plot", str(png)]) == 0
    r = json.loads(capsys.readouterr().out)
    for key in ("target", "method", "sensors", "lag", "n_fit", "r2", "residual_se", "n_holdout", "rmse_holdout"):
        assert key in r
    assert r["sensors"] == ["T_bearing", "T_housing", "T_ambient"] and png.stat().st_size > 20_000
    assert main(["thermal-fit", str(tmp_path / "run.csv"), "--target", "nope"]) == 2
