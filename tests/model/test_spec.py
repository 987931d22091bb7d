"""Error specs: bad input is reported with the file and the key; units convert once."""

from __future__ import annotations

import os
import re
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.base import _safeio as safeio
from volerr_pin.model import machines_dir, read_toml

from conftest import random_q


@pytest.fixture
def vmc500_copy(tmp_path):
    folder = tmp_path / "m"
    shutil.copytree(machines_dir() / "vmc500", folder)
    return folder


def edit(folder: Path, old: str, new: str) -> Path:
    spec = folder / "errors.toml"
    text = spec.read_text()
    assert old in text, old
    spec.write_text(text.replace(old, new, 1))
    return spec


def test_toml_syntax_error_names_line(vmc500_copy):
    edit(vmc500_copy, 'joint = "x_axis"', 'joint = "x_axis')
    with pytest.raises(vp.SpecError, match=r"errors\.toml: invalid TOML: .*line \d+"):
        vp.load_machine(vmc500_copy)


def test_unknown_axis_joint(vmc500_copy):
    edit(vmc500_copy, 'joint = "x_axis"', 'joint = "w_axis"')
    with pytest.raises(vp.SpecError, match=r"axes\.X: joint 'w_axis' is not a joint of .*vmc500\.urdf"):
        vp.load_machine(vmc500_copy)


def test_error_term_for_an_axis_that_does_not_exist(vmc500_copy):
    edit(vmc500_copy, "[errors.EYX]", "[errors.EYW]")
    with pytest.raises(vp.SpecError, match=r"errors\.EYW: 'W' is not an axis or body of this machine"):
        vp.load_machine(vmc500_copy)


def test_not_a_component_name(vmc500_copy):
    edit(vmc500_copy, "[errors.EYX]", "[errors.straightness]")
    with pytest.raises(vp.SpecError, match=r"errors\.straightness: .* is not a component error name"):
        vp.load_machine(vmc500_copy)


def test_unknown_frame(vmc500_copy):
    edit(vmc500_copy, 'tool_frame = "tool"', 'tool_frame = "cutter"')
    with pytest.raises(vp.SpecError, match=r"machine\.tool_frame = 'cutter' is not a link"):
        vp.load_machine(vmc500_copy)


def test_unknown_key_is_reported_not_ignored(vmc500_copy):
    edit(vmc500_copy, "coefficients_um = [0.0, 0.0, 1.5, -0.4]", "coeficients_um = [0.0, 0.0, 1.5, -0.4]")
    with pytest.raises(vp.SpecError, match=r"errors\.EYX: unknown key\(s\) coeficients_um"):
        vp.load_machine(vmc500_copy)


def test_angle_unit_on_a_translation(vmc500_copy):
    edit(vmc500_copy, "coefficients_um = [0.0, 0.0, 1.5, -0.4]", "coefficients_arcsec = [0.0, 0.0, 1.5, -0.4]")
    with pytest.raises(vp.SpecError, match=r"errors\.EYX\.coefficients_arcsec: unit 'arcsec' is an angle unit"):
        vp.load_machine(vmc500_copy)


def test_value_without_unit(vmc500_copy):
    edit(vmc500_copy, "value_arcsec = 4.0", "value = 4.0")
    with pytest.raises(vp.SpecError, match=r"errors\.EC0Y: key 'value' needs a unit suffix"):
        vp.load_machine(vmc500_copy)


def test_table_must_cover_travel(vmc500_copy):
    edit(vmc500_copy, "positions_mm = [0, 100, 200, 300, 400]", "positions_mm = [0, 100, 200, 300, 350]")
    with pytest.raises(vp.SpecError, match=r"errors\.EYY: the table covers 0\.\.350 mm but the travel is 0\.\.400 mm"):
        vp.load_machine(vmc500_copy)


def test_table_positions_must_increase(vmc500_copy):
    edit(vmc500_copy, "positions_mm = [0, 100, 200, 300, 400]", "positions_mm = [0, 200, 100, 300, 400]")
    with pytest.raises(vp.SpecError, match="strictly increasing"):
        vp.load_machine(vmc500_copy)


