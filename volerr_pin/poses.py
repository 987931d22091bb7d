"""Poses at NC positions: the joint values of every Pinocchio joint, the tool frame's pose in
the workpiece frame (actual or nominal), and Pinocchio configurations, for the machine's or
other coefficients.

Each function takes the machine first and is also its method (``m.tool_poses(q)`` is
``tool_poses(m, q)``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import assembly
from . import kinematics as K

if TYPE_CHECKING:  # the machine imports this module; its type is only named here
    from .machine import Machine

__all__ = ["joint_values", "pinocchio_configuration", "tool_poses"]


def joint_values(machine: "Machine", q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
    """Values of all Pinocchio joints (axes and error joints) at ``q``.

    An axis joint takes ``sign * q``; an error joint the value of its component error on the
    tool chain and its negative on the workpiece chain (see :mod:`volerr_pin.assembly`).

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
    ndarray, shape (N, nv)
        Joint values [m, rad], columns in Pinocchio's velocity-space order (``model.idx_vs``).

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    q, theta, cov = machine.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
    return assembly.joint_values(machine.assembly, q, theta, cov).T


def tool_poses(machine: "Machine", q, theta=None, *, nominal: bool = False, extrapolate: bool = False,
               **covariates) -> tuple[np.ndarray, np.ndarray]:
    """Poses of the tool frame in the workpiece frame, actual (default) or nominal.

    Parameters
    ----------
    machine : Machine
        The machine (``self`` of the method).
    q : array_like, shape (N, n_axes) or (n_axes,)
        NC positions [m, rad] (a single point gives N = 1).
    theta : array_like, shape (P,), optional
        Coefficients (SI); defaults to the machine's. Ignored when ``nominal``.
    nominal : bool, default False
        The nominal pose (every error joint at zero), which needs no covariates.
    extrapolate : bool, default False
        Allow positions outside the travel.
    **covariates
        As for :meth:`~volerr_pin.machine.Machine.volumetric_error`; ignored when ``nominal``.

    Returns
    -------
    R : ndarray, shape (N, 3, 3)
        Rotations of the tool frame in the workpiece frame.
    p : ndarray, shape (N, 3)
        Positions of the tool frame's origin in the workpiece frame [m].

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    if nominal:
        values = assembly.axis_values(machine.assembly, machine.check_q(q, extrapolate))
        return K.relative_poses(machine.assembly.chain, values, with_errors=False)
    values = machine.joint_values(q, theta, extrapolate=extrapolate, **covariates)
    return K.relative_poses(machine.assembly.chain, values.T, with_errors=True)


def pinocchio_configuration(machine: "Machine", q, theta=None, *, extrapolate: bool = False,
                            **covariates) -> np.ndarray:
    """Configurations of the machine's Pinocchio model for the points ``q``.

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
    ndarray, shape (N, nq)
        Pinocchio configuration vectors (cos, sin pairs for continuous joints).

    Raises
    ------
    InputError
        For invalid ``q``, ``theta`` or covariates.
    """
    values = machine.joint_values(q, theta, extrapolate=extrapolate, **covariates)
    return K.pinocchio_configuration(machine.assembly.model, values)
