"""A machine's model: its error joints injected into the URDF, Pinocchio's model of the
result, the chain from the workpiece frame to the tool frame flattened for the compiled
kernels, and where each component error and coefficient acts. Built once per structure
(:func:`build_model`) and never changed; the algorithms (:mod:`._algorithms`) evaluate it at
points, for any coefficients and covariates.

A group of six error joints (translations X, Y, Z, then rotations A, B, C) is injected for
every owner of location errors (before the owner's joint), every axis (after its joint when
the axis' errors frame is "moving", before it when "fixed") and every body (after its
joint). Joint values: an axis joint takes ``sign * q``; an error joint the value of its
component error on the tool chain and its negative on the workpiece chain (errors are
motions of the tool relative to the workpiece).
"""

from __future__ import annotations

import dataclasses

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from . import _kinematics as K
from ..base import SpecError, URDFError
from ._spec import DIRECTIONS, MachineSpec, axis_travel, component_name
from ._urdf import URDF, Site, inject, package_folders

__all__ = ["BLOCK_BYTES", "ComponentSite", "Model", "build_model"]

#: most memory one block of a batch evaluation takes for its Jacobians [bytes]
BLOCK_BYTES = 128_000_000


@dataclass(frozen=True)
class ComponentSite:
    """Where a component error acts.

    Attributes
    ----------
    name : str
        The component ("EXX").
    owner : str
        The axis or body it belongs to.
    axis_index : int or None
        Index into the machine's axes of the axis whose position it is a function of; None
        for bodies and location errors.
    column : int
        Pinocchio velocity index of its error joint.
    chain_sign : float
        +1 on the tool chain, -1 on the workpiece chain.
    terms : tuple of tuple of (TermSpec, slice)
        Its terms, each with its slice of ``theta``.
    """

    name: str
    owner: str
    axis_index: int | None
    column: int
    chain_sign: float
    terms: tuple


