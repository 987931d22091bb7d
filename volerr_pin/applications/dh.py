"""Denavit-Hartenberg tables to URDF: a robot described the way its maker or a paper does.

Two conventions, both written as one row per joint ``(a, alpha, d, theta)``:

- **standard** (distal): ``T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``;
- **modified** (proximal, Craig): ``T_i = Rx(alpha_i) Tx(a_i) Rz(theta_i) Tz(d_i)``, where
  row i holds ``alpha_{i-1}, a_{i-1}`` of the link before the joint.

The joint variable adds to ``theta`` (revolute) or ``d`` (prismatic); ``theta`` / ``d`` of a
row are the offsets at zero joint value. Each row becomes ``T_i(q) = A_i J(q) B_i`` with
``J`` the joint's own motion about / along z, so the URDF joint i sits at ``B_{i-1} A_i``
and a fixed joint places the tool at ``B_n T_tool``. Pinocchio's kinematics of the written
URDF equal the product of the DH matrices (the tests check random tables to 1e-12).

A table file is comma-separated:

.. code-block:: text

    # convention: standard        (or modified)
    # tool: 0, 0, 100              tool point in the last frame, mm (optional: x, y, z[, rx, ry, rz deg])
    joint,type,a_mm,alpha_deg,d_mm,theta_deg,lower,upper
    J1,revolute,312,-90,0,0,-180,180
    J2,revolute,1075,0,0,-90,-60,76

``lower`` / ``upper`` are the joint's travel (deg, or mm for a prismatic joint).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from scipy.spatial.transform import Rotation

from ..base import InputError, axis_scale
from ..measurements import MeasurementError, read_table


@dataclass(frozen=True)
class DHRow:
    """One joint of a DH table: lengths in m, angles in rad; ``lower``/``upper`` in rad (revolute) or m.

    Attributes
    ----------
    name : str
        Joint name.
    a : float
        Link length [m].
    alpha : float
        Link twist [rad].
    d : float
        Link offset [m] (offset at zero joint value for a prismatic joint).
    theta : float
        Joint angle [rad] (offset at zero joint value for a revolute joint).
    kind : str, default "revolute"
        "revolute" or "prismatic".
    lower, upper : float
        Joint travel [rad] (revolute) or [m] (prismatic); default -pi, pi.
    """

    name: str
    a: float
    alpha: float
    d: float
    theta: float
    kind: str = "revolute"
    lower: float = -math.pi
    upper: float = math.pi


def _rot(axis: str, angle: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler(axis, angle).as_matrix()
    return T


def _trans(axis: str, length: float) -> np.ndarray:
    T = np.eye(4)
    T["xyz".index(axis), 3] = length
    return T


def split(row: DHRow, convention: str) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) with ``T(q) = A J(q) B``, J the joint's motion about / along z.

    Parameters
    ----------
    row : DHRow
        The joint.
    convention : str
        "standard" or "modified".

    Returns
    -------
    A : ndarray, shape (4, 4)
        Homogeneous transform before the joint's motion [m].
    B : ndarray, shape (4, 4)
        Homogeneous transform after it [m].

    Raises
    ------
    InputError
        If ``convention`` is neither "standard" nor "modified".
    """
    revolute = row.kind == "revolute"
    if convention == "standard":
        if revolute:
            return np.eye(4), _rot("z", row.theta) @ _trans("z", row.d) @ _trans("x", row.a) @ _rot("x", row.alpha)
        return _rot("z", row.theta), _trans("z", row.d) @ _trans("x", row.a) @ _rot("x", row.alpha)
    if convention == "modified":  # Rz(theta + q) = Rz(theta) Rz(q); Tz(d + q) = Tz(q) Tz(d)
        return _rot("x", row.alpha) @ _trans("x", row.a) @ _rot("z", row.theta), _trans("z", row.d)
    raise InputError(f"convention must be 'standard' or 'modified', got {convention!r}", parameters=("convention",))


