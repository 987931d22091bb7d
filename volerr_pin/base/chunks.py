"""Calls over many points made in pieces, so that work arrays that grow with the call stay
bounded."""

from __future__ import annotations

import numpy as np

__all__ = ["CHUNK", "in_chunks"]

#: the most points given to the model in one call: its work arrays grow with the call (a
#: five-axis machine's take about 1.5 kB a point)
CHUNK = 100_000


def in_chunks(fn, q: np.ndarray, covariates: dict | None = None, chunk: int = CHUNK, **options):
    """``fn(q, **options, **covariates)`` over ``q`` (N, n_axes) in pieces of ``chunk`` rows
    (per-point ``covariates`` sliced alike), joined: an array, or a tuple of arrays."""
    covariates = covariates or {}
    if len(q) <= chunk:
        return fn(q, **options, **covariates)
    pieces = [fn(q[a:a + chunk], **options, **{k: v[a:a + chunk] for k, v in covariates.items()})
              for a in range(0, len(q), chunk)]
    if isinstance(pieces[0], tuple):
        return tuple(np.concatenate(p) for p in zip(*pieces))
    return np.concatenate(pieces)
