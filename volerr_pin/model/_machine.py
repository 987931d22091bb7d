"""The machine a user holds: a :class:`~volerr_pin.model.Model` with coefficient values and a
state, whose methods check what they are given once and call the algorithms of
:mod:`volerr_pin.model`; and :func:`load_machine`.
"""

from __future__ import annotations

import difflib
import os
from pathlib import Path
from typing import Mapping

import numpy as np

from . import _algorithms as alg
from ._catalog import SPEC_FILE, bundled_machines, machines_dir
from ._checks import check_covariates, check_inputs, check_parameters, check_q, check_theta, merge_state, outside_travel
from ._model import Model, build_model
from ._spec import MachineSpec, load_spec, spec_from_urdf
from ._urdf import URDF, load_urdf, package_folders
from ..base import SpecError, one_point

__all__ = ["Machine", "load_machine"]


class Machine:
    """A machine tool (or robot) with error joints on every axis: its model, coefficient
    values and state; an immutable value.

    Load one with :func:`load_machine`. Its evaluations (:meth:`volumetric_error`,
    :meth:`sensitivity` ...) check their inputs once (:func:`~volerr_pin.model.check_inputs`)
    and call the algorithm of the same name on :attr:`model`; code that evaluates in a loop
    checks once and calls the algorithms itself.

    Everything is SI: NC positions ``q`` in m (linear axes) and rad (rotary axes), errors in m
    and rad, coefficients ``theta`` in the SI unit of each coefficient, covariates in s, degC,
    N and +1/-1.

    Parameters
    ----------
    model : Model
        The model (:func:`~volerr_pin.model.build_model`).
    theta : array_like, shape (P,), optional
        Coefficient values; default the spec's (``model.theta``). Checked as :meth:`with_theta`
        checks them (``limits`` True).
    state : mapping, optional
        A state as :attr:`state` gives it (``t``, ``temperatures``, ``forces``, ``directions``),
        checked as :meth:`with_state` checks it.

    Raises
    ------
    InputError
        If ``theta`` or ``state`` is invalid.
    """

    __slots__ = ("model", "_theta", "_state", "_spec")

    def __init__(self, model: Model, theta=None, state: Mapping | None = None):
        self.model = model
        self._theta = model.theta if theta is None else check_theta(model, theta, limits=True)
        self._theta.flags.writeable = False
        self._state = merge_state({}, model.axes, **dict(state)) if state else {}
        self._spec = None

    def _copy(self, theta: np.ndarray | None = None, state: dict | None = None) -> "Machine":
        """This machine with checked ``theta`` or ``state`` (trusted)."""
        other = object.__new__(Machine)
        other.model, other._spec = self.model, None
        other._theta = self._theta if theta is None else theta
        other._theta.flags.writeable = False
        other._state = self._state if state is None else state
        return other

    # ------------------------------------------------------------------ description
    @property
    def name(self) -> str:
        """The machine's name, from its spec (str)."""
        return self.model.spec.name

    @property
    def spec(self) -> MachineSpec:
        """The error specification with the present coefficient values
        (:class:`~volerr_pin.model.MachineSpec`): edit it (:meth:`MachineSpec.with_terms
        <volerr_pin.model.MachineSpec.with_terms>` ...) and give it to :meth:`with_spec`."""
        if self._spec is None:
            self._spec = self.model.spec.with_values(self._theta, self.model.names)
        return self._spec

    @property
    def axes(self) -> tuple[str, ...]:
        """Axis names in the order of the columns of ``q`` (tuple of str)."""
        return self.model.axes

    @property
    def axis_kinds(self) -> tuple[str, ...]:
        """Kind of each axis, "linear" (a prismatic joint, SI unit m) or "rotary" (SI unit rad)."""
        return self.model.axis_kinds

    @property
    def travel(self) -> np.ndarray:
        """Lower and upper NC travel of each axis, ndarray of shape (n_axes, 2) [m, rad], a copy.

        From the joint limits and the axis sign; an endless (continuous) axis has one turn,
        (-pi, pi) (:data:`~volerr_pin.model.ENDLESS_TRAVEL`): positions beyond it are outside the
        travel like any other axis' (wrap them, or pass ``extrapolate=True``).
        """
        return self.model.travel.copy()

    @property
    def mid_travel(self) -> np.ndarray:
        """The middle of each axis' travel, ndarray of shape (n_axes,) [m, rad] (0 for an endless axis)."""
        t = self.model.travel
        return np.where(np.isfinite(t).all(axis=1), t.mean(axis=1), 0.0)

    @property
    def package_dirs(self) -> tuple[Path, ...]:
        """Folders of ``package://`` packages whose meshes pictures of the machine may read
        (tuple of Path, resolved): those given to :func:`load_machine` and the package a spec
        names its URDF by."""
        return self.model.package_dirs

    @property
    def chains(self) -> dict[str, tuple[str, ...]]:
        """Axes carried by the tool chain and by the workpiece chain.

        A dict ``{"tool": (axis names), "workpiece": (axis names)}``, each in kinematic order:
        from the bed outwards, as the URDF nests the axes' joints (not the spec's order of
        :attr:`axes`).
        """
        pinocchio, spec = self.model.pinocchio, self.model.spec
        # a joint's support is its path from the root: the deeper, the further out on its chain
        depth = [len(pinocchio.supports[pinocchio.getJointId(a.joint)]) for a in spec.axes]
        order = sorted(range(len(self.axes)), key=lambda j: (depth[j], j))
        return {"tool": tuple(self.axes[j] for j in order if self.model.axis_chain[j] > 0),
                "workpiece": tuple(self.axes[j] for j in order if self.model.axis_chain[j] < 0)}

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the coefficients ``theta`` (e.g. ``EXX.c2``), in order; tuple of P str."""
        return self.model.names

    @property
    def theta_bounds(self) -> np.ndarray:
        """(P, 2) lowest and highest plausible SI value of each coefficient, read-only
        (:func:`~volerr_pin.model.theta_bounds`)."""
        from ._checks import theta_bounds

        return theta_bounds(self.model)

    @property
    def theta(self) -> np.ndarray:
        """Current coefficient values, ndarray of shape (P,) in the SI unit of each coefficient; a copy."""
        return np.array(self._theta)

    @property
    def components(self) -> tuple[str, ...]:
        """Names of the component and location errors that have terms (tuple of str), the order
        of the columns of :meth:`component_values` and :meth:`component_sensitivity`."""
        return self.model.component_names

    @property
    def error_joints(self) -> tuple[str, ...]:
        """Names of the injected error joints of the spec's sites (six per site, X, Y, Z, A, B,
        C), tuple of str. A machine made by editing another shares that machine's Pinocchio
        model; where an edit added a location error, that model has a location site on every
        axis and body, and the error joints not named here stay at zero."""
        return self.model.error_joints

    @property
    def tool_frame(self) -> str:
        """Name of the tool frame (str): the error is that of this frame."""
        return self.model.spec.tool_frame

    @property
    def workpiece_frame(self) -> str:
        """Name of the workpiece frame (str): the error is expressed in this frame."""
        return self.model.spec.workpiece_frame

    @property
    def urdf(self) -> URDF:
        """The nominal URDF as read (:class:`~volerr_pin.model.URDF`), without error joints."""
        return self.model.urdf

    @property
    def nonlinear_parameters(self) -> tuple[int, ...]:
        """Indices (into theta) of coefficients the model is not linear in (time constants,
        periods); tuple of int."""
        return self.model.nonlinear_parameters

    @property
    def covariates_used(self) -> frozenset[str]:
        """The covariates the model reads (``t``, ``temperatures``, ``forces``, ``directions``);
        a purely geometric machine reads none. ``t`` is included when a term reads lagged
        temperatures. A frozenset of str."""
        return self.model.covariates_used

    @property
    def sensors(self) -> tuple[str, ...]:
        """Names of the temperature sensors the model reads, sorted (a tuple of str; empty for a
        machine without temperature-driven terms)."""
        return self.model.sensors

    @property
    def state(self) -> dict:
        """The state set by :meth:`with_state` (empty by default).

        A dict (a copy) with the keys given so far: ``t`` (float, s), ``temperatures`` ({sensor:
        degC}), ``forces`` (ndarray of shape (3,), N), ``directions`` (ndarray of shape (n_axes,)).
        """
        return dict(self._state)

    def injected_urdf(self) -> str:
        """The URDF with the error joints, as XML text (that of Pinocchio's model, ``model.pinocchio``).

        Joint values: an axis joint takes ``sign * q``; an error joint takes the error value
        on the tool chain and its negative on the workpiece chain (errors are defined as
        motions of the tool relative to the workpiece).

        Returns
        -------
        str
            The XML document, with declaration, pretty-printed.
        """
        return self.model.injected.to_string()

    # ------------------------------------------------------------------ new values
    def with_theta(self, theta, *, limits: bool = True) -> "Machine":
        """A copy of this machine with other coefficient values.

        Parameters
        ----------
        theta : array_like, shape (P,)
            Coefficient values in the SI unit of each coefficient (order of :attr:`parameter_names`).
        limits : bool, default True
            Refuse a value beyond the plausibility limits a spec would (:attr:`theta_bounds`);
            False for the steps of a fit, which may pass through any value, and simulated truths.

        Returns
        -------
        Machine
            A new machine sharing everything else (its state included).

        Raises
        ------
        InputError
            If ``theta`` does not have shape (P,), holds a value that is not finite, or (with
            ``limits``) one beyond its plausibility limits.
        """
        return self._copy(theta=check_theta(self.model, theta, limits))

    def with_state(self, t: float | None = None, temperatures: Mapping | None = None, forces=None,
                   directions=None) -> "Machine":
        """A copy of this machine held in one state.

        Covariates a call does not give are taken from here for every point. Calls may still
        pass their own. Values given here are merged into a state already set: temperatures by
        sensor, the others replaced.

        Parameters
        ----------
        t, temperatures, forces, directions : optional
            A time [s], temperatures by sensor [degC], the process force Fx, Fy, Fz [N] and each
            axis' approach direction (+1 or -1), as :func:`~volerr_pin.model.merge_state`
            checks and merges them.

        Returns
        -------
        Machine
            A new machine with the state set (see :attr:`state`).

        Raises
        ------
        InputError
            If a value is invalid (:func:`~volerr_pin.model.merge_state`).
        """
        return self._copy(state=merge_state(self._state, self.axes, t, temperatures, forces, directions))

    def with_spec(self, spec: MachineSpec) -> "Machine":
        """A machine of an edited spec (other components, terms or coefficient values; the same
        URDF, axes, bodies and frames), in the same state, with the spec's coefficient values.

        Its coefficients are laid out on this machine's Pinocchio model where that model has
        their error joints (:func:`~volerr_pin.model.build_model` with ``like``), so edits
        build Pinocchio's model at most once more.

        Parameters
        ----------
        spec : MachineSpec
            The edited spec, usually :attr:`spec` edited (:meth:`MachineSpec.with_terms
            <volerr_pin.model.MachineSpec.with_terms>`, :meth:`~volerr_pin.model.MachineSpec.without` ...).

        Returns
        -------
        Machine
            The new machine.

        Raises
        ------
        InputError
            If a coefficient value of ``spec`` is beyond the plausibility limits a spec file
            is read with.
        SpecError
            If a component of ``spec`` does not lie between the workpiece and the tool frames.
        """
        model = build_model(spec, self.model.urdf, self.model.package_dirs, like=self.model)
        return Machine._trusted(model, check_theta(model, model.theta, limits=True), self._state)

    @classmethod
    def _trusted(cls, model: Model, theta: np.ndarray, state: dict) -> "Machine":
        other = object.__new__(cls)
        other.model, other._spec, other._state = model, None, state
        other._theta = theta
        other._theta.flags.writeable = False
        return other

    # ------------------------------------------------------------------ evaluations
    def _call(self, algorithm, q, theta, extrapolate, covariates, width: int = 0, squeeze: bool = True,
              **options):
        """``algorithm`` of the model at checked inputs (``width``: sensitivity columns per point,
        for the memory check); one point (n_axes,) gives one result when ``squeeze``."""
        single = squeeze and one_point(q)
        q, theta, cov = check_inputs(self.model, q, self._theta if theta is None else theta, covariates,
                                     state=self._state, extrapolate=extrapolate, columns=width)
        out = algorithm(self.model, q, theta, cov, **options)
        return out[0] if single else out

    def outside_travel(self, q: np.ndarray) -> np.ndarray:
        """Where positions leave the travel by more than rounding (:func:`~volerr_pin.model.outside_travel`).

        Parameters
        ----------
        q : ndarray, shape (N, n_axes)
            NC positions [m, rad] (not converted or checked).

        Returns
        -------
        ndarray of bool, shape (N, n_axes)
            True beyond the travel by more than 1e-9 of the span (at least 1e-9 m or rad).
        """
        return outside_travel(self.model, q)

    def search_grid(self, index: int, theta=None, *, n: int, **covariates) -> np.ndarray:
        """Candidate values of a non-linear coefficient for a grid search
        (:func:`~volerr_pin.model.search_grid`).

        Parameters
        ----------
        index : int
            Index of the coefficient in ``theta``.
        theta : array_like, shape (P,), optional
            Coefficient values (SI); defaults to :attr:`theta`.
        n : int
            Number of points the covariates describe.
        **covariates
            The points' covariates, as for :meth:`volumetric_error`.

        Returns
        -------
        ndarray, shape (G,)
            Candidate values in the coefficient's SI unit (empty for a coefficient without a grid).

        Raises
        ------
        InputError
            If no coefficient has the index ``index``, or the covariates are invalid.
        """
        theta = self._theta if theta is None else check_theta(self.model, theta)
        return alg.search_grid(self.model, index, theta, check_covariates(self.model, n, covariates, self._state))

    def volumetric_error(self, q, theta=None, *, order: int | None = None, extrapolate: bool = False,
                         **covariates) -> np.ndarray:
        """The pose error of the tool point relative to the workpiece, in the workpiece frame.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            Commanded NC positions, m for linear and rad for rotary axes (a single (n_axes,)
            point gives a (6,) result).
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
            The error of each point (:func:`~volerr_pin.model.volumetric_error`).

        Raises
        ------
        InputError
            If ``order`` is not None or 1, or ``q``, ``theta`` or the covariates are invalid.
        """
        return self._call(alg.volumetric_error, q, theta, extrapolate, covariates, order=order)

    def sensitivity(self, q, theta=None, *, parameters=None, first_order: bool = False, extrapolate: bool = False,
                    **covariates) -> np.ndarray:
        """The derivative of :meth:`volumetric_error` with respect to the coefficients, exact.

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
            The derivatives at each point (:func:`~volerr_pin.model.sensitivity`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates, or ``parameters`` that are not indices of
            ``theta``.
        """
        columns = check_parameters(self.model, parameters)
        return self._call(alg.sensitivity, q, theta, extrapolate, covariates, len(columns), columns=columns,
                          first_order=first_order)

    def component_values(self, q, theta=None, *, extrapolate: bool = False, without_covariates: bool = False,
                         **covariates) -> np.ndarray:
        """The values of the component errors at ``q``, as motions of the tool relative to the workpiece.

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
            The values at each point, in the order of :attr:`components`
            (:func:`~volerr_pin.model.component_values`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        return self._call(alg.component_values, q, theta, extrapolate, {} if without_covariates else covariates,
                          squeeze=False, without_covariates=without_covariates)

    def component_sensitivity(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """The derivative of the error with respect to each component error's value at the point.

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
            The derivatives at each point, in the order of :attr:`components`
            (:func:`~volerr_pin.model.component_sensitivity`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        return self._call(alg.component_sensitivity, q, theta, extrapolate, covariates)

    def error_joint_sensitivity(self, q, theta=None, *, first_order: bool = False, extrapolate: bool = False,
                                **covariates) -> np.ndarray:
        """The derivative of the error with respect to the value of every injected error joint, in
        the order of :attr:`error_joints` (ISO sense), whether or not the spec gives the joint a
        term: what adding a term to any component would do.

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
            The derivatives at each point (:func:`~volerr_pin.model.error_joint_sensitivity`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        return self._call(alg.error_joint_sensitivity, q, theta, extrapolate, covariates, first_order=first_order)

    def axis_jacobian(self, q, theta=None, *, nominal: bool = False, extrapolate: bool = False,
                      **covariates) -> np.ndarray:
        """The derivative of the tool pose relative to the workpiece with respect to the NC positions.

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
            The Jacobian at each point (:func:`~volerr_pin.model.axis_jacobian`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        return self._call(alg.axis_jacobian, q, theta, extrapolate, covariates, nominal=nominal)

    def joint_jacobian(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """The derivative of the tool pose with respect to the values of all Pinocchio joints, as
        Pinocchio's frame Jacobians give it: point velocity and angular velocity of the tool, in
        workpiece axes.

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
            The Jacobian at each point (:func:`~volerr_pin.model.joint_jacobian`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        return self._call(alg.joint_jacobian, q, theta, extrapolate, covariates, squeeze=False)

    def joint_values(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """The values of all Pinocchio joints (axes and error joints) at ``q``.

        An axis joint takes ``sign * q``; an error joint the value of its component error on the
        tool chain and its negative on the workpiece chain.

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
            The values at each point (:func:`~volerr_pin.model.joint_values`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        return self._call(alg.joint_values, q, theta, extrapolate, covariates, squeeze=False)

    def tool_poses(self, q, theta=None, *, nominal: bool = False, extrapolate: bool = False,
                   **covariates) -> tuple[np.ndarray, np.ndarray]:
        """The poses of the tool frame in the workpiece frame, actual (default) or nominal.

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
        R, p : ndarray, shapes (N, 3, 3) and (N, 3)
            The poses (:func:`~volerr_pin.model.tool_poses`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        if nominal:
            return alg.tool_poses(self.model, check_q(self.model, q, extrapolate), nominal=True)
        return self._call(alg.tool_poses, q, theta, extrapolate, covariates, squeeze=False)

    def pinocchio_configuration(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """The configurations of Pinocchio's model (``model.pinocchio``) at the points ``q``.

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
            The configurations (:func:`~volerr_pin.model.pinocchio_configuration`).

        Raises
        ------
        InputError
            For invalid ``q``, ``theta`` or covariates.
        """
        return self._call(alg.pinocchio_configuration, q, theta, extrapolate, covariates, squeeze=False)

    def __repr__(self) -> str:
        return (f"<Machine {self.name}: axes {', '.join(self.axes)}; {len(self.model.components)} error "
                f"components, {len(self.model.names)} parameters>")


def load_machine(machine: str | os.PathLike, *, tool_frame: str | None = None,
                 workpiece_frame: str | None = None, package_dirs=()) -> Machine:
    """Load a machine.

    Limits, checked before the URDF is parsed or handed to Pinocchio: the URDF file is a regular
    file of at most 16 MB (:data:`~volerr_pin.model.MAX_URDF_BYTES`) with at most 1,000 joints
    (:data:`~volerr_pin.model.MAX_JOINTS`), and the model with its error joints (six per axis,
    body and location site, and a closing fixed joint per moving-frame site) has at most 2,000
    joints (:data:`~volerr_pin.model.MAX_MODEL_JOINTS`): about 280 axes in one chain, far beyond
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
        return Machine(build_model(spec_from_urdf(urdf, tool_frame, workpiece_frame), urdf, package_dirs))
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
    return Machine(build_model(spec, urdf, package_dirs))
