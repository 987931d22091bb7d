"""``volerr export``: files, report, pictures, refusals; the report's fields are documented and
the package's public API has numpydoc docstrings."""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest
import rerun as rr

from volerr_pin.cli import main

ROOT = Path(__file__).resolve().parents[2]
MODULES = ["compensation.export", "compensation.export._protocol", "compensation.export._registry", "compensation.export._zone", "compensation.export._tables", "compensation.export._simulate",
           "compensation.export._fit", "compensation.export._run", "compensation.export._layouts", "compensation.export._linuxcnc", "compensation.export._isg", "compensation.export._isg_model",
           "compensation.export._isg_volumetric", "compensation.export._siemens", "compensation.export._heidenhain", "compensation.export._fanuc", "viz._export"]


def chunks(path, entity):
    return [c.to_record_batch() for c in rr.chunk.RrdReader(str(path)).stream() if c.entity_path == entity]


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory):
    """One run of the command with every output, its report parsed."""
    folder = tmp_path_factory.mktemp("cli")
    out = folder / "tables"
    argv = ["export", "vmc500", "--controller", "siemens-840d", "-o", str(out), "--points", "512", "--zone",
            "X=0:400", "tool=0:50", "--png", str(folder / "e.png"), "--rrd", str(folder / "e.rrd"), "--json"]
    import contextlib
    import io

    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        assert main(argv) == 0
    return folder, json.loads(stdout.getvalue())


def test_export_cli_writes_tables_report_and_pictures(cli_run):
    folder, report = cli_run
    assert report["machine"] == "vmc500" and report["controller"] == "siemens-840d" and report["kind"] == "cec"
    assert sorted(Path(f).name for f in report["files"]) == ["AX_EEC.INI", "NC_CEC.INI"]
    assert all(Path(f).is_file() for f in report["files"])
    assert report["zone"]["ranges"]["X"] == [0.0, 400.0] and report["zone"]["tool_mm"] == [0.0, 50.0]
    assert report["residual_max_um"] < report["naive_residual_max_um"] < report["uncompensated_max_um"] * 1.5
    assert report["exact_residual_max_um"] < 1e-3 and report["read_back"] is True
    assert mpimg.imread(folder / "e.png").shape[2] in (3, 4)
    # the recording: one static entity (and view) per stage, arrows = error x scale on the same points
    stages = ["1_uncompensated", "2_naive_tables", "3_written_tables", "4_exact_compensation"]
    vectors = [np.asarray(row, dtype=float).reshape(-1, 3) for stage in stages
               for b in chunks(folder / "e.rrd", f"/export/{stage}/error") for row in b.column("Arrows3D:vectors").to_pylist()]
    assert len(vectors) == 4 and vectors[0].shape == (512, 3)
    rms = [np.sqrt(np.mean(np.sum(v ** 2, axis=1))) for v in vectors]
    assert rms[2] < rms[0] / 3 and rms[3] < rms[2] / 100                  # written tables shrink the arrows
    np.testing.assert_allclose(rms[2] / rms[0], report["residual_rms_um"] / report["uncompensated_rms_um"], rtol=1e-5)
    assert chunks(folder / "e.rrd", "/summary")


def test_export_cli_prints_a_table_and_the_files(tmp_path, capsys):
    assert main(["export", "vmc700", "--controller", "linuxcnc", "-o", str(tmp_path / "t"), "--points", "256"]) == 0
    out = capsys.readouterr().out
    assert "uncompensated" in out and "written tables, as the controller applies them" in out
    assert "wrote " + str(tmp_path / "t" / "compensation.ini") in out


@pytest.mark.parametrize("argv,message", [
    (["--controller", "linuxcnc", "--zone", "Q=1:2"], "volerr: error: --zone: 'Q=1:2' names no axis of vmc500"),
    (["--controller", "fanuc", "--kind", "cec"], "volerr: error: --kind: fanuc has no tables of kind 'cec'"),
    (["--controller", "linuxcnc", "--nodes", "300"], "volerr: error: --nodes: LinuxCNC holds 2 to 256 entries"),
    (["--controller", "isg", "--kind", "volumetric", "--zone", "X=9:8"],
     "volerr: error: --zone: 'X=9:8': the range runs"),
])
def test_export_cli_refuses_with_one_line_before_any_work(tmp_path, capsys, argv, message):
    out = tmp_path / "never"
    assert main(["export", "vmc500", "-o", str(out), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith(message) and err.count("\n") == 1
    assert not out.exists()


def test_export_cli_refuses_a_machine_and_an_output_that_is_a_file(tmp_path, capsys):
    assert main(["export", "ur5", "--controller", "heidenhain", "-o", str(tmp_path / "x")]) == 2
    assert "axis J1 is not an NC axis" in capsys.readouterr().err
    (tmp_path / "file").write_text("keep")
    assert main(["export", "vmc500", "--controller", "linuxcnc", "-o", str(tmp_path / "file")]) == 2
    assert capsys.readouterr().err.startswith("volerr: error: --out:")
    assert (tmp_path / "file").read_text() == "keep"


def test_every_export_field_is_documented(cli_run):
    folder, report = cli_run
    fields = set()

    def walk(value):
        if isinstance(value, dict):
            for k, v in value.items():
                if re.fullmatch(r"[a-z][a-z0-9_]*", k):
                    fields.add(k)
                walk(v)
        elif isinstance(value, list):
            for v in value:
                walk(v)

    walk(report)
    text = (ROOT / "docs" / "reports.md").read_text()
    section = text[text.index("## `volerr export --json`"):]
    documented = set(re.findall(r"`([a-z][a-z0-9_]*)`", section))
    assert fields and not fields - documented, sorted(fields - documented)


@pytest.mark.parametrize("name", MODULES)
def test_export_api_has_numpydoc_sections(name):
    from test_docstrings import problems_of, public_objects

    module = importlib.import_module(f"volerr_pin.{name}")
    if not public_objects(module):
        return
    problems = [p for p in problems_of(module)                    # a Protocol has no constructor to document
                if not (p.endswith("no Parameters section for the constructor")
                        and getattr(getattr(module, p.split(":")[0]), "_is_protocol", False))]
    assert not problems, f"volerr_pin.{name}:\n  " + "\n  ".join(problems)


def test_controllers_doc_cites_every_format_and_links_resolve():
    text = (ROOT / "docs" / "controllers.md").read_text()
    from volerr_pin.compensation.export import CONTROLLERS

    for name, fmt in CONTROLLERS.items():
        assert f"`{name}`" in text
        for kind in fmt.kinds:
            assert f"`{kind}`" in text
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if "://" not in target:
            assert (ROOT / "docs" / target).exists(), target
