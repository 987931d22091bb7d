"""URDF reading (errors with file, line and element) and the injected URDF's round trip."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

import volerr_pin as vp
from volerr_pin.urdf import parse_urdf

from conftest import ALL_MACHINES, random_q

GOOD = """<?xml version="1.0"?>
<robot name="slide">
  <link name="base"/>
  <link name="carriage"/>
  <link name="tip"/>
  <joint name="x" type="prismatic">
    <parent link="base"/><child link="carriage"/>
    <axis xyz="1 0 0"/>
    <limit lower="0" upper="0.3"/>
  </joint>
  <joint name="tip_mount" type="fixed">
    <parent link="carriage"/><child link="tip"/>
    <origin xyz="0 0.1 -0.05"/>
  </joint>
</robot>
"""


def test_malformed_xml_names_line_and_column():
    with pytest.raises(vp.URDFError, match=r"m\.urdf:15:9: malformed XML: .*tag mismatch: link line 4"):
        parse_urdf(GOOD.replace('<link name="carriage"/>', '<link name="carriage">'), "m.urdf")


def test_missing_limit_names_element_and_line():
    text = GOOD.replace('<limit lower="0" upper="0.3"/>', "")
    with pytest.raises(vp.URDFError, match=r"m\.urdf:6: <joint name='x'>: a prismatic joint needs <limit"):
        parse_urdf(text, "m.urdf")


def test_bad_number_names_attribute():
    text = GOOD.replace('upper="0.3"', 'upper="0.3mm"')
    with pytest.raises(vp.URDFError, match=r"m\.urdf:9: <limit>: attribute upper='0\.3mm'"):
        parse_urdf(text, "m.urdf")


def test_unknown_link_is_reported():
    text = GOOD.replace('<child link="tip"/>', '<child link="tipp"/>')
    with pytest.raises(vp.URDFError, match=r"m\.urdf:12: <child>: link 'tipp' is not defined"):
        parse_urdf(text, "m.urdf")


def test_two_roots_are_reported():
    text = GOOD.replace('<link name="tip"/>', '<link name="tip"/><link name="lost"/>')
    with pytest.raises(vp.URDFError, match="one tree"):
        parse_urdf(text, "m.urdf")


def test_bare_urdf_loads_with_frames(tmp_path):
    path = tmp_path / "slide.urdf"
    path.write_text(GOOD)
    m = vp.load_machine(path, tool_frame="tip", workpiece_frame="base")
    assert m.axes == ("x",)
    assert len(m.parameter_names) == 6  # six constant error terms
    assert m.parameter_names[0] == "EX_x.c0"
    theta = np.zeros(6)
    theta[m.parameter_names.index("EB_x.c0")] = 1e-4  # pitch: tool 0.05 m below the carriage
    e = m.volumetric_error([[0.1]], theta)
    np.testing.assert_allclose(e[0, :3], [-0.05 * np.sin(1e-4), 0, 0.05 * (1 - np.cos(1e-4))], atol=1e-18)


def test_bare_urdf_needs_both_frames(tmp_path):
    path = tmp_path / "slide.urdf"
    path.write_text(GOOD)
    with pytest.raises(vp.SpecError, match="tool_frame= and workpiece_frame="):
        vp.load_machine(path, tool_frame="tip")
    with pytest.raises(vp.SpecError, match="workpiece_frame 'nowhere' is not a link"):
        vp.load_machine(path, tool_frame="tip", workpiece_frame="nowhere")


def test_missing_urdf_file_is_named(tmp_path):
    with pytest.raises(vp.URDFError, match="cannot read URDF"):
        vp.load_machine(tmp_path / "none.urdf", tool_frame="a", workpiece_frame="b")


@pytest.mark.parametrize("name", ALL_MACHINES)
def test_injected_urdf_round_trips_through_yourdfpy_and_pinocchio(machines, tmp_path, name):
    """The written URDF (volerr urdf) gives the same kinematics in yourdfpy and Pinocchio."""
    m = machines[name]
    path = tmp_path / f"{name}_errors.urdf"
    path.write_text(m.injected_urdf())
    model = pin.buildModelFromUrdf(str(path))
    robot = yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False,
                               build_collision_scene_graph=False, load_collision_meshes=False)
    assert robot.validate()
    theta = m.theta * 50  # large enough that a wrong sign or order would show
    q = random_q(m, 8, seed=30)
    R, p = m.tool_poses(q, theta)
    values = m.joint_values(q, theta)
    own = m.model
    config = m.pinocchio_configuration(q, theta)
    for i in range(len(q)):
        # Pinocchio from the written file: map joint values by name
        qpin = pin.neutral(model)
        for j in range(1, own.njoints):
            jid = model.getJointId(own.names[j])
            qpin[model.idx_qs[jid]:model.idx_qs[jid] + model.nqs[jid]] = \
                config[i, own.idx_qs[j]:own.idx_qs[j] + own.nqs[j]]
        data = model.createData()
        pin.framesForwardKinematics(model, data, qpin)
        wMt = data.oMf[model.getFrameId(m.workpiece_frame)].actInv(data.oMf[model.getFrameId(m.tool_frame)])
        np.testing.assert_allclose(wMt.translation, p[i], atol=1e-12)
        np.testing.assert_allclose(wMt.rotation, R[i], atol=1e-12)
        # yourdfpy: one value per actuated joint, by name
        cfg = {own.names[j]: values[i, own.idx_vs[j]] for j in range(1, own.njoints)}
        robot.update_cfg(cfg)
        T = robot.get_transform(m.tool_frame, m.workpiece_frame)
        np.testing.assert_allclose(T[:3, 3], p[i], atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], R[i], atol=1e-12)


def test_injected_urdf_keeps_visuals_and_names_error_joints(machines):
    text = machines["vmc500"].injected_urdf()
    assert text.count("<visual>") == parse_urdf(open(machines["vmc500"].spec.urdf, "rb").read()).to_string().count("<visual>")
    for name in ("EXX", "EYX", "ECZ", "EC0Y", "EA0Z"):
        assert f'<joint name="{name}"' in text
