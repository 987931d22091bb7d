"""The batch evaluator against Pinocchio, identities, and exact-vs-first-order behaviour."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

import volerr_pin as vp
from volerr_pin.model import _kinematics as K

from conftest import ALL_MACHINES, random_q


@pytest.mark.parametrize("name", ALL_MACHINES)
def test_zero_errors_give_zero(machines, name):
    m = machines[name]
    q = random_q(m, 200, seed=1)
    error = m.volumetric_error(q, np.zeros_like(m.theta))
    assert np.abs(error).max() == 0.0


@pytest.mark.parametrize("name", ALL_MACHINES)
@pytest.mark.parametrize("scale", [1.0, 300.0])
def test_batch_equals_pinocchio_per_point(machines, name, scale):
    """Exact error from the compiled chain equals Pinocchio's frame placements, point by point.

    ``scale`` 300 inflates the errors to millimetres / degrees, where second-order effects
    are large, so the comparison also covers the exact (non-linearised) composition.
    """
    m = machines[name]
    theta = m.theta * scale
    q = random_q(m, 60, seed=2)
    error = m.volumetric_error(q, theta)
    model = m.model.pinocchio
    actual = m.pinocchio_configuration(q, theta)
    nominal = m.pinocchio_configuration(q, np.zeros_like(theta))
    for i in range(len(q)):
        a = K.relative_pose_pinocchio(model, m.tool_frame, m.workpiece_frame, actual[i])
        n = K.relative_pose_pinocchio(model, m.tool_frame, m.workpiece_frame, nominal[i])
        expected = np.r_[a.translation - n.translation, pin.log3(a.rotation @ n.rotation.T)]
        np.testing.assert_allclose(error[i], expected, rtol=0, atol=1e-12)
    R, p = m.tool_poses(q, theta)
    for i in range(0, len(q), 7):
        a = K.relative_pose_pinocchio(model, m.tool_frame, m.workpiece_frame, actual[i])
        np.testing.assert_allclose(R[i], a.rotation, atol=1e-12)
        np.testing.assert_allclose(p[i], a.translation, atol=1e-12)


@pytest.mark.parametrize("name", ALL_MACHINES)
def test_first_order_error_is_first_order(machines, name):
    """exact - first order shrinks quadratically with the size of the errors."""
    m = machines[name]
    q = random_q(m, 100, seed=3)
    gaps = []
    for s in (100.0, 50.0, 25.0):
        theta = m.theta * s
        gaps.append(np.abs(m.volumetric_error(q, theta) - m.volumetric_error(q, theta, order=1)).max())
    assert gaps[0] > 1e-12
    ratios = np.array(gaps[:-1]) / np.array(gaps[1:])
    np.testing.assert_allclose(ratios, 4.0, rtol=0.05)


@pytest.mark.parametrize("name", ALL_MACHINES)
def test_first_order_is_linear_in_errors(machines, name):
    m = machines[name]
    q = random_q(m, 50, seed=4)
    a = m.volumetric_error(q, order=1)
    b = m.volumetric_error(q, 2.5 * m.theta, order=1)
    np.testing.assert_allclose(b, 2.5 * a, rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize("name", ALL_MACHINES)
def test_nominal_tool_point_follows_nc_convention(machines, name):
    """Commanding +X moves the nominal tool +x relative to the workpiece (linear axes)."""
    m = machines[name]
    centre = m.travel.mean(axis=1)
    centre = np.where(np.isfinite(centre), centre, 0.0)
    for j, (axis, kind) in enumerate(zip(m.axes, m.axis_kinds)):
        if kind != "linear" or axis not in "XYZ":
            continue
        q = np.tile(centre, (2, 1))
        q[1, j] += 1e-3
        _, p = m.tool_poses(q, nominal=True)
        step = p[1] - p[0]
        expected = np.zeros(3)
        expected["XYZ".index(axis)] = 1e-3
        np.testing.assert_allclose(step, expected, atol=1e-15, err_msg=f"{name} axis {axis}")


def test_large_input_is_chunked(machines):
    m = machines["vmc500"]
    q = random_q(m, K.CHUNK * 2 + 17, seed=5)
    full = m.volumetric_error(q)
    np.testing.assert_allclose(full[-17:], m.volumetric_error(q[-17:]), rtol=1e-14, atol=1e-18)
    np.testing.assert_allclose(full[:5], m.volumetric_error(q[:5]), rtol=1e-14, atol=1e-18)


@pytest.mark.parametrize("name", ALL_MACHINES)
def test_joint_motions_match_forward_kinematics(machines, name):
    """Each joint's motion is computed alone (no pinocchio.Data, which grows with the cube of a
    chain's joints): it equals what forward kinematics gives for that joint."""
    model = machines[name].model.pinocchio
    moved = K._moved(model)
    data = model.createData()
    pin.forwardKinematics(model, data, moved)
    for j in range(1, model.njoints):
        kind, axis = K._joint_motion(model, j, moved)
        motion = model.jointPlacements[j].inverse() * data.liMi[j]
        if kind in (K.PX, K.PY, K.PZ, K.PG):
            np.testing.assert_allclose(motion.translation, axis, atol=1e-14)
            np.testing.assert_allclose(motion.rotation, np.eye(3), atol=1e-14)
        else:
            np.testing.assert_allclose(motion.rotation, pin.exp3(axis), atol=1e-14)
            np.testing.assert_allclose(motion.translation, 0.0, atol=1e-14)


