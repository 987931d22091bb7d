"""The test machine bridge_ca (``tests/data/bridge_ca``): a 5-axis bridge machine with a C/A
swivel head, a topology no bundled machine has (tool chain Y - X - Z - C - A, the workpiece on
the bed, the spec's axes listed X, Y, Z, A, C). An independent numpy model of its volumetric
error (``_bridge_ca.reference_error``: the URDF read with xml.etree, transforms in numpy, the
error groups where docs/conventions.md puts them) agrees with the product's, and the data sets
``_bridge_ca.generate`` makes for the diagnosis tests differ from the clean set by their hidden
effect alone, at its size."""

from __future__ import annotations

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.model import replace_terms

import _bridge_ca as B

ATOL = 1e-9                      # [m], [rad]
L_TOOL = -float(B.JOINTS["tool_mount"].xyz[2])   # the tool point below the A axis [m]
J = {a: j for j, a in enumerate(B.AXIS_NAMES)}


@pytest.fixture(scope="module")
def machine():
    return vp.load_machine(B.SPEC_FILE)


@pytest.fixture(scope="module")
def data():
    """Every kind's set of one seed (300 points)."""
    return {kind: B.generate(kind, 5, n=300) for kind in B.KINDS}


def random_terms(rng, components, size_um=30.0, size_arcsec=30.0):
    """Random terms (component -> SI coefficients) of the given forms: ``components`` maps a
    name to its number of Legendre coefficients (1 for a location error's constant)."""
    return {name: rng.normal(0.0, 1.0, k) * (size_um * B.UM if name[1] in "XYZ" else size_arcsec * B.ARCSEC)
            for name, k in components.items()}


def as_tables(terms):
    """SI coefficients as the spec's tables (legendre, or constant for a location error)."""
    out = {}
    for name, c in terms.items():
        suffix, unit = ("um", B.UM) if name[1] in "XYZ" else ("arcsec", B.ARCSEC)
        out[name] = ({"kind": "constant", f"value_{suffix}": float(c[0] / unit)} if B.owner(name)[1] else
                     {"kind": "legendre", f"coefficients_{suffix}": [float(v) for v in c / unit]})
    return out


def test_the_machine_and_its_chain(machine):
    """The axes in the spec's order, the chain in kinematic order: Y carries X, X carries Z, and
    the head's C carries A; nothing on the workpiece chain."""
    assert machine.axes == ("X", "Y", "Z", "A", "C")
    assert machine.chains["tool"] == ("Y", "X", "Z", "C", "A")
    assert machine.chains["workpiece"] == ()
    assert machine.axis_kinds == ("linear",) * 3 + ("rotary",) * 2
    np.testing.assert_allclose(machine.travel, B.TRAVEL, atol=1e-15)
    assert len(machine.components) == len(B.SPEC_TERMS) == 36


def test_nominal_kinematics(machine):
    """At zero error the product's tool pose is the reference's nominal one, at 200 random poses;
    at A = C = 0 the tool point is (X, Y, Z) and +X, +Y, +Z move it along +x, +y, +z."""
    q = B.poses(np.random.default_rng(0), 200)
    R, p = machine.tool_poses(q, nominal=True)
    R0, p0 = B.tool_pose(q)
    np.testing.assert_allclose(p, p0, atol=1e-12)
    np.testing.assert_allclose(R, R0, atol=1e-12)
    q[:, 3:] = 0.0
    np.testing.assert_allclose(B.tool_pose(q)[1], q[:, :3], atol=1e-12)
    Jq = machine.axis_jacobian(q[:3], nominal=True)
    np.testing.assert_allclose(Jq[:, :3, :3], np.broadcast_to(np.eye(3), (3, 3, 3)), atol=1e-12)


def test_the_spec_term_functions(machine):
    """The reference's Legendre polynomials over the travel give the product's component values,
    for the spec and for random coefficients on every component."""
    q = B.poses(np.random.default_rng(1), 200)
    values = machine.component_values(q)
    mine = B.spec_values(q)
    for i, name in enumerate(machine.components):
        np.testing.assert_allclose(values[:, i], mine[name], rtol=0, atol=1e-15, err_msg=name)


def test_reference_error_with_random_values_on_every_spec_component(machine):
    """Every coefficient of every component of the spec replaced by a random value (30 um and
    30 arcsec: second-order effects of 1e-7 m, well above the tolerance): the product's error
    and the reference's agree to 1e-9 m and rad at 200 random poses, position and rotation."""
    rng = np.random.default_rng(2)
    terms = random_terms(rng, {name: len(c) for name, c in B.SPEC_TERMS.items()})
    m = replace_terms(machine, as_tables(terms))
    assert m.components == machine.components
    q = B.poses(rng, 200)
    e = m.volumetric_error(q)
    dp, rot = B.reference_error(q, B.term_values(terms, q), rotation=True)
    assert np.abs(dp).max() > 1e-4
    np.testing.assert_allclose(e[:, :3], dp, rtol=0, atol=ATOL)
    np.testing.assert_allclose(e[:, 3:], rot, rtol=0, atol=ATOL)
    first = m.volumetric_error(q, order=1)   # the linearisation differs by the second order: it is tested
    assert np.abs(first[:, :3] - dp).max() > 100 * ATOL


