"""The algorithms of the model, as free functions of a :class:`~volerr_pin.model.Model` in
Pinocchio's style: ``volumetric_error(model, q, theta, cov)``.

Every layer that evaluates a machine in a loop calls these. They trust their inputs' values
and check only their sizes, once at the door, in O(1) (as Pinocchio's
``PINOCCHIO_CHECK_ARGUMENT_SIZE``):

- ``q``: a float array of shape (N, n_axes) of NC positions [m, rad], within what the model
  may evaluate (the travel unless the caller allows extrapolation);
- ``theta``: coefficients, shape (P,), SI;
- ``cov``: the :class:`~volerr_pin.model.Covariates` of the N points, or None when the model
  reads none.

Values a user gives are checked once where they enter (:func:`~volerr_pin.model.check_inputs`,
which :class:`~volerr_pin.model.Machine` calls). Every evaluation runs in blocks of
``model.block`` points, so millions of points take bounded work memory; ``out=`` takes a
buffer to fill where a loop reuses one.

Derivatives are exact: Jacobians of the tool frame relative to the workpiece frame along the
same flattened chain as the error (checked against Pinocchio's frame Jacobians), chained with
the derivatives of the error terms; the rotation rows of error derivatives include the inverse
left Jacobian of the rotation-vector error.
"""

from __future__ import annotations

import numpy as np

from . import _kinematics as K
from ..base import InputError
from ._model import ComponentSite, Model
from ._terms import Context, Covariates

__all__ = ["axis_jacobian", "component_sensitivity", "component_values", "error_joint_sensitivity", "joint_jacobian",
           "joint_values", "parameter_jacobian", "pinocchio_configuration", "search_grid", "sensitivity", "tool_poses",
           "volumetric_error"]


# ----------------------------------------------------------------------------- the door
def _door(model: Model, q, theta=None, cov=None, *, theta_needed: bool = True) -> Covariates:
    """Sizes only, O(1): ``q`` (N, n_axes), ``theta`` (P,) when needed, ``cov`` of N points
    (None: no covariates). Returns the covariates to use."""
    n_axes = len(model.axis_cols)
    if not isinstance(q, np.ndarray) or q.ndim != 2 or q.shape[1] != n_axes:
        raise InputError(f"q must be an array of shape (N, {n_axes}), got "
                         f"{q.shape if isinstance(q, np.ndarray) else type(q).__name__}", parameters=("q",))
    if theta_needed and (not isinstance(theta, np.ndarray) or theta.shape != (len(model.names),)):
        raise InputError(f"theta must be an array of shape ({len(model.names)},), got "
                         f"{theta.shape if isinstance(theta, np.ndarray) else type(theta).__name__}",
                         parameters=("theta",))
    if cov is None:
        return Covariates(q.shape[0])
    if cov.n != q.shape[0]:
        raise InputError(f"cov holds {cov.n} points, q {q.shape[0]}", parameters=("cov",))
    return cov


def _out(out: np.ndarray | None, shape: tuple) -> np.ndarray:
    """``out`` checked against ``shape`` (a new array when None)."""
    if out is None:
        return np.empty(shape)
    if not isinstance(out, np.ndarray) or out.shape != shape:
        raise InputError(f"out must be an array of shape {shape}, got "
                         f"{out.shape if isinstance(out, np.ndarray) else type(out).__name__}", parameters=("out",))
    return out


def _blocks(model: Model, n: int):
    """The slices of ``model.block`` points that every evaluation runs in."""
    return (slice(start, start + model.block) for start in range(0, n, model.block))


# ----------------------------------------------------------------------------- values at points
def _context(model: Model, comp: ComponentSite, q: np.ndarray, cov: Covariates) -> Context:
    """Where a component's terms are evaluated: its axis' positions and travel, the covariates."""
    if comp.axis_index is None:
        return Context(None, None, cov, None, comp.name)
    return Context(q[:, comp.axis_index], tuple(model.travel[comp.axis_index]), cov, comp.axis_index, comp.name)


