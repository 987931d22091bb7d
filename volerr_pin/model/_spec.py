"""Machine error specifications (TOML) and their checked, immutable form.

A spec names the URDF, the tool and workpiece frames, the machine axes (which URDF
joint, NC sign) and the error components with their terms. Units are in the key names
(``values_um``, ``value_arcsec``, ``positions_mm``). See ``docs/spec-format.md``.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from . import _terms as T
from ..base import ANGLE, LENGTH, InputError, SpecError, read_text, scale, within
from ._speckeys import NAME_RE, TermSite, check_keys, find_key, numbers, text
from ._termkinds import read_term
from ._urdf import URDF, load_urdf

DIRECTIONS = ("X", "Y", "Z", "A", "B", "C")
COMPONENT_RE = re.compile(r"^E([XYZABC])(0?)_?([A-Za-z][A-Za-z0-9_]*)$")


def component_name(direction: str, owner: str, location: bool = False) -> str:
    """The ISO 230-1 style name of a component error: ``EXX``, ``EC0Y``; owners other than one
    capital letter get ``_`` (``EX_J1``, ``EC_x``).

    Parameters
    ----------
    direction : str
        The error direction, X, Y, Z, A, B or C.
    owner : str
        The axis or body.
    location : bool, default False
        A location error (``EC0Y``).

    Returns
    -------
    str
        The name.
    """
    plain = len(owner) == 1 and owner.isupper()
    return "E" + direction + ("0" if location else "") + (owner if plain else "_" + owner)


def parse_component_name(name: str) -> tuple[str, bool, str]:
    """The parts of a component error's name: ``"EC0Y"`` -> ``("C", True, "Y")``.

    Parameters
    ----------
    name : str
        The name.

    Returns
    -------
    tuple of (str, bool, str)
        The direction, whether it is a location error, and the owner.

    Raises
    ------
    ValueError
        When ``name`` is not a component error's name.
    """
    match = COMPONENT_RE.match(name)
    if not match:
        raise ValueError(name)
    direction, zero, owner = match.groups()
    if component_name(direction, owner, bool(zero)) != name:
        raise ValueError(name)
    return direction, bool(zero), owner


@dataclass(frozen=True)
class AxisSpec:
    """A machine axis: a URDF joint driven by an NC coordinate.

    Attributes
    ----------
    name : str
        The axis' NC address letter or name (``X``, ``J1``).
    joint : str
        The URDF joint it drives.
    sign : float
        +1 or -1: joint value = sign * NC position.
    frame : str
        "moving" puts the axis' component errors after the joint, "fixed" before it (at the
        joint origin).
    reference : tuple of float
        Point in that frame about which angular errors act [m].
    kind : str
        "linear" (a prismatic joint; positions in m) or "rotary" (rad).
    travel : tuple of float
        NC travel (lower, upper) [m, rad], from the joint's limits and the sign.
    """

    name: str
    joint: str
    sign: float
    frame: str
    reference: tuple[float, float, float]
    kind: str = "linear"
    travel: tuple[float, float] = (-np.inf, np.inf)

    @property
    def position_quantity(self) -> str:
        """What the axis' position measures: "length" or "angle"."""
        return "length" if self.kind == "linear" else "angle"


@dataclass(frozen=True)
class BodySpec:
    """A body without an axis (turret, spindle housing) that carries component errors.

    Attributes
    ----------
    name : str
        The body's name.
    joint : str
        The URDF joint its errors act after.
    reference : tuple of float
        Point about which its angular errors act [m].
    """

    name: str
    joint: str
    reference: tuple[float, float, float]


