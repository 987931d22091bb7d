"""The part a program cuts: the deviation normal to the path, and a circle as a CMM measures it.

Checked against closed forms (a squareness error cuts a circle of radius R as an ellipse
whose out-of-roundness about the least-squares circle is R |S|; a positioning error linear in
X scales the diameter along X), against an independent evaluation (the plain batch
evaluator on the nominal circle, the radial component and a first-harmonic fit), and against
the sampling tolerance it states.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import single
from volerr_pin.applications.part import deviation_along, feature_ranking, fit_circle, measure, normal_part, predict
from volerr_pin.base import InputError
from volerr_pin.compensation.gcode import interpret

ARCSEC = np.pi / 180 / 3600
CIRCLE = "G17 G90 G21\nG0 X150 Y200 Z100\nG1 X150 Y200 Z100 F500\nG2 X150 Y200 I100 J0\nM30\n"   # R 100 about (250, 200)


def _circle(machine, program=CIRCLE, **options):
    segments = interpret(machine, program)
    deviation = deviation_along(machine, segments, **options)
    (feature,), _, _, _, _ = measure(machine, segments)
    return feature, deviation


def test_a_squareness_error_cuts_an_ellipse_of_out_of_roundness_r_s(machines):
    m = machines["vmc500"]
    for arcsec in (4.0, -10.0):
        s = arcsec * ARCSEC
        feature, _ = _circle(m.with_theta(single(m, "EC0Y", s)))
        assert feature.circularity_um == pytest.approx(0.1 * abs(s) * 1e6, rel=1e-3)   # R |S|, to first order
        assert abs(feature.diameter_error_um) < 1e-3 * feature.circularity_um
        assert feature.lines == (4,) and feature.radius == pytest.approx(0.1, abs=1e-12)


def _linear_exx(machine, slope):
    """Coefficients with only a positioning error of X, ``slope`` x (its table's nodes on a line)."""
    theta = np.zeros(len(machine.parameter_names))
    nodes = [n for n in machine.parameter_names if n.startswith("EXX.n")]
    for k, name in enumerate(nodes):
        theta[machine.parameter_names.index(name)] = slope * machine.travel[0, 1] * k / (len(nodes) - 1)
    return theta


def test_a_positioning_error_linear_in_x_scales_the_diameter_along_x(machines):
    """e_x = c x: the radial deviation is c (x0 + R cos a) cos a, so the least-squares circle
    grows by c R / 2 (diameter error c R) and the rest, c R cos(2a) / 2, is out of roundness c R."""
    m = machines["vmc500"]
    c = 20e-6   # 20 um/m
    linear = m.with_theta(_linear_exx(m, c))
    x = np.array([[0.1, 0.2, 0.1], [0.3, 0.2, 0.1]])
    err = linear.volumetric_error(x)[:, 0]
    slope = (err[1] - err[0]) / 0.2
    feature, _ = _circle(linear)
    assert feature.diameter_error_um == pytest.approx(slope * 0.1 * 1e6, rel=2e-3)
    assert feature.circularity_um == pytest.approx(abs(slope) * 0.1 * 1e6, rel=2e-3)


def test_the_circle_agrees_with_an_independent_evaluation(machines):
    """The bundled vmc500 with every error: the plain batch evaluator at 3,600 points of the
    nominal circle, the radial component, and its least-squares circle to first order (the
    mean and the first harmonics removed) give the same circularity and diameter error."""
    m = machines["vmc500"]
    feature, _ = _circle(m)
    a = np.linspace(0.0, 2 * np.pi, 3600, endpoint=False)
    q = np.c_[0.25 + 0.1 * np.cos(a), 0.2 + 0.1 * np.sin(a), np.full_like(a, 0.1)]
    radial = np.sum(m.volumetric_error(q)[:, :2] * np.c_[np.cos(a), np.sin(a)], axis=1) * 1e6
    basis = np.c_[np.ones_like(a), np.cos(a), np.sin(a)]
    coefficients, *_ = np.linalg.lstsq(basis, radial, rcond=None)
    rest = radial - basis @ coefficients
    assert feature.circularity_um == pytest.approx(float(np.ptp(rest)), rel=0.02)
    assert feature.diameter_error_um == pytest.approx(2 * coefficients[0], rel=0.02, abs=0.01)
    assert feature.centre_error_um == pytest.approx(float(np.hypot(*coefficients[1:])), rel=0.02, abs=0.01)


def test_what_moves_along_the_path_is_not_cut(machines):
    """A line along X on a machine with only a positioning error of X: the error is all along
    the path, and the cut deviates by nothing."""
    m = machines["vmc500"]
    along = m.with_theta(_linear_exx(m, 20e-6))
    segments = interpret(along, "G90 G21\nG0 X50 Y100 Z100\nG1 X450 F500\nM30\n")
    deviation = deviation_along(along, segments)
    assert np.abs(deviation.error[:, 0]).max() > 5e-6
    assert np.abs(deviation.normal).max() < 1e-12
    assert deviation.per_block() == {3: pytest.approx(0.0, abs=1e-6)}
    np.testing.assert_allclose(deviation.tangent[:, 0], 1.0)


def test_the_samples_meet_the_stated_tolerance(machines):
    """Between any two neighbouring samples, the deviation interpolated linearly is within the
    tolerance of the model, checked at points the sampling never evaluated."""
    m = machines["vmc500"]
    tolerance = 0.002e-6
    segments = interpret(m, CIRCLE)
    deviation = deviation_along(m, segments, tolerance=tolerance)
    arc = [s for s in segments if s.kind == "arc"][0]
    rows = deviation.line == arc.line   # (the zero-length G1 before it is no cutting move)
    k, normal = deviation.fraction[rows], deviation.normal[rows]
    probe = np.random.default_rng(3).random(500)
    q = arc.arc.point(probe)
    tangent = arc.arc.point(probe + 1e-7) - arc.arc.point(probe - 1e-7)   # vmc500's axes are the frame's
    exact = normal_part(m.volumetric_error(q)[:, :3], tangent / np.linalg.norm(tangent, axis=1)[:, None])
    interpolated = np.c_[[np.interp(probe, k, normal[:, i]) for i in range(3)]].T
    assert np.abs(exact - interpolated).max() <= 1.5 * tolerance
    assert q.shape == (500, 3)


def test_normal_part_and_the_circle_fit():
    t = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    e = np.array([[2.0, 3.0, 4.0], [1.0, 1.0, 1.0]])
    np.testing.assert_allclose(normal_part(e, t), [[0.0, 3.0, 4.0], [1.0, 1.0, 1.0]])
    a = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    centre, radius = fit_circle(np.c_[1.0 + 2.0 * np.cos(a), -3.0 + 2.0 * np.sin(a)])
    np.testing.assert_allclose(centre, [1.0, -3.0], atol=1e-12)
    assert radius == pytest.approx(2.0, abs=1e-12)
    with pytest.raises(InputError, match="fit_circle needs"):
        fit_circle(np.zeros((2, 2)))


def test_bad_tolerance_and_a_program_without_cuts_are_refused(machines):
    m = machines["vmc500"]
    with pytest.raises(InputError, match="tolerance must be a positive"):
        deviation_along(m, interpret(m, CIRCLE), tolerance=0.0)
    with pytest.raises(InputError, match="no cutting move"):
        deviation_along(m, interpret(m, "G90 G0 X10 Y10 Z10\nM30\n"))


def test_a_move_out_of_the_travel_is_refused_with_its_line(machines):
    m = machines["vmc500"]
    with pytest.raises(InputError, match=r"line 3: the move takes X to -50.0000 mm, outside its travel 0 .. 500 mm"):
        deviation_along(m, interpret(m, "G90 G21\nG0 X50 Y100 Z100\nG1 X-50 F500\nM30\n"))


SQUARE = ("G17 G90 G21\nG0 X150 Y100 Z100\nG1 X350 F500\nG1 Y300\nG1 X150\nG1 Y100\nG0 Z150\n"
          "G0 X150 Y200 Z100\nG2 X150 Y200 I100 J0\nM30\n")   # a 200 mm square, then the circle


def test_a_squareness_error_is_the_squareness_of_the_sides_and_nothing_else(machines):
    """Only a squareness S of X and Y: each side perpendicular to a datum side is out of square
    by L |S| (L = 200 mm), parallel sides stay parallel, every side straight."""
    m = machines["vmc500"]
    s = 6.0 * ARCSEC
    square = m.with_theta(single(m, "EC0Y", s))
    _, sides, pairs, _, _ = measure(square, interpret(square, SQUARE))
    assert [f.lines for f in sides] == [(3,), (4,), (5,), (6,)]
    assert max(f.straightness_um for f in sides) < 1e-6
    kinds = {(p.lines, p.kind): p.value_um for p in pairs}
    assert set(kinds) == {((3, 4), "squareness"), ((3, 5), "parallelism"), ((3, 6), "squareness"),
                          ((4, 5), "squareness"), ((4, 6), "parallelism"), ((5, 6), "squareness")}
    spans = {f.lines[0]: float(np.ptp(f.along())) for f in sides}   # the measured part of each side
    assert min(spans.values()) > 0.199
    for (lines, kind), value in kinds.items():
        expected = spans[lines[1]] * s * 1e6 if kind == "squareness" else 0.0
        assert value == pytest.approx(expected, rel=1e-4, abs=1e-6), (lines, kind)


def test_straightness_agrees_with_an_independent_evaluation(machines):
    """vmc500's spec: a side along X keeps the error across it, e_y; the batch evaluator at
    2,001 points of the side less its least-squares line gives the same straightness."""
    m = machines["vmc500"]
    _, sides, _, _, _ = measure(m, interpret(m, SQUARE))
    along = sides[0].along()
    x = np.linspace(0.15 + along.min(), 0.15 + along.max(), 2001)   # where the side was measured
    q = np.c_[x, np.full_like(x, 0.1), np.full_like(x, 0.1)]
    across = m.volumetric_error(q)[:, 1] * 1e6
    rest = across - np.polyval(np.polyfit(x, across, 1), x)
    assert sides[0].straightness_um == pytest.approx(float(np.ptp(rest)), rel=1e-3)


@pytest.mark.parametrize("which", ["circle", "side", "squareness", "parallelism"])
def test_the_feature_ranking_matches_finite_differences(machines, which):
    """Each component's profile from the exact sensitivities against the difference of the
    errors with and without that component (the batch evaluator, no derivative): the same
    ranges and shares."""
    m = machines["vmc500"]
    segments = interpret(m, SQUARE)
    circles, sides, pairs, _, _ = measure(m, segments)
    feature = {"circle": circles[0], "side": sides[0],
               "squareness": next(p for p in pairs if p.kind == "squareness"),
               "parallelism": next(p for p in pairs if p.kind == "parallelism")}[which]
    exact = {r["component"]: r for r in feature_ranking(m, feature)}
    columns = {}
    for term in m.model.term_info():
        columns.setdefault(term["component"], []).extend(m.parameter_names.index(n) for n in term["parameters"])

    def without(component):
        theta = m.theta.copy()
        theta[columns[component]] = 0.0
        return m.with_theta(theta)

    import volerr_pin.applications.part._ranking as ranking

    original = ranking._contributions

    def by_differences(machine, q, covariates=None):
        full = machine.volumetric_error(q, **(covariates or {}))
        return {c: full - without(c).volumetric_error(q, **(covariates or {})) for c in columns}

    ranking._contributions = by_differences
    try:
        differences = {r["component"]: r for r in feature_ranking(m, feature)}
    finally:
        ranking._contributions = original
    assert list(exact)[:3] == list(differences)[:3]
    for component, row in exact.items():
        assert row["share"] == pytest.approx(differences[component]["share"], abs=2e-3), component
        assert row["alone_um"] == pytest.approx(differences[component]["alone_um"], rel=1e-2, abs=1e-3), component
    assert sum(r["share"] for r in exact.values()) == pytest.approx(1.0)


def test_a_tool_tip_program_is_followed_where_the_controller_puts_the_axes(machines):
    """The same cut written in tool-tip programming (G43.4: X, Y, Z the tool tip) and in axes
    programming (the axis positions the controller would take): the same deviation. With the
    head tilted the two differ by the head's offset, which the tool-tip words leave out."""
    from volerr_pin.compensation import programming_for

    m = machines["cgm4000"]
    tip = programming_for("tool-tip", m)
    words = np.array([[1900e-3, 1200e-3, 250e-3, np.radians(20.0), np.radians(30.0)],
                      [2100e-3, 1300e-3, 260e-3, np.radians(20.0), np.radians(30.0)]])
    q = tip.to_axes(words)
    assert np.abs(q[:, :3] - words[:, :3]).max() > 10e-3   # the head's offset

    def program(rows, g43):
        def block(code, r):
            return f"{code} X{r[0] * 1e3:.6f} Y{r[1] * 1e3:.6f} Z{r[2] * 1e3:.6f} A{np.degrees(r[3]):.6f} B{np.degrees(r[4]):.6f}"
        return "\n".join(["G90 G21", *(["G43.4 H1"] if g43 else []), block("G0", rows[0]), block("G1", rows[1]) + " F500",
                          "M30"])

    by_tip = deviation_along(m, interpret(m, program(words, True)))
    by_axes = deviation_along(m, interpret(m, program(q, False)))
    np.testing.assert_allclose(by_tip.q, by_axes.q, atol=1e-9)
    np.testing.assert_allclose(by_tip.normal, by_axes.normal, atol=1e-12)
    np.testing.assert_allclose(by_tip.point, np.outer(1 - by_tip.fraction, words[0, :3])
                               + np.outer(by_tip.fraction, words[1, :3]), atol=1e-9)   # the tip goes straight


def test_a_backlash_on_x_cuts_steps_of_its_reversal_where_x_turns(machines):
    """Backlash b on X is (b/2) d, d the direction X moves in. Going round a circle X turns at
    its ends (angles 0 and 180 deg), so the radial deviation (b/2) d(theta) cos(theta) steps by
    b there; it has no first harmonic (the least-squares circle is the nominal one) and spans b.
    The directions come from the path, as the controller's."""
    from volerr_pin.model import add_terms

    m = machines["vmc500"]
    bare = m.with_theta(np.zeros_like(m.theta))
    loose = add_terms(bare, {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 3.0}})
    theta = np.zeros_like(loose.theta)
    theta[loose.parameter_names.index(next(n for n in loose.parameter_names if "rev" in n))] = 3e-6
    loose = loose.with_theta(theta)
    feature, deviation = _circle(loose)
    assert feature.circularity_um == pytest.approx(3.0, abs=0.02)
    assert abs(feature.diameter_error_um) < 0.02 and feature.centre_error_um < 0.02
    # the steps are where X turns
    order = np.argsort(feature.angle)
    round_ = feature.radial_um[order]
    jumps = np.abs(np.diff(np.r_[round_, round_[:1]]))   # round the circle, across +-180 deg too
    assert np.sort(jumps)[-2:] == pytest.approx([3.0, 3.0], abs=0.05)
    turns = np.sort(np.abs(np.degrees(feature.angle[order][np.argsort(jumps)[-2:]])))
    np.testing.assert_allclose(turns, [0.0, 180.0], atol=1.0)
    assert feature_ranking(loose, feature)[0]["component"] == "EXX"
    # without the path's directions the backlash would be its mean, nothing: the state's directions
    # only say how the axes arrived before the program
    assert deviation.max_um == pytest.approx(1.5, abs=0.01)
    arrived = loose.with_state(directions=[-1, 1, 1])
    assert _circle(arrived)[0].circularity_um == pytest.approx(3.0, abs=0.02)


