"""Derivatives of a machine's error and pose: with respect to its coefficients, its component
errors, every injected error joint, its NC positions and all of Pinocchio's joints.

Exact: Jacobians of the tool frame relative to the workpiece frame along the same flattened
chain as the error (checked against Pinocchio's frame Jacobians), chained with the
derivatives of the error terms; rotation rows of error derivatives include the inverse left
Jacobian of the rotation-vector error. Evaluated in blocks of points (bounded memory).

Each function takes the machine first and is also its method (``m.sensitivity(q)`` is
``sensitivity(m, q)``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import kinematics as K
from .assembly import axis_values, context, error_jacobian, joint_values, parameter_jacobian
from .checks import one_point
from .errors import InputError

if TYPE_CHECKING:  # the machine imports this module; its type is only named here
    from .machine import Machine

__all__ = ["axis_jacobian", "component_sensitivity", "error_joint_sensitivity", "joint_jacobian",
           "parameter_columns", "sensitivity"]


def parameter_columns(machine: "Machine", parameters) -> np.ndarray:
    """Indices of ``theta`` (all when None), checked: negative indices would wrap.

    Parameters
    ----------
    machine : Machine
        The machine.
    parameters : array_like of int or None
        Indices of coefficients.

    Returns
    -------
    ndarray of int, shape (P',)
        The indices.

    Raises
    ------
    InputError
        Naming ``parameters``, for values that are not indices of ``theta``.
    """
    count = len(machine.parameter_names)
    if parameters is None:
        return np.arange(count)
    raw = np.atleast_1d(np.asarray(parameters, dtype=object))
    if raw.ndim != 1 or not all(isinstance(p, (int, np.integer)) and not isinstance(p, bool)
                                and 0 <= p < count for p in raw):
        bad = next((p for p in raw.ravel() if not (isinstance(p, (int, np.integer)) and not isinstance(p, bool)
                                                  and 0 <= p < count)), raw)
        raise InputError(f"parameters must be indices of theta, 0 to {count - 1}, got {bad!r} (an index of "
                         "a name is parameter_names.index(name))", parameters=("parameters",))
    return raw.astype(int)


def sensitivity(machine: "Machine", q, theta=None, *, parameters=None, first_order: bool = False,
                extrapolate: bool = False, **covariates) -> np.ndarray:
    """Derivative of :meth:`~volerr_pin.machine.Machine.volumetric_error` with respect to the
    coefficients ``theta``.

    Exact: Jacobians of the tool frame relative to the workpiece frame (the same chain
    as the error, checked against Pinocchio's frame Jacobians), chained with the
    derivatives of the error terms; the rotation rows include the inverse left
    Jacobian of the rotation-vector error.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad] (a single point gives a (6, P') result).
    theta : array_like, shape (P,), optional
        Coefficients (SI) at which to differentiate; defaults to the machine's.
    parameters : array_like of int, shape (P',), optional
        Indices of the coefficients to differentiate by, in that order; default all (P' = P).
    first_order : bool, default False
        Take the kinematics at zero error (the derivative of the first-order model), where
        dependencies between coefficients are exact.
    extrapolate : bool, default False
        Allow positions outside the travel.
    **covariates
        As for :meth:`~volerr_pin.machine.Machine.volumetric_error`.

    Returns
    -------
    ndarray, shape (N, 6, P') or (6, P')
        d error / d theta: m or rad of error per SI unit of the coefficient; rows dx, dy, dz,
        rx, ry, rz.

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates, or ``parameters`` that are not indices of
        ``theta``.
    """
    single = one_point(q)
    cols = parameter_columns(machine, parameters)
    asm = machine.assembly
    q, theta, cov = machine.check_inputs(q, theta, extrapolate=extrapolate, columns=len(cols), **covariates)
    out = np.empty((q.shape[0], 6, len(cols)))
    param_column = np.ascontiguousarray(asm.param_column[cols])
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        qb, cb = q[rows], cov.take(rows)
        values = axis_values(asm, qb) if first_order else joint_values(asm, qb, theta, cb)
        # d v / d theta is one joint column per coefficient, scaled by the term's basis
        K.error_sensitivity(asm.chain, values, parameter_jacobian(asm, qb, theta, cb), param_column, out=out[rows],
                            columns=cols)
    return out[0] if single else out


def component_sensitivity(machine: "Machine", q, theta=None, *, extrapolate: bool = False,
                          **covariates) -> np.ndarray:
    """Derivative of the error with respect to each component error's value at the point.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad] (a single point gives a (6, n_components) result).
    theta : array_like, shape (P,), optional
        Coefficients (SI); defaults to the machine's.
    extrapolate : bool, default False
        Allow positions outside the travel.
    **covariates
        As for :meth:`~volerr_pin.machine.Machine.volumetric_error`.

    Returns
    -------
    ndarray, shape (N, 6, n_components) or (6, n_components)
        Error (dx, dy, dz [m], rx, ry, rz [rad]) per m or rad of each component, in the order
        of :attr:`~volerr_pin.machine.Machine.components`.

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    single = one_point(q)
    asm = machine.assembly
    q, theta, cov = machine.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
    out = np.empty((q.shape[0], 6, len(asm.components)))
    cols = np.array([c.column for c in asm.components], dtype=int)
    signs = np.array([c.chain_sign for c in asm.components])
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        J = error_jacobian(asm, joint_values(asm, q[rows], theta, cov.take(rows)))
        out[rows] = J[:, :, cols] * signs
    return out[0] if single else out


def error_joint_sensitivity(machine: "Machine", q, theta=None, *, first_order: bool = False,
                            extrapolate: bool = False, **covariates) -> np.ndarray:
    """Derivative of the error with respect to the value of every injected error joint.

    In the order of :attr:`~volerr_pin.machine.Machine.error_joints`, ISO sense, whether or
    not the spec gives the joint a term: what adding a term to any component would do.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad] (a single point gives a (6, n_error_joints) result).
    theta : array_like, shape (P,), optional
        Coefficients (SI); defaults to the machine's.
    first_order : bool, default False
        Evaluate at zero error.
    extrapolate : bool, default False
        Allow positions outside the travel.
    **covariates
        As for :meth:`~volerr_pin.machine.Machine.volumetric_error`.

    Returns
    -------
    ndarray, shape (N, 6, n_error_joints) or (6, n_error_joints)
        Error (dx, dy, dz [m], rx, ry, rz [rad]) per m or rad of each error joint.

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    single = one_point(q)
    asm = machine.assembly
    q, theta, cov = machine.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
    out = np.empty((q.shape[0], 6, len(asm.error_joint_cols)))
    for start in range(0, q.shape[0], asm.block):
        rows = slice(start, start + asm.block)
        values = (axis_values(asm, q[rows]) if first_order
                  else joint_values(asm, q[rows], theta, cov.take(rows)))
        J = error_jacobian(asm, values)
        out[rows] = J[:, :, asm.error_joint_cols] * asm.error_joint_signs
    return out[0] if single else out


def axis_jacobian(machine: "Machine", q, theta=None, *, nominal: bool = False, extrapolate: bool = False,
                  **covariates) -> np.ndarray:
    """Derivative of the tool pose relative to the workpiece with respect to the NC positions.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad] (a single point gives a (6, n_axes) result).
    theta : array_like, shape (P,), optional
        Coefficients (SI); defaults to the machine's.
    nominal : bool, default False
        Ignore the errors. The actual Jacobian (default) includes the position derivatives
        of the error terms.
    extrapolate : bool, default False
        Allow positions outside the travel.
    **covariates
        As for :meth:`~volerr_pin.machine.Machine.volumetric_error`.

    Returns
    -------
    ndarray, shape (N, 6, n_axes) or (6, n_axes)
        Rows 0-2 the tool point's displacement [m per m or rad], rows 3-5 the rotation
        (angular velocity, workpiece axes) [rad per m or rad].

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    single = one_point(q)
    asm = machine.assembly
    q, theta, cov = machine.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
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
    return out[0] if single else out


def joint_jacobian(machine: "Machine", q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
    """Derivative of the tool pose with respect to the values of all Pinocchio joints.

    As Pinocchio's frame Jacobians give it: point velocity and angular velocity of the tool,
    in workpiece axes.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad] (a single point gives N = 1).
    theta : array_like, shape (P,), optional
        Coefficients (SI); defaults to the machine's.
    extrapolate : bool, default False
        Allow positions outside the travel.
    **covariates
        As for :meth:`~volerr_pin.machine.Machine.volumetric_error`.

    Returns
    -------
    ndarray, shape (N, 6, nv)
        Rows 0-2 [m per m or rad of the joint], rows 3-5 [rad per m or rad]; columns in
        Pinocchio's velocity-space order.

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    values = machine.joint_values(q, theta, extrapolate=extrapolate, **covariates)
    return K.joint_jacobian(machine.assembly.chain, values.T, machine.assembly.model.nv)