def test_table_extrapolation_can_be_asked_for(vmc500_copy):
    edit(vmc500_copy, "positions_mm = [0, 100, 200, 300, 400]",
         "extrapolate = true\npositions_mm = [0, 100, 200, 300, 350]")
    assert vp.load_machine(vmc500_copy).name == "vmc500"


def test_axis_off_the_tool_workpiece_path(tmp_path):
    urdf = """<robot name="r"><link name="base"/><link name="a"/><link name="b"/><link name="tip"/>
    <joint name="j1" type="prismatic"><parent link="base"/><child link="a"/><limit lower="0" upper="1"/></joint>
    <joint name="j2" type="prismatic"><parent link="base"/><child link="b"/><limit lower="0" upper="1"/></joint>
    <joint name="t" type="fixed"><parent link="a"/><child link="tip"/></joint></robot>"""
    (tmp_path / "r.urdf").write_text(urdf)
    (tmp_path / "errors.toml").write_text("""
[machine]
name = "r"
urdf = "r.urdf"
tool_frame = "tip"
workpiece_frame = "base"
[axes.X]
joint = "j1"
[axes.W]
joint = "j2"
""")
    with pytest.raises(vp.SpecError, match=r"axis W \(joint 'j2'\) does not lie between the workpiece"):
        vp.load_machine(tmp_path)


def test_sign_minus_one_with_a_physical_joint_axis_equals_vmc500(vmc500_copy, machines):
    """A table joint written along +x with negative limits and sign = -1 is the same machine."""
    urdf = vmc500_copy / "vmc500.urdf"
    text = urdf.read_text()
    text = text.replace('<axis xyz="-1 0 0"/>\n    <limit lower="0" upper="0.5"',
                        '<axis xyz="1 0 0"/>\n    <limit lower="-0.5" upper="0"')
    urdf.write_text(text)
    edit(vmc500_copy, 'joint = "x_axis"', 'joint = "x_axis"\nsign = -1')
    m = vp.load_machine(vmc500_copy)
    ref = machines["vmc500"]
    np.testing.assert_allclose(m.travel, ref.travel)
    q = random_q(ref, 50, seed=40)
    np.testing.assert_allclose(m.volumetric_error(q), ref.volumetric_error(q), atol=1e-16)


def test_spec_units_convert_to_si(machines):
    m = machines["vmc500"]
    theta = dict(zip(m.parameter_names, m.theta))
    assert theta["EC0Y.c0"] == pytest.approx(4.0 * np.pi / 180 / 3600, rel=1e-15)
    assert theta["EXX.n10"] == pytest.approx(9.0e-6, rel=1e-15)
    # monomial over position in mm: 0.012 um/mm = 0.012 m/m * 1e-3; -1.5e-5 um/mm^2 = -15 um/m^2
    assert theta["EZZ.c1"] == pytest.approx(0.012e-6 / 1e-3, rel=1e-15)
    assert theta["EZZ.c2"] == pytest.approx(-1.5e-5 * 1e-6 / 1e-6, rel=1e-15)


def test_unknown_machine_name_lists_the_bundled_ones():
    with pytest.raises(vp.SpecError, match=r"'vmc999' is neither a bundled machine \(cgm4000, gear_roller"):
        vp.load_machine("vmc999")


@pytest.mark.parametrize("typo, meant", [("vmc50", "vmc500"), ("cgm400", "cgm4000"), ("gear_rolle", "gear_roller"),
                                         ("lathe_2axes", "lathe_2axis")])
def test_a_misspelt_machine_name_is_suggested(typo, meant):
    with pytest.raises(vp.SpecError, match=rf"; did you mean {meant}\?$"):
        vp.load_machine(typo)


@pytest.mark.parametrize("name", ["vmc999", "robot", "x"])
def test_a_name_like_none_gets_no_suggestion(name):
    with pytest.raises(vp.SpecError) as err:
        vp.load_machine(name)
    assert "did you mean" not in str(err.value)


