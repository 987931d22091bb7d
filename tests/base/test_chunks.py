"""Calls made in pieces give what one call gives."""

from __future__ import annotations

import numpy as np

from volerr_pin.base.chunks import in_chunks


def test_pieces_join_to_the_whole(machines):
    m = machines["cgm4000"]
    rng = np.random.default_rng(0)
    q = m.travel[:, 0] + rng.random((1_001, 5)) * (m.travel[:, 1] - m.travel[:, 0])
    whole = m.volumetric_error(q)
    np.testing.assert_array_equal(in_chunks(m.volumetric_error, q, chunk=100), whole)
    R, p = in_chunks(m.tool_poses, q, chunk=333, nominal=True)
    R1, p1 = m.tool_poses(q, nominal=True)
    np.testing.assert_array_equal(R, R1)
    np.testing.assert_array_equal(p, p1)
    seen = []

    def fn(rows, scale):   # covariates are sliced with the rows
        seen.append(len(rows))
        return rows[:, 0] * scale

    out = in_chunks(fn, q, {"scale": np.arange(len(q), dtype=float)}, chunk=400)
    np.testing.assert_array_equal(out, q[:, 0] * np.arange(len(q)))
    assert seen == [400, 400, 201]