def transform(row: DHRow, q: float, convention: str) -> np.ndarray:
    """The row's homogeneous transform at joint value ``q``, from the formula.

    Parameters
    ----------
    row : DHRow
        The joint.
    q : float
        Joint value [rad] (revolute) or [m] (prismatic).
    convention : str
        "standard" or "modified".

    Returns
    -------
    ndarray, shape (4, 4)
        The transform [m].

    Raises
    ------
    InputError
        If ``convention`` is neither "standard" nor "modified".
    """
    if convention not in ("standard", "modified"):
        raise InputError(f"convention must be 'standard' or 'modified', got {convention!r}",
                         parameters=("convention",))
    theta, d = (row.theta + q, row.d) if row.kind == "revolute" else (row.theta, row.d + q)
    if convention == "standard":
        return _rot("z", theta) @ _trans("z", d) @ _trans("x", row.a) @ _rot("x", row.alpha)
    return _rot("x", row.alpha) @ _trans("x", row.a) @ _rot("z", theta) @ _trans("z", d)


def urdf_origin(T: np.ndarray) -> str:
    """The URDF ``<origin>`` element of a 4x4 transform (xyz, and rpy as URDF reads them).

    Parameters
    ----------
    T : ndarray, shape (4, 4)
        Homogeneous transform [m].

    Returns
    -------
    str
        ``<origin xyz="..." rpy="..."/>`` with xyz [m] and fixed-axis roll, pitch, yaw [rad].
    """
    xyz = " ".join(repr(float(v)) for v in T[:3, 3])
    rpy = " ".join(repr(float(v)) for v in Rotation.from_matrix(T[:3, :3]).as_euler("xyz"))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def dh_to_urdf(rows: list[DHRow], convention: str = "standard", name: str = "robot",
               base: str = "base", tool: str = "tool0", tool_transform: np.ndarray | None = None) -> str:
    """URDF text of the serial chain ``base`` - joints - ``tool`` (frames by those names).

    Parameters
    ----------
    rows : list of DHRow
        The joints, base to tool.
    convention : str, default "standard"
        "standard" or "modified".
    name : str, default "robot"
        Robot name.
    base : str, default "base"
        Name of the base link.
    tool : str, default "tool0"
        Name of the tool link.
    tool_transform : ndarray, shape (4, 4), optional
        Tool frame in the last joint's frame [m] (default identity).

    Returns
    -------
    str
        The URDF document.

    Raises
    ------
    InputError
        If there are no rows, or a link or joint name of the URDF (``base``, ``tool``, each
        joint's name and its ``<name>_link``, ``<tool>_fixed``) is empty or given twice, or
        the convention is unknown.
    """
    if not rows:
        raise InputError("a DH table needs at least one joint", parameters=("rows",))
    for what, text, parameter in [("base frame", base, "base"), ("tool frame", tool, "tool")] + \
            [(f"joint {k + 1}", r.name, None) for k, r in enumerate(rows)]:
        if not text.strip():
            raise InputError(f"{parameter or what}: empty name", parameters=(parameter,) if parameter else ())
    twice = sorted({r.name for r in rows if [q.name for q in rows].count(r.name) > 1})
    if twice:
        raise InputError(f"joint '{twice[0]}' is given twice")
    # (what, URDF name, the parameter that gives it) of every link and joint the URDF will have
    links = [("the base frame", base, "base")] + [(f"the link of joint {r.name!r}", f"{r.name}_link", None)
                                                  for r in rows] + [("the tool frame", tool, "tool")]
    joints = [(f"joint {r.name!r}", r.name, None) for r in rows] + [("the tool frame's fixed joint", f"{tool}_fixed",
                                                                      "tool")]
    for kind, named in (("link", links), ("joint", joints)):
        seen = {}
        for what, text, parameter in named:
            if text in seen:
                other, first = seen[text], parameter or seen[text][1]
                if first is None:
                    raise InputError(f"{other[0]} and {what} would both be the URDF {kind} '{text}'")
                value = base if first == "base" else tool
                raise InputError(f"{first} = {value!r} gives the URDF {kind} '{text}', which is also "
                                 f"{what if first != parameter else other[0]}; choose another name",
                                 parameters=(first,))
            seen[text] = (what, parameter)
    lines = ['<?xml version="1.0"?>', f"<robot name={quoteattr(name)}>", f"  <link name={quoteattr(base)}/>"]
    parent, before = base, np.eye(4)
    for i, row in enumerate(rows):
        A, B = split(row, convention)
        link = f"{row.name}_link"
        kind = "revolute" if row.kind == "revolute" else "prismatic"
        lines += [f"  <link name={quoteattr(link)}/>",
                  f"  <joint name={quoteattr(row.name)} type=\"{kind}\">",
                  f"    <parent link={quoteattr(parent)}/><child link={quoteattr(link)}/>",
                  f"    {urdf_origin(before @ A)}",
                  '    <axis xyz="0 0 1"/>',
                  f'    <limit lower="{row.lower!r}" upper="{row.upper!r}"/>',
                  "  </joint>"]
        parent, before = link, B
    end = before @ (np.eye(4) if tool_transform is None else np.asarray(tool_transform, dtype=float))
    lines += [f"  <link name={quoteattr(tool)}/>",
              f"  <joint name={quoteattr(tool + '_fixed')} type=\"fixed\">",
              f"    <parent link={quoteattr(parent)}/><child link={quoteattr(tool)}/>",
              f"    {urdf_origin(end)}",
              "  </joint>", "</robot>", ""]
    return "\n".join(lines)


