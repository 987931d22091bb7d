"""The machine: URDF + error spec -> Pinocchio model with error joints -> volumetric error.

:class:`Machine` is the assembled model (:mod:`volerr_pin.assembly`) with coefficient values
and a state (:mod:`volerr_pin.state`); it evaluates the error and the tool pose at NC positions.
Its derivatives are the functions of :mod:`volerr_pin.sensitivities`, bound as its methods.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

import numpy as np
import pinocchio as pin

from . import inputs, poses, sensitivities
from . import state as states
from . import kinematics as K
from .assembly import Assembly, assemble, component_values, joint_values
from .checks import one_point
from .errors import InputError, SpecError
from .spec import MachineSpec, load_spec, spec_from_urdf
from .urdf import URDF, load_urdf, package_folders

__all__ = ["SPEC_FILE", "Machine", "bundled_machines", "load_machine", "machines_dir"]

SPEC_FILE = "errors.toml"


def machines_dir() -> Path:
    """Folder of the bundled machines (``VOLERR_MACHINES`` overrides it).

    Returns
    -------
    Path
        The ``VOLERR_MACHINES`` environment variable when it is set (whether or not the folder
        exists); otherwise the first existing folder of ``machines/`` beside the package and
        ``machines/`` inside it; otherwise ``machines/`` beside the package.
    """
    env = os.environ.get("VOLERR_MACHINES")
    if env:
        return Path(env)
    here = Path(__file__).resolve().parent
    for candidate in (here.parent / "machines", here / "machines"):
        if candidate.is_dir():
            return candidate
    return here.parent / "machines"


def bundled_machines() -> list[str]:
    """Names of the machines shipped with volerr_pin.

    Returns
    -------
    list of str
        Sorted names of the sub-folders of :func:`machines_dir` that hold an ``errors.toml``;
        empty when that folder does not exist.
    """
    root = machines_dir()
    return sorted(p.name for p in root.iterdir() if (p / SPEC_FILE).is_file()) if root.is_dir() else []


class Machine:
    """A machine tool (or robot) with error joints on every axis.

    Immutable: ``theta`` returns a copy, :meth:`with_theta` returns a new machine.
    Build it with :func:`load_machine`.

    The constructor assembles the model (:func:`volerr_pin.assembly.assemble`): it injects six
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
        (see :func:`volerr_pin.urdf.package_folders`), besides the package a spec names its URDF
        by (``urdf = {package = ...}``); the model itself reads no mesh.

    Raises
    ------
    SpecError
        If an injected joint or link name already exists in the URDF, the tool or workpiece
        frame is not in the model, a joint between them is not 1-DoF, or an axis, error site
        or component does not lie between the workpiece frame and the tool frame.
    URDFError
        If a ``<mimic>`` joint lies between the workpiece and the tool frames, the model would
        have more than :data:`~volerr_pin.urdf.MAX_MODEL_JOINTS` joints with its error joints,
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
        (:func:`~volerr_pin.assembly.assemble` with ``like``); no state, the spec's coefficient
        values."""
        other = object.__new__(Machine)
        other._asm = assemble(spec, self._asm.urdf, self._asm.package_dirs, like=self._asm)
        other._theta = other._asm.theta
        other._state = {}
        return other

    @property
    def assembly(self) -> Assembly:
        """The assembled model (:class:`~volerr_pin.assembly.Assembly`): error sites, Pinocchio
        model, flattened chain, where each coefficient acts; shared by every copy."""
        return self._asm

    # ------------------------------------------------------------------ description
    @property
    def name(self) -> str:
        """The machine's name, from its spec (str)."""
        return self._asm.spec.name

    @property
    def spec(self) -> MachineSpec:
        """The error specification (:class:`~volerr_pin.spec.MachineSpec`) the machine was built from."""
        return self._asm.spec

    @property
    def axes(self) -> tuple[str, ...]:
        """Axis names in the order of the columns of ``q`` (tuple of str)."""
        return tuple(a.name for a in self._asm.spec.axes)

    @property
    def axis_kinds(self) -> tuple[str, ...]:
        """Kind of each axis, "linear" (a prismatic joint, SI unit m) or "rotary" (SI unit rad)."""
        return tuple("linear" if self._asm.urdf.joints[a.joint].type == "prismatic" else "rotary"
                     for a in self._asm.spec.axes)

    @property
    def travel(self) -> np.ndarray:
        """Lower and upper NC travel of each axis, ndarray of shape (n_axes, 2) [m, rad], a copy.

        From the joint limits and the axis sign; an endless (continuous) axis has one turn,
        (-pi, pi) (:data:`~volerr_pin.urdf.ENDLESS_TRAVEL`): positions beyond it are outside the
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

    #: (P, 2) lowest and highest plausible SI value of each coefficient (:func:`~volerr_pin.inputs.theta_bounds`)
    theta_bounds = property(inputs.theta_bounds)

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

        A machine made by editing another (:mod:`volerr_pin.specio`) shares that machine's
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
        """The nominal URDF as read (:class:`~volerr_pin.urdf.URDF`), without error joints."""
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

    # ------------------------------------------------------------------ evaluation
    # (the checks of the inputs are volerr_pin.inputs', the covariates volerr_pin.state's;
    # joint values and poses volerr_pin.poses': all are the machine's methods too)
    outside_travel = inputs.outside_travel
    check_q = inputs.check_q
    check_theta = inputs.check_theta
    check_inputs = inputs.check_inputs
    check_covariates = states.check_covariates
    joint_values = poses.joint_values
    tool_poses = poses.tool_poses
    pinocchio_configuration = poses.pinocchio_configuration

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
        q = self.check_q(q, extrapolate)
        theta = self.check_theta(theta)
        cov = self.check_covariates(q.shape[0], covariates)
        out = np.empty((q.shape[0], 6))
        buffer = np.empty((self._asm.model.nv, min(self._asm.block, q.shape[0])))
        for start in range(0, q.shape[0], self._asm.block):  # bounded memory for millions of points
            rows = slice(start, start + self._asm.block)
            values = joint_values(self._asm, q[rows], theta, cov.take(rows), out=buffer)
            K.pose_error(self._asm.chain, values, order, out=out[rows])
        return out[0] if single else out

    # ------------------------------------------------------------------ derivatives
    # (volerr_pin.sensitivities owns them; they are the machine's methods too)
    sensitivity = sensitivities.sensitivity
    component_sensitivity = sensitivities.component_sensitivity
    error_joint_sensitivity = sensitivities.error_joint_sensitivity
    axis_jacobian = sensitivities.axis_jacobian
    joint_jacobian = sensitivities.joint_jacobian

    def __repr__(self) -> str:
        return (f"<Machine {self.name}: axes {', '.join(self.axes)}; {len(self._asm.components)} error "
                f"components, {len(self._asm.names)} parameters>")


def load_machine(machine: str | os.PathLike, *, tool_frame: str | None = None,
                 workpiece_frame: str | None = None, package_dirs=()) -> Machine:
    """Load a machine.

    Limits, checked before the URDF is parsed or handed to Pinocchio: the URDF file is a regular
    file of at most 16 MB (:data:`~volerr_pin.urdf.MAX_URDF_BYTES`) with at most 1,000 joints
    (:data:`~volerr_pin.urdf.MAX_JOINTS`), and the model with its error joints (six per axis,
    body and location site, and a closing fixed joint per moving-frame site) has at most 2,000
    joints (:data:`~volerr_pin.urdf.MAX_MODEL_JOINTS`): about 280 axes in one chain, far beyond
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
        known = ", ".join(bundled_machines())
        raise SpecError(f"'{text}' is neither a bundled machine ({known}) nor a machine folder, "
                        "spec (.toml) or URDF file")
    if not spec_path.is_file():
        raise SpecError(f"{spec_path}: no such spec file")
    spec, urdf = load_spec(spec_path)
    if tool_frame is not None or workpiece_frame is not None:
        raise SpecError(f"{spec_path}: tool_frame/workpiece_frame are given by the spec; "
                        "pass them only with a bare URDF")
    return Machine(spec, urdf, package_dirs=package_dirs)
