"""Strict URDF reading and error-joint injection.

The URDF is parsed with lxml so that every complaint names the file, the line and the
element. Injection rewrites the tree in place of the original joints: a group of six
error joints (three prismatic along x, y, z, then three revolute about x, y, z) is
inserted either *after* an axis joint (errors in the moving frame) or *before* it
(errors in the fixed frame, at the joint origin). Everything else in the file (visuals,
inertias, materials, unknown elements) is kept.

Limits, checked before anything else reads the file: a URDF file holds at most
:data:`MAX_URDF_BYTES` bytes and :data:`MAX_JOINTS` joints, and a model with its error joints
at most :data:`MAX_MODEL_JOINTS` joints (see :func:`load_urdf`). Files a URDF names (meshes,
textures) are only read through :func:`checked_meshes`, which keeps them inside the URDF's own
folder and the package folders named.
"""

from __future__ import annotations

import copy
import functools
import math
import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree

from ..base import InputError, URDFError, within

JOINT_TYPES = ("fixed", "prismatic", "revolute", "continuous", "floating", "planar")
#: directions of the six error joints of a group, in order
ERROR_DIRECTIONS = ("X", "Y", "Z", "A", "B", "C")
#: half-range of the limits written on injected error joints (m or rad): wide, never active
ERROR_JOINT_RANGE = 1.0
#: travel of an endless (continuous) joint [rad]: one turn, -180 to 180 deg
ENDLESS_TRAVEL = (-math.pi, math.pi)
#: largest URDF file read [bytes]; real machines and robots take well under 1 MB
MAX_URDF_BYTES = 16_000_000
#: most joints (of any type) a URDF file may hold
MAX_JOINTS = 1000
#: most joints a model may have once its error joints are added (Pinocchio's URDF parser
#: recurses once per joint of a chain, about 2.2 kB of stack each, and crashes past ~3,700
#: joints on an 8 MB stack; 2,000 also keeps its building under about a second)
MAX_MODEL_JOINTS = 2000
#: largest mesh or texture file a URDF may name [bytes]
MAX_MESH_BYTES = 64_000_000
#: largest total of the mesh and texture files of one URDF [bytes]
MAX_MESHES_BYTES = 256_000_000


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
        Joint limits [m or rad]: those of the file for prismatic and revolute joints,
        :data:`ENDLESS_TRAVEL` (one turn, -pi to pi) for continuous joints, -inf, inf for the
        others.
    line : int
        Line of the ``<joint>`` element in the file (0 if unknown).
    mimic : str or None
        The joint a ``<mimic>`` element makes this one follow (None without one).
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
    mimic: str | None = None


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
        return self._parents.get(link)

    @functools.cached_property
    def _parents(self) -> dict[str, Joint]:
        # built once: path_to_root walks it for every link of a chain
        return {joint.child: joint for joint in self.joints.values()}

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


def _floats(source: str, element, attr: str, count: int, default: str | None, limit: str | None = None
            ) -> tuple[float, ...]:
    """``count`` finite numbers of an attribute, within the plausibility limit ``limit`` (a key of
    :data:`volerr_pin.base.PLAUSIBLE`, SI values) when one is given."""
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
    if limit is not None:
        within(values, limit, f"{_where(source, element)}: attribute {attr}='{text}'",
               "rad" if limit.endswith("angle") else "m", error=URDFError)
    return values


def _parser() -> etree.XMLParser:
    # no DTD loading, no network, no external entities: a URDF names no other file to the parser
    return etree.XMLParser(remove_blank_text=True, resolve_entities=False, no_network=True,
                           load_dtd=False, huge_tree=False)