def test_evaluation_blocks_do_not_change_results(machines):
    """Blocks of points are sized by the model's joints (bounded memory for large models);
    the results do not depend on the block size (beyond the kernels' reassociated rounding)."""
    m = machines["cgm4000"]
    q = random_q(m, 40, seed=5)
    small = m.with_theta(m.theta)
    small = vp.Machine(dataclasses.replace(m.model, block=7), m.theta)
    for method in ("volumetric_error", "component_sensitivity", "error_joint_sensitivity", "axis_jacobian",
                   "sensitivity"):
        np.testing.assert_allclose(getattr(small, method)(q), getattr(m, method)(q), rtol=1e-12, atol=1e-18,
                                   err_msg=method)


@pytest.mark.parametrize("call, message", [
    (lambda m: m.volumetric_error([[0.1, 0.1], [0.1, 0.1, 0.1]]), r"^q \(shape \(N, 3\)\) must be real numbers: "),
    (lambda m: m.volumetric_error(np.array([[0.1 + 1j, 0.1, 0.1]])),
     r"^q \(shape \(N, 3\)\) must be real numbers, got complex values$"),
    (lambda m: m.volumetric_error(m.mid_travel, ["a"] * len(m.theta)), r"^theta must be real numbers: "),
    (lambda m: m.volumetric_error(m.mid_travel, m.theta + 0j), r"^theta must be real numbers, got complex"),
    (lambda m: m.with_state(temperatures={"spindle": "hot"}), r"^temperatures\['spindle'\] must be real numbers"),
    (lambda m: m.with_state(temperatures=[20.0]), r"^temperatures must map sensor names to degC$"),
    (lambda m: m.with_state(t="soon"), r"^t must be real numbers"),
    (lambda m: m.with_state(forces=[1j, 0, 0]), r"^forces must be real numbers, got complex"),
    (lambda m: m.sensitivity(m.mid_travel, parameters=["EXX.n0"]), r"^parameters must be indices of theta, "
                                                                    r"0 to 66, got 'EXX\.n0'"),
    (lambda m: m.sensitivity(m.mid_travel, parameters=[10**6]), r"^parameters must be indices of theta, 0 to 66, "
                                                                r"got 1000000"),
    (lambda m: m.sensitivity(m.mid_travel, parameters=[-1]), r"^parameters must be indices .* got -1 "),
], ids=["ragged-q", "complex-q", "text-theta", "complex-theta", "text-temperature", "temperatures-list",
        "text-time", "complex-force", "parameter-name", "parameter-beyond", "parameter-negative"])
def test_values_numpy_would_bend_are_refused(machines, call, message):
    """Ragged rows, text and complex numbers (numpy drops the imaginary part with a warning),
    and parameter indices that would wrap or overflow are refused, naming the parameter."""
    with pytest.raises(vp.InputError, match=message) as info:
        call(machines["vmc500"])
    assert len(info.value.parameters) == 1
    assert info.value.parameters[0] in str(info.value).split()[0]


def test_the_kernels_inverse_left_jacobian_is_pinocchios():
    """The inverse left Jacobian of SO(3) the sensitivity kernel computes at each point (and the
    array form) against Pinocchio's Jlog3 of exp(phi) (d log(R exp(w)) / dw is the right one; the
    left one is its transpose at phi) from 1e-2 to 3 rad, and below, where Pinocchio goes through
    the rotation matrix and loses digits, against the series I - K/2 + (1/12 + t^2/720 +
    t^4/30240) K^2, on both sides of the kernel's own switch to a series (1e-4)."""
    from volerr_pin.model._kinematics import _left_jacobian_inverse, log3_left_jacobian_inverse

    rng = np.random.default_rng(3)
    for size in (0.0, 1e-9, 3e-5, 9.9e-5, 1.01e-4, 1e-3, 1e-2, 0.3, 3.0):
        phi = rng.normal(size=3)
        phi *= size / np.linalg.norm(phi)
        K = np.array([[0.0, -phi[2], phi[1]], [phi[2], 0.0, -phi[0]], [-phi[1], phi[0], 0.0]])
        if size >= 1e-2:
            expected = pin.Jlog3(pin.exp3(phi)).T
        else:
            expected = np.eye(3) - K / 2 + (1 / 12 + size**2 / 720 + size**4 / 30240) * (K @ K)
        kernel = np.array(_left_jacobian_inverse(*phi)).reshape(3, 3)
        assert kernel == pytest.approx(expected, abs=1e-13)
        assert log3_left_jacobian_inverse(phi[None])[0] == pytest.approx(expected, abs=1e-13)
        if size:
            assert kernel == pytest.approx(pin.Jlog3(pin.exp3(phi)).T, abs=1e-9)
