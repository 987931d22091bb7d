"""Single error sources against closed forms written from the machines' documented geometry.

vmc500 geometry (machines/vmc500/README.md), in the workpiece frame with the nominal tool
point p = (X, Y, Z): the X reference point sits at (0, Y, 0), the Y reference point at the
workpiece zero (0, 0, 0), the Z reference point (spindle gauge point) at (X, Y, Z + L) with
tool length L = 0.2 m, and the base of Z (where EA0Z, EB0Z act: the gauge point at Z = 0) at
(X, Y, L).
An error motion with translation d and rotation e about a reference point r moves the tool
point to  d + R(e) (p - r) + r  relative to the workpiece.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import random_q, rot, single

L_VMC500 = 0.2
ARCSEC = np.pi / 180 / 3600


def _expected_single(p, d=(0.0, 0.0, 0.0), axis=None, angle=0.0, r=None):
    if axis is None:
        return p + np.asarray(d)
    return np.asarray(d) + (rot(axis, angle) @ (p - r).T).T + r


@pytest.mark.parametrize("component,direction", [("EXX", 0), ("EYX", 1), ("EZX", 2), ("EXY", 0),
                                                 ("EYY", 1), ("EZY", 2), ("EXZ", 0), ("EYZ", 1),
                                                 ("EZZ", 2)])
def test_vmc500_translations_move_the_tool_by_their_value(machines, component, direction):
    m = machines["vmc500"]
    c = 7.5e-6
    q = random_q(m, 40, seed=10)
    error = m.volumetric_error(q, single(m, component, c))
    expected = np.zeros((len(q), 6))
    expected[:, direction] = c
    np.testing.assert_allclose(error, expected, atol=1e-17)


@pytest.mark.parametrize("component", ["EAX", "EBX", "ECX", "EAY", "EBY", "ECY", "EAZ", "EBZ",
                                       "ECZ", "EC0Y", "EA0Z", "EB0Z"])
def test_vmc500_rotations_give_abbe_terms(machines, component):
    """Exact rotation about the documented reference point (Abbe offsets)."""
    m = machines["vmc500"]
    angle = 40 * ARCSEC
    q = random_q(m, 40, seed=11)
    X, Y, Z = q.T
    zeros = np.zeros_like(X)
    centre = {
        "X": np.c_[zeros, Y, zeros],
        "Y": np.zeros_like(q),
        "Z": np.c_[X, Y, Z + L_VMC500],
    }
    owner = component[-1]
    if component in ("EA0Z", "EB0Z"):
        r = np.c_[X, Y, np.full_like(X, 0.2)]
    elif component == "EC0Y":
        r = centre["X"]  # the base of Y is on the X carriage, at the X reference point
    else:
        r = centre[owner]
    axis = {"A": "x", "B": "y", "C": "z"}[component[1]]
    error = m.volumetric_error(q, single(m, component, angle))
    expected = _expected_single(q, axis=axis, angle=angle, r=r) - q
    np.testing.assert_allclose(error[:, :3], expected, atol=1e-15)
    rotation = np.zeros(3)
    rotation["xyz".index(axis)] = angle
    np.testing.assert_allclose(error[:, 3:], np.tile(rotation, (len(q), 1)), atol=1e-15)


def test_vmc500_yaw_of_x_is_the_textbook_abbe_term(machines):
    """ECX alone: dy = X sin(ECX), dx = X (cos(ECX) - 1): the lever arm is the X position."""
    m = machines["vmc500"]
    gamma = 10 * ARCSEC
    q = random_q(m, 30, seed=12)
    error = m.volumetric_error(q, single(m, "ECX", gamma))
    np.testing.assert_allclose(error[:, 1], q[:, 0] * np.sin(gamma), atol=1e-16)
    np.testing.assert_allclose(error[:, 0], q[:, 0] * (np.cos(gamma) - 1), atol=2e-16)


def test_vmc500_first_order_equals_21_term_iso_expression(machines):
    """The classic first-order 21-term expression, written from ISO 230-1 component errors
    (tool relative to workpiece) and the lever arms of the documented geometry."""
    m = machines["vmc500"]
    q = random_q(m, 300, seed=13)
    X, Y, Z = q.T
    L = L_VMC500
    e = dict(zip(m.components, m.component_values(q).T))
    dx = (e["EXX"] + e["EXY"] + e["EXZ"] + (e["EBX"] + e["EBY"]) * Z - e["ECY"] * Y
          - e["EBZ"] * L + e["EB0Z"] * (Z - L))
    dy = (e["EYX"] + e["EYY"] + e["EYZ"] + e["ECX"] * X - e["EAX"] * Z + e["ECY"] * X
          - e["EAY"] * Z + e["EAZ"] * L + e["EC0Y"] * X - e["EA0Z"] * (Z - L))
    dz = e["EZX"] + e["EZY"] + e["EZZ"] - e["EBX"] * X + e["EAY"] * Y - e["EBY"] * X
    rx = e["EAX"] + e["EAY"] + e["EAZ"] + e["EA0Z"]
    ry = e["EBX"] + e["EBY"] + e["EBZ"] + e["EB0Z"]
    rz = e["ECX"] + e["ECY"] + e["ECZ"] + e["EC0Y"]
    expected = np.c_[dx, dy, dz, rx, ry, rz]
    first = m.volumetric_error(q, order=1)
    np.testing.assert_allclose(first, expected, rtol=1e-12, atol=1e-18)
    # the exact model differs from it only at second order: (30 urad)^2 x 0.5 m ~ 1e-9 m
    gap = np.abs(m.volumetric_error(q) - expected).max()
    assert 1e-12 < gap < 2e-9


def test_cgm4000_linear_axis_translation_is_invariant_to_head_angles(machines):
    m = machines["cgm4000"]
    q = random_q(m, 50, seed=14)
    error = m.volumetric_error(q, single(m, "EYY", 3e-6))
    np.testing.assert_allclose(error, np.tile([0, 3e-6, 0, 0, 0, 0], (len(q), 1)), atol=1e-18)


@pytest.mark.parametrize("component,axis_index", [("EAA", 3), ("EBB", 4)])
def test_cgm4000_angular_positioning_equals_commanding_the_axis_further(machines, component,
                                                                        axis_index):
    m = machines["cgm4000"]
    c = 30 * ARCSEC
    q = random_q(m, 50, seed=15)
    q[:, axis_index] = np.clip(q[:, axis_index], m.travel[axis_index, 0], m.travel[axis_index, 1] - c)
    error = m.volumetric_error(q, single(m, component, c))
    shifted = q.copy()
    shifted[:, axis_index] += c
    R0, p0 = m.tool_poses(q, nominal=True)
    R1, p1 = m.tool_poses(shifted, nominal=True)
    np.testing.assert_allclose(error[:, :3], p1 - p0, atol=1e-15)


@pytest.mark.parametrize("component,axis", [("EBA", "y"), ("ECA", "z"), ("EAA", "x")])
def test_cgm4000_a_axis_tilt_rotates_the_tool_about_the_a_pivot(machines, component, axis):
    """The A pivot is 0.4 m above the nominal tool point at A = B = 0: (X, Y, Z + 0.4)."""
    m = machines["cgm4000"]
    beta = 25 * ARCSEC
    q = random_q(m, 50, seed=16)
    _, p = m.tool_poses(q, nominal=True)
    pivot = np.c_[q[:, 0], q[:, 1], q[:, 2] + 0.4]
    error = m.volumetric_error(q, single(m, component, beta))
    expected = (rot(axis, beta) @ (p - pivot).T).T + pivot - p
    np.testing.assert_allclose(error[:, :3], expected, atol=1e-15)


def test_cgm4000_translation_of_b_axis_follows_the_a_head(machines):
    """B's errors act in B's fixed frame, which is the A head: EZB moves the tool along Rx(A) z."""
    m = machines["cgm4000"]
    q = random_q(m, 50, seed=17)
    error = m.volumetric_error(q, single(m, "EZB", 2e-6))
    expected = np.array([rot("x", a) @ [0, 0, 2e-6] for a in q[:, 3]])
    np.testing.assert_allclose(error[:, :3], expected, atol=1e-18)
    np.testing.assert_allclose(error[:, 3:], 0, atol=1e-18)


@pytest.mark.parametrize("name,component,sign", [("vmc500", "EC0Y", -1), ("cgm4000", "EC0Y", +1),
                                                 ("vmc700", "EC0X", +1)])
def test_xy_squareness_changes_the_angle_between_x_and_y_motions(machines, name, component, sign):
    """The documented meaning: angle(+X, +Y) of the tool relative to the workpiece = 90 deg + sign * value.

    A location error turns the tool side of the relative chain (workpiece -> tool) by +value
    about its site: on vmc500 (workpiece - Y - site - X - bed - Z - tool) that turns X against
    Y (-), on cgm4000 (workpiece - bed - X - site - Y - ...) Y against X (+), on vmc700
    (workpiece - X - site - Y - bed - ...) Y against X (+).
    """
    m = machines[name]
    gamma = 20 * ARCSEC
    theta = single(m, component, gamma)
    centre = m.travel.mean(axis=1)
    centre[3:] = 0.0  # head at A = B = 0 on cgm4000
    h = 0.05
    q = np.tile(centre, (3, 1))
    q[1, 0] += h
    q[2, 1] += h
    _, p = m.tool_poses(q, theta)
    dx, dy = p[1] - p[0], p[2] - p[0]
    angle = np.arccos(dx @ dy / np.linalg.norm(dx) / np.linalg.norm(dy))
    np.testing.assert_allclose(angle, np.pi / 2 + sign * gamma, rtol=0, atol=1e-12)
