"""Rerun recordings read back from disk, and the static pictures."""

from __future__ import annotations

import json
import time

import matplotlib.image as mpimg
import numpy as np
import pytest
import rerun as rr

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.base import InputError
from volerr_pin.viz import field_slice_png, ranking_png
from volerr_pin.fit import rank
from volerr_pin.viz._recording import log_field, log_time_series, new_recording, record_field, sweep_angles
from volerr_pin.model import evaluate_field, field_grid


def chunks(path, entity):
    reader = rr.chunk.RrdReader(str(path))
    return [c.to_record_batch() for c in reader.stream() if c.entity_path == entity]


def column(batches, name):
    return [np.asarray(row, dtype=float) for b in batches for row in b.column(name).to_pylist()]


@pytest.mark.filterwarnings("error:RRD file has no footer")
def test_field_recording_holds_the_volumetric_error(machines, tmp_path):
    m = machines["vmc500"]
    path = tmp_path / "vmc500.rrd"
    summary = record_field(m, path, counts=[4, 3, 3], scale=500.0,
                           ranking=rank(m, points=128).to_dict(top=10))
    q = field_grid(m, [4, 3, 3])
    expected = m.volumetric_error(q)
    assert summary["points"] == 36 and summary["scale"] == 500.0
    points = chunks(path, "/field/points")
    positions = np.array(column(points, "Points3D:positions")[0]).reshape(-1, 3)
    np.testing.assert_allclose(positions, q, atol=1e-7)  # float32; nominal tool point = q here
    arrows = chunks(path, "/field/arrows")
    vectors = np.array(column(arrows, "Arrows3D:vectors")[0]).reshape(-1, 3)
    np.testing.assert_allclose(vectors, expected[:, :3] * 500.0, rtol=1e-6, atol=1e-9)
    for i, name in enumerate(("dx_um", "dy_um", "dz_um")):
        np.testing.assert_allclose(column(points, name)[0], expected[:, i] * 1e6, rtol=1e-12)
    frames = [f for b in points for f in b.column("CoordinateFrame:frame").to_pylist()]
    assert frames == [["workpiece"]]  # the field sits in the URDF's workpiece frame
    assert chunks(path, "/sensitivity/ranking") and chunks(path, "/field/legend")
    assert chunks(path, "/machine/transforms/x_axis")
    reader = rr.chunk.RrdReader(str(path))
    blueprint = reader.blueprints()
    assert len(blueprint) == 1
    views = {c.entity_path for c in reader.stream(store=blueprint[0]) if c.entity_path.count("/") == 2
             and c.entity_path.startswith("/view/")}
    assert len(views) == 3  # 3D view, ranking bars with names, ranking table
    assert chunks(path, "/sensitivity/bars")   # the bars with names, a picture


@pytest.mark.filterwarnings("error:RRD file has no footer")
def test_rotary_sweep_is_on_the_sweep_timeline(machines, tmp_path):
    m = machines["cgm4000"]
    path = tmp_path / "cgm.rrd"
    summary = record_field(m, path, counts=[3], sweep_steps=5, scale=100.0)
    assert summary["sweep_axes"] == ["A", "B"] and summary["sweep_steps"] == 5
    arrows = chunks(path, "/field/arrows")
    steps = [s for b in arrows for s in b.column("sweep").to_pylist()]
    vectors = column(arrows, "Arrows3D:vectors")
    assert steps == list(range(5))
    q = field_grid(m, [3])
    for step, angles in enumerate(sweep_angles(m, ("A", "B"), 5)):
        qs = q.copy()
        qs[:, 3:] = angles
        expected = m.volumetric_error(qs)[:, :3] * 100.0
        np.testing.assert_allclose(np.reshape(vectors[step], (-1, 3)), expected, rtol=1e-6, atol=1e-9)


def test_config_fixes_a_rotary_axis(machines, tmp_path):
    m = machines["cgm4000"]
    summary = record_field(m, tmp_path / "c.rrd", counts=[2], config={"A": np.radians(30)},
                           sweep_steps=3)
    assert summary["sweep_axes"] == ["B"] and summary["config"][3] == pytest.approx(30.0)


@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_hundred_thousand_arrows_are_one_batch(machines, tmp_path):
    m = machines["vmc500"]
    q = field_grid(m, [50, 50, 40])
    assert len(q) == 100_000
    field = evaluate_field(m, q, 1000.0)
    rec = new_recording()
    path = tmp_path / "big.rrd"
    rec.save(path)
    start = time.perf_counter()
    log_field(rec, m, field)
    elapsed = time.perf_counter() - start
    rec.flush()
    arrows = chunks(path, "/field/arrows")
    assert len(arrows) == 1 and arrows[0].num_rows == 1  # one log call, one row, 1e5 instances
    assert column(arrows, "Arrows3D:vectors")[0].shape == (100_000, 3)
    print(f"1e5-point field: {path.stat().st_size / 1e6:.1f} MB, logged in {elapsed:.2f} s")


