"""Gear flanks generated on gear_roller: geometry, closed forms, an independent envelope, reports."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.base import ARCSEC, DEG, MM, UM, InputError
from volerr_pin.applications.gear import (REFERENCE_GEAR, GearPair, contribution_degrees, deviations_by_source,
                             flank_deviations, unit_error_study)
from volerr_pin.applications.gear._generation import flank_grid, mesh_of
from volerr_pin.model import replace_terms

G = REFERENCE_GEAR


@pytest.fixture(scope="module")
def roller():
    return vp.load_machine("gear_roller")


@pytest.fixture(scope="module")
def bare(roller):
    return roller.with_spec(roller.spec.without(*roller.components))


def with_axis_errors(machine, axes: dict):
    """The machine with its axes' errors placed as ``axes`` says ({axis: {"frame", "reference"}})."""
    spec = machine.spec
    for axis, change in axes.items():
        spec = spec.with_axis(axis, **change)
    return machine.with_spec(spec)


def only(bare, tables):
    return replace_terms(bare, tables)


def test_gear_data_closed_forms():
    a = 20 * DEG
    assert G.pitch_radius == pytest.approx(40.25 * MM)
    assert G.centre_distance == pytest.approx(152.25 * MM)          # Table 7 / section 5
    assert G.base_radius == pytest.approx(40.25 * MM * np.cos(a))
    assert G.tip_radius == pytest.approx(42.0 * MM)
    # the wheel's tip circle (113.75 mm) meets the line of action where the workpiece's
    # active profile starts: radius sqrt(rb^2 + (r sin a - L1)^2), L1 from the wheel side
    l1 = np.sqrt(113.75 ** 2 - (112 * np.cos(a)) ** 2) - 112 * np.sin(a)
    assert G.form_radius / MM == pytest.approx(np.hypot(40.25 * np.cos(a), 40.25 * np.sin(a) - l1))
    assert G.radius_at(0.0) == pytest.approx(G.pitch_radius)
    assert G.radius_at(G.roll_end) == pytest.approx(G.tip_radius)


def test_gear_rejects_bad_data():
    with pytest.raises(InputError, match="module must be a positive number"):
        GearPair(module=-1.0, pressure_angle=0.3, teeth=46, tool_teeth=128, face_width=0.02)
    with pytest.raises(InputError, match="teeth must be an integer >= 5"):
        GearPair(module=1e-3, pressure_angle=0.3, teeth=4.5, tool_teeth=128, face_width=0.02)
    with pytest.raises(InputError, match="pressure_angle must be within"):
        GearPair(module=1e-3, pressure_angle=50 * DEG, teeth=46, tool_teeth=128, face_width=0.02)
    with pytest.raises(InputError, match="undercut"):       # 8 teeth at 20 deg, rolled by a big wheel
        GearPair(module=1e-3, pressure_angle=20 * DEG, teeth=8, tool_teeth=128, face_width=0.02)


def test_generated_flanks_are_the_involutes_of_the_gear(roller):
    """The ideal flank points the generation visits lie on the right involutes: radius from
    the roll position, polar angle = pitch-circle angle -/+ (inv(a_r) - inv(a)), tooth
    thickness half the pitch on the pitch circle, outward normals along the base tangents."""
    mesh = mesh_of(roller, G, ("B", "A"), None)
    grid = flank_grid(roller, G, mesh, 21, 5, None)
    p = grid.point.reshape(grid.shape + (3,))
    n = grid.normal.reshape(grid.shape + (3,))
    r = np.hypot(p[..., 0], p[..., 1])
    np.testing.assert_allclose(r, np.broadcast_to(G.radius_at(grid.roll)[None, None, :, None], r.shape), atol=1e-12)
    inv = lambda ang: np.tan(ang) - ang                          # noqa: E731
    a_r = np.arccos(G.base_radius / r)
    polar = np.arctan2(p[..., 1], p[..., 0])
    theta_pitch = polar[:, :, 10:11, :]                            # the middle point is on the pitch circle
    for index, sigma in enumerate((1, -1)):                      # right: clockwise side, polar angle falls
        expected = theta_pitch[index] + sigma * (inv(a_r[index]) - inv(G.pressure_angle))
        np.testing.assert_allclose(np.angle(np.exp(1j * (polar[index] - expected))), 0.0, atol=1e-12)
    # tooth thickness on the pitch circle: pi m / 2, i.e. half the angular pitch
    np.testing.assert_allclose(np.angle(np.exp(1j * (theta_pitch[1] - theta_pitch[0]))), np.pi / G.teeth, atol=1e-12)
    # the normal is tangent to the base circle (p x n = +-rb) and points away from the tooth
    moment = p[..., 0] * n[..., 1] - p[..., 1] * n[..., 0]
    np.testing.assert_allclose(np.abs(moment), G.base_radius, atol=1e-12)
    e_theta = np.stack([-np.sin(polar), np.cos(polar)], axis=-1)
    along = np.einsum("...i,...i->...", n[..., :2], e_theta)
    assert (along[0] < 0).all() and (along[1] > 0).all()
    # z of the points: the face width about the tool point's height
    np.testing.assert_allclose(p[0, 0, 0, :, 2], np.linspace(-10, 10, 5) * MM, atol=1e-12)


