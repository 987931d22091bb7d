"""URDF reading (errors with file, line and element) and the injected URDF's round trip."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

import volerr_pin as vp
from volerr_pin.model import load_urdf, parse_urdf

from conftest import ALL_MACHINES, needs_device, random_q

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
    own = m.model.pinocchio
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
    assert text.count("<visual>") == parse_urdf(machines["vmc500"].spec.urdf.read_bytes()).to_string().count("<visual>")
    for name in ("EXX", "EYX", "ECZ", "EC0Y", "EA0Z"):
        assert f'<joint name="{name}"' in text


# --- limits, entities, mimic and endless joints (issue 22) ---------------------------------

def chain_urdf(n: int, joint_type: str = "revolute", extra: str = "") -> str:
    """A serial chain l0 - j1 - l1 - ... - jn - ln of joints about z, 1 cm apart."""
    limit = '<limit lower="-1" upper="1"/>' if joint_type in ("revolute", "prismatic") else ""
    parts = ['<?xml version="1.0"?>', '<robot name="chain">', '<link name="l0"/>']
    for i in range(1, n + 1):
        parts.append(f'<link name="l{i}"/>')
        parts.append(f'<joint name="j{i}" type="{joint_type}"><parent link="l{i - 1}"/><child link="l{i}"/>'
                     f'<origin xyz="0 0 0.01"/><axis xyz="0 0 1"/>{limit}</joint>')
    parts += [extra, "</robot>"]
    return "\n".join(parts)


def test_too_many_joints_are_refused_before_parsing(tmp_path):
    """A 2,000-joint chain crashed Pinocchio's URDF parser (exit 139): it is refused with the
    file, the count and the limit before anything else reads it."""
    path = tmp_path / "long.urdf"
    path.write_text(chain_urdf(2000))
    with pytest.raises(vp.URDFError, match=r"long\.urdf: 2,000 joints, more than the 1,000 a URDF may have"):
        vp.load_machine(path, tool_frame="l2000", workpiece_frame="l0")


def test_a_model_with_too_many_error_joints_is_refused_before_pinocchio(tmp_path, monkeypatch):
    """300 axes get 1,800 error joints: refused before Pinocchio builds (it gave a MemoryError)."""
    import pinocchio

    def never(*args, **kwargs):
        raise AssertionError("Pinocchio must not be reached")

    monkeypatch.setattr(pinocchio, "buildModelFromXML", never)
    path = tmp_path / "c300.urdf"
    path.write_text(chain_urdf(300))
    with pytest.raises(vp.URDFError, match=r"c300\.urdf: 2,100 joints once the error joints are added "
                                           r"\(300 in the file, 1,800 for 300 error sites\), more than the 2,000"):
        vp.load_machine(path, tool_frame="l300", workpiece_frame="l0")


def test_a_hundred_axis_chain_loads_and_is_right(tmp_path):
    """700 joints with the error joints: Pinocchio's Data of that chain would take tens of GB
    (cubic in the joints), so the chain is built without one. Closed form: a translation error
    of joint 50 in its fixed frame is turned by the 49 joints before it (all about z)."""
    path = tmp_path / "c100.urdf"
    path.write_text(chain_urdf(100))
    m = vp.load_machine(path, tool_frame="l100", workpiece_frame="l0")
    assert m.model.pinocchio.njoints == 701
    q = np.random.default_rng(4).uniform(-1, 1, (5, 100))
    theta = np.zeros(len(m.parameter_names))
    theta[m.parameter_names.index("EX_j50.c0")] = 1e-6
    theta[m.parameter_names.index("EZ_j70.c0")] = 2e-6
    turn = q[:, :49].sum(axis=1)
    expected = np.c_[1e-6 * np.cos(turn), 1e-6 * np.sin(turn), np.full(5, 2e-6)]
    np.testing.assert_allclose(m.volumetric_error(q, theta)[:, :3], expected, rtol=0, atol=1e-15)


def test_oversize_urdf_is_refused_before_reading(tmp_path):
    path = tmp_path / "big.urdf"
    with open(path, "wb") as fh:
        fh.truncate(20_000_000)  # sparse: no disk used
    with pytest.raises(vp.URDFError, match=r"big\.urdf: 20,000,000 bytes, more than the 16,000,000"):
        load_urdf(path)


@pytest.mark.parametrize("kind", ["fifo", "folder", pytest.param("device", marks=needs_device("/dev/zero"))])
def test_a_urdf_that_is_not_a_regular_file_is_refused(tmp_path, kind):
    import os

    if kind == "fifo":
        path = tmp_path / "m.urdf"
        os.mkfifo(path)  # nobody writes: reading it would hang
    elif kind == "folder":
        path = tmp_path / "m.urdf"
        path.mkdir()
    else:
        path = "/dev/zero"
    with pytest.raises(vp.URDFError, match="(not a regular file|cannot read URDF)"):
        load_urdf(path)


def test_xml_entities_are_refused():
    text = GOOD.replace('<?xml version="1.0"?>', '<?xml version="1.0"?>\n<!DOCTYPE robot [ <!ENTITY '
                        'secret SYSTEM "file:///etc/hostname"> ]>').replace('<link name="tip"/>',
                                                                            '<link name="tip">&secret;</link>')
    with pytest.raises(vp.URDFError, match=r"m\.urdf: <!DOCTYPE>: XML entity declarations are not allowed "
                                           r"in a URDF \(<!ENTITY secret>\)"):
        parse_urdf(text, "m.urdf")


MIMIC = GOOD.replace('<link name="tip"/>', '<link name="tip"/><link name="slide2"/>').replace(
    '''  <joint name="tip_mount" type="fixed">
    <parent link="carriage"/><child link="tip"/>''', '''  <joint name="x2" type="prismatic">
    <parent link="carriage"/><child link="slide2"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.3"/>
    <mimic joint="x" multiplier="1"/>
  </joint>
  <joint name="tip_mount" type="fixed">
    <parent link="slide2"/><child link="tip"/>''')


def test_mimic_joint_between_the_frames_is_refused(tmp_path):
    """A <mimic> joint was taken as a free axis: refused with the file and its line."""
    path = tmp_path / "mimic.urdf"
    path.write_text(MIMIC)
    assert load_urdf(path).joints["x2"].mimic == "x"
    with pytest.raises(vp.URDFError, match=r"mimic\.urdf:11: <joint name='x2'> follows 'x' \(<mimic>\) and "
                                           r"lies between the workpiece frame 'base' and the tool frame 'tip'"):
        vp.load_machine(path, tool_frame="tip", workpiece_frame="base")


def test_mimic_joint_elsewhere_is_harmless(tmp_path):
    """A gripper's mimic finger beside the chain does not move the tool: the machine loads."""
    text = GOOD.replace('<link name="tip"/>', '<link name="tip"/><link name="finger"/>').replace(
        "</robot>", '''<joint name="f" type="prismatic"><parent link="carriage"/><child link="finger"/>
        <limit lower="0" upper="0.01"/><mimic joint="x"/></joint></robot>''')
    path = tmp_path / "gripper.urdf"
    path.write_text(text)
    assert vp.load_machine(path, tool_frame="tip", workpiece_frame="base").axes == ("x",)


