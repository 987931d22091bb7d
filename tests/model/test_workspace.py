"""Workspace sampling and the error summary."""

from __future__ import annotations

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.model import (error_summary, evaluate_field, field_grid, from_engineering, grid, nice_scale, sample,
                                  to_engineering)


def test_grid_covers_travel_corners(machines):
    m = machines["vmc500"]
    q = grid(m, (3, 2, 4))
    assert q.shape == (24, 3)
    np.testing.assert_allclose(q.min(axis=0), m.travel[:, 0])
    np.testing.assert_allclose(q.max(axis=0), m.travel[:, 1])


def test_sample_is_seeded_and_inside(machines):
    m = machines["cgm4000"]
    a, b = sample(m, 100, seed=3), sample(m, 100, seed=3)
    np.testing.assert_array_equal(a, b)
    assert np.all(a >= m.travel[:, 0]) and np.all(a <= m.travel[:, 1])
    assert not np.array_equal(a, sample(m, 100, seed=4))


def test_summary_matches_direct_computation(machines):
    m = machines["vmc700"]
    q = grid(m, 5)
    s = error_summary(m, q)
    norm = np.linalg.norm(m.volumetric_error(q)[:, :3], axis=1)
    assert s["max_position_um"] == np.max(norm) * 1e6
    np.testing.assert_allclose(s["rms_position_um"], np.sqrt(np.mean(norm**2)) * 1e6)
    np.testing.assert_allclose(s["worst_q"], to_engineering(m, q[np.argmax(norm)]))


def test_engineering_units_round_trip(machines):
    m = machines["cgm4000"]
    q = sample(m, 10)
    np.testing.assert_allclose(from_engineering(m, to_engineering(m, q)), q, rtol=1e-15)
    assert to_engineering(m, [[1.0, 0, 0, np.pi, 0]])[0, 3] == 180.0


# ------------------------------------------------------------------ bad or extreme inputs
@pytest.mark.parametrize("call, match, parameter", [
    (lambda m: grid(m, (3, 2.5, 4)), r"points_per_axis must be whole numbers >= 1, got \(3, 2.5, 4\)", "points_per_axis"),
    (lambda m: grid(m, 0), "points_per_axis must be a whole number >= 1, got 0", "points_per_axis"),
    (lambda m: grid(m, (3, 3)), "points_per_axis: give 1 or 3 counts", "points_per_axis"),
    (lambda m: grid(m, 100_000), r"a grid of 100000 x 100000 x 100000 = 1,000,000,000,000,000 points needs about",
     "points_per_axis"),
    (lambda m: sample(m, 0), "points must be >= 1, got 0", "points"),
    (lambda m: sample(m, 10**12), "a sample of 1,000,000,000,000 positions needs about", "points"),
    (lambda m: sample(m, 10, seed=-1), "seed must be >= 0, got -1", "seed"),
    (lambda m: field_grid(m, [1000]), r"a field grid of 1000 x 1000 x 1000 = 1,000,000,000 points needs about .* "
                                      r"of memory, more than this machine can spare", "counts"),
    (lambda m: field_grid(m, [0]), "counts must be whole numbers >= 1", "counts"),
    (lambda m: field_grid(m, [4.5]), "counts must be whole numbers >= 1", "counts"),
    (lambda m: error_summary(m, np.zeros((0, 3))), "q holds no points", "q"),
])
def test_bad_counts_and_sizes_are_refused_naming_them(machines, monkeypatch, call, match, parameter):
    """volerr field --grid 1000 gave a MemoryError traceback: sizes are checked against the free
    memory (here 1 GB) before anything is allocated, naming the parameter that sets them."""
    import volerr_pin.base._safeio as safeio

    monkeypatch.setattr(safeio, "available_memory", lambda: 1_000_000_000)
    with pytest.raises(vp.InputError, match=match) as err:
        call(machines["vmc500"])
    assert err.value.parameters == (parameter,)


def test_a_machine_without_linear_axes_sizes_its_field_by_points(machines, monkeypatch):
    import volerr_pin.base._safeio as safeio

    monkeypatch.setattr(safeio, "available_memory", lambda: 1_000_000_000)
    m = machines["ur5"]
    assert field_grid(m, points=10).shape == (10, len(m.axes))
    with pytest.raises(vp.InputError, match="a field of 1,000,000,000 configurations needs") as err:
        field_grid(m, points=10**9)
    assert err.value.parameters == ("points",)


def test_nice_scale_of_non_finite_sizes_is_one():
    assert nice_scale(float("nan"), 1.0) == nice_scale(1.0, float("inf")) == nice_scale(float("inf"), 1.0) == 1.0
    assert nice_scale(10.0, 1.0) == 5000.0


def test_an_empty_field_is_an_empty_result(machines):
    """Zero points is a valid request for a field (zero arrows), unlike a summary of them."""
    field = evaluate_field(machines["vmc500"], np.zeros((0, 3)))
    assert field.error.shape == (0, 6) and field.positions.shape == (0, 3) and field.scale == 1.0
