"""Laser-tracker data: absolute coordinates, the tracker's placement as a nuisance, several targets."""

from __future__ import annotations

import json

import numpy as np
import pytest

from volerr_pin.cli import main
from volerr_pin.fit.identify import identify
from volerr_pin.measurements import MeasurementError, TrackerMeasurements, read_any, read_tracker, register
from volerr_pin.measurements._tracker import tracker_observations
from volerr_pin.measurements._simulate import tracker_campaign, write_tracker
from volerr_pin.model import sample

TARGETS = ((0.0, 0.0, 0.0), (60.0, 0.0, -30.0), (0.0, 70.0, -30.0))


def test_register_is_exact_on_a_rigid_motion():
    rng = np.random.default_rng(0)
    points = rng.normal(size=(20, 3))
    angle = 0.7
    R = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    R2, t2 = register(points, points @ R.T + [1.0, -2.0, 3.0])
    np.testing.assert_allclose(R2, R, atol=1e-12)
    np.testing.assert_allclose(t2, [1.0, -2.0, 3.0], atol=1e-12)


@pytest.fixture(scope="module")
def truth(machines):
    m = machines["vmc500"]
    rng = np.random.default_rng(3)
    return m, m.with_theta(m.theta * (1 + 0.3 * rng.normal(size=len(m.theta))))


def test_ground_truth_through_the_tracker_frame(truth, tmp_path):
    """150 poses x 3 targets measured by a tracker 30 deg / 5 deg turned and 2 m away: the fit
    reaches the noise, and the model with its fitted registration reproduces the noiseless
    tracker coordinates of new poses to well within the noise."""
    m, real = truth
    data = tracker_campaign(real, 150, TARGETS, noise_um=1.0, seed=4)
    path = tmp_path / "tracker.csv"
    write_tracker(data, m, path)
    back = read_any(path, m)
    assert isinstance(back, TrackerMeasurements) and back.targets[:3] == ("T1", "T2", "T3")
    np.testing.assert_allclose(back.coordinates, data.coordinates, atol=0.6e-9)
    res = identify(m, [back], folds=0, sigma_um=1.0)
    report = res.to_dict()
    dof = 3 * len(back.q) - report["rank"] - 6
    assert report["residual_sigma"] == pytest.approx(1.0, abs=4 / np.sqrt(dof))  # noise 1 um / coordinate
    # new poses: the fitted machine, placed by the fitted registration, predicts the tracker
    new = tracker_campaign(real, 60, TARGETS, noise_um=0.0, seed=11)
    first = tracker_observations(m, back)
    R0, t0 = first["rotation"], first["translation"]
    nu = {k.split("[")[0]: v["value"] * 1e-6 for k, v in report["nuisance"].items()}
    shift = np.array([nu["shift_x"], nu["shift_y"], nu["shift_z"]])
    turn = np.array([nu["rotation_x"], nu["rotation_y"], nu["rotation_z"]])
    R_fit, p_fit = res.machine.tool_poses(new.q)
    target = p_fit + np.einsum("nij,nj->ni", R_fit, new.offsets)
    predicted = (target + shift + np.cross(turn, target)) @ R0.T + t0
    gap = np.linalg.norm(predicted - new.coordinates, axis=1)
    assert gap.max() < 1.0e-6 and np.sqrt(np.mean(gap**2)) < 0.5e-6


def test_targets_off_the_tool_see_its_orientation(truth):
    """One target on the tool point cannot see the tool's tilt; three targets can: more
    coefficients become identifiable, and the fitted orientation error is closer to the truth."""
    m, real = truth
    q = sample(m, 200, seed=9)
    fits = {}
    for name, offsets in (("one", TARGETS[:1]), ("three", TARGETS)):
        res = identify(m, [tracker_campaign(real, 150, offsets, noise_um=1.0, seed=4)], folds=0, sigma_um=1.0)
        fits[name] = (res.to_dict()["rank"], np.abs(res.machine.volumetric_error(q)[:, 3:]
                                                    - real.volumetric_error(q)[:, 3:]).max())
    assert fits["three"][0] > fits["one"][0]
    assert fits["three"][1] < 0.6 * fits["one"][1]


@pytest.mark.parametrize("text, match", [
    ("x,y,z,tx,ty\n1,1,1,1,1\n", r"tracker.csv:1: a tracker file needs the columns tx, ty, tz .* missing tz"),
    ("x,y,z,tx,ty,tz,ox,oy\n1,1,1,1,1,1,0,0\n", r"tracker.csv:1: target offsets need all of ox, oy, oz"),
    ("x,y,z,tx,ty,tz_um\n1,1,1,1,1,1\n", r"tracker.csv:1:6: column 'tz_um': unit 'um' is not the file unit 'mm'"),
    ("x,y,z,target,ox,oy,oz,tx,ty,tz\n1,1,1,A,0,0,0,1,1,1\n2,2,2,A,5,0,0,1,1,1\n",
     r"tracker.csv:3: target 'A' has the offset .* on line 2"),
    ("x,y,z,tx,ty,tz\n1,1,1,1,1,abc\n", r"tracker.csv:2:6: .*'abc' is not a number"),
    # issue 22: a coordinate or offset beyond 1 km, a column under two spellings, a nameless target
    ("x,y,z,tx,ty,tz\n1,1,1,1e300,1,1\n",
     r"tracker.csv:2:4: column 'tx': 1e\+300 mm is implausible: a position lies within \+-1e\+06 mm"),
    ("x,y,z,tx,ty,tz,ox,oy,oz\n1,1,1,1,1,1,0,-2e6,0\n", r"tracker.csv:2:8: column 'oy': -2000000 mm is implausible"),
    ("x,y,z,tx,ty,tz,tz_mm\n1,1,1,1,1,1,1\n", r"tracker.csv:1:7: columns 'tz' \(column 6\) and 'tz_mm' are both tz"),
    ("x,y,z,target,tx,ty,tz\n1,1,1,A,1,1,1\n2,2,2, ,1,1,1\n", r"tracker.csv:3:4: column 'target': empty target name"),
])
def test_malformed_tracker_files(machines, tmp_path, text, match):
    path = tmp_path / "tracker.csv"
    path.write_text(text)
    with pytest.raises(MeasurementError, match=match):
        read_tracker(path, machines["vmc500"])


def test_collinear_targets_are_refused(machines, tmp_path):
    m = machines["vmc500"]
    path = tmp_path / "tracker.csv"
    path.write_text("x,y,z,tx,ty,tz\n" + "".join(f"{v},100,100,{v},0,0\n" for v in (10, 20, 30, 40)))
    with pytest.raises(Exception, match="the measured targets lie on a line"):
        identify(m, [read_tracker(path, m)])


def test_cli_identify_reads_tracker_files(truth, tmp_path, capsys):
    m, real = truth
    path = tmp_path / "tracker.csv"
    write_tracker(tracker_campaign(real, 80, TARGETS, noise_um=1.0, seed=5), m, path)
    assert main(["identify", "vmc500", str(path), "--folds", "0", "--sigma-um", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    units = {k.split("[")[0]: v["unit"] for k, v in report["nuisance"].items()}
    assert units == {"shift_x": "um", "shift_y": "um", "shift_z": "um",
                     "rotation_x": "urad", "rotation_y": "urad", "rotation_z": "urad"}
    assert report["n_observations"] == 3 * 240
