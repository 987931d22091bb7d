"""Tolerance studies: the tolerance file, the shapes a tolerance stands for, the distribution
of the largest error, Sobol' drivers, the re-allocation (re-simulated), and the command line.

Closed forms: one toleranced squareness gives a largest error uniform on [0, t L] (L its
largest arm over the grid); every drawn shape has the range ISO 230 means (|xi| t) and
excludes what the standard excludes (the offset; for straightness the slope; for radial and
tilt error motions the once-per-revolution part), checked on the drawn component functions;
a component whose effect is one translation everywhere is left out, as a work offset removes
it; an additive model has first-order = total Sobol' indices with known shares. The re-allocation is re-simulated
independently (another seed, more draws, the tolerances read back from the file the command
writes) and must meet the target at the stated probability.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.fit import read_tolerances
from volerr_pin.studies import read_tolerance_file, study_tolerances, tolerance_source, tolerances_toml
from volerr_pin.studies._shapes import legendre_range, shapes_of
from volerr_pin.studies._sobol import sobol_indices
from volerr_pin.base import ARCSEC, UM
from volerr_pin.model import grid, parse_component_name


ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "data" / "vmc500_tolerances.toml"


def _write(tmp_path, text, name="tol.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------ the file


def test_a_rank_tolerance_file_means_the_same_to_the_studies(machines):
    m = machines["vmc500"]
    tol = read_tolerance_file(EXAMPLE, m)
    rank = read_tolerances(EXAMPLE, m)
    assert tol.components == m.components
    np.testing.assert_allclose(tol.values, [rank[c] for c in m.components], rtol=1e-15)
    assert all(e.distribution.name == "uniform" and e.cost == 1.0 for e in tol.entries)


def test_the_extended_format_gives_distributions_and_costs(machines, tmp_path):
    m = machines["vmc500"]
    path = _write(tmp_path, 'distribution = "normal"\nEXX_um = 5\n'
                            'EBX_arcsec = { value = 2, distribution = "uniform", cost = 3 }\n'
                            'EC0Y_arcsec = { value = 0 }\ndefault_um = 1\ndefault_arcsec = 0.5\n')
    tol = read_tolerance_file(path, m)
    by = {e.component: e for e in tol.entries}
    assert by["EXX"].value == pytest.approx(5 * UM) and by["EXX"].distribution.name == "normal"
    assert by["EBX"].value == pytest.approx(2 * ARCSEC) and by["EBX"].distribution.name == "uniform"
    assert by["EBX"].cost == 3.0 and by["EC0Y"].value == 0.0
    assert by["EYX"].value == pytest.approx(UM) and by["EAX"].value == pytest.approx(0.5 * ARCSEC)
    assert by["EYX"].distribution.name == "normal"            # the file's default distribution
    # what the writer writes reads back the same
    again = read_tolerance_file(_write(tmp_path, tolerances_toml(tol, "a header"), "back.toml"), m)
    np.testing.assert_allclose(again.values, tol.values, rtol=1e-6)
    assert [e.distribution.name for e in again.entries] == [e.distribution.name for e in tol.entries]
    np.testing.assert_array_equal(again.costs, tol.costs)


@pytest.mark.parametrize("text, match", [
    ("EQQ_um = 5\ndefault_um = 1\ndefault_arcsec = 1\n", r"tol.toml: EQQ_um: 'EQQ' is not an error term of vmc500"),
    ("EXX = 5\ndefault_um = 1\ndefault_arcsec = 1\n", "EXX: give the unit in the key"),
    ("EXX_arcsec = 5\ndefault_um = 1\ndefault_arcsec = 1\n", "unit 'arcsec' is an angle unit"),
    ("EXX_um = -5\ndefault_um = 1\ndefault_arcsec = 1\n", "expected a non-negative number, got -5"),
    ("EXX_um = { value = 5, distribution = \"cauchy\" }\ndefault_um = 1\ndefault_arcsec = 1\n",
     "unknown distribution 'cauchy'"),
    ("EXX_um = { value = 5, shape = 2 }\ndefault_um = 1\ndefault_arcsec = 1\n", "unknown key 'shape'"),
    ("EXX_um = { value = 5, cost = 0 }\ndefault_um = 1\ndefault_arcsec = 1\n", "cost: expected a positive number"),
    ("EXX_um = 5\ndefault_um = 1\n", "no tolerance for EAX"),
    ("EXX_um = 5\nEXX_um = 6\n", "invalid TOML"),
])
def test_a_bad_tolerance_file_is_refused_naming_file_and_key(machines, tmp_path, text, match):
    with pytest.raises(vp.SpecError, match=match):
        read_tolerance_file(_write(tmp_path, text), machines["vmc500"])


# ------------------------------------------------------------------ closed forms


def _arm(m, q, component):
    """The largest distance, over ``q``, a unit rotation ``component`` moves the tool by (m per rad)."""
    S = m.sensitivity(q, first_order=True)
    col = list(m.parameter_names).index(f"{component}.c0") if f"{component}.c0" in m.parameter_names else None
    assert col is not None
    return float(np.linalg.norm(S[:, :3, col], axis=1).max())


def test_one_toleranced_squareness_gives_a_uniform_largest_error(machines, tmp_path):
    """Only EC0Y, uniform within +-t: a squareness is the constant it is, and it moves the tool
    in proportion to its arm, so the largest error over the grid is |U(-t, t)| L, uniform on
    [0, t L] (L the largest arm, from the machine's own sensitivities): quantiles p t L,
    P(max <= T) = T / (t L)."""
    m = machines["vmc500"]
    t = 5.0
    tol = read_tolerance_file(_write(tmp_path, f"EC0Y_arcsec = {t}\ndefault_um = 0\ndefault_arcsec = 0\n"), m)
    q = grid(m, 3)
    shaped, _ = tolerance_source(m, tol, 0)
    top = t * ARCSEC * _arm(shaped, q, "EC0Y") / UM            # t L [um]
    n = 20_000
    target = 0.6 * top
    study = study_tolerances(m, tol, q, samples=n, seed=4, target=target * UM, sobol_samples=None,
                             reallocation=False)
    r = study.to_dict()
    se = top * math.sqrt(0.25 / n) * 4  # a quantile's standard error, generously
    assert r["max_error_um"]["p50"] == pytest.approx(0.5 * top, abs=se)
    assert r["max_error_um"]["p95"] == pytest.approx(0.95 * top, abs=se)
    assert r["max_error_um"]["mean"] == pytest.approx(top / 2, abs=4 * top / math.sqrt(12 * n))
    assert r["max_error_um"]["std"] == pytest.approx(top / math.sqrt(12), rel=0.03)
    assert r["max_error_um"]["max"] <= top * (1 + 1e-9)
    assert r["probability_within_target"] == pytest.approx(0.6, abs=4 * math.sqrt(0.24 / n))
    assert r["probability_se"] == pytest.approx(math.sqrt(0.24 / n), rel=0.05)
    assert {"component": "EC0Y", "shape": "location", "excludes": "", "basis": "one constant"} in r["shapes"]


def test_a_normal_tolerance_is_a_standard_deviation(machines, tmp_path):
    """EC0Y normal with sigma = t: the largest error is |N(0, t^2)| L, median 0.674 t L."""
    m = machines["vmc500"]
    tol = read_tolerance_file(_write(tmp_path, 'EC0Y_arcsec = { value = 2, distribution = "normal" }\n'
                                               'default_um = 0\ndefault_arcsec = 0\n'), m)
    q = grid(m, 2)
    shaped, _ = tolerance_source(m, tol, 0)
    top = 2 * ARCSEC * _arm(shaped, q, "EC0Y") / UM
    study = study_tolerances(m, tol, q, samples=20_000, seed=1, sobol_samples=None)
    assert study.to_dict()["max_error_um"]["p50"] == pytest.approx(0.6745 * top, rel=0.03)
    assert study.probability is None and study.reallocation is None


# ------------------------------------------------------------------ what a tolerance means


def test_shapes_are_named_from_the_kinematics(machines):
    """A slide's own direction is its positioning, the others its straightness; a rotary
    axis' own direction is its axial motion and angular positioning, whatever the letters:
    gear_roller's A and B turn about their own z, so EZA is axial and ECA its positioning."""
    vmc = {s.component: s.name for s in shapes_of(machines["vmc500"])}
    assert (vmc["EXX"], vmc["EYX"], vmc["EZX"], vmc["EAX"], vmc["EC0Y"]) == (
        "positioning", "straightness", "straightness", "angular", "location")
    cgm = {s.component: s.name for s in shapes_of(machines["cgm4000"])}
    assert (cgm["EXA"], cgm["EYA"], cgm["EAA"], cgm["EBA"], cgm["EYB"], cgm["EBB"]) == (
        "axial", "radial", "angular positioning", "tilt", "axial", "angular positioning")
    gear = {s.component: s.name for s in shapes_of(machines["gear_roller"])}
    assert (gear["EZA"], gear["ECA"], gear["EXA"], gear["EAA"]) == ("axial", "angular positioning", "radial", "tilt")
    lathe = {s.component: s.name for s in shapes_of(machines["lathe_2axis"])}
    assert lathe["EXT"] == "constant" and lathe["EZZ"] == "positioning"


def test_legendre_range_is_exact():
    rng = np.random.default_rng(3)
    c = rng.normal(size=(200, 4))
    u = np.linspace(-1.0, 1.0, 400_001)
    dense = np.array([np.ptp(np.polynomial.legendre.legval(u, ci)) for ci in c])
    got = legendre_range(c)
    assert np.all(got >= dense - 1e-12)                    # never below what a grid sees
    np.testing.assert_allclose(got, dense, rtol=0, atol=1e-9)
    np.testing.assert_allclose(legendre_range(np.array([[0.0, 1.0]])), [2.0])        # P1: -1 .. 1
    np.testing.assert_allclose(legendre_range(np.array([[0.0, 0.0, 1.0]])), [1.5])   # P2: -1/2 .. 1


@pytest.mark.parametrize("name, components", [
    ("vmc500", ["EXX", "EYX", "EBX", "EZZ", "EC0Y"]),
    ("cgm4000", ["EXB", "EYB", "EBB", "EAB", "EYA", "EAA"]),
])
def test_every_drawn_shape_has_the_range_the_tolerance_bounds_and_excludes_what_the_standard_excludes(
        machines, name, components, tmp_path):
    """The drawn component functions themselves, from the study's machine: over the travel
    (dense positions) each has range |xi| t (never above t for a uniform tolerance, and
    spread over [0, t]); its mean over the travel is zero but for location errors; a
    straightness has no slope; a radial or tilt motion has no once-per-revolution part."""
    m = machines[name]
    tol = read_tolerance_file(_write(tmp_path, "default_um = 2\ndefault_arcsec = 3\n"), m)
    shaped, source = tolerance_source(m, tol, 11)
    rows = source.rows(0, 0, 400)
    shapes = {s.component: s for s in source.shapes}
    for component in components:
        k = m.components.index(component)
        shape = shapes[component]
        owner = parse_component_name(component)[2]
        j = m.axes.index(owner)
        lo, hi = m.travel[j]
        x = np.linspace(lo, hi, 20_001)
        q = np.tile(m.mid_travel, (len(x), 1))
        q[:, j] = x
        values = np.stack([shaped.with_theta(r).component_values(q)[:, k] for r in rows[:40]])
        t = tol.values[k]
        spread = np.ptp(values, axis=1)
        assert np.all(spread <= t * (1 + 1e-9)), component
        if shape.family == "constant":
            continue
        coef = rows[:40][:, source.columns[k]] / t
        if shape.family == "legendre":
            np.testing.assert_allclose(spread / t, legendre_range(coef), rtol=1e-6, err_msg=component)
        mags = np.ptp(np.stack([shaped.with_theta(r).component_values(q[::50])[:, k] for r in rows]), axis=1) / t
        assert 0.0 <= mags.min() < 0.1 and 0.9 < mags.max() <= 1 + 1e-9, component   # spread over [0, t]
        w = np.full(len(x), x[1] - x[0])
        w[[0, -1]] /= 2
        mean = values @ w / (hi - lo)
        assert np.abs(mean).max() <= 1e-8 * t, component    # trapezoid rule on 20,001 positions
        if shape.name == "straightness":
            slope = values @ (w * (x - (lo + hi) / 2)) / np.sum(w * (x - (lo + hi) / 2) ** 2)
            assert np.abs(slope * (hi - lo)).max() <= 1e-6 * t, component
        turns = (hi - lo) / (2 * np.pi)
        if shape.name in ("radial", "tilt") and abs(turns - round(turns)) < 1e-9:   # over whole revolutions
            once = np.abs(values @ (w * np.cos(x))) + np.abs(values @ (w * np.sin(x)))
            assert once.max() / (hi - lo) <= 1e-7 * t, component     # a linear table of harmonics 2 and 3


def test_what_a_work_offset_removes_is_left_out(machines, tmp_path):
    """lathe_2axis' turret and spindle offsets move the tool by the same translation at every
    point (asked of the machine's own sensitivities here): the study leaves them out and says
    so, and its numbers are those of a file that gives them no tolerance. vmc500 has none."""
    from volerr_pin.model import replace_terms

    m = machines["lathe_2axis"]
    q = grid(m, 3)
    # every component as one constant: those whose effect is the same at every point
    constant = replace_terms(m, {c: {"kind": "constant", f"value_{'arcsec' if c[1] in 'ABC' else 'um'}": 0.0}
                                 for c in m.components})
    S = constant.sensitivity(q, first_order=True)[:, :3, :]
    same = [c for k, c in enumerate(constant.components)
            if np.abs(S[:, :, k]).max() > 0 and np.abs(S[:, :, k] - S[:1, :, k]).max() < 1e-12
            and (parse_component_name(c)[1] or parse_component_name(c)[2] not in m.axes)]   # the axes' own: shapes
    assert same == ["EXT", "EYT", "EZT", "EAT", "EBT", "ECT", "EXS", "EYS", "EZS"]
    tol = read_tolerance_file(_write(tmp_path, "default_um = 1\ndefault_arcsec = 1\n"), m)
    study = study_tolerances(m, tol, q, samples=600, seed=2, sobol_samples=None, reallocation=False)
    assert list(study.left_out) == same
    zeroed = read_tolerance_file(_write(tmp_path, "".join(f"{c}_{'arcsec' if c[1] in 'ABC' else 'um'} = 0\n"
                                                          for c in same) + "default_um = 1\ndefault_arcsec = 1\n",
                                        "zero.toml"), m)
    other = study_tolerances(m, zeroed, q, samples=600, seed=2, sobol_samples=None, reallocation=False)
    np.testing.assert_array_equal(study.run.max, other.run.max)
    report = study.to_dict()
    assert [r["component"] for r in report["left_out"]] == same and "work offset" in report["left_out"][0]["reason"]
    vmc = machines["vmc500"]
    assert study_tolerances(vmc, read_tolerance_file(EXAMPLE, vmc), grid(vmc, 2), samples=10,
                            sobol_samples=None).left_out == ()


@pytest.mark.parametrize("dists", [("unif", "unif", "unif"), ("unif", "norm", "unif")])
def test_sobol_indices_of_an_additive_model_are_its_variance_shares(dists):
    """Y = sum c_i X_i with independent X_i: first order = total = c_i^2 var_i / sum."""
    c = np.array([3.0, 1.0, 0.5])
    bounds = [[-1.0, 1.0], [0.0, 2.0] if dists[1] == "norm" else [-2.0, 2.0], [-1.0, 1.0]]
    var = np.array([(b[1] - b[0]) ** 2 / 12 if d == "unif" else b[1] ** 2 for b, d in zip(bounds, dists)])
    share = c**2 * var / np.sum(c**2 * var)
    problem = {"num_vars": 3, "names": ["a", "b", "c"], "bounds": bounds, "dists": list(dists)}
    result = sobol_indices(problem, lambda X: X @ c, n=4096, seed=3)
    np.testing.assert_allclose(result.first_order, share, atol=0.03)
    np.testing.assert_allclose(result.total, share, atol=0.03)
    assert result.runs == 4096 * 5
    assert [r["component"] for r in result.rows()] == [n for _, n in sorted(zip(-share, "abc"))]


@pytest.mark.parametrize("seed", [0, 1])
def test_sobol_confidence_intervals_repeat_with_the_seed(seed):
    """Seed 0 included: SALib leaves its bootstrap unseeded for a falsy seed, so intervals changed between runs."""
    problem = {"num_vars": 2, "names": ["a", "b"], "bounds": [[-1.0, 1.0], [-1.0, 1.0]], "dists": ["unif", "unif"]}
    model = lambda X: X[:, 0] + 0.3 * X[:, 1] ** 2  # noqa: E731
    np.random.seed(1)
    first = sobol_indices(problem, model, n=16, seed=seed)
    np.random.seed(2)  # the global state must not matter
    second = sobol_indices(problem, model, n=16, seed=seed)
    np.testing.assert_array_equal(first.first_order_conf, second.first_order_conf)
    np.testing.assert_array_equal(first.total_conf, second.total_conf)


def test_sobol_samples_must_be_a_power_of_two():
    problem = {"num_vars": 1, "names": ["a"], "bounds": [[-1, 1]], "dists": ["unif"]}
    with pytest.raises(vp.InputError, match="sobol_samples must be a power of 2"):
        sobol_indices(problem, lambda X: X[:, 0], n=100)


def test_the_drivers_of_the_largest_error_are_the_toleranced_components(machines, tmp_path):
    """Two toleranced components, one four times the other (offsets along x and y): the
    largest error sqrt(x^2 + y^2) is driven by the larger one; ECZ (a rotation about the
    tool axis) moves no tool point and has no index."""
    m = machines["vmc500"]
    tol = read_tolerance_file(_write(tmp_path, "EXX_um = 8\nEYY_um = 2\nECZ_arcsec = 5\n"
                                               "default_um = 0\ndefault_arcsec = 0\n"), m)
    study = study_tolerances(m, tol, grid(m, 2), samples=200, sobol_samples=512, reallocation=False)
    drivers = {d["component"]: d for d in study.to_dict()["drivers"]}
    assert list(drivers)[0] == "EXX" and drivers["EXX"]["total"] > 0.85
    assert drivers["EYY"]["total"] < 0.15 and abs(drivers["ECZ"]["total"]) < 1e-9


# ------------------------------------------------------------------ Done when: re-allocation


def test_the_reallocation_re_simulated_meets_the_target_at_the_stated_probability(machines, tmp_path):
    m = machines["vmc500"]
    tol = read_tolerance_file(EXAMPLE, m)
    q = grid(m, 3)
    target, p = 8.0 * UM, 0.9
    study = study_tolerances(m, tol, q, samples=3000, seed=7, target=target, target_probability=p,
                             sobol_samples=None)
    assert study.probability < p                          # the present tolerances miss it
    r = study.reallocation
    assert r.met and r.probability_lower >= p
    assert r.cost_after < r.uniform_cost                   # cheaper than scaling all alike
    # an independent re-simulation: the suggestion as the file states it, another seed, more draws
    path = _write(tmp_path, tolerances_toml(r.tolerances), "suggested.toml")
    suggested = read_tolerance_file(path, m)
    check = study_tolerances(m, suggested, q, samples=8000, seed=12345, target=target, sobol_samples=None,
                             reallocation=False)
    assert check.probability >= p
    # cost: sum of w t0 / t, as stated
    np.testing.assert_allclose(r.cost_after, np.sum(tol.values[tol.values > 0] / suggested.values[tol.values > 0]),
                               rtol=1e-5)
    # a component that moves no tool point is loosened to the bound
    ecz = list(m.components).index("ECZ")
    assert suggested.values[ecz] == pytest.approx(10 * tol.values[ecz], rel=1e-5)


# ------------------------------------------------------------------ bad input, command line


@pytest.mark.parametrize("kwargs, match", [
    ({"samples": 0}, "samples must be a whole number >= 2"),
    ({"target": -1.0}, "target must be a positive length"),
    ({"target": 0.0}, "target must be a positive length"),
    ({"target_probability": 1.0}, "target_probability must lie between 0 and 1"),
    ({"sobol_samples": 100}, "sobol_samples must be a power of 2"),
])
def test_bad_study_arguments_are_refused(machines, kwargs, match):
    m = machines["vmc500"]
    with pytest.raises(vp.InputError, match=match):
        study_tolerances(m, read_tolerance_file(EXAMPLE, m), grid(m, 2), **kwargs)


def _cli(argv, capsys):
    from volerr_pin.cli import main

    try:
        code = main(argv)
    except SystemExit as stop:
        code = stop.code
    out, err = capsys.readouterr()
    return code, out, err


def test_volerr_tolerance_json_png_and_suggested_file(tmp_path, capsys):
    png, out = tmp_path / "max.png", tmp_path / "suggested.toml"
    code, text, err = _cli(["tolerance", "vmc500", "--tolerances", str(EXAMPLE), "--samples", "1e3", "--grid", "3",
                            "--target-um", "12", "--sobol-samples", "64", "--workers", "0", "--png", str(png),
                            "--out", str(out), "--json"], capsys)
    assert code == 0, err
    report = json.loads(text)
    # the contract's fields
    assert {"machine", "samples", "workers", "seed", "max_error_um", "rms_error_um", "probability_within_target",
            "drivers"} <= set(report)
    assert set(report["max_error_um"]) >= {"mean", "std", "p50", "p95", "p99"}
    assert set(report["rms_error_um"]) >= {"mean", "std", "p95"}
    assert all(set(d) >= {"component", "first_order", "total"} for d in report["drivers"])
    assert report["samples"] == 1000 and report["workers"] == 1 and report["seed"] == 0
    assert png.stat().st_size > 5000 and report["png"] == str(png)
    assert read_tolerance_file(out, vp.load_machine("vmc500")).components
    # every field is documented
    import re

    from test_readme import _keys

    documented = set(re.findall(r"`([a-z][a-z0-9_]*)`", (ROOT / "docs" / "reports.md").read_text()))
    assert not _keys(report, set()) - documented, sorted(_keys(report, set()) - documented)


def test_volerr_uncertainty_fields_are_documented(tmp_path, capsys):
    import re

    from test_readme import _keys

    code, text, err = _cli(["uncertainty", "vmc500", "--instrument-sigma", "1", "--campaign-points", "40",
                            "--samples", "50", "--grid", "2", "--compensation", "point", "--workers", "0", "--json"],
                           capsys)
    assert code == 0, err
    report = json.loads(text)
    documented = set(re.findall(r"`([a-z][a-z0-9_]*)`", (ROOT / "docs" / "reports.md").read_text()))
    assert not _keys(report, set()) - documented, sorted(_keys(report, set()) - documented)


@pytest.mark.parametrize("argv, match", [
    (["--target-um", "0"], "argument --target-um: expected a positive number, got 0"),
    (["--target-um", "-3"], "argument --target-um: expected a positive number"),
    (["--samples", "0"], "argument --samples: expected a positive whole number, got 0"),
    (["--sobol-samples", "100"], "--sobol-samples must be a power of 2 (at least 4), got 100"),
    (["--target-probability", "1.5"], "argument --target-probability: expected a probability between 0 and 1"),
])
def test_volerr_tolerance_bad_input_is_one_line(capsys, argv, match):
    code, out, err = _cli(["tolerance", "vmc500", "--tolerances", str(EXAMPLE), "--workers", "0", *argv], capsys)
    assert code == 2 and out == "" and match in err.rstrip("\n").splitlines()[-1]


def test_volerr_tolerance_names_an_unknown_component_in_one_line(tmp_path, capsys):
    path = _write(tmp_path, "EQQ_um = 5\ndefault_um = 1\ndefault_arcsec = 1\n")
    code, out, err = _cli(["tolerance", "vmc500", "--tolerances", str(path), "--workers", "0"], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith(f"volerr: error: {path}: EQQ_um: 'EQQ' is not an error term of vmc500")


@pytest.mark.slow
def test_one_and_two_local_worker_processes_give_the_same_report(tmp_path, capsys, cluster):
    """The command line's own local clusters (1 and 2 worker processes) and a scheduler:
    the same seed gives the same report to the bit, whatever runs it."""
    base = ["tolerance", "vmc500", "--tolerances", str(EXAMPLE), "--samples", "1200", "--grid", "3",
            "--target-um", "12", "--sobol-samples", "32", "--seed", "9", "--json"]
    reports = []
    for where in (["--workers", "1"], ["--workers", "2"], ["--scheduler", cluster.scheduler_address]):
        code, text, err = _cli(base + where, capsys)
        assert code == 0, err
        reports.append(json.loads(text))
    assert [r["workers"] for r in reports] == [1, 2, 2]
    for r in reports:
        r.pop("workers"), r.pop("engine")
    assert reports[0] == reports[1] == reports[2]


def test_the_text_report_warns_where_the_sobol_intervals_do_not_separate_and_says_why_a_bound_was_hit(capsys):
    """The guide's example with 32 base samples: the intervals are wider than the indices, and
    the text says so with the samples that would separate the largest; the table says it shows
    12 of 21 components; a tolerance the re-allocation loosens to its bound says why."""
    from volerr_pin.studies._sobol import SobolIndices

    args = ["tolerance", "vmc500", "--tolerances", str(EXAMPLE), "--samples", "1e3", "--grid", "3",
            "--target-um", "12", "--sobol-samples", "32", "--workers", "0"]
    code, text, err = _cli(args + ["--json"], capsys)
    assert code == 0, err
    report = json.loads(text)
    res = report["sobol_resolution"]
    d = {r["component"]: r for r in report["drivers"]}
    assert set(res["first_order_unresolved"]) == {n for n, r in d.items() if r["first_order"] <= r["first_order_conf"]}
    assert set(res["total_unresolved"]) == {n for n, r in d.items() if r["total"] <= r["total_conf"]}
    lead = max(d.values(), key=lambda r: r["first_order"])
    assert res["samples"] == 32 and res["samples_needed"] >= 32 * (lead["first_order_conf"] / lead["first_order"]) ** 2
    ecz = next(t for t in report["reallocation"]["tolerances"] if t["component"] == "ECZ")
    assert ecz["after"] == pytest.approx(10 * ecz["before"]) and "it moves no point" in ecz["reason"]
    code, text, err = _cli(args, capsys)
    flat = " ".join(text.split())
    assert "the 12 of 21 components with the largest total index, --json gives all" in flat
    assert (f"warning: the first-order intervals of {sum(n in res['first_order_unresolved'] for n in list(d)[:12])} "
            "of these 12 components include zero") in flat
    assert f"about --sobol-samples {res['samples_needed']:,} would separate the largest" in flat
    assert "ECZ 1 -> 10 arcsec: at the largest factor allowed (10 x): it moves no point" in flat
    # the rule itself on made-up indices: an interval reaching zero is unresolved
    s = SobolIndices(("a", "b"), np.array([0.5, 0.1]), np.array([0.6, 0.2]), np.array([0.1, 0.2]),
                     np.array([0.1, 0.1]), 64, 16)
    r = s.resolution()
    assert (r["first_order_unresolved"], r["total_unresolved"], r["samples_needed"]) == (["b"], [], None)
    s = SobolIndices(("a",), np.array([0.1]), np.array([0.5]), np.array([0.2]), np.array([0.1]), 48, 16)
    assert s.resolution()["samples_needed"] == 128   # 16 x (0.2 / 0.1)^2 x 1.05 = 67.2 -> 128
