"""volerr_pin.studies.plan._ballbar: circles as identify sees them (predicted covariance = identify's),
the files read back and identified after filling them with the machine's exact kinematics, the
NC program read back by the product's NC reader to the same circles, the time in closed form,
the travel kept, the plan against random circles, and the command line's refusals."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.base import InputError
from volerr_pin.compensation.gcode import interpret
from volerr_pin.fit.identify import identify
from volerr_pin.measurements import BallbarRun, read_any
from volerr_pin.studies.plan import instrument, make_setup, plan
from volerr_pin.studies.plan._ballbar import Ballbar, Circle
from volerr_pin.studies.plan._poses import pose_candidates
from volerr_pin.studies.plan._assess import simulated


@pytest.fixture(scope="module")
def vmc500():
    return vp.load_machine("vmc500")


@pytest.fixture(scope="module")
def planned(vmc500):
    inst = instrument("ballbar")
    return plan(vmc500, inst, 8, make_setup(vmc500, inst), candidates=64, seed=3)


def test_ballbar_is_registered_and_plans_circles_inside_the_zone(vmc500, planned):
    inst = instrument("ballbar")
    assert isinstance(inst, Ballbar) and inst.unit == "circle"
    assert len(planned.units) == 8 and all(isinstance(c, Circle) for c in planned.units)
    assert not planned.notes and planned.zone_um["zone_rms_um"] > 0
    # the set-up absorbs every constant offset: no ballbar plan determines one (named, with the reason)
    zero = {g.parameters[0] for g in planned.not_separable if g.kind == "zero"}
    assert {"EYX.c0", "EZX.c0", "EXY.c0", "EZY.c0", "EXZ.c0", "EYZ.c0"} <= zero
    assert not zero & set(planned.identifiable)


@pytest.mark.parametrize("zone, layout", [(None, "sobol"), (None, "random"), (None, "grid"),
                                          ([[0.1, 0.35], [0.05, 0.4], [0.0, 0.25]], "random")])
def test_circles_stay_inside_the_zone(vmc500, zone, layout):
    """Every sample of every candidate circle lies in the zone (and the travel), radii from the
    stated set, planes of two linear axes."""
    inst = instrument("ballbar")
    setup = make_setup(vmc500, inst, zone=zone)
    circles = inst.candidates(vmc500, setup, 40, layout, 5)
    assert len(circles) == 40
    q = inst.visits(vmc500, circles)
    assert np.all(q >= setup.zone[:, 0] - 1e-12) and np.all(q <= setup.zone[:, 1] + 1e-12)
    vp.model.check_q(vmc500.model, q)
    assert {c.radius for c in circles} <= set(inst.radii)
    span = np.diff(setup.zone, axis=1)[:, 0]
    fits = {r for r in inst.radii if 2 * r <= min(span)}
    assert {c.radius for c in circles} == fits   # every radius that fits is offered
    assert {tuple(sorted(c.plane)) for c in circles} == {(0, 1), (1, 2), (0, 2)}


def test_a_zone_too_small_for_any_bar_is_refused(vmc500):
    inst = instrument("ballbar")
    setup = make_setup(vmc500, inst, zone=[[0.0, 0.09], [0.0, 0.4], [0.0, 0.08]])
    with pytest.raises(InputError, match="no ballbar circle") as err:
        inst.candidates(vmc500, setup, 4, "sobol", 0)
    assert err.value.parameters == ("zone",)
    # X spans 90 mm and Z 80 mm: no 50 mm bar fits; a 40 mm bar fits in every plane
    small = Ballbar(radii=(0.04,))
    circles = small.candidates(vmc500, setup, 6, "sobol", 0)
    assert {tuple(c.plane) for c in circles} == {(0, 1), (1, 2), (2, 0)}


def _rows(machine, inst, setup, units):
    data, _ = inst.measurements(machine, setup, units)
    return sum(len(m.angle) for m in data)


def test_predicted_uncertainty_is_identifys_covariance(vmc500, planned):
    """sigma (J^T W J)^-1 over the identified coefficients, each circle's centre offset and
    bar length projected out, is what identify reports for the same circles (its nuisance
    terms as columns)."""
    inst = instrument("ballbar")
    setup = planned.setup
    noise = np.random.default_rng(2).normal(0, setup.sigma, _rows(vmc500, inst, setup, planned.units))
    data, _ = inst.measurements(vmc500, setup, planned.units, noise)
    assert all(isinstance(d, BallbarRun) for d in data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(vmc500, data, folds=0, sigma_um=setup.sigma * 1e6, initialise=False)
    names = vmc500.parameter_names
    fitted = {names[k]: fit.uncertainty[k] / fit.residual_sigma for k in fit.fitted}
    assert set(fitted) == set(planned.std)
    for name, std in planned.std.items():
        assert std == pytest.approx(fitted[name], rel=2e-3), name


def _fill(machine, path: Path, out: Path) -> None:
    """Fill a planned ballbar file with what a bar of the nominal length would read on
    ``machine`` (exact kinematics): the distance from the actual tool point to the table ball,
    seated where the nominal tool point is at the circle's centre, less the nominal radius."""
    lines = path.read_text().splitlines()
    meta = {ln[1:].split(":")[0].strip(): ln.split(":", 1)[1] for ln in lines if ln.startswith("#") and ":" in ln}
    plane = [a.strip() for a in meta["plane"].split(",")]
    radius = float(meta["radius"]) * 1e-3
    centre = dict(item.split("=") for item in meta["centre"].replace(" ", "").split(","))
    c = np.array([float(centre[a]) for a in machine.axes]) * 1e-3
    head = [i for i, ln in enumerate(lines) if ln.startswith("angle_deg")][0]
    rows = [ln.split(",") for ln in lines[head + 1:]]
    a = np.radians([float(r[0]) for r in rows])
    q = np.tile(c, (len(rows), 1))
    j1, j2 = (machine.axes.index(p) for p in plane)
    q[:, j1] += radius * np.cos(a)
    q[:, j2] += radius * np.sin(a)
    directions = np.ones_like(q)   # the motion's approach directions, as the reader derives them
    sense = np.array([float(r[2]) for r in rows])
    directions[:, j1] = np.where(-np.sin(a) * sense >= 0, 1.0, -1.0)
    directions[:, j2] = np.where(np.cos(a) * sense >= 0, 1.0, -1.0)
    _, ball = machine.tool_poses(c[None, :], nominal=True)
    _, p = machine.tool_poses(q, directions=directions) if _takes_directions(machine) else machine.tool_poses(q)
    dev = np.linalg.norm(p - ball, axis=1) - radius
    body = [f"{r[0]},{v * 1e6:.6f},{r[2]}" for r, v in zip(rows, dev)]
    out.write_text("\n".join(lines[:head + 1] + body) + "\n")


