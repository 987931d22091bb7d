"""The test machine bridge_ca (``tests/data/bridge_ca``) without volerr_pin: an independent
model of its volumetric error, the functions of its spec's terms, and simulated measurement
sets with one hidden effect each, for the diagnosis tests.

bridge_ca is a 5-axis bridge (gantry) machine with a C/A swivel head: tool chain bed - Y
(bridge) - X (carriage) - Z (ram) - C (swivel, about z) - A (tilting head, about x) - tool, the
workpiece fixed on the bed. Its spec lists the axes X, Y, Z, A, C (not in kinematic order); the
columns of ``q`` here follow the spec, as the product's do.

Nothing here evaluates through volerr_pin (:func:`generate` only wraps its arrays in the
product's ``PointMeasurements``): the URDF is read with :mod:`xml.etree`, the spec with
:mod:`tomllib`, the kinematics are 4x4 homogeneous transforms in numpy, and the error groups sit
where ``docs/conventions.md`` puts them:

- a linear axis' six components (``EXX`` ... ``ECX``) after its joint, in the carriage frame,
  about the axis' reference point;
- a rotary axis' six (``EXC`` ... ``ECC``) before its joint, at the joint origin, in the
  non-rotating frame;
- location errors (``EC0X``, ``EY0A`` ...) a group before the axis' joint (before the rotary
  axis' own group), about the axis' reference point;
- a group is ``Trans(dx, dy, dz) Rx(a) Ry(b) Rz(c)``; every axis is on the tool chain, so every
  value enters as it is (a motion of the tool relative to the workpiece).

The error is the tool point's actual minus nominal position in the workpiece frame (and the
rotation vector of ``R_actual R_nominal^T``).

:func:`generate` makes a measurement set for a diagnosis: the spec's geometry with its
coefficients perturbed, small smooth geometry outside its function space, one hidden effect of
a kind (:data:`KINDS`), noise; deviations computed by :func:`reference_error`; and the finding
expected (:class:`Finding`).
"""

from __future__ import annotations

import tomllib
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

DATA = Path(__file__).resolve().parents[1] / "data" / "bridge_ca"
URDF_FILE = DATA / "bridge_ca.urdf"
SPEC_FILE = DATA / "errors.toml"

UM = 1e-6
ARCSEC = np.pi / 180.0 / 3600.0
DEG = np.pi / 180.0
LETTERS = "XYZABC"
TOOL_FRAME, WORKPIECE_FRAME = "tool", "workpiece"

#: the kinds :func:`generate` knows, in order
KINDS = ("clean", "c_once", "a_once", "c_location", "a_location", "backlash", "drift", "pitch", "bending")


# ----------------------------------------------------------------------------- the URDF and the spec
@dataclass(frozen=True)
class Joint:
    """One URDF joint: its type, links, origin, axis and limits."""

    name: str
    type: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float


def _floats(text: str | None, default: str) -> np.ndarray:
    return np.array([float(v) for v in (text if text is not None else default).split()])


def read_urdf(path: Path = URDF_FILE) -> dict[str, Joint]:
    """The joints of the URDF, by name."""
    joints = {}
    for element in ET.parse(path).getroot().findall("joint"):
        origin, axis, limit = element.find("origin"), element.find("axis"), element.find("limit")
        joints[element.get("name")] = Joint(
            element.get("name"), element.get("type"), element.find("parent").get("link"),
            element.find("child").get("link"),
            _floats(None if origin is None else origin.get("xyz"), "0 0 0"),
            _floats(None if origin is None else origin.get("rpy"), "0 0 0"),
            _floats(None if axis is None else axis.get("xyz"), "1 0 0"),
            -np.inf if limit is None else float(limit.get("lower")),
            np.inf if limit is None else float(limit.get("upper")))
    return joints


def _path_from_root(joints: dict[str, Joint], link: str) -> list[Joint]:
    """The joints from the root link down to ``link``."""
    by_child = {j.child: j for j in joints.values()}
    path = []
    while link in by_child:
        path.append(by_child[link])
        link = by_child[link].parent
    return path[::-1]


@dataclass(frozen=True)
class Axis:
    """An NC axis of the spec: its joint, kind, travel [m, rad] and reference point [m]."""

    name: str
    joint: str
    kind: str
    travel: tuple[float, float]
    reference: np.ndarray


