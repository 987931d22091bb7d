"""Batch forward kinematics of the tool relative to the workpiece.

The Pinocchio model is flattened once into a serial *relative chain* from the
workpiece frame to the tool frame: up the workpiece branch through inverted joints,
down the tool branch through ordinary ones, using the model's own joint placements
and motion axes. A compiled kernel (numba) then evaluates that chain for N points in
one call. Pinocchio stays the reference: :func:`relative_pose_pinocchio` computes the
same pose point by point, and the tests hold the two together to 1e-12.
"""

from __future__ import annotations

import types
from dataclasses import dataclass

import numba
import numpy as np
import pinocchio as pin

from ..base import SpecError

# motion kinds of a chain operation
PX, PY, PZ, RX, RY, RZ, PG, RG = range(8)
# Kernels may reassociate and contract floating-point operations (about 20 % faster, results
# change at the 1e-16 level); NaN and infinity semantics are kept (no "nnan"/"ninf").
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
CHUNK = 16384  # points per block: keeps the joint-value block in cache, memory bounded
PARALLEL_MIN = 2048  # fewer points run on the calling thread: waking a thread pool costs more


def _njit(**options):
    """``numba.njit`` with its compiled code cached on disk where a cache can be written (beside
    the source, or under the user's cache folder); where neither can - an installation that is
    read-only for a user whose HOME is not writable - the kernels are compiled in memory at
    each start instead of failing the import."""
    def wrap(fn):
        try:
            return numba.njit(cache=True, **options)(fn)
        except RuntimeError as err:
            if "no locator available" not in str(err):
                raise
            return numba.njit(**options)(fn)
    return wrap


def _kernel(fn):
    """Compile ``fn`` twice - over threads (``numba.prange``) and on the calling thread - and
    pick by the number of points (``values.shape[1]``, the first argument): small calls
    (thousands of them in an identification or diagnosis) then never wait for a pool."""
    parallel = _njit(parallel=True, fastmath=FAST)(fn)
    twin = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__ + "_serial")
    twin.__qualname__ = fn.__qualname__ + "_serial"  # its own on-disk cache entry
    serial = _njit(fastmath=FAST)(twin)

    def run(values, *args):
        return (parallel if values.shape[1] >= PARALLEL_MIN else serial)(values, *args)

    run.parallel, run.serial = parallel, serial
    run.__doc__, run.__name__ = fn.__doc__, fn.__name__
    return run


def run_on_this_thread() -> None:
    """From now on every kernel runs on the calling thread, whatever the number of points: for a
    forked process, where numba's thread pool (GNU OpenMP) does not survive the fork and a
    parallel kernel would terminate the process. Both forms compute each point alike.

    Returns
    -------
    None
    """
    global PARALLEL_MIN
    PARALLEL_MIN = float("inf")


