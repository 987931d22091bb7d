"""Pieces the axis-table formats share: which machines they can serve, and tables of the usual
shapes (an axis' own table, one axis as a function of another, of a plane) with their nodes
on the grid a file can state.
"""

from __future__ import annotations

import math

import numpy as np

from ...base import InputError, SpecError
from ...model import Machine, volumetric_error
from .._points import MachineInputs
from ._tables import Table, fixed
from ._zone import Zone, node_positions

__all__ = ["best_masters", "check_count", "cross_table", "explained_scores", "fixed", "linear_xyz", "nc_axes",
           "own_table", "plane_table"]

#: NC axis letters a controller addresses axes by
NC_LETTERS = ("X", "Y", "Z", "A", "B", "C", "U", "V", "W")


def nc_axes(machine: Machine, title: str) -> None:
    """Refuse a machine whose axes are not NC axes (``X``, ``Y``, ``Z``, ``A`` ... ``W``).

    Parameters
    ----------
    machine : Machine
        The machine.
    title : str
        The controller, for the message.

    Raises
    ------
    SpecError
        Naming the first axis that is not an NC axis letter.
    """
    for axis in machine.axes:
        if axis not in NC_LETTERS:
            raise SpecError(f"{machine.name}: axis {axis} is not an NC axis ({', '.join(NC_LETTERS)}); "
                            f"{title} addresses machine axes by these letters")


def linear_xyz(machine: Machine) -> list[int]:
    """Indices of the linear axes named X, Y, Z (the ones cross and plane tables couple).

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    list of int
        In machine axis order.
    """
    return [j for j, (a, k) in enumerate(zip(machine.axes, machine.axis_kinds)) if k == "linear" and a in "XYZ"]


def check_count(count: int, low: int, high: int, what: str) -> int:
    """``count`` if ``low <= count <= high``.

    Parameters
    ----------
    count : int
        Nodes asked for.
    low, high : int
        The format's limits.
    what : str
        What holds them, for the message.

    Returns
    -------
    int
        ``count``.

    Raises
    ------
    InputError
        Naming ``nodes``.
    """
    if not low <= count <= high:
        raise InputError(f"nodes: {what} holds {low} to {high} nodes, got {count}", parameters=("nodes",))
    return int(count)


def _grid(machine: Machine, zone: Zone, j: int, count: int, unit: float) -> np.ndarray:
    """``count`` nodes over the zone's range of axis ``j``, equally spaced by a whole number of
    ``unit`` (mm-type SI length), starting at a whole number of ``unit``."""
    lo, hi = zone.ranges[j]
    grid = node_positions(lo, hi, 2, machine.axis_kinds[j])
    start = round(grid[0] / unit) * unit
    spacing = max(math.ceil((grid[-1] - start) / (count - 1) / unit - 1e-9), 1) * unit
    return start + spacing * np.arange(count)


def own_table(machine: Machine, zone: Zone, j: int, count: int, unit: tuple[float, float], *,
              directional: bool = False, only: int = 0, step: bool = False) -> Table:
    """Axis ``j`` corrected as a function of its own commanded position.

    Parameters
    ----------
    machine : Machine
        The machine.
    zone : Zone
        Where the nodes lie.
    j : int
        The axis.
    count : int
        Nodes.
    unit : tuple of float
        The smallest position step the file states for a linear and for a rotary axis [m, rad].
    directional : bool, default False
        Values per direction of motion (tied to one set when the machine has no error that
        depends on the direction).
    only : int, default 0
        +1 / -1: applies only while moving that way.
    step : bool, default False
        Piecewise constant.

    Returns
    -------
    Table
        Zero-valued.
    """
    grid = _grid(machine, zone, j, count, unit[machine.axis_kinds[j] == "rotary"])
    shape = ((2,) if directional else ()) + (count,)
    suffix = {1: " +", -1: " -"}.get(only, "")
    tied = directional and "directions" not in machine.covariates_used
    return Table(j, (j,), (grid,), np.zeros(shape), directional=directional, only=only, step=step, tied=tied,
                 label=f"{machine.axes[j]}({machine.axes[j]}){suffix}")