def test_every_bundled_machine_is_listed():
    assert set(vp.bundled_machines()) == {"vmc500", "vmc700", "lathe_2axis", "cgm4000",
                                         "gear_roller", "ur5"}


def test_bundled_error_counts(machines):
    counts = {name: len(m.components) for name, m in machines.items()}
    assert counts == {"vmc500": 21, "vmc700": 21, "lathe_2axis": 24, "cgm4000": 37,
                      "gear_roller": 24, "ur5": 36}
    assert all(len(m.error_joints) % 6 == 0 for m in machines.values())
    assert len(machines["vmc500"].error_joints) == 6 * 3 + 6 * 2  # 3 axes + bases of Y and Z


def test_several_terms_per_component_add_up(vmc500_copy, machines):
    edit(vmc500_copy, '''[errors.EXY]
kind = "legendre"
coefficients_um = [0.0, 0.0, 1.1, 0.3]''', '''[errors.EXY]
terms = [
  { kind = "legendre", coefficients_um = [0.0, 0.0, 1.1, 0.3] },
  { kind = "constant", prefix = "offset", value_um = 2.0 },
]''')
    m = vp.load_machine(vmc500_copy)
    assert "EXY.offset.c0" in m.parameter_names and "EXY.c3" in m.parameter_names
    q = random_q(m, 20, seed=41)
    diff = m.volumetric_error(q) - machines["vmc500"].volumetric_error(q)
    np.testing.assert_allclose(diff[:, 0], 2e-6, atol=1e-16)


def test_clashing_term_names_need_a_prefix(vmc500_copy):
    edit(vmc500_copy, '''[errors.EXY]
kind = "legendre"
coefficients_um = [0.0, 0.0, 1.1, 0.3]''', '''[errors.EXY]
terms = [
  { kind = "legendre", coefficients_um = [0.0, 0.0, 1.1, 0.3] },
  { kind = "constant", value_um = 2.0 },
]''')
    with pytest.raises(vp.SpecError, match=r"errors\.EXY: coefficient names \['EXY\.c0'\] repeat"):
        vp.load_machine(vmc500_copy)


# ---------------------------------------------------------------- the documented examples load

DOC = Path(__file__).resolve().parents[2] / "docs" / "spec-format.md"


def _toml_blocks() -> list[str]:
    return re.findall(r"^```toml\n(.*?)^```", DOC.read_text(), flags=re.DOTALL | re.MULTILINE)


def _without_components(text: str, names) -> str:
    """The spec text with the tables [errors.<name>] removed (up to the next table header)."""
    out, skipping = [], False
    for line in text.splitlines(keepends=True):
        if line.startswith("["):
            skipping = any(line.startswith(f"[errors.{n}]") for n in names)
        if not skipping:
            out.append(line)
    return "".join(out)


def test_every_toml_example_of_the_spec_format_is_accepted(tmp_path):
    """The full example loads as it is (beside vmc500's URDF, which it names); every fragment
    loads in its place (its components replacing the full example's), and its terms are there."""
    blocks = _toml_blocks()
    assert len(blocks) >= 2
    full = [b for b in blocks if "[machine]" in b]
    assert len(full) == 1
    shutil.copy(machines_dir() / "vmc500" / "vmc500.urdf", tmp_path / "vmc500.urdf")
    spec = tmp_path / "errors.toml"
    spec.write_text(full[0])
    base = vp.load_machine(spec)
    assert base.name == "vmc500" and "EZZ.c2" in base.parameter_names
    for block in blocks:
        if block is full[0]:
            continue
        names = list(tomllib.loads(block)["errors"])
        spec.write_text(_without_components(full[0], names) + "\n" + block)
        m = vp.load_machine(spec)
        for name in names:
            assert any(p.startswith(f"{name}.") for p in m.parameter_names), name


# ---------------------------------------------------------------- bad files, bad values (issue 22)

