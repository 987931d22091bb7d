"""Files are sacred: outputs are checked before any work, written through a temporary file
renamed only on success, never over an input; a replaced spec is kept as a backup."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pytest

import volerr_pin as vp
from volerr_pin.base import _safeio as safeio
from volerr_pin.cli import main

DATA = Path(__file__).resolve().parents[2] / "examples" / "data"


def snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (hidden ones too) with the hash of its content."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def refused(capsys, argv, culprit: str) -> str:
    """Run ``volerr argv``: exit 2 with one error line on stderr naming ``culprit``."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("volerr: error: "), err
    assert culprit in err[0], err
    return err[0]


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copy(DATA / "part.nc", tmp_path / "P.nc")
    return tmp_path


# ------------------------------------------------------------------ the library pieces


def test_same_file_sees_links(tmp_path):
    a = tmp_path / "a.txt"
    a.write_text("x")
    os.symlink(a, tmp_path / "s.txt")
    os.link(a, tmp_path / "h.txt")
    assert safeio.same_file(a, tmp_path / "s.txt")
    assert safeio.same_file(a, tmp_path / "h.txt")
    assert safeio.same_file(a, tmp_path / "sub" / ".." / "a.txt")
    assert not safeio.same_file(a, tmp_path / "b.txt")


@pytest.mark.parametrize("target, message", [
    ("folder", "is a folder"),
    ("missing/x.png", "folder .*missing does not exist"),
    ("pipe", "exists and is not a regular file"),
    ("input.csv", "is an input of this run"),
    ("link.csv", r"is an input of this run \(.*input.csv\)"),
    ("", "empty file name"),
])
def test_check_outputs_refuses(tmp_path, target, message):
    (tmp_path / "folder").mkdir()
    (tmp_path / "input.csv").write_text("1\n")
    os.symlink(tmp_path / "input.csv", tmp_path / "link.csv")
    os.mkfifo(tmp_path / "pipe")  # not a device of the system: one that some sandboxes make a plain file
    path = target if target.startswith("/") or not target else str(tmp_path / target)
    with pytest.raises(vp.InputError, match=message) as info:
        safeio.check_outputs({"png": path}, [tmp_path / "input.csv"])
    assert info.value.parameters[0] == "png"