def test_a_lathes_profile_is_measured_in_its_xz_plane(machines):
    """lathe_2axis (axes Z, X): the contour plane found is xz, and a full circle of the profile
    (G18, I and K) agrees with the batch evaluator on the nominal circle, its radial component
    in xz less its mean and first harmonics."""
    m = machines["lathe_2axis"]
    program = "G18 G90 G21\nG0 X60 Z-10\nG1 X60 Z-200 F100\nG1 X100 Z-200\nG0 X80 Z-350\nG1 X80 Z-350\n" \
              "G2 X80 Z-350 I0 K20\nM30\n"
    part = predict(m, program)
    (circle,) = part.circles
    assert circle.plane == (0, 2) and [s.plane for s in part.sides] == [(0, 2), (0, 2)]
    np.testing.assert_allclose(circle.centre, [0.08, -0.33], atol=1e-12)
    assert circle.radius == pytest.approx(0.02, abs=1e-12)
    a = np.linspace(0.0, 2 * np.pi, 3600, endpoint=False)
    q = np.c_[-0.33 + 0.02 * np.sin(a), 0.08 + 0.02 * np.cos(a)]   # axes Z, X: x = X, z = Z
    radial = np.sum(m.volumetric_error(q)[:, [0, 2]] * np.c_[np.cos(a), np.sin(a)], axis=1) * 1e6
    basis = np.c_[np.ones_like(a), np.cos(a), np.sin(a)]
    coefficients, *_ = np.linalg.lstsq(basis, radial, rcond=None)
    assert circle.circularity_um == pytest.approx(float(np.ptp(radial - basis @ coefficients)), rel=0.02)
    assert circle.diameter_error_um == pytest.approx(2 * coefficients[0], rel=0.02, abs=0.01)
    assert circle.centre_error_um == pytest.approx(float(np.hypot(*coefficients[1:])), rel=0.02, abs=0.01)
    # the side along X at Z -200: its deviation across it (z) less its least-squares line
    x = np.linspace(0.06, 0.1, 1000)
    across = m.volumetric_error(np.c_[np.full_like(x, -0.2), x])[:, 2] * 1e6
    rest = across - np.polyval(np.polyfit(x, across, 1), x)
    assert part.sides[1].straightness_um == pytest.approx(float(np.ptp(rest)), rel=0.02)
    assert len(part.pairs) == 1 and part.pairs[0].kind == "squareness"


