"""One spelling per concept on the command line: ``-o/--out`` for every file a command
writes, its suffix checked against what is written; ``--png`` for every picture; no hidden
old spelling."""

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
    """No command has ``--output`` or ``--plot``, shown or hidden; every written file is
    ``-o/--out``, every picture ``--png``."""
    seen_out = []
    for name, parser in _commands().items():
        assert not {s for a in parser._actions for s in a.option_strings} & {"--output", "--plot"}, name
        for action in parser._actions:
            if action.dest == "out":
                assert action.option_strings == ["-o", "--out"], name
                seen_out.append(name)
            if action.dest == "png":
                assert action.option_strings == ["--png"], name
    assert {"compensate", "export", "urdf", "dh", "diagnose", "identify", "field", "demo"} <= set(seen_out)


@pytest.mark.parametrize("argv", [["urdf", "vmc500", "--output", "m.urdf"],
                                  ["iso230-2", str(DATA / "vmc500_x_positioning.csv"), "--plot", "x.png"]])
def test_the_old_spellings_are_unknown_options(tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == 2
    assert f"unrecognized arguments: {argv[-2]}" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv, message", [
    (["diagnose", "vmc500", str(DATA / "vmc500_tracker.csv"), "-o", "final.txt"],
     "this writes a spec (TOML): its name ends in .toml, got final.txt"),
    (["field", "vmc500", "-o", "field.toml"], "this writes a Rerun recording: its name ends in .rrd, got field.toml"),
    (["urdf", "vmc500", "--out", "m.json"], "this writes a URDF: its name ends in .urdf or .xml, got m.json"),
    (["compensate", "vmc500", str(DATA / "part.nc"), "-o", "part.json"],
     "part.json is named as a report (JSON), but this writes an NC program"),
    (["compensate", "vmc500", str(DATA / "part.nc"), "--out", "part.rrd"],
     "part.rrd is named as a Rerun recording, but this writes an NC program"),
])
def test_an_output_named_as_another_kind_of_file_is_refused_before_any_work(tmp_path, monkeypatch, capsys, argv,
                                                                           message):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert f"volerr: error: --out: {message}" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
