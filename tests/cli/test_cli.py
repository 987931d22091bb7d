"""The CLI wires the library: JSON on stdout, exit 2 with one line on stderr for bad input."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import volerr_pin as vp
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


def _urdf_nesting(path) -> dict[str, list[str]]:
    """Each joint of a URDF and the joints between it and the root, nearest first (read from the
    XML, not through the product)."""
    import xml.etree.ElementTree as ET

    joints = {j.get("name"): (j.find("parent").get("link"), j.find("child").get("link"))
              for j in ET.parse(path).getroot().findall("joint")}  # (not a transmission's)
    into = {child: name for name, (_, child) in joints.items()}
    out = {}
    for name, (parent, _) in joints.items():
        up = []
        while parent in into:
            up.append(into[parent])
            parent = joints[into[parent]][0]
        out[name] = up
    return out


@pytest.mark.parametrize("name", vp.bundled_machines())
def test_info_prints_each_chain_in_the_order_the_urdf_nests_it(name, capsys):
    """Each chain runs from the bed outwards as the URDF nests the axes' joints, whatever the
    order of the spec's [axes] (vmc700 names X before Y; its Y carries X)."""
    machine = vp.load_machine(name)
    spec = machine.model.spec
    nesting = _urdf_nesting(spec.urdf)
    joint = {a.name: a.joint for a in spec.axes}
    assert main(["info", name, "--json"]) == 0
    chains = json.loads(capsys.readouterr().out)["chains"]
    assert sorted(chains["tool"] + chains["workpiece"]) == sorted(machine.axes)
    for chain in chains.values():
        for inner, outer in zip(chain, chain[1:]):
            assert joint[inner] in nesting[joint[outer]], (name, chain)
    if name == "vmc700":
        assert chains["workpiece"] == ["Y", "X"] and list(machine.axes) == ["X", "Y", "Z"]


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


def test_demo_prints_summary(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)       # the default recording lands here, never in the user's folder
    assert main(["demo", "--grid", "3"]) == 0
    out = capsys.readouterr().out
    assert "vmc500" in out and "volumetric error over 27 workspace points" in out