@dataclass(frozen=True)
class TermSpec:
    """One term of a component error: its kind and form (:class:`~volerr_pin.model.Term`) and
    its coefficient values.

    Attributes
    ----------
    prefix : str
        Its coefficients' prefix among the component's terms (``""``: none; ``EXX.c2`` or
        ``EXX.drift.a0``).
    term : Term
        The term.
    coefficients : ndarray, shape (term.size,)
        Its coefficient values, SI.
    """

    prefix: str
    term: T.Term
    coefficients: np.ndarray  # SI

    def names(self, component: str) -> tuple[str, ...]:
        """The coefficients' names as ``component``'s term (``EXX.c0``, ``EXX.drift.a0``).

        Parameters
        ----------
        component : str
            The component's name.

        Returns
        -------
        tuple of str
            One name per coefficient.
        """
        stem = f"{component}.{self.prefix}." if self.prefix else f"{component}."
        return tuple(stem + local for local in self.term.local_names)

    def with_coefficients(self, coefficients) -> "TermSpec":
        """The term with other coefficient values.

        Parameters
        ----------
        coefficients : array_like, shape (term.size,)
            SI values.

        Returns
        -------
        TermSpec
            A new term spec.

        Raises
        ------
        InputError
            If there are not ``term.size`` values.
        """
        values = np.array(coefficients, dtype=float).reshape(-1)
        if values.shape != (self.term.size,):
            raise InputError(f"coefficients: a {self.term.kind} term takes {self.term.size} values, got "
                             f"{values.size}", parameters=("coefficients",))
        return TermSpec(self.prefix, self.term, values)


@dataclass(frozen=True)
class ComponentSpec:
    """One component error (EXX, EC0Y, EXT ...) and its terms.

    Attributes
    ----------
    name : str
        ISO 230-1 style name (:func:`component_name`).
    direction : str
        Its error direction, X, Y, Z (translations) or A, B, C (rotations).
    owner : str
        The axis or body it belongs to.
    location : bool
        A location error (a constant of the axis' placement, ``EC0Y``).
    terms : tuple of TermSpec
        Its terms; the error is their sum.
    """

    name: str
    direction: str
    owner: str
    location: bool
    terms: tuple[TermSpec, ...]

    @property
    def quantity(self) -> str:
        """What the error measures: "length" (X, Y, Z) or "angle" (A, B, C)."""
        return "length" if self.direction in "XYZ" else "angle"


