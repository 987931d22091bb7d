"""A program's cutting moves on a machine: where the axes are at any fraction of a move, where
the nominal tool point is and which way the path runs there, the tool point's error, and the
axes' directions a controller takes along the path (for a machine with backlash).

The moves are the program's :class:`~volerr_pin.compensation.MoveBatch` as the NC
reader gives it (:func:`volerr_pin.compensation.gcode.interpret`): its cutting rows (lines and
arcs; rapids cut nothing) are the path, its rapids keep their place in the program between
them (they end contours, and the axes' directions carry through them). Points along a move
are the batch's own (:meth:`~volerr_pin.compensation.MoveBatch.desired`), turned into
axis positions as the controller does (tool-tip programming through the nominal machine).
Every evaluation is one call of the model's algorithms for all the points asked at once.
"""

from __future__ import annotations

import numpy as np

from ...base import InputError
from ...compensation import ARC, LINE, POINT, MoveBatch
from ...model import Machine, check_covariates, outside_travel, tool_poses, volumetric_error

__all__ = ["TANGENT_STEP", "TIP_PIECE", "CuttingPath", "normal_part"]

#: the parameter step, as a fraction of a move, of the nominal tangent's finite difference
TANGENT_STEP = 1e-6
#: tool-tip words turned into axis positions at a time: the conversion takes four nominal tool
#: poses a point
TIP_PIECE = 25_000