def read_spec(path: Path = SPEC_FILE) -> tuple[tuple[Axis, ...], dict[str, np.ndarray]]:
    """The spec's axes (in its order: the columns of ``q``) and its terms: component ->
    coefficients in SI (a legendre term's c0..cN; a constant's value as one coefficient)."""
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    joints = read_urdf(path.parent / doc["machine"]["urdf"])
    axes = []
    for name, table in doc["axes"].items():
        joint = joints[table["joint"]]
        assert table.get("sign", 1) == 1, "this helper reads axes with sign 1"
        kind = "linear" if joint.type == "prismatic" else "rotary"
        axes.append(Axis(name, joint.name, kind, (joint.lower, joint.upper),
                         np.asarray(table.get("reference_point_mm", [0.0, 0.0, 0.0]), float) * 1e-3))
    terms = {}
    for name, table in doc["errors"].items():
        unit = UM if name[1] in "XYZ" else ARCSEC
        suffix = "um" if name[1] in "XYZ" else "arcsec"
        if table["kind"] == "legendre":
            terms[name] = np.asarray(table[f"coefficients_{suffix}"], float) * unit
        elif table["kind"] == "constant":
            terms[name] = np.array([float(table[f"value_{suffix}"])]) * unit
        else:
            raise ValueError(f"{name}: this helper reads legendre and constant terms only")
    return tuple(axes), terms


JOINTS = read_urdf()
AXES, SPEC_TERMS = read_spec()
AXIS_NAMES = tuple(a.name for a in AXES)
AXIS = {a.name: a for a in AXES}
TRAVEL = np.array([a.travel for a in AXES])


def owner(component: str) -> tuple[str, bool]:
    """The axis of a component name and whether it is a location error: "EXX" -> ("X", False),
    "EY0A" -> ("A", True)."""
    rest = component[2:]
    return (rest[1:], True) if rest.startswith("0") else (rest, False)


# ----------------------------------------------------------------------------- the error functions
def legendre(coefficients, u) -> np.ndarray:
    """``sum_k c_k P_k(u)`` by Bonnet's recursion ``(k + 1) P_k+1 = (2k + 1) u P_k - k P_k-1``."""
    u = np.asarray(u, float)
    previous, present = np.ones_like(u), u
    out = coefficients[0] * previous
    for k in range(1, len(coefficients)):
        out = out + coefficients[k] * present
        previous, present = present, ((2 * k + 1) * u * present - k * previous) / (k + 1)
    return out


def travel_u(axis: str, position) -> np.ndarray:
    """The argument of a Legendre term of ``axis``: ``u = 2 (q - lower) / (upper - lower) - 1``,
    -1 to 1 over the travel (docs/spec-format.md)."""
    lo, hi = AXIS[axis].travel
    return 2.0 * (np.asarray(position, float) - lo) / (hi - lo) - 1.0


def term_values(terms: dict[str, np.ndarray], q) -> dict[str, np.ndarray]:
    """The values at ``q`` (N, 5) [m, rad] of spec-style terms (component -> SI coefficients of
    a Legendre polynomial over the travel; a location error's single value is a constant)."""
    q = np.atleast_2d(np.asarray(q, float))
    out = {}
    for name, coefficients in terms.items():
        axis, location = owner(name)
        if location:
            out[name] = np.full(len(q), float(coefficients[0]))
        else:
            out[name] = legendre(coefficients, travel_u(axis, q[:, AXIS_NAMES.index(axis)]))
    return out


def spec_values(q) -> dict[str, np.ndarray]:
    """The values of the spec's own terms at ``q`` (N, 5): component -> (N,) [m, rad]."""
    return term_values(SPEC_TERMS, q)


# ----------------------------------------------------------------------------- the kinematics
def _rot(axis: np.ndarray, angle) -> np.ndarray:
    """(N, 3, 3) rotations about the unit ``axis`` by ``angle`` (N,) (Rodrigues)."""
    k = axis / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    a = np.asarray(angle, float)[:, None, None]
    return np.eye(3) + np.sin(a) * K + (1.0 - np.cos(a)) * (K @ K)


def _transform(R=None, p=None, n: int = 1) -> np.ndarray:
    T = np.tile(np.eye(4), (n, 1, 1))
    if R is not None:
        T[:, :3, :3] = R
    if p is not None:
        T[:, :3, 3] = p
    return T


