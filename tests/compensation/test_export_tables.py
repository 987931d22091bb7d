"""The pieces every controller export shares: interpolation as controllers do it, directions
from the path, tables as linear maps of their values, zones, the fit and the simulation."""

from __future__ import annotations

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.base import InputError
from volerr_pin.compensation.export import Points, Zone, fit, parse_zone, tool_tips
from volerr_pin.compensation.export._tables import SetpointTables, Table, interpolation_weights, quantised
from volerr_pin.compensation.export._simulate import exact_setpoints, residuals, tip_jacobian
from volerr_pin.compensation.export._zone import motion_directions
from volerr_pin.model import replace_terms


def test_linear_weights_interpolate_and_hold_the_ends():
    nodes = np.array([0.0, 1.0, 3.0, 4.0])
    values = np.array([2.0, -1.0, 5.0, 0.5])
    x = np.linspace(-2.0, 6.0, 201)
    idx, w = interpolation_weights(nodes, x)
    got = (w * values[idx]).sum(axis=1)
    np.testing.assert_allclose(got, np.interp(x, nodes, values), atol=1e-15)  # np.interp holds the ends too
    assert got[0] == 2.0 and got[-1] == 0.5
    np.testing.assert_allclose(w.sum(axis=1), 1.0)


def test_step_weights_hold_each_node_up_to_the_next():
    nodes = np.array([0.0, 1.0, 3.0])
    values = np.array([10.0, 20.0, 30.0])
    idx, w = interpolation_weights(nodes, np.array([-1.0, 0.0, 0.999, 1.0, 2.5, 3.0, 9.0]), step=True)
    np.testing.assert_array_equal((w * values[idx]).sum(axis=1), [10, 10, 10, 20, 20, 30, 30])


def test_plane_table_is_bilinear_with_held_margins():
    g1, g2 = np.array([0.0, 1.0, 2.0]), np.array([0.0, 2.0])
    values = np.array([[0.0, 4.0], [1.0, 5.0], [3.0, 7.0]])                  # [x node, y node]
    table = Table(2, (0, 1), (g1, g2), values)
    q = np.array([[0.5, 1.0, 0.0], [1.5, 0.5, 0.0], [-3.0, 9.0, 0.0], [2.0, 2.0, 0.0]])
    got = table.correction(q, np.ones_like(q))
    # by hand: bilinear in the cell, margins held outside
    bilinear = lambda v00, v10, v01, v11, t, s: (1 - t) * (1 - s) * v00 + t * (1 - s) * v10 + (1 - t) * s * v01 \
        + t * s * v11  # noqa: E731
    np.testing.assert_allclose(got, [bilinear(0, 1, 4, 5, 0.5, 0.5), bilinear(1, 3, 5, 7, 0.5, 0.25), 4.0, 7.0])


def test_directional_and_one_way_tables_read_the_first_inputs_direction():
    nodes = (np.array([0.0, 1.0]),)
    table = Table(0, (1,), nodes, np.array([[1.0, 3.0], [-1.0, -3.0]]), directional=True)
    q = np.array([[9.0, 0.5], [9.0, 0.5]])
    d = np.array([[-1.0, 1.0], [1.0, -1.0]])            # the output axis' own direction is not read
    np.testing.assert_allclose(table.correction(q, d), [2.0, -2.0])
    up = Table(0, (0,), nodes, np.array([1.0, 1.0]), only=1)
    np.testing.assert_allclose(up.correction(np.array([[0.5], [0.5]]), np.array([[1.0], [-1.0]])), [1.0, 0.0])


def test_tables_are_linear_maps_of_their_free_values():
    rng = np.random.default_rng(1)
    free = np.ones((2, 5), dtype=bool)
    free[0, 2] = False
    tables = SetpointTables((
        Table(0, (0,), (np.linspace(0, 1, 5),), np.zeros((2, 5)), directional=True, free=free, step=True),
        Table(1, (0, 1), (np.linspace(0, 1, 4), np.linspace(0, 2, 3)), np.zeros((4, 3))),
        Table(1, (1,), (np.linspace(0, 2, 6),), np.zeros((2, 6)), directional=True, tied=True)), 2)
    assert tables.values.size == 9 + 12 + 6
    v = rng.normal(size=tables.values.size)
    filled = tables.with_values(v)
    np.testing.assert_array_equal(filled.values, v)
    assert filled.tables[0].values[0, 2] == 0.0                                 # fixed value stays
    np.testing.assert_array_equal(filled.tables[2].values[0], filled.tables[2].values[1])   # tied directions
    q = rng.random((50, 2)) * [1.2, 2.4] - 0.1
    d = rng.choice([-1.0, 1.0], size=(50, 2))
    B = tables.basis(q, d, np.zeros(50))
    np.testing.assert_allclose((B @ v).reshape(50, 2), filled.correction(q, d, np.zeros(50)), atol=1e-14)


