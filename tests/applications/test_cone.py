"""The cone frustum cut by a tool's flank on a five-axis machine, as a CMM measures it.

Checked against closed forms (a rigid shift of the tool moves a section's centre by its part
normal to the axis and its diameter by 2 tan(alpha) times its part along the axis; an error
along the tool's own axis, or a turn about it, slides the flank along itself and cuts nothing;
a perfect machine cuts only the program's own chords and rounding), against an independent
evaluation (Pinocchio point by point, and the section of the actual tool's cylinder by the
section's plane: an ellipse whose nearest point to the axis lies r / cos(beta) from the
tool's axis), against the same features of each error source acting alone (the ranking), and
through compensation.
"""

from __future__ import annotations

import numpy as np
import pytest

import volerr_pin.applications.part._cone as cone_module
from volerr_pin.applications.part import (Cone, CuttingPath, cone_frustum_test_piece, cut_of, feature_ranking,
                                          find_cones, measure, measure_cones, predict)
from volerr_pin.base import InputError
from volerr_pin.compensation.gcode import interpret
from volerr_pin.model import _kinematics as K

HEIGHTS = (0.0, 10e-3, 18e-3)


@pytest.fixture(scope="module")
def piece(machines):
    m = machines["cgm4000"]
    text = cone_frustum_test_piece(m)
    path = CuttingPath(m, interpret(m, text))
    cut = cut_of(m, path)
    cones = find_cones(m, path.moves, path.contours, cut, 10e-3)
    return m, text, path, cut, cones


class Displaced:
    """A machine whose tool is displaced rigidly from the nominal: turned by ``R`` about the
    workpiece frame's origin, shifted by ``t``, and moved ``along`` its own axis and turned by
    ``spin`` about it (the tool frame's z). :meth:`measure` measures sections on it: the
    algorithm the cone's measurement takes the actual tool poses from gives these poses while
    it runs."""

    def __init__(self, machine, R=np.eye(3), t=np.zeros(3), along=0.0, spin=0.0):
        self.machine, self.R, self.t, self.along, self.spin = machine, R, np.asarray(t), along, spin

    def poses(self, Rn, pn):
        """The displaced tool poses of nominal ones."""
        c, s = np.cos(self.spin), np.sin(self.spin)
        turned = Rn @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return self.R @ turned, pn @ self.R.T + self.t + self.along * Rn[:, :, 2]

    def measure(self, cones, cut, heights):
        real = cone_module.tool_poses

        def tool_poses(model, q, theta=None, cov=None, *, nominal=False):
            Rn, pn = real(model, q, nominal=True)
            return (Rn, pn) if nominal else self.poses(Rn, pn)

        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(cone_module, "tool_poses", tool_poses)
            return measure_cones(self.machine, cones, cut, heights)


def test_the_test_piece_is_the_cone_it_says(piece):
    m, text, path, cut, cones = piece
    assert text.splitlines()[1] == "(measure it with the cutter's diameter 20 mm, at heights 2, 10, 18 mm)"
    (cone,) = cones
    assert cone.boss and cone.half_angle == pytest.approx(np.radians(15.0), abs=1e-6)
    np.testing.assert_allclose(cone.axis, [np.sin(np.radians(10)), 0.0, np.cos(np.radians(10))], atol=1e-7)
    assert 2 * cone.radius_at(0.0) == pytest.approx(80e-3, abs=0.5e-6)   # the base diameter
    assert len(cone.moves) == 1440 and cone.lines[0] == 7
    q = cut.q[np.isin(cut.move, cone.moves)]
    assert np.ptp(np.degrees(q[:, 3])) > 20 and np.ptp(np.degrees(q[:, 4])) > 20   # both rotary axes turn


def test_a_perfect_machine_cuts_the_programs_chords_only(piece):
    """The program's own form: 1,440 chords of an 80 mm circle sag 0.095 um, and the words are
    rounded to 0.1 um and 1e-4 deg."""
    m, _, _, cut, cones = piece
    for section in Displaced(m).measure(cones, cut, HEIGHTS):
        assert 0.09 < section.circularity_um < 0.3
        assert abs(section.diameter_error_um) < 0.01 and section.centre_error_um < 0.01


def test_a_rigid_shift_moves_the_centre_and_the_diameter_as_the_cone_does(piece):
    m, _, _, cut, cones = piece
    (cone,) = cones
    perfect = Displaced(m).measure(cones, cut, HEIGHTS)
    t = np.array([3e-6, -2e-6, 5e-6])
    shifted = Displaced(m, t=t).measure(cones, cut, HEIGHTS)
    along = t @ cone.axis
    across = t - along * cone.axis
    for a, b in zip(perfect, shifted):
        # up the axis by t_c: the section at a fixed height is the one t_c lower, tan(alpha) t_c wider
        assert b.diameter_error_um - a.diameter_error_um == pytest.approx(2 * np.tan(cone.half_angle) * along * 1e6,
                                                                          abs=1e-6)
        assert b.centre_error_um == pytest.approx(np.linalg.norm(across) * 1e6, abs=0.005)
        np.testing.assert_allclose(b.radial_um, a.radial_um, atol=1e-5)   # the form is the program's


