"""Tool-tip programming (tool centre point control: Fanuc G43.4, Siemens TRAORI, RTCP).

The program's X, Y and Z words are the position of the tool tip (the machine's tool frame)
in the workpiece frame; its rotary words (A, B, C) are rotary axis positions. The controller
takes the linear axis positions that put the *nominal* tool tip there: for fixed rotary axes
the tool tip moves affinely with the linear axes (a chain of prismatic joints and fixed
transforms), so four nominal poses give the map and one 3 x 3 solve inverts it exactly.
"""

from __future__ import annotations

import numpy as np

from ..base import InputError
from ..model import Machine, tool_poses
from ._programming import Programming

#: the words that carry the tool tip, and the workpiece direction each carries
TIP_WORDS = ("X", "Y", "Z")


class ToolTipProgramming(Programming):
    """Program coordinates: the tool tip in the workpiece frame [m] and rotary axis positions [rad].

    Parameters
    ----------
    machine : Machine
        The machine: its linear axes are X, Y and Z, and for every position of its rotary
        axes its linear axes move the nominal tool tip in three independent directions.

    Attributes
    ----------
    name : str
        ``"tool-tip"``.
    identity : bool
        False.

    Raises
    ------
    InputError
        Naming ``programming``: the machine's linear axes are not X, Y and Z, or they do not
        move the tool tip in three independent directions (checked at mid-travel and at random
        poses).

    Notes
    -----
    The methods of :class:`~volerr_pin.compensation.Programming` (documented there) do here:

    - ``to_words``: program coordinates: the nominal tool tip in the workpiece frame, and the
      rotary axes.
    - ``to_axes``: axis positions of program coordinates: the linear axes that put the nominal
      tool tip at the X, Y, Z words with the rotary axes at theirs.
    - ``word_rows``: derivatives with respect to program coordinates, through the map to axis
      positions. Program coordinates change with the axes as ``D``: the tip words as the nominal
      tool point (the position rows of ``jacobian``), the rotary words one to one; derivatives
      with respect to the words are ``rows D^-1``.
    """

    name = "tool-tip"
    identity = False

    def __init__(self, machine: Machine):
        self.machine = machine
        self._model = machine.model
        kinds = machine.axis_kinds
        linear = tuple(a for a, k in zip(machine.axes, kinds) if k == "linear")
        if sorted(linear) != sorted(TIP_WORDS):
            raise InputError(f"programming 'tool-tip' needs linear axes X, Y and Z; {machine.name} has "
                             f"{', '.join(linear) or 'none'}", parameters=("programming",))
        self._tip = np.array([machine.axes.index(a) for a in TIP_WORDS])
        rng = np.random.default_rng(0)
        travel = np.where(np.isfinite(machine.travel), machine.travel, np.array([-np.pi, np.pi]))
        q = travel[:, 0] + rng.random((16, len(machine.axes))) * (travel[:, 1] - travel[:, 0])
        q = np.vstack([machine.mid_travel, q])
        try:
            back = self.to_axes(self.to_words(q))
        except np.linalg.LinAlgError:
            back = np.full_like(q, np.nan)
        if not np.all(np.abs(back - q) < 1e-9):
            raise InputError(f"programming 'tool-tip': {machine.name}'s linear axes do not move the tool tip "
                             "affinely in three independent directions at every pose", parameters=("programming",))

    def to_words(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        _, p = tool_poses(self._model, q, nominal=True)
        out = q.copy()
        out[:, self._tip] = p
        return out

    def to_axes(self, words: np.ndarray) -> np.ndarray:
        words = np.asarray(words, dtype=float)
        n = len(words)
        base = words.copy()
        base[:, self._tip] = 0.0
        # the tip at the linear axes' zero and one metre along each: affine, so exact
        probe = np.repeat(base[None], 4, axis=0)
        for k, j in enumerate(self._tip):
            probe[k + 1, :, j] = 1.0
        _, p = tool_poses(self._model, probe.reshape(-1, words.shape[1]), nominal=True)
        p = p.reshape(4, n, 3)
        J = np.stack([p[1] - p[0], p[2] - p[0], p[3] - p[0]], axis=2)  # (N, 3 directions, 3 axes)
        x = np.linalg.solve(J, (words[:, self._tip] - p[0])[..., None])[..., 0]
        out = words.copy()
        out[:, self._tip] = x
        return out

    def word_rows(self, rows: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        n = rows.shape[2]
        D = np.repeat(np.eye(n)[None], len(rows), axis=0)
        D[:, self._tip, :] = jacobian[:, :3, :]
        return np.swapaxes(np.linalg.solve(np.swapaxes(D, 1, 2), np.swapaxes(rows, 1, 2)), 1, 2)