def test_a_spec_that_is_not_utf8_names_the_line_column_and_byte(vmc500_copy):
    spec = vmc500_copy / "errors.toml"
    text = spec.read_text().replace('description = "VMC-500', 'description = "VMC-500 \u00e9', 1)
    spec.write_bytes(text.encode("latin-1"))
    line = next(i for i, l in enumerate(text.splitlines(), 1) if "\u00e9" in l)
    column = text.splitlines()[line - 1].index("\u00e9") + 1
    with pytest.raises(vp.SpecError, match=rf"errors\.toml:{line}:{column}: not UTF-8 text \(byte 0xe9 at "
                                          r"offset \d+\); save the spec as UTF-8"):
        vp.load_machine(vmc500_copy)


def test_byte_order_mark_and_crlf_line_ends_are_read(vmc500_copy, machines):
    spec = vmc500_copy / "errors.toml"
    spec.write_bytes(b"\xef\xbb\xbf" + spec.read_bytes().replace(b"\n", b"\r\n"))
    np.testing.assert_array_equal(vp.load_machine(vmc500_copy).theta, machines["vmc500"].theta)


def test_a_spec_that_is_not_a_regular_file_is_refused(tmp_path):
    fifo = tmp_path / "errors.toml"
    os.mkfifo(fifo)              # reading it would wait for a writer forever
    with pytest.raises(vp.SpecError, match=r"errors\.toml: not a regular file"):
        read_toml(fifo)


def test_a_spec_larger_than_the_memory_allows_is_refused_before_reading(vmc500_copy, monkeypatch):
    monkeypatch.setattr(safeio, "available_memory", lambda: 10_000)
    with pytest.raises(vp.SpecError, match=r"errors\.toml: reading this spec of [\d,]+ bytes needs about .* "
                                          "more than this machine can spare"):
        vp.load_machine(vmc500_copy)


def test_a_key_given_twice_is_invalid_toml_naming_its_line(vmc500_copy):
    edit(vmc500_copy, "value_arcsec = 4.0", "value_arcsec = 4.0\nvalue_arcsec = 5.0")
    with pytest.raises(vp.SpecError, match=r"invalid TOML: Cannot overwrite a value \(at line \d+, column \d+\)"):
        vp.load_machine(vmc500_copy)


@pytest.mark.parametrize("old, new, match", [
    ("value_arcsec = 4.0", 'value_arcsec = "4.0"',
     r"errors\.EC0Y\.value_arcsec: expected a number, got a string '4\.0' \(write it without quotes\)"),
    ("value_arcsec = 4.0", "value_arcsec = true", r"errors\.EC0Y\.value_arcsec: expected a number, got a boolean True"),
    ("coefficients_um = [0.0, 0.0, 1.5, -0.4]", "coefficients_um = [0.0, true, 1.5, -0.4]",
     r"errors\.EYX\.coefficients_um: expected a number, got a boolean True"),
    ("coefficients_um = [0.0, 0.0, 1.5, -0.4]", 'coefficients_um = [0.0, "500", 1.5, -0.4]',
     r"errors\.EYX\.coefficients_um: expected a number, got a string '500'"),
    ("reference_point_mm = [250.0, 200.0, 350.0]", 'reference_point_mm = ["250", 200.0, 350.0]',
     r"axes\.X\.reference_point_mm: expected a number, got a string"),
    ('joint = "x_axis"', 'joint = "x_axis"\nsign = true', r"axes\.X\.sign: must be 1 or -1, got True"),
    ("format = 1", "format = true", r"format True is not supported"),
    ("value_arcsec = 4.0", "value_arcsec = [4.0]", r"errors\.EC0Y\.value_arcsec: a constant takes one number"),
    ("value_arcsec = 4.0", "value_arcsec = nan", r"errors\.EC0Y\.value_arcsec: values must be finite"),
])
def test_strings_and_booleans_where_numbers_belong_are_refused(vmc500_copy, old, new, match):
    edit(vmc500_copy, old, new)
    with pytest.raises(vp.SpecError, match=match):
        vp.load_machine(vmc500_copy)