def test_demo_json(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "--grid", "3", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["summary"]["points"] == 27
    assert data["summary"]["max_position_um"] >= data["summary"]["rms_position_um"] > 0
    comp = data["compensation"]
    assert comp["reduction_percent"] > 99 and comp["max_after_um"] < 0.02 < comp["max_before_um"]


NC = """N10 G21 G90 G17 (setup)
N20 T1 M6
N30 G0 X50 Y50 Z100
N40 G1 Z50 F500
N50 G1 X300 Y200
N60 G2 X400 Y100 I100 J0
N70 M30
"""


def test_compensate_writes_program_and_report(tmp_path, capsys):
    src = tmp_path / "part.nc"
    src.write_text(NC)
    out, rep = tmp_path / "part_comp.nc", tmp_path / "report.json"
    assert main(["compensate", "vmc500", str(src), "-o", str(out), "--tol-um", "2", "--report", str(rep)]) == 0
    report = json.loads(rep.read_text())
    assert report["blocks_in"] == 7 and report["blocks_out"] == len(out.read_text().splitlines())
    assert report["tolerance_um"] == 2 and report["max_residual_um"] <= 2
    assert "warnings" in report
    text = capsys.readouterr().out
    assert "blocks in" in text and "tolerance 2 um" in text
    lines = out.read_text().splitlines()
    assert lines[0] == "N10 G21 G90 G17 (setup)" and lines[1] == "N20 T1 M6" and lines[-1] == "N70 M30"


def test_compensate_json_and_errors(tmp_path, capsys):
    text = "G90 G0 X10 Y10 Z10\nG81 X20 Y20 Z5 R12\nG80\nG1 X30\n"
    src = tmp_path / "cycle.nc"
    src.write_text(text)
    out = tmp_path / "o.nc"
    # the default keeps the canned cycle byte for byte, names its line and compensates the rest
    assert main(["compensate", "vmc500", str(src), "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["blocks_in"] == 4 and report["passed_through"] == 1 and report["moves"] == 2
    assert any(w.startswith("line 2: G81 (canned cycle) kept unchanged") for w in report["warnings"])
    written = out.read_text().splitlines()
    assert written[1:3] == text.splitlines()[1:3] and written[3] != "G1 X30"
    # --strict refuses it: exit 2, one line naming the line and the option, nothing written
    out.unlink()
    assert main(["compensate", "vmc500", str(src), "-o", str(out), "--strict"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cycle.nc:2" in err and "--strict" in err and not out.exists()
    # a G code the reader does not know may change how later blocks read: refused unless
    # --pass-through keeps it (with a warning)
    unknown = tmp_path / "unknown.nc"
    unknown.write_text("G90 G0 X10 Y10 Z10\nG77 Q1\nG1 X30\n")
    assert main(["compensate", "vmc500", str(unknown), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown.nc:2:1" in err and "--pass-through" in err and not out.exists()
    assert main(["compensate", "vmc500", str(unknown), "-o", str(out), "--pass-through", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["passed_through"] == 1 and any("line 2: G77" in w and "misread" in w for w in report["warnings"])
    with pytest.raises(SystemExit) as exit:  # argparse: the two contradict each other
        main(["compensate", "vmc500", str(src), "-o", str(out), "--strict", "--pass-through"])
    assert exit.value.code == 2 and "not allowed with" in capsys.readouterr().err


def test_errormap_cli(tmp_path, capsys):
    table = tmp_path / "table.csv"
    assert main(["errormap", "vmc700", "--elements", "2", "--points", "300", "--table", str(table),
                 "--nodes", "4", "--axis-tables", str(tmp_path / "axes"), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [r["nodes_per_element"] for r in report["orders"]] == [8, 20, 32]
    rms = [r["rms_um"] for r in report["orders"]]
    assert rms[0] > rms[2]
    assert table.exists() and report["table"]["rows"] == 64
    assert len(report["axis_tables"]) == 3
    assert main(["errormap", "lathe_2axis"]) == 2
    assert "three linear axes" in capsys.readouterr().err


def test_compensate_png(tmp_path, capsys):
    src = tmp_path / "part.nc"
    src.write_text(NC)
    png = tmp_path / "c.png"
    assert main(["compensate", "vmc500", str(src), "-o", str(tmp_path / "o.nc"), "--png", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert f"wrote {png}" in capsys.readouterr().out


def _thermal_spec(tmp_path):
    """vmc500 with a 6 um thermal drift along z with a 50 min time constant."""
    import volerr_pin as vp
    from volerr_pin.model import add_terms, write_spec

    m = add_terms(vp.load_machine("vmc500"), {
        "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [6.0],
                "time_constants_min": [50.0]}})
    return m, write_spec(m, tmp_path / "warm.toml")


def test_state_drives_time_dependent_terms(tmp_path, capsys):
    m, spec = _thermal_spec(tmp_path)
    # without a state the command says what is missing
    assert main(["errormap", str(spec), "--elements", "1", "--points", "50"]) == 2
    err = capsys.readouterr().err
    assert "needs the covariate t" in err and "hold the machine in a state (--state)" in err
    # in a state it maps the warm machine: the map's error RMS equals the model's at t
    assert main(["errormap", str(spec), "--elements", "1", "--points", "400", "--order", "3",
                 "--state", "t=3600", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    from volerr_pin.compensation import ErrorMap

    warm = ErrorMap.build(m.with_state(t=3600.0), (1, 1, 1), 3).interpolation_error(400, 0)
    cold = ErrorMap.build(m.with_state(t=0.0), (1, 1, 1), 3).interpolation_error(400, 0)
    assert report["orders"][0]["error_rms_um"] == pytest.approx(warm["error_rms_um"], rel=1e-12)
    assert abs(warm["error_rms_um"] - cold["error_rms_um"]) > 0.1  # the state matters
    # compensate and rank take the state too
    src = tmp_path / "p.nc"
    src.write_text("G90 G0 X100 Y100 Z100\nG1 X300 Y200 F500\n")
    assert main(["compensate", str(spec), str(src), "-o", str(tmp_path / "o.nc"), "--state", "t=3600",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["max_residual_um"] <= 1.0
    assert main(["rank", str(spec), "--points", "64", "--state", "t=3600", "--json"]) == 0
    assert main(["rank", str(spec), "--points", "64", "--state", "t=abc"]) == 2
    assert "not a number" in capsys.readouterr().err


def test_with_state_fills_missing_covariates_only():
    import numpy as np
    import volerr_pin as vp
    from volerr_pin.model import add_terms

    m = add_terms(vp.load_machine("vmc500"), {
        "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [6.0],
                "time_constants_min": [50.0]}})
    q = np.array([[0.1, 0.1, 0.1], [0.2, 0.2, 0.2]])
    warm = m.with_state(t=7200.0)
    np.testing.assert_array_equal(warm.volumetric_error(q), m.volumetric_error(q, t=[7200.0, 7200.0]))
    np.testing.assert_array_equal(warm.volumetric_error(q, t=[0.0, 60.0]), m.volumetric_error(q, t=[0.0, 60.0]))
    assert m.state == {} and warm.state["t"] == 7200.0
    with pytest.raises(vp.InputError, match="forces"):
        m.with_state(forces=[1.0, 2.0])


def test_info_and_demo_of_a_time_dependent_spec(tmp_path, capsys):
    m, spec = _thermal_spec(tmp_path)
    # info shows the geometry without a state and says so; with a state, all terms
    assert main(["info", str(spec), "--json"]) == 0
    cold = json.loads(capsys.readouterr().out)
    assert cold["ranges_of"].startswith("terms that read no covariates (t not given")
    assert main(["info", str(spec), "--state", "t=36000", "--json"]) == 0
    warm = json.loads(capsys.readouterr().out)
    assert warm["ranges_of"] == "all terms"
    ezz = {c["name"]: c for c in cold["components"]}["EZZ"], {c["name"]: c for c in warm["components"]}["EZZ"]
    assert ezz[1]["max"] - ezz[0]["max"] == pytest.approx(6.0 * (1 - np.exp(-600 / 50)), abs=1e-6)
    assert main(["demo", "--machine", str(spec), "--out", str(tmp_path / "d.rrd")]) == 2
    assert "hold the machine in a state" in capsys.readouterr().err
    assert main(["demo", "--machine", str(spec), "--state", "t=3600", "--grid", "3",
                 "--out", str(tmp_path / "d.rrd"), "--json"]) == 0


def test_covariates_in_some_files_only(tmp_path, capsys):
    """A tracker file with times and temperatures beside an interferometer run without them:
    a geometric model does not read them (a note), a model that does needs them everywhere."""
    import volerr_pin as vp
    from volerr_pin.measurements import campaign, write_points

    m = vp.load_machine("vmc500")
    points = tmp_path / "points.csv"
    write_points(campaign(m, 60, 0.3, seed=3), m, points)
    run = tmp_path / "run.csv"
    run.write_text("# axis: X\ntarget_mm,cycle,direction,deviation_um\n"
                   + "".join(f"{x},1,1,{0.01 * x:.3f}\n" for x in range(0, 501, 50)))
    assert main(["identify", "vmc500", str(points), str(run), "--folds", "0", "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["n_points"] == 71
    assert "note: the time column t is in some measurement files but not in others" in captured.err
    _, spec = _thermal_spec(tmp_path)
    assert main(["identify", str(spec), str(points), str(run), "--folds", "0"]) == 2
    assert "the time column t is in some measurement files but not in others" in capsys.readouterr().err


def test_json_reports_are_strict_json():
    """Non-finite numbers become null: a NaN token would break strict JSON readers."""
    from volerr_pin.cli._common import dumps

    text = dumps({"a": float("nan"), "b": [1.0, float("inf")], "c": np.float64(2.5), "d": np.int64(3)})
    assert json.loads(text) == {"a": None, "b": [1.0, None], "c": 2.5, "d": 3}


def test_library_errors_name_parameters_and_the_cli_its_options(tmp_path, capsys):
    """The library speaks of its parameters (``lag``, ``run_axis``), the CLI of its options."""
    import io
    import re
    import tokenize
    from pathlib import Path

    import volerr_pin as vp
    from volerr_pin.measurements import read_series
    from volerr_pin.applications.thermalfit import thermal_fit

    data = Path(__file__).parents[2] / "examples" / "data" / "vmc500_spindle_thermal.csv"
    series = read_series([str(data)])
    target = list(series.columns)[-1]
    with pytest.raises(vp.InputError, match=r"^lag must be >= 0, got -1$") as err:
        thermal_fit(series, target, lag=-1)
    assert err.value.parameters == ("lag",)
    assert main(["thermal-fit", str(data), "--target", target, "--lag", "-1"]) == 2
    assert capsys.readouterr().err == "volerr: error: --lag must be >= 0, got -1\n"
    assert main(["thermal-fit", str(data), "--target", "nope"]) == 2
    assert capsys.readouterr().err.startswith("volerr: error: --target: no column 'nope'")

    run = tmp_path / "run.csv"
    run.write_text("target_mm,cycle,direction,deviation_um\n0,1,1,0.5\n100,1,1,1.5\n")
    m = vp.load_machine("vmc500")
    from volerr_pin.fit.identify import identify
    from volerr_pin.measurements import read_runs

    with pytest.raises(vp.InputError, match="in the file or run_axis$"):
        identify(m, [read_runs(run)])
    assert main(["identify", "vmc500", str(run)]) == 2
    assert capsys.readouterr().err.rstrip().endswith("Give '# axis: X' in the file or --axis")

    # no option of the command line is named in the library's own strings
    root = Path(vp.__file__).parent
    for path in sorted(root.rglob("*.py")):
        if "cli" in path.relative_to(root).parts:
            continue
        for tok in tokenize.generate_tokens(io.StringIO(path.read_text()).readline):
            if tok.type == tokenize.STRING:
                assert not re.search(r"(^|[\s(\"'])--[a-z]", tok.string), (path.name, tok.start, tok.string)


def test_state_the_machine_does_not_read_is_noted(tmp_path, capsys):
    import volerr_pin as vp
    from volerr_pin.model import replace_terms, write_spec

    assert vp.load_machine("vmc500").sensors == ()
    assert main(["rank", "vmc500", "--points", "16", "--state", "nosuch=25", "t=3", "--json"]) == 0
    assert capsys.readouterr().err.strip() == ("volerr: note: --state: vmc500 does not read sensor 'nosuch', t, which "
                                               "change nothing (temperature sensors it reads: none)")
    m = replace_terms(vp.load_machine("vmc500"), {
        "EYZ": {"kind": "thermal_drift", "driver": "temperature", "prefix": "h", "sensors": ["column", "bed"],
                "coefficients_um_per_K": [2.0, 1.0], "reference_degC": 21.0},
        "EXX": {"kind": "thermal_expansion", "driver": "temperature", "prefix": "e", "sensor": "spindle",
                "coefficient_ppm_per_K": 2.0, "reference_degC": 22.0}})
    assert m.sensors == ("bed", "column", "spindle")
    spec = write_spec(m, tmp_path / "thermal.toml")
    assert main(["rank", str(spec), "--points", "16", "--state", "column=25", "bed=21", "spindle=23", "--json"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["rank", str(spec), "--points", "16", "--state", "column=25", "bed=21", "spindle=23", "colum=24",
                 "--json"]) == 0
    assert "does not read sensor 'colum', which change nothing (temperature sensors it reads: bed, column, " \
           "spindle)" in capsys.readouterr().err


def test_rank_says_what_state_it_ranked_in_and_where_backlash_sits(tmp_path, capsys):
    """A backlash term without directions is at its mean (the spec format's d = 0): rank says so
    in its header and on stderr, and echoes the state; with directions it does neither."""
    from volerr_pin.model import add_terms, write_spec

    spec = tmp_path / "backlash.toml"
    write_spec(add_terms(vp.load_machine("vmc500"), {"EXX": {"kind": "backlash", "reversal_um": 4.0}}), spec)
    assert main(["rank", str(spec), "--top", "3", "--points", "64"]) == 0
    out, err = capsys.readouterr()
    assert "backlash at its mean: no directions in --state" in out and "half-way between" in err
    assert main(["rank", str(spec), "--top", "3", "--points", "64", "--state", "directions=1,-1,1"]) == 0
    out, err = capsys.readouterr()
    assert "state directions=1,-1,1)" in " ".join(out.split()) and "backlash" not in err


def test_demo_on_a_machine_without_error_values_says_so(tmp_path, capsys):
    """A bare URDF gets zero-valued terms: the demo says the field is zero and why the shares are."""
    from pathlib import Path

    urdf = Path(__file__).resolve().parents[2] / "examples" / "data" / "two_link_arm.urdf"
    assert main(["demo", "--machine", str(urdf), "--tool-frame", "tool0", "--workpiece-frame", "world",
                 "--grid", "3", "--out", str(tmp_path / "d.rrd")]) == 0
    out, err = capsys.readouterr()
    assert "has no error values: every error term is zero" in err
    assert "no error values: the ranking below lists the terms, every one with a zero share" in out


def test_info_shows_where_a_written_specs_values_came_from(tmp_path, capsys):
    from pathlib import Path

    data = Path(__file__).resolve().parents[2] / "examples" / "data" / "vmc500_tracker.csv"
    out = tmp_path / "identified.toml"
    assert main(["identify", "vmc500", str(data), "-o", str(out), "--json"]) == 0
    capsys.readouterr()
    assert main(["info", str(out), "--json"]) == 0
    provenance = json.loads(capsys.readouterr().out)["provenance"]
    assert provenance["derived_from"].endswith("errors.toml") and provenance["n_points"] == 300
    assert main(["info", str(out)]) == 0
    assert "provenance: written " in capsys.readouterr().out
    assert main(["info", "vmc500", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["provenance"] is None


def test_field_png_slices_the_plane_asked_for(tmp_path, capsys):
    """--slice picks the picture's plane; --config places the axes it does not span (and says so
    when it names one the slice spans); a slice of a rotary or unknown axis is refused."""
    png = tmp_path / "xz.png"
    assert main(["field", "vmc500", "--out", str(tmp_path / "f.rrd"), "--png", str(png), "--slice", "X", "Z",
                 "--config", "X=400", "Y=100", "--grid", "3", "--json"]) == 0
    out, err = capsys.readouterr()
    assert png.stat().st_size > 10_000 and json.loads(out)["png"] == str(png)
    assert "--config X: the --png slice spans X and Z over their whole travel" in err
    for argv, message in ((["--slice", "X", "Q", "--png", str(tmp_path / "q.png")], "'Q' is not an axis of vmc500"),
                          (["--slice", "X", "Z"], "give --png too")):
        assert main(["field", "vmc500", "--out", str(tmp_path / "g.rrd"), *argv]) == 2
        assert message in capsys.readouterr().err
    assert main(["field", "cgm4000", "--out", str(tmp_path / "h.rrd"), "--png", str(tmp_path / "h.png"),
                 "--slice", "X", "A"]) == 2
    assert "A is a rotary axis" in capsys.readouterr().err


def test_identifiability_factors_in_display_units_follow_the_group_kind():
    """A collinear group says A_k = f A_0, a combination sum w_k A_k = 0: in display units the first
    scales by u_k / u_0, the second by u_0 / u_k. A drift's time constant (per s) collinear with an
    offset (per m), 8.2e-10 m per s, is 0.049 um per minute, not 1.4e-17."""
    import io

    from rich.console import Console

    from volerr_pin.cli._tables import print_groups

    units = {"EZX.c0": (1e-6, "um"), "EZX.tau1": (60.0, "min"), "EYX.c1": (1e-6, "um")}
    out = io.StringIO()
    print_groups(Console(file=out, width=200), [
        {"kind": "collinear", "parameters": ["EZX.c0", "EZX.tau1"], "factors": [1.0, 8.2e-10]},
        {"kind": "combination", "parameters": ["EZX.tau1", "EYX.c1"], "factors": [1.0, -2e-9]}], units=units)
    text = out.getvalue()
    assert "+1 EZX.c0, +0.0492 EZX.tau1" in text          # 8.2e-10 m/s x 60 s/min / 1e-6 m/um
    assert "+1 EZX.tau1, -0.12 EYX.c1" in text             # -2e-9 x 60 s/min / 1e-6 m/um, unchanged by this fix