@dataclass(frozen=True, eq=False)
class Model:
    """The model of a machine (see the module docstring): built once per structure, never
    changed, shared by every machine of the same spec whatever its coefficients or state.

    The algorithms of :mod:`volerr_pin.model` (:func:`~volerr_pin.model.volumetric_error` and
    the others) take it first, as Pinocchio's take its model.

    Attributes
    ----------
    spec : MachineSpec
        The error specification (its coefficient values are :attr:`theta`).
    urdf : URDF
        The nominal URDF, without error joints.
    package_dirs : tuple of Path
        Folders of ``package://`` packages whose meshes pictures may read.
    sites : tuple of Site
        The injected error sites, in order.
    injected : URDF
        The URDF with the error joints.
    pinocchio : pinocchio.Model
        Pinocchio's model of ``injected`` (not to be modified).
    chain : Chain
        The flattened chain from the workpiece frame to the tool frame.
    block : int
        Points per block of a batch evaluation (Jacobian blocks within :data:`BLOCK_BYTES`).
    axis_cols : ndarray of int, shape (n_axes,)
        Velocity index of each axis joint.
    axis_signs : ndarray, shape (n_axes,)
        Sign of each axis joint against the NC position.
    axis_chain : tuple of float
        +1 for an axis on the tool chain, -1 on the workpiece chain.
    error_joint_cols : ndarray of int, shape (n_error_joints,)
        Velocity index of every injected error joint.
    error_joint_signs : ndarray, shape (n_error_joints,)
        Chain sign of every injected error joint.
    travel : ndarray, shape (n_axes, 2)
        NC travel of each axis [m, rad] (not to be modified).
    components : tuple of ComponentSite
        The component errors that have terms, in the spec's order.
    lags : tuple
        The lagged temperatures the terms read.
    names : tuple of str
        Coefficient names, in the order of ``theta``.
    param_column : ndarray of int, shape (P,)
        Velocity index of the error joint of each coefficient.
    theta : ndarray, shape (P,)
        The spec's coefficient values (SI, read-only).
    structures : list of Model
        The structures (error joints, Pinocchio model, chain) edits of this model may share,
        its own first (see :func:`build_model`); shared by all of them.
    """

    spec: MachineSpec
    urdf: URDF
    package_dirs: tuple
    sites: tuple
    injected: URDF
    pinocchio: pin.Model
    chain: object
    block: int
    axis_cols: np.ndarray
    axis_signs: np.ndarray
    axis_chain: tuple
    error_joint_cols: np.ndarray
    error_joint_signs: np.ndarray
    travel: np.ndarray
    components: tuple
    lags: tuple
    names: tuple
    param_column: np.ndarray
    theta: np.ndarray
    structures: list = field(default_factory=list, repr=False)

    @property
    def name(self) -> str:
        """The machine's name, from its spec (str)."""
        return self.spec.name

    @property
    def axes(self) -> tuple[str, ...]:
        """Axis names in the order of the columns of ``q`` (tuple of str)."""
        return tuple(a.name for a in self.spec.axes)

    @property
    def axis_kinds(self) -> tuple[str, ...]:
        """Kind of each axis, "linear" (a prismatic joint, SI unit m) or "rotary" (SI unit rad)."""
        return tuple("linear" if self.urdf.joints[a.joint].type == "prismatic" else "rotary" for a in self.spec.axes)

    @property
    def nv(self) -> int:
        """Pinocchio's velocity dimension: the number of joint values (axes and error joints)."""
        return self.pinocchio.nv

    @property
    def component_names(self) -> tuple[str, ...]:
        """Names of the component errors that have terms, in the order of :attr:`components`."""
        return tuple(c.name for c in self.components)

    @property
    def error_joints(self) -> tuple[str, ...]:
        """Names of the injected error joints of the spec's sites (six per site, X, Y, Z, A, B, C)."""
        return tuple(n for s in self.sites for n in s.names)

    @property
    def nonlinear_parameters(self) -> tuple[int, ...]:
        """Indices (into theta) of coefficients the model is not linear in (time constants,
        periods); tuple of int."""
        return tuple(span.start + tspec.term.local_names.index(local)
                     for comp in self.components for tspec, span in comp.terms
                     for local in tspec.term.nonlinear)

    @property
    def covariates_used(self) -> frozenset[str]:
        """The covariates the terms read (``t`` also when a term reads lagged temperatures); a
        frozenset of str."""
        used = {c for comp in self.components for tspec, _ in comp.terms for c in tspec.term.covariates}
        return frozenset(used | ({"t"} if self.lags else set()))

    @property
    def sensors(self) -> tuple[str, ...]:
        """Names of the temperature sensors the terms read, sorted (tuple of str)."""
        return tuple(sorted({s for comp in self.components for tspec, _ in comp.terms
                             for s in tspec.term.temperature_sensors()}))

    def term_spans(self) -> list[slice]:
        """The slice of ``theta`` of every term, in order.

        Returns
        -------
        list of slice
            One slice per term of every component, in the order of :meth:`term_info`.
        """
        return [span for comp in self.components for _, span in comp.terms]

    def term_info(self) -> list[dict]:
        """One entry per term: component, owner, kind, coefficient names.

        Returns
        -------
        list of dict
            Per term, in order: ``component`` (name), ``owner`` (axis or body name), ``kind`` (the
            term kind, e.g. "legendre") and ``parameters`` (list of its coefficient names).
        """
        return [{"component": comp.name, "owner": comp.owner, "kind": tspec.term.kind,
                 "parameters": list(self.names[span])}
                for comp in self.components for tspec, span in comp.terms]


def _sites(spec: MachineSpec, every_location: bool = False) -> list[Site]:
    """The error sites of a spec: location owners, axes, bodies (see the module docstring);
    with ``every_location``, a location site for every axis and body, in the same order."""
    sites, owner_joint = [], {}
    for axis in spec.axes:
        owner_joint[axis.name] = (axis.joint, axis.reference)
    for body in spec.bodies:
        owner_joint[body.name] = (body.joint, body.reference)
    located = list(owner_joint) if every_location else sorted(
        {c.owner for c in spec.components if c.location}, key=list(owner_joint).index)
    for owner in located:
        joint, ref = owner_joint[owner]
        sites.append(Site(f"loc_{owner}", joint, "before", ref,
                          tuple(component_name(d, owner, True) for d in DIRECTIONS)))
    for axis in spec.axes:
        sites.append(Site(f"axis_{axis.name}", axis.joint, "after" if axis.frame == "moving" else "before",
                          axis.reference, tuple(component_name(d, axis.name) for d in DIRECTIONS)))
    for body in spec.bodies:
        sites.append(Site(f"body_{body.name}", body.joint, "after", body.reference,
                          tuple(component_name(d, body.name) for d in DIRECTIONS)))
    return sites


def _refuse_mimic_between(spec: MachineSpec, urdf: URDF) -> None:
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


