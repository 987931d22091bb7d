"""The contouring test piece of ISO 10791-7 as a program: a square, a diamond and a circle in
the middle of a machine's travel, to predict like any program.
"""

from __future__ import annotations

import numpy as np

from ...base import InputError, feed_rate
from ...model import Machine

__all__ = ["SMALLEST_SIDE", "contouring_test_piece", "feed_word"]

#: the smallest square the contouring test piece takes [mm]: its diamond's sides (0.64 of it)
#: are then at least the 5 mm predict measures a side from
SMALLEST_SIDE = 10.0


def feed_word(feed: float) -> str:
    """A feed rate [mm/min] as an F word's number: plain decimals, no exponent a reader refuses.

    Parameters
    ----------
    feed : float
        The feed rate, checked (:func:`~volerr_pin.base.feed_rate`).

    Returns
    -------
    str
        ``"500"``, ``"0.001"``.
    """
    return f"{feed:.4f}".rstrip("0").rstrip(".")


def contouring_test_piece(machine: Machine, size: float | None = None, feed: float = 500.0) -> str:
    """A program of the contouring test piece's finishing contours, in the form of ISO 10791-7's:
    a square, a diamond (the square turned 45 degrees, inside it) and a circle (inside the
    diamond), each a closed contour at one height, in the middle of the machine's travel.

    Parameters
    ----------
    machine : Machine
        The machine: its first three axes must be linear X, Y, Z (the rotary ones, if any, stay
        at 0 or mid travel).
    size : float, optional
        The square's side [m]; default 160 mm, or less to keep 20 % of the smaller of the X and
        Y travels on either side.
    feed : float, default 500
        Feed rate [mm/min].

    Returns
    -------
    str
        The program (G17 G90 G21, mm), its contours separated by rapids, the size stated in a
        comment.

    Raises
    ------
    InputError
        If the machine has no linear X, Y and Z, the square does not fit its travel or is
        smaller than :data:`SMALLEST_SIDE`, or the feed is not a feed rate.
    """
    axes = machine.axes
    if axes[:3] != ("X", "Y", "Z") or any(k != "linear" for k in machine.axis_kinds[:3]):
        raise InputError(f"{machine.name}: the contouring test piece needs linear X, Y, Z as the first axes, "
                         f"got {', '.join(axes)}", parameters=("machine",))
    feed = feed_rate("feed", feed)
    travel = machine.travel[:3] * 1e3
    span = min(travel[0, 1] - travel[0, 0], travel[1, 1] - travel[1, 0])
    side = size * 1e3 if size is not None else min(160.0, np.floor(0.6 * span / 10.0) * 10.0)
    if not np.isfinite(side) or side > span:
        raise InputError(f"the square's side {side:g} mm does not fit {machine.name}'s travel ({span:g} mm across)",
                         parameters=("size",))
    if side < SMALLEST_SIDE:
        raise InputError(f"the square's side {side:g} mm is below {SMALLEST_SIDE:g} mm: the diamond's sides would be "
                         "shorter than the 5 mm predict measures a side from", parameters=("size",))
    cx, cy, z = (travel[:, 0] + travel[:, 1]) / 2.0
    half, tip, radius = side / 2.0, 0.45 * side, 0.3 * side
    others = "".join(f" {a}{(0.0 if 0.0 >= lo and 0.0 <= hi else (lo + hi) / 2):.4f}"
                     for a, (lo, hi) in zip(axes[3:], np.degrees(machine.travel[3:]) if len(axes) > 3 else []))
    lines = [f"(contouring test piece for {machine.name}: square {side:g} mm, diamond {2 * tip:g} mm across, "
             f"circle {2 * radius:g} mm, at Z {z:g})", "G17 G90 G21", f"G0 Z{z + 50:.4f}{others}",
             "(square)", f"G0 X{cx - half:.4f} Y{cy - half:.4f}", f"G0 Z{z:.4f}",
             f"G1 X{cx + half:.4f} F{feed_word(feed)}", f"G1 Y{cy + half:.4f}", f"G1 X{cx - half:.4f}",
             f"G1 Y{cy - half:.4f}",
             f"G0 Z{z + 50:.4f}", "(diamond)", f"G0 X{cx:.4f} Y{cy - tip:.4f}", f"G0 Z{z:.4f}",
             f"G1 X{cx + tip:.4f} Y{cy:.4f} F{feed_word(feed)}", f"G1 X{cx:.4f} Y{cy + tip:.4f}",
             f"G1 X{cx - tip:.4f} Y{cy:.4f}",
             f"G1 X{cx:.4f} Y{cy - tip:.4f}", f"G0 Z{z + 50:.4f}",
             "(circle)", f"G0 X{cx - radius:.4f} Y{cy:.4f}", f"G0 Z{z:.4f}",
             f"G2 X{cx - radius:.4f} Y{cy:.4f} I{radius:.4f} J0 F{feed_word(feed)}", f"G0 Z{z + 50:.4f}", "M30"]
    return "\n".join(lines) + "\n"