@pytest.mark.parametrize("name, table, right, left", [
    ("EXA", {"value_um": 5.0}, 5 * np.cos(20 * DEG), -5 * np.cos(20 * DEG)),    # tangential: along the line of action
    ("EYA", {"value_um": 5.0}, 5 * np.sin(20 * DEG), 5 * np.sin(20 * DEG)),     # away from the gear: both thicker
    ("EZA", {"value_um": 5.0}, 0.0, 0.0),                                        # along the axes: nothing
    ("EXB", {"value_um": -3.0}, -3 * np.cos(20 * DEG), 3 * np.cos(20 * DEG)),
    ("ECA", {"value_arcsec": 2.0}, 2 * ARCSEC * 112e3 * np.cos(20 * DEG), -2 * ARCSEC * 112e3 * np.cos(20 * DEG)),
    ("ECB", {"value_arcsec": 2.0}, -2 * ARCSEC * 40.25e3 * np.cos(20 * DEG), 2 * ARCSEC * 40.25e3 * np.cos(20 * DEG)),
])
def test_constant_errors_shift_the_flanks_by_their_normal_component(bare, name, table, right, left):
    """A constant translation moves every flank point by its component along the normal
    (cos 20 deg tangentially, sin 20 deg radially); a turn of a spindle about its own axis
    moves an involute by base radius x angle (wheel: 112 mm, gear: 40.25 mm pitch radius)."""
    result = flank_deviations(only(bare, {name: {"kind": "constant", **table}}))
    expected = {"right": right * UM, "left": left * UM}
    for flank, value in expected.items():
        np.testing.assert_allclose(result.normal[0 if flank == "right" else 1], value, atol=2e-5 * UM + 1e-6 * abs(value))
        vals = result.values[flank]
        assert vals["pitch"] == pytest.approx(value, abs=1e-11)
        assert vals["profile"] == pytest.approx(abs(value), abs=1e-11)
        assert vals["helix"] == pytest.approx(abs(value), abs=1e-11)
        # ISO: an offset is neither a profile nor a helix deviation, and every tooth has it
        assert vals["F_alpha"] < 1e-11 and vals["F_beta"] < 1e-11 and vals["f_pt"] < 1e-11 and vals["F_p"] < 1e-11


@pytest.mark.parametrize("name, lever", [("EBA", np.cos(20 * DEG)), ("EAA", np.sin(20 * DEG))])
def test_tilts_make_helix_deviations_over_the_face(bare, name, lever):
    """A tilt about the wheel's centre, in the contact plane, moves a flank point at face
    position s by angle x s along x (ey) or -y (ex): helix = angle x face width x cos / sin 20."""
    angle = 10 * ARCSEC
    result = flank_deviations(only(bare, {name: {"kind": "constant", "value_arcsec": 10.0}}))
    for flank in ("right", "left"):
        assert result.values[flank]["helix"] == pytest.approx(angle * G.face_width * lever, rel=1e-6)
        assert result.values[flank]["F_beta"] == pytest.approx(angle * G.face_width * lever, rel=1e-6)
        # no lever in the contact plane: what is left is second order (angle^2 x wheel radius)
        assert abs(result.values[flank]["pitch"]) < angle ** 2 * 0.112


