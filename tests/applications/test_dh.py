"""DH tables to URDF: Pinocchio's kinematics of the written URDF equal the DH matrix products."""

from __future__ import annotations

import math

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.applications.dh import DHRow, dh_to_urdf, read_dh, transform
from volerr_pin.measurements import MeasurementError


def random_table(rng, n, prismatic=()):
    rows = []
    for i in range(n):
        kind = "prismatic" if i in prismatic else "revolute"
        limits = (-0.3, 0.5) if kind == "prismatic" else (-2.5, 2.5)
        rows.append(DHRow(f"j{i + 1}", rng.uniform(-0.8, 0.8), rng.uniform(-math.pi, math.pi), rng.uniform(-0.5, 0.5),
                          rng.uniform(-math.pi, math.pi), kind, *limits))
    return rows


@pytest.mark.parametrize("convention", ["standard", "modified"])
@pytest.mark.parametrize("prismatic", [(), (1, 4)])
def test_urdf_kinematics_equal_the_dh_product(tmp_path, convention, prismatic):
    rng = np.random.default_rng(len(prismatic) + (convention == "modified"))
    rows = random_table(rng, 6, prismatic)
    tool = np.eye(4)
    tool[:3, 3] = [0.01, -0.02, 0.15]
    path = tmp_path / "robot.urdf"
    path.write_text(dh_to_urdf(rows, convention, tool_transform=tool))
    m = vp.load_machine(path, tool_frame="tool0", workpiece_frame="base")
    assert m.axes == tuple(r.name for r in rows)
    assert m.axis_kinds == tuple("linear" if r.kind == "prismatic" else "rotary" for r in rows)
    q = np.column_stack([rng.uniform(r.lower, r.upper, 50) for r in rows])
    R, p = m.tool_poses(q, nominal=True)
    for i in range(len(q)):
        T = np.eye(4)
        for row, value in zip(rows, q[i]):
            T = T @ transform(row, value, convention)
        T = T @ tool
        np.testing.assert_allclose(R[i], T[:3, :3], atol=1e-12)
        np.testing.assert_allclose(p[i], T[:3, 3], atol=1e-12)


def test_table_file_and_cli(tmp_path, capsys):
    table = tmp_path / "arm.csv"
    table.write_text("# convention: modified\n# tool: 0, 0, 100, 0, 90, 0\n"
                     "joint,type,a_mm,alpha_deg,d_mm,theta_deg,lower,upper\n"
                     "J1,revolute,0,0,400,0,-170,170\nJ2,revolute,150,-90,0,-90,-60,75\n"
                     "J3,prismatic,600,0,0,0,0,300\n")
    rows, convention, tool = read_dh(table)
    assert convention == "modified" and [r.kind for r in rows] == ["revolute", "revolute", "prismatic"]
    assert rows[1].a == pytest.approx(0.15) and rows[1].lower == pytest.approx(math.radians(-60))
    assert rows[2].upper == pytest.approx(0.3) and tool[:3, 3] == pytest.approx([0, 0, 0.1])
    out = tmp_path / "arm.urdf"
    assert main(["dh", str(table), "-o", str(out)]) == 0
    assert "3 joints (modified DH)" in capsys.readouterr().out
    m = vp.load_machine(out, tool_frame="tool0", workpiece_frame="base")
    R, p = m.tool_poses(np.array([[0.3, -0.2, 0.1]]), nominal=True)
    T = transform(rows[0], 0.3, "modified") @ transform(rows[1], -0.2, "modified") @ transform(rows[2], 0.1, "modified") @ tool
    np.testing.assert_allclose(p[0], T[:3, 3], atol=1e-12)
    assert main(["info", str(out), "--tool-frame", "tool0", "--workpiece-frame", "base"]) == 0


