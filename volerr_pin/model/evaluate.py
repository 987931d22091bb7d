"""The model core: evaluations of an assembled model (:class:`~volerr_pin.model.assembly.Assembly`)
for coefficients and covariates, as free functions in Pinocchio's style.

They are trusted and batched: NC positions ``q`` (N, n_axes) [m, rad] as a float array within
what the model may evaluate, coefficients ``theta`` (P,) SI, and covariates already checked
(:class:`~volerr_pin.model.terms.Covariates` for N points). They check nothing:
:class:`~volerr_pin.model.machine.Machine` is the checked front end, whose methods check their inputs
once and call these; code inside the library that holds checked arrays calls them directly.
Every evaluation runs in blocks of ``asm.block`` points (bounded memory for millions).

The derivatives are exact: Jacobians of the tool frame relative to the workpiece frame along
the same flattened chain as the error (checked against Pinocchio's frame Jacobians), chained
with the derivatives of the error terms; rotation rows of error derivatives include the
inverse left Jacobian of the rotation-vector error.
"""

from __future__ import annotations

import numpy as np

from . import kinematics as K
from .assembly import Assembly, axis_values, context, error_jacobian, joint_values, parameter_jacobian
from .terms import Covariates

__all__ = ["axis_jacobian", "component_sensitivity", "error_joint_sensitivity", "joint_jacobian",
           "pinocchio_configuration", "sensitivity", "tool_poses", "volumetric_error"]


def volumetric_error(asm: Assembly, q: np.ndarray, theta: np.ndarray, cov: Covariates,
                     order: int | None = None) -> np.ndarray:
    """Pose error of the tool point relative to the workpiece, in the workpiece frame.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates
        The covariates of the N points.
    order : None or 1
        None: exact; 1: first order (linearised in the errors).

    Returns
    -------
    ndarray, shape (N, 6)
        dx, dy, dz [m], rx, ry, rz [rad]: actual minus nominal.
    """
    out = np.empty((q.shape[0], 6))
    buffer = np.empty((asm.model.nv, min(asm.block, q.shape[0])))
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        values = joint_values(asm, q[rows], theta, cov.take(rows), out=buffer)
        K.pose_error(asm.chain, values, order, out=out[rows])
    return out


