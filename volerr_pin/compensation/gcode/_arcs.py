"""Reading the arc of a G2/G3 block: its centre from I/J/K or R, its turns from P."""

from __future__ import annotations

import math

import numpy as np

from .._arcs import RADIUS_SLACK, Arc, arc_from_center
from ...base import INCH, MM, InputError
from ._lexer import CENTRE, PLANES, Block, GcodeError

__all__ = ["ARC_SLACK", "MAX_ARC", "MAX_TURNS", "centre_from_radius", "read_arc"]

#: an arc's end may lie this far off its start's circle [m] (about what controllers accept);
#: an arc whose radius is not larger is degenerate: its end could lie anywhere around it
ARC_SLACK = 2e-6
#: the largest arc radius or centre offset read [m]: NC numbers hold nine digits (99999.9999 mm)
MAX_ARC = 100.0
#: the most whole turns (P) of one arc block
MAX_TURNS = 1000


#: the most an arc's radii may differ by for its numbers' rounding: an inch program's four decimals [m]
MOST_RADIUS_SLACK = 2 * math.sqrt(2) * 0.0001 * INCH


def radius_slack(block: Block, letters, scale: float) -> float:
    """How far an arc's start and end radii may differ [m]: :data:`RADIUS_SLACK`, or what
    the block's numbers, rounded to their last digit, may make of it, if more.

    A post that rounds its numbers to ``d`` decimals moves each coordinate by up to half a unit
    of the last digit, ``h / 2``: the start radius (the centre offsets) by up to ``h / sqrt(2)``,
    the end radius (the end, the start and the offsets) by up to three times that, so the two
    differ by up to ``2 sqrt(2) h``. An inch program to four decimals may so differ by 7.2 um,
    as controllers accept; a millimetre one to three by 2.8 um. Whole numbers are taken as
    exact, and programs of fewer digits get no more than :data:`MOST_RADIUS_SLACK` (LinuxCNC
    refuses 0.2 mm, which one decimal would allow).

    Parameters
    ----------
    block : Block
        The arc's block.
    letters : sequence of str
        The letters of its plane's coordinates, centre words and R.
    scale : float
        The program's unit [m] (mm or inch).

    Returns
    -------
    float
        The slack [m].
    """
    decimals = max((len(w.text) - w.text.index(".") - 1 for w in block.words if w.letter in letters and "." in w.text),
                   default=0)
    if not decimals:
        return RADIUS_SLACK
    return max(RADIUS_SLACK, min(2 * math.sqrt(2) * 10.0 ** -decimals * scale, MOST_RADIUS_SLACK))


def centre_from_radius(start: np.ndarray, end: np.ndarray, radius: float, clockwise: bool) -> np.ndarray | None:
    """The centre of the arc of a given radius between two points of its plane.

    Parameters
    ----------
    start, end : numpy.ndarray, shape (2,)
        The ends in the arc plane [m].
    radius : float
        The radius [m]; negative for the arc of more than half a turn (the R word's sign).
    clockwise : bool
        G2 (True) or G3 (False).

    Returns
    -------
    numpy.ndarray, shape (2,), or None
        The centre [m]; None when no circle of that radius joins the ends (they are more
        than a diameter apart, or the same point).
    """
    d = end - start
    chord = math.hypot(*d)
    a = abs(radius)
    if chord < 1e-12 or chord > 2 * a * (1 + 1e-9):
        return None
    h = math.sqrt(max((a - chord / 2) * (a + chord / 2), 0.0))
    normal = np.array([-d[1], d[0]]) / chord
    side = (1 if clockwise else -1) * (-1 if radius < 0 else 1)
    return start + d / 2 - side * h * normal


