"""Circle-point analysis on targets turned about known axis lines."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import volerr_pin as vp
from volerr_pin.applications.axisfit import axis_relation, fit_axis, fit_circle

AXIS_POINT = np.array([1.2, -0.4, 0.3])
AXIS_DIR = np.array([0.3, -0.2, 0.93]) / np.linalg.norm([0.3, -0.2, 0.93])
TARGETS = [np.array([1.5, -0.1, 0.5]), np.array([1.0, 0.1, 0.2]), np.array([1.4, -0.7, 0.1])]


def turned(q, scale=1.0, noise=0.0, seed=0, point=AXIS_POINT, direction=AXIS_DIR):
    rng = np.random.default_rng(seed)
    out = []
    for p in TARGETS:
        R = Rotation.from_rotvec(np.outer(q * scale, direction)).as_matrix()
        out.append(np.einsum("nij,j->ni", R, p - point) + point + rng.normal(0, noise, (len(q), 3)))
    return out


def test_circle_of_exact_points():
    q = np.radians([-30, -10, 5, 20, 40])
    circle = fit_circle(turned(q)[0])
    offset = TARGETS[0] - AXIS_POINT
    radius = np.linalg.norm(offset - (offset @ AXIS_DIR) * AXIS_DIR)
    assert circle.radius == pytest.approx(radius, abs=1e-12)
    assert circle.rms < 1e-12 and abs(abs(circle.normal @ AXIS_DIR) - 1) < 1e-12
    centre = AXIS_POINT + (offset @ AXIS_DIR) * AXIS_DIR
    np.testing.assert_allclose(circle.centre, centre, atol=1e-12)


def test_axis_line_orientation_and_angles():
    q = np.radians([-360, -216, -72, 72, 216, 360])      # whole turns, as a wrist is swept
    axis = fit_axis(turned(q), q)
    np.testing.assert_allclose(axis.direction, AXIS_DIR, atol=1e-12)   # right-handed for +q
    gap = axis.point - AXIS_POINT
    assert np.linalg.norm(gap - (gap @ AXIS_DIR) * AXIS_DIR) < 1e-12   # on the line
    assert np.abs(axis.angle_residual).max() < 1e-12 and axis.angle_scale == pytest.approx(1.0, abs=1e-12)
    flipped = fit_axis(turned(-q), q)                                  # turning the other way
    np.testing.assert_allclose(flipped.direction, -AXIS_DIR, atol=1e-12)


def test_a_joint_scale_error_shows_in_the_angles():
    q = np.radians([-30, -10, 5, 20, 40, 55])
    axis = fit_axis(turned(q, scale=1.002), q)
    assert axis.angle_scale == pytest.approx(1.002, abs=1e-9)
    np.testing.assert_allclose(axis.angle_residual, 0.002 * (q[1:] - q[0]), atol=1e-12)


def test_noise_gives_the_noise_back():
    q = np.radians(np.linspace(-60, 60, 25))
    axis = fit_axis(turned(q, noise=30e-6, seed=1), q)
    # 3D distance of isotropic noise from a fitted circle: about sqrt(2) x 30 um
    assert axis.rms == pytest.approx(math.sqrt(2) * 30e-6, rel=0.25)
    assert np.degrees(math.acos(min(1.0, axis.direction @ AXIS_DIR))) < 0.01


def test_relation_of_two_axes():
    """A second axis at right angles to the first, 0.25 along their common normal."""
    q = np.radians([-30, -10, 5, 20, 40])
    d2 = np.cross(AXIS_DIR, [1.0, 0.0, 0.0])
    d2 /= np.linalg.norm(d2)
    normal = np.cross(AXIS_DIR, d2)
    a = fit_axis(turned(q), q)
    b = fit_axis(turned(q, point=AXIS_POINT + 0.25 * normal + 0.3 * AXIS_DIR, direction=d2), q)
    assert axis_relation(a, b) == pytest.approx({"angle": math.pi / 2, "distance": 0.25, "parallel": False}, abs=1e-12)
    parallel = fit_axis(turned(q, point=AXIS_POINT + 0.1 * normal), q)
    assert axis_relation(a, parallel) == pytest.approx({"angle": 0.0, "distance": 0.1, "parallel": True}, abs=1e-9)


UR5_BASE = np.radians([10.0, -60.0, 70.0, -40.0, 30.0, 20.0])


def ur5_axes(m, offsets):
    """The UR5's joints swept one at a time (+-40 deg about UR5_BASE), each fitted from the
    targets at ``offsets`` on its tool."""
    axes = []
    for j in range(6):
        q = np.tile(UR5_BASE, (7, 1))
        q[:, j] += np.radians(np.linspace(-40, 40, 7))
        R, p = m.tool_poses(q, nominal=True)
        axes.append(fit_axis([p + np.einsum("nij,j->ni", R, o) for o in offsets], q[:, j]))
    return axes


def test_bundled_robot_axes_from_simulated_sweeps(machines):
    """The UR5 turning one joint at a time: the fitted axes are the model's joint axes, and
    consecutive axes meet at the model's angles (the UR5's 90 deg and parallel joints)."""
    axes = ur5_axes(machines["ur5"], np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.05]]))
    assert all(a.rms < 1e-12 for a in axes)
    angles = [math.degrees(axis_relation(a, b)["angle"]) for a, b in zip(axes[:-1], axes[1:])]
    np.testing.assert_allclose(angles, [90, 0, 0, 90, 90], atol=1e-7)


def test_a_robot_rebuilt_from_its_measured_axes(machines, tmp_path):
    """UR5 sweeps -> axes -> URDF: the rebuilt arm puts the targets where the UR5 does, at any
    joint values (relative to the reference configuration of the sweeps)."""
    from volerr_pin.applications.axisfit import axes_to_urdf

    m = machines["ur5"]
    offsets = np.array([[0.05, 0.02, 0.03], [0.1, 0.0, 0.0], [0.0, 0.1, 0.05]])
    base = UR5_BASE
    axes = ur5_axes(m, offsets)
    text, tool = axes_to_urdf(axes, [f"J{k + 1}" for k in range(6)], [(-6.0, 6.0)] * 6)
    (tmp_path / "rebuilt.urdf").write_text(text)
    rebuilt = vp.load_machine(tmp_path / "rebuilt.urdf", tool_frame="tool0", workpiece_frame="world")
    R0, p0 = m.tool_poses(base[None, :], nominal=True)
    targets_ref = p0[0] + offsets @ R0[0].T                      # targets at the reference
    in_tool = (targets_ref - tool[:3, 3]) @ tool[:3, :3]          # ... in the rebuilt tool frame
    rng = np.random.default_rng(2)
    q = base + rng.uniform(-0.5, 0.5, (20, 6))
    R, p = m.tool_poses(q, nominal=True)
    Rb, pb = rebuilt.tool_poses(q - base, nominal=True)
    for o, o_b in zip(offsets, in_tool):
        np.testing.assert_allclose(pb + np.einsum("nij,j->ni", Rb, o_b), p + np.einsum("nij,j->ni", R, o),
                                   atol=1e-9)


def test_axes_to_urdf_refuses_mismatched_lists():
    from volerr_pin.applications.axisfit import Axis, axes_to_urdf
    from volerr_pin.base import InputError

    axis = Axis(point=np.zeros(3), direction=np.array([0.0, 0.0, 1.0]), circles=(), angle_residual=np.zeros(0),
                angle_scale=1.0)
    with pytest.raises(InputError, match="one entry per joint; got 1, 2 and 1"):
        axes_to_urdf([axis], ["j1", "j2"], [(-1.0, 1.0)])
