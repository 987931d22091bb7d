"""Machine error specifications (TOML) and their checked, immutable form.

A spec names the URDF, the tool and workpiece frames, the machine axes (which URDF
joint, NC sign) and the error components with their terms. Units are in the key names
(``values_um``, ``value_arcsec``, ``positions_mm``). See ``docs/spec-format.md``.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import terms as T
from ..base.errors import SpecError
from ..base.safeio import read_text
from .speckeys import NAME_RE, TermSite, check_keys, find_key, numbers, text
from .termkinds import read_term
from ..base.units import scale, within
from .urdf import URDF, load_urdf

DIRECTIONS = ("X", "Y", "Z", "A", "B", "C")
COMPONENT_RE = re.compile(r"^E([XYZABC])(0?)_?([A-Za-z][A-Za-z0-9_]*)$")


def component_name(direction: str, owner: str, location: bool = False) -> str:
    """ISO 230-1 style name: ``EXX``, ``EC0Y``; owners other than one capital letter get ``_``
    (``EX_J1``, ``EC_x``)."""
    plain = len(owner) == 1 and owner.isupper()
    return "E" + direction + ("0" if location else "") + (owner if plain else "_" + owner)


def parse_component_name(name: str) -> tuple[str, bool, str]:
    """``"EC0Y"`` -> ``("C", True, "Y")``; raises ValueError when it is not a component name."""
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

    ``sign``: joint value = sign * NC position. ``frame``: "moving" puts the axis'
    component errors after the joint, "fixed" before it (at the joint origin).
    ``reference`` (m): point in that frame about which angular errors act.
    """

    name: str
    joint: str
    sign: float
    frame: str
    reference: tuple[float, float, float]


@dataclass(frozen=True)
class BodySpec:
    """A body without an axis (turret, spindle housing) that carries component errors."""

    name: str
    joint: str
    reference: tuple[float, float, float]


@dataclass(frozen=True)
class TermSpec:
    prefix: str
    term: T.Term
    coefficients: np.ndarray  # SI

    def names(self, component: str) -> tuple[str, ...]:
        stem = f"{component}.{self.prefix}." if self.prefix else f"{component}."
        return tuple(stem + local for local in self.term.local_names)


@dataclass(frozen=True)
class ComponentSpec:
    """One component error (EXX, EC0Y, EXT ...) and its terms."""

    name: str
    direction: str
    owner: str
    location: bool
    terms: tuple[TermSpec, ...]

    @property
    def quantity(self) -> str:
        return "length" if self.direction in "XYZ" else "angle"


@dataclass(frozen=True)
class MachineSpec:
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
    """Build one term from its spec table (the keys of each kind: docs/spec-format.md)."""
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
    """A spec's ``urdf``: a path relative to the spec, or ``{package=..., path=...}``
    naming a file inside an installed distribution (e.g. example-robot-data)."""
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
    """NC travel (lower, upper) of an axis, SI, from its joint limits and sign."""
    joint = urdf.joints[axis.joint]
    a, b = axis.sign * joint.lower, axis.sign * joint.upper
    return (min(a, b), max(a, b))


def parse_components(tables: dict, where: str, owners: dict[str, tuple[str | None, tuple | None]]
                ) -> tuple[ComponentSpec, ...]:
    """Components of ``[errors]``; ``owners`` maps owner name -> (position quantity, travel)."""
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
    """Read a machine error spec (TOML) and the URDF it names, checking both."""
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
        axis = AxisSpec(name, joint, float(sign), frame, _point(table, here))
        axes.append(axis)
        owners[name] = ("length" if jtype == "prismatic" else "angle", axis_travel(urdf, axis))
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
    """Spec for a bare URDF: every movable joint between the frames is an axis named after
    its joint, with six zero-valued constant error terms."""
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
        axes.append(AxisSpec(joint.name, joint.name, 1.0,
                             "moving" if joint.type == "prismatic" else "fixed", (0.0, 0.0, 0.0)))
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