def _origin(joint: Joint, n: int) -> np.ndarray:
    roll, pitch, yaw = joint.rpy
    R = (_rot(np.array([0.0, 0, 1]), np.full(n, yaw)) @ _rot(np.array([0.0, 1, 0]), np.full(n, pitch))
         @ _rot(np.array([1.0, 0, 0]), np.full(n, roll)))
    return _transform(R, np.broadcast_to(joint.xyz, (n, 3)), n)


def _motion(joint: Joint, value: np.ndarray) -> np.ndarray:
    n = len(value)
    if joint.type == "prismatic":
        return _transform(p=value[:, None] * joint.axis / np.linalg.norm(joint.axis), n=n)
    if joint.type in ("revolute", "continuous"):
        return _transform(R=_rot(joint.axis, value), n=n)
    return _transform(n=n)


def _group(errors: dict, names: list[str], n: int, reference: np.ndarray) -> np.ndarray:
    """``Trans(ref) Trans(dx, dy, dz) Rx(a) Ry(b) Rz(c) Trans(-ref)`` of the six components ``names``."""
    v = [np.broadcast_to(np.asarray(errors.get(name, 0.0), float), (n,)) for name in names]
    E = _transform(p=np.column_stack(v[:3]), n=n)
    for k, unit in enumerate(np.eye(3)):
        E = E @ _transform(R=_rot(unit, v[3 + k]), n=n)
    return _transform(p=np.broadcast_to(reference, (n, 3)), n=n) @ E @ _transform(
        p=np.broadcast_to(-reference, (n, 3)), n=n)


def _pose(q, errors: dict | None) -> tuple[np.ndarray, np.ndarray]:
    """(N, 4, 4) poses of the tool frame and of the workpiece frame in the bed frame."""
    q = np.atleast_2d(np.asarray(q, float))
    n, errors = len(q), errors or {}
    by_joint = {a.joint: a for a in AXES}

    def chain(frame: str) -> np.ndarray:
        T = _transform(n=n)
        for joint in _path_from_root(JOINTS, frame):
            T = T @ _origin(joint, n)
            axis = by_joint.get(joint.name)
            if axis is None:
                T = T @ _motion(joint, np.zeros(n))
                continue
            location = _group(errors, [f"E{d}0{axis.name}" for d in LETTERS], n, axis.reference)
            own = _group(errors, [f"E{d}{axis.name}" for d in LETTERS], n, axis.reference)
            motion = _motion(joint, q[:, AXIS_NAMES.index(axis.name)])
            if axis.kind == "linear":      # the location before the joint, the component errors after it
                T = T @ location @ motion @ own
            else:                          # both before the joint, in the non-rotating frame
                T = T @ location @ own @ motion
        return T

    return chain(TOOL_FRAME), chain(WORKPIECE_FRAME)


