"""Arc pieces as written: their centre words, and the arc a controller reads back from them.

The numbers of an arc block are rounded like every other; a small arc's centre words can
round to zero, or to a centre whose circle misses the written end points, or turn a short arc
into nearly a full circle. Every arc piece is read back from its written numbers, as a
controller reads it, and one whose path leaves the piece's by more than the tolerance allows
is written as straight pieces (chords) instead.
"""

from __future__ import annotations

import math

import numpy as np

from .._arcs import RADIUS_SLACK, sweep_of, sweeps
from .._path import Piece
from ...base import INCH, MM
from ._arcs import ARC_SLACK, centre_from_radius
from ._lexer import CENTRE, DIAMETER_AXIS, PLANES, Block

__all__ = ["ArcWords", "arc_errors"]

#: digits a written number may have (controllers read nine: 99999.9999 mm)
MAX_DIGITS = 9
#: fractions of an arc piece at which the arc read back is compared with it
_FRACTIONS = [k / 16 for k in range(17)]


class ArcWords:
    """Writes the centre words of arc pieces and checks the arcs they give back.

    ``st`` in the methods is the output state, as for :class:`~volerr_pin.compensation.gcode._rewrite.Writer`.

    Parameters
    ----------
    writer : Writer
        The writer whose numbers (decimals, rounding, origin) and tolerance are used.

    Attributes
    ----------
    writer : Writer
        As given.
    """

    def __init__(self, writer):
        self.writer = writer

    def centre_words(self, piece, prev, st: dict, forms: set) -> list[str]:
        """The centre words of an arc piece as written (``I..``, ``J..``, ``R..``).

        Parameters
        ----------
        piece : Piece
            The arc piece.
        prev : array_like, shape (n_axes,)
            Its start [m, rad].
        st : dict
            Output state.
        forms : set of str
            ``"ijk"`` and/or ``"r"``.

        Returns
        -------
        list of str
            The words.
        """
        plane = PLANES[st["plane"]]
        return [f"{letter}{self.writer.fmt(plane[0], value, st['inch'])}"
                for letter, value in self.centre_values(piece, prev, st, forms).items()]

    @staticmethod
    def forms(block: Block, st: dict) -> set:
        """The centre forms an arc block is written in: "ijk" (centre offsets), "r" (radius).

        Parameters
        ----------
        block : Block
            The block.
        st : dict
            Output state (its plane).

        Returns
        -------
        set of str
            The forms.
        """
        plane = PLANES[st["plane"]]
        letters = {w.letter for w in block.words}
        forms = {"r"} if "R" in letters else set()
        if letters & {CENTRE[plane[0]], CENTRE[plane[1]]}:
            forms.add("ijk")
        return forms

    def centre_values(self, piece, prev, st: dict, forms: set, written=None) -> dict[str, float]:
        """The centre words of an arc piece, rounded as written: offsets from the written
        start (with arc centres in absolute distance mode, ``st["centres_absolute"]``, G90.1:
        the centre's program coordinates), and a radius that puts the centre where it is.

        Parameters
        ----------
        piece : Piece
            The arc piece.
        prev : array_like, shape (n_axes,)
            Its start [m, rad].
        st : dict
            Output state.
        forms : set of str
            ``"ijk"`` and/or ``"r"``.
        written : tuple of ndarray, optional
            The start and end as their written numbers give them back
            (:meth:`~volerr_pin.compensation.gcode._rewrite.Writer.written`), if the caller has them.

        Returns
        -------
        dict of str to float
            ``I``/``J``/``K`` and/or ``R`` in program units.
        """
        reader, inch = self.writer.reader, st["inch"]
        plane = PLANES[st["plane"]]
        i, j = reader.axes.index(plane[0]), reader.axes.index(plane[1])
        d = self.writer.digits(plane[0], inch)
        s = self.writer.written(prev, inch, st.get("diameter", False)) if written is None else written[0]
        out = {}
        if "ijk" in forms:
            origin = self.writer.origin if st.get("centres_absolute") else None
            for axis, c, k in ((plane[0], piece.center[0], i), (plane[1], piece.center[1], j)):
                base = s[k] if origin is None else origin[k]
                out[CENTRE[axis]] = round(reader.from_si(axis, float(c - base), inch), d)
        if "r" in forms:
            e = self.writer.written(piece.end, inch, st.get("diameter", False)) if written is None else written[1]
            r = 0.5 * (math.hypot(s[i] - piece.center[0], s[j] - piece.center[1]) +
                       math.hypot(e[i] - piece.center[0], e[j] - piece.center[1]))
            out["R"] = round(reader.from_si(plane[0], float(-r if abs(piece.turns) > math.pi else r), inch), d)
        return out

    @staticmethod
    def piece_points(piece, plane: tuple[int, int], u: np.ndarray) -> np.ndarray:
        """Points of an arc piece's commanded path at fractions ``u``.

        Parameters
        ----------
        piece : Piece
            The arc piece.
        plane : tuple of int
            Indices of the plane coordinates.
        u : numpy.ndarray, shape (M,)
            Fractions of the piece.

        Returns
        -------
        numpy.ndarray, shape (M, n_axes)
            Program coordinates [m, rad].
        """
        i, j = plane
        c = piece.center
        a0 = math.atan2(piece.start[j] - c[1], piece.start[i] - c[0])
        r = math.hypot(piece.start[i] - c[0], piece.start[j] - c[1])
        out = piece.start + np.outer(u, piece.end - piece.start)
        out[:, i] = c[0] + r * np.cos(a0 + u * piece.turns)
        out[:, j] = c[1] + r * np.sin(a0 + u * piece.turns)
        return out

    def arc_error(self, piece, prev, st: dict, forms: set, written=None) -> float:
        """How far the arc a controller reads from a piece's written numbers leaves the
        piece's path [m] (inf if the numbers define no arc, or have too many digits).

        Parameters
        ----------
        piece : Piece
            The arc piece.
        prev : array_like, shape (n_axes,)
            Its start [m, rad].
        st : dict
            Output state.
        forms : set of str
            ``"ijk"`` and/or ``"r"``.
        written : tuple of ndarray, optional
            The start and end as their written numbers give them back, if the caller has
            them.

        Returns
        -------
        float
            The largest distance over 17 points at equal fractions of both arcs (linear
            axes) [m].
        """
        reader, inch = self.writer.reader, st["inch"]
        plane = PLANES[st["plane"]]
        i, j = (reader.axes.index(a) for a in plane[:2])
        if written is None:
            diameter = st.get("diameter", False)
            written = self.writer.written(prev, inch, diameter), self.writer.written(piece.end, inch, diameter)
        s, e = written
        vals = self.centre_values(piece, prev, st, forms, written)
        if any(abs(v) >= 10.0 ** (MAX_DIGITS - self.writer.digits(plane[0], inch)) for v in vals.values()):
            return math.inf
        scale = INCH if inch else MM
        centre = None
        if "ijk" in forms:
            words = np.array([vals[CENTRE[plane[0]]], vals[CENTRE[plane[1]]]]) * scale
            # as a controller reads them: from the written start, or (G90.1) from the origin
            if st.get("centres_absolute"):
                centre = self.writer.origin[[i, j]] + words
                offset = centre - s[[i, j]]
            else:
                offset = words
                centre = s[[i, j]] + offset
            if math.hypot(*offset) <= ARC_SLACK:
                return math.inf
        if "r" in forms:
            r = vals["R"] * scale
            from_r = None if abs(r) <= ARC_SLACK else centre_from_radius(s[[i, j]], e[[i, j]], r, piece.clockwise)
            if from_r is None or (centre is not None and math.hypot(*(from_r - centre)) > ARC_SLACK):
                return math.inf
            centre = from_r if centre is None else centre
        # the arc a controller reads (as :func:`~volerr_pin.compensation.arc_from_center`
        # builds it), in scalars: this runs for every arc piece written
        s, e = s.tolist(), e.tolist()
        cx, cy = float(centre[0]), float(centre[1])
        r0 = math.hypot(s[i] - cx, s[j] - cy)
        r1 = math.hypot(e[i] - cx, e[j] - cy)
        if not (math.isfinite(cx) and math.isfinite(cy)) or r0 == 0.0 or abs(r0 - r1) > RADIUS_SLACK:
            return math.inf
        a0 = math.atan2(s[j] - cy, s[i] - cx)
        a1 = math.atan2(e[j] - cy, e[i] - cx)
        sweep = sweep_of(a0, a1, piece.clockwise)
        if abs(sweep - piece.turns) > math.pi / 2:
            return math.inf  # read as (nearly) the rest of the circle
        # against the piece's own arc (piece_points), point by point
        p0, p1 = piece.start.tolist(), piece.end.tolist()
        pcx, pcy = float(piece.center[0]), float(piece.center[1])
        pa0 = math.atan2(p0[j] - pcy, p0[i] - pcx)
        pr = math.hypot(p0[i] - pcx, p0[j] - pcy)
        turns = float(piece.turns)
        # the other linear axes move linearly on both: their gap is linear in the fraction
        others = [(s[k] - p0[k], (e[k] - s[k]) - (p1[k] - p0[k]))
                  for k, lin in enumerate(reader.linear) if lin and k not in (i, j)]
        cos, sin = math.cos, math.sin
        worst = 0.0
        for u in _FRACTIONS:
            angle, radius, own = a0 + u * sweep, r0 + u * (r1 - r0), pa0 + u * turns
            dx = cx + radius * cos(angle) - (pcx + pr * cos(own))
            dy = cy + radius * sin(angle) - (pcy + pr * sin(own))
            gap = dx * dx + dy * dy
            for offset, slope in others:
                d = offset + u * slope
                gap += d * d
            if gap > worst:
                worst = gap
        return math.sqrt(worst)

    def writable(self, pieces: list, st: dict, forms: set, errors=None) -> list:
        """The pieces of a move with every arc the written numbers cannot hold within the
        tolerance replaced by straight pieces (chords) along it.

        Rounding moves a well-formed written arc by a few half-units of the last digit (its
        centre, radius and ends each by up to 0.07 um in mm): that much is always accepted,
        so that only arcs the numbers define badly become chords.

        Parameters
        ----------
        pieces : list of Piece
            The pieces of one move.
        st : dict
            Output state.
        forms : set of str
            The centre forms of the original block.
        errors : sequence of float, optional
            Per piece, :func:`arc_errors` as computed for the whole chunk (used for pieces written
            with centre offsets).

        Returns
        -------
        list of Piece
            The pieces as they can be written.
        """
        plane = PLANES[st["plane"]]
        rounding = 8 * 0.5 * 10.0 ** -self.writer.digits(plane[0], st["inch"]) * (INCH if st["inch"] else MM)
        out = []
        prev = pieces[0].start
        written = self.writer.written
        start = None  # prev as written, when known
        for n, piece in enumerate(pieces):
            # the original block keeps its centre form; inserted blocks use I/J/K
            piece_forms = (forms or {"ijk"}) if n == 0 else {"ijk"}
            end = None
            if piece.kind == "arc":
                if errors is not None and piece_forms == {"ijk"}:
                    error = errors[n]
                else:
                    start = written(prev, st["inch"], st.get("diameter", False)) if start is None else start
                    end = written(piece.end, st["inch"], st.get("diameter", False))
                    error = self.arc_error(piece, prev, st, piece_forms, (start, end))
                if error > max(self.writer.tol - piece.residual, rounding):
                    out.extend(self.chords(piece, st))
                else:
                    out.append(piece)
            else:
                out.append(piece)
            prev, start = piece.end, end
        return out

    def chords(self, piece, st: dict) -> list:
        """An arc piece as straight pieces whose sagitta keeps the tolerance.

        Parameters
        ----------
        piece : Piece
            The arc piece.
        st : dict
            Output state (its plane).

        Returns
        -------
        list of Piece
            Straight pieces from the arc's start to its end, their ends on the arc.
        """
        plane = PLANES[st["plane"]]
        i, j = self.writer.reader.axes.index(plane[0]), self.writer.reader.axes.index(plane[1])
        r = math.hypot(piece.start[i] - piece.center[0], piece.start[j] - piece.center[1])
        sweep = abs(piece.turns)
        allowed = max(self.writer.tol - piece.residual - self.writer.margin, 0.25 * self.writer.margin)
        n = 1 if r <= allowed else max(1, math.ceil(sweep / (2 * math.acos(1 - allowed / r))))
        u = np.linspace(0.0, 1.0, n + 1)
        points = self.piece_points(piece, (i, j), u)
        points[0], points[-1] = piece.start, piece.end
        sagitta = r * (1 - math.cos(sweep / (2 * n)))
        ks = piece.k0 + u * (piece.k1 - piece.k0)
        return [Piece("line", points[m], points[m + 1], residual=piece.residual + sagitta, k0=ks[m], k1=ks[m + 1],
                      limited=piece.limited) for m in range(n)]


