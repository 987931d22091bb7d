"""The NC program that visits the planned poses, and how long it takes.

The program (ISO 6983 style, mm and deg, absolute) moves to each pose with a feed move
``G1`` at the stated feed and dwells ``G4 P<seconds>`` there for the measurement (P in
seconds, as LinuxCNC reads it; a Fanuc control reads ``G4 X<seconds>`` or ``P`` in ms). It
carries one comment per pose naming its row in the plan, so a measurement can be matched
to its row.

Time model (the feed rule of LinuxCNC's G-code reference, "F: Set Feed Rate", for G94): a
move that changes a linear axis takes its straight-line length in the linear axes divided by
the feed (mm/min); a move of rotary axes alone takes its length in deg divided by the feed
taken as deg/min. Acceleration is neglected (a lower bound for short moves); each pose adds
its dwell. The move to the first pose, from wherever the machine stands, is not counted.
"""

from __future__ import annotations

import re

import numpy as np

from ...base import InputError, axis_scales, positive

__all__ = ["StopsProgram", "check_axes", "nc_program", "time_estimate"]

#: NC address letters of machine axes
AXIS_LETTER = re.compile(r"^[XYZABCUVW]$")


def check_axes(machine) -> None:
    """Refuse a machine whose axes an NC program cannot name.

    Parameters
    ----------
    machine : Machine
        The machine.

    Raises
    ------
    InputError
        Naming ``nc``, if an axis is not an NC address letter (X, Y, Z, A, B, C, U, V, W).
    """
    bad = [a for a in machine.axes if not AXIS_LETTER.match(a)]
    if bad:
        raise InputError(f"nc: axis {bad[0]!r} of {machine.name} is not an NC address letter (X, Y, Z, A, B, C, U, "
                         "V, W): no NC program can name it", parameters=("nc",))


def time_estimate(machine, q: np.ndarray, feed_mm_min: float, dwell_s: float) -> dict:
    """Time to visit the poses in order (see the module docstring for the model).

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (n, n_axes)
        Poses in the order visited [m, rad].
    feed_mm_min : float
        Feed [mm/min] (deg/min for moves of rotary axes alone).
    dwell_s : float
        Dwell per pose [s].

    Returns
    -------
    dict
        ``moves_s``, ``dwell_s`` (total), ``total_s``, ``total_min``, ``feed_mm_min``,
        ``dwell_per_pose_s``, ``path_mm`` (length in the linear axes) and ``model`` (in words).

    Raises
    ------
    InputError
        If the feed is not positive or the dwell negative or not finite.
    """
    feed = positive("feed_mm_min", feed_mm_min)
    if not (np.isfinite(dwell_s) and dwell_s >= 0):
        raise InputError(f"dwell_s must be a non-negative number of seconds, got {dwell_s!r}", parameters=("dwell_s",))
    x = np.asarray(q, dtype=float) / axis_scales(machine.axis_kinds)
    linear = np.array([k == "linear" for k in machine.axis_kinds])
    steps = np.diff(x, axis=0)
    lin = np.linalg.norm(steps[:, linear], axis=1) if linear.any() else np.zeros(len(steps))
    rot = np.linalg.norm(steps[:, ~linear], axis=1) if (~linear).any() else np.zeros(len(steps))
    minutes = np.where(lin > 0, lin, rot) / feed
    moves = float(np.sum(minutes) * 60.0)
    dwell = float(dwell_s * len(x))
    return {"moves_s": moves, "dwell_s": dwell, "total_s": moves + dwell, "total_min": (moves + dwell) / 60.0,
            "feed_mm_min": feed, "dwell_per_pose_s": float(dwell_s), "path_mm": float(np.sum(lin)),
            "model": "G1 moves at the feed (linear-axis length / feed; rotary-only moves: deg / feed) plus the "
                     "dwells; acceleration neglected; the move to the first pose not counted"}


def nc_program(machine, q: np.ndarray, feed_mm_min: float, dwell_s: float, title: str = "") -> str:
    """The program that visits the poses and dwells at each (module docstring).

    Parameters
    ----------
    machine : Machine
        The machine (its axes must be NC address letters X, Y, Z, A, B, C, U, V, W).
    q : ndarray, shape (n, n_axes)
        Poses in order [m, rad].
    feed_mm_min : float
        Feed [mm/min].
    dwell_s : float
        Dwell per pose [s].
    title : str, optional
        A comment line at the top (parentheses are removed).

    Returns
    -------
    str
        The program.

    Raises
    ------
    InputError
        If an axis is not an NC address letter, the feed is not positive or the dwell negative.
    """
    check_axes(machine)
    feed = positive("feed_mm_min", feed_mm_min)
    if not (np.isfinite(dwell_s) and dwell_s >= 0):
        raise InputError(f"dwell_s must be a non-negative number of seconds, got {dwell_s!r}", parameters=("dwell_s",))
    x = np.asarray(q, dtype=float) / axis_scales(machine.axis_kinds)
    clean = re.sub(r"[()]", "", title)
    lines = ["%", f"({clean})" if clean else "(measurement campaign)",
             "(one pose per G1 move, then a dwell G4 P in seconds for the measurement)", "G21 G90 G94 G17"]
    for i, row in enumerate(x):
        words = " ".join(f"{a}{v:.4f}" for a, v in zip(machine.axes, row))
        lines.append(f"G1 {words} F{feed:g} (pose {i + 1})")
        lines.append(f"G4 P{dwell_s:g}")
    lines += ["M30", "%"]
    return "\n".join(lines) + "\n"


class StopsProgram:
    """The NC program and time of an instrument that measures while the machine stands still:
    :func:`nc_program` and :func:`time_estimate` over its :meth:`visits` (a mixin for the
    instruments' classes)."""

    def program(self, machine, units: list, feed_mm_min: float, dwell_s: float, title: str = "") -> str:
        """The program that visits every stop of the units with a dwell at each.

        Parameters
        ----------
        machine : Machine
            The machine.
        units : list
            The units, in the order measured.
        feed_mm_min : float
            Feed [mm/min].
        dwell_s : float
            Dwell per stop [s].
        title : str, optional
            A comment line at the top.

        Returns
        -------
        str
            The program (:func:`nc_program`).
        """
        return nc_program(machine, self.visits(machine, units), feed_mm_min, dwell_s, title)

    def duration(self, machine, units: list, feed_mm_min: float, dwell_s: float) -> dict:
        """Time to visit every stop of the units (:func:`time_estimate`).

        Parameters
        ----------
        machine : Machine
            The machine.
        units : list
            The units, in order.
        feed_mm_min : float
            Feed [mm/min].
        dwell_s : float
            Dwell per stop [s].

        Returns
        -------
        dict
            As :func:`time_estimate`.
        """
        return time_estimate(machine, self.visits(machine, units), feed_mm_min, dwell_s)