@dataclass(frozen=True)
class MachineSpec:
    """A machine's error specification: its URDF, frames, axes, bodies and component errors,
    as checked, immutable values.

    It is read from its file by :func:`load_spec` (``docs/spec-format.md``) and written back
    by :func:`~volerr_pin.model.write_spec`; between the two it is edited as typed values,
    each edit a new spec (:meth:`with_terms`, :meth:`with_component`, :meth:`without`,
    :meth:`with_axis`, :meth:`with_values`), which
    :meth:`Machine.with_spec <volerr_pin.model.Machine.with_spec>` makes a machine of.

    Attributes
    ----------
    name : str
        The machine's name.
    source : str
        Where the spec was read from (for messages).
    urdf : Path
        The nominal URDF file.
    tool_frame : str
        The URDF link whose pose error is the machine's error.
    workpiece_frame : str
        The URDF link the error is expressed in.
    axes : tuple of AxisSpec
        The NC axes, in the order of the columns of ``q``.
    bodies : tuple of BodySpec
        Bodies without an axis that carry component errors.
    components : tuple of ComponentSpec
        The component errors and their terms.
    description : str
        A line about the machine.
    reference : str
        Where the machine comes from (paper, data set).
    extra : dict or None
        Other tables of the file kept as read (``provenance``).
    urdf_ref : object
        The spec file's own ``urdf`` value (path text or package table).
    """

    name: str
    source: str
    urdf: Path
    tool_frame: str
    workpiece_frame: str
    axes: tuple[AxisSpec, ...]
    bodies: tuple[BodySpec, ...]
    components: tuple[ComponentSpec, ...]
    description: str = ""
    reference: str = ""     # where the machine comes from (paper, data set)
    extra: dict | None = None
    urdf_ref: object = None  # the spec's own ``urdf`` value (path text or package table)

    # ------------------------------------------------------------------ reading one term
    def _owners(self) -> dict[str, tuple[str | None, tuple | None]]:
        """Owner name -> (position quantity, travel) of every axis and body."""
        return {**{a.name: (a.position_quantity, a.travel) for a in self.axes},
                **{b.name: (None, None) for b in self.bodies}}

    def term(self, component: str, table: dict) -> TermSpec:
        """One term of ``component`` from its table in the spec file's form (keys with their
        units, ``docs/spec-format.md``), checked as a spec file is: how a term written by hand
        enters the typed spec.

        Parameters
        ----------
        component : str
            The component it is a term of (``EXY``, ``EC0Y``); its owner must be an axis or
            body of this spec.
        table : dict
            The term's table, e.g. ``{"kind": "legendre", "coefficients_um": [0, 1.5, -0.4]}``.

        Returns
        -------
        TermSpec
            The term and its coefficient values (SI).

        Raises
        ------
        SpecError
            If the component name or the table is invalid (named as this spec's source with
            the component).
        """
        where = f"{self.source}: errors.{component}"
        direction, location, owner = self._component_site(component, where)
        position_quantity, travel = self._owners()[owner]
        if location:
            position_quantity = None
        if not isinstance(table, dict):
            raise SpecError(f"{where}: expected a term table, got {table!r}")
        return build_term(table, where, "length" if direction in "XYZ" else "angle", position_quantity, travel)

    def _component_site(self, name: str, where: str) -> tuple[str, bool, str]:
        try:
            direction, location, owner = parse_component_name(name)
        except ValueError:
            raise SpecError(f"{where}: '{name}' is not a component error name such as EXX, EBY, "
                            "EC0Y or EX_J1 (E + direction X/Y/Z/A/B/C + optional 0 + axis)") from None
        owners = self._owners()
        if owner not in owners:
            raise SpecError(f"{where}: '{owner}' is not an axis or body of this machine "
                            f"(known: {', '.join(owners)})")
        return direction, location, owner

    # ------------------------------------------------------------------ edits
    def component(self, name: str) -> ComponentSpec:
        """The component ``name``.

        Parameters
        ----------
        name : str
            Its name.

        Returns
        -------
        ComponentSpec
            The component.

        Raises
        ------
        InputError
            If the spec has no such component.
        """
        for comp in self.components:
            if comp.name == name:
                return comp
        raise InputError(f"{name} is not among the components of {self.name}", parameters=("component",))

    def with_component(self, component: str, *terms: TermSpec) -> "MachineSpec":
        """The spec with ``component``'s terms replaced by ``terms`` (the component added at
        the end when the spec has none).

        Parameters
        ----------
        component : str
            The component's name.
        *terms : TermSpec
            Its terms, at least one.

        Returns
        -------
        MachineSpec
            The edited spec.

        Raises
        ------
        SpecError
            If the name is not a component of an axis or body of this spec, no term is given,
            a term does not fit the component (an axis' term on a body, a length term on an
            angular error), or two terms' coefficients have the same names.
        """
        where = f"{self.source}: errors.{component}"
        direction, location, owner = self._component_site(component, where)
        if not terms:
            raise SpecError(f"{where}: give at least one term (or remove the component with without())")
        for tspec in terms:
            if not isinstance(tspec, TermSpec):
                raise SpecError(f"{where}: expected TermSpec terms (MachineSpec.term reads a table), got "
                                f"{type(tspec).__name__}")
            _fits(tspec, where, direction, location, self._owners()[owner][0])
        names = [n for tspec in terms for n in tspec.names(component)]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise SpecError(f"{where}: coefficient names {repeated} repeat; give the terms distinct prefixes")
        new = ComponentSpec(component, direction, owner, location, tuple(terms))
        if any(c.name == component for c in self.components):
            components = tuple(new if c.name == component else c for c in self.components)
        else:
            components = self.components + (new,)
        return replace(self, components=components)

    def with_terms(self, component: str, *terms: TermSpec) -> "MachineSpec":
        """The spec with ``terms`` added to ``component``'s (the component added when the spec
        has none); every other coefficient keeps its value.

        Parameters
        ----------
        component : str
            The component's name.
        *terms : TermSpec
            The terms to add.

        Returns
        -------
        MachineSpec
            The edited spec.

        Raises
        ------
        SpecError
            As :meth:`with_component`.
        """
        present = next((c.terms for c in self.components if c.name == component), ())
        return self.with_component(component, *present, *terms)

    def without(self, *components: str) -> "MachineSpec":
        """The spec without these components (their error joints stay, at zero).

        Parameters
        ----------
        *components : str
            Component names.

        Returns
        -------
        MachineSpec
            The edited spec.

        Raises
        ------
        InputError
            If a name is not among the spec's components.
        """
        unknown = sorted(set(components) - {c.name for c in self.components})
        if unknown:
            raise InputError(f"{', '.join(unknown)} not among the components of {self.name}",
                             parameters=("components",))
        return replace(self, components=tuple(c for c in self.components if c.name not in set(components)))

    def with_axis(self, axis: str, *, frame: str | None = None, reference=None) -> "MachineSpec":
        """The spec with an axis' component errors placed differently.

        Parameters
        ----------
        axis : str
            The axis.
        frame : str, optional
            "moving" (after the joint, turning with a rotary axis) or "fixed" (before it).
        reference : array_like, shape (3,), optional
            The point of that frame about which the axis' angular errors act [m].

        Returns
        -------
        MachineSpec
            The edited spec.

        Raises
        ------
        InputError
            Naming ``axes``: the axis is unknown, the frame is neither "moving" nor "fixed", or the
            reference point is not three finite numbers.
        """
        names = [a.name for a in self.axes]
        if axis not in names:
            raise InputError(f"{axis} not among the axes of {self.name} ({', '.join(names)})", parameters=("axes",))
        old = self.axes[names.index(axis)]
        frame = old.frame if frame is None else frame
        if frame not in ("moving", "fixed"):
            raise InputError(f"axes[{axis!r}]: frame must be 'moving' or 'fixed', got {frame!r}", parameters=("axes",))
        if reference is None:
            point = np.asarray(old.reference, dtype=float)
        else:
            try:
                point = np.asarray(reference, dtype=float)
            except (TypeError, ValueError):
                point = np.full(1, np.nan)
        if point.shape != (3,) or not np.isfinite(point).all():
            raise InputError(f"axes[{axis!r}]: reference must be three finite numbers [m], got {reference!r}",
                             parameters=("axes",))
        new = replace(old, frame=frame, reference=tuple(float(v) for v in point))
        return replace(self, axes=tuple(new if a.name == axis else a for a in self.axes))

    def with_values(self, theta, names) -> "MachineSpec":
        """The spec with its terms' coefficients set from values by name.

        Parameters
        ----------
        theta : array_like, shape (P,)
            SI values.
        names : sequence of str, shape (P,)
            The coefficients' names (``EXX.c0``); every coefficient of the spec must be named.

        Returns
        -------
        MachineSpec
            The spec with those values.

        Raises
        ------
        InputError
            If a coefficient of the spec is not named.
        """
        index = {n: k for k, n in enumerate(names)}
        theta = np.asarray(theta, dtype=float)
        components = []
        for comp in self.components:
            terms = []
            for tspec in comp.terms:
                try:
                    rows = [index[n] for n in tspec.names(comp.name)]
                except KeyError as err:
                    raise InputError(f"no value for the coefficient {err.args[0]}", parameters=("names",)) from None
                terms.append(TermSpec(tspec.prefix, tspec.term, theta[rows]))
            components.append(replace(comp, terms=tuple(terms)))
        return replace(self, components=tuple(components))


