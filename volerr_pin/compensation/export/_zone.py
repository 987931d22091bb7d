"""The working zone a compensation is chosen for, and the points it is fitted and judged on.

A zone is a range of every axis (NC positions, within the travel) and a range of tool
lengths. The tool length is an *extension* of the machine's tool point (its spec's tool frame)
along the tool axis: the tool point of a tool ``L`` longer is ``p - L z``, with ``z`` the tool
frame's z axis (pointing from the tool tip into the spindle). A longer tool turns the angular
errors into larger position errors (Abbe), which tables read at the commanded axis positions
cannot know about: the fit spreads the tables over the tool lengths asked for.

Points are visited in order along a path, and the controller's notion of direction follows
the path: an axis' direction is the sign of its last commanded motion, kept while it stands
still (:func:`motion_directions`). Tables are fitted and judged on points where every position
is reached from both directions (:meth:`Zone.sample`): a Sobol' sequence visited in its own
order arrives at each axis' position from the direction of the half of the travel it lies in
(Y 100 %, Z 93 %, X 75 % on vmc500), so half of each direction table was never fitted nor
judged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from ...base import AXIS_UNIT, MM, InputError, axis_scale, integer, parse_number, require_memory, sensible
from ...model import Machine

__all__ = ["Points", "Zone", "motion_directions", "node_positions", "parse_zone"]

#: the key of the tool length in a zone's items (``tool=0:80``, mm)
TOOL_KEY = "tool"


@dataclass(frozen=True)
class Zone:
    """Where the machine works: a range of each axis and of the tool length (SI).

    Attributes
    ----------
    ranges : ndarray, shape (n_axes, 2)
        Lower and upper NC position of each axis [m, rad], inside its travel; equal ends hold
        the axis at one position.
    tool : tuple of float
        Lower and upper tool extension beyond the machine's tool point [m] (0, 0 by default).
    """

    ranges: np.ndarray
    tool: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def workspace(cls, machine: Machine) -> "Zone":
        """The whole travel of every axis (one turn, -pi to pi, for an endless axis), the
        machine's own tool.

        Parameters
        ----------
        machine : Machine
            The machine.

        Returns
        -------
        Zone
            The zone.
        """
        travel = machine.travel
        travel = np.where(np.isfinite(travel), travel, np.array([-np.pi, np.pi]))
        return cls(travel)

    def sample(self, n: int, seed: int = 0) -> "Points":
        """``n`` points over the zone where every position is reached from both directions: the
        positions of a scrambled Sobol' sequence, each visited twice, approached with opposite
        motion of every axis (the directions of the first visit drawn from the sequence's other
        coordinates, so they are balanced and independent of the position; a path reaches them
        through an approach point a little beyond the position).

        Parameters
        ----------
        n : int
            Number of points (at least 2).
        seed : int, default 0
            Seed of the scrambling and of the tool lengths.

        Returns
        -------
        Points
            The points, their motion directions along the visiting order and tool extensions.

        Raises
        ------
        InputError
            If ``n`` is not a whole number of at least 2 or its points would not fit in the free
            memory, or ``seed`` is negative.
        """
        n = integer("points", n, 2)
        seed = integer("seed", seed, 0)
        lo, hi = self.ranges[:, 0], self.ranges[:, 1]
        axes = len(lo)
        half = (n + 1) // 2
        # the Sobol' draw (to the next power of two), then the points visited twice each
        require_memory(8 * (2 * half * (2 * axes + 1) + n * (3 * axes + 2)), f"a sample of {n:,} positions over the zone",
                       ("points",))
        unit = qmc.Sobol(d=2 * axes + 1, scramble=True, seed=seed).random_base2(int(np.ceil(np.log2(half))))[:half]
        q = lo + unit[:, :axes] * (hi - lo)
        tool = self.tool[0] + unit[:, axes] * (self.tool[1] - self.tool[0])
        return _both_ways(q, tool, np.where(unit[:, axes + 1:] < 0.5, -1.0, 1.0), n)

    def shuffled(self, points: "Points", seed: int = 0) -> "Points":
        """The positions of ``points`` visited once each, in a seeded random order, each axis'
        direction the sign of its motion along that path: what a program that visits them in
        no particular order leaves a direction table to.

        Parameters
        ----------
        points : Points
            The points.
        seed : int, default 0
            Seed of the order.

        Returns
        -------
        Points
            The distinct positions in random order.
        """
        _, first = np.unique(points.q, axis=0, return_index=True)
        order = np.random.default_rng(seed).permutation(np.sort(first))
        q = points.q[order]
        return Points(q, motion_directions(q), points.tool[order])

    def corners_and_nodes(self, nodes: list[np.ndarray], n: int, seed: int = 0) -> "Points":
        """``n`` points whose every axis sits on one of its table nodes (random combinations,
        seeded), each reached from both directions (:meth:`sample`): where a table holds exactly
        the values it was given.

        Parameters
        ----------
        nodes : list of ndarray
            The node positions of each axis [m, rad].
        n : int
            Number of points.
        seed : int, default 0
            Seed of the combinations and tool lengths.

        Returns
        -------
        Points
            The points.
        """
        rng = np.random.default_rng(seed)
        half = (n + 1) // 2
        q = np.column_stack([rng.choice(np.asarray(k, dtype=float), size=half) for k in nodes])
        tool = self.tool[0] + rng.random(half) * (self.tool[1] - self.tool[0])
        return _both_ways(q, tool, np.where(rng.random(q.shape) < 0.5, -1.0, 1.0), n)


@dataclass(frozen=True)
class Points:
    """Commanded positions visited in order, with the direction each axis last moved in (the
    direction it arrived from; a path reaches a position from either side through an approach
    point beyond it) and the tool in the spindle (SI).

    Attributes
    ----------
    q : ndarray, shape (N, n_axes)
        Commanded NC positions [m, rad].
    directions : ndarray, shape (N, n_axes)
        +1 or -1: the sign of each axis' last commanded motion (:func:`motion_directions`).
    tool : ndarray, shape (N,)
        Tool extension beyond the machine's tool point [m].
    """

    q: np.ndarray
    directions: np.ndarray
    tool: np.ndarray

    def __len__(self) -> int:
        return int(self.q.shape[0])


def _both_ways(q: np.ndarray, tool: np.ndarray, signs: np.ndarray, n: int) -> "Points":
    """The first ``n`` of the positions ``q`` each visited twice, with directions ``signs`` and
    then their opposites."""
    directions = np.empty((2 * len(q), q.shape[1]))
    directions[0::2], directions[1::2] = signs, -signs
    return Points(np.repeat(q, 2, axis=0)[:n], directions[:n], np.repeat(tool, 2)[:n])


def motion_directions(q: np.ndarray, start: np.ndarray | None = None) -> np.ndarray:
    """The direction of each axis at each point of a path, as a controller takes it: the sign
    of the commanded motion into the point, kept from the point before when the axis stands
    still.

    Parameters
    ----------
    q : ndarray, shape (N, n_axes)
        Commanded positions in the order visited [m, rad].
    start : ndarray, shape (n_axes,), optional
        Directions before the first point (default +1: every axis arrived moving up).

    Returns
    -------
    ndarray, shape (N, n_axes)
        +1.0 or -1.0.
    """
    q = np.asarray(q, dtype=float)
    out = np.empty_like(q)
    current = np.ones(q.shape[1]) if start is None else np.sign(np.asarray(start, dtype=float))
    previous = q[0]
    for i, row in enumerate(q):
        step = np.sign(row - previous) if i else np.zeros_like(row)
        current = np.where(step != 0, step, current)
        out[i] = current
        previous = row
    return out


def node_positions(lo: float, hi: float, count: int, kind: str) -> np.ndarray:
    """``count`` equally spaced table nodes over [lo, hi]; an axis held at one position gets
    nodes half an engineering unit (0.5 mm or 0.5 deg) either side of it.

    Parameters
    ----------
    lo, hi : float
        The zone's range of the axis [m, rad].
    count : int
        Number of nodes (at least 2).
    kind : str
        "linear" or "rotary".

    Returns
    -------
    ndarray, shape (count,)
        Strictly increasing node positions [m, rad].
    """
    if hi <= lo:
        half = 0.5 * axis_scale(kind)
        lo, hi = lo - half, lo + half
    return np.linspace(lo, hi, count)


def parse_zone(machine: Machine, items: list[str] | None) -> Zone:
    """A zone from ``AXIS=LO:HI`` items in mm / deg (``AXIS=V`` holds the axis at V) and
    ``tool=LO:HI`` or ``tool=L`` (mm, the extension beyond the machine's tool point); axes not
    named keep their whole travel.

    Parameters
    ----------
    machine : Machine
        The machine.
    items : list of str or None
        The items, e.g. ``["X=0:300", "Y=0:200", "tool=0:80"]``; None or empty: the workspace.

    Returns
    -------
    Zone
        The zone (SI).

    Raises
    ------
    InputError
        Naming ``zone``, for an item that is not KEY=LO:HI or KEY=V, an unknown axis, an axis
        given twice, a range with LO > HI, or a range outside the axis' travel.
    """
    zone = Zone.workspace(machine)
    ranges = zone.ranges.copy()
    tool = zone.tool
    seen = set()
    for item in items or []:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise InputError(f"zone: '{item}' is not AXIS=LO:HI, AXIS=V or {TOOL_KEY}=LO:HI", parameters=("zone",))
        if key in seen:
            raise InputError(f"zone: {key} is given twice", parameters=("zone",))
        seen.add(key)
        lo_text, colon, hi_text = text.partition(":")
        try:
            lo = parse_number(lo_text)
            hi = parse_number(hi_text) if colon else lo
        except ValueError as err:
            raise InputError(f"zone: '{item}': {err}", parameters=("zone",)) from None
        if lo > hi:
            raise InputError(f"zone: '{item}': the range runs backwards ({lo:g} > {hi:g})", parameters=("zone",))
        if key == TOOL_KEY:
            tool = tuple(sensible("zone", np.array([lo, hi]) * MM, "position_length", "mm", MM))
            continue
        if key not in machine.axes:
            raise InputError(f"zone: '{item}' names no axis of {machine.name} (axes: {', '.join(machine.axes)}; "
                             f"'{TOOL_KEY}' for the tool length)", parameters=("zone",))
        j = machine.axes.index(key)
        scale = axis_scale(machine.axis_kinds[j])
        unit = AXIS_UNIT[machine.axis_kinds[j]]
        travel = machine.travel[j]
        span = max(float(np.nan_to_num(travel[1] - travel[0], posinf=1.0)), 1.0)
        if lo * scale < travel[0] - 1e-9 * span or hi * scale > travel[1] + 1e-9 * span:
            raise InputError(f"zone: '{item}' leaves the travel of {key} [{travel[0] / scale:g}, "
                             f"{travel[1] / scale:g}] {unit}", parameters=("zone",))
        ranges[j] = (max(lo * scale, travel[0]), min(hi * scale, travel[1]))
    return Zone(ranges, tool)