@pytest.mark.filterwarnings("ignore:RRD file has no footer")
def test_time_series_go_in_bulk_on_the_time_timeline(tmp_path):
    rec = new_recording()
    path = tmp_path / "t.rrd"
    rec.save(path)
    t = np.arange(0.0, 3600.0, 6.0)
    drift = 10 * (1 - np.exp(-t / 900.0))
    log_time_series(rec, t, {"spindle_z_um": drift})
    rec.flush()
    batches = [b for b in chunks(path, "/thermal/spindle_z_um") if "Scalars:scalars" in b.schema.names]
    assert len(batches) == 1 and batches[0].num_rows == len(t)
    np.testing.assert_allclose([v[0] for v in batches[0].column("Scalars:scalars").to_pylist()], drift)
    assert "time" in batches[0].schema.names


def test_time_series_shape_is_checked():
    with pytest.raises(ValueError, match="series 'x' has shape"):
        log_time_series(new_recording(), np.arange(3.0), {"x": np.arange(4.0)})


def _image_is_non_trivial(path, min_side=400):
    image = mpimg.imread(path)
    assert image.shape[0] >= min_side and image.shape[1] >= min_side
    gray = image[..., :3].mean(axis=2)
    assert gray.std() > 0.05  # not blank
    assert len(np.unique(np.round(gray, 2))) > 20  # many tones: a filled field, not a few lines


@pytest.mark.parametrize("name", ["vmc500", "cgm4000", "ur5", "lathe_2axis"])
def test_field_png(machines, tmp_path, name):
    out = field_slice_png(machines[name], tmp_path / f"{name}.png")
    _image_is_non_trivial(out["path"])


def test_ranking_png(machines, tmp_path):
    out = ranking_png(rank(machines["cgm4000"], points=256).to_dict(), tmp_path / "r.png")
    assert out["rows"] == 15
    _image_is_non_trivial(out["path"])