def _fits(tspec: TermSpec, where: str, direction: str, location: bool, position_quantity: str | None) -> None:
    """Refuse a term that the component could not hold if a spec file gave it there."""
    term, quantity = tspec.term, "length" if direction in "XYZ" else "angle"
    owner_is_axis = position_quantity is not None and not location
    if tspec.prefix and not NAME_RE.match(tspec.prefix):
        raise SpecError(f"{where}: prefix {tspec.prefix!r} is not a plain name")
    if term.axis_only and not owner_is_axis:
        raise SpecError(f"{where}: a {term.kind} term belongs to a component error of an axis")
    if term.linear_length_only and (quantity != "length" or position_quantity != "length"):
        raise SpecError(f"{where}: a {term.kind} term is a length error of a linear axis")
    if isinstance(term, (T.Polynomial, T.Table)) and not owner_is_axis:
        raise SpecError(f"{where}: a {term.kind} term needs an axis position, but this component has none "
                        "(use kind = 'constant')")
    unit = getattr(term, "unit", None)
    if unit in (ANGLE if quantity == "length" else LENGTH):
        raise SpecError(f"{where}: a term in {unit} cannot be a{'n angular' if quantity == 'angle' else ' length'} "
                        "error")
    if np.shape(tspec.coefficients) != (term.size,):
        raise SpecError(f"{where}: a {term.kind} term takes {term.size} coefficients, got "
                        f"{np.size(tspec.coefficients)}")


