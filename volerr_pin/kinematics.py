"""Batch forward kinematics of the tool relative to the workpiece.

The Pinocchio model is flattened once into a serial *relative chain* from the
workpiece frame to the tool frame: up the workpiece branch through inverted joints,
down the tool branch through ordinary ones, using the model's own joint placements
and motion axes. A compiled kernel (numba) then evaluates that chain for N points in
one call. Pinocchio stays the reference: :func:`relative_pose_pinocchio` computes the
same pose point by point, and the tests hold the two together to 1e-12.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import pinocchio as pin

from .errors import SpecError

# motion kinds of a chain operation
PX, PY, PZ, RX, RY, RZ, PG, RG = range(8)
CHUNK = 65536


@dataclass(frozen=True)
class Chain:
    """A serial chain ``T = prod_k (C_k * Motion_k(sign_k * v[col_k])) * C_end``.

    Arrays have one row per operation; ``is_error`` marks the error joints, which the
    nominal pose skips. ``v`` is a (N, nv) array of Pinocchio joint velocities-space
    values (one per 1-DoF joint).
    """

    C_R: np.ndarray
    C_p: np.ndarray
    C_identity: np.ndarray
    kind: np.ndarray
    axis: np.ndarray
    col: np.ndarray
    sign: np.ndarray
    is_error: np.ndarray
    end_R: np.ndarray
    end_p: np.ndarray
    joints: tuple[int, ...]  # Pinocchio joint id of each operation


def _joint_motion(model: pin.Model, joint: int) -> tuple[int, np.ndarray]:
    """Kind and unit axis of a 1-DoF joint, read off the model by moving it by 1."""
    if model.nvs[joint] != 1:
        raise SpecError(f"joint '{model.names[joint]}' ({model.joints[joint].shortname()}) has "
                        f"{model.nvs[joint]} degrees of freedom; only 1-DoF joints can lie "
                        "between the workpiece and the tool")
    data = model.createData()
    q = pin.neutral(model)
    iq = model.idx_qs[joint]
    if model.nqs[joint] == 2:
        q[iq], q[iq + 1] = np.cos(1.0), np.sin(1.0)
    else:
        q[iq] = 1.0
    pin.forwardKinematics(model, data, q)
    motion = model.jointPlacements[joint].inverse() * data.liMi[joint]
    rotation, translation = motion.rotation, motion.translation
    if np.allclose(rotation, np.eye(3), atol=1e-12):
        axis, base = translation / np.linalg.norm(translation), PX
    else:
        axis, base = pin.log3(rotation), RX
        axis = axis / np.linalg.norm(axis)
    for k in range(3):
        unit = np.zeros(3)
        unit[k] = 1.0
        if np.allclose(axis, unit, atol=1e-14):
            return base + k, unit
    return (PG if base == PX else RG), axis


def _joint_path(model: pin.Model, joint: int) -> list[int]:
    path = []
    while joint != 0:
        path.append(joint)
        joint = model.parents[joint]
    return path


def build_chain(model: pin.Model, tool_frame: str, workpiece_frame: str,
                error_joints: set[int]) -> Chain:
    """Flatten the model into the relative chain workpiece -> tool."""
    ft = model.frames[model.getFrameId(tool_frame)]
    fw = model.frames[model.getFrameId(workpiece_frame)]
    tool_path = _joint_path(model, ft.parentJoint)
    work_path = _joint_path(model, fw.parentJoint)
    common = set(tool_path) & set(work_path)
    up = [j for j in work_path if j not in common]  # workpiece side, nearest the frame first
    down = [j for j in reversed(tool_path) if j not in common]
    ops = []  # (C, kind, axis, col, sign, joint)
    current = fw.placement.inverse()
    for j in up:
        kind, axis = _joint_motion(model, j)
        ops.append((current, kind, axis, model.idx_vs[j], -1.0, j))
        current = model.jointPlacements[j].inverse()
    for j in down:
        kind, axis = _joint_motion(model, j)
        ops.append((current * model.jointPlacements[j], kind, axis, model.idx_vs[j], 1.0, j))
        current = pin.SE3.Identity()
    end = current * ft.placement
    K = len(ops)
    C_R = np.array([o[0].rotation for o in ops]).reshape(K, 3, 3)
    C_p = np.array([o[0].translation for o in ops]).reshape(K, 3)
    C_identity = np.array([o[0].isIdentity(1e-15) for o in ops], dtype=np.bool_)
    return Chain(
        C_R=np.ascontiguousarray(C_R), C_p=np.ascontiguousarray(C_p), C_identity=C_identity,
        kind=np.array([o[1] for o in ops], dtype=np.int64),
        axis=np.ascontiguousarray(np.array([o[2] for o in ops]).reshape(K, 3)),
        col=np.array([o[3] for o in ops], dtype=np.int64),
        sign=np.array([o[4] for o in ops], dtype=np.float64),
        is_error=np.array([o[5] in error_joints for o in ops], dtype=np.bool_),
        end_R=np.ascontiguousarray(end.rotation), end_p=np.ascontiguousarray(end.translation),
        joints=tuple(o[5] for o in ops),
    )


@numba.njit(cache=True, inline="always")
def _apply_constant(R, p, CR, Cp):
    q0 = p[0] + R[0, 0] * Cp[0] + R[0, 1] * Cp[1] + R[0, 2] * Cp[2]
    q1 = p[1] + R[1, 0] * Cp[0] + R[1, 1] * Cp[1] + R[1, 2] * Cp[2]
    q2 = p[2] + R[2, 0] * Cp[0] + R[2, 1] * Cp[1] + R[2, 2] * Cp[2]
    p[0], p[1], p[2] = q0, q1, q2
    for r in range(3):
        a, b, c = R[r, 0], R[r, 1], R[r, 2]
        R[r, 0] = a * CR[0, 0] + b * CR[1, 0] + c * CR[2, 0]
        R[r, 1] = a * CR[0, 1] + b * CR[1, 1] + c * CR[2, 1]
        R[r, 2] = a * CR[0, 2] + b * CR[1, 2] + c * CR[2, 2]


@numba.njit(cache=True, inline="always")
def _apply_motion(R, p, kind, axis, v):
    if kind <= PZ:
        for r in range(3):
            p[r] += v * R[r, kind]
    elif kind <= RZ:
        c, s = np.cos(v), np.sin(v)
        i = (kind - RX + 1) % 3
        j = (kind - RX + 2) % 3
        # R @ Rot(axis k, v): columns i, j rotate (i, j, k cyclic)
        for r in range(3):
            a, b = R[r, i], R[r, j]
            R[r, i] = c * a + s * b
            R[r, j] = -s * a + c * b
    elif kind == PG:
        for r in range(3):
            p[r] += v * (R[r, 0] * axis[0] + R[r, 1] * axis[1] + R[r, 2] * axis[2])
    else:
        c, s = np.cos(v), np.sin(v)
        t = 1.0 - c
        x, y, z = axis[0], axis[1], axis[2]
        M = np.empty((3, 3))
        M[0, 0], M[0, 1], M[0, 2] = t * x * x + c, t * x * y - s * z, t * x * z + s * y
        M[1, 0], M[1, 1], M[1, 2] = t * x * y + s * z, t * y * y + c, t * y * z - s * x
        M[2, 0], M[2, 1], M[2, 2] = t * x * z - s * y, t * y * z + s * x, t * z * z + c
        for r in range(3):
            a, b, cc = R[r, 0], R[r, 1], R[r, 2]
            R[r, 0] = a * M[0, 0] + b * M[1, 0] + cc * M[2, 0]
            R[r, 1] = a * M[0, 1] + b * M[1, 1] + cc * M[2, 1]
            R[r, 2] = a * M[0, 2] + b * M[1, 2] + cc * M[2, 2]


@numba.njit(cache=True)
def _pose(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p,
          with_errors, R, p):
    for r in range(3):
        p[r] = 0.0
        for c in range(3):
            R[r, c] = 1.0 if r == c else 0.0
    for k in range(kind.shape[0]):
        if not C_id[k]:
            _apply_constant(R, p, C_R[k], C_p[k])
        if is_error[k] and not with_errors:
            continue
        _apply_motion(R, p, kind[k], axis[k], sign[k] * values[i, col[k]])
    _apply_constant(R, p, end_R, end_p)


@numba.njit(cache=True)
def _rotation_vector(R):
    """log of a rotation matrix, accurate for tiny angles."""
    wx = 0.5 * (R[2, 1] - R[1, 2])
    wy = 0.5 * (R[0, 2] - R[2, 0])
    wz = 0.5 * (R[1, 0] - R[0, 1])
    s = np.sqrt(wx * wx + wy * wy + wz * wz)
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    if s < 1e-6:
        f = 1.0 + s * s / 6.0 + 3.0 * s ** 4 / 40.0  # theta / sin(theta) as a series in sin
        if c < 0.0:
            return _rotation_vector_large(R)
        return wx * f, wy * f, wz * f
    theta = np.arctan2(s, c)
    if c < -0.99:
        return _rotation_vector_large(R)
    f = theta / s
    return wx * f, wy * f, wz * f


@numba.njit(cache=True)
def _rotation_vector_large(R):
    # near pi: axis from the symmetric part
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    theta = np.arccos(max(-1.0, min(1.0, c)))
    B = np.empty(3)
    for k in range(3):
        B[k] = np.sqrt(max(0.0, (R[k, k] - c) / (1.0 - c)))
    k = np.argmax(B)
    axis = np.empty(3)
    axis[k] = B[k]
    for m in range(3):
        if m != k:
            axis[m] = (R[k, m] + R[m, k]) / (2.0 * (1.0 - c) * B[k])
    sx = R[2, 1] - R[1, 2]
    sy = R[0, 2] - R[2, 0]
    sz = R[1, 0] - R[0, 1]
    if axis[0] * sx + axis[1] * sy + axis[2] * sz < 0.0:
        axis = -axis
    return axis[0] * theta, axis[1] * theta, axis[2] * theta


@numba.njit(cache=True, parallel=True)
def _exact_error(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, out):
    n = values.shape[0]
    for i in numba.prange(n):
        Ra = np.empty((3, 3))
        pa = np.empty(3)
        Rn = np.empty((3, 3))
        pn = np.empty(3)
        _pose(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, True, Ra, pa)
        _pose(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, False, Rn, pn)
        D = np.empty((3, 3))  # Ra @ Rn.T
        for r in range(3):
            for c in range(3):
                D[r, c] = Ra[r, 0] * Rn[c, 0] + Ra[r, 1] * Rn[c, 1] + Ra[r, 2] * Rn[c, 2]
        rx, ry, rz = _rotation_vector(D)
        out[i, 0] = pa[0] - pn[0]
        out[i, 1] = pa[1] - pn[1]
        out[i, 2] = pa[2] - pn[2]
        out[i, 3], out[i, 4], out[i, 5] = rx, ry, rz


@numba.njit(cache=True, parallel=True)
def _first_order_error(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, out):
    n = values.shape[0]
    for i in numba.prange(n):
        R = np.eye(3)
        p = np.zeros(3)
        dp = np.zeros(3)
        dth = np.zeros(3)
        for k in range(kind.shape[0]):
            if not C_id[k]:
                _apply_constant(R, p, C_R[k], C_p[k])
            v = sign[k] * values[i, col[k]]
            if not is_error[k]:
                _apply_motion(R, p, kind[k], axis[k], v)
                continue
            kk = kind[k]
            w0 = R[0, 0] * axis[k, 0] + R[0, 1] * axis[k, 1] + R[0, 2] * axis[k, 2]
            w1 = R[1, 0] * axis[k, 0] + R[1, 1] * axis[k, 1] + R[1, 2] * axis[k, 2]
            w2 = R[2, 0] * axis[k, 0] + R[2, 1] * axis[k, 1] + R[2, 2] * axis[k, 2]
            if kk <= PZ or kk == PG:
                dp[0] += v * w0
                dp[1] += v * w1
                dp[2] += v * w2
            else:  # rotation about the line through p along w: d p_tool = v w x (p_tool - p)
                dth[0] += v * w0
                dth[1] += v * w1
                dth[2] += v * w2
                dp[0] -= v * (w1 * p[2] - w2 * p[1])
                dp[1] -= v * (w2 * p[0] - w0 * p[2])
                dp[2] -= v * (w0 * p[1] - w1 * p[0])
        _apply_constant(R, p, end_R, end_p)
        out[i, 0] = dp[0] + dth[1] * p[2] - dth[2] * p[1]
        out[i, 1] = dp[1] + dth[2] * p[0] - dth[0] * p[2]
        out[i, 2] = dp[2] + dth[0] * p[1] - dth[1] * p[0]
        out[i, 3], out[i, 4], out[i, 5] = dth[0], dth[1], dth[2]


@numba.njit(cache=True, parallel=True)
def _poses(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, with_errors,
           out_R, out_p):
    n = values.shape[0]
    for i in numba.prange(n):
        _pose(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p,
              with_errors, out_R[i], out_p[i])


def _args(chain: Chain):
    return (chain.C_R, chain.C_p, chain.C_identity, chain.kind, chain.axis, chain.col,
            chain.sign, chain.is_error, chain.end_R, chain.end_p)


def pose_error(chain: Chain, values: np.ndarray, order: int | None = None) -> np.ndarray:
    """(N, 6) error of the tool relative to the workpiece: dx, dy, dz [m], rx, ry, rz [rad].

    ``values``: (N, nv) Pinocchio joint values. ``order=None`` is exact (rotation vector
    of R_actual R_nominal^T); ``order=1`` is the first-order (linearised) error.
    """
    kernel = _exact_error if order is None else _first_order_error
    out = np.empty((values.shape[0], 6))
    for start in range(0, values.shape[0], CHUNK):
        block = np.ascontiguousarray(values[start:start + CHUNK])
        kernel(block, *_args(chain), out[start:start + CHUNK])
    return out


def relative_poses(chain: Chain, values: np.ndarray, with_errors: bool = True
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3, 3) rotations and (N, 3) positions of the tool frame in the workpiece frame."""
    values = np.ascontiguousarray(values, dtype=float)
    out_R = np.empty((values.shape[0], 3, 3))
    out_p = np.empty((values.shape[0], 3))
    _poses(values, *_args(chain), with_errors, out_R, out_p)
    return out_R, out_p


def pinocchio_configuration(model: pin.Model, values: np.ndarray) -> np.ndarray:
    """(N, nq) Pinocchio configurations from (N, nv) joint values (cos/sin for unbounded joints)."""
    values = np.atleast_2d(values)
    q = np.tile(pin.neutral(model), (values.shape[0], 1))
    for j in range(1, model.njoints):
        iq, iv = model.idx_qs[j], model.idx_vs[j]
        if model.nqs[j] == 1:
            q[:, iq] = values[:, iv]
        elif model.nqs[j] == 2 and model.nvs[j] == 1:
            q[:, iq], q[:, iq + 1] = np.cos(values[:, iv]), np.sin(values[:, iv])
    return q


def relative_pose_pinocchio(model: pin.Model, tool_frame: str, workpiece_frame: str,
                            configuration: np.ndarray) -> pin.SE3:
    """Reference: the tool frame in the workpiece frame by Pinocchio, for one configuration."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, configuration)
    oMt = data.oMf[model.getFrameId(tool_frame)]
    oMw = data.oMf[model.getFrameId(workpiece_frame)]
    return oMw.actInv(oMt)