@dataclass(frozen=True)
class Chain:
    """A serial chain ``T = prod_k (C_k * Motion_k(sign_k * v[col_k])) * C_end``.

    Arrays have one row per operation; ``is_error`` marks the error joints, which the
    nominal pose skips. ``v`` holds Pinocchio joint velocity-space values (one per 1-DoF
    joint); the functions of this module take them as ``values`` of shape (nv, N), one row per
    joint, points contiguous.

    Attributes
    ----------
    C_R : ndarray, shape (K, 3, 3)
        Rotation of the constant placement before each operation.
    C_p : ndarray, shape (K, 3)
        Translation of the constant placement before each operation [m].
    C_identity : ndarray of bool, shape (K,)
        Whether that placement is the identity (then it is skipped).
    kind : ndarray of int64, shape (K,)
        Motion kind of each operation: ``PX``, ``PY``, ``PZ`` (translation along a frame axis),
        ``RX``, ``RY``, ``RZ`` (rotation about one), ``PG`` / ``RG`` (along / about a general axis).
    axis : ndarray, shape (K, 3)
        Unit motion axis of each operation.
    col : ndarray of int64, shape (K,)
        Row of ``values`` (Pinocchio velocity index) that drives each operation.
    sign : ndarray, shape (K,)
        +1 for joints on the tool branch, -1 for inverted joints on the workpiece branch.
    is_error : ndarray of bool, shape (K,)
        True for error joints.
    end_R : ndarray, shape (1, 3, 3)
        Rotation of the closing placement to the tool frame.
    end_p : ndarray, shape (1, 3)
        Translation of the closing placement to the tool frame [m].
    joints : tuple of int
        Pinocchio joint id of each operation.
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


def _moved(model: pin.Model) -> np.ndarray:
    """The configuration with every 1-DoF joint moved by 1 (m or rad), from which each joint's
    own motion is computed alone (:func:`_joint_motion`).

    No ``pinocchio.Data`` is made: Pinocchio's Data of a serial chain grows with the cube of
    its joints (2.8 GB for a chain of 350), and a machine with many axes and six error joints on each
    would not get one.
    """
    q = pin.neutral(model)
    for joint in range(1, model.njoints):
        iq = model.idx_qs[joint]
        if model.nvs[joint] == 1 and model.nqs[joint] == 2:
            q[iq], q[iq + 1] = np.cos(1.0), np.sin(1.0)
        elif model.nvs[joint] == 1:
            q[iq] = 1.0
    return q


def _joint_motion(model: pin.Model, joint: int, moved: np.ndarray) -> tuple[int, np.ndarray]:
    """Kind and unit axis of a 1-DoF joint, from its motion at the configuration ``moved``
    (:func:`_moved`)."""
    if model.nvs[joint] != 1:
        raise SpecError(f"joint '{model.names[joint]}' ({model.joints[joint].shortname()}) has "
                        f"{model.nvs[joint]} degrees of freedom; only 1-DoF joints can lie "
                        "between the workpiece and the tool")
    jmodel = model.joints[joint]
    jdata = jmodel.createData()
    jmodel.calc(jdata, moved)  # reads its own entries of the full configuration
    motion = jdata.M
    rotation, translation = motion.rotation, motion.translation
    if np.abs(rotation - np.eye(3)).max() <= 1e-12:
        axis, base = translation / np.linalg.norm(translation), PX
    else:
        axis, base = pin.log3(rotation), RX
        axis = axis / np.linalg.norm(axis)
    k = int(np.argmax(np.abs(axis)))
    if abs(axis[k] - 1.0) <= 1e-14 and np.abs(np.delete(axis, k)).max() <= 1e-14:
        unit = np.zeros(3)
        unit[k] = 1.0
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
    """Flatten the model into the relative chain workpiece -> tool.

    Up the workpiece branch through inverted joints (nearest the workpiece frame first), then
    down the tool branch through ordinary ones, with the model's own joint placements and
    motion axes.

    Parameters
    ----------
    model : pinocchio.Model
        The model (with error joints).
    tool_frame : str
        Name of the tool frame in the model.
    workpiece_frame : str
        Name of the workpiece frame in the model.
    error_joints : set of int
        Pinocchio joint ids of the error joints (marked ``is_error``).

    Returns
    -------
    Chain
        The relative chain.

    Raises
    ------
    SpecError
        If a joint between the two frames does not have exactly one degree of freedom.
    """
    ft = model.frames[model.getFrameId(tool_frame)]
    fw = model.frames[model.getFrameId(workpiece_frame)]
    tool_path = _joint_path(model, ft.parentJoint)
    work_path = _joint_path(model, fw.parentJoint)
    common = set(tool_path) & set(work_path)
    up = [j for j in work_path if j not in common]  # workpiece side, nearest the frame first
    down = [j for j in reversed(tool_path) if j not in common]
    ops = []  # (C, kind, axis, col, sign, joint)
    current = fw.placement.inverse()
    moved = _moved(model)
    for j in up:
        kind, axis = _joint_motion(model, j, moved)
        ops.append((current, kind, axis, model.idx_vs[j], -1.0, j))
        current = model.jointPlacements[j].inverse()
    for j in down:
        kind, axis = _joint_motion(model, j, moved)
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
        end_R=np.ascontiguousarray(end.rotation[None]), end_p=np.ascontiguousarray(end.translation[None]),
        joints=tuple(o[5] for o in ops),
    )


@_njit(fastmath=FAST)
def _sincos(v):
    """sin and cos; a short series for the tiny angles of error joints (exact to rounding
    for |v| < 1e-2: the first omitted terms are below 1e-26), libm otherwise."""
    if abs(v) < 1e-2:
        v2 = v * v
        s = v * (1.0 - v2 / 6.0 * (1.0 - v2 / 20.0 * (1.0 - v2 / 42.0)))
        c = 1.0 - v2 / 2.0 * (1.0 - v2 / 12.0 * (1.0 - v2 / 30.0 * (1.0 - v2 / 56.0)))
        return s, c
    return np.sin(v), np.cos(v)


# Poses inside the kernels are (R, p) with R a 9-tuple (row-major) and p a 3-tuple: plain
# scalars that stay in registers, no per-point allocation.

@_njit(fastmath=FAST)
def _compose_constant(R, p, C_R, C_p, k):
    """(R, p) * (C_R[k], C_p[k]); arrays are indexed here, not sliced (no views in the loop)."""
    p = (p[0] + R[0] * C_p[k, 0] + R[1] * C_p[k, 1] + R[2] * C_p[k, 2],
         p[1] + R[3] * C_p[k, 0] + R[4] * C_p[k, 1] + R[5] * C_p[k, 2],
         p[2] + R[6] * C_p[k, 0] + R[7] * C_p[k, 1] + R[8] * C_p[k, 2])
    R = (R[0] * C_R[k, 0, 0] + R[1] * C_R[k, 1, 0] + R[2] * C_R[k, 2, 0],
         R[0] * C_R[k, 0, 1] + R[1] * C_R[k, 1, 1] + R[2] * C_R[k, 2, 1],
         R[0] * C_R[k, 0, 2] + R[1] * C_R[k, 1, 2] + R[2] * C_R[k, 2, 2],
         R[3] * C_R[k, 0, 0] + R[4] * C_R[k, 1, 0] + R[5] * C_R[k, 2, 0],
         R[3] * C_R[k, 0, 1] + R[4] * C_R[k, 1, 1] + R[5] * C_R[k, 2, 1],
         R[3] * C_R[k, 0, 2] + R[4] * C_R[k, 1, 2] + R[5] * C_R[k, 2, 2],
         R[6] * C_R[k, 0, 0] + R[7] * C_R[k, 1, 0] + R[8] * C_R[k, 2, 0],
         R[6] * C_R[k, 0, 1] + R[7] * C_R[k, 1, 1] + R[8] * C_R[k, 2, 1],
         R[6] * C_R[k, 0, 2] + R[7] * C_R[k, 1, 2] + R[8] * C_R[k, 2, 2])
    return R, p


@_njit(fastmath=FAST)
def _compose_motion(R, p, kind, axis, k, v):
    if kind == PX:
        return R, (p[0] + v * R[0], p[1] + v * R[3], p[2] + v * R[6])
    if kind == PY:
        return R, (p[0] + v * R[1], p[1] + v * R[4], p[2] + v * R[7])
    if kind == PZ:
        return R, (p[0] + v * R[2], p[1] + v * R[5], p[2] + v * R[8])
    if kind == PG:
        a0, a1, a2 = axis[k, 0], axis[k, 1], axis[k, 2]
        return R, (p[0] + v * (R[0] * a0 + R[1] * a1 + R[2] * a2),
                   p[1] + v * (R[3] * a0 + R[4] * a1 + R[5] * a2),
                   p[2] + v * (R[6] * a0 + R[7] * a1 + R[8] * a2))
    s, c = _sincos(v)
    if kind == RX:  # R @ Rx: columns 1, 2 rotate
        return (R[0], c * R[1] + s * R[2], -s * R[1] + c * R[2],
                R[3], c * R[4] + s * R[5], -s * R[4] + c * R[5],
                R[6], c * R[7] + s * R[8], -s * R[7] + c * R[8]), p
    if kind == RY:  # columns 2, 0 rotate
        return (c * R[0] - s * R[2], R[1], s * R[0] + c * R[2],
                c * R[3] - s * R[5], R[4], s * R[3] + c * R[5],
                c * R[6] - s * R[8], R[7], s * R[6] + c * R[8]), p
    if kind == RZ:  # columns 0, 1 rotate
        return (c * R[0] + s * R[1], -s * R[0] + c * R[1], R[2],
                c * R[3] + s * R[4], -s * R[3] + c * R[4], R[5],
                c * R[6] + s * R[7], -s * R[6] + c * R[7], R[8]), p
    t = 1.0 - c
    x, y, z = axis[k, 0], axis[k, 1], axis[k, 2]
    m00, m01, m02 = t * x * x + c, t * x * y - s * z, t * x * z + s * y
    m10, m11, m12 = t * x * y + s * z, t * y * y + c, t * y * z - s * x
    m20, m21, m22 = t * x * z - s * y, t * y * z + s * x, t * z * z + c
    return (R[0] * m00 + R[1] * m10 + R[2] * m20, R[0] * m01 + R[1] * m11 + R[2] * m21,
            R[0] * m02 + R[1] * m12 + R[2] * m22,
            R[3] * m00 + R[4] * m10 + R[5] * m20, R[3] * m01 + R[4] * m11 + R[5] * m21,
            R[3] * m02 + R[4] * m12 + R[5] * m22,
            R[6] * m00 + R[7] * m10 + R[8] * m20, R[6] * m01 + R[7] * m11 + R[8] * m21,
            R[6] * m02 + R[7] * m12 + R[8] * m22), p


@_njit(fastmath=FAST)
def _pose(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, with_errors):
    R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    p = (0.0, 0.0, 0.0)
    for k in range(kind.shape[0]):
        if not C_id[k]:
            R, p = _compose_constant(R, p, C_R, C_p, k)
        if is_error[k] and not with_errors:
            continue
        R, p = _compose_motion(R, p, kind[k], axis, k, sign[k] * values[col[k], i])
    return _compose_constant(R, p, end_R, end_p, 0)


@_njit(fastmath=FAST)
def _times_transpose(Ra, Rn):
    """Ra Rn^T of two rotations (row-major 9-tuples): the error rotation of an actual pose
    against the nominal one."""
    return (Ra[0] * Rn[0] + Ra[1] * Rn[1] + Ra[2] * Rn[2],
            Ra[0] * Rn[3] + Ra[1] * Rn[4] + Ra[2] * Rn[5],
            Ra[0] * Rn[6] + Ra[1] * Rn[7] + Ra[2] * Rn[8],
            Ra[3] * Rn[0] + Ra[4] * Rn[1] + Ra[5] * Rn[2],
            Ra[3] * Rn[3] + Ra[4] * Rn[4] + Ra[5] * Rn[5],
            Ra[3] * Rn[6] + Ra[4] * Rn[7] + Ra[5] * Rn[8],
            Ra[6] * Rn[0] + Ra[7] * Rn[1] + Ra[8] * Rn[2],
            Ra[6] * Rn[3] + Ra[7] * Rn[4] + Ra[8] * Rn[5],
            Ra[6] * Rn[6] + Ra[7] * Rn[7] + Ra[8] * Rn[8])


@_njit(fastmath=FAST)
def _rotation_vector(D):
    """log of a rotation matrix (9-tuple), accurate for tiny angles, valid up to pi."""
    wx = 0.5 * (D[7] - D[5])
    wy = 0.5 * (D[2] - D[6])
    wz = 0.5 * (D[3] - D[1])
    s = np.sqrt(wx * wx + wy * wy + wz * wz)
    c = 0.5 * (D[0] + D[4] + D[8] - 1.0)
    if c > 0.0:
        if s < 1e-6:
            f = 1.0 + s * s / 6.0 + 3.0 * s ** 4 / 40.0  # theta / sin(theta), series in sin
        else:
            f = np.arctan2(s, c) / s
        return wx * f, wy * f, wz * f
    # beyond 90 degrees: axis from the symmetric part, sign from the skew part
    theta = np.arccos(max(-1.0, min(1.0, c)))
    d = (D[0], D[4], D[8])
    k = 0
    if d[1] > d[k]:
        k = 1
    if d[2] > d[k]:
        k = 2
    a = [0.0, 0.0, 0.0]
    a[k] = np.sqrt(max(0.0, (d[k] - c) / (1.0 - c)))
    for m in range(3):
        if m != k:
            a[m] = (D[3 * k + m] + D[3 * m + k]) / (2.0 * (1.0 - c) * a[k])
    if a[0] * wx + a[1] * wy + a[2] * wz < 0.0:
        theta = -theta
    return a[0] * theta, a[1] * theta, a[2] * theta


@_kernel
def _exact_error(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, out):
    n = values.shape[1]
    for i in numba.prange(n):
        # actual and nominal poses in one pass over the chain
        Ra = Rn = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        pa = pn = (0.0, 0.0, 0.0)
        for k in range(kind.shape[0]):
            if not C_id[k]:
                Ra, pa = _compose_constant(Ra, pa, C_R, C_p, k)
                Rn, pn = _compose_constant(Rn, pn, C_R, C_p, k)
            v = sign[k] * values[col[k], i]
            Ra, pa = _compose_motion(Ra, pa, kind[k], axis, k, v)
            if not is_error[k]:
                Rn, pn = _compose_motion(Rn, pn, kind[k], axis, k, v)
        Ra, pa = _compose_constant(Ra, pa, end_R, end_p, 0)
        Rn, pn = _compose_constant(Rn, pn, end_R, end_p, 0)
        rx, ry, rz = _rotation_vector(_times_transpose(Ra, Rn))
        out[i, 0] = pa[0] - pn[0]
        out[i, 1] = pa[1] - pn[1]
        out[i, 2] = pa[2] - pn[2]
        out[i, 3] = rx
        out[i, 4] = ry
        out[i, 5] = rz


@_kernel
def _first_order_error(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, out):
    n = values.shape[1]
    for i in numba.prange(n):
        R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        p = (0.0, 0.0, 0.0)
        dp0 = dp1 = dp2 = 0.0
        dt0 = dt1 = dt2 = 0.0
        for k in range(kind.shape[0]):
            if not C_id[k]:
                R, p = _compose_constant(R, p, C_R, C_p, k)
            v = sign[k] * values[col[k], i]
            if not is_error[k]:
                R, p = _compose_motion(R, p, kind[k], axis, k, v)
                continue
            w0 = R[0] * axis[k, 0] + R[1] * axis[k, 1] + R[2] * axis[k, 2]
            w1 = R[3] * axis[k, 0] + R[4] * axis[k, 1] + R[5] * axis[k, 2]
            w2 = R[6] * axis[k, 0] + R[7] * axis[k, 1] + R[8] * axis[k, 2]
            if kind[k] <= PZ or kind[k] == PG:
                dp0 += v * w0
                dp1 += v * w1
                dp2 += v * w2
            else:  # rotation about the line through p along w: d p_tool = v w x (p_tool - p)
                dt0 += v * w0
                dt1 += v * w1
                dt2 += v * w2
                dp0 -= v * (w1 * p[2] - w2 * p[1])
                dp1 -= v * (w2 * p[0] - w0 * p[2])
                dp2 -= v * (w0 * p[1] - w1 * p[0])
        R, p = _compose_constant(R, p, end_R, end_p, 0)
        out[i, 0] = dp0 + dt1 * p[2] - dt2 * p[1]
        out[i, 1] = dp1 + dt2 * p[0] - dt0 * p[2]
        out[i, 2] = dp2 + dt0 * p[1] - dt1 * p[0]
        out[i, 3] = dt0
        out[i, 4] = dt1
        out[i, 5] = dt2


@_kernel
def _poses(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, with_errors,
           out_R, out_p):
    n = values.shape[1]
    for i in numba.prange(n):
        R, p = _pose(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p,
                     with_errors)
        for r in range(3):
            out_p[i, r] = p[r]
            for c in range(3):
                out_R[i, r, c] = R[3 * r + c]


@_njit(fastmath=FAST)
def _jacobian_point(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p,
                    nominal, J):
    """Derivative of the tool pose (in the workpiece frame) w.r.t. every joint value, for point i.

    J[0:3, c]: d p_tool / d v_c; J[3:6, c]: angular velocity of the tool frame per unit of
    v_c, both in workpiece axes. ``nominal`` evaluates at zero error values. Returns the tool
    frame's rotation there (9-tuple, row-major).
    """
    for r in range(6):
        for c in range(J.shape[1]):
            J[r, c] = 0.0
    R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    p = (0.0, 0.0, 0.0)
    for k in range(kind.shape[0]):
        if not C_id[k]:
            R, p = _compose_constant(R, p, C_R, C_p, k)
        c = col[k]
        s = sign[k]
        w0 = s * (R[0] * axis[k, 0] + R[1] * axis[k, 1] + R[2] * axis[k, 2])
        w1 = s * (R[3] * axis[k, 0] + R[4] * axis[k, 1] + R[5] * axis[k, 2])
        w2 = s * (R[6] * axis[k, 0] + R[7] * axis[k, 1] + R[8] * axis[k, 2])
        if kind[k] <= PZ or kind[k] == PG:
            J[0, c] = w0
            J[1, c] = w1
            J[2, c] = w2
        else:  # -w x p_k now; + w x p_tool once the tool point is known
            J[3, c] = w0
            J[4, c] = w1
            J[5, c] = w2
            J[0, c] = -(w1 * p[2] - w2 * p[1])
            J[1, c] = -(w2 * p[0] - w0 * p[2])
            J[2, c] = -(w0 * p[1] - w1 * p[0])
        if nominal and is_error[k]:
            continue
        R, p = _compose_motion(R, p, kind[k], axis, k, s * values[c, i])
    R, p = _compose_constant(R, p, end_R, end_p, 0)
    for k in range(kind.shape[0]):
        if kind[k] > PZ and kind[k] != PG:
            c = col[k]
            w0, w1, w2 = J[3, c], J[4, c], J[5, c]
            J[0, c] += w1 * p[2] - w2 * p[1]
            J[1, c] += w2 * p[0] - w0 * p[2]
            J[2, c] += w0 * p[1] - w1 * p[0]
    return R


@_kernel
def _jacobian(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, nominal,
              out_J):
    for i in numba.prange(values.shape[1]):
        _jacobian_point(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p,
                        nominal, out_J[i])


@_njit(fastmath=FAST)
def _left_jacobian_inverse(x, y, z):
    """Jl^-1 at the rotation vector (x, y, z), row-major 9-tuple: I - K/2 + c K^2 with K its
    skew matrix (K^2 = phi phi^T - |phi|^2 I), as :func:`log3_left_jacobian_inverse`."""
    t2 = x * x + y * y + z * z
    t = np.sqrt(t2)
    if t < 1e-4:
        c = 1.0 / 12.0 + t2 / 720.0
    else:
        c = 1.0 / t2 - (1.0 + np.cos(t)) / (2.0 * t * np.sin(t))
    return (1.0 + c * (x * x - t2), 0.5 * z + c * x * y, -0.5 * y + c * x * z,
            -0.5 * z + c * x * y, 1.0 + c * (y * y - t2), 0.5 * x + c * y * z,
            0.5 * y + c * x * z, -0.5 * x + c * y * z, 1.0 + c * (z * z - t2))


@_kernel
def _sensitivity(values, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, basis, bcol, pcol,
                 out):
    """out[i, r, p] = (Jl-corrected J)[r, pcol[p]] * basis[i, bcol[p]]: the chain rule to the
    coefficients, with the rotation rows through the inverse left Jacobian at the point's
    rotation error (the actual tool rotation against the nominal one, both from this pass)."""
    nv = values.shape[0]
    for i in numba.prange(values.shape[1]):
        J = np.empty((6, nv))
        Ra = _jacobian_point(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p,
                             False, J)
        Rn, _ = _pose(values, i, C_R, C_p, C_id, kind, axis, col, sign, is_error, end_R, end_p, False)
        rx, ry, rz = _rotation_vector(_times_transpose(Ra, Rn))
        L = _left_jacobian_inverse(rx, ry, rz)
        for c in range(nv):
            a, b, d = J[3, c], J[4, c], J[5, c]
            J[3, c] = L[0] * a + L[1] * b + L[2] * d
            J[4, c] = L[3] * a + L[4] * b + L[5] * d
            J[5, c] = L[6] * a + L[7] * b + L[8] * d
        for r in range(6):
            for p in range(pcol.shape[0]):
                out[i, r, p] = J[r, pcol[p]] * basis[i, bcol[p]]


def error_sensitivity(chain: Chain, values: np.ndarray, basis: np.ndarray, pcol: np.ndarray,
                      out: np.ndarray | None = None, columns: np.ndarray | None = None) -> np.ndarray:
    """Derivative of the 6-component error with respect to coefficients.

    Each coefficient p drives the joint value of row ``pcol[p]`` with derivative
    ``basis[:, columns[p]]``; the rotation rows go through the inverse left Jacobian of the
    rotation-vector error.

    Parameters
    ----------
    chain : Chain
        The relative chain.
    values : ndarray, shape (nv, N)
        Joint values [m, rad], one row per joint.
    basis : ndarray, shape (N, B)
        d(joint value) / d(coefficient) at each point [m or rad per SI unit of the coefficient].
    pcol : ndarray of int64, shape (P,)
        The joint row of each coefficient.
    out : ndarray, shape (N, 6, P), optional
        A C-contiguous array to fill.
    columns : ndarray of int64, shape (P,), optional
        The column of ``basis`` of each coefficient (default ``arange(B)``, B = P): read in
        place, where a copy of the columns took half as long as the chain rule itself.

    Returns
    -------
    ndarray, shape (N, 6, P)
        dx, dy, dz [m] and rx, ry, rz [rad] per SI unit of each coefficient (``out`` if given).
    """
    values = np.ascontiguousarray(values, dtype=float)
    if out is None:
        out = np.empty((values.shape[1], 6, len(pcol)))
    columns = np.arange(basis.shape[1]) if columns is None else columns
    if len(columns) != len(pcol) or (len(columns) and not 0 <= columns.min() <= columns.max() < basis.shape[1]):
        raise ValueError(f"{len(columns)} basis columns (of {basis.shape[1]}) for {len(pcol)} coefficients")
    _sensitivity(values, *_args(chain), np.ascontiguousarray(basis), np.ascontiguousarray(columns, dtype=np.int64),
                 pcol, out)
    return out


def joint_jacobian(chain: Chain, values: np.ndarray, nv: int, nominal: bool = False
                   ) -> np.ndarray:
    """Derivative of the tool pose in the workpiece frame with respect to the joint values.

    Parameters
    ----------
    chain : Chain
        The relative chain.
    values : ndarray, shape (nv, N)
        Joint values [m, rad], one row per joint.
    nv : int
        Number of joint values (columns of the result).
    nominal : bool, default False
        Evaluate at zero error-joint values.

    Returns
    -------
    ndarray, shape (N, 6, nv)
        Rows 0-2 the tool point's velocity [m per m or rad], rows 3-5 the angular velocity
        [rad per m or rad], both in workpiece axes; columns of joints not on the chain are 0.
    """
    values = np.ascontiguousarray(values, dtype=float)
    out = np.empty((values.shape[1], 6, nv))
    _jacobian(values, *_args(chain), nominal, out)
    return out


def log3_left_jacobian_inverse(phi: np.ndarray) -> np.ndarray:
    """Inverse left Jacobian of SO(3) at rotation vectors: d log(exp(dw) exp(phi)) = Jl^-1(phi) dw.

    Parameters
    ----------
    phi : ndarray, shape (N, 3)
        Rotation vectors [rad].

    Returns
    -------
    ndarray, shape (N, 3, 3)
        Jl^-1(phi) for each point (a series below 1e-4 rad).
    """
    theta = np.linalg.norm(phi, axis=1)
    K = np.zeros((len(phi), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -phi[:, 2], phi[:, 1], -phi[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = phi[:, 2], -phi[:, 1], phi[:, 0]
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    coef = np.where(small, 1.0 / 12.0 + theta**2 / 720.0,
                    1.0 / t**2 - (1.0 + np.cos(t)) / (2.0 * t * np.sin(t)))
    return np.eye(3) - 0.5 * K + coef[:, None, None] * (K @ K)


def _args(chain: Chain):
    return (chain.C_R, chain.C_p, chain.C_identity, chain.kind, chain.axis, chain.col,
            chain.sign, chain.is_error, chain.end_R, chain.end_p)


def pose_error(chain: Chain, values: np.ndarray, order: int | None = None,
               out: np.ndarray | None = None) -> np.ndarray:
    """Error of the tool relative to the workpiece: dx, dy, dz [m], rx, ry, rz [rad].

    Parameters
    ----------
    chain : Chain
        The relative chain.
    values : ndarray, shape (nv, N)
        Pinocchio joint values [m, rad], one row per joint (points contiguous).
    order : None or int, optional
        None is exact (rotation vector of R_actual R_nominal^T); any other value (``order=1``)
        the first-order (linearised) error.
    out : ndarray, shape (N, 6), optional
        An array to fill.

    Returns
    -------
    ndarray, shape (N, 6)
        Actual minus nominal pose of the tool frame, in the workpiece frame (``out`` if given).
    """
    kernel = _exact_error if order is None else _first_order_error
    values = np.ascontiguousarray(values, dtype=float)
    if out is None:
        out = np.empty((values.shape[1], 6))
    kernel(values, *_args(chain), out)
    return out


def relative_poses(chain: Chain, values: np.ndarray, with_errors: bool = True
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Poses of the tool frame in the workpiece frame.

    Parameters
    ----------
    chain : Chain
        The relative chain.
    values : ndarray, shape (nv, N)
        Joint values [m, rad], one row per joint.
    with_errors : bool, default True
        Include the error joints (False: the nominal pose).

    Returns
    -------
    R : ndarray, shape (N, 3, 3)
        Rotations.
    p : ndarray, shape (N, 3)
        Positions [m].
    """
    values = np.ascontiguousarray(values, dtype=float)
    out_R = np.empty((values.shape[1], 3, 3))
    out_p = np.empty((values.shape[1], 3))
    _poses(values, *_args(chain), with_errors, out_R, out_p)
    return out_R, out_p


def pinocchio_configuration(model: pin.Model, values: np.ndarray) -> np.ndarray:
    """Pinocchio configurations from joint values (cos/sin for unbounded joints).

    Parameters
    ----------
    model : pinocchio.Model
        The model.
    values : ndarray, shape (N, nv) or (nv,)
        Joint values [m, rad], one row per point.

    Returns
    -------
    ndarray, shape (N, nq)
        Configurations: the neutral configuration with every 1-DoF joint set.
    """
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
    """Reference: the tool frame in the workpiece frame by Pinocchio, for one configuration.

    Parameters
    ----------
    model : pinocchio.Model
        The model.
    tool_frame : str
        Name of the tool frame.
    workpiece_frame : str
        Name of the workpiece frame.
    configuration : ndarray, shape (nq,)
        One Pinocchio configuration.

    Returns
    -------
    pinocchio.SE3
        Pose of the tool frame in the workpiece frame (translation in m).
    """
    data = model.createData()
    pin.framesForwardKinematics(model, data, configuration)
    oMt = data.oMf[model.getFrameId(tool_frame)]
    oMw = data.oMf[model.getFrameId(workpiece_frame)]
    return oMw.actInv(oMt)