MACHINE_KEYS = {"name", "urdf", "tool_frame", "workpiece_frame", "description", "source"}
AXIS_KEYS = {"joint", "sign", "errors_frame", "reference_point"}
BODY_KEYS = {"joint", "reference_point"}


def _point(table: dict, where: str) -> tuple[float, float, float]:
    value, key = find_key(table, "reference_point", where, required=False, example="mm")
    if value is None:
        return (0.0, 0.0, 0.0)
    unit = key[len("reference_point_"):]
    factor = scale(unit, "length", f"{where}.{key}")
    point = numbers(value, f"{where}.{key}", 3) * factor
    within(point, "position_length", f"{where}.{key}", unit, factor)
    return tuple(float(v) for v in point)


def build_term(table: dict, where: str, quantity: str, position_quantity: str | None,
               travel: tuple[float, float] | None) -> TermSpec:
    """One term read from its table in the spec file's form (the keys of each kind:
    docs/spec-format.md); :meth:`MachineSpec.term` reads one for a component of a spec.

    Parameters
    ----------
    table : dict
        The term's table.
    where : str
        Where it is, for messages (file and table path).
    quantity : str
        What the error measures: "length" or "angle".
    position_quantity : str or None
        What the owner's axis position measures ("length", "angle"); None for a body or a
        location error.
    travel : tuple of float or None
        The axis' travel [m, rad].

    Returns
    -------
    TermSpec
        The term and its coefficients (SI).

    Raises
    ------
    SpecError
        Naming ``where`` and the key, when the table is invalid.
    """
    prefix, term, coefficients = read_term(table, TermSite(where, quantity, position_quantity, travel,
                                                            owner_is_axis=position_quantity is not None))
    return TermSpec(prefix, term, coefficients)


def read_toml(path: Path) -> dict:
    """A TOML file (a spec, a tolerance file) as a dict; see :func:`read_text` for what is
    refused before parsing.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    dict
        The parsed tables.

    Raises
    ------
    SpecError
        If the file cannot be read (see :func:`read_text`) or is not valid TOML (naming line
        and column; a key given twice is invalid TOML; nesting beyond Python's recursion
        limit is refused too).
    """
    content = read_text(path, SpecError, "spec")
    try:
        return tomllib.loads(content)
    except tomllib.TOMLDecodeError as err:
        raise SpecError(f"{path}: invalid TOML: {err}") from err
    except RecursionError:  # tomllib parses nested arrays and tables recursively
        raise SpecError(f"{path}: invalid TOML: arrays or tables nested too deeply") from None