def test_backlash_reversals_inside_arcs_and_between_lines_are_sampled(machines):
    """Backlash b on Y. A circle starting at 30 deg: Y turns inside the arc (at 90 and 270 deg),
    where the deviation steps; the sampling leaves each step between two samples a hair apart
    and meets the tolerance everywhere else. A zig-zag of lines: Y turns where the second line
    starts, each line keeps its own direction, and the step is between them."""
    from volerr_pin.model import add_terms

    m = machines["vmc500"]
    bare = m.with_theta(np.zeros_like(m.theta))
    loose = add_terms(bare, {"EYY": {"kind": "backlash", "prefix": "rev", "reversal_um": 3.0}})
    theta = np.zeros_like(loose.theta)
    theta[[i for i, n in enumerate(loose.parameter_names) if "rev" in n]] = 3e-6
    loose = loose.with_theta(theta)
    c, s = 0.1 * np.cos(np.radians(30)), 0.1 * np.sin(np.radians(30))
    start = f"X{(0.25 + c) * 1e3:.6f} Y{(0.2 + s) * 1e3:.6f}"
    program = (f"G17 G90 G21\nG0 {start} Z100\nG1 {start} Z100 F500\n"
               f"G3 {start} I{-c * 1e3:.6f} J{-s * 1e3:.6f}\nM30\n")
    deviation = deviation_along(loose, interpret(loose, program))
    arc = deviation.line == 4   # the G3 (the zero-length G1 before it is no cutting move)
    y_error = deviation.error[arc, 1] * 1e6
    steps = np.flatnonzero(np.abs(np.diff(y_error)) > 1.0)
    assert len(steps) == 2 and np.allclose(np.abs(np.diff(y_error))[steps], 3.0, atol=1e-6)
    gaps = np.diff(deviation.fraction[arc])[steps]
    assert gaps.max() < 1e-8   # the steps are pinned between two samples a hair apart
    angles = np.degrees(np.arctan2(deviation.point[arc][steps, 1] - 0.2, deviation.point[arc][steps, 0] - 0.25))
    # where Y turns, to the 1e-6 of the move its direction is read over (3.6e-4 deg)
    np.testing.assert_allclose(np.sort(angles), [-90.0, 90.0], atol=1e-3)
    assert len(deviation.line) < 2_000   # elsewhere the tolerance is met with a few samples

    zigzag = "G17 G90 G21\nG0 X150 Y100 Z100\nG1 X350 Y150 F500\nG1 X150 Y100\nM30\n"
    lines = deviation_along(loose, interpret(loose, zigzag))
    ends = lines.error[:, 1] * 1e6
    first, second = lines.move == 0, lines.move == 1
    np.testing.assert_allclose(ends[first], 1.5, atol=1e-9)    # Y up: +b/2 all along, its end included
    np.testing.assert_allclose(ends[second], -1.5, atol=1e-9)  # Y down from its start
    assert first.sum() == 3 and second.sum() == 3


