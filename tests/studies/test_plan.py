"""volerr_pin.studies.plan: the D-optimal choice against brute force, the predicted covariance against
identify's, what no plan separates (closed forms), the plan against grid and random poses,
the files (a filled plan read back by identify, the NC program read by the product's NC
reader), the after-diagnosis plan on a simulated case, a toy instrument registered without
editing the library, and the command line's refusals."""

from __future__ import annotations

import csv
import itertools
import json
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.base import InputError
from volerr_pin.compensation.gcode import interpret
from volerr_pin.fit.identify import identify
from volerr_pin.measurements import ObservationOptions, PointMeasurements, read_any
from volerr_pin.studies.plan import (INSTRUMENTS, after_diagnosis, instrument, make_setup, nc_program, plan,
                                     register_instrument, time_estimate)
from volerr_pin.studies.plan._nc import StopsProgram
from volerr_pin.studies.plan._design import UnitDesign, d_optimal
from volerr_pin.studies.plan._after import components_to_settle
from volerr_pin.studies.plan._poses import grid_counts, pose_candidates
from volerr_pin.studies.plan._tracker import in_sight

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def vmc500():
    return vp.load_machine("vmc500")


def _logdet(design, units, columns):
    X = design.take(units)[:, columns]
    return np.linalg.slogdet(X.T @ X)[1]


# ------------------------------------------------------------------ the choice of units

def test_d_optimal_finds_the_best_subset_of_a_small_pool():
    """Greedy selection and Fedorov exchange reach the brute-force optimum of log det on small
    random pools (units of 2 rows, 3 columns, 4 of 9 units)."""
    for seed in range(5):
        rng = np.random.default_rng(seed)
        rows = rng.normal(size=(18, 3)) * np.array([1.0, 3.0, 0.2])
        design = UnitDesign(rows, np.arange(0, 19, 2), ["a", "b", "c"], 0, np.arange(3), np.ones(3))
        cols = np.arange(3)
        chosen = d_optimal(design, cols, 4)
        assert len(set(chosen.tolist())) == 4
        best = max(_logdet(design, np.array(c), cols) for c in itertools.combinations(range(9), 4))
        assert _logdet(design, chosen, cols) == pytest.approx(best, abs=1e-9)


def test_i_optimal_finds_the_best_subset_of_a_small_pool():
    """With zone sensitivities the exchange minimises trace(W M^-1): the brute-force optimum."""
    for seed in range(4):
        rng = np.random.default_rng(10 + seed)
        rows = rng.normal(size=(20, 3))
        design = UnitDesign(rows, np.arange(0, 21, 2), ["a", "b", "c"], 0, np.arange(3), np.ones(3))
        zone = rng.normal(size=(7, 3, 3))
        W = zone.reshape(-1, 3).T @ zone.reshape(-1, 3)

        def mean_var(units):
            X = design.take(np.array(units))
            return np.trace(W @ np.linalg.inv(X.T @ X))
        chosen = d_optimal(design, np.arange(3), 4, zone=zone, eps=1e-9)
        best = min(mean_var(c) for c in itertools.combinations(range(10), 4))
        assert mean_var(chosen) == pytest.approx(best, rel=1e-9)


def test_d_optimal_refuses_a_budget_beyond_the_pool():
    design = UnitDesign(np.eye(3), np.arange(4), ["a", "b", "c"], 0, np.arange(3), np.ones(3))
    with pytest.raises(InputError, match="budget 4 exceeds the 3 candidate"):
        d_optimal(design, np.arange(3), 4)


def test_grid_counts_and_layouts():
    counts = grid_counts(np.array([0.5, 0.4, 0.0]), 12)
    assert counts[2] == 1 and counts.prod() >= 12
    zone = np.array([[0.0, 0.5], [0.0, 0.4], [-np.pi, np.pi]])
    for layout in ("sobol", "grid", "random"):
        q = pose_candidates(zone, ("linear", "linear", "rotary"), 30, layout, 3)
        assert q.shape == (30, 3)
        assert np.all(q >= zone[:, 0] - 1e-15) and np.all(q <= zone[:, 1] + 1e-15)
    g = pose_candidates(zone, ("linear", "linear", "rotary"), 8, "grid", 0)
    assert not np.any(np.isclose(g[:, 2], np.pi))   # a full turn's two ends are one pose