def tool_pose(q, errors: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (N, 3, 3) and position (N, 3) [m] of the tool frame in the workpiece frame;
    nominal without ``errors``."""
    tool, work = _pose(q, errors)
    T = np.linalg.inv(work) @ tool
    return T[:, :3, :3], T[:, :3, 3]


def reference_error(q, errors: dict, rotation: bool = False):
    """The volumetric error at NC positions ``q`` (N, 5) [m, rad], columns in the spec's order
    X, Y, Z, A, C.

    ``errors``: component name (``EXX``, ``EC0X``, ``EY0A`` ...) -> its value at each point
    (scalar or (N,)) [m, rad], a motion of the tool relative to the workpiece; components not
    given are zero. Returns the (N, 3) position error of the tool point in the workpiece frame
    [m]; with ``rotation`` also the (N, 3) rotation vector of ``R_actual R_nominal^T`` [rad].
    """
    R0, p0 = tool_pose(q)
    R1, p1 = tool_pose(q, errors)
    dp = p1 - p0
    if not rotation:
        return dp
    return dp, Rotation.from_matrix(R1 @ np.transpose(R0, (0, 2, 1))).as_rotvec()


# ----------------------------------------------------------------------------- simulated data
@dataclass(frozen=True)
class Finding:
    """What a diagnosis should report for a hidden effect.

    ``name``, ``axis`` and ``direction`` are those of the product's finding (``Change.name``,
    ``.axis``, ``.direction``: "x", "y", "z", for rotations the axis turned about; ``axis`` None
    where the effect is the same at the tool through every axis). ``role`` says where it shows:

    - "effect": named in ``Diagnosis.effects``;
    - "under_modelled": a raise of the spec's own component ``component`` in
      ``Diagnosis.under_modelled`` (``name`` is then the geometric kind, "straightness");
    - "absorbed": nothing to name: the effect is exactly a coefficient of the spec
      (``absorbed_by``, e.g. "EXA.c0"), which the base fit (``Diagnosis.base``) moves by
      ``size`` against the clean set of the same seed.

    ``size`` is the effect's amplitude in ``unit`` (the reversal of a backlash, the amplitude of
    a periodic error, the drift's amplitude, the largest value of a bend, a location's value);
    ``order`` the periods per revolution of a per-revolution error, ``period`` its period [deg]
    or a pitch's [mm].
    """

    name: str
    axis: str | None
    direction: str
    component: str
    size: float
    unit: str
    role: str = "effect"
    order: int | None = None
    period: float | None = None
    absorbed_by: str | None = None

    @property
    def key(self) -> tuple[str, str | None, str]:
        """(name, axis, direction), as a finding of the product is compared."""
        return (self.name, self.axis, self.direction)


@dataclass
class Truth:
    """The simulated machine: the spec's terms with perturbed coefficients (``base``:
    component -> SI Legendre coefficients or constant), smooth geometry outside that function
    space (``off``: component -> (nodes, values) of a cubic spline [m, rad] of the axis
    position), and the hidden effect (``hidden``: its description, ``None`` for "clean").
    """

    kind: str
    seed: int
    base: dict
    off: dict
    hidden: dict | None
    expected: tuple = field(default=())

    def errors(self, q, covariates: dict) -> dict[str, np.ndarray]:
        """Every component's value at ``q`` (N, 5) under ``covariates`` (``t``, ``directions``)."""
        q = np.atleast_2d(np.asarray(q, float))
        out = term_values(self.base, q)
        for name, (nodes, values) in self.off.items():
            axis, _ = owner(name)
            extra = CubicSpline(nodes, values)(q[:, AXIS_NAMES.index(axis)])
            out[name] = out.get(name, 0.0) + extra
        if self.hidden is not None:
            out[self.hidden["component"]] = out.get(self.hidden["component"], 0.0) + hidden_value(
                self.hidden, q, covariates)
        return out

    def deviations(self, q, covariates: dict) -> np.ndarray:
        """The (N, 3) position error [m] of the truth at ``q`` (:func:`reference_error`)."""
        return reference_error(q, self.errors(q, covariates))

    def tables(self) -> dict[str, list[dict]]:
        """The truth as spec tables (component -> terms, for ``volerr_pin.model.replace_terms``):
        the base Legendre terms, the off-space splines as cubic tables (prefix "off") and the
        hidden effect (prefix "h"); for checking that the product reads these forms as this
        module evaluates them."""
        out: dict[str, list[dict]] = {}
        for name, c in self.base.items():
            axis, location = owner(name)
            suffix, unit = ("um", UM) if name[1] in "XYZ" else ("arcsec", ARCSEC)
            out[name] = [{"kind": "constant", f"value_{suffix}": float(c[0] / unit)} if location else
                         {"kind": "legendre", f"coefficients_{suffix}": [float(v) for v in c / unit]}]
        for name, (nodes, values) in self.off.items():
            axis, _ = owner(name)
            suffix, unit = ("um", UM) if name[1] in "XYZ" else ("arcsec", ARCSEC)
            punit, pscale = ("mm", 1e-3) if AXIS[axis].kind == "linear" else ("deg", DEG)
            out.setdefault(name, []).append(
                {"kind": "table", "prefix": "off", "interpolation": "cubic",
                 f"positions_{punit}": [float(v / pscale) for v in nodes],
                 f"values_{suffix}": [float(v / unit) for v in values]})
        if self.hidden is not None:
            name, table = self.hidden["component"], dict(self.hidden["table"])
            if name in out:
                table["prefix"] = "h"
            out.setdefault(name, []).append(table)
        return out