def test_normal_deviation_matches_the_volumetric_error(roller):
    """Independent path: the tool's 6-D pose error from volumetric_error (rotation vector and
    translation of the tool frame) moves the contact point; its normal component is the
    deviation flank_deviations finds from the two poses."""
    mesh = mesh_of(roller, G, ("B", "A"), None)
    grid = flank_grid(roller, G, mesh, 7, 3, [0, 5, 30])
    result = flank_deviations(roller, profile_points=7, face_points=3, tooth_numbers=[0, 5, 30])
    err = roller.volumetric_error(grid.q)
    _, p_nom = roller.tool_poses(grid.q, nominal=True)
    moved = Rotation.from_rotvec(err[:, 3:]).apply(grid.point - p_nom) + p_nom + err[:, :3]
    expected = np.einsum("ni,ni->n", moved - grid.point, grid.normal)
    np.testing.assert_allclose(result.normal.ravel(), expected, atol=1e-13)
    assert np.abs(expected).max() > 0.5 * UM                        # the spec's errors do reach the flank


def _wheel_flank(machine, grid, index, tooth_row):
    """The wheel's flank in the tool frame: the contact points of one generated flank."""
    n_s = grid.shape[3]
    sel = np.zeros(grid.shape, bool)
    sel[index, tooth_row, :, n_s // 2] = True
    q, pts = grid.q[sel.ravel()], grid.point[sel.ravel()]
    R, p = machine.tool_poses(q, nominal=True)
    return np.einsum("nji,nj->ni", R, pts - p), q


def test_first_order_matches_an_independent_envelope(roller, bare):
    """Generate the flank for real: sweep the wheel's flank curve (mid face) through the
    mesh with the actual poses and take, along each ideal flank point's normal, the surface
    the sweep leaves (min over the generating positions). Without errors the sweep touches
    the ideal involute and never cuts into it (conjugate generation); with errors it leaves
    the first-order normal deviation, to 1e-3 of the error."""
    mesh = mesh_of(roller, G, ("B", "A"), None)
    grid = flank_grid(roller, G, mesh, 11, 3, [0])
    dense = flank_grid(roller, G, mesh, 301, 3, [0])
    machines = {"none": bare,
                "errors": only(bare, {"EXA": {"kind": "constant", "value_um": 4.0},
                                      "ECA": {"kind": "constant", "value_arcsec": 3.0},
                                      "EYB": {"kind": "constant", "value_um": -2.5},
                                      "ECB": {"kind": "constant", "value_arcsec": -4.0}})}
    first = flank_deviations(machines["errors"], profile_points=11, face_points=3, tooth_numbers=[0])
    for index in (0, 1):
        curve, q_dense = _wheel_flank(roller, dense, index, 0)
        curve = np.concatenate([curve[:1] + 3 * (curve[:1] - curve[1:2]), curve])   # a little past the tip
        beta = q_dense[:, mesh.work] - mesh.q0[mesh.work]
        sweep = np.linspace(beta.min() - 0.05, beta.max() + 0.05, 600)
        sel = np.zeros(grid.shape, bool)
        sel[index, 0, :, 1] = True
        points, normals, q_points = grid.point[sel.ravel()], grid.normal[sel.ravel()], grid.q[sel.ravel()]
        # fine sweeps about each point's own instant, plus the coarse one over the whole mesh
        fine = (q_points[:, mesh.work] - mesh.q0[mesh.work])[:, None] + np.linspace(-2e-3, 2e-3, 201)[None, :]
        betas = np.unique(np.concatenate([sweep, fine.ravel()]))
        q = np.repeat(mesh.q0[None], betas.size, axis=0)
        q[:, mesh.work] += betas
        q[:, mesh.tool] += mesh.ratio * betas
        for label, machine in machines.items():
            R, p = machine.tool_poses(q)
            world = np.einsum("bij,kj->bki", R, curve) + p[:, None, :]             # (beta, curve, 3)
            side = np.cross(np.array([0.0, 0.0, 1.0]), normals)                    # along the flank, in plane
            rel = world[:, None, :, :] - points[None, :, None, :]                 # (beta, point, curve, 3)
            t = np.einsum("bpki,pi->bpk", rel, normals)
            d = np.einsum("bpki,pi->bpk", rel, side)
            cross = (d[..., :-1] * d[..., 1:]) <= 0
            w = d[..., :-1] / np.where(cross, d[..., :-1] - d[..., 1:], 1.0)
            t_at = np.where(cross, t[..., :-1] + w * (t[..., 1:] - t[..., :-1]), np.inf).min(axis=2)
            envelope = t_at.min(axis=0)                                            # (point,)
            if label == "none":
                np.testing.assert_allclose(envelope, 0.0, atol=1e-9)
            else:
                expected = first.normal[index, 0, :, 1]
                assert np.abs(expected).min() > 1 * UM
                np.testing.assert_allclose(envelope, expected, rtol=1e-3, atol=5e-9)


def test_unit_study_matches_seed004_where_the_paper_is_consistent(roller):
    """Seed 004's convention (errors in the moving spindle frames, B's angular errors about
    the gear's mid face): ez(A) within 1 % of Table 4, the helix deviations of the four
    tilts within 10 %, dz(A), dz(B) zero, the translations' shares within 5 points."""
    machine = with_axis_errors(roller, {"A": {"frame": "moving"},
                                        "B": {"frame": "moving", "reference": (0.0, 0.0, 0.05)}})
    rows = {r.source: r for r in unit_error_study(machine, tooth_numbers=[0])}
    v = {k: r.deviations.values["right"] for k, r in rows.items()}
    assert v["ECA"]["profile"] / MM == pytest.approx(1.8272, rel=0.01)
    for name, paper in (("EAA", 0.131), ("EBA", 0.3267), ("EAB", 0.1154), ("EBB", 0.3355)):
        assert v[name]["helix"] / MM == pytest.approx(paper, rel=0.1)
    for name in ("EZA", "EZB"):
        assert max(abs(x) for x in v[name].values() if x is not None) < 1e-9
    shares = contribution_degrees(list(rows.values()))
    by = dict(zip(rows, shares))
    for name, paper in (("EXA", (72.9, 76.2, 77.1)), ("EXB", (73.0, 76.9, 78.1))):
        got = [100 * by[name][k] for k in ("profile", "helix", "pitch")]
        np.testing.assert_allclose(got, paper, atol=5.0)


def test_contribution_degrees_sum_to_one_per_group(roller):
    rows = unit_error_study(roller, tooth_numbers=[0, 1])
    shares = contribution_degrees(rows, "left")
    for group in {r.group for r in rows}:
        for key in ("profile", "helix", "pitch"):
            total = sum(s[key] for r, s in zip(rows, shares) if r.group == group)
            assert total == pytest.approx(1.0)
    with pytest.raises(InputError, match="flank must be"):
        contribution_degrees(rows, "middle")


def test_sources_add_up_to_all_for_offsets(roller):
    """Per source, then all together: normal deviations are additive to first order."""
    rows = deviations_by_source(roller, profile_points=5, face_points=3)
    total = sum(r.deviations.normal for r in rows[:-1])
    assert rows[-1].source == "all"
    np.testing.assert_allclose(rows[-1].deviations.normal, total, atol=1e-3 * np.abs(total).max())
    assert len(rows) == 25 and rows[0].source == "EXY"


def test_pitch_deviations_come_from_errors_that_vary_with_the_spindle(bare):
    """An eccentric workpiece (dx(B) turning with B, i.e. in the moving frame) moves tooth k's
    flank along its normal by e cos(angle_k + const), i.e. along the pitch circle by that over
    cos 20 deg: cumulative pitch F_p = 2 e / cos 20 deg (to the grid of 46 teeth), single pitch
    f_pt = 2 e sin(pi / 46) / cos 20 deg."""
    e = 10 * UM
    moving = with_axis_errors(only(bare, {"EXB": {"kind": "constant", "value_um": 10.0}}),
                              {"B": {"frame": "moving"}})
    result = flank_deviations(moving, profile_points=3, face_points=3)
    for flank in ("right", "left"):
        vals = result.values[flank]
        assert vals["F_p"] == pytest.approx(2 * e / np.cos(G.pressure_angle), rel=3e-3)
        assert vals["f_pt"] == pytest.approx(2 * e * np.sin(np.pi / G.teeth) / np.cos(G.pressure_angle), rel=3e-3)
        assert vals["F_alpha"] > 0                                  # the flank turns across the roll


def test_inputs_are_checked(roller):
    with pytest.raises(InputError, match="not an axis of gear_roller"):
        flank_deviations(roller, spindles=("B", "W"))
    with pytest.raises(InputError, match="not a rotary axis"):
        flank_deviations(roller, spindles=("Z", "A"))
    with pytest.raises(InputError, match="pitch radius"):
        flank_deviations(roller, GearPair(module=2e-3, pressure_angle=20 * DEG, teeth=46, tool_teeth=128,
                                          face_width=0.02))
    with pytest.raises(InputError, match="odd integer"):
        flank_deviations(roller, profile_points=4)
    with pytest.raises(InputError, match="tooth numbers 0..45"):
        flank_deviations(roller, tooth_numbers=[46])
    with pytest.raises(InputError, match="outside the travel"):
        flank_deviations(roller, at={"Z": -0.01})
    with pytest.raises(InputError, match="have no terms"):
        deviations_by_source(roller, components=["EQQ"])
    with pytest.raises(InputError, match="not among the axes"):
        roller.spec.with_axis("W", frame="moving")
    with pytest.raises(InputError, match="frame must be"):
        roller.spec.with_axis("A", frame="rotating")


def test_cli_gear_json(capsys):
    assert main(["gear", "gear_roller", "--unit-errors", "--tooth", "0", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["mode"] == "unit errors" and report["teeth_evaluated"] == 1
    assert report["gear"]["pitch_diameter_mm"] == pytest.approx(80.5)
    by = {s["source"]: s for s in report["sources"]}
    assert by["EXA"]["flanks"]["right"]["profile_um"] == pytest.approx(1000 * np.cos(20 * DEG), rel=1e-9)
    assert by["EXA"]["contribution"]["profile"] == pytest.approx(1 / (1 + np.tan(20 * DEG)))
    assert by["EXA"]["flanks"]["right"]["f_pt_um"] is None               # one tooth: no pitch between teeth
    assert report["frames"]["B"]["errors_frame"] == "fixed"


def test_cli_gear_table_and_errors(capsys):
    assert main(["gear", "gear_roller", "--profile-points", "5", "--face-points", "3"]) == 0
    out = capsys.readouterr().out
    assert "all sources" in out and "ez(A)" in out and "F_alpha um" in out
    assert main(["gear", "gear_roller", "--module-mm", "-1"]) == 2
    assert "--module-mm must be a positive number" in capsys.readouterr().err
    assert main(["gear", "gear_roller", "--tooth", "50"]) == 2
    assert "--tooth must be distinct tooth numbers" in capsys.readouterr().err
    assert main(["gear", "gear_roller", "--reference", "B=0,0"]) == 2
    assert "--reference: 'B=0,0' is not AXIS=X,Y,Z" in capsys.readouterr().err
    assert main(["gear", "gear_roller", "--errors-frame", "moving"]) == 2
    assert "--errors-frame goes with --unit-errors" in capsys.readouterr().err
    assert main(["gear", "gear_roller", "--reference", "B=0,0,nan"]) == 2
    assert "is not AXIS=X,Y,Z" in capsys.readouterr().err
    assert main(["gear", "gear_roller", "--teeth", "47"]) == 2
    assert "(--module-mm x --teeth / 2) is 41.1250 mm" in capsys.readouterr().err


def test_cli_gear_png(tmp_path, capsys):
    path = tmp_path / "gear.png"
    assert main(["gear", "gear_roller", "--profile-points", "5", "--face-points", "3", "--png", str(path)]) == 0
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {path}" in capsys.readouterr().err
    assert main(["gear", "gear_roller", "--unit-errors", "--png", str(path)]) == 2
    assert "--png draws all sources together" in capsys.readouterr().err


STEEL = {"e_tool": 210e9, "e_work": 209e9, "nu_tool": 0.3, "nu_work": 0.3, "yield_strength": 835e6}


def test_springback_is_dimensionally_consistent():
    """Seed 004's contact formulas in N, mm, MPa give the SI result in mm: the logarithm's
    argument and the CEB ratio are dimensionless, as they must be."""
    from volerr_pin.applications.gear import contact_springback

    si = contact_springback([30.79e3, 3.01e3], [0.02, 0.0029], G, roll=1e-3, **STEEL)
    in_mm = GearPair(module=1.75, pressure_angle=20 * DEG, teeth=46, tool_teeth=128, face_width=20.0)
    mm = contact_springback([30.79e3, 3.01e3], [20.0, 2.9], in_mm, roll=1.0, e_tool=210e3, e_work=209e3,
                            nu_tool=0.3, nu_work=0.3, yield_strength=835.0)
    np.testing.assert_allclose(mm.deformation, si.deformation * 1e3, rtol=1e-12)
    assert mm.critical == pytest.approx(si.critical * 1e3, rel=1e-12)
    assert si.modulus == pytest.approx(1 / (0.91 / 210e9 + 0.91 / 209e9))
    assert (si.rebound == si.deformation - si.critical).all()                # elastoplastic here
    # a workpiece that does not yield springs back entirely
    hard = contact_springback(3.01e3, 0.0029, G, **{**STEEL, "yield_strength": 1e12})
    assert hard.rebound == pytest.approx(hard.deformation) and hard.critical > hard.deformation
    with pytest.raises(InputError, match="force must be positive"):
        contact_springback([-1.0], [0.02], G, **STEEL)
    with pytest.raises(InputError, match="nu_work must be within"):
        contact_springback(1e3, 0.02, G, **{**STEEL, "nu_work": 0.6})
    with pytest.raises(InputError, match="off the involutes"):
        contact_springback(1e3, 0.02, G, roll=-0.02, **STEEL)


def test_through_rolling_carries_feed_axis_errors_into_the_helix(bare):
    """With the feed axis, each section is finished in the wheel's plane at its own Z: a
    straightness error of Z that grows linearly (dx = c P1 over the 150 mm travel) tilts the
    helix by its slope x face width x cos 20 deg; generated at one Z it is only an offset."""
    m = only(bare, {"EXZ": {"kind": "legendre", "coefficients_um": [0.0, 1.0]}})
    slope = 2 * UM / 0.15                                          # d(dx)/dZ of P1 over the travel
    through = flank_deviations(m, feed="Z", at={"Z": 0.075})
    plunge = flank_deviations(m, at={"Z": 0.075})
    for flank in ("right", "left"):
        assert through.values[flank]["F_beta"] == pytest.approx(slope * G.face_width * np.cos(G.pressure_angle),
                                                                rel=1e-6)
        assert plunge.values[flank]["F_beta"] < 1e-15
    # the mid section is the same either way
    np.testing.assert_allclose(through.normal[..., 5], plunge.normal[..., 5], atol=1e-15)
    with pytest.raises(InputError, match="not a linear axis"):
        flank_deviations(m, feed="B")
    with pytest.raises(InputError, match="does not move the tool along the gear axis"):
        flank_deviations(m, feed="Y")
    with pytest.raises(InputError, match=r"needs Z from -10 to 10 mm \(travel 0 to 150\)"):
        flank_deviations(m, feed="Z")                              # Z = 0 - 10 mm for the lower face


def test_state_reaches_every_source(roller):
    """A time-driven term needs the machine's state in every single-source row, not only in
    'all' (the rebuilt single-source machines keep the state)."""
    from volerr_pin.model import add_terms

    warm = add_terms(roller, {"EXA": {"kind": "thermal_drift", "driver": "time", "amplitudes_um": [4.0],
                                      "time_constants_min": [30.0]}}).with_state(t=3600.0)
    rows = {r.source: r for r in deviations_by_source(warm, components=["EXA", "EYA"], profile_points=3, face_points=3)}
    cold = {r.source: r for r in deviations_by_source(warm.with_state(t=0.0), components=["EXA"],
                                                      profile_points=3, face_points=3)}
    drift = 4 * UM * (1 - np.exp(-2.0))
    np.testing.assert_allclose(rows["EXA"].deviations.normal[0] - cold["EXA"].deviations.normal[0],
                               drift * np.cos(G.pressure_angle), rtol=1e-9)
    assert with_axis_errors(warm, {"A": {"frame": "moving"}}).state == warm.state


def test_pitch_does_not_depend_on_the_order_teeth_are_given(bare):
    moving = with_axis_errors(only(bare, {"EXB": {"kind": "constant", "value_um": 10.0}}), {"B": {"frame": "moving"}})
    order = list(range(G.teeth))
    order[1], order[30] = order[30], order[1]
    a = flank_deviations(moving, profile_points=3, face_points=3)
    b = flank_deviations(moving, profile_points=3, face_points=3, tooth_numbers=order)
    assert a.values == b.values
    # an eccentricity repeats every turn: the step at the seam continues its neighbours'
    pos = a.normal[0, :, 1, 1] / np.cos(G.pressure_angle)
    steps = pos - np.roll(pos, 1)
    seam = G.teeth // 2 + 1
    assert a.values["right"]["seam"] == pytest.approx(steps[seam])
    assert steps[seam] == pytest.approx((steps[seam - 1] + steps[seam + 1]) / 2, rel=0.01)


def test_seam_shows_what_does_not_repeat_over_a_turn(bare):
    """The wheel turns 46/128 of a turn while the workpiece turns once: a wheel-spindle error
    that grows along A's travel differs at the teeth generated last and first by its slope
    times that turn; every other pair of adjacent teeth changes little."""
    m = only(bare, {"EXA": {"kind": "legendre", "coefficients_um": [0.0, 5.0]}})     # dx grows along A's travel
    d = flank_deviations(m, profile_points=3, face_points=3)
    pos = d.normal[0, :, 1, 1] / np.cos(G.pressure_angle)
    steps = pos - np.roll(pos, 1)
    assert d.values["right"]["seam"] == pytest.approx(steps[G.teeth // 2 + 1])
    assert abs(d.values["right"]["seam"]) == pytest.approx(d.values["right"]["f_pt"])
    # the slope of A's travel (5 um over 360 deg) times the wheel's turn of 2 pi 46/128, along the pitch circle
    a_turn = 2 * np.pi * 46 / 128
    assert abs(d.values["right"]["seam"]) == pytest.approx(5 * UM / (2 * np.pi) * a_turn, rel=0.03)


def test_more_bad_inputs(roller):
    with pytest.raises(InputError, match="would interfere"):
        GearPair(module=1e-3, pressure_angle=20 * DEG, teeth=200, tool_teeth=5, face_width=0.02)
    GearPair(module=np.float32(1e-3), pressure_angle=20 * DEG, teeth=46, tool_teeth=128, face_width=np.float64(0.02))
    with pytest.raises(InputError, match="module must be a positive number, got -1 mm"):
        GearPair(module=-1e-3, pressure_angle=20 * DEG, teeth=46, tool_teeth=128, face_width=0.02)
    with pytest.raises(InputError, match="three finite numbers"):
        roller.spec.with_axis("A", reference="abc")
    with pytest.raises(InputError, match="three finite numbers"):
        roller.spec.with_axis("A", reference=(0.0, float("nan"), 0.0))
    with pytest.raises(InputError, match="rotation must be positive, got -2 deg"):
        unit_error_study(roller, rotation=-2 * DEG)
    with pytest.raises(InputError, match=r"\(Y=0, Z=-5, A=0, B=0; mm, deg\)"):
        flank_deviations(roller, at={"Z": -0.005})
    with pytest.raises(InputError, match="broadcast"):
        from volerr_pin.applications.gear import contact_springback
        contact_springback([1e3, 2e3], [0.01, 0.02, 0.03], G, **STEEL)