def test_reference_error_with_every_error_joint(machine):
    """Beyond the spec: all six components of every axis and all six location errors of every
    axis (Y's, X's, Z's, C's and A's), each random (degree 2 for the components), agree too."""
    rng = np.random.default_rng(3)
    forms = {f"E{d}{a}": 3 for a in B.AXIS_NAMES for d in B.LETTERS}
    forms.update({f"E{d}0{a}": 1 for a in B.AXIS_NAMES for d in B.LETTERS})
    terms = random_terms(rng, forms, 20.0, 20.0)
    m = replace_terms(machine, as_tables(terms))
    assert len(m.components) == 60
    q = B.poses(rng, 200)
    e = m.volumetric_error(q)
    dp, rot = B.reference_error(q, B.term_values(terms, q), rotation=True)
    np.testing.assert_allclose(e[:, :3], dp, rtol=0, atol=ATOL)
    np.testing.assert_allclose(e[:, 3:], rot, rtol=0, atol=ATOL)


def test_squareness_of_a_bridge(machine):
    """X rides on Y here, on the tool side (vmc700's X rides on Y on the workpiece side): EC0X
    turns X's motion towards +y, so the angle between the +X and +Y motions is 90 deg - EC0X;
    EB0Z tilts the Z motion towards +x. The product and the reference agree."""
    g = 10.0 * B.ARCSEC
    zero = machine.with_theta(np.zeros(len(machine.theta)))
    m = replace_terms(zero, {name: {"kind": "constant", "value_arcsec": 10.0} for name in ("EC0X", "EB0Z")})
    q = np.zeros((4, 5))
    q[1, 0], q[2, 1], q[3, 2] = 0.5, 0.5, 0.4
    p = m.tool_poses(q)[1]
    np.testing.assert_allclose(p, B.tool_pose(q, {"EC0X": g, "EB0Z": g})[1], rtol=0, atol=1e-12)
    along_x, along_y, along_z = p[1] - p[0], p[2] - p[0], p[3] - p[0]
    angle = np.arccos(along_x @ along_y / np.linalg.norm(along_x) / np.linalg.norm(along_y))
    assert angle == pytest.approx(np.pi / 2 - g, abs=1e-12)
    # EC0X turns Z too (X carries it): its tilt towards +x gains 0.4 m g^2 = 1e-9 m along y
    np.testing.assert_allclose(along_z, 0.4 * np.array([np.sin(g), 0.0, np.cos(g)]), rtol=0, atol=1.5e-9)


def test_a_rotary_axis_location_is_its_components_constant(machine):
    """A location error of C or A and the constant of the same-named component both sit before
    the joint in the fixed frame: the same motion to first order (which is why "c_location" and
    "a_location" hide in EXA's and EBA's constants), in the product and in the reference."""
    m = replace_terms(machine, {"EX0A": {"kind": "constant", "value_um": 0.0},
                                "EB0A": {"kind": "constant", "value_arcsec": 0.0}})
    q = B.poses(np.random.default_rng(4), 50)
    names = m.parameter_names
    pairs = [("EX0A.c0", "EXA.c0"), ("EB0A.c0", "EBA.c0"), ("EY0A.c0", "EYA.c0"), ("EA0C.c0", "EAC.c0")]
    S = m.sensitivity(q, parameters=[names.index(n) for pair in pairs for n in pair], first_order=True)
    np.testing.assert_allclose(S[:, :, 0::2], S[:, :, 1::2], rtol=0, atol=1e-12)
    g = 12.0 * B.ARCSEC
    np.testing.assert_allclose(B.reference_error(q, {"EB0A": g}), B.reference_error(q, {"EBA": g}),
                               rtol=0, atol=1e-15)


def _lever(q):
    """The tool point relative to the A pivot in the swivel frame, and C's rotation (nominal)."""
    a, c = q[:, J["A"]], q[:, J["C"]]
    r = np.column_stack([np.zeros(len(q)), L_TOOL * np.sin(a), -L_TOOL * np.cos(a)])
    Rc = np.zeros((len(q), 3, 3))
    Rc[:, 0, 0], Rc[:, 0, 1], Rc[:, 1, 0], Rc[:, 1, 1], Rc[:, 2, 2] = np.cos(c), -np.sin(c), np.sin(c), np.cos(c), 1
    return r, Rc