def read_arc(block: Block, where: str, axes: list[str], linear: list[bool], start: np.ndarray, target: np.ndarray,
             clockwise: bool, plane_code: int, inch: bool, warn, absolute_origin: np.ndarray | None = None) -> Arc:
    """The arc of a G2/G3 block, from its centre words (I/J/K) or radius (R).

    Parameters
    ----------
    block : Block
        The block: I/J/K centre offsets from the start (absolute centre coordinates with
        ``absolute_origin``), or R (negative for more than half a turn), in the program's
        units; both only if they give the same centre; P whole turns (default 1).
    where : str
        ``source:line`` for messages.
    axes : list of str
        The machine's axis letters.
    linear : list of bool
        Which axes are linear.
    start, target : numpy.ndarray, shape (n_axes,)
        Program coordinates at the ends [m, rad].
    clockwise : bool
        G2 (True) or G3 (False).
    plane_code : int
        17, 18 or 19.
    inch : bool
        Coordinates in inch (G20).
    warn : callable
        ``warn(line, text)`` notes something kept but not read.
    absolute_origin : numpy.ndarray, shape (n_axes,), optional
        With arc centres in absolute distance mode (G90.1): the program's origin [m, rad],
        which I/J/K are read from, as axis words are; then both centre words of the plane
        must be given. None (G91.1, the default): I/J/K are offsets from the start.
    Returns
    -------
    Arc
        The desired arc, in program coordinates [m, rad].

    Raises
    ------
    GcodeError
        The plane's two axes are not linear axes of the machine, the centre words are
        missing, R cannot join the end points, R and I/J/K disagree, the radius is zero
        or degenerate (not more than :data:`ARC_SLACK`) or too large (:data:`MAX_ARC`),
        P is not a whole number of turns from 1 to :data:`MAX_TURNS`, the start and
        end radii differ, or (G90.1) one of the plane's centre words is missing.
    """
    plane = PLANES[plane_code]
    if not all(a in axes and linear[axes.index(a)] for a in plane[:2]):
        raise GcodeError(f"{where}: an arc in G{plane_code} needs linear axes {plane[0]} and {plane[1]}")
    # the third (helical) axis may be missing: a 2-axis lathe turns its arcs in G18 (Z, X) alone
    i, j = axes.index(plane[0]), axes.index(plane[1])
    k = axes.index(plane[2]) if plane[2] in axes else -1
    words = {w.letter: w for w in block.words}
    scale = INCH if inch else MM
    unit = "inch" if inch else "mm"
    offs = [CENTRE[plane[0]], CENTRE[plane[1]]]
    third = words.get(CENTRE[plane[2]])
    if third is not None:
        warn(block.number, f"{third.name} is not a centre word of a G{plane_code} arc (its centre words are "
             f"{offs[0]} and {offs[1]}): kept unchanged, not read")
    big = [w for w in block.words if w.letter in offs + ["R"] and abs(w.value) * scale > MAX_ARC]
    if big:
        raise GcodeError(f"{where}:{big[0].start + 1}: {big[0].name}: an arc radius or centre offset over "
                         f"{MAX_ARC:g} m; NC numbers hold nine digits (program a line)")
    centre = None
    named = [words[o] for o in offs if o in words]
    if named and absolute_origin is not None:
        missing = [o for o in offs if o not in words]
        if missing:
            raise GcodeError(f"{where}: an arc with absolute centres (G90.1) needs both {offs[0]} and {offs[1]}; "
                             f"{missing[0]} is missing")
        centre = np.array([words[offs[0]].value * scale + float(absolute_origin[i]),
                           words[offs[1]].value * scale + float(absolute_origin[j])])
        offset = [float(centre[0] - start[i]), float(centre[1] - start[j])]
    elif named:
        # (on plain floats: the arithmetic of the arrays s + offset, one arc block at a time)
        offset = [(words[o].value if o in words else 0.0) * scale for o in offs]
        centre = np.array([float(start[i]) + offset[0], float(start[j]) + offset[1]])
    if named:
        r0 = math.hypot(*offset)
        if r0 <= ARC_SLACK:
            text = " ".join(w.name for w in named)
            raise GcodeError(f"{where}: a degenerate arc ({text}): its radius {r0 / scale:.6g} {unit} is zero "
                             f"or not more than the {ARC_SLACK * 1e6:g} um its end may lie off its circle; "
                             "program a line")
    if "R" in words:
        s, e = start[[i, j]], target[[i, j]]
        rw = words["R"]
        r = rw.value * scale
        if abs(r) <= ARC_SLACK:
            raise GcodeError(f"{where}:{rw.start + 1}: a degenerate arc ({rw.name}): a radius of zero or not "
                             f"more than the {ARC_SLACK * 1e6:g} um its end may lie off its circle; program a line")
        from_r = centre_from_radius(s, e, r, clockwise)
        if from_r is None:
            chord = math.hypot(*(e - s))
            if chord < 1e-12:
                why = f"R cannot program a full circle (start and end are one point): use {offs[0]}/{offs[1]}"
            else:
                why = f"the end points are {chord / scale:.4f} {unit} apart, more than its diameter"
            raise GcodeError(f"{where}:{rw.start + 1}: {rw.name} cannot join these end points: {why}")
        if centre is not None and math.hypot(*(from_r - centre)) > ARC_SLACK:
            text = " ".join(w.name for w in named)
            raise GcodeError(f"{where}:{rw.start + 1}: {rw.name} and {text} disagree: their centres are "
                             f"{math.hypot(*(from_r - centre)) / scale:.4f} {unit} apart; give one of them")
        if centre is None:
            centre = from_r
    if centre is None:
        raise GcodeError(f"{where}: an arc needs {offs[0]}/{offs[1]} or R")
    turns = 1.0
    if "P" in words:
        turns = words["P"].value
        if turns != int(turns) or not 1 <= turns <= MAX_TURNS:
            raise GcodeError(f"{where}:{words['P'].start + 1}: {words['P'].name} on an arc must be a whole number "
                             f"of turns from 1 to {MAX_TURNS} (split a longer helix into blocks)")
    try:
        return arc_from_center(start, target, centre, (i, j, k), clockwise, full_turns=int(turns) - 1,
                               radius_slack=radius_slack(block, plane[:2] + tuple(offs) + ("R",), scale))
    except InputError as err:
        raise GcodeError(f"{where}: {err}") from None
