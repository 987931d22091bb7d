"""The CLI wires the library: JSON on stdout, exit 2 with one line on stderr for bad input."""

from __future__ import annotations

import json

import pinocchio as pin
import pytest

from volerr_pin.cli import main


def test_info_json(capsys):
    assert main(["info", "cgm4000", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["machine"] == "cgm4000"
    assert [a["name"] for a in info["axes"]] == ["X", "Y", "Z", "A", "B"]
    assert info["axes"][3]["unit"] == "deg"
    assert info["axes"][3]["travel"] == pytest.approx([-110.0, 90.0])
    assert info["chains"] == {"tool": ["X", "Y", "Z", "A", "B"], "workpiece": []}
    assert len(info["components"]) == 37
    assert sum(len(v) for v in info["terms_by_kind"].values()) == 37


def test_info_table(capsys):
    assert main(["info", "vmc500"]) == 0
    out = capsys.readouterr().out
    assert "workpiece chain: bed - X - Y - workpiece" in out
    assert "EC0Y" in out and "arcsec" in out


def test_urdf_writes_a_loadable_file(tmp_path, capsys):
    out = tmp_path / "gear.urdf"
    assert main(["urdf", "gear_roller", "-o", str(out)]) == 0
    model = pin.buildModelFromUrdf(str(out))
    assert model.nq == 4 + 24
    assert "24 error joints" in capsys.readouterr().err


def test_urdf_to_stdout(capsys):
    assert main(["urdf", "vmc500"]) == 0
    assert capsys.readouterr().out.startswith("<?xml")


def test_bad_machine_exits_2_with_one_line(capsys):
    assert main(["info", "nonexistent_machine"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and "nonexistent_machine" in captured.err


def test_demo_prints_summary(capsys):
    assert main(["demo", "--grid", "3"]) == 0
    out = capsys.readouterr().out
    assert "vmc500" in out and "volumetric error over 27 workspace points" in out


def test_demo_json(capsys):
    assert main(["demo", "--grid", "3", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["summary"]["points"] == 27
    assert data["summary"]["max_position_um"] >= data["summary"]["rms_position_um"] > 0
