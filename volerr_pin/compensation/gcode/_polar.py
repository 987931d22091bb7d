"""LinuxCNC's polar coordinates: ``@`` (distance from the origin) and ``^`` (angle from +X,
degrees, counter-clockwise) in place of X and Y.

A block with them is rewritten with the X and Y words they mean, before it is read, so its
move is compensated like any other and written in Cartesian words (a compensated end point
is no longer where a round polar word would put it). The rules are LinuxCNC's (checked with
its rs274 interpreter):

- in the XY plane (G17) only, and never with X or Y in the same block; on arcs as on lines;
- absolute (G90): ``@`` and ``^`` are the end point's distance and angle; a word left out
  keeps the current one (``@5`` alone moves along the current angle);
- incremental (G91): they are added to the current distance and angle from the origin;
- ``@`` is in the program's length unit (G20 / G21).
"""

from __future__ import annotations

import math
import re

from . import _kept as kept
from ._lexer import CANNED, GcodeError

__all__ = ["POLAR_WORD", "g_codes", "has_polar", "read_polar", "to_cartesian"]

POLAR_WORD = re.compile(r"([@^])[ \t]*([-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))")
#: G codes whose blocks LinuxCNC refuses polar words in (they are no moves)
NOT_MOTION = {4, 10, 28, 28.1, 30, 30.1, 52, 53}
G_WORD = re.compile(r"G[ \t]*([0-9]+(?:\.[0-9]+)?)", re.IGNORECASE)
XY_WORD = re.compile(r"(?<![A-Z])[XY][ \t]*[-+.0-9]", re.IGNORECASE)


def has_polar(masked: str) -> bool:
    """Whether a line's code (comments blanked) holds a polar word."""
    return "@" in masked or "^" in masked


def read_polar(reader, body: str, masked: str, number: int, state) -> str | None:
    """A line with polar words as the reader takes it: with X and Y in their place, or None for
    a drilling position (``G81 ... ^60 L6``), kept with its cycle (``state`` follows it: its
    modes set, the position unknown after it).

    Parameters are those of :func:`to_cartesian`.
    """
    if state.canned or state.regions or any(g in CANNED for g in g_codes(masked)):
        kept.skip(reader, POLAR_WORD.sub("", masked), state, None, number)
        state.lose_position(f"line {number}")
        return None
    return to_cartesian(reader, body, masked, number, state)


def g_codes(masked: str) -> list[float]:
    """The G codes of a line's code (comments blanked)."""
    return [float(m.group(1)) for m in G_WORD.finditer(masked)]


def _number(value: float) -> str:
    text = f"{value:.10f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def to_cartesian(reader, body: str, masked: str, number: int, state) -> str:
    """A line with its polar words replaced by the X and Y words they mean.

    Parameters
    ----------
    reader : Interpreter
        The program's interpreter (axes, units, origin).
    body, masked : str
        The line, and its code with comments blanked (same spans).
    number : int
        Its line number, for messages.
    state : ModalState
        The modal state before the block (its G codes are taken into account).

    Returns
    -------
    str
        The line, with ``X.. Y..`` where its first polar word stood and the other gone.

    Raises
    ------
    GcodeError
        Naming line and column: a polar word outside the XY plane, with X or Y, twice in one
        block, on a machine without X and Y, or from a position not known.
    """
    where = f"{reader.source}:{number}"
    words = list(POLAR_WORD.finditer(masked))
    bad = [i for i, c in enumerate(masked) if c in "@^" and not any(m.start() == i for m in words)]
    if bad:
        raise GcodeError(f"{where}:{bad[0] + 1}: '{masked[bad[0]]}' without a number (a polar word is @ or ^ and "
                         "a number)")
    letters = [m.group(1) for m in words]
    for c in "@^":
        if letters.count(c) > 1:
            raise GcodeError(f"{where}:{words[letters.index(c, letters.index(c) + 1)].start() + 1}: two {c} words "
                             "in one block")
    first = words[0].start() + 1
    if "X" not in reader.axes or "Y" not in reader.axes:
        raise GcodeError(f"{where}:{first}: polar coordinates (@ ^) need axes X and Y; {reader.machine.name} has "
                         f"{', '.join(reader.axes)}")
    code = masked.upper()
    xy = XY_WORD.search(code)
    if xy:
        raise GcodeError(f"{where}:{xy.start() + 1}: X or Y with polar coordinates (@ ^) in one block; LinuxCNC "
                         "refuses it")
    # (LinuxCNC asks for the plane in force before the block; its own distance and units apply)
    plane, absolute, inch = state.plane, state.absolute, state.inch
    for g in g_codes(code):
        absolute = True if g == 90 else (False if g == 91 else absolute)
        inch = True if g == 20 else (False if g == 21 else inch)
        if g in NOT_MOTION or int(g) == 92:
            raise GcodeError(f"{where}:{first}: polar coordinates (@ ^) in a G{g:g} block; LinuxCNC takes them "
                             "for moves only")
    if plane != 17:
        raise GcodeError(f"{where}:{first}: polar coordinates (@ ^) in the G{plane} plane; LinuxCNC takes them in "
                         "the XY plane (G17) only")
    if state.diameter:
        raise GcodeError(f"{where}:{first}: polar coordinates (@ ^) in lathe diameter mode (G7)")
    ix, iy = reader.axes.index("X"), reader.axes.index("Y")
    given = {m.group(1): float(m.group(2)) for m in words}
    needs_current = not absolute or len(given) < 2
    if needs_current and not (state.known[ix] and state.known[iy]):
        raise GcodeError(f"{where}:{first}: a polar word {'added to' if not absolute else 'beside'} the current "
                         "position, which is not known; program X and Y first")
    ux, uy = reader.to_si("X", 1.0, inch), reader.to_si("Y", 1.0, inch)
    x0 = (state.position[ix] - reader.origin[ix]) / ux
    y0 = (state.position[iy] - reader.origin[iy]) / uy
    r0, a0 = math.hypot(x0, y0), math.degrees(math.atan2(y0, x0))
    if r0 == 0 and (not absolute or "^" not in given):
        raise GcodeError(f"{where}:{first}: a polar word from the origin, where the angle is indeterminate; "
                         "LinuxCNC refuses it")
    if absolute:
        r, a = given.get("@", r0), given.get("^", a0)
    else:
        r, a = r0 + given.get("@", 0.0), a0 + given.get("^", 0.0)
    x, y = r * math.cos(math.radians(a)), r * math.sin(math.radians(a))
    if not absolute:
        x, y = x - x0, y - y0
    out, last = [], 0
    for k, m in enumerate(words):
        out.append(body[last:m.start()])
        if k == 0:
            out.append(f"X{_number(x)} Y{_number(y)}")
        last = m.end()
    out.append(body[last:])
    return "".join(out)