def build_model(spec: MachineSpec, urdf: URDF, package_dirs=(), like: Model | None = None) -> Model:
    """Inject the error joints, build Pinocchio's model and flatten the chain.

    With ``like``, the model of a machine this spec edits (same URDF, axes, bodies and
    frames; other components, terms or coefficients), only the coefficients are laid out again:
    the injected URDF, Pinocchio model and chain of one of ``like``'s structures are shared.
    An edit that needs an error site none of them has (a location error added) builds once more,
    with a location site on every axis and body, and every later edit shares that structure;
    the error joints a spec does not need stay at zero there (they are in ``model`` but not in
    ``sites``). So a diagnosis, however many rounds it edits the model, builds Pinocchio's
    model at most twice.

    Parameters
    ----------
    spec : MachineSpec
        The error specification: axes, bodies, tool and workpiece frames, components and
        their terms with their coefficient values.
    urdf : URDF
        The nominal URDF the spec refers to.
    package_dirs : path or iterable of path, optional
        Folders of ``package://`` packages for pictures (the package a spec names its URDF
        by is added).
    like : Model, optional
        The model of the machine this spec edits (see above); one of another URDF, other
        axes, bodies or frames is not used.

    Returns
    -------
    Model
        The model.

    Raises
    ------
    SpecError
        If an injected joint or link name already exists in the URDF, the tool or workpiece
        frame is not in the model, a joint between them is not 1-DoF, or an axis, error site
        or component does not lie between the workpiece frame and the tool frame.
    URDFError
        If a ``<mimic>`` joint lies between the workpiece and the tool frames, the model would
        have more than :data:`~volerr_pin.model.MAX_MODEL_JOINTS` joints with its error joints,
        or Pinocchio cannot build the model.
    InputError
        If a folder of ``package_dirs`` does not exist.
    """
    package_dirs = package_folders(package_folders(package_dirs) + spec_package(spec))
    sites = _sites(spec)
    if like is None or not _same_frame(like, spec, urdf, package_dirs):
        structure = _structure(spec, urdf, package_dirs, sites)
        structure.structures.append(structure)
        return _laid_out(spec, structure, sites)
    for structure in like.structures:
        if set(sites) <= set(structure.sites):
            return _laid_out(spec, structure, sites)
    # an edit that needs error joints its machine lacks (a location error added): build once with
    # a location site on every axis and body, so that every later edit shares that model too
    try:
        structure = _structure(spec, urdf, package_dirs, _sites(spec, every_location=True))
    except (SpecError, URDFError):  # an owner off the chain, or too many joints: only what it needs
        structure = _structure(spec, urdf, package_dirs, sites)
    structure = dataclasses.replace(structure, structures=like.structures)
    like.structures.append(structure)
    return _laid_out(spec, structure, sites)


def _structure(spec: MachineSpec, urdf: URDF, package_dirs: tuple, sites: list[Site]) -> Model:
    """The error joints of ``sites`` injected into ``urdf``, Pinocchio's model of the result and
    its chain, as a model without components (:func:`_laid_out` adds them)."""
    _refuse_mimic_between(spec, urdf)
    taken = set(urdf.joints) | set(urdf.links)
    for site in sites:
        clash = taken & (set(site.names) | {f"{site.key}__err{i}" for i in range(7)})
        if clash:
            raise SpecError(f"{spec.source}: injected error joint names {sorted(clash)} "
                            f"already exist in {urdf.source}")
    injected = inject(urdf, sites)
    try:
        model = pin.buildModelFromXML(injected.to_string())
    except Exception as err:  # Pinocchio raises plain RuntimeError/ValueError
        raise URDFError(f"{urdf.source}: Pinocchio cannot build the model: {err}") from err
    for frame in (spec.tool_frame, spec.workpiece_frame):
        if not model.existFrame(frame):
            raise SpecError(f"{spec.source}: frame '{frame}' is not in the model")
    error_ids = {model.getJointId(n) for s in sites for n in s.names}
    chain = K.build_chain(model, spec.tool_frame, spec.workpiece_frame, error_ids)
    chain_sign = _chain_sign(spec, model, chain)
    axis_cols = np.array([model.idx_vs[model.getJointId(a.joint)] for a in spec.axes])
    axis_signs = np.array([a.sign for a in spec.axes])
    axis_chain = tuple(chain_sign(a.joint, f"axis {a.name}") for a in spec.axes)
    error_joint_cols = np.array([model.idx_vs[model.getJointId(n)] for s in sites for n in s.names], dtype=int)
    error_joint_signs = np.array([chain_sign(n, f"error site {s.key}") for s in sites for n in s.names])
    travel = np.array([axis_travel(urdf, a) for a in spec.axes], dtype=float).reshape(-1, 2)
    return Model(spec, urdf, package_dirs, tuple(sites), injected, model, chain, 0, axis_cols, axis_signs,
                    axis_chain, error_joint_cols, error_joint_signs, travel, (), (), (), np.zeros(0, int), np.zeros(0))