def hidden_value(hidden: dict, q: np.ndarray, covariates: dict) -> np.ndarray:
    """The hidden effect's value [m, rad] at each point, as the product defines its kind
    (docs/spec-format.md): a periodic error ``s sin(2 pi (q - q0) / p) + c cos(...)``, a
    backlash ``(b / 2) d``, a time drift ``a (1 - exp(-t / tau))``, a constant, a cubic table."""
    n = len(q)
    form = hidden["form"]
    if form == "constant":
        return np.full(n, hidden["value"])
    if form == "periodic":
        x = q[:, AXIS_NAMES.index(hidden["axis"])] - hidden["origin"]
        w = 2 * np.pi * x / hidden["period"]
        return hidden["sine"] * np.sin(w) + hidden["cosine"] * np.cos(w)
    if form == "backlash":
        return 0.5 * hidden["reversal"] * covariates["directions"][:, AXIS_NAMES.index(hidden["axis"])]
    if form == "drift":
        t = covariates["t"]
        return np.where(t >= 0, hidden["amplitude"] * (1.0 - np.exp(-t / hidden["tau"])), 0.0)
    if form == "spline":
        return CubicSpline(hidden["nodes"], hidden["values"])(q[:, AXIS_NAMES.index(hidden["axis"])])
    raise ValueError(form)


def _periodic(component, axis, amplitude, period, phase, unit, punit, pscale):
    """A periodic error ``amplitude sin(2 pi q / period + phase)`` (SI)."""
    sine, cosine = amplitude * np.cos(phase), amplitude * np.sin(phase)
    return {"form": "periodic", "component": component, "axis": axis, "period": period, "origin": 0.0,
            "sine": sine, "cosine": cosine,
            "table": {"kind": "periodic_pitch", f"period_{punit}": period / pscale, f"origin_{punit}": 0.0,
                      f"sine_{unit}": [sine / (UM if unit == "um" else ARCSEC)],
                      f"cosine_{unit}": [cosine / (UM if unit == "um" else ARCSEC)]}}


#: the bridge's bend hidden by "bending": EZX, a sag of the carriage's path in z along X, a cubic
#: spline through these values [um] at these positions [mm]: two dips between the bridge's
#: supports, which no cubic (the spec's degree 3) follows (1.0 um rms left over the travel, 1.8 um at most)
BEND_MM = np.array([0.0, 125.0, 250.0, 375.0, 500.0, 625.0, 750.0, 875.0, 1000.0])
BEND_UM = np.array([0.0, -2.2, -3.0, -1.6, 0.0, -1.6, -3.0, -2.2, 0.0])