def test_an_error_along_or_about_the_tool_axis_cuts_nothing(piece):
    """The flank slides along itself: a tool length error or a turn of the tool about its axis
    leaves the surface where it was."""
    m, _, _, cut, cones = piece
    perfect = Displaced(m).measure(cones, cut, HEIGHTS)
    for stub in (Displaced(m, along=7e-6), Displaced(m, spin=50e-6)):
        for a, b in zip(perfect, stub.measure(cones, cut, HEIGHTS)):
            np.testing.assert_allclose(b.radial_um, a.radial_um, atol=1e-4)   # second order: 1e-5 um
            assert b.diameter_error_um == pytest.approx(a.diameter_error_um, abs=1e-4)
            assert b.centre_error_um == pytest.approx(a.centre_error_um, abs=1e-4)


def test_a_tilt_of_the_tool_moves_the_sections_apart_with_height(piece):
    """A small turn ``omega`` of the tool about its tip (about x): the contact point at arm
    ``a = s w - r m`` moves by omega x a, and a section counts a displacement ``d`` as
    ``d . v`` with ``v = u + tan(alpha) c`` (radially, and up the slope). With
    ``w = cos(alpha) c - sin(alpha) u``, ``w x v = (c x u) / cos(alpha)``, and ``s`` grows by
    ``dh / cos(alpha)`` between sections ``dh`` apart: the radial profiles differ by
    ``dh / cos(alpha)^2 u . (omega x c)``, a centre moved by ``dh (omega x c) / cos(alpha)^2``."""
    m, _, _, cut, cones = piece
    (cone,) = cones
    omega = 20e-6
    R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(omega), -np.sin(omega)], [0.0, np.sin(omega), np.cos(omega)]])

    class AboutTip(Displaced):
        def poses(self, Rn, pn):
            return R @ Rn, pn

    def centre(section):   # the least-squares centre, in the workpiece frame
        return section.fitted_centre @ cone.basis()

    low, high = AboutTip(m).measure(cones, cut, (2e-3, 18e-3))
    moved = centre(high) - centre(low)
    expected = omega * 16e-3 * np.cross([1.0, 0.0, 0.0], cone.axis) / np.cos(cone.half_angle) ** 2
    np.testing.assert_allclose(moved, expected, atol=0.01 * np.linalg.norm(expected))


@pytest.mark.parametrize("form", ["boss", "bore"])
def test_sections_agree_with_pinocchio_and_the_cylinder_cut_by_the_plane(piece, form):
    """The tool's cylinder cut by the section's plane is an ellipse whose point nearest the
    cone's axis (a boss: the tool outside) or farthest from it (a bore) lies r / cos(beta) from
    where the tool's axis meets the plane, beta the angle of the tool's axis to the cone's."""
    m = piece[0]
    if form == "boss":
        _, _, _, cut, cones = piece
    else:
        path = CuttingPath(m, interpret(m, cone_frustum_test_piece(m, form="bore", tool_diameter=10e-3)))
        cut = cut_of(m, path)
        cones = find_cones(m, path.moves, path.contours, cut, 5e-3)
    (cone,) = cones
    height = 10e-3
    (section,) = measure_cones(m, cones, cut, [height])
    q = section.q   # every point: a subset (block ends only, say) would see the chords' sag differently
    actual = m.pinocchio_configuration(q, m.theta)
    basis = cone.basis()
    level = cone.bottom + height
    points = []
    for k in range(len(q)):
        pose = K.relative_pose_pinocchio(m.model.pinocchio, m.tool_frame, m.workpiece_frame, actual[k])
        w, tip = pose.rotation[:, 2], pose.translation
        s = (level - (tip - cone.apex) @ cone.axis) / (w @ cone.axis)   # the tool's axis meets the plane
        meet = tip + s * w - cone.apex
        radial = meet - (meet @ cone.axis) * cone.axis
        beta = np.arccos(w @ cone.axis)
        side = 1.0 if cone.boss else -1.0   # the ellipse's point nearest the axis, or farthest from it
        rho = np.linalg.norm(radial) - side * cone.tool_radius / np.cos(beta)
        angle = np.arctan2(radial @ basis[1], radial @ basis[0])
        points.append(rho * np.array([np.cos(angle), np.sin(angle)]))
    from volerr_pin.applications.part import fit_circle

    points = np.array(points)
    centre, radius = fit_circle(points)
    deviation = (np.linalg.norm(points - centre, axis=1) - radius) * 1e6
    assert np.abs(deviation - section.radial_um).max() < 0.01
    assert 2 * (radius - section.radius) * 1e6 == pytest.approx(section.diameter_error_um, abs=0.01)
    assert np.linalg.norm(centre) * 1e6 == pytest.approx(section.centre_error_um, abs=0.01)
    assert section.circularity_um > 1.0   # cgm4000's errors, not the program's chords


