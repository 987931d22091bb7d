"""The machine: URDF + error spec -> Pinocchio model with error joints -> volumetric error.

:class:`Machine` is the assembled model (:mod:`volerr_pin.model.assembly`) with coefficient values
and a state (:mod:`volerr_pin.model.state`); it evaluates the error and the tool pose at NC positions.
It is the checked front end of the model core: each evaluation and derivative checks its
inputs once (:mod:`volerr_pin.model.inputs`, :mod:`volerr_pin.model.state`) and calls the trusted,
batched free functions of :mod:`volerr_pin.model.evaluate` on the assembled model.
"""

from __future__ import annotations

import difflib
import os
from pathlib import Path
from typing import Mapping

import numpy as np
import pinocchio as pin

from . import evaluate, inputs
from . import state as states
from .assembly import Assembly, assemble, component_values, joint_values
from ..base.checks import one_point
from ..base.errors import InputError, SpecError
from .spec import MachineSpec, load_spec, spec_from_urdf
from .terms import Covariates
from .urdf import URDF, load_urdf, package_folders
from .catalog import SPEC_FILE, bundled_machines, machines_dir

__all__ = ["SPEC_FILE", "Machine", "bundled_machines", "load_machine", "machines_dir"]

class Machine:
    """A machine tool (or robot) with error joints on every axis.

    Immutable: ``theta`` returns a copy, :meth:`with_theta` returns a new machine.
    Build it with :func:`load_machine`.

    The constructor assembles the model (:func:`volerr_pin.model.assembly.assemble`): it injects six
    error joints per error site, builds the Pinocchio model of the injected URDF and flattens
    it into the relative chain from the workpiece frame to the tool frame.

    Everything is SI: NC positions ``q`` in m (linear axes) and rad (rotary axes), errors in m
    and rad, coefficients ``theta`` in the SI unit of each coefficient, covariates in s, degC,
    N and +1/-1.

    Parameters
    ----------
    spec : MachineSpec
        The error specification: axes, bodies, tool and workpiece frames, components and
        their terms with their coefficient values.
    urdf : URDF
        The nominal URDF the spec refers to.
    package_dirs : path or iterable of path, optional
        Folders of the ``package://`` packages whose meshes pictures of the machine may read
        (see :func:`volerr_pin.model.urdf.package_folders`), besides the package a spec names its URDF
        by (``urdf = {package = ...}``); the model itself reads no mesh.

    Raises
    ------
    SpecError
        If an injected joint or link name already exists in the URDF, the tool or workpiece
        frame is not in the model, a joint between them is not 1-DoF, or an axis, error site
        or component does not lie between the workpiece frame and the tool frame.
    URDFError
        If a ``<mimic>`` joint lies between the workpiece and the tool frames, the model would
        have more than :data:`~volerr_pin.model.urdf.MAX_MODEL_JOINTS` joints with its error joints,
        or Pinocchio cannot build the model.
    InputError
        If a folder of ``package_dirs`` does not exist.
    """

    def __init__(self, spec: MachineSpec, urdf: URDF, *, package_dirs=()):
        self._asm = assemble(spec, urdf, package_dirs)
        self._theta = self._asm.theta
        self._state: dict = {}

    def _edited(self, spec: MachineSpec) -> "Machine":
        """A machine of ``spec`` (an edit of this one's components) on the same URDF: its
        coefficients laid out again on a Pinocchio model and chain this one's edits share
        (:func:`~volerr_pin.model.assembly.assemble` with ``like``); no state, the spec's coefficient
        values."""
        other = object.__new__(Machine)
        other._asm = assemble(spec, self._asm.urdf, self._asm.package_dirs, like=self._asm)
        other._theta = other._asm.theta
        other._state = {}
        return other

    @property
    def assembly(self) -> Assembly:
        """The assembled model (:class:`~volerr_pin.model.assembly.Assembly`): error sites, Pinocchio
        model, flattened chain, where each coefficient acts; shared by every copy."""
        return self._asm

    # ------------------------------------------------------------------ description
    @property
    def name(self) -> str:
        """The machine's name, from its spec (str)."""
        return self._asm.spec.name

    @property
    def spec(self) -> MachineSpec:
        """The error specification (:class:`~volerr_pin.model.spec.MachineSpec`) the machine was built from."""
        return self._asm.spec

    @property
    def axes(self) -> tuple[str, ...]:
        """Axis names in the order of the columns of ``q`` (tuple of str)."""
        return self._asm.axes

    @property
    def axis_kinds(self) -> tuple[str, ...]:
        """Kind of each axis, "linear" (a prismatic joint, SI unit m) or "rotary" (SI unit rad)."""
        return self._asm.axis_kinds

    @property
    def travel(self) -> np.ndarray:
        """Lower and upper NC travel of each axis, ndarray of shape (n_axes, 2) [m, rad], a copy.

        From the joint limits and the axis sign; an endless (continuous) axis has one turn,
        (-pi, pi) (:data:`~volerr_pin.model.urdf.ENDLESS_TRAVEL`): positions beyond it are outside the
        travel like any other axis' (wrap them, or pass ``extrapolate=True``).
        """
        return self._asm.travel.copy()

    @property
    def mid_travel(self) -> np.ndarray:
        """The middle of each axis' travel, ndarray of shape (n_axes,) [m, rad] (0 for an endless axis)."""
        t = self._asm.travel
        return np.where(np.isfinite(t).all(axis=1), t.mean(axis=1), 0.0)

    @property
    def package_dirs(self) -> tuple[Path, ...]:
        """Folders of ``package://`` packages whose meshes pictures of the machine may read
        (tuple of Path, resolved): those given to :func:`load_machine` and the package a spec
        names its URDF by."""
        return self._asm.package_dirs

    @property
    def chains(self) -> dict[str, tuple[str, ...]]:
        """Axes carried by the tool chain and by the workpiece chain.

        A dict ``{"tool": (axis names), "workpiece": (axis names)}``, each in the order of :attr:`axes`.
        """
        return {
            "tool": tuple(a for a, s in zip(self.axes, self._asm.axis_chain) if s > 0),
            "workpiece": tuple(a for a, s in zip(self.axes, self._asm.axis_chain) if s < 0),
        }

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the coefficients ``theta`` (e.g. ``EXX.c2``), in order; tuple of P str."""
        return self._asm.names

    @property
    def theta_bounds(self) -> np.ndarray:
        """(P, 2) lowest and highest plausible SI value of each coefficient, read-only
        (:func:`~volerr_pin.model.inputs.theta_bounds`)."""
        return inputs.theta_bounds(self._asm)

    @property
    def theta(self) -> np.ndarray:
        """Current coefficient values, ndarray of shape (P,) in the SI unit of each coefficient; a copy."""
        return np.array(self._theta)

    @property
    def components(self) -> tuple[str, ...]:
        """Names of the component and location errors that have terms (tuple of str).

        This is the order of the columns of :meth:`component_values` and :meth:`component_sensitivity`.
        """
        return tuple(c.name for c in self._asm.components)

    @property
    def error_joints(self) -> tuple[str, ...]:
        """Names of all injected error joints (six per site, X, Y, Z, A, B, C), tuple of str."""
        return tuple(n for s in self._asm.sites for n in s.names)

    @property
    def model(self) -> pin.Model:
        """The Pinocchio model with error joints (a copy: the machine is immutable).

        A machine made by editing another (:mod:`volerr_pin.model.specio`) shares that machine's
        model; where an edit added a location error, the model has a location site on every axis
        and body, and the error joints it does not use (not in :attr:`error_joints`) stay at
        zero."""
        return pin.Model(self._asm.model)

    @property
    def tool_frame(self) -> str:
        """Name of the tool frame (str): the error is that of this frame."""
        return self._asm.spec.tool_frame

    @property
    def workpiece_frame(self) -> str:
        """Name of the workpiece frame (str): the error is expressed in this frame."""
        return self._asm.spec.workpiece_frame

    @property
    def urdf(self) -> URDF:
        """The nominal URDF as read (:class:`~volerr_pin.model.urdf.URDF`), without error joints."""
        return self._asm.urdf

    def injected_urdf(self) -> str:
        """The URDF with the error joints, as XML text (those of :attr:`model`).

        Joint values: an axis joint takes ``sign * q``; an error joint takes the error value
        on the tool chain and its negative on the workpiece chain (errors are defined as
        motions of the tool relative to the workpiece).

        Returns
        -------
        str
            The XML document, with declaration, pretty-printed.
        """
        return self._asm.injected.to_string()

    def with_theta(self, theta) -> "Machine":
        """A copy of this machine with other coefficient values.

        Parameters
        ----------
        theta : array_like, shape (P,)
            Coefficient values in the SI unit of each coefficient (order of :attr:`parameter_names`).

        Returns
        -------
        Machine
            A new machine sharing everything else (including a state set by :meth:`with_state`).

        Raises
        ------
        InputError
            If ``theta`` does not have shape (P,), holds a value that is not finite, or one
            beyond the plausibility limits a spec would refuse (:attr:`theta_bounds`).
        """
        return self._with_theta(theta, limits=True)

    def _with_theta(self, theta, limits: bool = False) -> "Machine":
        """:meth:`with_theta`, by default without the plausibility limits: for the steps of a fit,
        which may pass through any value on the way, and for simulated truths."""
        theta = self.check_theta(theta, limits=limits)
        other = object.__new__(Machine)
        other.__dict__.update(self.__dict__)
        other._theta = theta
        other._theta.flags.writeable = False
        return other

    def with_state(self, t: float | None = None, temperatures: Mapping | None = None, forces=None,
                   directions=None) -> "Machine":
        """A copy of this machine held in one state.

        Covariates a call does not give are taken from here for every point. Calls may still
        pass their own. Values given here are merged into a state already set: temperatures by
        sensor, the others replaced.

        Parameters
        ----------
        t : float, optional
            Time [s].
        temperatures : mapping of str to float, optional
            Temperature by sensor name [degC]. An empty mapping changes nothing.
        forces : array_like, shape (3,), optional
            Process force Fx, Fy, Fz [N].
        directions : array_like, shape (n_axes,), optional
            Approach direction of each axis, +1 or -1.

        Returns
        -------
        Machine
            A new machine with the state set (see :attr:`state`).

        Raises
        ------
        InputError
            If a value is not a real number, ``forces`` is not three values, ``directions`` not
            n_axes values of +1 or -1, or a value of the state is not finite.
        """
        other = object.__new__(Machine)
        other.__dict__.update(self.__dict__)
        other._state = states.merge_state(self._state, self.axes, t, temperatures, forces, directions)
        return other

    @property
    def state(self) -> dict:
        """The state set by :meth:`with_state` (empty by default).

        A dict (a copy) with the keys given so far: ``t`` (float, s), ``temperatures`` ({sensor:
        degC}), ``forces`` (ndarray of shape (3,), N), ``directions`` (ndarray of shape (n_axes,)).
        """
        return dict(self._state)

    @property
    def nonlinear_parameters(self) -> tuple[int, ...]:
        """Indices (into theta) of coefficients the model is not linear in (time constants,
        periods); tuple of int.
        """
        return self._asm.nonlinear_parameters

    def search_grid(self, index: int, theta=None, *, n: int, **covariates) -> np.ndarray:
        """Candidate values of a non-linear coefficient for a grid search.

        Parameters
        ----------
        index : int
            Index of the coefficient in ``theta``.
        theta : array_like, shape (P,), optional
            Coefficient values (SI); defaults to :attr:`theta`.
        n : int
            Number of points the covariates describe.
        **covariates
            The points' covariates, as for :meth:`volumetric_error` (e.g. time constants are
            chosen to span the recorded times ``t``).

        Returns
        -------
        ndarray, shape (G,)
            Candidate values in the coefficient's SI unit (empty for a coefficient without a
            grid, such as a linear one).

        Raises
        ------
        InputError
            If no coefficient has the index ``index``, or the covariates are invalid.
        """
        theta = self.check_theta(theta)
        for comp in self._asm.components:
            for tspec, span in comp.terms:
                if span.start <= index < span.stop:
                    cov = self.check_covariates(n, covariates)
                    local = tspec.term.local_names[index - span.start]
                    return tspec.term.search_grid(local, theta[span], cov)
        raise InputError(f"no coefficient with index {index}")

    @property
    def covariates_used(self) -> frozenset[str]:
        """The covariates the model reads (``t``, ``temperatures``, ``forces``, ``directions``);
        a purely geometric machine reads none. ``t`` is included when a term reads lagged
        temperatures. A frozenset of str.
        """
        return self._asm.covariates_used

    @property
    def sensors(self) -> tuple[str, ...]:
        """Names of the temperature sensors the model reads, sorted (a tuple of str; empty for a
        machine without temperature-driven terms)."""
        return self._asm.sensors

    # ------------------------------------------------------------------ checks
    # (volerr_pin.model.inputs and volerr_pin.model.state check, on the assembled model; every evaluation
    # below checks its inputs once and calls the model core, volerr_pin.model.evaluate)

    def outside_travel(self, q: np.ndarray) -> np.ndarray:
        """Where positions leave the travel by more than rounding.

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            NC positions [m, rad] (not converted or checked).

        Returns
        -------
        ndarray of bool, shape (N, n_axes)
            True where ``q`` is below the lower or above the upper travel by more than 1e-9 of the
            span (at least 1e-9 m or rad).
        """
        return inputs.outside_travel(self._asm, q)

    def check_q(self, q, extrapolate: bool = False, columns: int = 0, name: str = "q") -> np.ndarray:
        """Convert ``q`` to a float array of NC positions and check it.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad]; a single point becomes one row.
        extrapolate : bool, default False
            Allow positions outside the travel.
        columns : int, default 0
            Columns of a sensitivity the evaluation returns per point (0 for errors alone): with
            the number of points, what the evaluation will hold, checked against the free memory
            before ``q`` is copied (a broadcast view of a billion points takes one row of memory).
        name : str, default "q"
            The caller's name of the positions (``q_desired``), so that a refusal names what the
            caller was given.

        Returns
        -------
        ndarray, shape (N, n_axes)
            The positions as a new float array [m, rad].

        Raises
        ------
        InputError
            If ``q`` is not real numbers, has the wrong shape, holds a value that is not finite, or
            (unless ``extrapolate``) leaves the travel (see :meth:`outside_travel`), or more
            points than the free memory can evaluate at once.
        """
        return inputs.check_q(self._asm, q, extrapolate, columns, name)

    def check_theta(self, theta, limits: bool = False) -> np.ndarray:
        """Coefficients as a new float array, checked; the machine's own when not given.

        Parameters
        ----------
        theta : array_like, shape (P,) or None
            Coefficients in the SI unit of each (order of ``parameter_names``).
        limits : bool, default False
            Also refuse values beyond the limits a spec would (:func:`~volerr_pin.model.inputs.plausible_theta`).

        Returns
        -------
        ndarray, shape (P,)
            The coefficients.

        Raises
        ------
        InputError
            If ``theta`` does not have shape (P,) or holds a value that is not finite (or, with
            ``limits``, one beyond its plausibility limits).
        """
        return self._theta if theta is None else inputs.check_theta(self._asm, theta, limits)

    def check_covariates(self, n: int, covariates: Mapping) -> Covariates:
        """Check keyword covariates (t, temperatures, forces, directions; see
        :meth:`volumetric_error`).

        Covariates not given are filled in from the state set by
        :meth:`with_state`, and the lagged temperatures that terms read
        (``sensor@<lag>s``) are added.

        Parameters
        ----------
        n : int
            Number of points.
        covariates : mapping
            ``t`` (n,) [s], ``temperatures`` {sensor: (n,)} [degC], ``forces`` (n, 3) [N],
            ``directions`` (n, n_axes) of +1/-1, ``series`` (n,) whole numbers naming the time
            series each point belongs to (the file it came from: a lagged temperature is read
            along its own series only), ``history`` the whole temperature record the points are
            part of (:class:`~volerr_pin.model.terms.TemperatureHistory`); missing or None entries are
            not given.

        Returns
        -------
        Covariates
            The checked covariates as float arrays (SI).

        Raises
        ------
        InputError
            For an unknown covariate, a value that is not numeric, has the wrong shape or is not
            finite, a sensor name containing '@' (reserved for lags), directions other than +1 /
            -1, or a lagged temperature without ``t``.
        """
        return states.check_covariates(self._asm, self._state, n, covariates)

    def check_inputs(self, q, theta=None, *, extrapolate: bool = False, columns: int = 0, **covariates
                     ) -> tuple[np.ndarray, np.ndarray, Covariates]:
        """Check positions, coefficients and covariates at once, as every evaluation does.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad].
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        extrapolate : bool, default False
            Allow positions outside the travel.
        columns : int, default 0
            Columns of a sensitivity the evaluation returns per point (0 for errors alone): with
            the number of points, what the evaluation will hold, checked against the free memory
            before ``q`` is copied (a broadcast view of a billion points is one row in memory).
        **covariates
            As for :meth:`volumetric_error`.

        Returns
        -------
        q : ndarray, shape (N, n_axes)
            The positions (see :meth:`check_q`).
        theta : ndarray, shape (P,)
            The coefficients (the machine's own array when not given: not to be modified).
        covariates : Covariates
            The covariates (see :meth:`check_covariates`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates, or more points than the free memory can
            evaluate at once (see :meth:`check_q`).
        """
        q = self.check_q(q, extrapolate, columns)
        return q, self.check_theta(theta), self.check_covariates(q.shape[0], covariates)

    def joint_values(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """Values of all Pinocchio joints (axes and error joints) at ``q``.

        An axis joint takes ``sign * q``; an error joint the value of its component error on the
        tool chain and its negative on the workpiece chain (see :mod:`volerr_pin.model.assembly`).

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives N = 1).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`.

        Returns
        -------
        ndarray, shape (N, nv)
            Joint values [m, rad], columns in Pinocchio's velocity-space order (``model.idx_vs``).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        return joint_values(self._asm, q, theta, cov).T

    def tool_poses(self, q, theta=None, *, nominal: bool = False, extrapolate: bool = False,
                   **covariates) -> tuple[np.ndarray, np.ndarray]:
        """Poses of the tool frame in the workpiece frame, actual (default) or nominal.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives N = 1).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`. Ignored when ``nominal``.
        nominal : bool, default False
            The nominal pose (every error joint at zero), which needs no covariates.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`; ignored when ``nominal``.

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
            return evaluate.tool_poses(self._asm, self.check_q(q, extrapolate), None, None, nominal=True)
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        return evaluate.tool_poses(self._asm, q, theta, cov)

    def pinocchio_configuration(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """Configurations of the machine's Pinocchio model for the points ``q``.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives N = 1).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`.

        Returns
        -------
        ndarray, shape (N, nq)
            Pinocchio configuration vectors (cos, sin pairs for continuous joints).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        return evaluate.pinocchio_configuration(self._asm, q, theta, cov)

    # ------------------------------------------------------------------ evaluation

    def component_values(self, q, theta=None, *, extrapolate: bool = False, without_covariates: bool = False,
                         **covariates) -> np.ndarray:
        """Values of the component errors at ``q``, as motions of the tool relative to the workpiece.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives N = 1).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        extrapolate : bool, default False
            Allow positions outside the travel.
        without_covariates : bool, default False
            Leave out the terms that read covariates (time, temperature, force, direction), e.g.
            to show the geometry of a machine that has no state; the covariates given are then
            ignored.
        **covariates
            As for :meth:`volumetric_error`.

        Returns
        -------
        ndarray, shape (N, n_components)
            Component error values [m, rad], columns in the order of :attr:`components`.

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates (including covariates a term needs and
            neither the call nor the state gives).
        """
        q = self.check_q(q, extrapolate)
        theta = self.check_theta(theta)
        cov = self.check_covariates(q.shape[0], {} if without_covariates else covariates)
        return component_values(self._asm, q, theta, cov, without_covariates).T

    def volumetric_error(self, q, theta=None, *, order: int | None = None,
                         extrapolate: bool = False, **covariates) -> np.ndarray:
        """Pose error of the tool point relative to the workpiece, in the workpiece frame.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            Commanded NC positions, m for linear and rad for rotary axes (a single
            (n_axes,) point gives a (6,) result).
        theta : array_like, shape (P,), optional
            Coefficients, SI; defaults to :attr:`theta`.
        order : None or 1
            None: exact (rotation part is the rotation vector of R_act R_nom^T);
            1: first-order (linearised in the errors).
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            ``t`` (N,) s, ``temperatures`` {name: (N,)} degC, ``forces`` (N, 3) N,
            ``directions`` (N, n_axes) of +1/-1. Those not given come from :attr:`state`.

        Returns
        -------
        ndarray, shape (N, 6) or (6,)
            dx, dy, dz [m], rx, ry, rz [rad]: actual minus nominal.

        Raises
        ------
        InputError
            If ``order`` is not None or 1, or ``q``, ``theta`` or the covariates are invalid.
        """
        single = one_point(q)
        if order not in (None, 1):
            raise InputError(f"order must be None (exact) or 1 (first order), got {order!r}")
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        out = evaluate.volumetric_error(self._asm, q, theta, cov, order)
        return out[0] if single else out

    # ------------------------------------------------------------------ derivatives
    # (exact: Jacobians of the tool frame relative to the workpiece frame along the same chain as
    # the error, checked against Pinocchio's frame Jacobians, chained with the derivatives of the
    # error terms; the rotation rows include the inverse left Jacobian of the rotation vector)

    def sensitivity(self, q, theta=None, *, parameters=None, first_order: bool = False, extrapolate: bool = False,
                    **covariates) -> np.ndarray:
        """Derivative of :meth:`volumetric_error` with respect to the
        coefficients ``theta``.

        Exact: Jacobians of the tool frame relative to the workpiece frame (the same chain
        as the error, checked against Pinocchio's frame Jacobians), chained with the
        derivatives of the error terms; the rotation rows include the inverse left
        Jacobian of the rotation-vector error.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives a (6, P') result).
        theta : array_like, shape (P,), optional
            Coefficients (SI) at which to differentiate; defaults to :attr:`theta`.
        parameters : array_like of int, shape (P',), optional
            Indices of the coefficients to differentiate by, in that order; default all (P' = P).
        first_order : bool, default False
            Take the kinematics at zero error (the derivative of the first-order model), where
            dependencies between coefficients are exact.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`.

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
        cols = inputs.check_parameters(self._asm, parameters)
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, columns=len(cols), **covariates)
        out = evaluate.sensitivity(self._asm, q, theta, cov, cols, first_order)
        return out[0] if single else out

    def component_sensitivity(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """Derivative of the error with respect to each component error's value at the point.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives a (6, n_components) result).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`.

        Returns
        -------
        ndarray, shape (N, 6, n_components) or (6, n_components)
            Error (dx, dy, dz [m], rx, ry, rz [rad]) per m or rad of each component, in the order
            of :attr:`components`.

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        single = one_point(q)
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        out = evaluate.component_sensitivity(self._asm, q, theta, cov)
        return out[0] if single else out

    def error_joint_sensitivity(self, q, theta=None, *, first_order: bool = False, extrapolate: bool = False,
                                **covariates) -> np.ndarray:
        """Derivative of the error with respect to the value of every injected error joint.

        In the order of :attr:`error_joints`, ISO sense, whether or
        not the spec gives the joint a term: what adding a term to any component would do.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives a (6, n_error_joints) result).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        first_order : bool, default False
            Evaluate at zero error.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`.

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
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        out = evaluate.error_joint_sensitivity(self._asm, q, theta, cov, first_order)
        return out[0] if single else out

    def axis_jacobian(self, q, theta=None, *, nominal: bool = False, extrapolate: bool = False,
                      **covariates) -> np.ndarray:
        """Derivative of the tool pose relative to the workpiece with respect to the NC positions.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives a (6, n_axes) result).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        nominal : bool, default False
            Ignore the errors. The actual Jacobian (default) includes the position derivatives
            of the error terms.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`.

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
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        out = evaluate.axis_jacobian(self._asm, q, theta, cov, nominal)
        return out[0] if single else out

    def joint_jacobian(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """Derivative of the tool pose with respect to the values of all Pinocchio joints.

        As Pinocchio's frame Jacobians give it: point velocity and angular velocity of the tool,
        in workpiece axes.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad] (a single point gives N = 1).
        theta : array_like, shape (P,), optional
            Coefficients (SI); defaults to :attr:`theta`.
        extrapolate : bool, default False
            Allow positions outside the travel.
        **covariates
            As for :meth:`volumetric_error`.

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
        q, theta, cov = self.check_inputs(q, theta, extrapolate=extrapolate, **covariates)
        return evaluate.joint_jacobian(self._asm, q, theta, cov)

    def __repr__(self) -> str:
        return (f"<Machine {self.name}: axes {', '.join(self.axes)}; {len(self._asm.components)} error "
                f"components, {len(self._asm.names)} parameters>")


def load_machine(machine: str | os.PathLike, *, tool_frame: str | None = None,
                 workpiece_frame: str | None = None, package_dirs=()) -> Machine:
    """Load a machine.

    Limits, checked before the URDF is parsed or handed to Pinocchio: the URDF file is a regular
    file of at most 16 MB (:data:`~volerr_pin.model.urdf.MAX_URDF_BYTES`) with at most 1,000 joints
    (:data:`~volerr_pin.model.urdf.MAX_JOINTS`), and the model with its error joints (six per axis,
    body and location site, and a closing fixed joint per moving-frame site) has at most 2,000
    joints (:data:`~volerr_pin.model.urdf.MAX_MODEL_JOINTS`): about 280 axes in one chain, far beyond
    real machines and robots. A continuous (endless) joint has the travel of one turn, -180 to
    180 deg. ``<mimic>`` joints between the workpiece and the tool frames are refused.

    Parameters
    ----------
    machine : str or path
        A bundled machine name (``"vmc500"``), a machine folder holding ``errors.toml``,
        a spec file (``.toml``), or a bare URDF file (then ``tool_frame`` and
        ``workpiece_frame`` are required and every movable joint between them gets six
        zero-valued constant error terms).
    tool_frame : str, optional
        Name of the tool frame; only with a bare URDF.
    workpiece_frame : str, optional
        Name of the workpiece frame; only with a bare URDF.
    package_dirs : path or iterable of path, optional
        Folders in which ``package://NAME/...`` meshes of the URDF are looked up, as
        ``<folder>/NAME/...`` (or ``<folder>/...`` for a folder called NAME), for pictures of
        the machine (:attr:`Machine.package_dirs`). The package a spec names its URDF by
        (``urdf = {package = ...}``) is always one.

    Returns
    -------
    Machine
        The machine with the spec's coefficient values.

    Raises
    ------
    SpecError
        If the name is neither a bundled machine nor an existing folder, spec or URDF; a
        bare URDF lacks ``tool_frame`` or ``workpiece_frame``; they are given with a spec;
        or the spec is invalid.
    URDFError
        If the URDF cannot be read or parsed, or is beyond the limits above.
    InputError
        If a folder of ``package_dirs`` does not exist.

    Examples
    --------
    >>> import volerr_pin as vp
    >>> m = vp.load_machine("vmc500")
    >>> m.axes
    ('X', 'Y', 'Z')
    """
    package_dirs = package_folders(package_dirs)
    text = os.fspath(machine)
    path = Path(text)
    if path.suffix.lower() == ".urdf":
        if tool_frame is None or workpiece_frame is None:
            raise SpecError(f"{path}: a bare URDF needs tool_frame= and workpiece_frame=")
        urdf = load_urdf(path)
        return Machine(spec_from_urdf(urdf, tool_frame, workpiece_frame), urdf, package_dirs=package_dirs)
    if path.suffix.lower() == ".toml":
        spec_path = path
    elif path.is_dir():
        spec_path = path / SPEC_FILE
    elif (machines_dir() / text / SPEC_FILE).is_file() and os.sep not in text:
        spec_path = machines_dir() / text / SPEC_FILE
    else:
        names = bundled_machines()
        close = difflib.get_close_matches(text, names, n=1, cutoff=0.75)
        hint = f"; did you mean {close[0]}?" if close else ""
        raise SpecError(f"'{text}' is neither a bundled machine ({', '.join(names)}) nor a machine folder, "
                        f"spec (.toml) or URDF file{hint}")
    if not spec_path.is_file():
        raise SpecError(f"{spec_path}: no such spec file")
    spec, urdf = load_spec(spec_path)
    if tool_frame is not None or workpiece_frame is not None:
        raise SpecError(f"{spec_path}: tool_frame/workpiece_frame are given by the spec; "
                        "pass them only with a bare URDF")
    return Machine(spec, urdf, package_dirs=package_dirs)