def resolve_urdf(value: Any, base: Path, where: str) -> Path:
    """The file a spec's ``urdf`` names: a path relative to the spec, or ``{package=...,
    path=...}`` naming a file inside an installed distribution (e.g. example-robot-data).

    Parameters
    ----------
    value : str or dict
        The spec's ``urdf`` value.
    base : Path
        The spec's folder.
    where : str
        Where the value is, for messages.

    Returns
    -------
    Path
        The URDF file, resolved.

    Raises
    ------
    SpecError
        If the value is neither form, or the package or file is not found.
    """
    if isinstance(value, str):
        if not value.strip():
            raise SpecError(f"{where}: empty path")
        return (base / value).resolve()
    if isinstance(value, dict) and set(value) == {"package", "path"}:
        from importlib import metadata

        package, wanted = value["package"], value["path"]
        if not isinstance(package, str) or not isinstance(wanted, str) or not package or not wanted.strip("/"):
            raise SpecError(f"{where}: package and path must be non-empty strings, got {value!r}")
        try:
            dist = metadata.distribution(package)
        except metadata.PackageNotFoundError:
            raise SpecError(f"{where}: package '{package}' is not installed") from None
        wanted = wanted.strip("/")
        found = [file for file in dist.files or ()
                 if (name := str(file).replace("\\", "/")) == wanted or name.endswith("/" + wanted)]
        if len(found) > 1:
            raise SpecError(f"{where}: package '{package}' has {len(found)} files '{wanted}' ({found[0]}, "
                            f"{found[1]}); give more of the path")
        if found:
            return Path(dist.locate_file(found[0])).resolve()
        raise SpecError(f"{where}: package '{package}' has no file '{wanted}'")
    raise SpecError(f"{where}: expected a path or {{package = ..., path = ...}}, got {value!r}")


def axis_travel(urdf: URDF, axis: AxisSpec) -> tuple[float, float]:
    """The NC travel of an axis, from its joint limits and sign.

    Parameters
    ----------
    urdf : URDF
        The URDF.
    axis : AxisSpec
        The axis.

    Returns
    -------
    tuple of float
        (lower, upper) [m, rad].
    """
    joint = urdf.joints[axis.joint]
    a, b = axis.sign * joint.lower, axis.sign * joint.upper
    return (min(a, b), max(a, b))


def parse_components(tables: dict, where: str, owners: dict[str, tuple[str | None, tuple | None]]
                ) -> tuple[ComponentSpec, ...]:
    """The components of a spec file's ``[errors]`` tables.

    Parameters
    ----------
    tables : dict
        Component name -> one term table or ``{"terms": [...]}``.
    where : str
        The file, for messages.
    owners : dict of str to tuple
        Owner name -> (position quantity, travel) of every axis and body.

    Returns
    -------
    tuple of ComponentSpec
        The components, in the tables' order.

    Raises
    ------
    SpecError
        Naming the file, component and key of what is invalid.
    """
    components = []
    for name, table in tables.items():
        here = f"{where}: errors.{name}"
        try:
            direction, location, owner = parse_component_name(name)
        except ValueError:
            raise SpecError(f"{here}: '{name}' is not a component error name such as EXX, EBY, "
                            "EC0Y or EX_J1 (E + direction X/Y/Z/A/B/C + optional 0 + axis)") from None
        if owner not in owners:
            raise SpecError(f"{here}: '{owner}' is not an axis or body of this machine "
                            f"(known: {', '.join(owners)})")
        position_quantity, travel = owners[owner]
        if location:
            position_quantity = None  # location errors are constants (or covariate-driven)
        if not isinstance(table, dict):
            raise SpecError(f"{here}: expected a table")
        quantity = "length" if direction in "XYZ" else "angle"
        if "terms" in table:
            if set(table) != {"terms"}:
                raise SpecError(f"{here}: give either one term's keys or a 'terms' list, not both")
            if not isinstance(table["terms"], list):
                raise SpecError(f"{here}.terms: expected a list of term tables, got {table['terms']!r}")
            if not table["terms"]:
                raise SpecError(f"{here}.terms: the list is empty; give at least one term or remove "
                                f"errors.{name}")
            raw = table["terms"]
        else:
            raw = [table]
        built = tuple(build_term(t, f"{here}" + (f".terms[{i}]" if "terms" in table else ""),
                                 quantity, position_quantity, travel) for i, t in enumerate(raw))
        names = [n for tspec in built for n in tspec.names(name)]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise SpecError(f"{here}: coefficient names {duplicates} repeat; give the terms "
                            "distinct 'prefix' values")
        components.append(ComponentSpec(name, direction, owner, location, built))
    return tuple(components)