def test_motion_directions_follow_the_commanded_motion_and_hold_at_standstill():
    q = np.array([[0.0, 5.0], [1.0, 5.0], [1.0, 4.0], [0.5, 4.0], [0.5, 4.0], [2.0, 6.0]])
    np.testing.assert_array_equal(motion_directions(q), [[1, 1], [1, 1], [1, -1], [-1, -1], [-1, -1], [1, 1]])
    np.testing.assert_array_equal(motion_directions(q[:1], start=np.array([-1.0, 1.0])), [[-1, 1]])


def test_quantised_rounds_half_away_from_zero():
    np.testing.assert_allclose(quantised(np.array([0.25, -0.25, 0.24, -0.76, 0.0]), 0.5), [0.5, -0.5, 0.0, -1.0, 0.0])


def test_zones_parse_in_engineering_units_and_refuse_nonsense(machines):
    m = machines["cgm4000"]
    z = parse_zone(m, ["X=100:300", "A=-30:45", "B=0", "tool=0:80"])
    np.testing.assert_allclose(z.ranges[0], [0.1, 0.3])
    np.testing.assert_allclose(z.ranges[3], np.radians([-30, 45]))
    np.testing.assert_allclose(z.ranges[4], [0.0, 0.0])
    np.testing.assert_allclose(z.ranges[1], m.travel[1])                       # not named: whole travel
    assert z.tool == (0.0, 0.08)
    for items, match in ((["Q=0:1"], "names no axis"), (["X=300:100"], "runs backwards"),
                         (["X=-10:100"], "leaves the travel of X"), (["X=1", "X=2"], "given twice"),
                         (["X"], "is not AXIS=LO:HI"), (["X=a:b"], "zone: 'X=a:b'")):
        with pytest.raises(InputError, match=match) as err:
            parse_zone(m, items)
        assert err.value.parameters == ("zone",)


def test_a_zone_given_is_checked_where_the_export_takes_it(machines):
    """The positions sampled from a zone are evaluated unchecked: a zone that is not a finite
    range of every axis is refused at the door, naming the axis."""
    from volerr_pin.compensation.export import export_tables, layout_files

    m = machines["vmc500"]
    nan = Zone(np.array([[0.0, 0.5], [0.0, np.nan], [0.0, 0.4]]))
    for call in (lambda: export_tables(m, "linuxcnc", zone=nan, points=64), lambda: layout_files(m, "fanuc", zone=nan)):
        with pytest.raises(InputError, match=r"zone: the range of Y is \[0.0, nan\]; it must be finite") as err:
            call()
        assert err.value.parameters == ("zone",)
    with pytest.raises(InputError, match=r"zone: the ranges have shape \(2, 2\); expected \(3, 2\)"):
        export_tables(m, "linuxcnc", zone=Zone(np.zeros((2, 2))), points=64)


def test_zone_samples_stay_inside_and_carry_tools():
    m = vp.load_machine("vmc700")
    z = parse_zone(m, ["X=100:200", "tool=10:30"])
    p = z.sample(256, seed=3)
    assert p.q[:, 0].min() >= 0.1 and p.q[:, 0].max() <= 0.2
    assert p.tool.min() >= 0.01 and p.tool.max() <= 0.03
    with pytest.raises(InputError, match="points must be >= 2"):
        z.sample(1)


@pytest.mark.parametrize("sample", ["sample", "corners_and_nodes"])
def test_every_position_is_reached_from_both_directions(sample):
    """The points tables are fitted and judged on reach every position from both directions,
    independently of where it lies. Visited in a Sobol' sequence's own order, each axis arrived
    from the direction of the half of its travel it lay in (Y 100 %, Z 93 %, X 75 % on vmc500),
    so half of each direction table was never fitted nor judged."""
    m = vp.load_machine("vmc500")
    z = parse_zone(m, [])
    p = z.sample(4096, seed=0) if sample == "sample" else z.corners_and_nodes(
        [np.linspace(lo, hi, 9) for lo, hi in m.travel], 4096, seed=0)
    np.testing.assert_array_equal(p.q[0::2], p.q[1::2])
    np.testing.assert_array_equal(p.directions[0::2], -p.directions[1::2])
    upper = p.q > np.median(p.q, axis=0)
    agree = (p.directions > 0) == upper
    assert np.all(np.abs(agree.mean(axis=0) - 0.5) < 0.03), agree.mean(axis=0)
    if sample != "sample":
        return
    # the old order: the sequence's own (here, the same positions in it)
    old = motion_directions(p.q[0::2])
    assert ((old > 0) == upper[0::2]).mean(axis=0).max() > 0.7
    # visited once each in a random order, directions come from that path
    r = z.shuffled(p, seed=1)
    assert len(r) == 2048 and len(np.unique(r.q, axis=0)) == 2048
    np.testing.assert_array_equal(r.directions, motion_directions(r.q))


def test_a_direction_tables_claimed_residual_is_what_a_random_order_leaves():
    """The issue's case: vmc500 with a 6 um reversal of X, exported to LinuxCNC. Fitted and
    judged on the Sobol' sequence's own order the claim was 18.40 / 6.10 um (max / RMS) where the
    same points in random order gave 24.57 / 6.74 um. Both-ways points give a claim within 5 % of
    the random order, which the report gives beside it."""
    from volerr_pin.compensation.export import export_tables
    from volerr_pin.model import add_terms

    m = add_terms(vp.load_machine("vmc500"), {"EXX": {"kind": "backlash", "prefix": "h", "reversal_um": 6.0}})
    for controller in ("linuxcnc", "fanuc"):
        report = export_tables(m, controller).to_dict()
        for stat in ("max", "rms"):
            claim, random = report[f"residual_{stat}_um"], report[f"random_order_residual_{stat}_um"]
            assert abs(claim - random) <= 0.05 * random, (controller, stat, claim, random)


def test_tool_tip_jacobian_matches_finite_differences(machines):
    m = machines["cgm4000"]
    p = Zone.workspace(m).sample(8, seed=2)
    p = Points(p.q, p.directions, np.full(8, 0.12))
    J = tip_jacobian(m, p.q, p)
    h = 1e-7
    for j in range(len(m.axes)):
        dq = np.zeros_like(p.q)
        dq[:, j] = h
        fd = (tool_tips(m, p.q + dq, p) - tool_tips(m, p.q - dq, p)) / (2 * h)
        np.testing.assert_allclose(J[:, :, j], fd, atol=1e-7)


def test_exact_setpoints_put_the_longer_tool_on_target(machines):
    m = machines["vmc500"]
    p = Zone((m.travel), (0.05, 0.05)).sample(64, seed=5)
    q = exact_setpoints(m, p)
    assert np.abs(tool_tips(m, q, p) - tool_tips(m, p.q, p, nominal=True)).max() < 1e-11


def test_fit_recovers_a_table_the_machine_is_made_of():
    """A machine whose only error is a linear-table positioning error of X with the fit's own
    nodes: the naive tables are minus that table; the fit finds it too, up to the second-order
    term the naive tables miss (the error is met at the corrected position, a slope of 5e-5
    times a correction of 4 um: 0.2 nm), and leaves less residual."""
    m = vp.load_machine("vmc500")
    nodes = np.linspace(0.0, 0.5, 6)
    errors_um = [0.0, 3.0, -2.0, 1.0, 4.0, 0.5]
    m = m.with_spec(m.spec.without(*(c for c in m.components if c != "EXX")))
    m = replace_terms(m, {"EXX": {"kind": "table", "interpolation": "linear", "positions_mm": list(nodes * 1e3),
                                  "values_um": errors_um}})
    layout = SetpointTables((Table(0, (0,), (nodes,), np.zeros(6)),), 3)
    points = Zone.workspace(m).sample(512, seed=4)
    fitted = fit(m, layout, points)
    naive = layout.naive(m)
    np.testing.assert_allclose(naive.tables[0].values, -np.array(errors_um) * 1e-6, atol=1e-15)
    np.testing.assert_allclose(fitted.tables[0].values, -np.array(errors_um) * 1e-6, atol=3e-10)
    left, naive_left = np.abs(residuals(m, fitted, points)), np.abs(residuals(m, naive, points))
    assert left.max() < 3e-10 and np.sqrt(np.mean(left ** 2)) < np.sqrt(np.mean(naive_left ** 2))
