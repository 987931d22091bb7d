"""Candidate poses over a working zone, shared by the instruments that measure at poses.

Three layouts of the same count: scrambled Sobol' points (:class:`scipy.stats.qmc.Sobol`, the
low-discrepancy pool a plan chooses from), a regular grid (the campaign a calibration engineer
lays out by hand: equal steps along every axis that moves, counts in proportion to the
axes' ranges, its first ``count`` nodes in a serpentine order when the full grid has more),
and uniform random draws. A rotary axis that covers a full turn has its grid levels spaced
over the turn without repeating its two ends (one pose).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import qmc

from ...base import InputError

if TYPE_CHECKING:
    from ._protocol import Setup

__all__ = ["OneFileOfPoses", "grid_counts", "pose_candidates"]


def grid_counts(extent: np.ndarray, count: int) -> np.ndarray:
    """Nodes per axis of the smallest grid with at least ``count`` nodes, in proportion to
    the axes' extents (an axis of zero extent has one node).

    Parameters
    ----------
    extent : ndarray, shape (n_axes,)
        Range of each axis, in units that make them comparable (scaled to the largest: 1).
    count : int
        Nodes wanted (>= 1).

    Returns
    -------
    ndarray of int, shape (n_axes,)
        Nodes per axis; their product is at least ``count``.
    """
    moving = extent > 0
    counts = np.ones(len(extent), dtype=int)
    if not moving.any() or count <= 1:
        return counts
    share = extent[moving] / extent[moving].max()
    k = 1.0
    while True:   # grow the scale until the grid is large enough
        trial = np.maximum(1, np.round(share * k)).astype(int)
        if math.prod(trial.tolist()) >= count:
            counts[moving] = trial
            return counts
        k *= 1.05


def pose_candidates(zone: np.ndarray, kinds, count: int, layout: str, seed: int) -> np.ndarray:
    """``count`` poses in the zone, in one of the layouts of the module docstring.

    Parameters
    ----------
    zone : ndarray, shape (n_axes, 2)
        Lower and upper NC position of each axis [m, rad].
    kinds : sequence of str
        "linear" or "rotary" per axis (rotary ranges are compared with linear ones at 1 rad = 0.1 m).
    count : int
        Number of poses (>= 1).
    layout : str
        "sobol", "grid" or "random".
    seed : int
        Seed of the scrambling or the draws (the grid takes none).

    Returns
    -------
    ndarray, shape (count, n_axes)
        NC positions [m, rad].

    Raises
    ------
    InputError
        If the layout is unknown.
    """
    lo, hi = zone[:, 0], zone[:, 1]
    d = len(lo)
    if layout == "sobol":
        m = max(0, math.ceil(math.log2(max(count, 1))))
        u = qmc.Sobol(d, scramble=True, seed=seed).random_base2(m)[:count]
    elif layout == "random":
        u = np.random.default_rng(seed).random((count, d))
    elif layout == "grid":
        weight = np.array([0.1 if k == "rotary" else 1.0 for k in kinds])
        counts = grid_counts((hi - lo) * weight, count)
        turn = np.array([k == "rotary" for k in kinds]) & (hi - lo >= 2 * np.pi - 1e-9)
        # a full turn's two ends are one pose: its levels leave the upper end out
        levels = [np.linspace(0.0, 1.0, c, endpoint=not t) if c > 1 else np.array([0.5])
                  for c, t in zip(counts, turn)]
        nodes = _serpentine(levels)
        if len(nodes) > count:   # nodes spread over the whole grid, not its first rows
            nodes = nodes[np.round(np.linspace(0, len(nodes) - 1, count)).astype(int)]
        u = nodes
    else:
        raise InputError(f"layout must be one of sobol, grid, random; got {layout!r}", parameters=("layout",))
    return lo + u * (hi - lo)


def _serpentine(levels: list[np.ndarray]) -> np.ndarray:
    """Grid nodes ordered so that consecutive nodes differ in one axis (boustrophedon): the
    first axis changes fastest, reversing at every step of the next."""
    nodes = levels[0][:, None]
    for lv in levels[1:]:
        rows = []
        for i, v in enumerate(lv):
            block = nodes if i % 2 == 0 else nodes[::-1]
            rows.append(np.column_stack([block, np.full(len(block), v)]))
        nodes = np.vstack(rows)
    return nodes


class OneFileOfPoses:
    """The files and visits of an instrument that measures at poses and writes one file, its
    :meth:`table` (the probe, the tracker)."""

    def outputs(self, out, count: int) -> list:
        """One file: the plan's own.

        Parameters
        ----------
        out : str or Path
            The plan's file.
        count : int
            Number of poses (unused).

        Returns
        -------
        list of Path
            ``[out]``.
        """
        return [Path(out)]

    def files(self, machine, setup: Setup, units: list) -> list:
        """The one file of :meth:`table`.

        Parameters
        ----------
        machine : Machine
            The machine.
        setup : Setup
            Targets.
        units : list of ndarray
            Poses [m, rad].

        Returns
        -------
        list of str
            One text.
        """
        return [self.table(machine, setup, units)]

    def visits(self, machine, units: list) -> np.ndarray:
        """The poses themselves.

        Parameters
        ----------
        machine : Machine
            The machine.
        units : list of ndarray
            Poses [m, rad].

        Returns
        -------
        ndarray, shape (n, n_axes)
            NC positions [m, rad].
        """
        return np.asarray(units, dtype=float).reshape(len(units), len(machine.axes))