@pytest.mark.parametrize("old, new, match", [
    ('joint = "x_axis"', 'joint = ["x_axis"]', r"axes\.X\.joint: expected a string \(in quotes\), got \['x_axis'\]"),
    ('tool_frame = "tool"', "tool_frame = 5", r"machine\.tool_frame: expected a string"),
    ('name = "vmc500"', "name = 500", r"machine\.name: expected a string"),
    ('interpolation = "cubic"', "interpolation = 3", r"errors\.EXX\.interpolation: expected a string"),
    ('position_unit = "mm"', 'position_unit = ["mm"]', r"errors\.EZZ\.position_unit: expected a string"),
    ('kind = "legendre"\ncoefficients_um = [0.0, 0.0, 1.5, -0.4]',
     'kind = "legendre"\nprefix = 5\ncoefficients_um = [0.0, 0.0, 1.5, -0.4]', r"errors\.EYX\.prefix: expected a string"),
    ("format = 1", "format = 1\nbodies = 5", r"'bodies' must be a table"),
    ("format = 1", "format = 1\nprovenance = 5", r"'provenance' must be a table"),
])
def test_numbers_and_lists_where_strings_or_tables_belong_are_refused(vmc500_copy, old, new, match):
    edit(vmc500_copy, old, new)
    with pytest.raises(vp.SpecError, match=match):
        vp.load_machine(vmc500_copy)


@pytest.mark.parametrize("old, new, match", [
    # one value under two keys: with and without its unit, or in two units
    ("coefficients_um = [0.0, 0.0, 1.5, -0.4]", "coefficients_um = [0.0, 0.0, 1.5, -0.4]\ncoefficients = [1.0]",
     r"errors\.EYX: both coefficients_um and coefficients given; give the value once, with its unit"),
    ("coefficients_um = [0.0, 0.0, 1.5, -0.4]", "coefficients_um = [0.0, 0.0, 1.5, -0.4]\ncoefficients_nm = [1.0]",
     r"errors\.EYX: both coefficients_um and coefficients_nm given"),
    ("reference_point_mm = [250.0, 200.0, 350.0]",
     "reference_point_mm = [250.0, 200.0, 350.0]\nreference_point_m = [0.25, 0.2, 0.35]",
     r"axes\.X: both reference_point_mm and reference_point_m given"),
    # a unit suffix the key does not take
    ("value_arcsec = 4.0", "value_arcsec_per_K = 4.0",
     r"errors\.EC0Y\.value_arcsec_per_K: unit 'arcsec_per_K' does not fit; write it as e\.g\. value_arcsec"),
    ("coefficients_um = [0.0, 0.0, 1.5, -0.4]", "coefficients_um_per_N = [0.0, 0.0, 1.5, -0.4]",
     r"errors\.EYX\.coefficients_um_per_N: unit 'um_per_N' does not fit"),
    ("reference_point_mm = [250.0, 200.0, 350.0]", "reference_point_mm_per_K = [250.0, 200.0, 350.0]",
     r"axes\.X\.reference_point_mm_per_K: unknown unit 'mm_per_K'"),
    ("positions_mm = [0, 100, 200, 300, 400]", "positions_deg = [0, 100, 200, 300, 400]",
     r"errors\.EYY\.positions_deg: unit 'deg' is an angle unit but this value is a length"),
    # keys the term would not use
    ('interpolation = "linear"', 'interpolation = "linear"\nboundary = "natural"',
     r"errors\.EYY\.boundary: only a cubic table has a boundary condition"),
    ('kind = "legendre"\ncoefficients_um = [0.0, 0.0, 1.5, -0.4]',
     'kind = "legendre"\nposition_unit = "mm"\ncoefficients_um = [0.0, 0.0, 1.5, -0.4]',
     r"errors\.EYX\.position_unit: only a monomial over = 'position' has one"),
])
def test_values_given_twice_or_with_a_suffix_the_key_does_not_take(vmc500_copy, old, new, match):
    edit(vmc500_copy, old, new)
    with pytest.raises(vp.SpecError, match=match):
        vp.load_machine(vmc500_copy)


