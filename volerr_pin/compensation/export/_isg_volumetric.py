"""TF5280 Volumetric Compensation files (Beckhoff TwinCAT CNC / ISG kernel): the kernel's
serial model of the machine (:mod:`volerr_pin.compensation.export`) built from the machine's own
nominal kinematics, its component tables in ISG CSV form, and the configuration list.

Files (TF5280 "General configuration", "ISG CSV format", "Units of measure"; TF5200
P-VOLC-00001..00014, P-STUP-00101):

- ``volcomp_components.csv``: one block per axis, ``#`` between blocks, ``//`` comment lines;
  header ``X EXX EYX EZX EAX EBX ECX`` (the argument and ISO 230-1 component names), one row
  per node; arguments in mm (linear) or deg (rotary), values in mm and rad;
- ``volcomp_geometry.csv``: one row of the model's constants: ``P0X P0Y P0Z`` (tool point at
  zero, mm), ``N0X N0Y N0Z`` (tool axis at zero), ``PXA PYA PZA`` ... (centres of rotation,
  mm) and the position errors (``C0Y``, ``B0A``, ... mm / rad);
- ``volcomp_0.lis``: the configuration: logical axis numbers (``x 1`` ...), ``chain``,
  ``workpiece_axes 0``, ``interpolation GRID``, ``file[j]`` / ``file_format[j] ISG_CSV``; the
  start-up lines (``vol_comp[0].file_name``, ``vol_comp[0].max_records``) as comments.

The values are the model's error parameters: the kernel computes from them the deviation of
the tool point and corrects the set-points by its negative.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ...base import DEG, MM, InputError, SpecError
from ...model import Machine, axis_jacobian, component_values, tool_poses
from .._points import MachineInputs
from ._isg_model import DIRECTIONS, VolumetricModel
from ._layouts import check_count, fixed
from ._zone import Zone, node_positions

__all__ = ["CONFIG", "COMPONENTS", "GEOMETRY", "kinematic_chain", "model_of", "read_volumetric", "volumetric_files"]

COMPONENTS = "volcomp_components.csv"
GEOMETRY = "volcomp_geometry.csv"
CONFIG = "volcomp_0.lis"
#: digits: mm to 1e-7 (0.1 nm), rad to 1e-12, deg to 1e-7
MM_DIGITS, RAD_DIGITS, DEG_DIGITS = 7, 12, 7
ROTARY_OF = {"A": 0, "B": 1, "C": 2}
LINEAR_OF = {"X": 0, "Y": 1, "Z": 2}
TOLERANCE = 1e-9                     # nominal model vs machine, m and rad


def kinematic_chain(machine: Machine) -> tuple[list[int], list[int]]:
    """The axes on the workpiece side (from the workpiece outwards) and on the tool side (from
    the bed outwards), from the model's joint tree.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    workpiece, tool : list of int
        Axis indices.
    """
    model = machine.model.pinocchio
    support_of = lambda frame: list(model.supports[model.frames[model.getFrameId(frame)].parentJoint])  # noqa: E731
    wp, tl = support_of(machine.workpiece_frame), support_of(machine.tool_frame)
    workpiece, tool = [], []
    for j, axis in enumerate(machine.spec.axes):
        jid = model.getJointId(axis.joint)
        if jid in wp and jid not in tl:
            workpiece.append((wp.index(jid), j))
        elif jid in tl and jid not in wp:
            tool.append((tl.index(jid), j))
    return [j for _, j in sorted(workpiece, reverse=True)], [j for _, j in sorted(tool)]


def model_of(machine: Machine, zone: Zone, nodes: int) -> VolumetricModel:
    """The kernel's model of ``machine``: chain, directions and centres at zero, tool point and
    axis, tables over the zone (values zero), position errors from the machine's location
    errors; checked against the machine's nominal kinematics.

    Parameters
    ----------
    machine : Machine
        The machine.
    zone : Zone
        Where the table nodes lie.
    nodes : int
        Nodes per axis.

    Returns
    -------
    VolumetricModel
        Zero-valued tables.

    Raises
    ------
    SpecError
        If the machine is not three linear axes X, Y, Z along x, y, z plus rotary axes A, B, C
        about x, y, z, or the kernel's model does not reproduce its nominal kinematics.
    """
    names, kinds = machine.axes, machine.axis_kinds
    linear = [a for a, k in zip(names, kinds) if k == "linear"]
    if sorted(linear) != ["X", "Y", "Z"] or any(a not in ROTARY_OF for a, k in zip(names, kinds) if k == "rotary"):
        raise SpecError(f"{machine.name}: TF5280 Volumetric Compensation needs precisely three linear axes X, Y, Z "
                        f"and rotary axes A, B, C; this machine has {', '.join(names)}")
    workpiece, tool = kinematic_chain(machine)
    chain = workpiece + tool
    if len(chain) != len(names):
        raise SpecError(f"{machine.name}: not every axis lies between workpiece and tool")
    zero = np.zeros((1, len(names)))
    J = axis_jacobian(machine.model, zero, nominal=True)[0]
    R0, p0 = tool_poses(machine.model, zero, nominal=True)
    directions, centres = np.zeros((len(chain), 3)), np.zeros((len(chain), 3))
    for k, j in enumerate(chain):
        if kinds[j] == "linear":
            u, want = J[:3, j], LINEAR_OF[names[j]]
        else:
            u, want = J[3:, j], ROTARY_OF[names[j]]
            v = J[:3, j]
            centres[k] = p0[0] + np.cross(u, v) / (u @ u)
        if abs(u[want] - 1.0) > TOLERANCE or np.abs(np.delete(u, want)).max() > TOLERANCE:
            verb = "move along" if kinds[j] == "linear" else "turn about"
            raise SpecError(f"{machine.name}: axis {names[j]} does not {verb} +{'xyz'[want]} at zero "
                            f"({np.round(u, 9).tolist()}); the kernel's model takes axis letters as directions")
        directions[k] = np.eye(3)[want]
    count = check_count(nodes, 2, 100000, "a TF5280 component table")
    grids = tuple(node_positions(*zone.ranges[j], count, kinds[j]) for j in chain)
    positions = np.zeros((len(chain), 6))
    inputs = MachineInputs(machine)
    at_zero = None
    for name in machine.components:
        if len(name) == 4 and name[0] == "E" and name[2] == "0" and name[3] in [names[j] for j in chain]:
            k = [names[j] for j in chain].index(name[3])
            if at_zero is None:
                at_zero = component_values(inputs.model, zero, inputs.theta, inputs.covariates(1))[0]
            positions[k, DIRECTIONS.index(name[1])] = at_zero[machine.components.index(name)]
    model = VolumetricModel(tuple(chain), tuple(names[j] for j in chain), tuple(kinds[j] == "rotary" for j in chain),
                            directions, centres, p0[0].copy(), R0[0][:, 2].copy(), grids,
                            tuple(np.zeros((count, 6)) for _ in chain), positions, len(names),
                            notes=(f"chain {''.join(names[j] for j in chain)} from the workpiece to the tool",))
    _check_nominal(machine, model, zone)
    return model


def _check_nominal(machine: Machine, model: VolumetricModel, zone: Zone) -> None:
    points = zone.sample(64, seed=7)
    q = points.q
    tool = np.zeros(len(q))
    _, p = tool_poses(machine.model, q, nominal=True)
    mismatch = np.abs(model.tool_points(q, tool, with_errors=False) - p).max()
    if mismatch > TOLERANCE:
        raise SpecError(f"{machine.name}: the kernel's serial model (chain {''.join(model.names)}, centres at zero) "
                        f"misses the machine's nominal tool point by {mismatch * 1e6:.3g} um")


# ------------------------------------------------------------------ files

def _fmt(value: float, digits: int) -> str:
    return fixed(value, digits)


def volumetric_files(model: VolumetricModel, machine: Machine) -> dict[str, str]:
    """The ISG CSV files and the configuration list.

    Parameters
    ----------
    model : VolumetricModel
        The kernel's model with its (rounded) tables.
    machine : Machine
        The machine.

    Returns
    -------
    dict of str to str
        File name -> text.
    """
    lines = [f"// volerr_pin: ISO 230-1 component errors of {machine.name} for TF5280 Volumetric Compensation",
             "// values in mm (EX?, EY?, EZ?) and rad (EA?, EB?, EC?); arguments in mm (linear) or deg (rotary)",
             "// errors are motions of the tool relative to the workpiece; every axis is tool-side (workpiece_axes 0)"]
    for k, name in enumerate(model.names):
        if k:
            lines.append("#")
        lines.append("  ".join([name] + [f"E{d}{name}" for d in DIRECTIONS]))
        scale = DEG if model.rotary[k] else MM
        for x, row in zip(model.nodes[k], model.tables[k]):
            cells = [_fmt(x / scale, DEG_DIGITS if model.rotary[k] else MM_DIGITS)]
            cells += [_fmt(v / MM, MM_DIGITS) for v in row[:3]] + [_fmt(v, RAD_DIGITS) for v in row[3:]]
            lines.append("  ".join(cells))
    header, row = ["P0X", "P0Y", "P0Z", "N0X", "N0Y", "N0Z"], [*(model.p0 / MM), *model.n0]
    digits = [MM_DIGITS] * 3 + [RAD_DIGITS] * 3
    for k, name in enumerate(model.names):
        if model.rotary[k]:
            header += [f"P{d}{name}" for d in "XYZ"]
            row += list(model.centres[k] / MM)
            digits += [MM_DIGITS] * 3
    for k, name in enumerate(model.names):
        for c, d in enumerate(DIRECTIONS):
            if model.positions[k, c] != 0.0:
                header.append(f"{d}0{name}")
                row.append(model.positions[k, c] / (MM if c < 3 else 1.0))
                digits.append(MM_DIGITS if c < 3 else RAD_DIGITS)
    geometry = [f"// volerr_pin: kinematic model and position errors of {machine.name} "
                "(mm, rad; N0: tool axis at zero)",
                "  ".join(header), "  ".join(_fmt(v, d) for v, d in zip(row, digits))]
    records = sum(len(n) for n in model.nodes) + 1
    config = [f"# volerr_pin: TF5280 Volumetric Compensation of {machine.name} (compensation 0)",
              "# logical axis numbers: the machine's axes in order, numbered from 1",
              *[f"{name.lower()} {j + 1}" for j, name in enumerate(machine.axes)],
              f"chain {''.join(model.names)}", "workpiece_axes 0", "interpolation GRID",
              f"file[0] {COMPONENTS}", "file_format[0] ISG_CSV", f"file[1] {GEOMETRY}", "file_format[1] ISG_CSV",
              "# start-up list (hochlauf.lis):", f"#   vol_comp[0].file_name {CONFIG}",
              f"#   vol_comp[0].max_records {records}"]
    return {COMPONENTS: "\n".join(lines) + "\n", GEOMETRY: "\n".join(geometry) + "\n", CONFIG: "\n".join(config) + "\n"}


def _rows(name: str, text: str) -> list[tuple[int, list[str]]]:
    return [(n, line.split()) for n, line in enumerate(text.splitlines(), 1)
            if line.strip() and not line.lstrip().startswith("//")]


def _number(name: str, line: int, token: str) -> float:
    if not re.fullmatch(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", token):
        raise InputError(f"{name}:{line}: {token!r} is not a number")
    return float(token)


def read_volumetric(texts: Mapping[str, str], machine: Machine) -> VolumetricModel:
    """The model the three files describe.

    Parameters
    ----------
    texts : mapping of str to str
        File name -> text.
    machine : Machine
        The machine (axis names and order).

    Returns
    -------
    VolumetricModel
        The model, tables and position errors as written.

    Raises
    ------
    InputError
        Naming file and line, for a missing file or key, an unknown column, a table not on a
        grid (arguments not strictly increasing) or a number that does not parse.
    """
    for name in (COMPONENTS, GEOMETRY, CONFIG):
        if name not in texts:
            raise InputError(f"{name}: missing")
    config = {}
    for line, tokens in _rows(CONFIG, texts[CONFIG]):
        if tokens[0].startswith("#"):
            continue
        if len(tokens) != 2:
            raise InputError(f"{CONFIG}:{line}: expected 'key value'")
        config[tokens[0]] = tokens[1]
    for key, want in (("workpiece_axes", "0"), ("interpolation", "GRID")):
        if config.get(key) != want:
            raise InputError(f"{CONFIG}: {key} must be {want}, got {config.get(key)!r}")
    chain_text = config.get("chain", "")
    names = machine.axes
    if sorted(chain_text) != sorted(names):
        raise InputError(f"{CONFIG}: chain {chain_text!r} is not an order of the axes {''.join(names)}")
    for j, name in enumerate(names):
        if config.get(name.lower()) != str(j + 1):
            raise InputError(f"{CONFIG}: logical axis number of {name} must be {j + 1}, "
                             f"got {config.get(name.lower())!r}")
    blocks: dict[str, tuple[list, list]] = {}
    header = None
    for line, tokens in _rows(COMPONENTS, texts[COMPONENTS]):
        if tokens == ["#"]:
            header = None
            continue
        if header is None:
            axis = tokens[0]
            if axis not in names or tokens[1:] != [f"E{d}{axis}" for d in DIRECTIONS] or axis in blocks:
                raise InputError(f"{COMPONENTS}:{line}: expected the header '{axis} EX{axis} ... EC{axis}' "
                                 "of a new axis")
            header = axis
            blocks[axis] = ([], [])
            continue
        if len(tokens) != 7:
            raise InputError(f"{COMPONENTS}:{line}: expected 7 numbers")
        values = [_number(COMPONENTS, line, t) for t in tokens]
        args, rows = blocks[header]
        if args and values[0] <= args[-1]:
            raise InputError(f"{COMPONENTS}:{line}: argument {values[0]:g} does not increase: not a grid")
        args.append(values[0])
        rows.append(values[1:])
    geometry = _rows(GEOMETRY, texts[GEOMETRY])
    if len(geometry) != 2 or len(geometry[0][1]) != len(geometry[1][1]):
        raise InputError(f"{GEOMETRY}: expected a header and one row of as many numbers")
    constants = {key: _number(GEOMETRY, geometry[1][0], t) for key, t in zip(geometry[0][1], geometry[1][1])}
    chain = tuple(names.index(a) for a in chain_text)
    rotary = tuple(machine.axis_kinds[j] == "rotary" for j in chain)
    directions = np.array([np.eye(3)[(ROTARY_OF if r else LINEAR_OF)[names[j]]] for j, r in zip(chain, rotary)])
    centres = np.zeros((len(chain), 3))
    positions = np.zeros((len(chain), 6))
    known = {"P0X", "P0Y", "P0Z", "N0X", "N0Y", "N0Z"}
    for k, j in enumerate(chain):
        if rotary[k]:
            keys = [f"P{d}{names[j]}" for d in "XYZ"]
            known.update(keys)
            centres[k] = [constants.get(key, 0.0) * MM for key in keys]
        for c, d in enumerate(DIRECTIONS):
            key = f"{d}0{names[j]}"
            known.add(key)
            positions[k, c] = constants.get(key, 0.0) * (MM if c < 3 else 1.0)
    unknown = sorted(set(constants) - known)
    if unknown:
        raise InputError(f"{GEOMETRY}: unknown parameter(s) {', '.join(unknown)}")
    nodes, tables = [], []
    for k, j in enumerate(chain):
        if names[j] not in blocks:
            raise InputError(f"{COMPONENTS}: no block for axis {names[j]}")
        args, rows = blocks[names[j]]
        if len(args) < 2:
            raise InputError(f"{COMPONENTS}: axis {names[j]} has {len(args)} rows; a table needs 2")
        nodes.append(np.array(args) * (DEG if rotary[k] else MM))
        rows = np.array(rows)
        rows[:, :3] *= MM
        tables.append(rows)
    p0 = np.array([constants.get(k, 0.0) for k in ("P0X", "P0Y", "P0Z")]) * MM
    n0 = np.array([constants.get(k, 0.0) for k in ("N0X", "N0Y", "N0Z")])
    return VolumetricModel(chain, tuple(names[j] for j in chain), rotary, directions, centres, p0, n0, tuple(nodes),
                           tuple(tables), positions, len(names),
                           notes=(f"chain {chain_text} from the workpiece to the tool",))


def quantise_model(model: VolumetricModel) -> VolumetricModel:
    """Tables, nodes and constants rounded to the digits the files hold.

    Parameters
    ----------
    model : VolumetricModel
        The model.

    Returns
    -------
    VolumetricModel
        The rounded model.
    """
    from dataclasses import replace

    def r(values, unit, digits):
        return np.round(np.asarray(values) / unit, digits) * unit

    tables = []
    for t in model.tables:
        t = t.copy()
        t[:, :3] = r(t[:, :3], MM, MM_DIGITS)
        t[:, 3:] = r(t[:, 3:], 1.0, RAD_DIGITS)
        tables.append(t)
    nodes = tuple(r(n, DEG if rot else MM, DEG_DIGITS if rot else MM_DIGITS)
                  for n, rot in zip(model.nodes, model.rotary))
    positions = model.positions.copy()
    positions[:, :3] = r(positions[:, :3], MM, MM_DIGITS)
    positions[:, 3:] = r(positions[:, 3:], 1.0, RAD_DIGITS)
    return replace(model, tables=tuple(tables), nodes=nodes, positions=positions, p0=r(model.p0, MM, MM_DIGITS),
                   n0=r(model.n0, 1.0, RAD_DIGITS), centres=r(model.centres, MM, MM_DIGITS))