def load_spec(path: str | Path) -> tuple[MachineSpec, URDF]:
    """Read a machine's error spec (TOML, docs/spec-format.md) and the URDF it names, checking both.

    Parameters
    ----------
    path : str or Path
        The spec file.

    Returns
    -------
    spec : MachineSpec
        The spec.
    urdf : URDF
        Its URDF.

    Raises
    ------
    SpecError
        Naming the file, table and key of what is invalid.
    URDFError
        If the URDF cannot be read.
    """
    path = Path(path)
    data = read_toml(path)
    where = str(path)
    check_keys(data, {"format", "machine", "axes", "bodies", "errors", "provenance"}, where)
    fmt = data.get("format", 1)
    if isinstance(fmt, bool) or fmt != 1:
        raise SpecError(f"{where}: format {fmt!r} is not supported (expected 1)")
    machine = data.get("machine")
    if not isinstance(machine, dict):
        raise SpecError(f"{where}: missing [machine] table")
    for key in ("axes", "bodies", "errors", "provenance"):
        if key in data and not isinstance(data[key], dict):
            raise SpecError(f"{where}: '{key}' must be a table ([{key}.<name>] sections), got {data[key]!r}")
    check_keys(machine, MACHINE_KEYS, f"{where}: [machine]")
    for key in ("name", "urdf", "tool_frame", "workpiece_frame"):
        if key not in machine:
            raise SpecError(f"{where}: [machine] needs '{key}'")
    strings = {key: text(machine, key, f"{where}: machine", default="")
               for key in ("name", "tool_frame", "workpiece_frame", "description", "source")}
    if not strings["name"].strip():
        raise SpecError(f"{where}: machine.name is empty")
    urdf = load_urdf(resolve_urdf(machine["urdf"], path.parent, f"{where}: machine.urdf"))
    for key in ("tool_frame", "workpiece_frame"):
        if machine[key] not in urdf.links:
            raise SpecError(f"{where}: machine.{key} = '{machine[key]}' is not a link of {urdf.source}")
    axes, owners = [], {}
    raw_axes = data.get("axes", {})
    if not raw_axes:
        raise SpecError(f"{where}: [axes] names no axis")
    for name, table in raw_axes.items():
        here = f"{where}: axes.{name}"
        if not NAME_RE.match(name):
            raise SpecError(f"{here}: axis names must be plain names like X or J1")
        if not isinstance(table, dict) or "joint" not in table:
            raise SpecError(f"{here}: needs joint = '<URDF joint name>'")
        check_keys(table, AXIS_KEYS, here)
        joint = text(table, "joint", here)
        if joint not in urdf.joints:
            raise SpecError(f"{here}: joint '{joint}' is not a joint of {urdf.source}")
        jtype = urdf.joints[joint].type
        if jtype not in ("prismatic", "revolute", "continuous"):
            raise SpecError(f"{here}: joint '{joint}' is {jtype}; an axis must be prismatic, "
                            "revolute or continuous")
        sign = table.get("sign", 1)
        if isinstance(sign, bool) or sign not in (1, -1):
            raise SpecError(f"{here}.sign: must be 1 or -1, got {sign!r}")
        frame = table.get("errors_frame", "moving" if jtype == "prismatic" else "fixed")
        if frame not in ("moving", "fixed"):
            raise SpecError(f"{here}.errors_frame: must be 'moving' or 'fixed', got {frame!r}")
        axis = AxisSpec(name, joint, float(sign), frame, _point(table, here),
                        "linear" if jtype == "prismatic" else "rotary")
        axis = replace(axis, travel=axis_travel(urdf, axis))
        axes.append(axis)
        owners[name] = (axis.position_quantity, axis.travel)
    bodies = []
    for name, table in data.get("bodies", {}).items():
        here = f"{where}: bodies.{name}"
        if not NAME_RE.match(name) or name in owners:
            raise SpecError(f"{here}: body names must be plain names distinct from the axes")
        if not isinstance(table, dict) or "joint" not in table:
            raise SpecError(f"{here}: needs joint = '<URDF joint name>'")
        check_keys(table, BODY_KEYS, here)
        if text(table, "joint", here) not in urdf.joints:
            raise SpecError(f"{here}: joint '{table['joint']}' is not a joint of {urdf.source}")
        bodies.append(BodySpec(name, table["joint"], _point(table, here)))
        owners[name] = (None, None)
    used = [a.joint for a in axes] + [b.joint for b in bodies]
    if len(set(used)) != len(used):
        raise SpecError(f"{where}: a URDF joint is used by two axes or bodies: {used}")
    components = parse_components(data.get("errors", {}), where, owners)
    extra = {k: v for k, v in data.items() if k == "provenance"}
    spec = MachineSpec(strings["name"], where, Path(urdf.source), strings["tool_frame"],
                       strings["workpiece_frame"], tuple(axes), tuple(bodies), components,
                       strings["description"], strings["source"], extra or None, machine["urdf"])
    return spec, urdf