@pytest.mark.parametrize("old, new, match", [
    ("value_arcsec = 4.0", "value_arcsec = 1e300",
     r"errors\.EC0Y\.value_arcsec: 1e\+300 arcsec is implausible: an angular deviation lies within \+-206265 arcsec"),
    ("values_um = [0.0, 1.2", "values_um = [2e6, 1.2",
     r"errors\.EXX\.values_um: 2000000 um is implausible: a deviation lies within \+-1e\+06 um"),
    ("positions_mm = [0, 100, 200, 300, 400]", "extrapolate = true\npositions_mm = [0, 100, 200, 300, 4e9]",
     r"errors\.EYY\.positions_mm: 4000000000 mm is implausible: a position lies within \+-1e\+06 mm"),
    ("reference_point_mm = [250.0, 200.0, 350.0]", "reference_point_mm = [250.0, 200.0, 1e300]",
     r"axes\.X\.reference_point_mm: 1e\+300 mm is implausible"),
])
def test_implausible_spec_values_are_refused(vmc500_copy, old, new, match):
    edit(vmc500_copy, old, new)
    with pytest.raises(vp.SpecError, match=match):
        vp.load_machine(vmc500_copy)


def test_an_error_just_below_the_limit_is_read(vmc500_copy):
    edit(vmc500_copy, "values_um = [0.0, 1.2", "values_um = [-999999.0, 1.2")
    assert vp.load_machine(vmc500_copy).theta[0] == pytest.approx(-0.999999)


def test_an_empty_term_list_is_refused(vmc500_copy):
    edit(vmc500_copy, 'kind = "legendre"\ncoefficients_um = [0.0, 0.0, 1.5, -0.4]', "terms = []")
    with pytest.raises(vp.SpecError, match=r"errors\.EYX\.terms: the list is empty"):
        vp.load_machine(vmc500_copy)


def test_non_increasing_positions_are_named(vmc500_copy):
    edit(vmc500_copy, "positions_mm = [0, 100, 200, 300, 400]", "positions_mm = [0, 100, 100, 300, 400]")
    with pytest.raises(vp.SpecError, match=r"errors\.EYY\.positions_mm: positions must be strictly increasing, "
                                          r"got 100 then 100 mm \(entries 2 and 3\)"):
        vp.load_machine(vmc500_copy)


def test_toml_nested_beyond_the_recursion_limit_is_one_error(vmc500_copy):
    edit(vmc500_copy, "format = 1", "format = 1\ndeep = " + "[" * 5000 + "]" * 5000)
    with pytest.raises(vp.SpecError, match=r"errors\.toml: invalid TOML: arrays or tables nested too deeply"):
        vp.load_machine(vmc500_copy)


@pytest.mark.parametrize("new, match", [
    ('urdf = {package = 5, path = "x.urdf"}', r"machine\.urdf: package and path must be non-empty strings"),
    ('urdf = {package = "example-robot-data", path = ["x"]}', r"machine\.urdf: package and path must be"),
    ('urdf = {package = "example-robot-data", path = ""}', r"machine\.urdf: package and path must be"),
    ('urdf = {package = "example-robot-data", path = "5_robot.urdf"}',
     r"machine\.urdf: package 'example-robot-data' has no file '5_robot\.urdf'"),
    ('urdf = ""', r"machine\.urdf: empty path"),
])
def test_the_urdf_reference_is_checked(vmc500_copy, new, match):
    """A path suffix matched any file ending in it ('5_robot.urdf' found 'ur5_robot.urdf');
    non-strings crashed."""
    edit(vmc500_copy, 'urdf = "vmc500.urdf"', new)
    with pytest.raises(vp.SpecError, match=match):
        vp.load_machine(vmc500_copy)