def _chain_sign(spec: MachineSpec, model: pin.Model, chain) -> callable:
    """The sign of a joint on the chain from the workpiece to the tool; one off it is refused."""
    op_sign = dict(zip(chain.joints, chain.sign))

    def chain_sign(joint_name: str, what: str) -> float:
        jid = model.getJointId(joint_name)
        if jid not in op_sign:
            raise SpecError(f"{spec.source}: {what} (joint '{joint_name}') does not lie between "
                            f"the workpiece frame '{spec.workpiece_frame}' and the tool frame "
                            f"'{spec.tool_frame}', so it cannot move the tool relative to the "
                            "workpiece")
        return float(op_sign[jid])
    return chain_sign


def _same_frame(like: Model, spec: MachineSpec, urdf: URDF, package_dirs: tuple) -> bool:
    """Whether ``spec`` on ``urdf`` has the axes, bodies and frames of ``like``: an edit of its
    components, whose error joints may be laid out on one of ``like``'s structures."""
    old = like.spec
    return (like.urdf is urdf and like.package_dirs == package_dirs
            and (old.axes, old.bodies, old.tool_frame, old.workpiece_frame)
            == (spec.axes, spec.bodies, spec.tool_frame, spec.workpiece_frame))


def _laid_out(spec: MachineSpec, structure: Model, sites: list[Site]) -> Model:
    """The model of ``spec``: its error ``sites`` (all among the structure's) and its
    components' terms and coefficients laid out on the model and chain of ``structure``; the
    structure's other error joints stay at zero."""
    model = structure.pinocchio
    chain_sign = _chain_sign(spec, model, structure.chain)
    every = [n for s in structure.sites for n in s.names]
    col = dict(zip(every, structure.error_joint_cols))
    sign = dict(zip(every, structure.error_joint_signs))
    names_here = [n for s in sites for n in s.names]
    error_joint_cols = np.array([col[n] for n in names_here], dtype=int)
    error_joint_signs = np.array([sign[n] for n in names_here], dtype=float)
    # points per block: Jacobian blocks (rows, 6, nv) stay within BLOCK_BYTES however many
    # joints (counted without the structure's unused error joints, as a model of its own has)
    nv = model.nv - (len(every) - len(names_here))
    block = int(max(64, min(K.CHUNK, BLOCK_BYTES // (48 * nv))))
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
        components.append(ComponentSite(comp.name, comp.owner, index, model.idx_vs[jid],
                                        chain_sign(comp.name, f"error {comp.name}"), tuple(spans)))
    lags = tuple(sorted({r for c in components for tspec, _ in c.terms for r in tspec.term.lag_requests()}))
    param_column = np.array([c.column for c in components for _, span in c.terms
                             for _ in range(span.start, span.stop)], dtype=int)
    theta = np.asarray(theta, dtype=float)
    theta.flags.writeable = False
    return dataclasses.replace(structure, spec=spec, sites=tuple(sites), block=block,
                               error_joint_cols=error_joint_cols, error_joint_signs=error_joint_signs,
                               components=tuple(components), lags=lags, names=tuple(names),
                               param_column=param_column, theta=theta)


def spec_package(spec: MachineSpec) -> tuple[Path, ...]:
    """The folder of the package a spec names its URDF by (``urdf = {package, path}``): the
    URDF's path without the spec's ``path``, e.g. ``.../share/example-robot-data``.

    Parameters
    ----------
    spec : MachineSpec
        The spec.

    Returns
    -------
    tuple of Path
        The folder, or () when the spec names its URDF by a path.
    """
    ref = spec.urdf_ref
    if not isinstance(ref, dict) or not isinstance(ref.get("path"), str):
        return ()
    urdf, inner = Path(spec.urdf), Path(ref["path"])
    if urdf.parts[-len(inner.parts):] != inner.parts:
        return ()
    return package_folders(Path(*urdf.parts[:-len(inner.parts)]))
