"""Circular tests (ISO 230-4): figures on closed forms, strict reading, and the model round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.measurements import (BallbarRun, MeasurementError, ballbar_run, evaluate_circular, read_any,
                                     read_ballbar, write_ballbar)
from volerr_pin.cli import main
from volerr_pin.fit.diagnosis import diagnose
from volerr_pin.fit.identify import identify
from volerr_pin.model import add_terms

ANGLES = np.linspace(0.0, 2 * np.pi, 360, endpoint=False)
CENTRE = {"X": 250.0, "Y": 200.0, "Z": 200.0}


def run_of(deviation_um, direction=None, angle=ANGLES):
    direction = np.ones(len(angle)) if direction is None else direction
    return BallbarRun("test", angle, np.asarray(deviation_um) * 1e-6, direction, 0.1, ("X", "Y"), {},
                      np.arange(len(angle)))


def test_closed_forms_of_the_figures():
    # a set-up offset alone: the least-squares centre takes it all, nothing is left
    r = evaluate_circular(run_of(3.0 * np.cos(ANGLES) - 2.0 * np.sin(ANGLES) + 1.5))
    assert r["centre_offset_um"] == pytest.approx([3.0, -2.0], abs=1e-12)
    assert r["radius_error_um"] == pytest.approx(1.5, abs=1e-12)
    assert r["G"] == pytest.approx(0.0, abs=1e-12) and r["H"] is None
    assert (r["F_max"], r["F_min"]) == pytest.approx((1.5 + np.sqrt(13), 1.5 - np.sqrt(13)), abs=1e-3)
    # an ellipse (scale mismatch) of +-s: G = 2 s
    r = evaluate_circular(run_of(2.5 * np.cos(2 * ANGLES)))
    assert r["G"] == pytest.approx(5.0, abs=1e-12) and r["G_ccw"] == pytest.approx(5.0, abs=1e-12)
    # the two directions apart by h everywhere: H = h, each direction round (G_ccw = G_cw = 0)
    both = np.concatenate([ANGLES, ANGLES[::-1]])
    direction = np.concatenate([np.ones(360), -np.ones(360)])
    r = evaluate_circular(run_of(np.where(direction > 0, 0.8, -0.8), direction, both))
    assert r["H"] == pytest.approx(1.6, abs=1e-12)
    assert r["G_ccw"] == pytest.approx(0.0, abs=1e-12) and r["G_cw"] == pytest.approx(0.0, abs=1e-12)
    assert r["G"] == pytest.approx(1.6, abs=1e-12) and (r["n_ccw"], r["n_cw"]) == (360, 360)


def test_sampled_hysteresis_needs_no_common_angles():
    """H compares the directions at the same angle even when they were sampled elsewhere."""
    shifted = ANGLES + np.radians(0.37)
    both = np.concatenate([ANGLES, shifted[::-1]])
    direction = np.concatenate([np.ones(360), -np.ones(360)])
    r = evaluate_circular(run_of(np.where(direction > 0, 0.3, -0.3) + 1.0 * np.cos(2 * both), direction, both))
    assert r["H"] == pytest.approx(0.6, abs=2e-3)  # interpolation of a cos 2a at 1 deg spacing


def _truth(machine):
    """vmc500 with backlash of X and Y and a squareness of X, Y 8 arcsec off the spec."""
    spec = add_terms(machine, {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 0.0},
                               "EYY": {"kind": "backlash", "prefix": "rev", "reversal_um": 0.0}})
    names = list(spec.parameter_names)
    theta = spec.theta.copy()
    theta[names.index("EXX.rev.b")] = 4e-6
    theta[names.index("EYY.rev.b")] = 2e-6
    theta[names.index("EC0Y.c0")] += np.radians(8.0 / 3600)
    return spec, spec.with_theta(theta), names


def test_file_round_trip_and_identification(machines, tmp_path):
    """Simulated exactly (bar length, not the model's projection), written, read, fitted: the
    squareness, both backlashes and the set-up come back within 3 standard uncertainties."""
    spec, truth, names = _truth(machines["vmc500"])
    run = ballbar_run(truth, centre_mm=CENTRE, noise_um=0.1, seed=1, setup_offset_um=(3.0, -2.0),
                      length_error_um=1.5)
    path = tmp_path / "circle.csv"
    write_ballbar(run, path)
    back = read_any(path, spec)
    assert isinstance(back, BallbarRun) and back.plane == ("X", "Y") and back.centre == CENTRE
    np.testing.assert_allclose(back.deviation, run.deviation, atol=0.6e-11)  # written to 1e-5 um
    free = [names.index(n) for n in ("EXX.rev.b", "EYY.rev.b", "EC0Y.c0")]
    report = identify(spec, [back], free=free, folds=0, sigma_um=0.1).to_dict()
    expected = {"EXX.rev.b": 4.0, "EYY.rev.b": 2.0, "EC0Y.c0": 4.0 + 8.0}   # um, um, arcsec
    for name, value in expected.items():
        p = report["parameters"][name]
        assert abs(p["value"] - value) < 3 * p["uncertainty"], (name, p)
    nuisance = {k.split("[")[0]: v["value"] for k, v in report["nuisance"].items()}
    # the table ball sits (3, -2) um off: the bar reads it with the opposite sign; length +1.5
    assert nuisance["centre_X"] == pytest.approx(-3.0, abs=0.05)
    assert nuisance["centre_Y"] == pytest.approx(2.0, abs=0.05)
    assert nuisance["length"] == pytest.approx(1.5, abs=0.05)
    assert report["rms_fit_um"] == pytest.approx(0.1, rel=0.15)


def test_diagnose_names_backlash_from_circles(machines):
    """Two circles of a machine whose X has 4 um of backlash the spec lacks: diagnose names it."""
    m = machines["vmc500"]
    truth = add_terms(m, {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 4.0}})
    runs = [ballbar_run(truth, centre_mm=CENTRE, noise_um=0.1, seed=1, setup_offset_um=(3, -2), source="c1"),
            ballbar_run(truth, centre_mm={"X": 250, "Y": 200, "Z": 100}, radius_mm=150, noise_um=0.1, seed=2,
                        source="c2")]
    result = diagnose(m, runs)
    assert [(e.name, e.axis) for e in result.effects] == [("backlash", "X")]
    (p,) = result.effects[0].parameters.values()
    assert abs(p["value"] - 4.0) < 3 * p["uncertainty"]
    assert result.rms_after_um < 0.12 < 1.0 < result.rms_before_um
    # the two directions meet at every angle but differ by the backlash: that is no repeat,
    # so the floor is the residual's upper bound, at the simulated noise
    assert result.noise_floor_upper_bound and result.noise_floor_um == pytest.approx(0.1, rel=0.1)


@pytest.mark.parametrize("text, match", [
    ("angle_deg,deviation_um\n0,1\n", r"circle.csv: which axes ran the circle\? Give '# plane: X, Y'"),
    ("# plane: X, Y\nangle_deg,deviation_um\n0,1\n", r"circle.csv: give the nominal radius"),
    ("# plane: X, X\n# radius: 100\nangle_deg,deviation_um\n0,1\n", r"two different axes expected"),
    ("# plane: X, Y\n# radius: -5\nangle_deg,deviation_um\n0,1\n", r"must be positive"),
    ("# plane: X, Y\n# radius: 100\nangle_deg,deviation_um,direction\n0,1,up\n5,1,sideways\n",
     r"circle.csv:5:3: column 'direction': 'sideways' is not a direction"),
    ("# plane: X, Y\n# radius: 100\nangle_deg,deviation_um\n0,abc\n", r"circle.csv:4:2: .*'abc' is not a number"),
    ("# plane: X, Y\n# radius: 100\n# centre: X=abc\nangle_deg,deviation_um\n0,1\n", r"'X=abc' is not AXIS=VALUE"),
])
def test_malformed_ballbar_files(tmp_path, text, match):
    path = tmp_path / "circle.csv"
    path.write_text(text)
    with pytest.raises(MeasurementError, match=match):
        read_ballbar(path)


def test_a_circle_beyond_the_travel_names_the_file(machines, tmp_path):
    path = tmp_path / "circle.csv"
    path.write_text("# plane: X, Y\n# radius: 300\n# centre: X=250, Y=200\nangle_deg,deviation_um\n"
                    "0,1\n90,1\n180,1\n270,1\n")
    with pytest.raises(vp.InputError, match=r"circle.csv: the circle leaves the travel"):
        identify(machines["vmc500"], [read_ballbar(path)])


def test_cli_ballbar(machines, tmp_path, capsys):
    _, truth, _ = _truth(machines["vmc500"])
    path = tmp_path / "circle.csv"
    write_ballbar(ballbar_run(truth, centre_mm=CENTRE, noise_um=0.1, seed=3), path)
    assert main(["ballbar", str(path), "--json", "--png", str(tmp_path / "c.png")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["G"] > report["G_ccw"] > 0 and report["H"] > 2.0          # 4 um of backlash in X
    assert report["png"] == str(tmp_path / "c.png") and "plot" not in report   # one name for the picture
    assert (tmp_path / "c.png").stat().st_size > 10_000
    assert main(["ballbar", str(path)]) == 0
    assert "circular hysteresis" in capsys.readouterr().out


# ---------------------------------------------------------------- degenerate geometry (issue 22)

HEAD = "# plane: X, Y\n# radius: 100\nangle_deg,deviation_um,direction\n"


def sweep(first_deg, last_deg, n=40, direction=1):
    return "".join(f"{float(a)!r},{float(0.5 * np.sin(np.radians(a)))!r},{direction}\n"
                   for a in np.linspace(first_deg, last_deg, n))


@pytest.mark.parametrize("rows, match", [
    ("".join("0,%d,1\n" % i for i in range(10)),
     r"circle\.csv: the counter-clockwise \(\+1\) samples cover 0 deg of the circle; a circular test needs at "
     r"least 90 deg"),
    (sweep(10.0, 10.05), r"circle\.csv: the counter-clockwise \(\+1\) samples cover 0\.05 deg"),
    (sweep(0.0, 45.0), r"cover 45 deg of the circle"),
    (sweep(0.0, 360.0) + sweep(0.0, 20.0, direction=-1), r"the clockwise \(-1\) samples cover 20 deg"),
    ("0,1,1\n120,1,1\n240,1,1\n", r"circle\.csv: 3 counter-clockwise \(\+1\) sample\(s\); a circular test needs at "
                                  "least 4 per direction"),
    (sweep(0.0, 360.0) + "90,-150000,1\n", r"circle\.csv:\d+:2: column 'deviation_um': a radial deviation of "
                                           r"-150000 um is not smaller than the radius 100 mm"),
    ("0,1e300,1\n", r"circle\.csv:4:2: column 'deviation_um': 1e\+300 um is implausible"),
    ("1e300,1,1\n", r"circle\.csv:4:1: column 'angle_deg': 1e\+300 deg is implausible"),
])
def test_degenerate_circles_are_refused(tmp_path, rows, match):
    path = tmp_path / "circle.csv"
    path.write_text(HEAD + rows)
    with pytest.raises(MeasurementError, match=match):
        read_ballbar(path)


@pytest.mark.parametrize("radius, match", [
    ("0", r"must be positive"), ("-5", r"must be positive"), ("1e300", r"must be positive and at most 1e\+06 mm"),
    ("100 um", r"'# radius: 100 um': not a number of mm"), ("nan", r"not a number of mm"),
    ("100 mm", None), ("100mm", None),
])
def test_the_radius_is_a_positive_length_in_mm(tmp_path, radius, match):
    path = tmp_path / "circle.csv"
    path.write_text(HEAD.replace("100", radius) + sweep(0.0, 350.0))
    if match is None:
        assert read_ballbar(path).radius == pytest.approx(0.1)
    else:
        with pytest.raises(MeasurementError, match=match):
            read_ballbar(path)


def test_a_quarter_circle_is_enough_and_its_figures_are_right(tmp_path):
    """90 deg (the least arc taken) of a set-up offset alone: the centre comes back, G = 0."""
    a = np.linspace(0.0, 90.0, 46)
    r = 3.0 * np.cos(np.radians(a)) - 2.0 * np.sin(np.radians(a)) + 1.5
    path = tmp_path / "circle.csv"
    path.write_text(HEAD + "".join(f"{float(x)!r},{float(y)!r},1\n" for x, y in zip(a, r)))
    result = evaluate_circular(read_ballbar(path))
    assert result["centre_offset_um"] == pytest.approx([3.0, -2.0], abs=1e-9)
    assert result["radius_error_um"] == pytest.approx(1.5, abs=1e-9) and result["G"] == pytest.approx(0.0, abs=1e-9)


def test_evaluating_a_run_built_in_code_checks_its_arc_too():
    short = np.radians(np.linspace(0.0, 2.0, 30))
    with pytest.raises(vp.InputError, match=r"test: the counter-clockwise \(\+1\) samples cover 2 deg"):
        evaluate_circular(run_of(np.zeros(30), angle=short))