def _takes_directions(machine) -> bool:
    import inspect

    return "directions" in inspect.signature(machine.tool_poses).parameters


def test_filled_circles_are_read_and_identified(tmp_path, vmc500, capsys):
    """plan -> files filled with the exact kinematics -> read_any -> identify: the model
    explains the data to well below the noise, and the coefficients the plan identifies are
    recovered (what it calls not separable is not asked of it)."""
    out, nc, template = tmp_path / "bb.csv", tmp_path / "bb.nc", tmp_path / "results.csv"
    assert main(["plan", "vmc500", "--instrument", "ballbar", "--budget", "6", "--candidates", "48", "--out",
                 str(out), "--template", str(template), "--nc", str(nc), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    files = [Path(p) for p in report["files"]["template"]]
    assert [p.name for p in files] == [f"results_circle{i:02d}.csv" for i in range(1, 7)]
    assert [Path(p).name for p in report["files"]["out"]] == [f"bb_circle{i:02d}.csv" for i in range(1, 7)]
    assert report["unit"] == "circle" and len(report["poses"]) == 6 * 2 * 72
    with pytest.raises(Exception):
        read_any(Path(report["files"]["out"][0]), vmc500)   # deviations empty: not data yet
    filled = []
    for path in files:
        target = tmp_path / f"filled_{path.name}"
        _fill(vmc500, path, target)
        filled.append(target)
    data = [read_any(p, vmc500) for p in filled]
    assert all(isinstance(d, BallbarRun) for d in data)
    prior = vmc500.with_theta(np.zeros(len(vmc500.theta)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(prior, data, folds=0, initialise=False)
    assert fit.n_points == 6 * 144
    assert fit.rms_fit_um < 0.02   # noiseless exact data: the identifiable model explains them
    assert main(["identify", "vmc500", *map(str, filled), "--folds", "0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_points"] == fit.n_points


def test_nc_program_reads_back_to_the_planned_circles(vmc500, planned):
    """The product's NC reader finds, per circle and direction, arcs about the planned centre
    of the planned radius in the planned plane, sweeping lead-in + 360 deg + lead-out in the
    run's sense, in the plan's order, after one dwell each."""
    inst = instrument("ballbar")
    assert {c.plane for c in planned.units} == {(0, 1), (1, 2), (2, 0)}   # G17, G19 and G18 all read back
    text = inst.program(vmc500, planned.units, 1500.0, 2.5, "ballbar (test)")
    assert text.count("G4 P2.5") == 2 * len(planned.units)
    arcs = [s for s in interpret(vmc500, text) if s.kind == "arc"]
    assert len(arcs) == 4 * 2 * len(planned.units)
    for i, circle in enumerate(planned.units):
        for k, d in enumerate(circle.directions):
            run = arcs[(2 * i + k) * 4:(2 * i + k + 1) * 4]
            sweep = sum(s.arc.sweep for s in run)
            assert sweep == pytest.approx(d * math.radians(360 + 2 * inst.lead_deg), abs=1e-6)
            for s in run:
                plane = s.arc.plane[:2]
                assert set(plane) == set(circle.plane)
                centre = dict(zip(plane, s.arc.center))
                for j in circle.plane:
                    assert centre[j] == pytest.approx(circle.centre[j], abs=1e-7)
                assert s.arc.radius == pytest.approx(circle.radius, abs=1e-7)
                off = [j for j in range(3) if j not in circle.plane][0]
                assert s.start[off] == pytest.approx(circle.centre[off], abs=1e-7)


def test_time_estimate_closed_form(vmc500):
    """One 100 mm circle, both directions, 45 deg leads: the clockwise lead-in starts where
    the counter-clockwise lead-out ends, so the path is two arcs of 450 deg."""
    inst = instrument("ballbar")
    circle = Circle((0, 1), np.array([0.25, 0.2, 0.1]), 0.1)
    t = inst.duration(vmc500, [circle], 1000.0, 4.0)
    path = 2 * 2 * math.pi * 100.0 * 450.0 / 360.0
    assert t["path_mm"] == pytest.approx(path)
    assert t["total_s"] == pytest.approx(path / 1000.0 * 60.0 + 8.0)
    two = inst.duration(vmc500, [circle, Circle((0, 1), np.array([0.25, 0.2, 0.2]), 0.1)], 1000.0, 0.0)
    assert two["path_mm"] == pytest.approx(2 * path + 100.0)   # a 100 mm move in Z between the circles
    with pytest.raises(InputError, match="feed_mm_min"):
        inst.duration(vmc500, [circle], 0.0, 1.0)


def test_plan_beats_random_circles_predicted_and_simulated(vmc500):
    p = plan(vmc500, instrument("ballbar"), 6, candidates=64, compare=True, repeats=3, seed=1)
    c = p.comparison
    assert c["plan"]["not_identified"] == []
    r = c["random"]["ratios"]
    if c["random"].get("not_comparable"):   # random circles that leave coefficients undetermined
        assert c["random"]["not_identified"] and c["random"]["not_comparable"]
    else:
        assert r["predicted_std_geomean"] < 1.0 and r["simulated_std_geomean"] < 1.0
        assert r["predicted_zone_rms"] is None or r["predicted_zone_rms"] < 1.0


def test_simulated_campaigns_find_the_predicted_uncertainty(vmc500, planned):
    """20 simulated campaigns identified by identify: the RMS error of every coefficient and of
    the volumetric error over the zone match the prediction (20 repeats: a coefficient's RMS
    is within about +-35 % of its standard deviation, their median and the zone's within 20 %)."""
    free = np.array([vmc500.parameter_names.index(n) for n in planned.identifiable])
    zone_q = pose_candidates(planned.setup.zone, vmc500.axis_kinds, 256, "sobol", 4)
    s = simulated(vmc500, instrument("ballbar"), planned.setup, planned.units, free, zone_q, 20, 100)
    ratio = s["std"] / np.array([planned.std[n] for n in planned.identifiable])
    assert 0.8 < np.median(ratio) < 1.2 and np.all((ratio > 0.55) & (ratio < 1.45)), ratio
    assert s["held"] == []
    predicted_rms = planned.zone_um["zone_rms_um"] * 1e-6
    assert 0.8 < s["zone_rms"] / predicted_rms < 1.25


@pytest.mark.parametrize("argv, option", [
    (["--zone", "X=0:80", "Y=0:400", "Z=0:70"], "--zone"),
    (["--targets", "0,0,10"], "--targets"),
    (["--feed-mm-min", "0"], "--feed-mm-min"),
    (["--budget", "0"], "--budget"),
])
def test_cli_refuses_bad_input_naming_the_option(argv, option, capsys):
    args = ["plan", "vmc500", "--instrument", "ballbar", "--candidates", "16", *argv]
    if "--budget" not in argv:
        args += ["--budget", "2"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and option in err[0]
