"""The machine: URDF + error spec -> Pinocchio model with error joints -> volumetric error."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np
import pinocchio as pin

from . import kinematics as K
from .errors import InputError, SpecError, URDFError
from .spec import (DIRECTIONS, MachineSpec, axis_travel, component_name, load_spec,
                   spec_from_urdf)
from .effects import add_lagged_temperatures
from .terms import Context, Covariates
from .urdf import URDF, Site, inject, load_urdf, package_folders

SPEC_FILE = "errors.toml"
#: most memory one block of a batch evaluation takes for its Jacobians [bytes]
BLOCK_BYTES = 128_000_000


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


def _real(value, name: str, parameter: str) -> np.ndarray:
    """``value`` as a new float array; an InputError naming ``parameter`` if it is not an array of
    real numbers (text, ragged rows, complex values: numpy would drop the imaginary part)."""
    try:
        raw = np.asarray(value)
        complex_ = np.iscomplexobj(raw)
        array = None if complex_ else np.array(raw, dtype=float)
    except (TypeError, ValueError) as err:
        raise InputError(f"{name} must be real numbers: {err}", parameters=(parameter,)) from None
    if complex_:
        raise InputError(f"{name} must be real numbers, got complex values", parameters=(parameter,))
    return array


def _single(q) -> bool:
    """Whether ``q`` is one point (one dimension); ragged input is left to :meth:`Machine.check_q`."""
    try:
        return np.ndim(q) == 1
    except ValueError:
        return False


@dataclass(frozen=True)
class _Component:
    name: str
    owner: str
    axis_index: int | None      # index into Machine.axes, None for bodies and location errors
    column: int                 # Pinocchio v-index of its error joint
    chain_sign: float           # +1 tool chain, -1 workpiece chain
    terms: tuple                # (TermSpec, slice into theta)


class Machine:
    """A machine tool (or robot) with error joints on every axis.

    Immutable: ``theta`` returns a copy, :meth:`with_theta` returns a new machine.
    Build it with :func:`load_machine`.

    The constructor injects a group of six error joints (translations X, Y, Z, then rotations
    A, B, C) for every owner of location errors (before the owner's joint), every axis (after
    its joint when the axis' errors frame is "moving", before it when "fixed") and every body
    (after its joint); builds the Pinocchio model of the injected URDF; and flattens it into
    the relative chain from the workpiece frame to the tool frame (:mod:`volerr_pin.kinematics`).

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
        self._spec = spec
        self._urdf = urdf
        self._package_dirs = package_folders(package_folders(package_dirs) + _spec_package(spec))
        tool_path = urdf.path_to_root(spec.tool_frame)
        work_path = urdf.path_to_root(spec.workpiece_frame)
        between = {j.name for j in tool_path} ^ {j.name for j in work_path}
        for joint in tool_path + work_path:
            if joint.name in between and joint.mimic is not None and joint.type != "fixed":
                # Pinocchio's URDF reader would make it a free joint held at 0 while its master moves
                raise URDFError(f"{urdf.source}:{joint.line}: <joint name='{joint.name}'> follows "
                                f"'{joint.mimic}' (<mimic>) and lies between the workpiece frame "
                                f"'{spec.workpiece_frame}' and the tool frame '{spec.tool_frame}'; "
                                "mimic joints are not supported there")
        sites, owner_joint = [], {}
        for axis in spec.axes:
            owner_joint[axis.name] = (axis.joint, axis.reference)
        for body in spec.bodies:
            owner_joint[body.name] = (body.joint, body.reference)
        located = sorted({c.owner for c in spec.components if c.location},
                         key=list(owner_joint).index)
        for owner in located:
            joint, ref = owner_joint[owner]
            sites.append(Site(f"loc_{owner}", joint, "before", ref,
                              tuple(component_name(d, owner, True) for d in DIRECTIONS)))
        for axis in spec.axes:
            sites.append(Site(f"axis_{axis.name}", axis.joint,
                              "after" if axis.frame == "moving" else "before", axis.reference,
                              tuple(component_name(d, axis.name) for d in DIRECTIONS)))
        for body in spec.bodies:
            sites.append(Site(f"body_{body.name}", body.joint, "after", body.reference,
                              tuple(component_name(d, body.name) for d in DIRECTIONS)))
        taken = set(urdf.joints) | set(urdf.links)
        for site in sites:
            clash = taken & (set(site.names) | {f"{site.key}__err{i}" for i in range(7)})
            if clash:
                raise SpecError(f"{spec.source}: injected error joint names {sorted(clash)} "
                                f"already exist in {urdf.source}")
        self._sites = tuple(sites)
        self._injected = inject(urdf, sites)
        try:
            model = pin.buildModelFromXML(self._injected.to_string())
        except Exception as err:  # Pinocchio raises plain RuntimeError/ValueError
            raise URDFError(f"{urdf.source}: Pinocchio cannot build the model: {err}") from err
        for frame in (spec.tool_frame, spec.workpiece_frame):
            if not model.existFrame(frame):
                raise SpecError(f"{spec.source}: frame '{frame}' is not in the model")
        self._model = model
        # points per block: Jacobian blocks (rows, 6, nv) stay within BLOCK_BYTES however many joints
        self._block = int(max(64, min(K.CHUNK, BLOCK_BYTES // (48 * model.nv))))
        error_names = [n for s in sites for n in s.names]
        error_ids = {model.getJointId(n) for n in error_names}
        self._chain = K.build_chain(model, spec.tool_frame, spec.workpiece_frame, error_ids)
        op_sign = dict(zip(self._chain.joints, self._chain.sign))

        def chain_sign(joint_name: str, what: str) -> float:
            jid = model.getJointId(joint_name)
            if jid not in op_sign:
                raise SpecError(f"{spec.source}: {what} (joint '{joint_name}') does not lie between "
                                f"the workpiece frame '{spec.workpiece_frame}' and the tool frame "
                                f"'{spec.tool_frame}', so it cannot move the tool relative to the "
                                "workpiece")
            return float(op_sign[jid])

        self._axis_cols = np.array([model.idx_vs[model.getJointId(a.joint)] for a in spec.axes])
        self._axis_signs = np.array([a.sign for a in spec.axes])
        self._axis_chain = tuple(chain_sign(a.joint, f"axis {a.name}") for a in spec.axes)
        self._error_joint_cols = np.array([model.idx_vs[model.getJointId(n)] for s in sites
                                           for n in s.names], dtype=int)
        self._error_joint_signs = np.array([chain_sign(n, f"error site {s.key}") for s in sites
                                            for n in s.names])
        self._travel = np.array([axis_travel(urdf, a) for a in spec.axes], dtype=float).reshape(-1, 2)
        axis_names = [a.name for a in spec.axes]
        components, names, theta = [], [], []
        for comp in spec.components:
            jid = model.getJointId(comp.name)
            spans = []
            for tspec in comp.terms:
                start = len(names)
                names.extend(tspec.names(comp.name))
                theta.extend(tspec.coefficients)
                spans.append((tspec, slice(start, len(names))))
            index = axis_names.index(comp.owner) if (comp.owner in axis_names and not comp.location) else None
            components.append(_Component(comp.name, comp.owner, index, model.idx_vs[jid],
                                         chain_sign(comp.name, f"error {comp.name}"), tuple(spans)))
        self._components = tuple(components)
        self._lags = tuple(sorted({r for c in components for tspec, _ in c.terms
                                   for r in tspec.term.lag_requests()}))
        self._names = tuple(names)
        self._param_column = np.array([c.column for c in components for _, span in c.terms
                                       for _ in range(span.start, span.stop)], dtype=int)
        self._theta = np.asarray(theta, dtype=float)
        self._theta.flags.writeable = False

    # ------------------------------------------------------------------ description
    @property
    def name(self) -> str:
        """The machine's name, from its spec (str)."""
        return self._spec.name

    @property
    def spec(self) -> MachineSpec:
        """The error specification (:class:`~volerr_pin.spec.MachineSpec`) the machine was built from."""
        return self._spec

    @property
    def axes(self) -> tuple[str, ...]:
        """Axis names in the order of the columns of ``q`` (tuple of str)."""
        return tuple(a.name for a in self._spec.axes)

    @property
    def axis_kinds(self) -> tuple[str, ...]:
        """Kind of each axis, "linear" (a prismatic joint, SI unit m) or "rotary" (SI unit rad)."""
        return tuple("linear" if self._urdf.joints[a.joint].type == "prismatic" else "rotary"
                     for a in self._spec.axes)

    @property
    def travel(self) -> np.ndarray:
        """Lower and upper NC travel of each axis, ndarray of shape (n_axes, 2) [m, rad], a copy.

        From the joint limits and the axis sign; an endless (continuous) axis has one turn,
        (-pi, pi) (:data:`~volerr_pin.urdf.ENDLESS_TRAVEL`): positions beyond it are outside the
        travel like any other axis' (wrap them, or pass ``extrapolate=True``).
        """
        return self._travel.copy()

    @property
    def mid_travel(self) -> np.ndarray:
        """The middle of each axis' travel, ndarray of shape (n_axes,) [m, rad] (0 for an endless axis)."""
        t = self._travel
        return np.where(np.isfinite(t).all(axis=1), t.mean(axis=1), 0.0)

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
        span = self._travel[:, 1] - self._travel[:, 0]
        tol = 1e-9 * np.where(np.isfinite(span), np.maximum(span, 1.0), 1.0)
        return (q < self._travel[:, 0] - tol) | (q > self._travel[:, 1] + tol)

    @property
    def package_dirs(self) -> tuple[Path, ...]:
        """Folders of ``package://`` packages whose meshes pictures of the machine may read
        (tuple of Path, resolved): those given to :func:`load_machine` and the package a spec
        names its URDF by."""
        return self._package_dirs

    @property
    def chains(self) -> dict[str, tuple[str, ...]]:
        """Axes carried by the tool chain and by the workpiece chain.

        A dict ``{"tool": (axis names), "workpiece": (axis names)}``, each in the order of :attr:`axes`.
        """
        return {
            "tool": tuple(a for a, s in zip(self.axes, self._axis_chain) if s > 0),
            "workpiece": tuple(a for a, s in zip(self.axes, self._axis_chain) if s < 0),
        }

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the coefficients ``theta`` (e.g. ``EXX.c2``), in order; tuple of P str."""
        return self._names

    @property
    def theta(self) -> np.ndarray:
        """Current coefficient values, ndarray of shape (P,) in the SI unit of each coefficient; a copy."""
        return np.array(self._theta)

    @property
    def components(self) -> tuple[str, ...]:
        """Names of the component and location errors that have terms (tuple of str).

        This is the order of the columns of :meth:`component_values` and :meth:`component_sensitivity`.
        """
        return tuple(c.name for c in self._components)

    @property
    def error_joints(self) -> tuple[str, ...]:
        """Names of all injected error joints (six per site, X, Y, Z, A, B, C), tuple of str."""
        return tuple(n for s in self._sites for n in s.names)

    @property
    def model(self) -> pin.Model:
        """The Pinocchio model with error joints (a copy: the machine is immutable)."""
        return pin.Model(self._model)

    @property
    def tool_frame(self) -> str:
        """Name of the tool frame (str): the error is that of this frame."""
        return self._spec.tool_frame

    @property
    def workpiece_frame(self) -> str:
        """Name of the workpiece frame (str): the error is expressed in this frame."""
        return self._spec.workpiece_frame

    @property
    def urdf(self) -> URDF:
        """The nominal URDF as read (:class:`~volerr_pin.urdf.URDF`), without error joints."""
        return self._urdf

    def injected_urdf(self) -> str:
        """The URDF with the error joints, as XML text.

        Joint values: an axis joint takes ``sign * q``; an error joint takes the error value
        on the tool chain and its negative on the workpiece chain (errors are defined as
        motions of the tool relative to the workpiece).

        Returns
        -------
        str
            The XML document, with declaration, pretty-printed.
        """
        return self._injected.to_string()

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
            If ``theta`` does not have shape (P,) or holds a value that is not finite.
        """
        theta = self._check_theta(theta)
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
        state = dict(getattr(self, "_state", {}))
        if t is not None:
            value = _real(t, "t", "t")
            if value.shape != ():
                raise InputError(f"t must be one time in s, got shape {value.shape}", parameters=("t",))
            state["t"] = float(value)
        if temperatures:
            if not isinstance(temperatures, Mapping):
                raise InputError("temperatures must map sensor names to degC", parameters=("temperatures",))
            given = {}
            for k, v in temperatures.items():
                value = _real(v, f"temperatures[{k!r}]", "temperatures")
                if value.shape != ():
                    raise InputError(f"temperatures[{k!r}] must be one value in degC, got shape {value.shape}",
                                     parameters=("temperatures",))
                given[str(k)] = float(value)
            state["temperatures"] = {**state.get("temperatures", {}), **given}
        if forces is not None:
            f = _real(forces, "forces", "forces")
            if f.shape != (3,):
                raise InputError(f"forces must be three values (Fx, Fy, Fz in N), got shape {f.shape}")
            state["forces"] = f
        if directions is not None:
            d = _real(directions, "directions", "directions")
            if d.shape != (len(self.axes),) or not np.all(np.isin(d, (-1.0, 1.0))):
                raise InputError(f"directions must be {len(self.axes)} values of +1 or -1 "
                                 f"(axes {', '.join(self.axes)})")
            state["directions"] = d
        for key, value in state.items():
            values = value.values() if isinstance(value, dict) else np.atleast_1d(value)
            if not np.all(np.isfinite(list(values))):
                raise InputError(f"state '{key}' is not finite")
        other = object.__new__(Machine)
        other.__dict__.update(self.__dict__)
        other._state = state
        return other

    @property
    def state(self) -> dict:
        """The state set by :meth:`with_state` (empty by default).

        A dict (a copy) with the keys given so far: ``t`` (float, s), ``temperatures`` ({sensor:
        degC}), ``forces`` (ndarray of shape (3,), N), ``directions`` (ndarray of shape (n_axes,)).
        """
        return dict(getattr(self, "_state", {}))

    def _with_state_defaults(self, n: int, covariates: Mapping) -> dict:
        state = getattr(self, "_state", None)
        if not state:
            return dict(covariates)
        out = dict(covariates)
        if out.get("t") is None and "t" in state:
            out["t"] = np.full(n, state["t"])
        if "temperatures" in state:
            given = dict(out.get("temperatures") or {})
            for sensor, value in state["temperatures"].items():
                given.setdefault(sensor, np.full(n, value))
            out["temperatures"] = given
        if out.get("forces") is None and "forces" in state:
            out["forces"] = np.tile(state["forces"], (n, 1))
        if out.get("directions") is None and "directions" in state:
            out["directions"] = np.tile(state["directions"], (n, 1))
        return out

    @property
    def nonlinear_parameters(self) -> tuple[int, ...]:
        """Indices (into theta) of coefficients the model is not linear in (time constants,
        periods); tuple of int.
        """
        return tuple(span.start + tspec.term.local_names.index(local)
                     for comp in self._components for tspec, span in comp.terms
                     for local in tspec.term.nonlinear)

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
        theta = self._check_theta(theta)
        for comp in self._components:
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
        used = {c for comp in self._components for tspec, _ in comp.terms for c in tspec.term.covariates}
        return frozenset(used | ({"t"} if self._lags else set()))

    @property
    def sensors(self) -> tuple[str, ...]:
        """Names of the temperature sensors the model reads, sorted (a tuple of str; empty for a
        machine without temperature-driven terms)."""
        return tuple(sorted({s for comp in self._components for tspec, _ in comp.terms
                             for s in tspec.term.temperature_sensors()}))

    def term_spans(self) -> list[slice]:
        """The slice of ``theta`` of every term, in order.

        Returns
        -------
        list of slice
            One slice into ``theta`` per term of every component, in the order of :meth:`term_info`.
        """
        return [span for comp in self._components for _, span in comp.terms]

    def term_info(self) -> list[dict]:
        """One entry per term: component, owner, kind, coefficient names.

        Returns
        -------
        list of dict
            Per term, in order: ``component`` (name), ``owner`` (axis or body name), ``kind`` (the
            term kind, e.g. "legendre") and ``parameters`` (list of its coefficient names).
        """
        out = []
        for comp in self._components:
            for tspec, span in comp.terms:
                out.append({"component": comp.name, "owner": comp.owner, "kind": tspec.term.kind,
                            "parameters": list(self._names[span])})
        return out

    # ------------------------------------------------------------------ evaluation
    def _check_theta(self, theta) -> np.ndarray:
        if theta is None:
            return self._theta
        theta = _real(theta, "theta", "theta")
        if theta.shape != (len(self._names),):
            raise InputError(f"theta has shape {theta.shape}; expected ({len(self._names)},) "
                             f"for the parameters of {self.name}")
        bad = np.flatnonzero(~np.isfinite(theta))
        if bad.size:
            raise InputError(f"theta[{bad[0]}] ({self._names[bad[0]]}) is {theta[bad[0]]}")
        return theta

    def check_q(self, q, extrapolate: bool = False) -> np.ndarray:
        """Convert ``q`` to a float array of NC positions and check it.

        Parameters
        ----------
        q : array_like, shape (N, n_axes) or (n_axes,)
            NC positions [m, rad]; a single point becomes one row.
        extrapolate : bool, default False
            Allow positions outside the travel.

        Returns
        -------
        ndarray, shape (N, n_axes)
            The positions as a new float array [m, rad].

        Raises
        ------
        InputError
            If ``q`` is not real numbers, has the wrong shape, holds a value that is not finite, or
            (unless ``extrapolate``) leaves the travel (see :meth:`outside_travel`).
        """
        q = _real(q, f"q (shape (N, {len(self.axes)}))", "q")
        if q.ndim == 1 and q.shape[0] == len(self.axes):
            q = q[None, :]
        if q.ndim != 2 or q.shape[1] != len(self.axes):
            raise InputError(f"q has shape {q.shape}; expected (N, {len(self.axes)}) with columns "
                             f"{', '.join(self.axes)}")
        bad = np.argwhere(~np.isfinite(q))
        if bad.size:
            i, j = bad[0]
            raise InputError(f"q[{i}, {j}] (axis {self.axes[j]}) is {q[i, j]}")
        if not extrapolate:
            outside = self.outside_travel(q)
            if outside.any():
                i, j = np.argwhere(outside)[0]
                unit = "m" if self.axis_kinds[j] == "linear" else "rad"
                raise InputError(
                    f"q[{i}, {j}] = {q[i, j]:.6g} {unit} is outside the travel of axis {self.axes[j]} "
                    f"[{self._travel[j, 0]:.6g}, {self._travel[j, 1]:.6g}] {unit} "
                    f"({int(outside.sum())} value(s) outside); pass extrapolate=True to evaluate there")
        return q

    def check_covariates(self, n: int, covariates: Mapping) -> Covariates:
        """Check keyword covariates (t, temperatures, forces, directions; see :meth:`volumetric_error`).

        Covariates not given are filled in from the state set by :meth:`with_state`, and the
        lagged temperatures that terms read (``sensor@<lag>s``) are added.

        Parameters
        ----------
        n : int
            Number of points.
        covariates : mapping
            ``t`` (n,) [s], ``temperatures`` {sensor: (n,)} [degC], ``forces`` (n, 3) [N],
            ``directions`` (n, n_axes) of +1/-1; missing or None entries are not given.

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
        known = {"t", "temperatures", "forces", "directions"}
        covariates = self._with_state_defaults(n, covariates)
        unknown = sorted(set(covariates) - known)
        if unknown:
            raise InputError(f"unknown covariate(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")

        def vector(name, value, shape):
            array = _real(value, f"covariate '{name}'", name.split("[")[0])
            if array.shape != shape:
                raise InputError(f"covariate '{name}' has shape {array.shape}; expected {shape}")
            bad = np.argwhere(~np.isfinite(array))
            if bad.size:
                raise InputError(f"covariate '{name}'[{', '.join(map(str, bad[0]))}] is not finite")
            return array

        t = covariates.get("t")
        t = None if t is None else vector("t", t, (n,))
        temps = {}
        for sensor, values in dict(covariates.get("temperatures") or {}).items():
            if "@" in str(sensor):
                raise InputError(f"temperature sensor name {sensor!r}: '@' is reserved for lags")
            temps[str(sensor)] = vector(f"temperatures[{sensor!r}]", values, (n,))
        forces = covariates.get("forces")
        forces = None if forces is None else vector("forces", forces, (n, 3))
        directions = covariates.get("directions")
        if directions is not None:
            directions = vector("directions", directions, (n, len(self.axes)))
            if not np.all(np.isin(directions, (-1.0, 1.0))):
                raise InputError("covariate 'directions' must hold only +1 and -1")
        return add_lagged_temperatures(Covariates(n, t, temps, forces, directions), self._lags)

    def joint_values(self, q, theta=None, *, extrapolate: bool = False, **covariates) -> np.ndarray:
        """Values of all Pinocchio joints (axes and error joints) at ``q``.

        An axis joint takes ``sign * q``; an error joint the value of its component error on the
        tool chain and its negative on the workpiece chain (see :meth:`injected_urdf`).

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
        q = self.check_q(q, extrapolate)
        theta = self._check_theta(theta)
        cov = self.check_covariates(q.shape[0], covariates)
        return self._joint_values(q, theta, cov).T

    def _axis_values(self, q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(nv, N) joint values with every error joint at zero (the nominal machine);
        ``out`` (nv, >= N) is a buffer to reuse (block loops: no fresh pages per block)."""
        if out is None:
            values = np.zeros((self._model.nv, q.shape[0]))
        else:
            values = out[:, :q.shape[0]]
            values[...] = 0.0
        values[self._axis_cols] = (q * self._axis_signs).T
        return values

    def _joint_values(self, q: np.ndarray, theta: np.ndarray, cov: Covariates,
                      out: np.ndarray | None = None) -> np.ndarray:
        """(nv, N): one row per joint, points contiguous (the kernels' layout)."""
        values = self._axis_values(q, out)
        components = self._component_values(q, theta, cov)
        for k, comp in enumerate(self._components):
            values[comp.column] += comp.chain_sign * components[k]
        return values

    def _component_values(self, q: np.ndarray, theta: np.ndarray, cov: Covariates,
                          without_covariates: bool = False) -> np.ndarray:
        """(n_components, N) component error values, SI."""
        out = np.zeros((len(self._components), q.shape[0]))
        for k, comp in enumerate(self._components):
            ctx = self._context(comp, q, cov)
            for tspec, span in comp.terms:
                if without_covariates and tspec.term.covariates:
                    continue
                out[k] += tspec.term.value(theta[span], ctx)
        return out

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
        theta = self._check_theta(theta)
        cov = self.check_covariates(q.shape[0], {} if without_covariates else covariates)
        return self._component_values(q, theta, cov, without_covariates).T

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
        single = _single(q)
        if order not in (None, 1):
            raise InputError(f"order must be None (exact) or 1 (first order), got {order!r}")
        q = self.check_q(q, extrapolate)
        theta = self._check_theta(theta)
        cov = self.check_covariates(q.shape[0], covariates)
        out = np.empty((q.shape[0], 6))
        buffer = np.empty((self._model.nv, min(self._block, q.shape[0])))
        for start in range(0, q.shape[0], self._block):  # bounded memory for millions of points
            rows = slice(start, start + self._block)
            values = self._joint_values(q[rows], theta, cov.take(rows), out=buffer)
            K.pose_error(self._chain, values, order, out=out[rows])
        return out[0] if single else out

    # ------------------------------------------------------------------ derivatives
    def _prepare(self, q, theta, extrapolate, covariates):
        q = self.check_q(q, extrapolate)
        return q, self._check_theta(theta), self.check_covariates(q.shape[0], covariates)

    def _error_jacobian(self, values: np.ndarray) -> np.ndarray:
        """(N, 6, nv) derivative of the 6-component error w.r.t. the joint values at ``values``
        (nv, N): position rows as they are, rotation rows through Jl^-1 of the rotation error."""
        J = K.joint_jacobian(self._chain, values, self._model.nv)
        phi = K.pose_error(self._chain, values, None)[:, 3:]
        J[:, 3:] = K.log3_left_jacobian_inverse(phi) @ J[:, 3:]
        return J

    def sensitivity(self, q, theta=None, *, parameters=None, first_order: bool = False,
                    extrapolate: bool = False, **covariates) -> np.ndarray:
        """Derivative of :meth:`volumetric_error` with respect to the coefficients ``theta``.

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
        single = _single(q)
        cols = self._parameter_columns(parameters)
        q, theta, cov = self._prepare(q, theta, extrapolate, covariates)
        out = np.empty((q.shape[0], 6, len(cols)))
        for start in range(0, q.shape[0], self._block):
            rows = slice(start, start + self._block)
            qb, cb = q[rows], cov.take(rows)
            values = self._axis_values(qb) if first_order else self._joint_values(qb, theta, cb)
            # d v / d theta is one joint column per coefficient, scaled by the term's basis
            K.error_sensitivity(self._chain, values,
                                np.ascontiguousarray(self._parameter_jacobian(qb, theta, cb)[:, cols]),
                                np.ascontiguousarray(self._param_column[cols]), out=out[rows])
        return out[0] if single else out

    def _parameter_columns(self, parameters) -> np.ndarray:
        """Indices of ``theta`` (all when None), checked: negative indices would wrap."""
        count = len(self._names)
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

    def _parameter_jacobian(self, q: np.ndarray, theta: np.ndarray, cov: Covariates) -> np.ndarray:
        """(N, P): d (error-joint value) / d theta_p, i.e. chain sign times the term's
        derivative with respect to its coefficient."""
        out = np.empty((q.shape[0], len(self._names)))
        for comp in self._components:
            ctx = self._context(comp, q, cov)
            for tspec, span in comp.terms:
                out[:, span] = comp.chain_sign * tspec.term.jacobian(theta[span], ctx)
        return out

    def component_sensitivity(self, q, theta=None, *, extrapolate: bool = False,
                              **covariates) -> np.ndarray:
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
        single = _single(q)
        q, theta, cov = self._prepare(q, theta, extrapolate, covariates)
        out = np.empty((q.shape[0], 6, len(self._components)))
        cols = np.array([c.column for c in self._components], dtype=int)
        signs = np.array([c.chain_sign for c in self._components])
        for start in range(0, q.shape[0], self._block):
            rows = slice(start, start + self._block)
            J = self._error_jacobian(self._joint_values(q[rows], theta, cov.take(rows)))
            out[rows] = J[:, :, cols] * signs
        return out[0] if single else out

    def error_joint_sensitivity(self, q, theta=None, *, first_order: bool = False,
                                extrapolate: bool = False, **covariates) -> np.ndarray:
        """Derivative of the error with respect to the value of every injected error joint.

        In the order of :attr:`error_joints`, ISO sense, whether or not the spec gives the joint
        a term: what adding a term to any component would do.

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
        single = _single(q)
        q, theta, cov = self._prepare(q, theta, extrapolate, covariates)
        out = np.empty((q.shape[0], 6, len(self._error_joint_cols)))
        for start in range(0, q.shape[0], self._block):
            rows = slice(start, start + self._block)
            values = (self._axis_values(q[rows]) if first_order
                      else self._joint_values(q[rows], theta, cov.take(rows)))
            J = self._error_jacobian(values)
            out[rows] = J[:, :, self._error_joint_cols] * self._error_joint_signs
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
        single = _single(q)
        q, theta, cov = self._prepare(q, theta, extrapolate, covariates)
        out = np.empty((q.shape[0], 6, len(self.axes)))
        for start in range(0, q.shape[0], self._block):
            rows = slice(start, start + self._block)
            qb, cb = q[rows], cov.take(rows)
            values = self._axis_values(qb) if nominal else self._joint_values(qb, theta, cb)
            J = K.joint_jacobian(self._chain, values, self._model.nv, nominal=nominal)
            block = J[:, :, self._axis_cols] * self._axis_signs
            if not nominal:
                for comp in self._components:
                    if comp.axis_index is None:
                        continue
                    ctx = self._context(comp, qb, cb)
                    slope = sum(tspec.term.position_slope(theta[span], ctx)
                                for tspec, span in comp.terms)
                    block[:, :, comp.axis_index] += (comp.chain_sign * J[:, :, comp.column]
                                                     * slope[:, None])
            out[rows] = block
        return out[0] if single else out

    def joint_jacobian(self, q, theta=None, *, extrapolate: bool = False, **covariates
                       ) -> np.ndarray:
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
        values = self.joint_values(q, theta, extrapolate=extrapolate, **covariates)
        return K.joint_jacobian(self._chain, values.T, self._model.nv)

    def _context(self, comp: _Component, q: np.ndarray, cov: Covariates) -> Context:
        if comp.axis_index is None:
            return Context(None, None, cov, None, comp.name)
        return Context(q[:, comp.axis_index], tuple(self._travel[comp.axis_index]), cov,
                       comp.axis_index, comp.name)

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
            return K.relative_poses(self._chain, self._axis_values(self.check_q(q, extrapolate)),
                                    with_errors=False)
        values = self.joint_values(q, theta, extrapolate=extrapolate, **covariates)
        return K.relative_poses(self._chain, values.T, with_errors=True)

    def pinocchio_configuration(self, q, theta=None, *, extrapolate: bool = False,
                                **covariates) -> np.ndarray:
        """Configurations of :attr:`model` for the points ``q``.

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
        values = self.joint_values(q, theta, extrapolate=extrapolate, **covariates)
        return K.pinocchio_configuration(self._model, values)

    def __repr__(self) -> str:
        return (f"<Machine {self.name}: axes {', '.join(self.axes)}; {len(self._components)} error "
                f"components, {len(self._names)} parameters>")


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


def _spec_package(spec: MachineSpec) -> tuple[Path, ...]:
    """The folder of the package a spec names its URDF by (``urdf = {package, path}``): the
    URDF's path without the spec's ``path``, e.g. ``.../share/example-robot-data``."""
    ref = spec.urdf_ref
    if not isinstance(ref, dict) or not isinstance(ref.get("path"), str):
        return ()
    urdf, inner = Path(spec.urdf), Path(ref["path"])
    if urdf.parts[-len(inner.parts):] != inner.parts:
        return ()
    return package_folders(Path(*urdf.parts[:-len(inner.parts)]))