@pytest.mark.parametrize("plunge, plane", [(100, (0, 1)), (150, (0, 1)), (None, (0, 2))])
def test_the_contour_plane_is_where_the_cutting_length_is(machines, plunge, plane):
    """A 40 mm circle after a plunge along z is measured in xy however deep the plunge (a move
    along one axis counts half in each of its two planes); a profile of lines along X and Z (a
    lathe's, here on vmc500) is measured in xz."""
    m = machines["vmc500"]
    if plunge is not None:
        program = f"G17 G90 G21\nG0 X150 Y200 Z{100 + plunge}\nG1 Z100 F500\nG2 X150 Y200 I20 J0\nM30\n"
    else:
        program = "G18 G90 G21\nG0 X150 Y200 Z300\nG1 Z150 F500\nG1 X200\nG1 Z100\nG1 X250\nM30\n"
    part = predict(m, program)
    assert {f.plane for f in [*part.circles, *part.sides]} == {plane} and part.notes == []
    if plunge is not None:
        assert [c.lines for c in part.circles] == [(4,)]
    else:
        assert [s.lines for s in part.sides] == [(3,), (4,), (5,), (6,)]


def test_a_circle_outside_the_contour_plane_is_named_not_dropped(machines):
    m = machines["vmc500"]
    program = "G17 G90 G21\nG0 X150 Y200 Z110\nG1 Z100 F500\nG2 X150 Y200 I20 J0\nG18 G2 X150 Z100 I5 K0\nM30\n"
    part = predict(m, program)
    assert [c.lines for c in part.circles] == [(4,)] and part.circles[0].plane == (0, 1)
    assert part.notes == ["the full circle of line 5 lies in the xz plane, not in the contour plane xy: it is "
                          "measured in a prediction of that plane"]
    assert part.to_dict()["notes"] == part.notes
    assert predict(m, program, plane=(0, 2)).circles[0].lines == (5,)


