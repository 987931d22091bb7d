"""A new instrument is one new module: a measurement kind defined here, registered, read by
``read_any`` and identified through, with no edit to the library. And the built-in kinds keep
to the same protocol."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.fit.identify import build_observations, identify, pose_folds
from volerr_pin.measurements import (Measurement, MeasurementError, MeasurementKind, NuisanceTerm, ObservationBlock,
                                     ObservationOptions, Table, _registry as registry)
from volerr_pin.measurements._simulate import campaign, tracker_campaign

# ---------------------------------------------------------------- the toy instrument, as a user writes it


@dataclass(frozen=True)
class IndicatorReadings:
    """A dial indicator on the table, touching the tool along a unit direction ``u`` (workpiece
    frame): it reads the tool's displacement along ``u`` plus its own zero. Each mounting of
    the indicator (``setup``) is one pose: its readings leave a cross-validation together."""

    source: str
    q: np.ndarray            # (n, 3) m
    u: np.ndarray            # (n, 3)
    reading: np.ndarray      # (n,) m
    setup: np.ndarray        # (n,) int
    lines: np.ndarray
    unused: tuple = ()

    def observations(self, machine, options: ObservationOptions) -> ObservationBlock:
        n = len(self.q)
        w = np.zeros((n, 6))
        w[:, :3] = self.u
        return ObservationBlock(self.source, self.q, {}, np.arange(n), w, self.reading,
                                np.full(n, options.sigma_um * 1e-6), np.zeros(n, bool), self.lines,
                                np.ones((n, 1)), (NuisanceTerm(f"zero[indicator {self.source}]", False),),
                                poses=self.setup)


def read_indicator(table, machine) -> IndicatorReadings:
    cols = {h: c for c, h in enumerate(table.header)}
    q = np.column_stack([table.column(cols[a.lower()]) for a in machine.axes]) * 1e-3
    u = np.column_stack([table.column(cols[c]) for c in ("ux", "uy", "uz")])
    return IndicatorReadings(table.path, q, u / np.linalg.norm(u, axis=1, keepdims=True),
                             table.column(cols["reading_um"]) * 1e-6, table.column(cols["setup"]).astype(int),
                             np.array(table.lines))


INDICATOR = MeasurementKind("indicator", "indicator readings", True, recognises=lambda header: "reading_um" in header,
                            read=lambda table, machine=None, axis=None: read_indicator(table, machine))

# ----------------------------------------------------------------------------------------------


@pytest.fixture
def kinds(monkeypatch):
    """The registry as shipped, restored after the test."""
    monkeypatch.setattr(registry, "KINDS", list(registry.KINDS))
    return registry.KINDS


def _truth_and_file(machine, tmp_path, setups=40, per_setup=3, zero_um=2.5, seed=4):
    """A vmc500 whose positioning and squareness differ from the spec, read by an indicator
    mounted ``setups`` times, ``per_setup`` readings in different directions at different
    positions each time."""
    rng = np.random.default_rng(seed)
    names = machine.parameter_names
    moved = [k for k, n in enumerate(names) if n.split(".")[0] in ("EXX", "EYY", "EC0Y")]
    theta = machine.theta.copy()
    theta[moved] += rng.normal(0.0, 2e-6, len(moved))
    truth = machine.with_theta(theta)
    n = setups * per_setup
    q = rng.uniform(machine.travel[:, 0], machine.travel[:, 1], (n, 3))
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    reading = np.einsum("nk,nk->n", u, truth.volumetric_error(q)[:, :3]) + zero_um * 1e-6
    setup = np.repeat(np.arange(setups), per_setup)
    rows = [f"{x:.9f},{y:.9f},{z:.9f},{a:.15f},{b:.15f},{c:.15f},{r:.12f},{s}"
            for (x, y, z), (a, b, c), r, s in zip(q * 1e3, u, reading * 1e6, setup)]
    path = tmp_path / "indicator.csv"
    path.write_text("x,y,z,ux,uy,uz,reading_um,setup\n" + "\n".join(rows) + "\n")
    return truth, moved, path


def test_a_new_instrument_is_one_module_read_and_identified_through_the_protocol(machines, tmp_path, kinds):
    m = machines["vmc500"]
    truth, moved, path = _truth_and_file(m, tmp_path)
    with pytest.raises(MeasurementError, match="no deviation column"):   # not registered: read as points
        registry.read_any(path, m)
    registry.register_kind(INDICATOR)
    data = registry.read_any(path, m)
    assert isinstance(data, IndicatorReadings) and isinstance(data, Measurement)
    result = identify(m, [data], terms=["EXX", "EYY", "EC0Y"], holdout=0.25, seed=1)
    report = result.to_dict()
    # the moved coefficients come back (the readings carry 1e-12 um of rounding)
    fitted = result.machine.theta[moved]
    assert np.allclose(fitted, truth.theta[moved], rtol=0, atol=1e-12)
    assert report["rms_fit_um"] < 1e-5 and report["rms_holdout_um"] < 1e-5
    zero = report["nuisance"][f"zero[indicator {path}]"]
    assert zero["value"] == pytest.approx(2.5, abs=1e-6) and zero["unit"] == "um"
    # the held-out split counts the instrument's poses (set-ups), not distinct positions
    assert "10 of 40 poses" in report["holdout"]


def test_the_instruments_poses_leave_a_cross_validation_together(machines, tmp_path, kinds):
    m = machines["vmc500"]
    _, _, path = _truth_and_file(m, tmp_path, setups=12, per_setup=4)
    registry.register_kind(INDICATOR)
    data = registry.read_any(path, m)
    points = replace(campaign(m, 10, seed=2), covariates={})
    obs = build_observations(m, [points, data])
    pose = obs.poses()
    # the points' poses by position (10 distinct), then the 12 set-ups, 4 readings each
    assert len(np.unique(pose[:10])) == 10 and np.array_equal(pose[10:], 10 + np.repeat(np.arange(12), 4))
    for fold in pose_folds(obs, 4, seed=0):
        for label in np.unique(pose[fold]):
            assert set(np.flatnonzero(pose == label)) <= set(fold.tolist())   # a pose is never split


def test_a_kind_is_registered_once_before_the_catch_all(kinds):
    registry.register_kind(INDICATOR)
    assert [k.name for k in registry.KINDS] == ["runs", "ballbar", "tracker", "indicator", "points"]
    with pytest.raises(vp.InputError, match="'indicator' is registered already") as err:
        registry.register_kind(INDICATOR)
    assert err.value.parameters == ("kind",)


def test_a_kind_that_needs_the_machine_says_so(tmp_path, kinds):
    path = tmp_path / "tracker.csv"
    path.write_text("x,y,z,tx,ty,tz\n1,2,3,4,5,6\n")
    with pytest.raises(MeasurementError, match="tracker measurements need the machine"):
        registry.read_any(path)


def test_every_built_in_kind_turns_itself_into_observations(machines, tmp_path):
    """One object of each kind, read from the sample files, follows the protocol; its block has one
    entry per row and point, and stacking keeps rows, points and nuisance columns in order."""
    m = machines["vmc500"]
    files = ["vmc500_x_positioning.csv", "vmc500_ballbar_xy.csv"]
    data = [tracker_campaign(m, 20, seed=1, source="tracker.csv")]
    data += [registry.read_any(Path(__file__).resolve().parents[2] / "examples" / "data" / f, m) for f in files]
    blocks = [d.observations(m, ObservationOptions()) for d in data]
    for d, b in zip(data, blocks):
        assert isinstance(d, Measurement)
        rows, points = len(b.point), len(b.q)
        assert b.w.shape == (rows, 6) and b.y.shape == b.sigma.shape == b.angular.shape == b.lines.shape == (rows,)
        assert b.nuisance.shape == (rows, len(b.nuisance_terms)) and b.point.max() == points - 1
    obs = build_observations(m, data)
    assert obs.nuisance_names == [t.name for b in blocks for t in b.nuisance_terms]
    assert len(obs.y) == sum(len(b.y) for b in blocks) and obs.n_points == sum(len(b.q) for b in blocks)
    # the tracker's rotations are in rad, its shifts in m; runs on a linear axis in m
    angular = dict(zip(obs.nuisance_names, obs.nuisance_angular))
    assert [k for k, v in angular.items() if v] == [f"rotation_{a}[tracker {data[0].source}]" for a in "xyz"]


def test_an_object_that_is_not_a_measurement_is_refused(machines):
    table = Table("t.csv", ["x"], 1, [["1"]], [2])
    with pytest.raises(vp.InputError, match="cannot use Table as measurements"):
        build_observations(machines["vmc500"], [table])
