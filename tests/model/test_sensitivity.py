"""Sensitivities: finite differences, Pinocchio's frame Jacobians, and known physics."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import random_q

ARCSEC = np.pi / 180 / 3600


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


@pytest.mark.parametrize("name", ["vmc500", "cgm4000", "ur5", "gear_roller", "lathe_2axis"])
def test_sensitivity_equals_central_differences(machines, name):
    m = machines[name]
    theta = m.theta * 20  # errors large enough that the rotation-vector Jacobian matters
    q = random_q(m, 12, seed=50)
    S = m.sensitivity(q, theta)
    h = 1e-6
    for j in range(len(theta)):
        tp, tm = theta.copy(), theta.copy()
        tp[j] += h
        tm[j] -= h
        fd = (m.volumetric_error(q, tp) - m.volumetric_error(q, tm)) / (2 * h)
        scale = max(np.abs(fd).max(), 1e-3)
        np.testing.assert_allclose(S[:, :, j], fd, rtol=0, atol=1e-6 * scale,
                                   err_msg=m.parameter_names[j])


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_a_chosen_set_of_coefficients_in_any_order_gives_their_columns(machines, name):
    """Coefficients chosen out of order, repeated, or one: the same numbers as those columns of
    the full sensitivity, to the last bit, over more points than one block of the batch."""
    m = machines[name]
    q = random_q(m, m.model.block + 37, seed=51)
    full = m.sensitivity(q, m.theta * 20)
    P = len(m.theta)
    for cols in ([P - 1, 3, 0, P // 2], [5, 5], [P - 2], list(range(P))[::-1]):
        assert np.array_equal(m.sensitivity(q, m.theta * 20, parameters=cols), full[:, :, cols])
    assert m.sensitivity(q[:3], parameters=[]).shape == (3, 6, 0)
    assert m.sensitivity(q[0], parameters=[1, 0]).shape == (6, 2)


@pytest.mark.parametrize("name", ["vmc500", "cgm4000", "ur5", "gear_roller"])
def test_joint_jacobian_equals_pinocchio_frame_jacobians(machines, name):
    """GUIDE section 6: J = R_w^T (Jt_lin - Jw_lin + [p_t - p_w] Jw_ang); angular R_w^T (Jt - Jw)."""
    m = machines[name]
    model = m.model.pinocchio
    data = model.createData()
    q = random_q(m, 6, seed=51)
    J = m.joint_jacobian(q, m.theta * 30)
    config = m.pinocchio_configuration(q, m.theta * 30)
    T, W = model.getFrameId(m.tool_frame), model.getFrameId(m.workpiece_frame)
    for i in range(len(q)):
        pin.computeJointJacobians(model, data, config[i])
        oMt = pin.updateFramePlacement(model, data, T)
        oMw = pin.updateFramePlacement(model, data, W)
        Jt = pin.getFrameJacobian(model, data, T, pin.LOCAL_WORLD_ALIGNED)
        Jw = pin.getFrameJacobian(model, data, W, pin.LOCAL_WORLD_ALIGNED)
        Rw = oMw.rotation
        lin = Rw.T @ (Jt[:3] - Jw[:3] + skew(oMt.translation - oMw.translation) @ Jw[3:])
        ang = Rw.T @ (Jt[3:] - Jw[3:])
        np.testing.assert_allclose(J[i, :3], lin, atol=1e-12)
        np.testing.assert_allclose(J[i, 3:], ang, atol=1e-12)


@pytest.mark.parametrize("name,nominal", [("vmc500", False), ("cgm4000", False),
                                          ("cgm4000", True), ("gear_roller", False)])
def test_axis_jacobian_equals_differences_of_the_tool_pose(machines, name, nominal):
    m = machines[name]
    theta = m.theta * 20
    q = random_q(m, 10, seed=52)
    span = m.travel[:, 1] - m.travel[:, 0]
    q = np.clip(q, m.travel[:, 0] + 1e-3 * span, m.travel[:, 1] - 1e-3 * span)
    J = m.axis_jacobian(q, theta, nominal=nominal)
    R0, _ = m.tool_poses(q, theta, nominal=nominal)
    for j in range(len(m.axes)):
        h = 1e-7 * (1.0 if m.axis_kinds[j] == "linear" else 10.0)
        qp, qm = q.copy(), q.copy()
        qp[:, j] += h
        qm[:, j] -= h
        Rp, pp = m.tool_poses(qp, theta, nominal=nominal)
        Rm, pm = m.tool_poses(qm, theta, nominal=nominal)
        np.testing.assert_allclose(J[:, :3, j], (pp - pm) / (2 * h), rtol=1e-6, atol=1e-8)
        for i in range(len(q)):
            w = pin.log3(Rp[i] @ Rm[i].T) / (2 * h)
            np.testing.assert_allclose(J[i, 3:, j], w, rtol=1e-6, atol=1e-8)


def test_component_sensitivity_is_the_column_of_the_chain(machines):
    """d error / d (component value) times the values reproduces the first-order error."""
    m = machines["cgm4000"]
    q = random_q(m, 30, seed=53)
    C = m.component_sensitivity(q, np.zeros_like(m.theta))
    first = np.einsum("nrc,nc->nr", C, m.component_values(q))
    np.testing.assert_allclose(first, m.volumetric_error(q, order=1), rtol=1e-12, atol=1e-18)


def test_vmc500_exx_sensitivity_is_one_everywhere(machines):
    m = machines["vmc500"]
    q = random_q(m, 100, seed=54)
    k = m.components.index("EXX")
    C = m.component_sensitivity(q, np.zeros_like(m.theta))
    np.testing.assert_array_equal(C[:, 0, k], 1.0)
    np.testing.assert_array_equal(C[:, 1:, k], 0.0)
    # with the machine's other errors present the direction tilts by their angles (~1e-5)
    C = m.component_sensitivity(q)
    np.testing.assert_allclose(C[:, 0, k], 1.0, atol=1e-9)
    np.testing.assert_allclose(C[:, 1:3, k], 0.0, atol=1e-4)


def test_vmc500_angular_sensitivity_grows_with_abbe_offset(machines):
    """Yaw of X: d dy / d ECX = X (its Abbe offset); pitch of X: d dz / d EBX = -X, d dx / d EBX = Z."""
    m = machines["vmc500"]
    q = random_q(m, 100, seed=55)
    C = m.component_sensitivity(q, np.zeros_like(m.theta))
    X, Y, Z = q.T
    np.testing.assert_allclose(C[:, 1, m.components.index("ECX")], X, atol=1e-12)
    np.testing.assert_allclose(C[:, 2, m.components.index("EBX")], -X, atol=1e-12)
    np.testing.assert_allclose(C[:, 0, m.components.index("EBX")], Z, atol=1e-12)
    # slope of the linear growth along the offset is 1 m/m, the intercept 0
    slope, intercept = np.polyfit(X, C[:, 1, m.components.index("ECX")], 1)
    assert slope == pytest.approx(1.0, abs=1e-9) and intercept == pytest.approx(0.0, abs=1e-9)


def test_vmc500_squareness_scales_with_the_orthogonal_axis(machines):
    m = machines["vmc500"]
    q = random_q(m, 100, seed=56)
    C = m.component_sensitivity(q, np.zeros_like(m.theta))
    X, Y, Z = q.T
    np.testing.assert_allclose(C[:, 1, m.components.index("EC0Y")], X, atol=1e-12)
    np.testing.assert_allclose(C[:, 0, m.components.index("EB0Z")], Z - 0.2, atol=1e-12)
    np.testing.assert_allclose(C[:, 1, m.components.index("EA0Z")], -(Z - 0.2), atol=1e-12)


def test_sensitivity_times_theta_is_the_first_order_error(machines):
    m = machines["vmc700"]
    q = random_q(m, 40, seed=57)
    zero = np.zeros_like(m.theta)
    S = m.sensitivity(q, zero)
    np.testing.assert_allclose(S @ m.theta, m.volumetric_error(q, order=1), rtol=1e-11, atol=1e-18)