def spec_from_urdf(urdf: URDF, tool_frame: str, workpiece_frame: str, name: str | None = None
                   ) -> MachineSpec:
    """The spec of a bare URDF: every movable joint between the frames is an axis named after
    its joint, with six zero-valued constant error terms.

    Parameters
    ----------
    urdf : URDF
        The URDF.
    tool_frame : str
        The tool's link.
    workpiece_frame : str
        The workpiece's link.
    name : str, optional
        The machine's name (default the URDF's robot name, else its file's stem).

    Returns
    -------
    MachineSpec
        The spec.

    Raises
    ------
    SpecError
        If a frame is not a link, a joint's name cannot name an axis, or no movable joint lies
        between the frames.
    """
    for label, frame in (("tool_frame", tool_frame), ("workpiece_frame", workpiece_frame)):
        if frame not in urdf.links:
            raise SpecError(f"{urdf.source}: {label} '{frame}' is not a link "
                            f"(links: {', '.join(urdf.links)})")
    tool_path = urdf.path_to_root(tool_frame)
    work_path = urdf.path_to_root(workpiece_frame)
    common = {j.name for j in tool_path} & {j.name for j in work_path}
    chain = [j for j in reversed(work_path) if j.name not in common]
    chain += [j for j in reversed(tool_path) if j.name not in common]
    axes, components = [], []
    for joint in chain:
        if joint.type not in ("prismatic", "revolute", "continuous"):
            continue
        if not NAME_RE.match(joint.name):
            raise SpecError(f"{urdf.source}:{joint.line}: joint name '{joint.name}' cannot name an axis")
        axis = AxisSpec(joint.name, joint.name, 1.0, "moving" if joint.type == "prismatic" else "fixed",
                        (0.0, 0.0, 0.0), "linear" if joint.type == "prismatic" else "rotary")
        axes.append(replace(axis, travel=axis_travel(urdf, axis)))
        for direction in DIRECTIONS:
            quantity = "length" if direction in "XYZ" else "angle"
            unit = "um" if quantity == "length" else "urad"
            term = T.Constant(unit, scale(unit, quantity, unit))
            components.append(ComponentSpec(component_name(direction, joint.name), direction,
                                            joint.name, False, (TermSpec("", term, np.zeros(1)),)))
    if not axes:
        raise SpecError(f"{urdf.source}: no prismatic or revolute joint lies between "
                        f"'{workpiece_frame}' and '{tool_frame}'")
    return MachineSpec(name or urdf.name or Path(urdf.source).stem, urdf.source, Path(urdf.source),
                       tool_frame, workpiece_frame, tuple(axes), (), tuple(components))