def test_a_move_that_turns_a_rotary_axis_is_sampled_along_its_curve(machines):
    """G1 B180 on cgm4000 with A at 30 deg: the tool point goes round a half circle, not along
    its chord (which would give 3 samples a half turn apart)."""
    from volerr_pin.applications.part import cut_of

    m = machines["cgm4000"]
    cut = cut_of(m, interpret(m, "G90 G21\nG0 X2000 Y1250 Z300 A30 B0\nG1 B180 F500\nM30\n"))
    spacing = np.linalg.norm(np.diff(cut.nominal, axis=0), axis=1)
    assert spacing.max() <= 0.25e-3 * 1.002 and len(cut.move) > 3000


def test_pairs_are_corners_and_opposite_sides_so_a_long_contour_stays_linear(machines):
    """A zig-zag of 40 passes (one contour): each pass is parallel to the pass before, and the
    short steps between them are no sides; 39 parallelism pairs, each to the previous pass (all
    pairs of 40 sides would be 780). A square: its four corners and two pairs of opposite
    sides."""
    m = machines["vmc500"]
    lines = ["G17 G90 G21", "G0 X100 Y100 Z100", "G1 X100 Y100 F500"]
    for k in range(40):
        lines += [f"G1 X{200 if k % 2 == 0 else 100} Y{100 + 2 * k}", f"G1 Y{102 + 2 * k}"]
    part = predict(m, "\n".join(lines) + "\nM30\n")
    assert len(part.sides) == 40 and len(part.pairs) == 39
    assert all(p.kind == "parallelism" and p.datum.lines[0] + 2 == p.toleranced.lines[0] for p in part.pairs)
    _, sides, pairs, _, _ = measure(m, interpret(m, SQUARE))
    corners = {(p.datum.lines[0], p.toleranced.lines[0]) for p in pairs if p.kind == "squareness"}
    opposite = {(p.datum.lines[0], p.toleranced.lines[0]) for p in pairs if p.kind == "parallelism"}
    first = sides[0].lines[0]
    assert corners == {(first, first + 1), (first + 1, first + 2), (first + 2, first + 3), (first, first + 3)}
    assert opposite == {(first, first + 2), (first + 1, first + 3)}