def _hidden(kind: str, rng: np.random.Generator) -> tuple[dict | None, tuple]:
    """The hidden effect of ``kind`` and its expected finding."""
    phase = float(rng.uniform(0.0, 2 * np.pi))
    if kind == "clean":
        return None, ()
    if kind == "c_once":        # C's angular positioning, once per revolution (a worm's eccentricity)
        h = _periodic("ECC", "C", 5.0 * ARCSEC, 2 * np.pi, phase, "arcsec", "deg", DEG)
        return h, (Finding("periodic_rotary", "C", "z", "ECC", 5.0, "arcsec", order=1, period=360.0),)
    if kind == "a_once":        # A's angular positioning, 8 per revolution: A turns 200 deg, and a
        # per-revolution error over part of a turn needs 4 periods in the span (45 deg x 4 = 180)
        h = _periodic("EAA", "A", 3.0 * ARCSEC, np.pi / 4, phase, "arcsec", "deg", DEG)
        return h, (Finding("periodic_rotary", "A", "x", "EAA", 3.0, "arcsec", order=8, period=45.0),)
    # A location error of a rotary axis sits before its joint in the fixed frame, as the axis'
    # own components do: it is the constant of the same-named component, which the spec has
    if kind == "c_location":    # the head 15 um off C's axis along A's axis (turns with C) = EXA's c0
        h = {"form": "constant", "component": "EX0A", "value": 15.0 * UM,
             "table": {"kind": "constant", "value_um": 15.0}}
        return h, (Finding("location", "A", "x", "EX0A", 15.0, "um", role="absorbed", absorbed_by="EXA.c0"),)
    if kind == "a_location":    # A not square to C: its axis tilted 12 arcsec about y = EBA's c0
        h = {"form": "constant", "component": "EB0A", "value": 12.0 * ARCSEC,
             "table": {"kind": "constant", "value_arcsec": 12.0}}
        return h, (Finding("location", "A", "y", "EB0A", 12.0, "arcsec", role="absorbed", absorbed_by="EBA.c0"),)
    if kind == "backlash":      # Y's reversal
        h = {"form": "backlash", "component": "EYY", "axis": "Y", "reversal": 4.0 * UM,
             "table": {"kind": "backlash", "reversal_um": 4.0}}
        return h, (Finding("backlash", "Y", "y", "EYY", 4.0, "um"),)
    if kind == "drift":         # the ram's growth over the run (a time drift in z: the same through every axis)
        h = {"form": "drift", "component": "EZZ", "amplitude": 7.0 * UM, "tau": 90.0 * 60.0,
             "table": {"kind": "thermal_drift", "driver": "time", "amplitudes_um": [7.0],
                       "time_constants_min": [90.0]}}
        return h, (Finding("thermal_drift", None, "z", "EZZ", 7.0, "um"),)
    if kind == "pitch":         # X's ball screw: 20 mm, 1.5 um
        h = _periodic("EXX", "X", 1.5 * UM, 0.02, phase, "um", "mm", 1e-3)
        return h, (Finding("periodic_pitch", "X", "x", "EXX", 1.5, "um", period=20.0),)
    if kind == "bending":
        h = {"form": "spline", "component": "EZX", "axis": "X", "nodes": BEND_MM * 1e-3, "values": BEND_UM * UM,
             "table": {"kind": "table", "interpolation": "cubic", "positions_mm": [float(v) for v in BEND_MM],
                       "values_um": [float(v) for v in BEND_UM]}}
        largest = np.abs(CubicSpline(BEND_MM, BEND_UM)(np.linspace(0.0, 1000.0, 2001))).max()
        return h, (Finding("straightness", "X", "z", "EZX", float(largest), "um", role="under_modelled"),)
    raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")


def covariates(rng: np.random.Generator, n: int, hours: float) -> dict:
    """Times over ``hours`` (sorted), three temperatures (a spindle warming up, a column on a
    slow cycle, the room) with 0.1 degC noise, process forces on about half of the points and
    random approach directions of the five axes, as point measurements carry them (SI)."""
    t = np.sort(rng.uniform(0.0, hours * 3600.0, n))
    temperatures = {"spindle": 23.0 + 7.0 * (1.0 - np.exp(-t / 3000.0)) + rng.normal(0.0, 0.1, n),
                    "column": 21.0 + 1.8 * np.sin(2 * np.pi * t / (4.5 * 3600.0)) + rng.normal(0.0, 0.1, n),
                    "ambient": 20.0 + 1.2 * np.cos(2 * np.pi * t / (3.5 * 3600.0) + 0.5) + rng.normal(0.0, 0.1, n)}
    forces = np.where((rng.random(n) < 0.5)[:, None], rng.normal(0.0, 150.0, (n, 3)), 0.0)
    directions = rng.choice([-1.0, 1.0], (n, len(AXES)))
    return {"t": t, "temperatures": temperatures, "forces": forces, "directions": directions}