def test_mimic_of_an_unknown_joint_is_refused():
    with pytest.raises(vp.URDFError, match=r"m\.urdf:14: <mimic>: joint 'x2' mimics 'nope', which is not "
                                           "another joint"):
        parse_urdf(MIMIC.replace('<mimic joint="x"', '<mimic joint="nope"'), "m.urdf")


ENDLESS = GOOD.replace('<link name="tip"/>', '<link name="tip"/><link name="table"/>').replace(
    "</robot>", '''<joint name="c" type="continuous"><parent link="base"/><child link="table"/>
    <axis xyz="0 0 1"/></joint></robot>''')


def test_continuous_joint_travels_one_turn(tmp_path):
    """An endless axis has the travel of one turn, -180 to 180 deg (it was -inf..inf, and the
    field's sweep over it gave NaN positions)."""
    path = tmp_path / "endless.urdf"
    path.write_text(ENDLESS)
    assert load_urdf(path).joints["c"].lower == -np.pi and load_urdf(path).joints["c"].upper == np.pi
    m = vp.load_machine(path, tool_frame="tip", workpiece_frame="table")
    assert m.axes == ("c", "x")
    np.testing.assert_array_equal(m.travel, [[-np.pi, np.pi], [0.0, 0.3]])
    np.testing.assert_array_equal(m.mid_travel, [0.0, 0.15])
    with pytest.raises(vp.InputError, match=r"q\[0, 0\] = 4 rad is outside the travel of axis c \[-3\.14159, "
                                            r"3\.14159\] rad"):
        m.volumetric_error([4.0, 0.1])
    assert np.all(np.isfinite(m.volumetric_error([4.0, 0.1], extrapolate=True)))


def test_continuous_axis_with_terms_over_its_turn(tmp_path):
    """A polynomial over an endless axis' travel is over one turn (u = angle / pi)."""
    (tmp_path / "endless.urdf").write_text(ENDLESS)
    (tmp_path / "errors.toml").write_text('''format = 1
[machine]
name = "endless"
urdf = "endless.urdf"
tool_frame = "tip"
workpiece_frame = "table"
[axes.C]
joint = "c"
[axes.X]
joint = "x"
[errors.EXC]
kind = "legendre"
coefficients_um = [0.0, 5.0]
''')
    m = vp.load_machine(tmp_path)
    q = np.array([[np.pi / 2, 0.1], [-np.pi, 0.2]])
    np.testing.assert_allclose(m.component_values(q)[:, 0], [2.5e-6, -5e-6], rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(m.volumetric_error(q)[:, :3], axis=1), [2.5e-6, 5e-6], rtol=1e-9)