def read_dh(path: str | Path) -> tuple[list[DHRow], str, np.ndarray | None]:
    """Read a DH table file (see the module docstring): rows, convention, tool transform.

    Parameters
    ----------
    path : str or Path
        The table file.

    Returns
    -------
    rows : list of DHRow
        The joints, in SI.
    convention : str
        "standard" (default) or "modified", from ``# convention:``.
    tool : ndarray, shape (4, 4) or None
        Tool transform [m] from ``# tool: x, y, z[, rx, ry, rz]`` (mm, deg; fixed-axis xyz
        angles), None without the line.

    Raises
    ------
    MeasurementError
        If a required column is missing, the convention or a joint type is unknown, a
        prismatic joint lacks its limits, a lower limit is not below the upper, the tool line
        is invalid, or the table is malformed.
    """
    table = read_table(path)
    header = table.header
    needed = ["joint", "a_mm", "alpha_deg", "d_mm", "theta_deg"]
    missing = [c for c in needed if c not in header]
    if missing:
        raise MeasurementError(f"{table.path}:{table.header_line}: a DH table needs the columns "
                               f"{', '.join(needed)} (missing {', '.join(missing)})")
    col = {h: c for c, h in enumerate(header)}
    convention = table.meta.get("convention", "standard").strip().lower()
    if convention not in ("standard", "modified"):
        raise MeasurementError(f"{table.path}: '# convention: {convention}': expected standard or modified")
    rows = []
    for r, cells in enumerate(table.rows):
        kind = cells[col["type"]].strip().lower() if "type" in col else "revolute"
        if kind not in ("revolute", "prismatic"):
            raise MeasurementError(f"{table.where(r, col['type'])}: column 'type': '{kind}' is not revolute or prismatic")
        scale = axis_scale("rotary" if kind == "revolute" else "linear")
        limits = [table.number(r, col[k]) * scale if k in col else (-math.pi if k == "lower" else math.pi)
                  for k in ("lower", "upper")]
        if kind == "prismatic" and ("lower" not in col or "upper" not in col):
            raise MeasurementError(f"{table.path}:{table.lines[r]}: a prismatic joint needs lower and upper (mm)")
        if not limits[0] < limits[1]:
            raise MeasurementError(f"{table.path}:{table.lines[r]}: lower must be below upper")
        if not cells[col["joint"]].strip():
            raise MeasurementError(f"{table.where(r, col['joint'])}: column 'joint': empty joint name")
        rows.append(DHRow(cells[col["joint"]].strip(), table.number(r, col["a_mm"]) * 1e-3,
                          math.radians(table.number(r, col["alpha_deg"])), table.number(r, col["d_mm"]) * 1e-3,
                          math.radians(table.number(r, col["theta_deg"])), kind, *limits))
    tool = None
    if "tool" in table.meta:
        try:
            values = [float(v) for v in table.meta["tool"].split(",")]
        except ValueError:
            raise MeasurementError(f"{table.path}: '# tool: {table.meta['tool']}': numbers expected") from None
        if not all(math.isfinite(v) for v in values):
            raise MeasurementError(f"{table.path}: '# tool: {table.meta['tool']}': finite numbers expected")
        if len(values) not in (3, 6):
            raise MeasurementError(f"{table.path}: '# tool: ...': x, y, z (mm) and optionally rx, ry, rz (deg)")
        tool = np.eye(4)
        tool[:3, 3] = np.array(values[:3]) * 1e-3
        if len(values) == 6:
            tool[:3, :3] = Rotation.from_euler("xyz", values[3:], degrees=True).as_matrix()
    return rows, convention, tool