def poses(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` NC positions (N, 5) [m, rad]: uniform over each travel; C over [-180, 180) deg."""
    return rng.uniform(TRAVEL[:, 0], TRAVEL[:, 1], (n, len(AXES)))


#: size of the geometry outside the function space: small beside 1 um of noise (0.05 arcsec is
#: 0.25 um at the 1 m lever of Y's angles), yet the diagnosis may raise a component for it now and then
OFF_UM, OFF_ARCSEC = 0.1, 0.05


def _off_space(rng: np.random.Generator, size_um: float, size_arcsec: float) -> dict:
    """Every axis component gets a cubic spline through 7 random values at uneven positions
    over the travel (normal, ``size_um`` / ``size_arcsec``): smooth, small, outside the spec."""
    out = {}
    for axis in AXES:
        lo, hi = axis.travel
        for d in LETTERS:
            u = np.linspace(0.0, 1.0, 7)
            u[1:-1] += rng.uniform(-0.25, 0.25, 5) / 6
            size = size_um * UM if d in "XYZ" else size_arcsec * ARCSEC
            out[f"E{d}{axis.name}"] = (lo + (hi - lo) * u, rng.normal(0.0, size, 7))
    return out


def _perturbed(rng: np.random.Generator) -> dict:
    """The spec's coefficients, each moved by a normal draw of 25 % of its size plus 0.2 um or
    arcsec: another machine of the same function space."""
    out = {}
    for name, c in SPEC_TERMS.items():
        unit = UM if name[1] in "XYZ" else ARCSEC
        out[name] = c + rng.normal(0.0, 1.0, len(c)) * (0.25 * np.abs(c) + 0.2 * unit)
    return out


def generate(kind: str, seed: int, n: int = 600, noise_um: float = 1.0, hours: float = 8.0, *,
             off_um: float = OFF_UM, off_arcsec: float = OFF_ARCSEC):
    """A simulated measurement set of bridge_ca with one hidden effect.

    The draws come from separate streams of ``seed``, so that every kind of one seed has the
    same poses, covariates, base geometry and noise: two kinds' data differ by their hidden
    effects only.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`, the hidden effect:

        - "clean": nothing;
        - "c_once": C's angular positioning ECC once per revolution, 5 arcsec (2.4 um per
          0.1 m of the tool point's distance from C's axis: up to 4.4 um at A = 90 deg);
        - "a_once": A's angular positioning EAA (A turns about x: EAA, not ECA), 3 arcsec 8 times
          per revolution (45 deg): A travels 200 deg, and a per-revolution error over part of
          a turn is looked for with 4 periods in the span at least; 2.6 um at the tool;
        - "c_location": the head 15 um off C's axis along A's axis, EX0A (turns with C);
        - "a_location": A's axis tilted 12 arcsec about y, EB0A (A not square to C; up to
          10.5 um at A = 0). Both locations are the constants of A's own EXA and EBA, which
          the spec has: "absorbed", nothing to name;
        - "backlash": Y's reversal, 4 um (EYY, by ``dir_y``);
        - "drift": the ram's growth EZZ = 7 um (1 - exp(-t / 90 min)) (6.97 um after 8 h);
        - "pitch": X's ball screw, 1.5 um over 20 mm (EXX);
        - "bending": a sag of X's straightness in z (EZX), a spline with two dips of 3 um
          that the spec's cubic does not follow.

        Positions are uniform over the travels; C's over [-180, 180) deg, so the span
        measured is a little short of a full turn.
    seed : int
        Seed of every draw.
    n : int, default 600
        Points.
    noise_um : float, default 1.0
        Standard deviation of the noise on dx, dy, dz [um].
    hours : float, default 8.0
        Length of the run.
    off_um, off_arcsec : float, default :data:`OFF_UM`, :data:`OFF_ARCSEC`
        Size of the geometry outside the spec's function space (:func:`_off_space`).

    Returns
    -------
    truth : Truth
        The simulated machine (its ``errors`` and ``deviations`` at any points, ``tables``).
    data : volerr_pin.measurements.PointMeasurements
        Positions (N, 5) [m, rad] in the spec's order, deviations dx, dy, dz [m] (rotations
        NaN), covariates ``t``, ``temperatures``, ``forces``, ``directions``; lines 0..N-1.
    expected : tuple of Finding
        What a diagnosis should report (empty for "clean"): one :class:`Finding` with the
        product's name, axis and direction of the finding and its role ("effect",
        "under_modelled" or "absorbed").
    """
    from volerr_pin.measurements import PointMeasurements   # the container only

    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(6)]
    q = poses(streams[0], n)
    cov = covariates(streams[1], n, hours)
    base, off = _perturbed(streams[2]), _off_space(streams[3], off_um, off_arcsec)
    noise = streams[4].normal(0.0, noise_um * UM, (n, 3))
    hidden, expected = _hidden(kind, streams[5])
    truth = Truth(kind, seed, base, off, hidden, expected)
    values = np.full((n, 6), np.nan)
    values[:, :3] = truth.deviations(q, cov) + noise
    data = PointMeasurements(f"bridge_ca {kind} seed {seed}", q, values, cov, np.arange(n))
    return truth, data, expected


def named(diagnosis) -> tuple[list[tuple], list[str]]:
    """What a diagnosis named: (name, axis, direction) of each effect, and the components it
    found under-modelled."""
    return ([(e.name, e.axis, e.direction) for e in diagnosis.effects],
            [u.component for u in diagnosis.under_modelled])