@pytest.mark.parametrize("text, match", [
    ("joint,a_mm,alpha_deg,d_mm\nJ1,0,0,0\n", r"dh.csv:1: a DH table needs the columns .* \(missing theta_deg\)"),
    ("joint,type,a_mm,alpha_deg,d_mm,theta_deg\nJ1,spherical,0,0,0,0\n", r"dh.csv:2:2: .*'spherical' is not revolute"),
    ("joint,type,a_mm,alpha_deg,d_mm,theta_deg\nJ1,prismatic,0,0,0,0\n", r"dh.csv:2: a prismatic joint needs lower"),
    ("joint,a_mm,alpha_deg,d_mm,theta_deg,lower,upper\nJ1,0,0,0,0,10,-10\n", r"dh.csv:2: lower must be below upper"),
    ("# convention: sideways\njoint,a_mm,alpha_deg,d_mm,theta_deg\nJ1,0,0,0,0\n", r"expected standard or modified"),
    ("# tool: 1, 2\njoint,a_mm,alpha_deg,d_mm,theta_deg\nJ1,0,0,0,0\n", r"x, y, z \(mm\) and optionally"),
])
def test_malformed_dh_tables(tmp_path, text, match):
    path = tmp_path / "dh.csv"
    path.write_text(text)
    with pytest.raises(MeasurementError, match=match):
        read_dh(path)


def test_duplicate_joint_names_are_refused(tmp_path, capsys):
    path = tmp_path / "dh.csv"
    path.write_text("joint,a_mm,alpha_deg,d_mm,theta_deg\nJ1,0,0,0,0\nJ1,100,0,0,0\n")
    assert main(["dh", str(path), "-o", str(tmp_path / "x.urdf")]) == 2
    assert "joint 'J1' is given twice" in capsys.readouterr().err


def test_unknown_convention_is_refused():
    from volerr_pin.applications.dh import DHRow, split, transform
    from volerr_pin.base import InputError

    row = DHRow(name="j1", a=0.1, alpha=0.0, d=0.0, theta=0.0)
    for function in (lambda: transform(row, 0.0, "craig"), lambda: split(row, "craig")):
        with pytest.raises(InputError, match="convention must be 'standard' or 'modified', got 'craig'"):
            function()


@pytest.mark.parametrize("names, kwargs, message, parameter", [
    ([], {}, "a DH table needs at least one joint", "rows"),
    (["j1", ""], {}, "joint 2: empty name", None),
    (["j1", "j1"], {}, "joint 'j1' is given twice", None),
    (["j1", "j2"], {"tool": "j1_link"}, "tool = 'j1_link' gives the URDF link 'j1_link', which is also the link of "
                                        "joint 'j1'", "tool"),
    (["j1", "j2"], {"tool": "base"}, "tool = 'base' gives the URDF link 'base', which is also the base frame", "tool"),
    (["j1", "j2"], {"base": "j2_link"}, "base = 'j2_link' gives the URDF link 'j2_link', which is also the link of "
                                        "joint 'j2'", "base"),
    (["j1", "tool0_fixed"], {}, "tool = 'tool0' gives the URDF joint 'tool0_fixed', which is also joint "
                                "'tool0_fixed'", "tool"),
    (["j1"], {"base": " "}, "base: empty name", "base"),
])
def test_names_that_would_make_a_broken_urdf_are_refused(names, kwargs, message, parameter):
    rows = [DHRow(n, 0.1, 0.0, 0.0, 0.0, "revolute", -1.0, 1.0) for n in names]
    with pytest.raises(vp.InputError, match=message.replace("(", r"\(")) as info:
        dh_to_urdf(rows, **kwargs)
    assert info.value.parameters == ((parameter,) if parameter else ())


def test_cli_names_the_frame_options_and_the_table(tmp_path, capsys):
    table = tmp_path / "t.csv"
    table.write_text("# tool: 0, nan, 100\njoint,a_mm,alpha_deg,d_mm,theta_deg\nJ1,1,0,0,0\n")
    assert main(["dh", str(table), "-o", str(tmp_path / "r.urdf")]) == 2
    assert "'# tool: 0, nan, 100': finite numbers expected" in capsys.readouterr().err
    table.write_text("joint,a_mm,alpha_deg,d_mm,theta_deg\nJ1,1,0,0,0\nJ1,2,0,0,0\n")
    assert main(["dh", str(table), "-o", str(tmp_path / "r.urdf")]) == 2
    assert capsys.readouterr().err.strip() == f"volerr: error: {table}: joint 'J1' is given twice"
    table.write_text("joint,a_mm,alpha_deg,d_mm,theta_deg\nJ1,1,0,0,0\n")
    assert main(["dh", str(table), "-o", str(tmp_path / "r.urdf"), "--tool-frame", "J1_link"]) == 2
    assert capsys.readouterr().err.strip() == ("volerr: error: --tool-frame = 'J1_link' gives the URDF link 'J1_link', "
                                               "which is also the link of joint 'J1'; choose another name")
    assert not (tmp_path / "r.urdf").exists()