def test_check_outputs_refuses_one_file_for_two_outputs(tmp_path):
    with pytest.raises(vp.InputError, match="report: .*x.json is also given as output") as info:
        safeio.check_outputs({"output": tmp_path / "x.json", "report": tmp_path / "x.json", "png": None})
    assert info.value.parameters == ("report", "output")
    assert safeio.check_outputs({"output": tmp_path / "a", "png": None}) == {"output": tmp_path / "a"}


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_check_outputs_refuses_a_read_only_folder(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(vp.InputError, match="is not writable"):
            safeio.check_outputs({"out": folder / "x.toml"})
    finally:
        folder.chmod(0o700)


def test_transaction_writes_all_or_nothing(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.png"
    a.write_text("old a")
    a.chmod(0o640)
    with pytest.raises(RuntimeError):
        with safeio.transaction() as tx:
            tx.path(a).write_text("new a")
            tx.path(b).write_text("new b")
            raise RuntimeError("the picture failed")
    assert snapshot(tmp_path) == {"a.txt": hashlib.sha256(b"old a").hexdigest()}
    with safeio.transaction() as tx:
        ta = tx.path(a)
        assert ta.parent == tmp_path and ta.suffix == ".txt" and ta.name.startswith(".a.txt.")
        ta.write_text("new a")
        tx.path(b).write_text("new b")
        assert tx.final({"path": str(ta), "n": [ta, 3]}) == {"path": str(a), "n": [a, 3]}
    assert a.read_text() == "new a" and b.read_text() == "new b"
    assert (a.stat().st_mode & 0o777) == 0o640  # a replaced file keeps its permissions
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.png"]


LONG = "p" * 251 + ".png"        # 255 bytes: as long as a name may be
WIDE = "\u00e9" * 125 + ".png"    # 254 bytes in UTF-8, 129 characters


@pytest.mark.parametrize("name", ["plot", ".plot", "plot.", "my.plot.png", "table.csv", "a.tar.gz", LONG, WIDE])
def test_a_temporary_file_has_exactly_its_targets_suffix(tmp_path, name):
    # writers choose a format by suffix: a target without one must not get ".part" (matplotlib refused it)
    with safeio.transaction() as tx:
        tmp = tx.path(tmp_path / name)
        assert tmp.parent == tmp_path and tmp.name.startswith(".") and tmp != tmp_path / name
        assert tmp.suffix == (tmp_path / name).suffix
        tmp.write_text("x")
    assert (tmp_path / name).read_text() == "x" and [p.name for p in tmp_path.iterdir()] == [name]


@pytest.mark.parametrize("argv", [
    ["iso230-2", str(DATA / "vmc500_x_positioning.csv"), "--png", "picture"],
    ["iso230-2", str(DATA / "vmc500_x_positioning.csv"), "--png", "p" * 255],
    ["thermal-fit", str(DATA / "vmc500_spindle_thermal.csv"), "--target", "dz_um", "--png", "picture"],
])
def test_a_picture_named_without_a_suffix_is_a_png(work, capsys, argv):
    # the longest name a file may have too: its temporary file beside it was longer (refused after the work)
    assert main(argv) == 0, capsys.readouterr().err
    assert (work / argv[-1]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in work.iterdir()) == ["P.nc", argv[-1]]


def test_a_name_the_file_system_cannot_take_is_refused_naming_the_parameter(tmp_path):
    with pytest.raises(vp.InputError, match=r"^plot: p{24}\.\.\.: a file name of 256 bytes; this file system takes "
                                            r"at most 255$") as info:
        safeio.check_outputs({"plot": tmp_path / ("p" + LONG)})
    assert info.value.parameters == ("plot",)
    with pytest.raises(vp.InputError, match="^plot: .*/x.png: File name too long$"):  # a folder's name
        safeio.check_outputs({"plot": tmp_path / ("p" + LONG) / "x.png"})
    assert safeio.check_outputs({"plot": tmp_path / LONG}) == {"plot": tmp_path / LONG}
    for folder in (tmp_path / ("p" + LONG), tmp_path / ("p" + LONG) / "sub", tmp_path / "new" / ("p" + LONG)):
        with pytest.raises(vp.InputError, match=r"^tables: .*(: File name too long|p{24}\.\.\.: a folder name of 256 bytes; this file system "
                                                  r"takes at most 255)$") as info:
            safeio.check_output_folder("tables", folder)
        assert info.value.parameters == ("tables",)
    assert safeio.check_output_folder("tables", tmp_path / "new" / LONG) == tmp_path / "new" / LONG


def test_a_backup_of_a_long_name_fits_the_file_system(tmp_path):
    spec = tmp_path / ("s" * 250 + ".toml")
    spec.write_text("first")
    safeio.write_text(spec, "second", backup=True)
    safeio.write_text(spec, "third", backup=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["s" * 246 + ".bak.toml", "s" * 245 + ".bak2.toml",
                                                                 spec.name])
    assert (tmp_path / ("s" * 246 + ".bak.toml")).read_text() == "first" and spec.read_text() == "third"


def test_backups_are_numbered_and_never_overwritten(tmp_path):
    spec = tmp_path / "errors.toml"
    spec.write_text("first")
    safeio.write_text(spec, "second", backup=True)
    safeio.write_text(spec, "third", backup=True)
    assert spec.read_text() == "third"
    assert (tmp_path / "errors.bak.toml").read_text() == "first"
    assert (tmp_path / "errors.bak2.toml").read_text() == "second"
    assert safeio.keep_backup(tmp_path / "absent.toml") is None


def test_require_memory_names_the_parameter(monkeypatch):
    monkeypatch.setattr(safeio, "available_memory", lambda: 8 << 30)
    safeio.require_memory(1 << 30, "a grid")
    with pytest.raises(vp.InputError, match=r"a grid needs about 5\.5 GB of memory, more than this machine can "
                                            r"spare \(8\.59 GB free\); reduce counts") as info:
        safeio.require_memory(5.5e9, "a grid", ("counts",))
    assert info.value.parameters == ("counts",)
    assert safeio.available_memory() > 0


# ------------------------------------------------------------------ commands never write over an input


def test_compensate_refuses_its_input_as_output(work, capsys):
    before = snapshot(work)
    refused(capsys, ["compensate", "vmc700", "P.nc", "-o", "P.nc"], "--out: P.nc is an input")
    os.symlink("P.nc", "L.nc")
    os.link("P.nc", "H.nc")
    refused(capsys, ["compensate", "vmc700", "P.nc", "-o", "L.nc"], "--out: L.nc is an input of this run (P.nc)")
    refused(capsys, ["compensate", "vmc700", "P.nc", "-o", "H.nc"], "--out: H.nc is an input")
    refused(capsys, ["compensate", "vmc700", "P.nc", "-o", "out.nc", "--report", "out.nc"], "--report")
    assert {k: v for k, v in snapshot(work).items() if k == "P.nc"} == before


def test_urdf_and_dh_refuse_their_input_as_output(work, capsys):
    shutil.copy(DATA / "two_link_arm.urdf", "A.urdf")
    (work / "t.csv").write_text("# convention: standard\njoint,type,a_mm,alpha_deg,d_mm,theta_deg,lower,upper\n"
                                "j1,revolute,100,0,0,0,-90,90\n")
    before = snapshot(work)
    refused(capsys, ["urdf", "A.urdf", "--tool-frame", "tool0", "--workpiece-frame", "base", "-o", "A.urdf"],
            "--out: A.urdf is an input")
    refused(capsys, ["dh", "t.csv", "-o", "t.csv"], "--out: this writes a URDF: its name ends in .urdf or .xml, got t.csv")
    assert snapshot(work) == before


def test_identify_refuses_to_replace_the_machines_own_spec(work, capsys):
    shutil.copytree(Path(vp.load_machine("vmc500").spec.source).parent, "m")
    before = snapshot(work)
    refused(capsys, ["identify", "m", str(DATA / "vmc500_x_positioning.csv"), "--out", "m/errors.toml"],
            "--out: m/errors.toml is an input")
    refused(capsys, ["identify", "m", str(DATA / "vmc500_x_positioning.csv"), "--out", "m/vmc500.urdf"],
            "--out: this writes a spec (TOML): its name ends in .toml, got m/vmc500.urdf")
    assert snapshot(work) == before


def test_write_spec_refuses_the_machines_own_files(tmp_path):
    from volerr_pin.model import write_spec

    shutil.copytree(Path(vp.load_machine("vmc500").spec.source).parent, tmp_path / "m")
    machine = vp.load_machine(tmp_path / "m")
    with pytest.raises(vp.InputError, match="is the machine's own spec") as info:
        write_spec(machine, tmp_path / "m" / "errors.toml")
    assert info.value.parameters == ("out",)


# ------------------------------------------------------------------ a failing run changes nothing


@pytest.mark.parametrize("argv, culprit", [
    (["compensate", "vmc700", "P.nc", "-o", "existing.out", "--report", "missing/r.json"], "--report"),
    (["compensate", "vmc700", "P.nc", "-o", "existing.out", "--png", "missing/x.png"], "--png"),
    (["compensate", "vmc700", "P.nc", "-o", "existing.out", "--png", "x.notapicture"], "--png"),
    (["field", "vmc500", "--out", "f.rrd", "--png", "missing/x.png"], "--png"),
    (["field", "vmc500", "--out", "folder.rrd"], "--out: folder.rrd is a folder"),
    (["field", "vmc500", "--out", "existing.out"], "--out: this writes a Rerun recording: its name ends in .rrd"),
    (["iso230-2", str(DATA / "vmc500_x_positioning.csv"), "--png", "missing/x.png"], "--png"),
    (["ballbar", str(DATA / "vmc500_ballbar_xy.csv"), "--png", "folder"], "--png"),
    (["rank", "vmc500", "--png", "missing/x.png"], "--png"),
    (["gear", "gear_roller", "--rrd", "existing.out", "--png", "missing/x.png"], "--png"),
    (["thermal-fit", str(DATA / "vmc500_spindle_thermal.csv"), "--target", "dz_um", "--png", "pipe"], "--png: pipe exists and is not"),
    (["demo", "--out", "folder.rrd"], "--out: folder.rrd is a folder"),
    (["errormap", "vmc500", "--table", "folder"], "--table"),
    (["errormap", "vmc500", "--axis-tables", "existing.out/sub"], "--axis-tables: existing.out is not a folder"),
])
def test_bad_output_is_refused_before_any_work(work, capsys, argv, culprit):
    (work / "folder").mkdir()
    (work / "folder.rrd").mkdir()
    (work / "existing.out").write_text("keep me")
    os.mkfifo(work / "pipe")
    before = snapshot(work)
    refused(capsys, argv, culprit)
    assert snapshot(work) == before


@pytest.mark.slow
def test_diagnose_with_a_bad_picture_keeps_the_existing_spec(work, capsys):
    (work / "existing.toml").write_text("keep me")
    before = snapshot(work)
    refused(capsys, ["diagnose", "vmc500", str(DATA / "vmc500_tracker.csv"), "--out", "existing.toml",
                     "--png", "missing/x.png"], "--png")
    assert snapshot(work) == before


def test_a_writer_failing_midway_leaves_every_output_as_it_was(work, capsys, monkeypatch):
    import volerr_pin.viz as viz

    def broken(*args, **kwargs):
        raise vp.InputError("the picture failed")

    monkeypatch.setattr(viz, "compensation_png", broken)
    (work / "existing.out").write_text("keep me")
    (work / "r.json").write_text("{}")
    before = snapshot(work)
    refused(capsys, ["compensate", "vmc700", "P.nc", "-o", "existing.out", "--report", "r.json", "--png", "x.png"],
            "the picture failed")
    assert snapshot(work) == before  # no output replaced, no temporary file left


def test_successful_outputs_replace_targets_and_leave_no_temporary_files(work, capsys):
    (work / "existing.out").write_text("old")
    assert main(["compensate", "vmc700", "P.nc", "-o", "existing.out", "--report", "r.json", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["output"] == "existing.out"
    assert (work / "existing.out").read_text().startswith("%") or "G" in (work / "existing.out").read_text()
    assert json.loads((work / "r.json").read_text())["blocks_in"] == report["blocks_in"]
    assert sorted(p.name for p in work.iterdir()) == ["P.nc", "existing.out", "r.json"]


def test_identify_keeps_the_spec_it_replaces(work, capsys):
    data = str(DATA / "vmc500_x_positioning.csv")
    argv = ["identify", "vmc500", data, "--terms", "EXX", "--folds", "0", "--out", "new.toml", "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    assert first["out"] == "new.toml" and first["backup"] is None
    original = (work / "new.toml").read_bytes()
    assert main(argv) == 0
    second = json.loads(capsys.readouterr().out)
    assert second["backup"] == "new.bak.toml"
    assert (work / "new.bak.toml").read_bytes() == original
    assert vp.load_machine(work / "new.bak.toml").name == "vmc500"  # a backup still loads
    assert main(argv[:-1]) == 0
    assert "the spec it replaced is kept as new.bak2.toml" in capsys.readouterr().out
    # the transaction keeps the backups, nothing else: no copy of its own temporary file
    assert not [p.name for p in work.iterdir() if p.name.startswith(".")]
    assert main(["diagnose", "vmc500", data, "--out", "diagnosed.toml", "--max-effects", "0", "--json"]) == 0
    assert not [p.name for p in work.iterdir() if p.name.startswith(".")]


def test_a_data_file_given_twice_is_refused(work, capsys):
    data = DATA / "vmc500_x_positioning.csv"
    os.symlink(data, "again.csv")
    refused(capsys, ["identify", "vmc500", str(data), str(data), "--folds", "0"], "DATA: ")
    refused(capsys, ["identify", "vmc500", str(data), "again.csv", "--folds", "0"], f"again.csv is given twice (as {data})")
    refused(capsys, ["diagnose", "vmc500", "again.csv", str(data)], "its data would count twice")
