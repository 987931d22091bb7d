"""One spelling per concept on the command line: ``-o/--out`` for every file a command
writes, its suffix checked against what is written; ``--png`` for every picture; the old
spellings hidden, working for one release, and saying the new one."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from volerr_pin.cli import build_parser, main

DATA = Path(__file__).resolve().parents[2] / "examples" / "data"


def _commands() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def test_every_command_spells_its_outputs_one_way():
    """No command shows ``--output`` or ``--plot``; every written file is ``-o/--out``, every
    picture ``--png``."""
    seen_out = []
    for name, parser in _commands().items():
        shown = {s for a in parser._actions if a.help != argparse.SUPPRESS for s in a.option_strings}
        assert not shown & {"--output", "--plot"}, name
        for action in parser._actions:
            if action.dest == "out" and action.help != argparse.SUPPRESS:
                assert action.option_strings == ["-o", "--out"], name
                seen_out.append(name)
            if action.dest == "png" and action.help != argparse.SUPPRESS:
                assert action.option_strings == ["--png"], name
    assert {"compensate", "export", "urdf", "dh", "diagnose", "identify", "field", "demo"} <= set(seen_out)


def test_the_old_spellings_still_work_and_say_the_new_one(tmp_path, capsys):
    urdf, png = tmp_path / "m.urdf", tmp_path / "x.png"
    assert main(["urdf", "vmc500", "--output", str(urdf)]) == 0
    assert "volerr: warning: --output is spelled -o/--out now" in capsys.readouterr().err
    assert urdf.read_text().startswith("<?xml")
    assert main(["iso230-2", str(DATA / "vmc500_x_positioning.csv"), "--plot", str(png), "--json"]) == 0
    assert "volerr: warning: --plot is spelled --png now" in capsys.readouterr().err
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("argv, message", [
    (["diagnose", "vmc500", str(DATA / "vmc500_tracker.csv"), "-o", "final.txt"],
     "this writes a spec (TOML): its name ends in .toml, got final.txt"),
    (["field", "vmc500", "-o", "field.toml"], "this writes a Rerun recording: its name ends in .rrd, got field.toml"),
    (["urdf", "vmc500", "--out", "m.json"], "this writes a URDF: its name ends in .urdf or .xml, got m.json"),
    (["compensate", "vmc500", str(DATA / "part.nc"), "-o", "part.json"],
     "part.json is named as a report (JSON), but this writes an NC program"),
    (["compensate", "vmc500", str(DATA / "part.nc"), "--output", "part.rrd"],
     "part.rrd is named as a Rerun recording, but this writes an NC program"),
])
def test_an_output_named_as_another_kind_of_file_is_refused_before_any_work(tmp_path, monkeypatch, capsys, argv,
                                                                           message):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert f"volerr: error: --out: {message}" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