def cross_table(machine: Machine, zone: Zone, slave: int, master: int, count: int, unit: tuple[float, float]) -> Table:
    """Axis ``slave`` corrected as a function of axis ``master`` (both directions alike).

    Parameters
    ----------
    machine : Machine
        The machine.
    zone : Zone
        Where the nodes lie.
    slave, master : int
        The axes.
    count : int
        Nodes.
    unit : tuple of float
        Position step of the file for linear and rotary axes [m, rad].

    Returns
    -------
    Table
        Zero-valued.
    """
    grid = _grid(machine, zone, master, count, unit[machine.axis_kinds[master] == "rotary"])
    return Table(slave, (master,), (grid,), np.zeros(count), label=f"{machine.axes[slave]}({machine.axes[master]})")


def plane_table(machine: Machine, zone: Zone, slave: int, masters: tuple[int, int], count: int, unit: float) -> Table:
    """Axis ``slave`` corrected as a function of two linear axes on a square grid (one node
    spacing for both, as ISG's quadratic grid has it): the spacing is set by the longer range
    and ``count``; the shorter range gets as many nodes as it needs.

    Parameters
    ----------
    machine : Machine
        The machine.
    zone : Zone
        Where the nodes lie.
    slave : int
        The corrected axis.
    masters : tuple of int
        The two axes read.
    count : int
        Nodes along the longer range.
    unit : float
        Position step of the file [m].

    Returns
    -------
    Table
        Zero-valued.
    """
    spans = [node_positions(*zone.ranges[m], 2, "linear") for m in masters]
    spacing = max(math.ceil(max(s[-1] - s[0] for s in spans) / (count - 1) / unit - 1e-9), 1) * unit
    grids = []
    for s in spans:
        start = round(s[0] / unit) * unit
        n = max(int(math.ceil((s[-1] - start) / spacing - 1e-9)) + 1, 2)
        grids.append(start + spacing * np.arange(n))
    names = machine.axes
    return Table(slave, tuple(masters), tuple(grids), np.zeros(tuple(len(g) for g in grids)),
                 label=f"{names[slave]}({names[masters[0]]},{names[masters[1]]})")


def explained_scores(machine: Machine, zone: Zone, slaves: list[int], candidates: list[int], bins: int = 20,
                     seed: int = 0) -> dict[tuple[int, int], float]:
    """How much of the error along each slave axis the position of each candidate axis
    explains: the spread of the error's means over bins of the candidate's range (sum of
    count x squared deviation from the mean, m^2), at Sobol' points of the zone.

    Parameters
    ----------
    machine : Machine
        The machine.
    zone : Zone
        The zone.
    slaves, candidates : list of int
        Axis indices; slaves are linear axes named X, Y or Z.
    bins : int, default 20
        Bins over each candidate's range.
    seed : int, default 0
        Seed of the points.

    Returns
    -------
    dict of (int, int) to float
        (slave, candidate) -> score, for every pair of different axes.
    """
    points = zone.sample(2048, seed)
    inputs = MachineInputs(machine)
    error = volumetric_error(inputs.model, points.q, inputs.theta,
                             inputs.covariates(len(points), points.directions))[:, :3]
    out = {}
    for s in slaves:
        e = error[:, "XYZ".index(machine.axes[s])]
        for m in candidates:
            if m == s:
                continue
            x = points.q[:, m]
            edges = np.linspace(x.min(), x.max() + 1e-12, bins + 1)
            which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
            counts = np.bincount(which, minlength=bins)
            means = np.bincount(which, weights=e, minlength=bins) / np.maximum(counts, 1)
            out[(s, m)] = float(np.sum(counts * (means - e.mean()) ** 2))
    return out


def best_masters(machine: Machine, zone: Zone, slaves: list[int], candidates: list[int]) -> dict[int, int]:
    """For each slave axis, the one candidate axis whose position explains most of the error
    along it (:func:`explained_scores`): where a controller allows one master per slave, this one.

    Parameters
    ----------
    machine : Machine
        The machine.
    zone : Zone
        The zone.
    slaves, candidates : list of int
        Axis indices (a slave is never its own master).

    Returns
    -------
    dict of int to int
        Slave -> master.
    """
    scores = explained_scores(machine, zone, slaves, candidates)
    out = {}
    for s in slaves:
        ranked = sorted((score, m) for (slave, m), score in scores.items() if slave == s)
        if ranked:
            out[s] = ranked[-1][1]
    return out
