"""Workspace sampling and the error summary."""

from __future__ import annotations

import numpy as np

from volerr_pin.workspace import error_summary, from_engineering, grid, sample, to_engineering


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
