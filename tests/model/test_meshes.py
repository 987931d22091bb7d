"""Files a URDF names (meshes, textures) are read only inside the URDF's folder or a package
folder named, only if they are regular files of a bounded size, and only through a checked
copy: a recording is shared, and Rerun's URDF importer embeds every mesh it is given."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pytest
import rerun as rr

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.model import checked_meshes, default_config, load_urdf, package_folders
from volerr_pin.viz import log_machine, new_recording

STL = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n"
SECRET = b"root:x:0:0:secret line that must not leave this machine\n"


def robot_text(*filenames: str, texture: str | None = None) -> str:
    """A one-axis slide whose base link has one visual per mesh file name (one per line)."""
    visuals = "\n".join(f'    <visual><geometry><mesh filename="{name}"/></geometry></visual>' for name in filenames)
    material = f'<material name="m"><texture filename="{texture}"/></material>' if texture else ""
    return f"""<?xml version="1.0"?>
<robot name="slide">
  <link name="base">
{visuals}
  </link>
  <link name="carriage"><visual><geometry><box size="0.1 0.1 0.1"/></geometry>{material}</visual></link>
  <joint name="x" type="prismatic">
    <parent link="base"/><child link="carriage"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.3"/>
  </joint>
</robot>
"""


@pytest.fixture
def site(tmp_path):
    """``tmp/robot/`` (the URDF's folder, with ``meshes/good.stl``), a secret file beside it and
    a package folder ``tmp/share/pkg/meshes/part.stl``."""
    folder = tmp_path / "robot"
    (folder / "meshes").mkdir(parents=True)
    (folder / "meshes" / "good.stl").write_bytes(STL)
    (tmp_path / "secret.txt").write_bytes(SECRET)
    (tmp_path / "share" / "pkg" / "meshes").mkdir(parents=True)
    (tmp_path / "share" / "pkg" / "meshes" / "part.stl").write_bytes(STL + b"\n")
    return tmp_path


def check(site, *filenames, package_dirs=(), **limits):
    path = site / "robot" / "robot.urdf"
    path.write_text(robot_text(*filenames))
    out = site / "copies"
    out.mkdir(exist_ok=True)
    urdf = load_urdf(path)
    document, notes = checked_meshes(urdf, out, package_dirs, **limits)
    kept = [m.get("filename") for m in document.getroot().iter("mesh")]
    assert [m.get("filename") for m in urdf.document.getroot().iter("mesh")] == list(filenames)  # unchanged
    return kept, notes


def test_meshes_inside_the_folder_are_copied_and_named_absolutely(site):
    kept, notes = check(site, "meshes/good.stl", "meshes/good.stl", str(site / "robot" / "meshes" / "good.stl"))
    assert notes == []
    assert len(set(kept)) == 1  # one file, copied once
    assert Path(kept[0]).is_absolute() and Path(kept[0]).parent == site / "copies"
    assert Path(kept[0]).read_bytes() == STL


def _escape_link(site):
    os.symlink(site / "secret.txt", site / "robot" / "meshes" / "link.stl")
    return "meshes/link.stl"


def _device_link(site):
    os.symlink("/dev/zero", site / "robot" / "meshes" / "zero.stl")
    return "meshes/zero.stl"


def _fifo(site):
    os.mkfifo(site / "robot" / "meshes" / "pipe.stl")  # nobody writes: reading it would hang
    return "meshes/pipe.stl"


def _folder(site):
    (site / "robot" / "meshes" / "dir.stl").mkdir()
    return "meshes/dir.stl"


@pytest.mark.parametrize("make, reason", [
    (lambda s: "../../../../../../../../etc/passwd", "lies outside the URDF's folder"),
    (lambda s: "../secret.txt", "lies outside the URDF's folder"),
    (lambda s: str(s / "secret.txt"), "lies outside the URDF's folder"),
    (lambda s: "file://" + str(s / "secret.txt"), "lies outside the URDF's folder"),
    (lambda s: "/dev/zero", "lies outside the URDF's folder"),
    (_escape_link, "lies outside the URDF's folder"),
    (_device_link, "lies outside the URDF's folder"),
    (_fifo, "is not a regular file"),
    (_folder, "is not a regular file"),
    (lambda s: "meshes/missing.stl", "does not exist"),
    (lambda s: "http://example.com/part.stl", "is a http:// address; only files are read"),
    (lambda s: "file://relative/part.stl", "is a file:// address without an absolute path"),
    (lambda s: "package://pkg/meshes/part.stl", r"is in package 'pkg', which none of the package folders holds"),
    (lambda s: "package://../secret.txt", "is not package://NAME/path"),
    (lambda s: "", "is empty"),
], ids=["dotdot-passwd", "dotdot", "absolute", "file-uri", "device", "symlink-out", "symlink-device", "fifo",
        "folder", "missing", "http", "file-relative", "unknown-package", "bad-package", "empty"])
def test_refused_meshes_drop_their_visual_with_a_note(site, make, reason):
    name = make(site)
    kept, notes = check(site, "meshes/good.stl", name)
    assert len(kept) == 1 and Path(kept[0]).read_bytes() == STL
    assert len(notes) == 1
    assert notes[0].startswith(f"{site / 'robot' / 'robot.urdf'}:5: <visual> of link 'base' dropped: "
                               f"mesh file '{name}' ")
    assert reason in notes[0]
    assert SECRET not in b"".join(Path(k).read_bytes() for k in kept)


def test_package_meshes_resolve_in_the_package_folders_named(site):
    for dirs in ([site / "share"], [site / "share" / "pkg"], str(site / "share")):
        kept, notes = check(site, "package://pkg/meshes/part.stl", package_dirs=dirs)
        assert notes == [] and Path(kept[0]).read_bytes() == STL + b"\n"
    kept, notes = check(site, "package://pkg/../../secret.txt", package_dirs=[site / "share"])
    assert kept == [] and "lies outside the URDF's folder and the package folders named" in notes[0]
    os.symlink(site / "secret.txt", site / "share" / "pkg" / "meshes" / "out.stl")
    kept, notes = check(site, "package://pkg/meshes/out.stl", package_dirs=[site / "share"])
    assert kept == [] and "lies outside" in notes[0]


def test_a_sibling_meshes_folder_needs_its_root_named(site):
    """robot/urdf/robot.urdf naming ../meshes/part.stl (a common layout): outside the URDF's
    folder unless a folder holding both is named."""
    (site / "robot" / "urdf").mkdir()
    path = site / "robot" / "urdf" / "robot.urdf"
    path.write_text(robot_text("../meshes/good.stl"))
    _, notes = checked_meshes(load_urdf(path), site)
    assert "'../meshes/good.stl' lies outside the URDF's folder" in notes[0]
    document, notes = checked_meshes(load_urdf(path), site, [site / "robot"])
    assert notes == [] and Path(next(document.getroot().iter("mesh")).get("filename")).read_bytes() == STL
    path.write_text(robot_text("../../secret.txt"))
    _, notes = checked_meshes(load_urdf(path), site, [site / "robot"])
    assert "lies outside the URDF's folder and the package folders named" in notes[0]


def test_mesh_size_limits(site):
    (site / "robot" / "meshes" / "other.stl").write_bytes(STL + b" ")
    kept, notes = check(site, "meshes/good.stl", max_bytes=len(STL) - 1)
    assert kept == [] and f"is {len(STL):,} bytes, more than the {len(STL) - 1:,} a mesh may have" in notes[0]
    kept, notes = check(site, "meshes/good.stl", "meshes/other.stl", max_total=len(STL) + 1)
    assert len(kept) == 1 and f"would bring the files of this URDF past {len(STL) + 1:,} bytes" in notes[0]
    with open(site / "robot" / "meshes" / "huge.stl", "wb") as fh:
        fh.truncate(100_000_000)  # sparse: past the default 64 MB without using the disk
    kept, notes = check(site, "meshes/huge.stl")
    assert kept == [] and "is 100,000,000 bytes, more than the 64,000,000 a mesh may have" in notes[0]


def test_a_refused_texture_is_dropped_alone(site):
    path = site / "robot" / "robot.urdf"
    path.write_text(robot_text("meshes/good.stl", texture="../secret.txt"))
    document, notes = checked_meshes(load_urdf(path), site)
    assert len(notes) == 1 and ": <texture> of link 'carriage' dropped: texture file '../secret.txt' lies" in notes[0]
    assert not list(document.getroot().iter("texture")) and len(list(document.getroot().iter("visual"))) == 2


def test_package_folders_must_exist(tmp_path):
    with pytest.raises(vp.InputError, match="package_dirs: .*nowhere' is not a folder") as info:
        package_folders([tmp_path, tmp_path / "nowhere"])
    assert info.value.parameters == ("package_dirs",)
    (tmp_path / "slide.urdf").write_text(robot_text())
    with pytest.raises(vp.InputError, match="package_dirs"):
        vp.load_machine(tmp_path / "slide.urdf", tool_frame="carriage", workpiece_frame="base",
                        package_dirs=tmp_path / "nowhere")


def assets(path) -> list[bytes]:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the file is complete: no "no footer" warning
        reader = rr.chunk.RrdReader(str(path))
        return [bytes(blob) for c in reader.stream() for b in [c.to_record_batch()]
                if "Asset3D:blob" in b.schema.names
                for row in b.column("Asset3D:blob").to_pylist() for blob in row]


def test_the_recording_holds_only_checked_meshes(site):
    """``volerr field`` copied ../../../../etc/passwd into the .rrd: now the visual is dropped
    with a note naming the URDF, its line and the mesh, and the other meshes are kept."""
    path = site / "robot" / "robot.urdf"
    path.write_text(robot_text("meshes/good.stl", "../secret.txt", "package://pkg/meshes/part.stl"))
    machine = vp.load_machine(path, tool_frame="carriage", workpiece_frame="base", package_dirs=[site / "share"])
    out = site / "m.rrd"
    rec = new_recording()
    rec.save(out)
    with pytest.warns(UserWarning, match=r"robot\.urdf:5: <visual> of link 'base' dropped: mesh file "
                                         r"'\.\./secret\.txt' lies outside the URDF's folder") as caught:
        log_machine(rec, machine, default_config(machine))
    rec.flush()
    rec.disconnect()
    assert len(caught) == 1
    blobs = assets(out)
    assert sorted(blobs) == sorted([STL, STL + b"\n"])
    assert SECRET not in out.read_bytes()


def test_field_cli_notes_a_dropped_mesh(site, capsys):
    path = site / "robot" / "robot.urdf"
    path.write_text(robot_text("meshes/good.stl", "/dev/zero", "../../../../../../../../etc/passwd"))
    out = site / "f.rrd"
    assert main(["field", str(path), "--tool-frame", "carriage", "--workpiece-frame", "base", "--out", str(out),
                 "--grid", "2", "--sweep-steps", "0"]) == 0
    err = capsys.readouterr().err
    assert f"volerr: note: {path}:5: <visual> of link 'base' dropped: mesh file '/dev/zero' lies outside" in err
    assert f"volerr: note: {path}:6: <visual> of link 'base' dropped: mesh file '../../../../../../../../etc/passwd'" in err
    assert assets(out) == [STL]
    assert out.stat().st_size < 1_000_000


def test_bundled_ur5_keeps_its_package_meshes(machines, tmp_path):
    """example-robot-data's package:// meshes: the package the spec names is a package folder."""
    machine = machines["ur5"]
    assert machine.package_dirs and machine.package_dirs[0].name == "example-robot-data"
    out = tmp_path / "ur5.rrd"
    rec = new_recording()
    rec.save(out)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        log_machine(rec, machine, default_config(machine))
    rec.flush()
    rec.disconnect()
    assert len(assets(out)) == 14  # 7 visual and 7 collision meshes


def test_field_cli_reads_package_meshes_from_the_folders_named(site, capsys):
    path = site / "robot" / "robot.urdf"
    path.write_text(robot_text("meshes/good.stl", "package://pkg/meshes/part.stl"))
    out = site / "f.rrd"
    argv = ["field", str(path), "--tool-frame", "carriage", "--workpiece-frame", "base", "--out", str(out),
            "--grid", "2", "--sweep-steps", "0"]
    assert main(argv) == 0
    assert "'package://pkg/meshes/part.stl'" in capsys.readouterr().err  # no package folder named: dropped
    assert assets(out) == [STL]
    assert main(argv + ["--package-dir", str(site / "share")]) == 0
    assert "dropped" not in capsys.readouterr().err
    assert sorted(assets(out)) == sorted([STL, STL + b"\n"])
    assert main(argv + ["--package-dir", str(site / "nowhere")]) == 2
    assert "--package-dir" in capsys.readouterr().err
