"""volerr testpiece and volerr predict, end to end: the test piece predicted, compensated, and
the compensated program predicted against the part it was made for."""

from __future__ import annotations

import json

import numpy as np
import pytest

from volerr_pin.cli import main


def _code(argv) -> int:
    """The exit status of a command, argparse's refusals (which exit) included."""
    try:
        return main(argv)
    except SystemExit as exit:
        return exit.code


def _json(capsys, argv) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_the_test_piece_predicted_compensated_and_predicted_again(tmp_path, capsys):
    piece, compensated, png = tmp_path / "tp.nc", tmp_path / "tp_comp.nc", tmp_path / "part.png"
    assert main(["testpiece", "vmc500", "-o", str(piece)]) == 0
    assert "square 160 mm" in capsys.readouterr().err
    before = _json(capsys, ["predict", "vmc500", str(piece), "--png", str(png), "--json"])
    kinds = [f["kind"] for f in before["features"]]
    assert kinds.count("circle") == 1 and kinds.count("straightness") == 8
    assert kinds.count("squareness") == 8 and kinds.count("parallelism") == 4
    circle = before["features"][0]
    assert circle["diameter_mm"] == pytest.approx(96.0) and circle["circularity_um"] > 1.0
    assert {s["component"] for s in circle["drivers"]} & {"EC0Y", "EXX"}
    assert before["max_normal_deviation_um"] == max(b["max_um"] for b in before["blocks"])
    assert png.read_bytes()[:4] == b"\x89PNG" and before["png"]["path"] == str(png)
    assert main(["compensate", "vmc500", str(piece), "-o", str(compensated), "--tol-um", "0.1",
                 "--start", "X=250", "Y=200", "Z=250", "--json"]) == 0
    capsys.readouterr()
    after = _json(capsys, ["predict", "vmc500", str(compensated), "--reference", str(piece), "--json"])
    assert after["reference"] == str(piece)
    assert [f["blocks"] for f in after["features"]] == [f["blocks"] for f in before["features"]]
    for b, a in zip(before["features"], after["features"]):
        key = next(k for k in a if k.endswith("_um") and k not in ("diameter_error_um", "centre_error_um"))
        # compensated to 0.1 um, written to 4 decimals (up to 0.087 um more): what is left
        assert a[key] < 0.25, (a["kind"], a["blocks"], a[key])
    assert after["features"][0]["circularity_um"] < before["features"][0]["circularity_um"] / 5


def test_predict_prints_the_features_and_their_sources(tmp_path, capsys):
    piece = tmp_path / "tp.nc"
    assert main(["testpiece", "cgm4000", "-o", str(piece), "--size", "100"]) == 0
    assert main(["predict", "cgm4000", str(piece), "--top", "2"]) == 0
    out = capsys.readouterr().out
    assert "largest deviation normal to the programmed path" in out
    assert "squareness" in out and "roundness" in out and "EC0Y" in out


def test_the_cone_frustum_of_a_five_axis_machine(tmp_path, capsys):
    piece = tmp_path / "cone.nc"
    assert main(["testpiece", "cgm4000", "--kind", "cone-frustum", "-o", str(piece)]) == 0
    err = capsys.readouterr().err
    assert "NAS 979" in err and "--tool-diameter 20 --cone-heights 2,10,18" in err
    assert "G43.4" in piece.read_text()
    report = _json(capsys, ["predict", "cgm4000", str(piece), "--tool-diameter", "20", "--cone-heights", "2,10,18",
                            "--json"])
    cones = [f for f in report["features"] if f["kind"] == "cone"]
    assert [c["height_mm"] for c in cones] == [2.0, 10.0, 18.0] and len(report["features"]) == 3
    assert cones[0]["diameter_mm"] == pytest.approx(80 - 4 * np.tan(np.radians(15)), abs=1e-3)   # chords: 0.1 um in
    assert cones[0]["form"] == "boss" and cones[0]["half_angle_deg"] == pytest.approx(15.0, abs=1e-4)
    for cone in cones:
        assert cone["circularity_um"] > 1.0 and cone["drivers"] and len(cone["blocks"]) == 1440
    # without the cutter's diameter: the cone the tool's axis sweeps, and a note
    assert main(["predict", "cgm4000", str(piece), "--top", "1"]) == 0
    out = capsys.readouterr().out
    assert "cone at 0 mm" in out and "give the cutter's --tool-diameter" in out
    # the tool tips go round 80 + 2 r cos(15 deg) across (less 0.1 um: the chords)
    import re

    across = float(re.search(r"cone at 0 mm \(([\d.]+) mm\)", out).group(1))
    assert across == pytest.approx(80 + 20 * np.cos(np.radians(15)), abs=1.5e-3)