def expected_difference(kind, truth, data):
    """The hidden effect at the tool in closed form, to first order [m]: a translation of a
    linear axis along its direction, a location offset turned by C, a rotation about C's or A's
    axis (or tilt of A) times the tool's lever about it."""
    q, cov = data.q, data.covariates
    h = truth.hidden
    v = B.hidden_value(h, q, cov)
    out = np.zeros((len(q), 3))
    r, Rc = _lever(q)
    if kind in ("backlash", "pitch", "drift", "bending"):
        out[:, "XYZ".index(h["component"][1])] = v
    elif kind == "c_location":
        out = np.einsum("nij,nj->ni", Rc, np.column_stack([v, 0 * v, 0 * v]))
    elif kind in ("a_location", "a_once"):       # about the swivel's y (tilt) or x (A itself), at A's pivot
        about = np.array([0.0, 1.0, 0.0]) if kind == "a_location" else np.array([1.0, 0.0, 0.0])
        out = np.einsum("nij,nj->ni", Rc, v[:, None] * np.cross(about, r))
    elif kind == "c_once":                       # about C's axis, through the A pivot
        out = v[:, None] * np.cross([0.0, 0.0, 1.0], np.einsum("nij,nj->ni", Rc, r))
    return out


@pytest.mark.parametrize("kind", [k for k in B.KINDS if k != "clean"])
def test_each_kind_differs_from_the_clean_set_by_its_hidden_effect(data, kind):
    """Same seed, same poses, covariates, geometry and noise: the difference from the clean set
    is the hidden effect, as its closed form at the tool gives it (to its second order), and it
    has the expected finding's size."""
    truth, d, expected = data[kind]
    clean = data["clean"][1]
    np.testing.assert_array_equal(d.q, clean.q)
    (finding,) = expected
    assert finding.component == truth.hidden["component"]
    assert finding.role == {"c_location": "absorbed", "a_location": "absorbed",
                            "bending": "under_modelled"}.get(kind, "effect")
    diff = d.values[:, :3] - clean.values[:, :3]
    np.testing.assert_allclose(diff, expected_difference(kind, truth, d), rtol=0, atol=2e-9)
    unit = B.UM if finding.unit == "um" else B.ARCSEC
    size = finding.size * unit
    if kind == "backlash":
        assert np.abs(diff[:, 1]).max() == pytest.approx(size / 2, rel=1e-6)
        steps = diff[:, 1] * d.covariates["directions"][:, J["Y"]]
        np.testing.assert_allclose(steps, size / 2, rtol=1e-6)
    elif kind in ("pitch", "bending"):
        assert 0.95 * size < np.abs(diff).max() <= 1.0001 * size
    elif kind == "drift":
        end = size * (1 - np.exp(-d.covariates["t"].max() / truth.hidden["tau"]))
        assert np.abs(diff[:, 2]).max() == pytest.approx(end, rel=1e-4) and end > 6.5e-6
    elif kind == "c_location":
        np.testing.assert_allclose(np.linalg.norm(diff, axis=1), size, rtol=1e-4)
    else:   # rotations: the angle times the tool's lever about the axis turned about
        lever = {"c_once": L_TOOL * np.abs(np.sin(d.q[:, J["A"]])), "a_once": np.full(len(d.q), L_TOOL),
                 "a_location": L_TOOL * np.abs(np.cos(d.q[:, J["A"]]))}[kind]
        ratio = np.linalg.norm(diff, axis=1).max() / (size * lever.max())
        assert 0.9 < ratio <= 1.0001, ratio
    if finding.order:
        assert finding.period == pytest.approx(360.0 / finding.order)


def test_the_generated_sets(data):
    """Poses within the travel, C over (nearly) a full turn, A over most of its 200 deg, times
    over the run, every covariate column, the noise at its size; the same seed gives the same set."""
    truth, d, expected = data["clean"]
    assert expected == () and truth.hidden is None
    assert ((d.q >= B.TRAVEL[:, 0]) & (d.q <= B.TRAVEL[:, 1])).all()
    assert np.ptp(d.q[:, J["C"]]) > np.radians(350) and np.ptp(d.q[:, J["A"]]) > np.radians(180)
    assert set(d.covariates) == {"t", "temperatures", "forces", "directions"}
    assert d.covariates["directions"].shape == (300, 5) and np.ptp(d.covariates["t"]) > 7.5 * 3600
    assert np.isnan(d.values[:, 3:]).all()
    noise = d.values[:, :3] - truth.deviations(d.q, d.covariates)
    assert 0.85e-6 < noise.std() < 1.15e-6
    again = B.generate("clean", 5, n=300)[1]
    np.testing.assert_array_equal(again.values, d.values)


@pytest.mark.parametrize("kind", B.KINDS)
def test_the_truth_read_by_the_product(machine, data, kind):
    """The truth written as spec tables (perturbed Legendre terms, off-space cubic tables, the
    hidden effect's kind) and evaluated by the product gives the generated deviations: the
    helper's forms are the product's definitions of legendre, table, periodic_pitch, backlash
    and thermal_drift."""
    truth, d, _ = data[kind]
    m = replace_terms(machine, truth.tables())
    e = m.volumetric_error(d.q, **{k: v for k, v in d.covariates.items() if k in ("t", "directions")})
    np.testing.assert_allclose(e[:, :3], truth.deviations(d.q, d.covariates), rtol=0, atol=ATOL)