def arc_errors(writer, start: np.ndarray, end: np.ndarray, center: np.ndarray, turns: np.ndarray,
           plane: np.ndarray, inch: np.ndarray, absolute: np.ndarray | None = None,
           diameter: np.ndarray | None = None) -> np.ndarray:
    """:meth:`ArcWords.arc_error` of many arc pieces at once, written with centre words (I/J/K)
    after the piece before them (the start as written is the piece's start rounded).

    The arithmetic is :meth:`arc_error`'s on arrays; the numbers are rounded to their
    decimals as NumPy rounds (which may differ from the written digits by a unit of the
    last place of a double at an exact half), so the two agree to a few 1e-16 m.

    Parameters
    ----------
    writer : Writer
        The writer whose numbers (decimals, rounding, origin) are used.
    start, end : ndarray, shape (P, n_axes)
        Program coordinates of the pieces' ends [m, rad].
    center : ndarray, shape (P, 2)
        Their centres in their plane [m].
    turns : ndarray, shape (P,)
        Their signed sweeps [rad] (< 0 clockwise).
    plane : ndarray of int, shape (P,)
        Their planes (17, 18, 19).
    inch : ndarray of bool, shape (P,)
        Whether they are written in inch.
    absolute : ndarray of bool, shape (P,), optional
        Whether their centres are written as absolute coordinates (G90.1) rather than as
        offsets from the start (default: offsets).
    diameter : ndarray of bool, shape (P,), optional
        Whether X is written as a diameter (G7; default: a radius).

    Returns
    -------
    ndarray, shape (P,)
        [m]; inf where the numbers define no arc, have too many digits, or define the
        rest of the circle.
    """
    reader = writer.reader
    count = len(turns)
    if count == 0:
        return np.zeros(0)
    axes = reader.axes
    # a plane whose axes the machine lacks holds no arc (a 2-axis lathe has only G18's)
    ij = np.array([[axes.index(PLANES[code][0]), axes.index(PLANES[code][1])]
                   if PLANES[code][0] in axes and PLANES[code][1] in axes else [0, 0] for code in (17, 18, 19)])
    plane_ij = ij[np.asarray(plane) - 17]
    rows = np.arange(count)
    i, j = plane_ij[:, 0], plane_ij[:, 1]
    inch = np.asarray(inch, dtype=bool)
    origin = writer.origin
    scale = np.where(inch[:, None], [[reader._scale[a, True] for a in axes]],
                     [[reader._scale[a, False] for a in axes]])
    digits = np.where(inch[:, None], [[writer.digits(a, True) for a in axes]],
                      [[writer.digits(a, False) for a in axes]])
    power = 10.0 ** digits
    # positions as written: an X word in diameter mode (G7) is twice the radius; centre words
    # (I) stay radii
    halved = np.zeros(count, dtype=bool) if diameter is None else np.asarray(diameter, dtype=bool)
    position_scale = np.where(halved[:, None] & (np.array(axes) == DIAMETER_AXIS), 0.5 * scale, scale)

    def written(q):
        return np.rint((q - origin) / position_scale * power) / power * position_scale + origin

    s, e = written(start), written(end)
    d = digits[rows, i]
    unit = scale[rows, i]
    # the centre words are offsets from the written start, or (G90.1) coordinates from the origin
    absolute = np.zeros(count, dtype=bool) if absolute is None else np.asarray(absolute, dtype=bool)
    base_i = np.where(absolute, origin[i], s[rows, i])
    base_j = np.where(absolute, origin[j], s[rows, j])
    words = np.stack([np.rint((center[:, 0] - base_i) / unit * 10.0 ** d) / 10.0 ** d,
                      np.rint((center[:, 1] - base_j) / unit * 10.0 ** d) / 10.0 ** d], axis=1)
    bad = (np.abs(words) >= 10.0 ** (MAX_DIGITS - d)[:, None]).any(axis=1)
    cx, cy = base_i + words[:, 0] * unit, base_j + words[:, 1] * unit
    radius = np.where(absolute, np.hypot(cx - s[rows, i], cy - s[rows, j]),
                      np.hypot(words[:, 0] * unit, words[:, 1] * unit))
    bad |= radius <= ARC_SLACK
    r0 = np.hypot(s[rows, i] - cx, s[rows, j] - cy)
    r1 = np.hypot(e[rows, i] - cx, e[rows, j] - cy)
    bad |= ~(np.isfinite(cx) & np.isfinite(cy)) | (r0 == 0.0) | (np.abs(r0 - r1) > RADIUS_SLACK)
    a0 = np.arctan2(s[rows, j] - cy, s[rows, i] - cx)
    a1 = np.arctan2(e[rows, j] - cy, e[rows, i] - cx)
    sweep = sweeps(a0, a1, turns >= 0)
    bad |= np.abs(sweep - turns) > math.pi / 2
    # against the piece's own arc, at the same fractions
    pcx, pcy = center[:, 0], center[:, 1]
    pa0 = np.arctan2(start[rows, j] - pcy, start[rows, i] - pcx)
    pr = np.hypot(start[rows, i] - pcx, start[rows, j] - pcy)
    u = np.array(_FRACTIONS)
    angle = a0[:, None] + u * sweep[:, None]
    radius = r0[:, None] + u * (r1 - r0)[:, None]
    own = pa0[:, None] + u * turns[:, None]
    dx = cx[:, None] + radius * np.cos(angle) - (pcx[:, None] + pr[:, None] * np.cos(own))
    dy = cy[:, None] + radius * np.sin(angle) - (pcy[:, None] + pr[:, None] * np.sin(own))
    gap = dx * dx + dy * dy
    linear = np.array(reader.linear)
    for k in np.flatnonzero(linear):
        other = (i != k) & (j != k)
        if other.any():
            slope = (e[:, k] - s[:, k]) - (end[:, k] - start[:, k])
            dk = (s[:, k] - start[:, k])[:, None] + u * slope[:, None]
            gap += np.where(other[:, None], dk * dk, 0.0)
    with np.errstate(invalid="ignore"):
        out = np.sqrt(gap.max(axis=1))
    out[bad | ~np.isfinite(out)] = math.inf
    return out