def normal_part(error: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """The part of an error normal to the path: what the cut surface keeps.

    Parameters
    ----------
    error : ndarray, shape (N, 3)
        Tool point errors [m].
    tangent : ndarray, shape (N, 3)
        Unit tangents of the path (zero where the path has no direction).

    Returns
    -------
    ndarray, shape (N, 3)
        ``error - (error . t) t``; where the tangent is zero, the whole error [m].
    """
    along = np.sum(error * tangent, axis=1)
    return error - along[:, None] * tangent


def _signs(step: np.ndarray) -> np.ndarray:
    """Signs of axis steps, rounding below 1e-13 (m or rad: an axis that stands still) to 0."""
    return np.where(np.abs(step) > 1e-13, np.sign(step), 0.0)


def _contours(kind: np.ndarray) -> list[list[int]]:
    """The cutting moves grouped in contours (runs between rapids), as indices among the
    cutting moves, from the kind of every move of the program in its order."""
    cutting = kind != POINT
    if not cutting.any():
        return []
    opens = cutting & ~np.r_[False, cutting[:-1]]   # a cutting move after a rapid (or first)
    contour = np.cumsum(opens)[cutting]
    return [run.tolist() for run in np.split(np.arange(len(contour)), np.flatnonzero(np.diff(contour)) + 1)]


class CuttingPath:
    """A program's cutting moves on a machine, whose points at any fractions are asked for in
    one batch (see the module docstring).

    Parameters
    ----------
    machine : Machine
        The machine, in the state to predict.
    program : MoveBatch
        The program's moves, in its order (:func:`volerr_pin.compensation.gcode.interpret`).

    Attributes
    ----------
    machine : Machine
        The machine.
    program : MoveBatch
        All the program's moves, rapids included, but lines of zero length (they move nothing).
    moves : MoveBatch
        Its cutting moves (lines and arcs), in order; the rows the methods' ``move`` index.
    order : ndarray of int, shape (M,)
        Each cutting move's row in ``program``.
    line : ndarray of int, shape (M,)
        Each cutting move's block line.
    arc : ndarray of bool, shape (M,)
        The cutting move is an arc.
    tool_tip : ndarray of bool, shape (M,)
        The cutting move is in tool-tip programming.
    contours : list of list of int
        The cutting moves in contours (runs between rapids), as indices among them.
    uses_directions : bool
        The machine's errors depend on the axes' directions (the path sets them).

    Raises
    ------
    InputError
        If the program has no cutting move.
    """

    def __init__(self, machine: Machine, program: MoveBatch):
        self.machine = machine
        still = (program.kind == LINE) & np.all(program.w0 == program.w1, axis=1)
        if still.any():   # a line to where the axes stand moves nothing: it cuts nothing, nor ends a contour
            program = program.take(~still)
        self.program = program
        self.order = np.flatnonzero(program.kind != POINT)   # place in the program
        if not len(self.order):
            raise InputError("the program has no cutting move (lines or arcs)", parameters=("moves",))
        self.moves = program.take(self.order)
        self.line = self.moves.line
        self.arc = self.moves.kind == ARC
        self.tool_tip = self.moves.tool_tip
        self.contours = _contours(program.kind)
        self._model, self._theta, self._state = machine.model, machine.theta, machine.state
        self._tip = None
        self.uses_directions = "directions" in machine.covariates_used
        self._carry = None

    def __len__(self) -> int:
        return len(self.moves)

    @classmethod
    def of(cls, machine: Machine, moves) -> "CuttingPath":
        """``moves`` on ``machine``: a program's moves are taken once however many steps ask.

        Parameters
        ----------
        machine : Machine
            The machine.
        moves : MoveBatch or CuttingPath
            A program's moves, or its path already made.

        Returns
        -------
        CuttingPath
            ``moves`` itself when it is one.
        """
        return moves if isinstance(moves, cls) else cls(machine, moves)

    # ------------------------------------------------------------------ positions
    def axes(self, move: np.ndarray, k: np.ndarray) -> np.ndarray:
        """Axis positions of cutting moves at fractions of them.

        Parameters
        ----------
        move : ndarray of int, shape (P,)
            Cutting move of each point.
        k : ndarray, shape (P,)
            Fraction of its move, 0 to 1.

        Returns
        -------
        ndarray, shape (P, n_axes)
            Axis positions [m, rad] (a tool-tip move's words through the nominal machine).
        """
        out = self.moves.desired(move, k)
        tip = self.tool_tip[move]
        if tip.any():
            out[tip] = self._to_axes(out[tip])
        return out

    def _to_axes(self, words: np.ndarray) -> np.ndarray:
        """Tool-tip words as axis positions, :data:`TIP_PIECE` points at a time."""
        if self._tip is None:
            from ...compensation import programming_for

            self._tip = programming_for("tool-tip", self.machine)
        if len(words) <= TIP_PIECE:
            return self._tip.to_axes(words)
        return np.concatenate([self._tip.to_axes(words[a:a + TIP_PIECE]) for a in range(0, len(words), TIP_PIECE)])

    def check_travel(self, move: np.ndarray, q: np.ndarray) -> None:
        """Refuse positions that leave the travel, naming the move's line: the model is not
        extrapolated into a part.

        Parameters
        ----------
        move : ndarray of int, shape (P,)
            Cutting move of each point.
        q : ndarray, shape (P, n_axes)
            Their axis positions [m, rad].

        Raises
        ------
        InputError
            At the first position outside the travel.
        """
        machine = self.machine
        outside = outside_travel(self._model, q)
        if outside.any():
            row, axis = np.argwhere(outside)[0]
            unit, scale = ("deg", 180.0 / np.pi) if machine.axis_kinds[axis] == "rotary" else ("mm", 1e3)
            low, high = self._model.travel[axis] * scale
            raise InputError(f"line {self.line[move[row]]}: the move takes {machine.axes[axis]} to "
                             f"{q[row, axis] * scale:.4f} {unit}, outside its travel {low:g} .. {high:g} {unit}",
                             parameters=("moves",))

    def tool_points(self, q: np.ndarray) -> np.ndarray:
        """The nominal tool point at axis positions the path gives (a tangent's step may touch
        the ends of the travel).

        Parameters
        ----------
        q : ndarray, shape (P, n_axes)
            Axis positions [m, rad].

        Returns
        -------
        ndarray, shape (P, 3)
            The tool point in the workpiece frame [m].
        """
        return tool_poses(self._model, q, nominal=True)[1]

    def errors(self, q: np.ndarray, covariates: dict) -> np.ndarray:
        """The tool point's error at points of the path, in the machine's state with the
        covariates the path sets there.

        Parameters
        ----------
        q : ndarray, shape (P, n_axes)
            Axis positions [m, rad] of points of the path, within the travel
            (:meth:`check_travel`).
        covariates : dict
            Their covariates (:meth:`covariates`); those not given come from the machine's
            state.

        Returns
        -------
        ndarray, shape (P, 3)
            Actual minus nominal tool point [m].
        """
        cov = check_covariates(self._model, len(q), covariates, state=self._state)
        return volumetric_error(self._model, q, self._theta, cov)[:, :3]

    def evaluate(self, move: np.ndarray, k: np.ndarray):
        """Everything the deviation along the path needs at points of it.

        Parameters
        ----------
        move : ndarray of int, shape (P,)
            Cutting move of each point.
        k : ndarray, shape (P,)
            Fraction of its move.

        Returns
        -------
        tuple of ndarray
            Axis positions (P, n_axes), the nominal tool point (P, 3), the unit tangent of
            the nominal path (a central difference in the fraction; zero where the tool point
            does not move), the error and its part normal to the path (P, 3 each).

        Raises
        ------
        InputError
            If a point leaves the travel (:meth:`check_travel`).
        """
        q = self.axes(move, k)
        self.check_travel(move, q)
        point = self.tool_points(q)
        ahead = self.axes(move, np.clip(k + TANGENT_STEP, 0.0, 1.0))
        behind = self.axes(move, np.clip(k - TANGENT_STEP, 0.0, 1.0))
        step = self.tool_points(ahead) - self.tool_points(behind)
        length = np.linalg.norm(step, axis=1)
        moving = length > 1e-12 * max(1.0, float(np.abs(point).max(initial=0.0)))
        tangent = np.zeros_like(step)
        tangent[moving] = step[moving] / length[moving, None]
        error = self.errors(q, self.covariates(move, k, q))
        return q, point, tangent, error, normal_part(error, tangent)

    # ------------------------------------------------------------------ the axes' directions
    def _motion(self, move: np.ndarray, k: np.ndarray, q: np.ndarray, toward: float) -> np.ndarray:
        """Signs of each axis' motion within the move next to fraction ``k``: over the step
        ``TANGENT_STEP`` before ``k`` (``toward`` -1) or after it (+1), or, where an axis barely
        moves there (at the top of an arc), over a thousandth of the move; 0 where it stands."""
        signs = np.zeros_like(q)
        for step in (TANGENT_STEP, 1e-3):
            other = self.axes(move, np.clip(k + toward * step, 0.0, 1.0))
            found = _signs(toward * (other - q))
            signs = np.where(signs != 0, signs, found)
            if (signs != 0).all():
                break
        return signs

    def _rapid_signs(self) -> tuple[np.ndarray, np.ndarray]:
        """The program's rapids (rows) and the signs of each axis' motion over each, straight in
        axis positions (a start not known moves nothing)."""
        program = self.program
        rows = np.flatnonzero(program.kind == POINT)
        starts, ends = program.w0[rows], program.w1[rows]
        tip = program.tool_tip[rows] & np.isfinite(starts).all(axis=1) & np.isfinite(ends).all(axis=1)
        if tip.any():
            both = self._to_axes(np.concatenate([starts[tip], ends[tip]]))
            starts[tip], ends[tip] = both[:int(tip.sum())], both[int(tip.sum()):]
        return rows, np.nan_to_num(_signs(ends - starts))

    def _carry_in(self) -> np.ndarray:
        """Each axis' direction as each move starts (n_moves, n_axes): the sign of its last motion
        before it, rapids included; before the program, the machine state's directions (+1
        without)."""
        if self._carry is None:
            n, index = len(self), np.arange(len(self))
            total = len(self.program)
            last = np.zeros((total, self.moves.w0.shape[1]))
            last[self.order] = self._motion(index, np.ones(n), self.axes(index, np.ones(n)), -1.0)
            rapids, signs = self._rapid_signs()
            last[rapids] = signs
            start = self._state.get("directions")
            start = np.ones(last.shape[1]) if start is None else np.sign(np.asarray(start, dtype=float))
            # forward fill: an axis standing still keeps the direction it had
            seen = np.where(last != 0, np.arange(total)[:, None], -1)
            latest = np.maximum.accumulate(seen, axis=0)
            filled = np.where(latest >= 0, np.take_along_axis(last, np.maximum(latest, 0), axis=0), start)
            before = self.order - 1
            self._carry = np.where((before >= 0)[:, None], filled[np.maximum(before, 0)], start)
        return self._carry

    def covariates(self, move: np.ndarray, k: np.ndarray, q: np.ndarray) -> dict:
        """The covariates the path itself sets.

        For a machine whose errors depend on the axes' directions (backlash), each axis'
        direction at each point of a move as a controller takes it: the sign of the move's
        motion into the point (at the move's start, of its first motion: the move is followed
        in its own directions, and a reversal at its start steps the path between the move
        before and it); while the axis stands still, the direction it had.

        Parameters
        ----------
        move : ndarray of int, shape (P,)
            Cutting move of each point.
        k : ndarray, shape (P,)
            Fraction of its move.
        q : ndarray, shape (P, n_axes)
            Their axis positions [m, rad].

        Returns
        -------
        dict
            ``directions`` (P, n_axes) of +1 / -1 for a machine that reads them; else empty.
        """
        if not self.uses_directions:
            return {}
        signs = self._motion(move, k, q, -1.0)
        first = k <= 0.0
        if first.any():
            signs[first] = self._motion(move[first], k[first], q[first], 1.0)
        return {"directions": np.where(signs != 0, signs, self._carry_in()[move])}