def _axis_values(model: Model, q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Joint values (nv, N) with every error joint at zero, points contiguous (the kernels'
    layout); ``out`` (nv, >= N) a buffer to reuse."""
    if out is None:
        values = np.zeros((model.nv, q.shape[0]))
    else:
        values = out[:, :q.shape[0]]
        values[...] = 0.0
    values[model.axis_cols] = (q * model.axis_signs).T
    return values


def _component_values(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates,
                      without_covariates: bool = False) -> np.ndarray:
    """The component errors' values (n_components, N)."""
    out = np.zeros((len(model.components), q.shape[0]))
    for k, comp in enumerate(model.components):
        ctx = _context(model, comp, q, cov)
        for tspec, span in comp.terms:
            if without_covariates and tspec.term.covariates:
                continue
            out[k] += tspec.term.value(theta[span], ctx)
    return out


def _joint_values(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates,
                  out: np.ndarray | None = None) -> np.ndarray:
    """Joint values (nv, N): axes at ``sign * q``, error joints at their components' values
    (negated on the workpiece chain)."""
    values = _axis_values(model, q, out)
    components = _component_values(model, q, theta, cov)
    for k, comp in enumerate(model.components):
        values[comp.column] += comp.chain_sign * components[k]
    return values


def _parameter_jacobian(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates) -> np.ndarray:
    """d (error-joint value) / d theta (N, P): the chain sign times the term's derivative."""
    out = np.empty((q.shape[0], len(model.names)))
    for comp in model.components:
        ctx = _context(model, comp, q, cov)
        for tspec, span in comp.terms:
            out[:, span] = comp.chain_sign * tspec.term.jacobian(theta[span], ctx)
    return out


def _error_jacobian(model: Model, values: np.ndarray) -> np.ndarray:
    """d error / d joint values (N, 6, nv): position rows as they are, rotation rows through
    the inverse left Jacobian of the rotation error."""
    J = K.joint_jacobian(model.chain, values, model.nv)
    phi = K.pose_error(model.chain, values, None)[:, 3:]
    J[:, 3:] = K.log3_left_jacobian_inverse(phi) @ J[:, 3:]
    return J


def component_values(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates | None = None, *,
                     without_covariates: bool = False) -> np.ndarray:
    """The values of the component errors, as motions of the tool relative to the workpiece.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates, optional
        The points' covariates.
    without_covariates : bool, default False
        Leave out the terms that read covariates.

    Returns
    -------
    ndarray, shape (N, n_components)
        Values [m, rad], columns in the order of ``model.components``.
    """
    cov = _door(model, q, theta, cov)
    return _component_values(model, q, theta, cov, without_covariates).T


def joint_values(model: Model, q: np.ndarray, theta: np.ndarray | None = None,
                 cov: Covariates | None = None) -> np.ndarray:
    """The values of every Pinocchio joint: axes at ``sign * q``, error joints at their
    components' values (negated on the workpiece chain; see :mod:`volerr_pin.model`).

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,), optional
        Coefficients (SI); None: the nominal machine (every error joint at zero).
    cov : Covariates, optional
        The points' covariates (not read when ``theta`` is None).

    Returns
    -------
    ndarray, shape (N, nv)
        Joint values [m, rad], columns in Pinocchio's velocity-space order (``idx_vs``).
    """
    cov = _door(model, q, theta, cov, theta_needed=theta is not None)
    return (_axis_values(model, q) if theta is None else _joint_values(model, q, theta, cov)).T


def parameter_jacobian(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates | None = None) -> np.ndarray:
    """The derivatives of the error joints' values with respect to the coefficients: each
    coefficient moves one joint (``model.param_column``), by its term's derivative times the
    joint's chain sign.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates, optional
        The points' covariates.

    Returns
    -------
    ndarray, shape (N, P)
        [m or rad of the joint per SI unit of the coefficient].
    """
    cov = _door(model, q, theta, cov)
    return _parameter_jacobian(model, q, theta, cov)


def search_grid(model: Model, index: int, theta: np.ndarray, cov: Covariates) -> np.ndarray:
    """Candidate values of a non-linear coefficient (a time constant, a period) for a grid
    search before a fit.

    Parameters
    ----------
    model : Model
        The model.
    index : int
        The coefficient's index in ``theta``.
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates
        The covariates of the points to be fitted (time constants span their times).

    Returns
    -------
    ndarray, shape (G,)
        Values in the coefficient's SI unit (empty for one without a grid, such as a linear one).
    """
    for comp in model.components:
        for tspec, span in comp.terms:
            if span.start <= index < span.stop:
                return tspec.term.search_grid(tspec.term.local_names[index - span.start], theta[span], cov)
    raise InputError(f"no coefficient with index {index}", parameters=("index",))


# ----------------------------------------------------------------------------- poses and errors
def volumetric_error(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates | None = None, *,
                     order: int | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """The pose error of the tool point relative to the workpiece, in the workpiece frame:
    actual minus nominal.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates, optional
        The points' covariates.
    order : None or 1
        None: exact (the rotation part is the rotation vector of ``R_act R_nom^T``); 1: first
        order (linearised in the errors).
    out : ndarray, shape (N, 6), optional
        Filled and returned.

    Returns
    -------
    ndarray, shape (N, 6)
        dx, dy, dz [m], rx, ry, rz [rad].
    """
    cov = _door(model, q, theta, cov)
    if order not in (None, 1):
        raise InputError(f"order must be None (exact) or 1 (first order), got {order!r}", parameters=("order",))
    out = _out(out, (q.shape[0], 6))
    buffer = np.empty((model.nv, min(model.block, q.shape[0])))
    for rows in _blocks(model, q.shape[0]):
        values = _joint_values(model, q[rows], theta, cov.take(rows), out=buffer)
        K.pose_error(model.chain, values, order, out=out[rows])
    return out


def tool_poses(model: Model, q: np.ndarray, theta: np.ndarray | None = None, cov: Covariates | None = None, *,
               nominal: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The poses of the tool frame in the workpiece frame, actual or nominal.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,), optional
        Coefficients (SI); not read (and not needed) when ``nominal``.
    cov : Covariates, optional
        The points' covariates; not read when ``nominal``.
    nominal : bool, default False
        The nominal pose (every error joint at zero).

    Returns
    -------
    R : ndarray, shape (N, 3, 3)
        Rotations of the tool frame in the workpiece frame.
    p : ndarray, shape (N, 3)
        Positions of the tool frame's origin in the workpiece frame [m].
    """
    cov = _door(model, q, theta, cov, theta_needed=not nominal)
    R, p = np.empty((q.shape[0], 3, 3)), np.empty((q.shape[0], 3))
    buffer = np.empty((model.nv, min(model.block, q.shape[0])))
    for rows in _blocks(model, q.shape[0]):
        values = (_axis_values(model, q[rows], buffer) if nominal
                  else _joint_values(model, q[rows], theta, cov.take(rows), out=buffer))
        R[rows], p[rows] = K.relative_poses(model.chain, values, with_errors=not nominal)
    return R, p


def pinocchio_configuration(model: Model, q: np.ndarray, theta: np.ndarray | None = None,
                            cov: Covariates | None = None) -> np.ndarray:
    """The configurations of the model's Pinocchio model at the points.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,), optional
        Coefficients (SI); None: the nominal machine (every error joint at zero).
    cov : Covariates, optional
        The points' covariates (not read when ``theta`` is None).

    Returns
    -------
    ndarray, shape (N, nq)
        Pinocchio configuration vectors (cos, sin pairs for continuous joints).
    """
    cov = _door(model, q, theta, cov, theta_needed=theta is not None)
    values = _axis_values(model, q) if theta is None else _joint_values(model, q, theta, cov)
    return K.pinocchio_configuration(model.pinocchio, values.T)


# ----------------------------------------------------------------------------- derivatives
def sensitivity(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates | None = None, *,
                columns: np.ndarray | None = None, first_order: bool = False,
                out: np.ndarray | None = None) -> np.ndarray:
    """The derivative of the error with respect to the coefficients.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI) at which to differentiate.
    cov : Covariates, optional
        The points' covariates.
    columns : ndarray of int, shape (P',), optional
        Indices of the coefficients to differentiate by, in that order; default all.
    first_order : bool, default False
        Take the kinematics at zero error (the derivative of the first-order model).
    out : ndarray, shape (N, 6, P'), optional
        Filled and returned.

    Returns
    -------
    ndarray, shape (N, 6, P')
        [m or rad of error per SI unit of the coefficient], rows dx, dy, dz, rx, ry, rz.
    """
    cov = _door(model, q, theta, cov)
    columns = np.arange(len(model.names)) if columns is None else columns
    out = _out(out, (q.shape[0], 6, len(columns)))
    param_column = np.ascontiguousarray(model.param_column[columns])
    for rows in _blocks(model, q.shape[0]):
        qb, cb = q[rows], cov.take(rows)
        values = _axis_values(model, qb) if first_order else _joint_values(model, qb, theta, cb)
        # d v / d theta is one joint column per coefficient, scaled by the term's basis
        K.error_sensitivity(model.chain, values, _parameter_jacobian(model, qb, theta, cb), param_column,
                            out=out[rows], columns=columns)
    return out


def component_sensitivity(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates | None = None, *,
                          out: np.ndarray | None = None) -> np.ndarray:
    """The derivative of the error with respect to each component error's value at the point.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates, optional
        The points' covariates.
    out : ndarray, shape (N, 6, n_components), optional
        Filled and returned.

    Returns
    -------
    ndarray, shape (N, 6, n_components)
        Error per m or rad of each component, in the order of ``model.components``.
    """
    cov = _door(model, q, theta, cov)
    out = _out(out, (q.shape[0], 6, len(model.components)))
    cols = np.array([c.column for c in model.components], dtype=int)
    signs = np.array([c.chain_sign for c in model.components])
    for rows in _blocks(model, q.shape[0]):
        J = _error_jacobian(model, _joint_values(model, q[rows], theta, cov.take(rows)))
        out[rows] = J[:, :, cols] * signs
    return out


def error_joint_sensitivity(model: Model, q: np.ndarray, theta: np.ndarray | None = None,
                            cov: Covariates | None = None, *, first_order: bool = False,
                            out: np.ndarray | None = None) -> np.ndarray:
    """The derivative of the error with respect to the value of every error joint of the
    spec's sites, whether or not a term drives it: what adding a term anywhere would do.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,), optional
        Coefficients (SI); not read (and not needed) when ``first_order``.
    cov : Covariates, optional
        The points' covariates; not read when ``first_order``.
    first_order : bool, default False
        Evaluate at zero error.
    out : ndarray, shape (N, 6, n_error_joints), optional
        Filled and returned.

    Returns
    -------
    ndarray, shape (N, 6, n_error_joints)
        Error per m or rad of each error joint, in the order of ``model.error_joints``, ISO sense.
    """
    cov = _door(model, q, theta, cov, theta_needed=not first_order)
    out = _out(out, (q.shape[0], 6, len(model.error_joint_cols)))
    for rows in _blocks(model, q.shape[0]):
        values = (_axis_values(model, q[rows]) if first_order
                  else _joint_values(model, q[rows], theta, cov.take(rows)))
        J = _error_jacobian(model, values)
        out[rows] = J[:, :, model.error_joint_cols] * model.error_joint_signs
    return out


def axis_jacobian(model: Model, q: np.ndarray, theta: np.ndarray | None = None, cov: Covariates | None = None, *,
                  nominal: bool = False, out: np.ndarray | None = None) -> np.ndarray:
    """The derivative of the tool pose relative to the workpiece with respect to the NC positions.

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,), optional
        Coefficients (SI); not read (and not needed) when ``nominal``.
    cov : Covariates, optional
        The points' covariates; not read when ``nominal``.
    nominal : bool, default False
        Ignore the errors; the actual Jacobian includes the position derivatives of the terms.
    out : ndarray, shape (N, 6, n_axes), optional
        Filled and returned.

    Returns
    -------
    ndarray, shape (N, 6, n_axes)
        Rows 0-2 the tool point's displacement [m per m or rad], rows 3-5 the rotation
        (angular velocity, workpiece axes) [rad per m or rad].
    """
    cov = _door(model, q, theta, cov, theta_needed=not nominal)
    out = _out(out, (q.shape[0], 6, len(model.axis_cols)))
    for rows in _blocks(model, q.shape[0]):
        qb, cb = q[rows], cov.take(rows)
        values = _axis_values(model, qb) if nominal else _joint_values(model, qb, theta, cb)
        J = K.joint_jacobian(model.chain, values, model.nv, nominal=nominal)
        block = J[:, :, model.axis_cols] * model.axis_signs
        if not nominal:
            for comp in model.components:
                if comp.axis_index is None:
                    continue
                ctx = _context(model, comp, qb, cb)
                slope = sum(tspec.term.position_slope(theta[span], ctx) for tspec, span in comp.terms)
                block[:, :, comp.axis_index] += comp.chain_sign * J[:, :, comp.column] * slope[:, None]
        out[rows] = block
    return out


def joint_jacobian(model: Model, q: np.ndarray, theta: np.ndarray, cov: Covariates | None = None) -> np.ndarray:
    """The derivative of the tool pose with respect to the values of all Pinocchio joints, as
    Pinocchio's frame Jacobians give it (point and angular velocity, workpiece axes).

    Parameters
    ----------
    model : Model
        The model.
    q : ndarray, shape (N, n_axes)
        NC positions [m, rad].
    theta : ndarray, shape (P,)
        Coefficients (SI).
    cov : Covariates, optional
        The points' covariates.

    Returns
    -------
    ndarray, shape (N, 6, nv)
        Rows 0-2 [m per m or rad of the joint], rows 3-5 [rad per m or rad]; columns in
        Pinocchio's velocity-space order.
    """
    cov = _door(model, q, theta, cov)
    return K.joint_jacobian(model.chain, _joint_values(model, q, theta, cov), model.nv)