def test_field_cli(tmp_path, capsys):
    out, png = tmp_path / "f.rrd", tmp_path / "f.png"
    assert main(["field", "gear_roller", "--out", str(out), "--grid", "4", "3", "--sweep-steps", "4",
                 "--png", str(png), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["points"] == 12 and summary["sweep_steps"] == 4 and out.exists() and png.exists()
    assert main(["field", "vmc500", "--out", str(out), "--config", "X=700"]) == 2
    assert "X = 700 mm is outside its travel [0, 500] mm" in capsys.readouterr().err
    assert main(["field", "vmc500", "--out", str(out), "--grid", "3", "3"]) == 2
    assert "--grid: give 1 or 3 counts" in capsys.readouterr().err


def test_rank_png_cli(tmp_path, capsys):
    png = tmp_path / "r.png"
    assert main(["rank", "vmc700", "--points", "128", "--png", str(png), "--top", "8"]) == 0
    _image_is_non_trivial(png, min_side=300)


def test_demo_writes_a_recording(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "--grid", "3"]) == 0
    out = capsys.readouterr().out
    assert "open it with: rerun volerr_demo.rrd" in out
    assert (tmp_path / "volerr_demo.rrd").stat().st_size > 10_000


def test_the_model_and_the_pictures_do_not_load_rerun():
    """Pictures are a layer on top: every module outside volerr_pin.viz and the CLI imports
    without Rerun or matplotlib, and the matplotlib pictures without Rerun."""
    import pkgutil
    import subprocess
    import sys

    import volerr_pin

    core = [m.name for m in pkgutil.walk_packages(volerr_pin.__path__, "volerr_pin.")
            if m.name.split(".")[1] not in ("viz", "cli")]
    assert "volerr_pin.fit.identify" in core and "volerr_pin.fit.diagnosis" in core and len(core) > 20
    code = (f"import sys, {', '.join(core)}; "
            "print('rerun' in sys.modules, 'matplotlib' in sys.modules); "
            "import volerr_pin.viz._plots; print('rerun' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False", "False"]


@pytest.mark.filterwarnings("error:RRD file has no footer")
def test_gear_recording_holds_the_normal_deviations(machines, tmp_path):
    from volerr_pin.applications.gear import deviations_by_source
    from volerr_pin.viz import record_gear

    rows = deviations_by_source(machines["gear_roller"], components=["EXA", "ECB"], profile_points=5, face_points=3)
    path = tmp_path / "gear.rrd"
    summary = record_gear(rows, path, scale=2000.0)
    assert summary == {"path": str(path), "sources": 3, "points": 2 * 46 * 5 * 3, "scale": 2000.0}
    points = chunks(path, "/gear/flanks")
    steps = [b for b in points if "normal_deviation_um" in b.schema.names]
    values = column(steps, "normal_deviation_um")
    assert len(values) == 3                                            # one step per source
    # the row of all sources together opens the recording (step 0); then the sources as given
    assert [row.source for row in rows] == ["EXA", "ECB", "all"]
    assert [s for b in steps for s in b.column("error_source").to_pylist()] == [["all"], ["EXA"], ["ECB"]]
    opened = [rows[2], rows[0], rows[1]]
    for row, logged in zip(opened, values):
        np.testing.assert_allclose(logged, row.deviations.normal.reshape(-1) * 1e6, rtol=1e-12)
    static = [b for b in points if "Points3D:positions" in b.schema.names]   # positions once, not per step
    assert len(static) == 1 and not any("Points3D:positions" in b.schema.names for b in steps)
    positions = np.array(column(static, "Points3D:positions")[0]).reshape(-1, 3)
    np.testing.assert_allclose(positions, rows[0].deviations.points.reshape(-1, 3), atol=1e-7)
    vectors = [b for b in chunks(path, "/gear/deviation") if "source" in b.schema.names]
    arrows = np.array(column(vectors, "Arrows3D:vectors")[2]).reshape(-1, 3)   # step 2: ECB
    expected = rows[1].deviations.normals.reshape(-1, 3) * rows[1].deviations.normal.reshape(-1, 1) * 2000.0
    np.testing.assert_allclose(arrows, expected, rtol=1e-6, atol=1e-9)


def test_gear_cli_rrd(tmp_path, capsys):
    path = tmp_path / "g.rrd"
    assert main(["gear", "gear_roller", "--profile-points", "3", "--face-points", "3", "--rrd", str(path)]) == 0
    assert path.stat().st_size > 0 and "wrote" in capsys.readouterr().err


# --- bad inputs and atomic files (issue 22) -------------------------------------------------

@pytest.mark.parametrize("steps", [-1, 2.5, True, "4"])
def test_sweep_steps_must_be_a_whole_number(machines, tmp_path, steps):
    with pytest.raises(InputError, match=r"sweep_steps must be a whole number >= 0 \(0: no sweep\), got") as info:
        record_field(machines["cgm4000"], tmp_path / "c.rrd", counts=[2], sweep_steps=steps)
    assert info.value.parameters == ("sweep_steps",)
    assert not (tmp_path / "c.rrd").exists()


def test_sweep_steps_cli(tmp_path, capsys):
    assert main(["field", "cgm4000", "--out", str(tmp_path / "c.rrd"), "--grid", "2", "--sweep-steps", "-1"]) == 2
    assert "--sweep-steps must be a whole number >= 0" in capsys.readouterr().err


@pytest.mark.parametrize("counts, steps, names", [([100_000], 0, "counts"), ([2], 10**9, "counts, sweep_steps")])
def test_absurd_field_sizes_are_refused_before_allocating(machines, tmp_path, counts, steps, names):
    machine = machines["vmc500"] if steps == 0 else machines["cgm4000"]
    with pytest.raises(InputError, match=f"needs about .* of memory, more than this machine can spare .*; reduce {names}"):
        record_field(machine, tmp_path / "c.rrd", counts=counts, sweep_steps=steps)


def test_a_failed_recording_leaves_the_file_as_it_was(machines, tmp_path, monkeypatch):
    import volerr_pin.viz._recording as recording

    target = tmp_path / "field.rrd"
    target.write_bytes(b"the recording of yesterday")

    def failing(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(recording, "log_field", failing)
    with pytest.raises(RuntimeError, match="disk full"):
        record_field(machines["vmc500"], target, counts=[2])
    assert target.read_bytes() == b"the recording of yesterday"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["field.rrd"]  # no temporary file left


@pytest.mark.filterwarnings("error:RRD file has no footer")
def test_a_recording_replaces_the_file_complete(machines, tmp_path):
    """Written beside the target and renamed once Rerun has closed it: the footer is there."""
    target = tmp_path / "field.rrd"
    target.write_bytes(b"old")
    target.chmod(0o640)
    summary = record_field(machines["vmc500"], target, counts=[2])
    assert summary["bytes"] == target.stat().st_size > 10_000
    assert chunks(target, "/field/arrows") and (target.stat().st_mode & 0o777) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["field.rrd"]


@pytest.mark.filterwarnings("error:RRD file has no footer")
def test_the_file_keeps_everything_while_a_viewer_is_fed(machines, tmp_path):
    """``save`` then ``connect_grpc`` replaced the file sink: the file held only properties."""
    import socket

    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    viewer = rr.RecordingStream("stand-in viewer")
    url = viewer.serve_grpc(grpc_port=port)
    try:
        record_field(machines["vmc500"], tmp_path / "tee.rrd", counts=[3], connect=url)
    finally:
        viewer.disconnect()
    assert chunks(tmp_path / "tee.rrd", "/field/arrows") and chunks(tmp_path / "tee.rrd", "/machine/transforms/x_axis")


@pytest.mark.parametrize("url", ["nonsense", "rerun+http://127.0.0.1:{port}/proxy"])
def test_an_unreachable_viewer_is_one_clean_error(machines, tmp_path, url):
    import socket

    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()  # nothing listens there now
    target = tmp_path / "f.rrd"
    target.write_bytes(b"old")
    with pytest.raises(InputError, match="connect: cannot reach a Rerun viewer") as info:
        record_field(machines["vmc500"], target, counts=[2], connect=url.format(port=port))
    assert info.value.parameters == ("connect",)
    assert target.read_bytes() == b"old" and len(list(tmp_path.iterdir())) == 1


ENDLESS_URDF = """<?xml version="1.0"?>
<robot name="endless">
  <link name="base"/><link name="carriage"/><link name="tip"/><link name="table"/>
  <joint name="x" type="prismatic"><parent link="base"/><child link="carriage"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.3"/></joint>
  <joint name="tip_mount" type="fixed"><parent link="carriage"/><child link="tip"/>
    <origin xyz="0 0.1 -0.05"/></joint>
  <joint name="c" type="continuous"><parent link="base"/><child link="table"/>
    <axis xyz="0 0 1"/></joint>
</robot>
"""


@pytest.mark.filterwarnings("error:RRD file has no footer")
def test_field_of_an_endless_axis_sweeps_one_turn(tmp_path):
    """``volerr field`` stopped with "q[0, 3] (axis gc) is nan" on a continuous joint."""
    (tmp_path / "endless.urdf").write_text(ENDLESS_URDF)
    (tmp_path / "errors.toml").write_text('''format = 1
[machine]
name = "endless"
urdf = "endless.urdf"
tool_frame = "tip"
workpiece_frame = "table"
[axes.C]
joint = "c"
[axes.X]
joint = "x"
[errors.EXC]
kind = "legendre"
coefficients_um = [0.0, 5.0]
[errors.ECC]
kind = "legendre"
coefficients_arcsec = [2.0, 0.0, 3.0]
''')
    m = vp.load_machine(tmp_path)
    summary = record_field(m, tmp_path / "e.rrd", counts=[3], sweep_steps=5, scale=1000.0)
    assert summary["sweep_axes"] == ["C"] and summary["sweep_steps"] == 5
    angles = sweep_angles(m, ("C",), 5)
    np.testing.assert_allclose(angles[:, 0], np.linspace(-np.pi, np.pi, 5))
    vectors = column(chunks(tmp_path / "e.rrd", "/field/arrows"), "Arrows3D:vectors")
    q = field_grid(m, [3])
    for step, angle in enumerate(angles):
        qs = q.copy()
        qs[:, 0] = angle
        expected = m.volumetric_error(qs)[:, :3] * 1000.0
        assert np.abs(expected).max() > 1e-4
        np.testing.assert_allclose(np.reshape(vectors[step], (-1, 3)), expected, rtol=1e-6, atol=1e-9)


def test_field_cli_on_a_bare_urdf_with_an_endless_axis(tmp_path, capsys):
    (tmp_path / "endless.urdf").write_text(ENDLESS_URDF)
    out = tmp_path / "e.rrd"
    assert main(["field", str(tmp_path / "endless.urdf"), "--tool-frame", "tip", "--workpiece-frame", "table",
                 "--out", str(out), "--grid", "3", "--sweep-steps", "4", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["sweep_axes"] == ["c"] and summary["config"] == [0.0, 150.0] and out.stat().st_size > 10_000


@pytest.mark.slow
def test_demo_on_a_bare_urdf_with_an_endless_axis(tmp_path, capsys):
    (tmp_path / "endless.urdf").write_text(ENDLESS_URDF)
    out = tmp_path / "d.rrd"
    assert main(["demo", "--machine", str(tmp_path / "endless.urdf"), "--tool-frame", "tip", "--workpiece-frame",
                 "table", "--grid", "3", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["recording"]["sweep_axes"] == ["c"] and out.stat().st_size > 10_000