# ------------------------------------------------------------------ predictions are identify's

def _rows(machine, inst, setup, units):
    data, _ = inst.measurements(machine, setup, units)
    return sum(len(m.observations(machine, ObservationOptions()).y) for m in data)


@pytest.mark.parametrize("kind, targets, budget", [("probe", None, 25), ("tracker", [[0, 0, 0], [0.1, 0, -0.05]], 25),
                                                   ("interferometer", None, 30)])
def test_predicted_uncertainty_is_identifys_covariance(vmc500, kind, targets, budget):
    """sigma (J^T W J)^-1 over the identified coefficients, nuisance terms included (a tracker's
    placement shared by the campaign, a run's own zero projected out), is what identify
    reports (its uncertainty divided by its residual scale) for the same units."""
    inst = instrument(kind)
    setup = make_setup(vmc500, inst, targets=targets)
    p = plan(vmc500, inst, budget, setup, candidates=256)
    assert not [n for n in p.notes if not n.startswith("weak plan")]   # every coefficient determined
    noise = np.random.default_rng(1).normal(0, setup.sigma, _rows(vmc500, inst, setup, p.units))
    data, _ = inst.measurements(vmc500, setup, p.units, noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(vmc500, data, folds=0, sigma_um=setup.sigma * 1e6, initialise=False)
    names = vmc500.parameter_names
    fitted = {names[k]: fit.uncertainty[k] / fit.residual_sigma for k in fit.fitted}
    assert set(fitted) == set(p.std)
    for name, std in p.std.items():
        assert std == pytest.approx(fitted[name], rel=2e-3), name


def test_not_separable_names_the_constant_translations_of_three_chains(vmc500):
    """A constant z offset of X, Y or Z moves the tool point the same way: no probe plan
    separates EZX.c0, EZY.c0, EZZ.c0 (exactly collinear); the plan identifies the rest."""
    p = plan(vmc500, instrument("probe"), 30, candidates=256)
    groups = {tuple(sorted(g.parameters)): g for g in p.not_separable}
    assert groups[("EZX.c0", "EZY.c0", "EZZ.c0")].kind == "collinear"
    dependent = {g.parameters[0] for g in p.not_separable if g.kind != "collinear"}
    dependent |= {n for g in p.not_separable if g.kind == "collinear" for n in g.parameters[1:]}
    assert not dependent & set(p.identifiable)
    assert len(p.identifiable) + len(dependent) == len(vmc500.parameter_names)
    assert p.zone_um["zone_rms_um"] > 0 and p.zone_um["zone_max_um"] >= p.zone_um["zone_rms_um"]


def test_a_budget_too_small_is_said(vmc500):
    """11 nodes of EXX need 11 positions along X: 10 poses cannot determine them all."""
    p = plan(vmc500, instrument("probe"), 10, terms=["EXX"], candidates=64)
    assert p.zone_um["zone_rms_um"] is None
    assert p.notes and "raise the budget" in p.notes[0]
    assert not plan(vmc500, instrument("probe"), 12, terms=["EXX"], candidates=64).notes


def test_plan_beats_grid_and_random_predicted_and_simulated(vmc500):
    p = plan(vmc500, instrument("probe"), 30, candidates=256, compare=True, repeats=3)
    c = p.comparison
    assert c["plan"]["not_identified"] == []
    assert c["random"]["ratios"]["predicted_zone_rms"] < 1.0
    assert c["random"]["ratios"]["simulated_zone_rms"] < 1.0
    assert c["random"]["ratios"]["predicted_std_geomean"] < 1.0
    # the simulation estimates what the prediction says (3 repeats: within a factor 1.5)
    assert 0.67 < c["plan"]["simulated_zone_rms_um"] / c["plan"]["zone_rms_um"] < 1.5
    grid = c["grid"]
    assert grid["not_identified"] or grid["ratios"]["predicted_zone_rms"] < 1.0


def test_a_design_that_leaves_coefficients_undetermined_is_no_yardstick(vmc500, capsys):
    """30 tracker poses on a grid leave 11 of the plan's coefficients undetermined: no ratio
    is given for it (a ratio against a map it does not determine reads as a 1,600-fold win),
    the reason is, and its simulation holds those coefficients at their priors as identify
    would."""
    p = plan(vmc500, instrument("tracker"), 30, compare=True, repeats=1)
    grid = p.comparison["grid"]
    assert len(grid["not_identified"]) == 11 and grid["zone_rms_um"] is None
    assert [grid["ratios"][k] for k in ("predicted_zone_rms", "simulated_zone_rms", "predicted_std_geomean",
                                        "simulated_std_geomean")] == [None] * 4
    assert 0 < grid["ratios"]["predicted_lower_share"] <= 1
    assert grid["not_comparable"] == "the grid leaves 11 of the plan's 38 coefficients undetermined"
    assert grid["simulated_std_geomean"] is None and grid["simulated_zone_rms_um"] > 0
    assert p.comparison["random"]["ratios"]["predicted_zone_rms"] < 1 and "not_comparable" not in p.comparison["random"]
    assert main(["plan", "vmc500", "--instrument", "tracker", "--budget", "30", "--compare", "--repeats", "1"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "plan / grid: not comparable: the grid leaves 11 of the plan's 38 coefficients undetermined" in text


# ------------------------------------------------------------------ files

def _fill(machine, path, out, kind):
    """Fill a plan's empty columns with the exact measurement of ``machine`` (exact kinematics,
    not the planner's linear model)."""
    lines = open(path).read().splitlines()
    comments = [ln for ln in lines if ln.startswith("#")]
    rows = list(csv.reader(ln for ln in lines if not ln.startswith("#")))
    header, body = rows[0], rows[1:]
    axes = [header.index(a.lower()) for a in machine.axes]
    q = np.array([[float(r[i]) for i in axes] for r in body]) * 1e-3
    R, p = machine.tool_poses(q)
    Rn, pn = machine.tool_poses(q, nominal=True)
    if kind == "probe":
        values = (p - pn) * 1e6
        cols = [header.index(c) for c in ("dx", "dy", "dz")]
    else:
        o = np.array([[float(r[header.index(c)]) for c in ("ox", "oy", "oz")] for r in body]) * 1e-3
        values = (p + np.einsum("nij,nj->ni", R, o)) * 1e3 + np.array([1500.0, -800.0, 300.0])
        cols = [header.index(c) for c in ("tx", "ty", "tz")]
    for r, v in zip(body, values):
        for c, x in zip(cols, v):
            r[c] = f"{x:.6f}"
    with open(out, "w", newline="") as fh:
        fh.write("".join(c + "\n" for c in comments))   # the template's comments stay
        csv.writer(fh, lineterminator="\n").writerows([header, *body])


@pytest.mark.parametrize("kind, extra", [("probe", []), ("tracker", ["--targets", "0,0,0", "80,0,0", "0,60,-40"])])
def test_filled_plan_is_read_and_identified(tmp_path, vmc500, kind, extra, capsys):
    plan_csv, nc, template = tmp_path / "plan.csv", tmp_path / "plan.nc", tmp_path / "results.csv"
    assert main(["plan", "vmc500", "--instrument", kind, "--budget", "24", "--candidates", "128", "--out",
                 str(plan_csv), "--nc", str(nc), "--template", str(template), "--json", *extra]) == 0
    report = json.loads(capsys.readouterr().out)
    for key in ("machine", "instrument", "budget", "poses", "predicted", "not_separable"):
        assert key in report
    assert report["budget"] == 24 and len(report["poses"]) == 24
    with pytest.raises(Exception):
        read_any(plan_csv, vmc500)   # deviations empty: not data yet
    filled = tmp_path / "filled.csv"
    _fill(vmc500, template, filled, kind)   # the template: comments, then the plan's rows
    data = read_any(filled, vmc500)
    prior = vmc500.with_theta(np.zeros(len(vmc500.theta)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(prior, [data], folds=0, initialise=False)
    assert fit.rms_fit_um < 0.05   # noiseless exact data: the identifiable model explains them
    assert fit.n_points == 24 * (3 if kind == "tracker" else 1)
    assert main(["identify", "vmc500", str(filled), "--folds", "0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_points"] == fit.n_points


def test_nc_program_passes_the_nc_reader_and_visits_the_poses(vmc500):
    q = pose_candidates(np.array([[0, 0.5], [0, 0.4], [0, 0.4]]), vmc500.axis_kinds, 7, "random", 2)
    text = nc_program(vmc500, q, 1500.0, 2.0, "test (plan)")
    segments = interpret(vmc500, text)
    moves = [s for s in segments if s.kind in ("line", "rapid")]  # the first move starts from an unknown position
    assert len(moves) == 7 and all(s.kind == "line" for s in moves[1:])
    np.testing.assert_allclose(np.array([s.end for s in moves]), q, atol=1e-7)
    assert text.count("G4 P2") == 7


def test_time_estimate_closed_form(vmc500):
    q = np.array([[0.0, 0.0, 0.0], [0.3, 0.4, 0.0], [0.3, 0.4, 0.1]])  # 500 mm then 100 mm
    t = time_estimate(vmc500, q, 1000.0, 5.0)
    assert t["moves_s"] == pytest.approx(600.0 / 1000.0 * 60.0)
    assert t["total_s"] == pytest.approx(36.0 + 15.0) and t["path_mm"] == pytest.approx(600.0)
    with pytest.raises(InputError, match="feed_mm_min"):
        time_estimate(vmc500, q, 0.0, 5.0)


def test_nc_program_refuses_axes_that_are_not_nc_letters():
    ur5 = vp.load_machine("ur5")
    with pytest.raises(InputError, match="not an NC address letter"):
        nc_program(ur5, np.zeros((2, 6)), 1000.0, 1.0)


# ------------------------------------------------------------------ line of sight

def test_line_of_sight_keeps_poses_within_the_acceptance_cone(vmc500):
    """On a 3-axis machine the tool does not turn: a reflector facing the tracker from the
    zone's centre sees it wherever the direction to the tracker stays within the cone."""
    inst = instrument("tracker")
    station = np.array([0.25, -0.15, 0.2])
    setup = make_setup(vmc500, inst, station=station, acceptance_deg=25.0)
    q = pose_candidates(setup.zone, vmc500.axis_kinds, 400, "random", 0)
    ok = in_sight(vmc500, setup, q)
    _, p = vmc500.tool_poses(q, nominal=True)
    _, p0 = vmc500.tool_poses(setup.zone.mean(axis=1)[None, :], nominal=True)
    facing = (station - p0[0]) / np.linalg.norm(station - p0[0])
    d = (station - p) / np.linalg.norm(station - p, axis=1, keepdims=True)
    expected = d @ facing >= np.cos(np.radians(25.0))
    assert np.array_equal(ok, expected) and 0 < ok.sum() < len(q)
    assert all(in_sight(vmc500, setup, np.array(inst.candidates(vmc500, setup, 64, "sobol", 0))))


# ------------------------------------------------------------------ after a diagnosis

def test_after_diagnosis_a_second_tool_length_separates_the_roll_of_z(vmc500):
    """EAZ (roll of Z) and EYX, EYZ move the tool point alike; a second tool length turns
    EAZ's rotation into a displacement: with it, the simulated campaign recovers EAZ; the
    constant y offsets (EYX.c0, EYZ.c0) stay inseparable, named with the reason."""
    report = {"machine": "vmc500", "effects": [{"name": "straightness", "component": "EAZ",
                                                "same_at_tool_as": ["EYX", "EYZ"]}], "under_modelled": []}
    assert components_to_settle(report) == [("EAZ", "EYX", "EYZ")]
    inst = instrument("tracker")
    one = after_diagnosis(vmc500, inst, make_setup(vmc500, inst), report, 12, candidates=256)
    assert any("EAZ.c0" in g.parameters for g in one.not_separable)
    two = after_diagnosis(vmc500, inst, make_setup(vmc500, inst, targets=[[0, 0, 0], [0, 0, -0.1]]), report, 12,
                          candidates=256)
    assert not any("EAZ.c0" in g.parameters for g in two.not_separable)
    assert {g.parameters[0] for g in two.not_separable} <= {"shift_y[tracker planned tracker poses]", "EYX.c0"}
    assert "EAZ.c0" in two.simulation and two.separated and len(two.units) == 12
    for row in two.simulation.values():
        assert abs(row["identified"] - row["truth"]) <= 3 * row["std"]


def test_after_diagnosis_refuses_components_the_model_lacks(vmc500):
    inst = instrument("probe")
    with pytest.raises(InputError, match="EQQ, not components"):
        after_diagnosis(vmc500, inst, make_setup(vmc500, inst),
                        {"effects": [{"component": "EQQ", "same_at_tool_as": ["EZX"]}]}, 3)
    with pytest.raises(InputError, match="not a diagnosis report"):
        components_to_settle({"machine": "vmc500"})


# ------------------------------------------------------------------ a new instrument is one new module

@dataclass(frozen=True)
class DialX(StopsProgram):
    """A dial indicator along x at the tool point: one reading (dx) per pose."""

    name: str = "dial-x-test"
    unit: str = "pose"
    default_sigma_um: float = 0.5

    def candidates(self, machine, setup, count, layout, seed):
        return list(pose_candidates(setup.zone, machine.axis_kinds, count, layout, seed))

    def measurements(self, machine, setup, units, values=None):
        q = np.asarray(units)
        dev = np.full((len(q), 6), np.nan)
        dev[:, 0] = 0.0 if values is None else values
        return [PointMeasurements("dial", q, dev, {}, np.arange(len(q)))], np.arange(len(q))

    def outputs(self, out, count):
        return [Path(out)]

    def files(self, machine, setup, units):
        return [""]

    def visits(self, machine, units):
        return np.asarray(units)


def test_a_toy_instrument_plans_through_the_registry(vmc500):
    if "dial-x-test" not in INSTRUMENTS:
        register_instrument(DialX())
    with pytest.raises(InputError, match="registered already"):
        register_instrument(DialX())
    p = plan(vmc500, instrument("dial-x-test"), 20, candidates=128)
    # a reading along x sees only x components of the error: z straightness of X is not seen
    assert any(g.kind == "zero" and g.parameters[0].startswith("EZX") for g in p.not_separable)
    assert all(not n.startswith("EZX") for n in p.identifiable)
    INSTRUMENTS.pop("dial-x-test")


# ------------------------------------------------------------------ command line

@pytest.mark.parametrize("argv, option", [
    (["--budget", "0"], "--budget"),
    (["--budget", "5", "--terms", "EQQ"], "--terms"),
    (["--budget", "5", "--targets", "0,0,10"], "--targets"),
    (["--budget", "5", "--zone", "X=0:900"], "--zone"),
    (["--budget", "5000", "--candidates", "64"], "--budget"),
])
def test_cli_refuses_bad_input_naming_the_option(argv, option, capsys):
    assert main(["plan", "vmc500", "--instrument", "probe", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and option in err[0]


def test_cli_checks_outputs_before_work(tmp_path, capsys):
    diag = tmp_path / "d.json"
    diag.write_text(json.dumps({"effects": []}))
    assert main(["plan", "vmc500", "--instrument", "probe", "--budget", "5", "--after", str(diag),
                 "--out", str(diag)]) == 2
    assert "d.json" in capsys.readouterr().err
    assert main(["plan", "ur5", "--instrument", "probe", "--budget", "5", "--candidates", "64",
                 "--nc", str(tmp_path / "ur5.nc")]) == 2
    assert "--nc" in capsys.readouterr().err
    assert not (tmp_path / "ur5.nc").exists()


def _keys(value, out: set) -> set:
    if isinstance(value, dict):
        for k, v in value.items():
            if re.fullmatch(r"[a-z][a-z0-9_]*", k):
                out.add(k)
            _keys(v, out)
    elif isinstance(value, list):
        for v in value:
            _keys(v, out)
    return out


def test_every_plan_field_is_documented(tmp_path, capsys):
    diag = tmp_path / "diagnosis.json"
    diag.write_text(json.dumps({"machine": "vmc500", "effects": [
        {"name": "straightness", "component": "EAZ", "same_at_tool_as": ["EYX"]}]}))
    runs = [["--compare", "--repeats", "1"], ["--after", str(diag), "--tool-lengths", "0", "100"]]
    documented = set(re.findall(r"`([a-z][a-z0-9_]*)`", (ROOT / "docs" / "reports.md").read_text()))
    for extra in runs:
        assert main(["plan", "vmc500", "--instrument", "tracker", "--budget", "8", "--candidates", "64",
                     "--json", *extra]) == 0
        fields = _keys(json.loads(capsys.readouterr().out), set())
        assert fields and not fields - documented, sorted(fields - documented)


def test_plan_example_runs(tmp_path, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("plan_vmc500", ROOT / "examples" / "plan_vmc500.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    result = module.main(tmp_path)
    assert (tmp_path / "plan.nc").exists() and (tmp_path / "measured.csv").exists()
    assert result["after"]["separated"]
    assert result["plan"]["comparison"]["random"]["ratios"]["predicted_zone_rms"] < 1.0


def test_interferometer_runs_are_files_identify_reads(tmp_path, vmc500, capsys):
    """A plan of runs is one positioning-run file per run (both approach directions); filled
    with the machine's error along the axis they are read back and identified."""
    out = tmp_path / "runs.csv"
    assert main(["plan", "vmc500", "--instrument", "interferometer", "--budget", "12", "--candidates", "64",
                 "--out", str(out), "--nc", str(tmp_path / "runs.nc"), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    files = [Path(p) for p in report["files"]["out"]]
    assert [p.name for p in files] == [f"runs_run{i:02d}.csv" for i in range(1, 13)]
    assert len(report["poses"]) == 12 * 2 * 11   # 11 targets up and down per run
    segments = interpret(vmc500, (tmp_path / "runs.nc").read_text())
    assert len(segments) == len(report["poses"])
    filled = []
    for path in files:
        lines = path.read_text().splitlines()
        axis = lines[0].split(":")[1].strip()
        at = dict(item.split("=") for item in lines[1].split(":", 1)[1].replace(" ", "").split(","))
        j = vmc500.axes.index(axis)
        rows = [ln.split(",") for ln in lines[3:]]
        q = np.tile([float(at.get(a, 0.0)) for a in vmc500.axes], (len(rows), 1)) * 1e-3
        q[:, j] = [float(r[0]) * 1e-3 for r in rows]
        directions = np.ones((len(rows), 3))
        directions[:, j] = [int(r[2]) for r in rows]
        e = vmc500.volumetric_error(q, directions=directions)[:, j]   # the axes of vmc500 move along x, y, z
        text = "\n".join(lines[:3] + [f"{r[0]},{r[1]},{r[2]},{v * 1e6:.6f}" for r, v in zip(rows, e)]) + "\n"
        target = tmp_path / f"filled_{path.name}"
        target.write_text(text)
        filled.append(target)
    data = [read_any(p, vmc500) for p in filled]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(vmc500.with_theta(np.zeros(len(vmc500.theta))), data, folds=0, initialise=False)
    assert fit.rms_fit_um < 0.01 and fit.n_points == 12 * 22


def test_files_of_one_unit_each_are_numbered_to_the_width_of_the_count(tmp_path):
    from volerr_pin.studies.plan._protocol import numbered_files

    assert [p.name for p in numbered_files(tmp_path / "bb.csv", 3, "circle")] == [
        "bb_circle01.csv", "bb_circle02.csv", "bb_circle03.csv"]
    many = numbered_files(tmp_path / "runs.csv", 120, "run")
    assert many[0] == tmp_path / "runs_run001.csv" and many[-1].name == "runs_run120.csv"


def test_a_plan_says_what_it_assumes_and_when_it_cannot_resolve_the_error(vmc500, capsys):
    """30 tracker poses at the tracker's default 5 um leave an uncertainty of what they determine
    about as large as that error over the zone: the plan says it is weak, with both figures, and
    the text says the noise it assumed; the same poses with a stated 0.5 um instrument resolve it."""
    weak = plan(vmc500, instrument("tracker"), 30)
    z = weak.zone_um
    error = np.linalg.norm(vmc500.volumetric_error(
        pose_candidates(make_setup(vmc500, instrument("tracker")).zone, vmc500.axis_kinds, 512, "sobol", 1))[:, :3],
        axis=1) * 1e6
    assert z["error_rms_um"] == pytest.approx(np.sqrt(np.mean(error ** 2)), rel=1e-12)
    assert z["determinable_rms_um"] > z["determinable_error_rms_um"] / 3   # a tracker: what it determines
    assert any(n.startswith("weak plan: its predicted uncertainty over the zone") for n in weak.notes)
    strong = plan(vmc500, instrument("tracker"), 30, make_setup(vmc500, instrument("tracker"), sigma_um=0.5))
    assert strong.zone_um["determinable_rms_um"] <= strong.zone_um["determinable_error_rms_um"] / 3
    assert not any(n.startswith("weak plan") for n in strong.notes)
    assert main(["plan", "vmc500", "--instrument", "tracker", "--budget", "30"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "assumed: instrument noise 5 um per observed value (the tracker's default; --sigma-um states yours)" in text
    assert f"for such an error of RMS {z['determinable_error_rms_um']:.3g} um there" in text
    assert "note: weak plan" in text
    assert main(["plan", "vmc500", "--instrument", "tracker", "--budget", "30", "--sigma-um", "0.5"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "assumed: instrument noise 0.5 um per observed value;" in text and "weak plan" not in text


def test_a_trackers_headline_is_what_it_determines_and_simulated_campaigns_find_it(vmc500):
    """A tracker's own placement is fitted, so a rigid motion of the whole map is not
    determined: the headline is the map less its best rigid fit. Campaigns simulated on a
    machine whose every coefficient is off from a prior of zero (those the tracker cannot
    separate included) find that figure; the whole map's error exceeds the prediction by the
    rigid part. The split is exact: total^2 = determinable^2 + rigid^2."""
    from volerr_pin.studies.plan._assess import rigid_basis, simulated, without_rigid

    inst = instrument("tracker")
    setup = make_setup(vmc500, inst)
    p = plan(vmc500, inst, 40, setup, candidates=512)
    z = p.zone_um
    assert z["zone_rms_um"] ** 2 == pytest.approx(z["determinable_rms_um"] ** 2 + z["rigid_rms_um"] ** 2, rel=1e-9)
    assert z["determinable_rms_um"] < 0.7 * z["zone_rms_um"]
    zone_q = pose_candidates(setup.zone, vmc500.axis_kinds, 512, "sobol", 1)
    P = rigid_basis(vmc500.tool_poses(zone_q, nominal=True)[1])
    rigid = np.random.default_rng(3).normal(size=(1, 6))
    field = np.zeros((len(zone_q), 3))
    field[:] = rigid[0, :3]
    assert np.abs(without_rigid(field, P)).max() < 1e-12          # a pure shift is all rigid
    rng = np.random.default_rng(5)
    truth = vmc500.with_theta(vmc500.theta + rng.normal(0.0, 1.0, len(vmc500.theta)) * 2e-6, limits=False)
    free = np.array([vmc500.parameter_names.index(n) for n in p.identifiable])
    zero = np.zeros(len(vmc500.theta))
    det = simulated(truth, inst, setup, p.units, free, zone_q, 8, 11, P, prior=zero)["zone_rms"] * 1e6
    whole = simulated(truth, inst, setup, p.units, free, zone_q, 8, 11, None, prior=zero)["zone_rms"] * 1e6
    assert 0.75 < det / z["determinable_rms_um"] < 1.33, (det, z["determinable_rms_um"])
    assert whole > 1.2 * z["zone_rms_um"]


def test_the_plan_is_compared_with_the_median_of_many_random_sets(vmc500, capsys):
    """One random set is one draw: the comparison's random entry is the median of 21 draws by
    predicted zone uncertainty (recomputed here from the same seeds), and the spread is
    reported."""
    from volerr_pin.studies.plan._assess import predicted, rigid_basis, without_rigid, zone_summary
    from volerr_pin.studies.plan._campaign import RANDOM_SETS, free_coefficients
    from volerr_pin.studies.plan._design import unit_design

    inst = instrument("tracker")
    setup = make_setup(vmc500, inst)
    p = plan(vmc500, inst, 30, setup, candidates=256, compare=True, repeats=1, seed=2)
    sets = p.comparison["random"]["sets"]
    free = free_coefficients(vmc500, None)
    pool_design = unit_design(vmc500, inst, setup, inst.candidates(vmc500, setup, 256, "sobol", 2), free)
    columns = np.array(pool_design.analyse().kept, dtype=int)
    zone_q = pose_candidates(setup.zone, vmc500.axis_kinds, 512, "sobol", 3)
    S = without_rigid(vmc500.sensitivity(zone_q, parameters=free, first_order=True)[:, :3, :],
                      rigid_basis(vmc500.tool_poses(zone_q, nominal=True)[1]))
    zones = []
    for k in range(RANDOM_SETS):
        units = inst.candidates(vmc500, setup, 30, "random", 2 + 7 + k)
        d = unit_design(vmc500, inst, setup, units, free)
        zones.append(zone_summary(predicted(d, np.arange(d.n_units), columns, S)["zone"])["zone_rms_um"])
    determined = sorted(z for z in zones if z is not None)
    assert sets["count"] == RANDOM_SETS and sets["not_determining"] == RANDOM_SETS - len(determined)
    assert sets["predicted_zone_rms_um"]["median"] == pytest.approx(np.median(determined), rel=1e-9)
    assert p.comparison["random"]["zone_rms_um"] == pytest.approx(zones[sets["median_seed"] - 9], rel=1e-9)
    assert sets["plan_over_p10"] == pytest.approx(p.comparison["plan"]["zone_rms_um"] / np.quantile(determined, 0.1))


def test_a_coefficient_that_stands_for_a_combination_is_marked(vmc500):
    """Off from a zero prior by 20 um or arcsec-sized values everywhere, the coefficients a
    tracker cannot separate from others held at their priors carry those others' errors: the
    ones the plan marks (stands_for) reach several of their predicted uncertainties, the
    unmarked stay within two."""
    from volerr_pin.studies.plan._assess import simulated

    inst = instrument("tracker")
    setup = make_setup(vmc500, inst)
    p = plan(vmc500, inst, 40, setup, candidates=512)
    marked = p.stands_for()
    assert marked["EXX.n0"] == ["EXX.n10"]       # the table's last node, held: its first ones absorb it
    assert all(set(held).isdisjoint(p.identifiable) for held in marked.values())
    zone_q = pose_candidates(setup.zone, vmc500.axis_kinds, 512, "sobol", 1)
    truth = vmc500.with_theta(vmc500.theta + np.random.default_rng(5).normal(0.0, 1.0, len(vmc500.theta)) * 20e-6,
                              limits=False)
    free = np.array([vmc500.parameter_names.index(n) for n in p.identifiable])
    s = simulated(truth, inst, setup, p.units, free, zone_q, 8, 11, prior=np.zeros(len(vmc500.theta)))
    ratio = dict(zip(p.identifiable, s["std"] / np.array([p.std[n] for n in p.identifiable])))
    assert max(ratio[n] for n in marked) > 4
    assert max(v for n, v in ratio.items() if n not in marked) < 2.5
    assert p.to_dict()["predicted"]["coefficients"]["EXX.n0"]["stands_for"] == ["EXX.n10"]