def test_the_ranking_matches_each_source_acting_alone(piece):
    """Each component's share and range from the exact sensitivities against the section
    measured with that component alone (the batch evaluator, no derivative)."""
    m, _, _, cut, cones = piece
    (section,) = measure_cones(m, cones, cut, [10e-3])
    ranking = feature_ranking(m, section)
    columns = {}
    for term in m.model.term_info():
        columns.setdefault(term["component"], []).extend(m.parameter_names.index(n) for n in term["parameters"])
    perfect = Displaced(m).measure(cones, cut, [10e-3])[0].radial_um
    alone = {}
    for row in ranking[:4]:
        theta = np.zeros_like(m.theta)
        theta[columns[row["component"]]] = m.theta[columns[row["component"]]]
        profile = measure_cones(m.with_theta(theta), cones, cut, [10e-3])[0].radial_um - perfect
        alone[row["component"]] = profile
        assert row["alone_um"] == pytest.approx(np.ptp(profile), rel=0.02, abs=0.002), row
    energy = {c: float(np.sum(p ** 2)) for c, p in alone.items()}
    total = sum(energy.values())
    known = sum(r["share"] for r in ranking[:4])
    for row in ranking[:4]:
        assert row["share"] / known == pytest.approx(energy[row["component"]] / total, abs=0.01), row
    assert sum(r["share"] for r in ranking) == pytest.approx(1.0)


def test_compensation_leaves_the_programs_form_and_its_tolerance(machines, tmp_path):
    from volerr_pin.cli import main

    m = machines["cgm4000"]
    original, compensated = tmp_path / "cone.nc", tmp_path / "cone_comp.nc"
    original.write_text(cone_frustum_test_piece(m))
    assert main(["compensate", "cgm4000", str(original), "-o", str(compensated), "--tol-um", "0.1"]) == 0
    before = predict(m, original.read_text(), tool_diameter=20e-3, cone_heights=HEIGHTS)
    after = predict(m, compensated.read_text(), reference=original.read_text(), tool_diameter=20e-3,
                    cone_heights=HEIGHTS)
    assert len(after.cones) == 3 and after.rankings == [[], [], []]
    for b, a in zip(before.cones, after.cones):
        assert b.circularity_um > 2.0 and b.centre_error_um > 20.0
        # the program's own 0.1 .. 0.3 um, the compensation's 0.1 um and its rounding
        assert a.circularity_um < 0.5 and abs(a.diameter_error_um) < 0.1 and a.centre_error_um < 0.1
        assert len(a.q) > 0.99 * len(b.q)


def test_a_conical_bore(machines):
    m = machines["cgm4000"]
    text = cone_frustum_test_piece(m, form="bore", tool_diameter=10e-3)
    found = measure(m, interpret(m, text), tool_diameter=10e-3, cone_heights=(0.0, 10e-3))
    assert [s.cone.boss for s in found.cones] == [False, False]
    low, high = found.cones
    assert 2 * low.radius == pytest.approx(80e-3, abs=0.5e-6)
    assert high.radius - low.radius == pytest.approx(10e-3 * np.tan(np.radians(15)), abs=1e-6)   # widens upwards
    assert low.circularity_um > 1.0


def test_three_axis_programs_and_sections_out_of_the_cone_are_refused_or_absent(machines, piece):
    m, text, path, cut, cones = piece
    with pytest.raises(InputError, match="cone_heights run from 0"):
        measure_cones(m, cones, cut, [0.5])
    with pytest.raises(InputError, match="two rotary axes"):
        cone_frustum_test_piece(machines["vmc500"])
    with pytest.raises(InputError, match="size"):
        cone_frustum_test_piece(m, size=0.0)
    # the contouring test piece on the same machine: tool axes fixed, no cone
    from volerr_pin.applications.part import contouring_test_piece

    assert predict(m, contouring_test_piece(m)).cones == []
    assert isinstance(cones[0], Cone)


@pytest.mark.parametrize("shift_mm", [0.3, 2.0])
def test_a_cut_that_strays_from_the_reference_cone_is_named_not_measured(machines, shift_mm):
    """With a reference, a cone is measured on the samples whose tool point lies within the
    capture (0.2 mm) of the reference's: a program shifted further than that does not go all
    round the cone (0.3 mm: a part of it; 2 mm: none), and the note says so instead of a
    section of a part of a circle."""
    import re

    m = machines["cgm4000"]
    original = cone_frustum_test_piece(m)
    shifted = re.sub(r"X(\d+\.\d+)", lambda g: f"X{float(g.group(1)) + shift_mm:.4f}", original)
    part = predict(m, shifted, reference=original, tool_diameter=20e-3, cone_heights=HEIGHTS)
    assert part.cones == []
    (note,) = [n for n in part.notes if "cone" in n]
    assert note.startswith("the cone of lines 7..1446 is not measured: the cut has") and "not all round it" in note
