"""Strict URDF reading and error-joint injection.

The URDF is parsed with lxml so that every complaint names the file, the line and the
element. Injection rewrites the tree in place of the original joints: a group of six
error joints (three prismatic along x, y, z, then three revolute about x, y, z) is
inserted either *after* an axis joint (errors in the moving frame) or *before* it
(errors in the fixed frame, at the joint origin). Everything else in the file (visuals,
inertias, materials, unknown elements) is kept.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from .errors import URDFError

JOINT_TYPES = ("fixed", "prismatic", "revolute", "continuous", "floating", "planar")
#: directions of the six error joints of a group, in order
ERROR_DIRECTIONS = ("X", "Y", "Z", "A", "B", "C")
#: half-range of the limits written on injected error joints (m or rad): wide, never active
ERROR_JOINT_RANGE = 1.0


@dataclass(frozen=True)
class Joint:
    """One URDF joint as read from the file (SI units).

    Attributes
    ----------
    name : str
        Joint name.
    type : str
        "fixed", "prismatic", "revolute", "continuous", "floating" or "planar".
    parent, child : str
        Parent and child link names.
    xyz : tuple of float (3,)
        Origin translation [m].
    rpy : tuple of float (3,)
        Origin roll, pitch, yaw [rad].
    axis : tuple of float (3,)
        Unit joint axis (default (1, 0, 0)).
    lower, upper : float
        Joint limits [m or rad]; -inf, inf for joints other than prismatic and revolute.
    line : int
        Line of the ``<joint>`` element in the file (0 if unknown).
    """

    name: str
    type: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]
    lower: float
    upper: float
    line: int


@dataclass(frozen=True)
class URDF:
    """A parsed URDF: its tree and where it came from.

    Attributes
    ----------
    name : str
        Robot name ("" if the file gives none).
    source : str
        File name used in messages.
    links : tuple of str
        Link names, in file order.
    joints : dict of str to Joint
        Joints by name, in file order.
    root : str
        The root link.
    document : lxml.etree._ElementTree
        The XML document (everything in the file is kept).
    """

    name: str
    source: str
    links: tuple[str, ...]
    joints: dict[str, Joint]
    root: str
    document: etree._ElementTree

    def parent_joint(self, link: str) -> Joint | None:
        """The joint whose child is ``link`` (None for the root).

        Parameters
        ----------
        link : str
            Link name.

        Returns
        -------
        Joint or None
            The parent joint.
        """
        for joint in self.joints.values():
            if joint.child == link:
                return joint
        return None

    def path_to_root(self, link: str) -> list[Joint]:
        """Joints from ``link`` up to the root, nearest first.

        Parameters
        ----------
        link : str
            Link name.

        Returns
        -------
        list of Joint
            Empty for the root.
        """
        path = []
        joint = self.parent_joint(link)
        while joint is not None:
            path.append(joint)
            joint = self.parent_joint(joint.parent)
        return path

    def to_string(self) -> str:
        """The document as XML text.

        Returns
        -------
        str
            Pretty-printed, with an XML declaration (UTF-8).
        """
        return etree.tostring(self.document, pretty_print=True, xml_declaration=True,
                              encoding="utf-8").decode()


def _where(source: str, element) -> str:
    line = getattr(element, "sourceline", None)
    tag = element.tag if isinstance(element.tag, str) else "?"
    name = element.get("name")
    label = f"<{tag} name='{name}'>" if name else f"<{tag}>"
    return f"{source}:{line}: {label}" if line else f"{source}: {label}"


def _floats(source: str, element, attr: str, count: int, default: str | None) -> tuple[float, ...]:
    text = element.get(attr, default)
    if text is None:
        raise URDFError(f"{_where(source, element)}: missing attribute '{attr}'")
    parts = text.split()
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise URDFError(f"{_where(source, element)}: attribute {attr}='{text}' is not "
                        f"{count} numbers") from None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise URDFError(f"{_where(source, element)}: attribute {attr}='{text}' must be "
                        f"{count} finite numbers")
    return values


def parse_urdf(text: str | bytes, source: str = "<string>") -> URDF:
    """Parse and check a URDF document.

    Checks: the root element is ``<robot>``; links and joints have unique names; joint types
    are known; parents and children are defined links; every link has at most one parent
    joint; numbers are finite; prismatic and revolute joints have limits with lower < upper;
    the links form one tree.

    Parameters
    ----------
    text : str or bytes
        The XML text.
    source : str, default "<string>"
        File name used in error messages.

    Returns
    -------
    URDF
        The parsed document (joint axes normalised).

    Raises
    ------
    URDFError
        Naming the file, line and element of the first problem found.
    """
    if isinstance(text, str):
        text = text.encode()
    parser = etree.XMLParser(remove_blank_text=True)
    try:
        document = etree.ElementTree(etree.fromstring(text, parser))
    except etree.XMLSyntaxError as err:
        line, col = err.position if err.position else (err.lineno, 0)
        raise URDFError(f"{source}:{line}:{col}: malformed XML: {err.msg}") from err
    robot = document.getroot()
    if robot.tag != "robot":
        raise URDFError(f"{_where(source, robot)}: root element must be <robot>")
    links = []
    for link in robot.findall("link"):
        name = link.get("name")
        if not name:
            raise URDFError(f"{_where(source, link)}: <link> without a name")
        if name in links:
            raise URDFError(f"{_where(source, link)}: duplicate link name '{name}'")
        links.append(name)
    if not links:
        raise URDFError(f"{source}: the robot has no <link>")
    joints: dict[str, Joint] = {}
    children: dict[str, str] = {}
    for element in robot.findall("joint"):
        where = _where(source, element)
        name = element.get("name")
        if not name:
            raise URDFError(f"{where}: <joint> without a name")
        if name in joints:
            raise URDFError(f"{where}: duplicate joint name '{name}'")
        jtype = element.get("type")
        if jtype not in JOINT_TYPES:
            raise URDFError(f"{where}: joint type '{jtype}' is not one of {', '.join(JOINT_TYPES)}")
        ends = {}
        for tag in ("parent", "child"):
            sub = element.find(tag)
            if sub is None or not sub.get("link"):
                raise URDFError(f"{where}: missing <{tag} link='...'>")
            if sub.get("link") not in links:
                raise URDFError(f"{_where(source, sub)}: link '{sub.get('link')}' is not "
                                f"defined in {source}")
            ends[tag] = sub.get("link")
        if ends["child"] in children:
            raise URDFError(f"{where}: link '{ends['child']}' already has parent joint "
                            f"'{children[ends['child']]}'")
        children[ends["child"]] = name
        origin = element.find("origin")
        xyz = rpy = (0.0, 0.0, 0.0)
        if origin is not None:
            xyz = _floats(source, origin, "xyz", 3, "0 0 0")
            rpy = _floats(source, origin, "rpy", 3, "0 0 0")
        axis = (1.0, 0.0, 0.0)
        axis_el = element.find("axis")
        if axis_el is not None:
            axis = _floats(source, axis_el, "xyz", 3, None)
            norm = float(np.linalg.norm(axis))
            if norm < 1e-12:
                raise URDFError(f"{_where(source, axis_el)}: joint axis is zero")
            axis = tuple(float(a) / norm for a in axis)
        lower, upper = -math.inf, math.inf
        if jtype in ("prismatic", "revolute"):
            limit = element.find("limit")
            if limit is None:
                raise URDFError(f"{where}: a {jtype} joint needs <limit lower='...' upper='...'>")
            lower = _floats(source, limit, "lower", 1, None)[0]
            upper = _floats(source, limit, "upper", 1, None)[0]
            if not lower < upper:
                raise URDFError(f"{_where(source, limit)}: lower={lower} must be below upper={upper}")
        joints[name] = Joint(name, jtype, ends["parent"], ends["child"], xyz, rpy, axis,
                             lower, upper, element.sourceline or 0)
    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        raise URDFError(f"{source}: the links must form one tree; root candidates: {roots}")
    # a cycle would leave some link unreachable from the root
    reachable, frontier = {roots[0]}, [roots[0]]
    while frontier:
        link = frontier.pop()
        for joint in joints.values():
            if joint.parent == link and joint.child not in reachable:
                reachable.add(joint.child)
                frontier.append(joint.child)
    if len(reachable) != len(links):
        missing = sorted(set(links) - reachable)
        raise URDFError(f"{source}: links {missing} are not reachable from root '{roots[0]}' "
                        "(cycle in the joint graph)")
    return URDF(robot.get("name", ""), source, tuple(links), joints, roots[0], document)


def load_urdf(path: str | Path) -> URDF:
    """Read and parse a URDF file (see :func:`parse_urdf`).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    URDF
        The parsed document.

    Raises
    ------
    URDFError
        If the file cannot be read or is not a valid URDF.
    """
    path = Path(path)
    try:
        text = path.read_bytes()
    except OSError as err:
        raise URDFError(f"{path}: cannot read URDF: {err.strerror}") from err
    return parse_urdf(text, str(path))


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _error_joint(name: str, parent: str, child: str, direction: str,
                 xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> etree._Element:
    index = ERROR_DIRECTIONS.index(direction)
    element = etree.Element("joint", name=name, type="prismatic" if index < 3 else "revolute")
    etree.SubElement(element, "parent", link=parent)
    etree.SubElement(element, "child", link=child)
    etree.SubElement(element, "origin", xyz=_fmt(xyz), rpy=_fmt(rpy))
    axis = [0.0, 0.0, 0.0]
    axis[index % 3] = 1.0
    etree.SubElement(element, "axis", xyz=_fmt(axis))
    etree.SubElement(element, "limit", lower=repr(-ERROR_JOINT_RANGE),
                     upper=repr(ERROR_JOINT_RANGE), effort="0", velocity="0")
    return element


@dataclass(frozen=True)
class Site:
    """Where a group of six error joints goes.

    ``joint`` is the URDF joint the group is attached to; ``where`` is "after" (between
    the joint and its child link: the moving frame) or "before" (between the parent
    link and the joint, at the joint origin: the fixed frame). ``reference`` (m) is the
    point, in that frame, about which the angular errors act. ``names`` are the names
    of the six injected joints in the order X, Y, Z, A, B, C.

    Attributes
    ----------
    key : str
        Prefix of the injected link names (``<key>__err0`` ...).
    joint : str
        The URDF joint the group is attached to.
    where : str
        "after" or "before".
    reference : tuple of float (3,)
        Point about which the angular errors act [m].
    names : tuple of str (6,)
        Names of the six injected joints, X, Y, Z, A, B, C.
    """

    key: str
    joint: str
    where: str
    reference: tuple[float, float, float]
    names: tuple[str, ...]


def complete_limits(robot: etree._Element) -> bool:
    """Give every joint ``<limit>`` an ``effort`` and a ``velocity`` (0 where missing).

    URDF allows leaving them out, Pinocchio's and Rerun's importers do not. The element is
    changed in place.

    Parameters
    ----------
    robot : lxml.etree._Element
        The ``<robot>`` element.

    Returns
    -------
    bool
        True if any was missing.
    """
    missing = False
    for limit in robot.findall("joint/limit"):
        for key in ("effort", "velocity"):
            if limit.get(key) is None:
                limit.set(key, "0")
                missing = True
    return missing


def inject(urdf: URDF, sites: list[Site]) -> URDF:
    """Return a new URDF with the error-joint groups of ``sites`` inserted.

    Each group is three prismatic joints along x, y, z then three revolute joints about x, y,
    z (limits +-1 m or rad), placed at the site's reference point (see the module docstring);
    the original document is not changed.

    Parameters
    ----------
    urdf : URDF
        The nominal URDF.
    sites : list of Site
        Where the groups go.

    Returns
    -------
    URDF
        The injected URDF (its source is the original's plus " (with error joints)").

    Raises
    ------
    URDFError
        If a joint origin of the file is invalid.
    """
    document = copy.deepcopy(urdf.document)
    robot = document.getroot()
    elements = {j.get("name"): j for j in robot.findall("joint")}
    complete_limits(robot)  # Pinocchio needs effort and velocity on every limit
    for site in sites:
        element = elements[site.joint]
        ref = site.reference
        links = [f"{site.key}__err{i}" for i in range(7)]
        for link in links[1:] if site.where == "before" else links:
            robot.append(etree.Element("link", name=link))
        origin = element.find("origin")
        if site.where == "after":
            child = element.find("child")
            final_child = child.get("link")
            child.set("link", links[0])
            first_xyz, first_rpy = ref, (0.0, 0.0, 0.0)
        else:
            parent = element.find("parent")
            first_parent = parent.get("link")
            # the group takes the joint's current origin; the joint keeps only -reference
            xyz = _floats(urdf.source, origin, "xyz", 3, "0 0 0") if origin is not None else (0.0,) * 3
            rpy = _floats(urdf.source, origin, "rpy", 3, "0 0 0") if origin is not None else (0.0,) * 3
            first_xyz = tuple(np.asarray(xyz) + _rpy_matrix(rpy) @ np.asarray(ref))
            first_rpy = rpy
            parent.set("link", links[6])
            if origin is None:
                origin = etree.SubElement(element, "origin")
            origin.set("xyz", _fmt(-np.asarray(ref)))
            origin.set("rpy", "0 0 0")
        chain_parent = links[0] if site.where == "after" else first_parent
        for i, direction in enumerate(ERROR_DIRECTIONS):
            xyz, rpy = (first_xyz, first_rpy) if i == 0 else ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
            parent_link = chain_parent if i == 0 else links[i]
            robot.append(_error_joint(site.names[i], parent_link, links[i + 1], direction, xyz, rpy))
        if site.where == "after":
            closing = etree.Element("joint", name=f"{site.key}__err_end", type="fixed")
            etree.SubElement(closing, "parent", link=links[6])
            etree.SubElement(closing, "child", link=final_child)
            etree.SubElement(closing, "origin", xyz=_fmt(-np.asarray(ref)), rpy="0 0 0")
            robot.append(closing)
    text = etree.tostring(document, pretty_print=True, xml_declaration=True, encoding="utf-8")
    return parse_urdf(text, urdf.source + " (with error joints)")


def _rpy_matrix(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx
