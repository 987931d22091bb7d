"""Batches of moves (a program's, or a chunk's to compensate) and of the compensated pieces
they become.

Everything is in program coordinates (SI: m, rad; see :mod:`._programming`): a controller
interpolates straight moves linearly and arcs along circles *in program coordinates*, so the
desired path of a move and the commanded path of a piece are both defined there; poses come
from the axis positions the programming mode maps them to.

:class:`MoveBatch` is the one home of a program's moves as arrays: the NC reader gives a
program as one (:func:`volerr_pin.compensation.gcode.interpret`), the compensation takes a
chunk of one, and the points along its moves, arcs included, come from :meth:`MoveBatch.desired`
(through :func:`~.arcs.arc_points`). Reading a batch row by row (:class:`Move`) is for
callers that look at a few moves.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._arcs import Arc, arc_points

__all__ = ["ARC", "KIND_NAMES", "LINE", "POINT", "Move", "MoveBatch", "PieceSet", "Skipped", "skip_run"]

#: kinds of moves: only the end point is compensated (rapid moves, moves from an unknown
#: position), a straight move, an arc or helix
POINT, LINE, ARC = 0, 1, 2
#: what reading a program calls each kind (a :data:`POINT` move is a rapid: it cuts nothing)
KIND_NAMES = ("rapid", "line", "arc")


@dataclass
class Skipped:
    """Blocks of a program, one after the other, that the reader did not follow, for one reason.

    Attributes
    ----------
    line, last_line : int
        The program lines of the first and the last (1-based).
    blocks : int
        How many blocks were run (a loop's pass counts each time).
    reason : str
        Why: the construct kept as written (as compensate names it), or the cut's unknown start.
    moved : bool
        The blocks are moves of the batch (cuts from an unknown position, taken as rapids to
        their ends), not blocks kept out of it.
    """

    line: int
    last_line: int
    blocks: int
    reason: str
    moved: bool = False

    @property
    def where(self) -> str:
        """``"line 5"``, or ``"lines 5-12"`` for a run of blocks (str)."""
        return f"line {self.line}" if self.line == self.last_line else f"lines {self.line}-{self.last_line}"

    def to_dict(self) -> dict:
        """The run for a report.

        Returns
        -------
        dict
            JSON-ready: ``line``, ``last_line``, ``blocks`` and ``reason``.
        """
        return {"line": self.line, "last_line": self.last_line, "blocks": self.blocks, "reason": self.reason}


def skip_run(runs: list, line: int, reason: str, moves_between: bool, moved: bool = False) -> None:
    """Add a block not followed to ``runs`` (a list of :class:`Skipped`): into the last run when it
    has the same reason and no move was followed since, so that a program of millions of kept
    blocks gives a short list.

    Parameters
    ----------
    runs : list of Skipped
        Updated in place.
    line : int
        The block's program line.
    reason : str
        Why it is not followed.
    moves_between : bool
        Whether a move was followed since the last block added.
    moved : bool, default False
        The block is a move of the batch (:attr:`Skipped.moved`).
    """
    if runs and not moves_between and runs[-1].reason == reason:
        last = runs[-1]
        last.last_line, last.blocks = line, last.blocks + 1
    else:
        runs.append(Skipped(line, line, 1, reason, moved))


@dataclass
class MoveBatch:
    """Desired moves, one row each (SI program coordinates), in the order they are made.

    Attributes
    ----------
    kind : ndarray of int, shape (M,)
        :data:`POINT`, :data:`LINE` or :data:`ARC`.
    w0, w1 : ndarray, shape (M, n)
        Start and end [m, rad]. A move that is not a :data:`POINT` starts where the move
        before it ends.
    plane : ndarray of int, shape (M, 3)
        Arcs: indices of the two plane coordinates and the third one (-1 when the machine has
        none; any value for other moves).
    center : ndarray, shape (M, 2)
        Arcs: centre in the plane [m].
    r0, r1 : ndarray, shape (M,)
        Arcs: radius at the start and at the end [m] (spread linearly over the sweep).
    a0, sweep : ndarray, shape (M,)
        Arcs: start angle and signed sweep [rad] (> 0 counter-clockwise).
    line : ndarray of int, shape (M,)
        The program line of each move's block (1-based; 0 when not from a program).
    tool_tip : ndarray of bool, shape (M,)
        The move's coordinates are tool-tip programming's (the tool tip in the workpiece frame
        and the rotary axes) rather than axis positions.
    skipped : list of Skipped
        A program's blocks the reader did not follow (kept as written, or cuts from an unknown
        position), each run of blocks with one reason once (:func:`skip_run`); empty for a chunk.
    notes : list of str
        What the reader tells of a program it follows (work and tool offsets taken as the
        model's), each naming its line; empty for a chunk.
    dialect : tuple of (str, str) or None
        For a program: the dialect it was read in and what decided it (``("fanuc", "detected:
        line 2: O1000, a FANUC program number")``).
    """

    kind: np.ndarray
    w0: np.ndarray
    w1: np.ndarray
    plane: np.ndarray
    center: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    a0: np.ndarray
    sweep: np.ndarray
    line: np.ndarray
    tool_tip: np.ndarray
    skipped: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    dialect: tuple | None = None

    @classmethod
    def empty(cls, m: int, n: int) -> "MoveBatch":
        """A batch of ``m`` point moves at zero, to be filled in.

        Parameters
        ----------
        m : int
            Moves.
        n : int
            Program coordinates per point.

        Returns
        -------
        MoveBatch
            Zeros; ``plane`` (0, 1, 2), ``line`` 0, axes programming.
        """
        z = np.zeros(m)
        return cls(np.zeros(m, dtype=np.int8), np.zeros((m, n)), np.zeros((m, n)),
                   np.tile(np.array([0, 1, 2]), (m, 1)), np.zeros((m, 2)), z.copy(), z.copy(), z.copy(), z.copy(),
                   np.zeros(m, dtype=np.int64), np.zeros(m, dtype=bool))

    def __len__(self) -> int:
        return len(self.kind)

    def take(self, rows) -> "MoveBatch":
        """The moves of some rows.

        Parameters
        ----------
        rows : slice, ndarray of int or ndarray of bool
            The rows.

        Returns
        -------
        MoveBatch
            A batch of those moves (copies; views for a slice).
        """
        return MoveBatch(self.kind[rows], self.w0[rows], self.w1[rows], self.plane[rows], self.center[rows],
                         self.r0[rows], self.r1[rows], self.a0[rows], self.sweep[rows], self.line[rows],
                         self.tool_tip[rows])

    def put_arcs(self, rows, arcs) -> None:
        """Give rows the circles of arcs (their ``kind`` is set apart).

        Parameters
        ----------
        rows : sequence of int
            The rows.
        arcs : sequence of Arc
            One arc per row (:func:`~.arcs.arc_from_center`).
        """
        if not len(rows):
            return
        self.plane[rows] = [a.plane for a in arcs]
        self.center[rows] = [a.center for a in arcs]
        self.r0[rows] = [a.radius for a in arcs]
        self.r1[rows] = [a.radius if a.end_radius is None else a.end_radius for a in arcs]
        self.a0[rows] = [a.start_angle for a in arcs]
        self.sweep[rows] = [a.sweep for a in arcs]

    def desired(self, move: np.ndarray, k: np.ndarray) -> np.ndarray:
        """Desired points of moves at fractions of them: straight in program coordinates, or
        on an arc's circle (:func:`~.arcs.arc_points`).

        Parameters
        ----------
        move : ndarray of int, shape (P,)
            Row of each point's move.
        k : ndarray, shape (P,)
            Fraction of the move, 0 to 1.

        Returns
        -------
        ndarray, shape (P, n)
            Program coordinates [m, rad].
        """
        w0, w1 = self.w0[move], self.w1[move]
        out = w0 + k[:, None] * (w1 - w0)
        arc = self.kind[move] == ARC
        if arc.any():
            m = move[arc]
            out[arc] = arc_points(w0[arc], w1[arc], self.plane[m, :2], self.center[m], self.r0[m], self.r1[m],
                                  self.a0[m], self.sweep[m], k[arc])
        return out

    def __getitem__(self, row: int) -> "Move":
        """Row ``row`` read as one move (:class:`Move`); negative rows count from the end."""
        if not isinstance(row, (int, np.integer)) or isinstance(row, bool):
            raise TypeError(f"a MoveBatch's moves are read one at a time by an integer row (take() takes "
                            f"several), got {type(row).__name__}")
        row = range(len(self))[row]   # (an IndexError past the end)
        kind = int(self.kind[row])
        arc = None
        if kind == ARC:
            arc = Arc(tuple(int(v) for v in self.plane[row]), self.center[row].copy(), float(self.r0[row]),
                      float(self.a0[row]), float(self.sweep[row]), self.w0[row].copy(), self.w1[row].copy(),
                      end_radius=float(self.r1[row]))
        return Move(self, row, int(self.line[row]), KIND_NAMES[kind], self.w0[row].copy(), self.w1[row].copy(), arc,
                    "tool-tip" if self.tool_tip[row] else "axes")

    def __iter__(self):
        return (self[row] for row in range(len(self)))


@dataclass(frozen=True)
class Move:
    """One move of a :class:`MoveBatch`, read on its own (for callers that look at a few moves;
    a batch's rows are its moves, and loops over many read the arrays).

    Attributes
    ----------
    batch : MoveBatch
        The batch it is a row of.
    row : int
        Its row.
    line : int
        1-based line of its block.
    kind : str
        "rapid" (:data:`POINT`: only its end point is meaningful), "line" (straight in program
        coordinates) or "arc".
    start, end : ndarray, shape (n,)
        Program coordinates at the ends [m, rad] (axis positions in axes programming).
    arc : Arc or None
        The arc, for ``kind == "arc"``.
    programming : str
        ``"axes"`` or ``"tool-tip"``: what the coordinates are.
    """

    batch: MoveBatch = field(repr=False, compare=False)
    row: int
    line: int
    kind: str
    start: np.ndarray
    end: np.ndarray
    arc: Arc | None
    programming: str

    def sample(self, n: int) -> np.ndarray:
        """Points along the move, evenly spaced in its parameter (:meth:`MoveBatch.desired`).

        Parameters
        ----------
        n : int
            Number of points, ends included.

        Returns
        -------
        ndarray, shape (n, n_axes)
            Program coordinates [m, rad].
        """
        return self.batch.desired(np.full(n, self.row), np.linspace(0.0, 1.0, n))


@dataclass
class PieceSet:
    """Compensated pieces of a batch of moves, ordered by move and along each move.

    Attributes
    ----------
    move : ndarray of int, shape (P,)
        Row of the move each piece belongs to.
    k0, k1 : ndarray, shape (P,)
        Fractions of the move the piece covers.
    arc : ndarray of bool, shape (P,)
        The piece is an arc (else straight).
    cw0, cw1 : ndarray, shape (P, n)
        Commanded program coordinates at the ends [m, rad].
    center : ndarray, shape (P, 2)
        Arc pieces: commanded centre in the plane [m].
    sweep : ndarray, shape (P,)
        Arc pieces: signed sweep [rad] (< 0 clockwise).
    residual : ndarray, shape (P,)
        Bound of the residual along the piece [m] (sampled maximum plus what can hide between
        samples).
    limited : ndarray of bool, shape (P,)
        No command reaches the tolerance on this piece (singular pose, or an error the axes
        cannot undo).
    before : ndarray, shape (M,)
        Per move: largest residual of the desired path run uncompensated (sampled) [m].
    """

    move: np.ndarray
    k0: np.ndarray
    k1: np.ndarray
    arc: np.ndarray
    cw0: np.ndarray
    cw1: np.ndarray
    center: np.ndarray
    sweep: np.ndarray
    residual: np.ndarray
    limited: np.ndarray
    before: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @classmethod
    def concat(cls, parts: list["PieceSet"], before: np.ndarray) -> "PieceSet":
        """Pieces of several sets, sorted by move and fraction.

        Parameters
        ----------
        parts : list of PieceSet
            Sets over the same batch of moves (their ``before`` is ignored).
        before : ndarray, shape (M,)
            Per move: the uncompensated residual [m].

        Returns
        -------
        PieceSet
            One set, ordered.
        """
        parts = [p for p in parts if len(p.move)]
        if not parts:
            n = 0
            return cls(np.zeros(0, dtype=int), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool), np.zeros((0, n)),
                       np.zeros((0, n)), np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool), before)
        cat = {name: np.concatenate([getattr(p, name) for p in parts])
               for name in ("move", "k0", "k1", "arc", "cw0", "cw1", "center", "sweep", "residual", "limited")}
        order = np.lexsort((cat["k0"], cat["move"]))
        return cls(**{name: value[order] for name, value in cat.items()}, before=before)

    def __len__(self) -> int:
        return len(self.move)

    def bounds(self, moves: int) -> np.ndarray:
        """Index of each move's first piece, and the total.

        Parameters
        ----------
        moves : int
            Number of moves of the batch.

        Returns
        -------
        ndarray of int, shape (moves + 1,)
            Pieces of move ``m`` are ``starts[m]:starts[m + 1]``.
        """
        return np.searchsorted(self.move, np.arange(moves + 1))
