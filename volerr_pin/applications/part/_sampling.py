"""Sampling the cut of a program's path: the deviation along the path, sampled until it meets a
stated tolerance (:func:`deviation_along`), and the cut surface sampled evenly along every
cutting move, where the tool actually is (:func:`cut_of`), which features are measured on.

The deviation is what the cut surface keeps of the tool point's error ``e``: its part normal
to the path, ``d = e - (e . t) t`` (:func:`~volerr_pin.applications.part.normal_part`), the part along the path
only shifting where the tool passes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...base import UM_PER_M, InputError
from ...model import Machine
from ._path import CuttingPath

__all__ = ["SHORTEST", "Cut", "PathDeviation", "cut_of", "deviation_along"]


@dataclass(frozen=True)
class PathDeviation:
    """The tool's deviation from the programmed path, at the samples of the cutting moves.

    Attributes
    ----------
    line : ndarray, shape (M,)
        Line of the block each sample belongs to.
    move : ndarray, shape (M,)
        Index of the move (in the program's cutting moves) each sample belongs to.
    fraction : ndarray, shape (M,)
        Where on its move the sample is, 0 (start) to 1 (end).
    q : ndarray, shape (M, n_axes)
        Axis positions [m, rad].
    point : ndarray, shape (M, 3)
        Nominal tool point in the workpiece frame [m].
    tangent : ndarray, shape (M, 3)
        Unit tangent of the nominal tool path (zero where the tool point does not move).
    error : ndarray, shape (M, 3)
        Tool point error, actual minus nominal [m].
    normal : ndarray, shape (M, 3)
        Its part normal to the path [m]: what the cut surface keeps.
    tolerance : float
        The sampling tolerance [m] the samples meet.
    """

    line: np.ndarray
    move: np.ndarray
    fraction: np.ndarray
    q: np.ndarray
    point: np.ndarray
    tangent: np.ndarray
    error: np.ndarray
    normal: np.ndarray
    tolerance: float

    def per_block(self) -> dict[int, float]:
        """Largest normal deviation per block line [um].

        Returns
        -------
        dict of int to float
            Block line -> the largest normal deviation of its samples [um], in the order the
            blocks are first sampled.
        """
        size = np.linalg.norm(self.normal, axis=1) * UM_PER_M
        out: dict[int, float] = {}
        for line, value in zip(self.line.tolist(), size.tolist()):
            out[line] = max(out.get(line, 0.0), value)
        return out

    def runs(self) -> list[np.ndarray]:
        """Each move's rows, in order (the samples run move by move).

        Returns
        -------
        list of ndarray of int
            The indices of the samples of each sampled move, one array per move.
        """
        return np.split(np.arange(len(self.move)), np.flatnonzero(np.diff(self.move)) + 1)

    @property
    def max_um(self) -> float:
        """The largest normal deviation over the path [um]."""
        return float(np.linalg.norm(self.normal, axis=1).max() * UM_PER_M) if len(self.normal) else 0.0


#: the shortest interval between samples, as a fraction of a move: where the deviation steps (an
#: axis with backlash reversing inside an arc) no number of samples meets the tolerance, and the
#: step is left between two samples this close
SHORTEST = 2.0 ** -30


def deviation_along(machine: Machine, moves, tolerance: float = 0.01e-6, *,
                    max_points: int = 2_000_000) -> PathDeviation:
    """The deviation of the tool from the programmed path along the cutting moves.

    Every move starts with 3 samples. The midpoint of every interval still open is evaluated
    (all the moves' in one batch); where the normal deviation interpolated linearly between the
    interval's ends is further than ``tolerance`` from the model's, the midpoint joins the
    samples and the two halves stay open, else the interval is closed; until none is open. An
    interval shorter than :data:`SHORTEST` of its move is closed as it is: a step of the
    deviation (an axis with backlash reversing inside an arc) stays between its two samples.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict (:meth:`Machine.with_state`: the part cold or
        warm, under load).
    moves : MoveBatch or CuttingPath
        The program's moves (:func:`volerr_pin.compensation.gcode.interpret`), in axes or
        tool-tip programming; rapids are left out, as they cut nothing.
    tolerance : float, default 0.01e-6
        Sampling tolerance [m].
    max_points : int, default 2,000,000
        The most samples in all; more is refused, naming ``tolerance``.

    Returns
    -------
    PathDeviation

    Raises
    ------
    InputError
        If ``tolerance`` is not a positive number, the program has no cutting move, a move
        leaves the travel (naming its line), or the samples would exceed ``max_points``.
    """
    if not (isinstance(tolerance, (int, float)) and np.isfinite(tolerance) and tolerance > 0):
        raise InputError(f"tolerance must be a positive number of metres, got {tolerance!r}", parameters=("tolerance",))
    moves = CuttingPath.of(machine, moves)
    n = len(moves)
    names = ("q", "point", "tangent", "error", "normal")
    first = np.repeat(np.arange(n), 3)
    k0 = np.tile([0.0, 0.5, 1.0], n)
    values = moves.evaluate(first, k0)
    fraction = [k0[3 * m:3 * m + 3] for m in range(n)]
    kept = [{name: v[3 * m:3 * m + 3] for name, v in zip(names, values)} for m in range(n)]
    open_: dict[int, np.ndarray] = {}   # per move still refined, which of its intervals are open
    total = 3 * n

    def refine(m: int, w: np.ndarray, mid_k: np.ndarray, mid: tuple) -> None:
        """Move ``m``'s open intervals ``w`` against their midpoints ``mid`` (at ``mid_k``)."""
        nonlocal total
        normal = kept[m]["normal"]
        split = np.abs(mid[4] - (normal[w] + normal[w + 1]) / 2.0).max(axis=1) > tolerance
        if not split.any():
            open_.pop(m, None)
            return
        at = w[split]
        total += len(at)
        if total > max_points:
            raise InputError(f"line {moves.line[m]}: sampling the path to {tolerance * UM_PER_M:g} um takes more "
                             f"than {max_points:,} points; give a larger tolerance", parameters=("tolerance",))
        fraction[m] = np.insert(fraction[m], at + 1, mid_k[split])
        kept[m] = {name: np.insert(kept[m][name], at + 1, v[split], axis=0) for name, v in zip(names, mid)}
        # the halves of a split interval stay open, unless they are as short as sampling goes
        halves = np.zeros(len(normal) - 1, dtype=bool)
        halves[at] = True
        still = np.repeat(halves, 1 + halves) & (np.diff(fraction[m]) > SHORTEST)
        if still.any():
            open_[m] = still
        else:
            open_.pop(m, None)

    # the first round for every move at once: most moves meet the tolerance with their 3 samples
    mid_k = np.tile([0.25, 0.75], n)
    mid = moves.evaluate(np.repeat(np.arange(n), 2), mid_k)
    normal = values[4].reshape(n, 3, 3)
    off = np.abs(mid[4].reshape(n, 2, 3) - (normal[:, :-1] + normal[:, 1:]) / 2.0).max(axis=2)
    for m in np.flatnonzero((off > tolerance).any(axis=1)).tolist():
        rows = slice(2 * m, 2 * m + 2)
        refine(m, np.arange(2), mid_k[rows], tuple(v[rows] for v in mid))
    while open_:
        pending = list(open_)
        where = [np.flatnonzero(open_[m]) for m in pending]
        which = np.repeat(pending, [len(w) for w in where])
        mid_k = np.concatenate([(fraction[m][w] + fraction[m][w + 1]) / 2.0 for m, w in zip(pending, where)])
        mid = moves.evaluate(which, mid_k)
        bounds = np.concatenate([[0], np.cumsum([len(w) for w in where])])
        for m, w, a, b in zip(pending, where, bounds[:-1], bounds[1:]):
            refine(m, w, mid_k[a:b], tuple(v[a:b] for v in mid))
    joined = {name: np.concatenate([kept[m][name] for m in range(n)]) for name in names}
    counts = [len(f) for f in fraction]
    return PathDeviation(line=np.repeat(moves.line, counts), move=np.repeat(np.arange(n), counts),
                         fraction=np.concatenate(fraction), tolerance=float(tolerance), **joined)


@dataclass(frozen=True)
class Cut:
    """The surface a program cuts: samples of every cutting move, where the tool actually is.

    Attributes
    ----------
    move : ndarray, shape (M,)
        Index of the sample's move among the program's cutting moves.
    q : ndarray, shape (M, n_axes)
        Axis positions [m, rad].
    nominal, actual : ndarray, shape (M, 3)
        The tool point in the workpiece frame as programmed and as the machine puts it [m].
    covariates : dict
        Per sample, the covariates the path sets (``directions``, for a machine that reads
        them), given to the model with the machine's state.
    """

    move: np.ndarray
    q: np.ndarray
    nominal: np.ndarray
    actual: np.ndarray
    covariates: dict = field(default_factory=dict)

    def at(self, rows) -> dict:
        """The covariates of samples ``rows``.

        Parameters
        ----------
        rows : slice, ndarray of int or ndarray of bool
            The samples.

        Returns
        -------
        dict
            Covariate name -> its values at those samples (as :attr:`covariates`).
        """
        return {name: value[rows] for name, value in self.covariates.items()}

    def distinct(self, rows: np.ndarray) -> np.ndarray:
        """Of samples ``rows``, those at axis positions and covariates no earlier one of them
        has: a pass cut again over the same points (a spring pass, a circle of many turns)
        leaves the same surface, which a CMM measures once.

        Parameters
        ----------
        rows : ndarray of int
            The samples, in order.

        Returns
        -------
        ndarray of int
            The first of each, in order (``rows`` itself when none repeats).
        """
        if len(rows) < 2:
            return rows
        columns = [self.q[rows]]
        for value in self.covariates.values():
            for array in (value.values() if isinstance(value, dict) else (value,)):
                columns.append(np.asarray(array, dtype=float)[rows].reshape(len(rows), -1))
        _, first = np.unique(np.hstack(columns), axis=0, return_index=True)
        return rows if len(first) == len(rows) else rows[np.sort(first)]

    def rows(self, moves: list[int]) -> np.ndarray:
        """The rows of the samples of ``moves`` (the samples run move by move).

        Parameters
        ----------
        moves : list of int
            Indices of moves among the program's cutting moves.

        Returns
        -------
        ndarray of int
            The rows, ascending (empty for no moves).
        """
        if not len(moves):
            return np.zeros(0, dtype=int)
        if max(moves) - min(moves) + 1 == len(moves):   # a run of moves: one range of rows
            return np.arange(np.searchsorted(self.move, min(moves), "left"),
                             np.searchsorted(self.move, max(moves), "right"))
        return np.flatnonzero(np.isin(self.move, moves))


def cut_of(machine: Machine, moves, spacing: float = 0.25e-3) -> Cut:
    """Samples of the cutting moves, where the tool actually is.

    The samples are at most ``spacing`` apart along the nominal tool path (at least 3 per
    move; a move's end is the next one's start, so ends are not sampled twice). A move that
    turns a rotary axis in axes programming curves: its length is taken from 16 chords, short
    of the curve's by up to 0.2 % (a half turn), and its samples as much further apart.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict.
    moves : MoveBatch or CuttingPath
        The program's moves (:func:`volerr_pin.compensation.gcode.interpret`).
    spacing : float, default 0.25e-3
        The largest distance between samples along a move [m].

    Returns
    -------
    Cut

    Raises
    ------
    InputError
        If the program has no cutting move, or a move leaves the travel (naming its line).
    """
    moves = CuttingPath.of(machine, moves)
    n = len(moves)
    index = np.arange(n)
    ends = moves.tool_points(moves.axes(np.repeat(index, 2), np.tile([0.0, 1.0], n))).reshape(n, 2, 3)
    length = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    # a move that turns a rotary axis in axes programming takes the tool point along a curve: its
    # length from 16 chords (a tool-tip move's tip goes straight, an arc's length is its own)
    rotary = np.array(machine.axis_kinds) == "rotary"
    words = moves.moves
    curved = np.flatnonzero(~moves.arc & ~moves.tool_tip & (words.w0[:, rotary] != words.w1[:, rotary]).any(axis=1))
    if len(curved):
        k = np.linspace(0.0, 1.0, 17)
        points = moves.tool_points(moves.axes(np.repeat(curved, 17), np.tile(k, len(curved)))).reshape(-1, 17, 3)
        length[curved] = np.linalg.norm(np.diff(points, axis=1), axis=2).sum(axis=1)
    arcs = np.flatnonzero(moves.arc)
    length[arcs] = np.abs(words.sweep[arcs]) * np.maximum(words.r0[arcs], 1e-9)
    counts = np.maximum(3, np.ceil(length / spacing).astype(int))
    move = np.repeat(index, counts)
    k = (np.arange(len(move)) - np.repeat(np.cumsum(counts) - counts, counts)) / np.repeat(counts, counts)
    q = moves.axes(move, k)
    moves.check_travel(move, q)
    nominal = moves.tool_points(q)
    covariates = moves.covariates(move, k, q)
    return Cut(move, q, nominal, nominal + moves.errors(q, covariates), covariates)
