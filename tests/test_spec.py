"""Error specs: bad input is reported with the file and the key; units convert once."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.machine import machines_dir

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