def tool_poses(asm: Assembly, q: np.ndarray, theta: np.ndarray | None, cov: Covariates | None,
               nominal: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Poses of the tool frame in the workpiece frame, actual or nominal.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,), or None
        Coefficients (SI); not read when ``nominal``.
    cov : Covariates or None
        The covariates of the N points; not read when ``nominal``.
    nominal : bool, default False
        The nominal pose (every error joint at zero).

    Returns
    -------
    R : ndarray, shape (N, 3, 3)
        Rotations of the tool frame in the workpiece frame.
    p : ndarray, shape (N, 3)
        Positions of the tool frame's origin in the workpiece frame [m].
    """
    if nominal:
        return K.relative_poses(asm.chain, axis_values(asm, q), with_errors=False)
    return K.relative_poses(asm.chain, joint_values(asm, q, theta, cov), with_errors=True)


def pinocchio_configuration(asm: Assembly, q: np.ndarray, theta: np.ndarray, cov: Covariates) -> np.ndarray:
    """Configurations of the assembled Pinocchio model at the points ``q``.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates
        The covariates of the N points.

    Returns
    -------
    ndarray, shape (N, nq)
        Pinocchio configuration vectors (cos, sin pairs for continuous joints).
    """
    return K.pinocchio_configuration(asm.model, joint_values(asm, q, theta, cov).T)


def sensitivity(asm: Assembly, q: np.ndarray, theta: np.ndarray, cov: Covariates, cols: np.ndarray | None = None,
                first_order: bool = False) -> np.ndarray:
    """Derivative of the error with respect to the coefficients.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI) at which to differentiate.
    cov : Covariates
        The covariates of the N points.
    cols : ndarray of int, shape (P',), optional
        Indices of the coefficients to differentiate by, in that order; default all.
    first_order : bool, default False
        Take the kinematics at zero error (the derivative of the first-order model).

    Returns
    -------
    ndarray, shape (N, 6, P')
        d error / d theta (rows dx, dy, dz, rx, ry, rz).
    """
    cols = np.arange(len(asm.names)) if cols is None else cols
    out = np.empty((q.shape[0], 6, len(cols)))
    param_column = np.ascontiguousarray(asm.param_column[cols])
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        qb, cb = q[rows], cov.take(rows)
        values = axis_values(asm, qb) if first_order else joint_values(asm, qb, theta, cb)
        # d v / d theta is one joint column per coefficient, scaled by the term's basis
        K.error_sensitivity(asm.chain, values, parameter_jacobian(asm, qb, theta, cb), param_column, out=out[rows],
                            columns=cols)
    return out


def component_sensitivity(asm: Assembly, q: np.ndarray, theta: np.ndarray, cov: Covariates) -> np.ndarray:
    """Derivative of the error with respect to each component error's value at the point.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates
        The covariates of the N points.

    Returns
    -------
    ndarray, shape (N, 6, n_components)
        Error per m or rad of each component, in the order of ``asm.components``.
    """
    out = np.empty((q.shape[0], 6, len(asm.components)))
    cols = np.array([c.column for c in asm.components], dtype=int)
    signs = np.array([c.chain_sign for c in asm.components])
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        J = error_jacobian(asm, joint_values(asm, q[rows], theta, cov.take(rows)))
        out[rows] = J[:, :, cols] * signs
    return out


def error_joint_sensitivity(asm: Assembly, q: np.ndarray, theta: np.ndarray, cov: Covariates,
                            first_order: bool = False) -> np.ndarray:
    """Derivative of the error with respect to the value of every error joint of the spec.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI); not read when ``first_order``.
    cov : Covariates
        The covariates of the N points; not read when ``first_order``.
    first_order : bool, default False
        Evaluate at zero error.

    Returns
    -------
    ndarray, shape (N, 6, n_error_joints)
        Error per m or rad of each error joint, in the order of ``asm.sites``, ISO sense.
    """
    out = np.empty((q.shape[0], 6, len(asm.error_joint_cols)))
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        values = (axis_values(asm, q[rows]) if first_order
                  else joint_values(asm, q[rows], theta, cov.take(rows)))
        J = error_jacobian(asm, values)
        out[rows] = J[:, :, asm.error_joint_cols] * asm.error_joint_signs
    return out


def axis_jacobian(asm: Assembly, q: np.ndarray, theta: np.ndarray, cov: Covariates,
                  nominal: bool = False) -> np.ndarray:
    """Derivative of the tool pose relative to the workpiece with respect to the NC positions.

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI); not read when ``nominal``.
    cov : Covariates
        The covariates of the N points; not read when ``nominal``.
    nominal : bool, default False
        Ignore the errors; the actual Jacobian includes the position derivatives of the terms.

    Returns
    -------
    ndarray, shape (N, 6, n_axes)
        Rows 0-2 the tool point's displacement [m per m or rad], rows 3-5 the rotation
        (angular velocity, workpiece axes) [rad per m or rad].
    """
    out = np.empty((q.shape[0], 6, len(asm.axis_cols)))
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        qb, cb = q[rows], cov.take(rows)
        values = axis_values(asm, qb) if nominal else joint_values(asm, qb, theta, cb)
        J = K.joint_jacobian(asm.chain, values, asm.model.nv, nominal=nominal)
        block = J[:, :, asm.axis_cols] * asm.axis_signs
        if not nominal:
            for comp in asm.components:
                if comp.axis_index is None:
                    continue
                ctx = context(asm, comp, qb, cb)
                slope = sum(tspec.term.position_slope(theta[span], ctx) for tspec, span in comp.terms)
                block[:, :, comp.axis_index] += comp.chain_sign * J[:, :, comp.column] * slope[:, None]
        out[rows] = block
    return out


def joint_jacobian(asm: Assembly, q: np.ndarray, theta: np.ndarray, cov: Covariates) -> np.ndarray:
    """Derivative of the tool pose with respect to the values of all Pinocchio joints, as
    Pinocchio's frame Jacobians give it (point and angular velocity, workpiece axes).

    Parameters
    ----------
    asm : Assembly
        The assembled model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates
        The covariates of the N points.

    Returns
    -------
    ndarray, shape (N, 6, nv)
        Rows 0-2 [m per m or rad of the joint], rows 3-5 [rad per m or rad]; columns in
        Pinocchio's velocity-space order.
    """
    return K.joint_jacobian(asm.chain, joint_values(asm, q, theta, cov), asm.model.nv)