def parse_urdf(text: str | bytes, source: str = "<string>", *, max_joints: int = MAX_JOINTS,
               max_bytes: int | None = MAX_URDF_BYTES) -> URDF:
    """Parse and check a URDF document.

    Checks: the text is at most ``max_bytes`` long and declares no XML entities; the
    root element is ``<robot>``; it holds at most ``max_joints`` joints (counted before anything
    else); links and joints have unique names; joint types are known; parents and children are
    defined links; every link has at most one parent joint; numbers are finite; prismatic and
    revolute joints have limits with lower < upper; a ``<mimic>`` names a joint of the file; the
    links form one tree. A continuous joint gets the travel :data:`ENDLESS_TRAVEL` (one turn,
    -180 to 180 deg).

    Parameters
    ----------
    text : str or bytes
        The XML text.
    source : str, default "<string>"
        File name used in error messages.
    max_joints : int, default MAX_JOINTS
        Most joints the document may hold.
    max_bytes : int or None, default MAX_URDF_BYTES
        Longest text accepted [bytes]; None for no limit.

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
    if max_bytes is not None and len(text) > max_bytes:
        raise URDFError(f"{source}: {len(text):,} bytes, more than the {max_bytes:,} a URDF may have")
    try:
        document = etree.ElementTree(etree.fromstring(text, _parser()))
    except etree.XMLSyntaxError as err:
        line, col = err.position if err.position else (err.lineno, 0)
        raise URDFError(f"{source}:{line}:{col}: malformed XML: {err.msg}") from err
    dtd = document.docinfo.internalDTD
    entities = [e.name for e in dtd.iterentities()] if dtd is not None else []
    if entities:
        raise URDFError(f"{source}: <!DOCTYPE>: XML entity declarations are not allowed in a URDF "
                        f"(<!ENTITY {entities[0]}>)")
    robot = document.getroot()
    if robot.tag != "robot":
        raise URDFError(f"{_where(source, robot)}: root element must be <robot>")
    elements = robot.findall("joint")
    if len(elements) > max_joints:
        raise URDFError(f"{source}: {len(elements):,} joints, more than the {max_joints:,} a URDF may have")
    for node in robot.iter(etree.Entity):
        raise URDFError(f"{source}:{node.sourceline}: entity reference {node.text} is not allowed in a URDF")
    links: dict[str, int] = {}
    for link in robot.findall("link"):
        name = link.get("name")
        if not name:
            raise URDFError(f"{_where(source, link)}: <link> without a name")
        if name in links:
            raise URDFError(f"{_where(source, link)}: duplicate link name '{name}'")
        links[name] = link.sourceline or 0
    if not links:
        raise URDFError(f"{source}: the robot has no <link>")
    if len(links) > max_joints + 1:
        raise URDFError(f"{source}: {len(links):,} links, more than the {max_joints + 1:,} a tree of "
                        f"{max_joints:,} joints may have")
    joints: dict[str, Joint] = {}
    children: dict[str, str] = {}
    mimics: dict[str, etree._Element] = {}
    for element in elements:
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
            xyz = _floats(source, origin, "xyz", 3, "0 0 0", "position_length")
            rpy = _floats(source, origin, "rpy", 3, "0 0 0", "position_angle")
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
            travel = "position_length" if jtype == "prismatic" else "position_angle"
            lower = _floats(source, limit, "lower", 1, None, travel)[0]
            upper = _floats(source, limit, "upper", 1, None, travel)[0]
            if not lower < upper:
                raise URDFError(f"{_where(source, limit)}: lower={lower} must be below upper={upper}")
        elif jtype == "continuous":
            lower, upper = ENDLESS_TRAVEL  # URDF gives an endless joint no limits; one turn
        mimic = element.find("mimic")
        if mimic is not None:
            mimics[name] = mimic
        joints[name] = Joint(name, jtype, ends["parent"], ends["child"], xyz, rpy, axis,
                             lower, upper, element.sourceline or 0,
                             mimic.get("joint") if mimic is not None else None)
    for name, mimic in mimics.items():
        if mimic.get("joint") not in joints or mimic.get("joint") == name:
            raise URDFError(f"{_where(source, mimic)}: joint '{name}' mimics '{mimic.get('joint')}', "
                            f"which is not another joint of {source}")
    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        shown = roots[:10] + (["..."] if len(roots) > 10 else [])
        raise URDFError(f"{source}: the links must form one tree; root candidates: {shown}")
    # a cycle would leave some link unreachable from the root
    below: dict[str, list[str]] = {}
    for joint in joints.values():
        below.setdefault(joint.parent, []).append(joint.child)
    reachable, frontier = {roots[0]}, [roots[0]]
    while frontier:
        for child in below.get(frontier.pop(), ()):
            if child not in reachable:
                reachable.add(child)
                frontier.append(child)
    if len(reachable) != len(links):
        missing = sorted(set(links) - reachable)
        raise URDFError(f"{source}: links {missing[:10]}{' ...' if len(missing) > 10 else ''} are not "
                        f"reachable from root '{roots[0]}' (cycle in the joint graph)")
    return URDF(robot.get("name", ""), source, tuple(links), joints, roots[0], document)


def load_urdf(path: str | Path) -> URDF:
    """Read and parse a URDF file (see :func:`parse_urdf`).

    The file must be a regular file of at most :data:`MAX_URDF_BYTES` (16 MB) holding at most
    :data:`MAX_JOINTS` (1,000) joints; both are checked before it is parsed. A continuous joint
    gets the travel :data:`ENDLESS_TRAVEL`, one turn from -180 to 180 deg. Meshes the file names
    are not read here (see :func:`checked_meshes`).

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
        If the file cannot be read, is not a regular file, is too large, holds too many joints
        or is not a valid URDF.
    """
    path = Path(path)
    try:
        # O_NONBLOCK: a FIFO named as the URDF must not hang the open
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as err:
        raise URDFError(f"{path}: cannot read URDF: {err.strerror}") from err
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise URDFError(f"{path}: not a regular file; a URDF must be one")
        if info.st_size > MAX_URDF_BYTES:
            raise URDFError(f"{path}: {info.st_size:,} bytes, more than the {MAX_URDF_BYTES:,} a URDF may have")
        text = _read_at_most(fd, MAX_URDF_BYTES + 1)
    except OSError as err:
        raise URDFError(f"{path}: cannot read URDF: {err.strerror}") from err
    finally:
        os.close(fd)
    return parse_urdf(text, str(path))


def _read_at_most(fd: int, limit: int) -> bytes:
    """Up to ``limit`` bytes of an open file (it may grow while it is read)."""
    parts, size = [], 0
    while size < limit:
        chunk = os.read(fd, min(1 << 20, limit - size))
        if not chunk:
            break
        parts.append(chunk)
        size += len(chunk)
    return b"".join(parts)


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


def package_folders(package_dirs) -> tuple[Path, ...]:
    """Check the folders ``package://`` file names may be looked up in.

    Parameters
    ----------
    package_dirs : path or iterable of path
        One folder or several. ``package://NAME/rest`` is ``<folder>/NAME/rest``, or
        ``<folder>/rest`` when the folder itself is called NAME (as ROS and Pinocchio look
        packages up).

    Returns
    -------
    tuple of Path
        The folders, resolved (links followed), without repeats.

    Raises
    ------
    InputError
        Naming ``package_dirs``, if one of them is not an existing folder.
    """
    if package_dirs is None:
        return ()
    if isinstance(package_dirs, (str, os.PathLike)):
        package_dirs = (package_dirs,)
    out: list[Path] = []
    for entry in package_dirs:
        text = os.fspath(entry)
        if not str(text).strip() or not os.path.isdir(text):
            raise InputError(f"package_dirs: {text!r} is not a folder", parameters=("package_dirs",))
        folder = Path(os.path.realpath(text))
        if folder not in out:
            out.append(folder)
    return tuple(out)


class _Refused(Exception):
    """Why a file a URDF names is not read (the end of a sentence starting with its name)."""


_PACKAGE_RE = re.compile(r"^[A-Za-z0-9_.+-]+$")
_SCHEME_RE = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://")


def _inside(path: str, root: str) -> bool:
    return path == root or path.startswith(root.rstrip(os.sep) + os.sep)


def _locate(filename: str, base: Path | None, packages: tuple[Path, ...]) -> tuple[Path, list[Path]]:
    """The file a URDF file name points at (links not yet followed) and the folders it must
    lie in once they are."""
    name = filename.strip()
    if not name:
        raise _Refused("is empty")
    if name.startswith("package://"):
        package, _, rest = name[len("package://"):].partition("/")
        if not _PACKAGE_RE.match(package) or package in (".", "..") or not rest:
            raise _Refused("is not package://NAME/path")
        for folder in packages:
            for root in (folder / package, folder if folder.name == package else None):
                if root is not None and root.is_dir():
                    return root / rest, [root]
        named = ", ".join(str(f) for f in packages) if packages else "none named"
        raise _Refused(f"is in package '{package}', which none of the package folders holds ({named})")
    scheme = _SCHEME_RE.match(name)
    if scheme and scheme.group(1).lower() == "file":
        name = name[len(scheme.group(0)):]
        if not name.startswith("/"):
            raise _Refused("is a file:// address without an absolute path")
    elif scheme:
        raise _Refused(f"is a {scheme.group(1)}:// address; only files are read")
    path = Path(name)
    roots = ([base] if base is not None else []) + list(packages)
    if not path.is_absolute():
        if base is None:
            raise _Refused("is relative, and the URDF was not read from a folder")
        return base / path, roots  # ../meshes beside urdf/ is read when a package folder holds it
    return path, roots


def _read_resource(filename: str, base: Path | None, packages: tuple[Path, ...], max_bytes: int
                   ) -> tuple[tuple[int, int], str, bytes]:
    """Identity (device, inode), resolved path and content of a file a URDF names, if it lies
    inside its allowed folders (links followed), is a regular file and is at most ``max_bytes``."""
    target, roots = _locate(filename, base, packages)
    real = os.path.realpath(target)
    allowed = [os.path.realpath(r) for r in roots]
    where = "the URDF's folder" + (" and the package folders named" if packages else "")
    if not any(_inside(real, r) for r in allowed):
        raise _Refused(f"lies outside {where}")
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(real, flags)  # non-blocking: a FIFO must not hang the open
    except FileNotFoundError:
        raise _Refused("does not exist") from None
    except OSError as err:
        raise _Refused(f"cannot be read ({err.strerror})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise _Refused("is not a regular file")
        if info.st_size > max_bytes:
            raise _Refused(f"is {info.st_size:,} bytes, more than the {max_bytes:,} a mesh may have")
        opened = f"/proc/self/fd/{fd}"
        if os.path.islink(opened) and not any(_inside(os.readlink(opened), r) for r in allowed):
            raise _Refused(f"lies outside {where}")  # a folder on the way was swapped for a link
        content = _read_at_most(fd, max_bytes + 1)
    except OSError as err:
        raise _Refused(f"cannot be read ({err.strerror})") from None
    finally:
        os.close(fd)
    if len(content) > max_bytes:
        raise _Refused(f"is more than the {max_bytes:,} bytes a mesh may have")
    return (info.st_dev, info.st_ino), real, content


def checked_meshes(urdf: URDF, folder: str | os.PathLike, package_dirs=(), *, path: str | os.PathLike | None = None,
                   max_bytes: int = MAX_MESH_BYTES, max_total: int = MAX_MESHES_BYTES
                   ) -> tuple[etree._ElementTree, list[str]]:
    """A copy of the URDF whose meshes and textures are copies, in ``folder``, of checked files.

    Any program given the copy (Rerun's URDF importer embeds every mesh file it names in the
    recording) reads only files that passed these checks: a relative, absolute or ``file://``
    name must lie inside the URDF's own folder or one of ``package_dirs``, a ``package://``
    name inside its package's folder among ``package_dirs``; once links are followed it
    must still lie there, be a regular file (no FIFO, device or folder)
    of at most ``max_bytes``, and all files together at most ``max_total``. Other URI schemes
    are not read. A ``<visual>`` or ``<collision>`` whose mesh fails is dropped (a
    ``<texture>``: the element), and a note says which.

    Parameters
    ----------
    urdf : URDF
        The URDF (unchanged).
    folder : path
        An existing folder to copy the files into (a temporary one).
    package_dirs : path or iterable of path, optional
        Folders of ``package://`` packages (see :func:`package_folders`).
    path : path, optional
        The URDF file, whose folder relative names start from; default ``urdf.source`` when
        that is an existing file, else no folder (only ``package://`` names are read).
    max_bytes : int, default MAX_MESH_BYTES
        Largest file read [bytes].
    max_total : int, default MAX_MESHES_BYTES
        Largest total of the files read [bytes].

    Returns
    -------
    document : lxml.etree._ElementTree
        The copy, every kept ``filename`` an absolute path in ``folder``.
    notes : list of str
        One line per element dropped: URDF file and line, the element, the file name and why.

    Raises
    ------
    InputError
        If a folder of ``package_dirs`` does not exist.
    """
    packages = package_folders(package_dirs)
    folder = Path(folder)
    if path is None and os.path.isfile(urdf.source):
        path = urdf.source
    base = Path(os.path.realpath(Path(path).parent)) if path is not None else None
    document = copy.deepcopy(urdf.document)
    robot = document.getroot()
    notes: list[str] = []
    copies: dict[tuple[int, int], str] = {}
    total = 0
    for element in list(robot.iter("mesh", "texture")):
        if robot not in element.iterancestors():
            continue  # its <visual> is already dropped
        filename = element.get("filename")
        try:
            if filename is None:
                raise _Refused("is missing")
            key, real, content = _read_resource(filename, base, packages, max_bytes)
            if key not in copies:
                if total + len(content) > max_total:
                    raise _Refused(f"would bring the files of this URDF past {max_total:,} bytes")
                total += len(content)
                safe = re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.basename(real))[-80:]
                copies[key] = str(folder / f"{len(copies):04d}_{safe}")
                Path(copies[key]).write_bytes(content)
            element.set("filename", copies[key])
        except _Refused as why:
            holder = next((a for a in element.iterancestors() if a.tag in ("visual", "collision")), None) \
                if element.tag == "mesh" else None
            drop = holder if holder is not None else element
            link = next((a.get("name") for a in element.iterancestors() if a.tag == "link"), None)
            owner = f" of link '{link}'" if link else ""
            shown = "" if filename is None else f" '{filename}'"
            notes.append(f"{urdf.source}:{element.sourceline}: <{drop.tag}>{owner} dropped: "
                         f"{element.tag} file{shown} {why}")
            drop.getparent().remove(drop)
    return document, notes


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
        If a joint origin of the file is invalid, or the model would have more than
        :data:`MAX_MODEL_JOINTS` joints (counted before anything is built).
    """
    added = sum(7 if site.where == "after" else 6 for site in sites)  # "after" closes with a fixed joint
    if len(urdf.joints) + added > MAX_MODEL_JOINTS:
        raise URDFError(f"{urdf.source}: {len(urdf.joints) + added:,} joints once the error joints are added "
                        f"({len(urdf.joints):,} in the file, {added:,} for {len(sites):,} error sites), more "
                        f"than the {MAX_MODEL_JOINTS:,} a model may have")
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
    return parse_urdf(text, urdf.source + " (with error joints)", max_joints=MAX_MODEL_JOINTS, max_bytes=None)


def _rpy_matrix(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx
