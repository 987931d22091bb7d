"""Error terms: interpolation properties, derivatives, and writing back in spec units."""

from __future__ import annotations

import numpy as np
import pytest

from volerr_pin.base import _safeio as safeio
from volerr_pin.model import _terms as T, build_term

TRAVEL = (0.0, 0.5)


def ctx(q):
    q = np.asarray(q, dtype=float)
    return T.Context(q, TRAVEL, T.Covariates(len(q)))


def term(table, quantity="length", position="length"):
    return build_term(table, "test", quantity, position, TRAVEL)


Q = np.linspace(0.0, 0.5, 37)


def test_legendre_basis_is_legendre():
    t = term({"kind": "legendre", "coefficients_um": [1.0, 2.0, 3.0]})
    u = 2 * Q / 0.5 - 1
    expected = 1.0 + 2.0 * u + 3.0 * (3 * u**2 - 1) / 2
    np.testing.assert_allclose(t.term.value(t.coefficients, ctx(Q)), expected * 1e-6, rtol=1e-14)


def test_monomial_over_position_in_mm():
    t = term({"kind": "monomial", "over": "position", "coefficients_um": [1.0, 0.02, -3e-5]})
    mm = Q * 1e3
    expected = (1.0 + 0.02 * mm - 3e-5 * mm**2) * 1e-6
    np.testing.assert_allclose(t.term.value(t.coefficients, ctx(Q)), expected, rtol=1e-13, atol=1e-20)


@pytest.mark.parametrize("table", [
    {"kind": "legendre", "coefficients_arcsec": [0.5, -1.0, 2.0, 0.7]},
    {"kind": "monomial", "coefficients_um": [0.0, 1.0, -2.0, 0.5]},
    {"kind": "monomial", "over": "position", "coefficients_um": [0.0, 0.01, -2e-5]},
    {"kind": "table", "interpolation": "cubic", "positions_mm": [0, 100, 250, 400, 500],
     "values_um": [0.0, 1.0, -0.5, 2.0, 1.0]},
    {"kind": "table", "interpolation": "cubic", "boundary": "natural",
     "positions_mm": [0, 100, 250, 400, 500], "values_um": [0.0, 1.0, -0.5, 2.0, 1.0]},
])
def test_position_derivative_equals_finite_differences(table):
    quantity = "angle" if "coefficients_arcsec" in table else "length"
    t = term(table, quantity)
    q = np.linspace(0.01, 0.49, 25)
    h = 1e-6
    fd = (t.term.basis(ctx(q + h)) - t.term.basis(ctx(q - h))) / (2 * h)
    np.testing.assert_allclose(t.term.basis_derivative(ctx(q)), fd, rtol=1e-6, atol=1e-8)


def test_tables_interpolate_their_nodes():
    for interpolation in ("linear", "cubic"):
        nodes = [0, 100, 200, 350, 500]
        values = [0.0, 1.2, -0.4, 2.2, 3.0]
        t = term({"kind": "table", "interpolation": interpolation, "positions_mm": nodes,
                  "values_um": values})
        got = t.term.value(t.coefficients, ctx(np.array(nodes) * 1e-3))
        np.testing.assert_allclose(got, np.array(values) * 1e-6, rtol=1e-12, atol=1e-20)


def test_not_a_knot_spline_reproduces_a_cubic():
    nodes = np.array([0.0, 0.07, 0.2, 0.31, 0.5])
    f = lambda x: 1e-6 * (1 + 3 * x - 20 * x**2 + 40 * x**3)
    t = term({"kind": "table", "interpolation": "cubic", "positions_m": list(nodes),
              "values_m": list(f(nodes))})
    np.testing.assert_allclose(t.term.value(t.coefficients, ctx(Q)), f(Q), rtol=1e-10, atol=1e-20)


def test_linear_table_is_piecewise_linear():
    t = term({"kind": "table", "interpolation": "linear", "positions_mm": [0, 200, 500],
              "values_um": [0.0, 2.0, -1.0]})
    np.testing.assert_allclose(t.term.value(t.coefficients, ctx([0.1, 0.35])), [1e-6, 0.5e-6], rtol=1e-12)


@pytest.mark.parametrize("table", [
    {"kind": "constant", "value_arcsec": 3.5},
    {"kind": "legendre", "coefficients_um": [1.0, 2.0]},
    {"kind": "monomial", "over": "position", "position_unit": "mm", "coefficients_um": [1.0, 0.5, 1e-4]},
    {"kind": "table", "interpolation": "cubic", "boundary": "not-a-knot",
     "positions_mm": [0.0, 100.0, 300.0, 500.0], "values_um": [0.0, 1.0, 3.0, 2.0]},
])
def test_to_spec_round_trips(table):
    quantity = "angle" if "value_arcsec" in table else "length"
    t = term(table, quantity)
    written = t.term.to_spec(t.coefficients)
    again = term(written, quantity)
    np.testing.assert_allclose(again.coefficients, t.coefficients, rtol=1e-14)
    assert set(written) == set(table) | ({"over"} if table["kind"] == "monomial" else set())


def test_polynomial_on_a_body_without_axis_is_refused():
    with pytest.raises(ValueError, match="needs an axis position"):
        build_term({"kind": "legendre", "coefficients_um": [1.0]}, "errors.EXT", "length", None, None)


@pytest.mark.parametrize("table, match", [
    ({"kind": "table", "positions_mm": ["0", 500], "values_um": [0, 1], "interpolation": "linear"},
     r"test\.positions_mm: expected a number, got a string '0'"),
    ({"kind": "table", "positions_mm": [0, 500], "values_um": [0, False], "interpolation": "linear"},
     r"test\.values_um: expected a number, got a boolean False"),
    ({"kind": "table", "positions_mm": [0, 250, 500], "values_um": [0, 1, 2]},
     r"test\.positions_mm: cubic interpolation needs at least 4 positions, got 3"),
    ({"kind": "table", "positions_mm": [0, 500, 250, 500], "values_um": [0, 1, 2, 3]},
     r"strictly increasing, got 500 then 250 mm \(entries 2 and 3\)"),
    ({"kind": "table", "positions_mm": [0, 500], "values_um": [0, 1], "interpolation": "linear",
      "extrapolate": 1}, r"test\.extrapolate: must be true or false"),
    ({"kind": "monomial", "over": ["position"], "coefficients_um": [1.0]}, r"test\.over: expected a string"),
    ({"kind": "legendre", "coefficients_um": [[1.0, 2.0]]}, r"test\.coefficients_um: expected a flat list"),
    ({"kind": "legendre", "coefficients_um": []}, r"test\.coefficients_um: needs at least one coefficient"),
    ({"kind": "constant", "value_um": 1.0, "value": 2.0}, r"test: both value_um and value given"),
    ({"kind": "legendre", "coefficients_um": [0.0] * 51},
     r"test\.coefficients_um: 51 coefficients; a polynomial takes at most 50 \(use a table"),
])
def test_bad_term_tables_name_the_key(table, match):
    with pytest.raises(ValueError, match=match):
        term(table)


def test_a_table_too_large_for_the_memory_is_refused_before_it_is_built(monkeypatch):
    """A spline table keeps every node's unit vector: a spec of a few hundred kB with 100,000
    positions would ask for 1 TB. The check names the key instead."""
    monkeypatch.setattr(safeio, "available_memory", lambda: 1e9)
    n = 10_000
    table = {"kind": "table", "positions_mm": np.linspace(0, 500, n).tolist(), "values_um": [0.0] * n}
    with pytest.raises(ValueError, match=r"test\.positions_mm: a table of 10,000 positions needs about 10 GB"):
        term(table)
    small = {**table, "positions_mm": np.linspace(0, 500, 500).tolist(), "values_um": [0.0] * 500}
    assert term(small).term.size == 500


@pytest.mark.parametrize("positions, swing", [
    ([0, 50, 100, 150, 150.01, 200, 250, 300], 1.72e3),          # a node 0.01 mm from another
    ([0, 50, 100, 150, 250, 250.000000000001, 300], 1e12),       # the near-duplicate (rounding decides)
])
def test_a_cubic_table_that_swings_between_its_nodes_is_refused(positions, swing):
    """The plausibility check of a table looked at its node values only: nodes 0.01 mm apart
    among 50 mm steps swung a 0-9 um EXX to -80 ... +90 um, and nodes 1e-12 mm apart made
    export write LinuxCNC trims of 45,755,321,214 mm. The spline's own reach beyond its values
    (its Lebesgue constant) is checked, and the closest nodes named."""
    table = {"kind": "table", "interpolation": "cubic", "positions_mm": positions,
             "values_um": list(np.linspace(0, 9, len(positions)))}
    with pytest.raises(T.SpecError, match=r"swings to [\d.e+]+ times their largest size .* more than 10: its nodes "
                                          r"(150 and 150\.01|250 and 250) mm"):
        build_term(table, "t", "length", "length", (0.0, positions[-1] * 1e-3))
    assert T.spline_swing(np.asarray(positions, float) * 1e-3, "not-a-knot")[0] >= 0.99 * swing
    # as values they are a function the spline really takes between the nodes: its extremes
    nodes = np.asarray(positions, float) * 1e-3
    x = np.linspace(nodes[0], nodes[-1], 200_001)
    from scipy.interpolate import CubicSpline
    assert np.abs(CubicSpline(nodes, np.linspace(0, 9, len(nodes))).__call__(x)).max() > 9 * 5
    # the same nodes interpolated linearly stay within their values: accepted
    build_term(dict(table, interpolation="linear"), "t", "length", "length", (0.0, positions[-1] * 1e-3))


@pytest.mark.parametrize("positions", [list(np.linspace(0, 500, 11)), [0, 10, 50, 60, 100, 110, 150],
                                       [0, 2, 50, 100, 150, 200, 250]])
def test_tables_of_usual_spacings_are_accepted(positions):
    """Even steps (a swing of 2), spacings of 1:4 (6) and a short first step (9) stay within
    the limit."""
    table = {"kind": "table", "interpolation": "cubic", "positions_mm": positions, "values_um": [0.0] * len(positions)}
    build_term(table, "t", "length", "length", (0.0, positions[-1] * 1e-3))
    assert T.spline_swing(np.asarray(positions, float), "not-a-knot")[0] <= T.MAX_SWING