@pytest.mark.parametrize("argv, message", [
    (["testpiece", "vmc500", "--size", "900"], "the square's side 900 mm does not fit vmc500's travel"),
    (["testpiece", "lathe_2axis"], "needs linear X, Y, Z"),
    (["testpiece", "vmc500", "--kind", "cone-frustum"], "needs a five-axis machine"),
    (["testpiece", "cgm4000", "--kind", "cone-frustum", "--size", "0"], "--size (the base diameter) must be"),
    (["testpiece", "vmc500", "--feed", "nan"], "--feed: nan mm/min is not a number: a feed rate lies within 0.001 .. "),
    (["testpiece", "vmc500", "--feed", "1e300"], "--feed: 1e+300 mm/min is implausible"),
    (["testpiece", "vmc500", "--feed", "0"], "--feed: 0 mm/min is implausible"),
    (["testpiece", "vmc500", "--size", "0.0001"], "the square's side 0.0001 mm is below 10 mm"),
    (["testpiece", "vmc500", "--size", "1e300"], "argument --size: 1e300 mm is implausible"),
])
def test_testpiece_refusals(tmp_path, capsys, argv, message):
    assert _code([*argv, "-o", str(tmp_path / "x.nc")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.nc").exists()


@pytest.mark.parametrize("option, message", [
    (["--tol-um", "nan"], "argument --tol-um: expected a positive, finite tolerance in um, got 'nan'"),
    (["--tol-um", "1e300"], "argument --tol-um: 1e300 um is implausible"),
    (["--tool-diameter", "1e300"], "argument --tool-diameter: 1e300 mm is implausible"),
    (["--cone-heights", "2,1e300"], "argument --cone-heights: 1e300 mm is implausible"),
    (["--start", "X=1e300"], "--start X: 1e+300 mm is implausible"),
    (["--origin", "Y=-1e9"], "--origin Y: -1000000000 mm is implausible"),
])
def test_predict_options_are_checked_as_a_spec_s_values(tmp_path, capsys, option, message):
    piece = tmp_path / "tp.nc"
    assert main(["testpiece", "vmc500", "-o", str(piece)]) == 0
    capsys.readouterr()
    assert _code(["predict", "vmc500", str(piece), *option]) == 2
    err = capsys.readouterr().err
    assert message in err.strip().splitlines()[-1] and "Traceback" not in err


def test_predict_refuses_a_move_out_of_the_travel_naming_its_line(tmp_path, capsys):
    program = tmp_path / "far.nc"
    program.write_text("G90 G21\nG0 X50 Y100 Z100\nG1 X700 F500\nM30\n")
    assert main(["predict", "vmc500", str(program)]) == 2
    assert "line 3: the move takes X to 700.0000 mm, outside its travel 0 .. 500 mm" in capsys.readouterr().err


def test_predict_reads_each_program_once_and_never_joins_its_text(tmp_path, capsys, monkeypatch):
    """volerr predict reads the program (and the reference) line by line once and gives the NC
    reader its lines: no file is read twice and no text is joined to be split again."""
    from volerr_pin.compensation.gcode import ProgramFile, _segments as segments

    piece = tmp_path / "tp.nc"
    assert main(["testpiece", "vmc500", "-o", str(piece)]) == 0
    capsys.readouterr()
    expected = _json(capsys, ["predict", "vmc500", str(piece), "--reference", str(piece), "--json"])
    reads = []
    lines = ProgramFile.lines

    def counted(self):
        reads.append(self.path)
        return lines(self)

    def refused(text):
        raise AssertionError("the program's text was split again")

    monkeypatch.setattr(ProgramFile, "lines", counted)
    monkeypatch.setattr(segments, "split_lines", refused)
    assert _json(capsys, ["predict", "vmc500", str(piece), "--reference", str(piece), "--json"]) == expected
    assert reads == [piece, piece]   # the program, then the reference


def test_predict_reports_a_state_of_directions(tmp_path, capsys):
    """A state with directions (an array) is reported as numbers in JSON (it was refused by the
    JSON encoder), and named in the text."""
    piece = tmp_path / "tp.nc"
    assert main(["testpiece", "vmc500", "-o", str(piece)]) == 0
    capsys.readouterr()
    report = _json(capsys, ["predict", "vmc500", str(piece), "--state", "directions=-1,1,1", "t=10", "--json"])
    assert report["state"] == {"directions": [-1.0, 1.0, 1.0], "t": 10.0}
    assert main(["predict", "vmc500", str(piece), "--state", "directions=-1,1,1"]) == 0
    assert "(directions=" in capsys.readouterr().out
