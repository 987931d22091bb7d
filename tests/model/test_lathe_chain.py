"""lathe_2axis against the HTM chain of seed 000 (eqs. 10-26), computed independently here.

Each body's actual HTM is Trans(offset + motion + delta) . Rot(eps) with the composite
rotation Rot(x) Rot(y) Rot(z) of the paper's eq. 6, taken exactly (not small-angle). The
paper's spindle errors are physical displacements of the spindle body; the library's are
motions of the tool relative to the workpiece, so delta4 = -(EXS, EYS, EZS) and
eps4 = -(EAS, EBS, ECS).
"""

from __future__ import annotations

import numpy as np

from conftest import random_q, rot

# offsets of the paper, as placed in machines/lathe_2axis/lathe_2axis.urdf (m)
A1 = np.array([0.35, 0.0, 0.10])
A2 = np.array([0.05, 0.0, 0.08])
A3 = np.array([-0.20, 0.0, 0.12])
A4 = np.array([0.14, 0.0, 0.15])
T_TOOL = np.array([-0.06, 0.0, 0.03])
W_WORK = np.array([0.0, 0.0, 0.18])


def htm(translation, eps=(0.0, 0.0, 0.0)):
    H = np.eye(4)
    H[:3, :3] = rot("x", eps[0]) @ rot("y", eps[1]) @ rot("z", eps[2])
    H[:3, 3] = translation
    return H


def paper_tool_in_workpiece(z, x, e):
    """Tool point and orientation relative to the workpiece for error values ``e`` (dict)."""
    d = lambda owner: np.array([e[f"EX{owner}"], e[f"EY{owner}"], e[f"EZ{owner}"]])
    eps = lambda owner: np.array([e[f"EA{owner}"], e[f"EB{owner}"], e[f"EC{owner}"]])
    RT1 = htm(A1 + [0, 0, z] + d("Z"), eps("Z"))
    T12 = htm(A2 + [x, 0, 0] + d("X"), eps("X"))
    T23 = htm(A3 + d("T"), eps("T"))
    RT4 = htm(A4 - d("S"), -eps("S"))
    RT_tool = RT1 @ T12 @ T23 @ htm(T_TOOL)
    RT_work = RT4 @ htm(W_WORK)
    return np.linalg.inv(RT_work) @ RT_tool


def test_lathe_equals_seed000_htm_chain(machines):
    m = machines["lathe_2axis"]
    q = random_q(m, 50, seed=20)
    for scale in (1.0, 1000.0):  # also with errors inflated to mm and degrees
        theta = m.theta * scale
        values = m.component_values(q, theta)
        error = m.volumetric_error(q, theta)
        for i, (z, x) in enumerate(q):
            e = dict(zip(m.components, values[i]))
            actual = paper_tool_in_workpiece(z, x, e)
            nominal = paper_tool_in_workpiece(z, x, dict.fromkeys(e, 0.0))
            np.testing.assert_allclose(error[i, :3], actual[:3, 3] - nominal[:3, 3], atol=1e-12)
            D = actual[:3, :3] @ nominal[:3, :3].T
            angle = np.arccos(np.clip((np.trace(D) - 1) / 2, -1, 1))
            axis = np.array([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])
            rotvec = axis / (2 * np.sin(angle)) * angle if angle > 1e-12 else axis / 2
            np.testing.assert_allclose(error[i, 3:], rotvec, atol=1e-12)


def test_lathe_nominal_tool_point_is_the_nc_position(machines):
    m = machines["lathe_2axis"]
    q = random_q(m, 20, seed=21)
    _, p = m.tool_poses(q, nominal=True)
    np.testing.assert_allclose(p, np.c_[q[:, 1], np.zeros(len(q)), q[:, 0]], atol=1e-15)


def test_lathe_first_order_x_matches_paper_structure(machines):
    """First-order Px of eq. 27, re-derived: the carriage's and cross slide's translations add,
    the spindle's subtract (physical delta4 = -EXS), and angular errors act through the
    offsets between each body and the tool point."""
    m = machines["lathe_2axis"]
    q = random_q(m, 100, seed=22)
    Z, X = q.T
    e = dict(zip(m.components, m.component_values(q).T))
    # tool point relative to each body origin (bed frame), nominal
    tool = A1 + A2 + A3 + T_TOOL
    r1 = np.c_[tool[0] - A1[0] + X, np.zeros_like(X), tool[2] - A1[2] + 0 * Z]  # from carriage
    r2 = np.c_[np.full_like(X, tool[0] - A1[0] - A2[0]), 0 * X, np.full_like(X, tool[2] - A1[2] - A2[2])]
    r3 = np.tile(tool - A1 - A2 - A3, (len(q), 1))
    # from the spindle origin to the tool point: workpiece offset + the NC position
    r4 = np.c_[W_WORK[0] + X, np.zeros_like(X) + W_WORK[1], W_WORK[2] + Z]
    px = e["EXZ"] + e["EXX"] + e["EXT"] + e["EXS"]
    for owner, r in (("Z", r1), ("X", r2), ("T", r3), ("S", r4)):
        px = px + e[f"EB{owner}"] * r[:, 2] - e[f"EC{owner}"] * r[:, 1]
    np.testing.assert_allclose(m.volumetric_error(q, order=1)[:, 0], px, rtol=1e-10, atol=1e-17)
