"""Writing compensated pieces back into the text of a program.

A compensated block keeps its text: only the numbers of its coordinate words change (axes it
did not name are appended, since compensation moves every axis; an arc's centre words are
replaced likewise), and the further pieces of a split move follow as new blocks with explicit
G words. Numbers are written to 0.1 um (mm), 0.025 um (inch) and 1e-5 deg.

The numbers of an arc block are rounded like every other; a small arc's centre words can
round to zero, or to a centre whose circle misses the written end points, or turn a short arc
into nearly a full circle. Every arc piece is read back from its written numbers, as a
controller reads it, and one whose path leaves the piece's by more than the tolerance allows
is written as straight pieces (chords) instead.
"""

from __future__ import annotations

import math

import numpy as np

from ..compensation.arcs import arc_from_center
from ..compensation.path import Piece
from ..errors import InputError
from ..units import INCH, MM
from .arcs import ARC_SLACK, centre_from_radius
from .lexer import CENTRE, LATE_M, PLANES, Block, Word
from .modal import Interpreter

__all__ = ["MAX_DIGITS", "Writer"]

#: digits a written number may have (controllers read nine: 99999.9999 mm)
MAX_DIGITS = 9


class Writer:
    """Writes the pieces of compensated moves as program text.

    ``st`` in the methods is the output state: the modes the block is written in
    (``"absolute"``, ``"inch"``, ``"plane"``, ``"all_known"``) and the output's modal motion
    (``"out_motion"``, updated as lines are written).

    Parameters
    ----------
    reader : Interpreter
        The program's interpreter (axes, units, origin).
    tol : float
        The position tolerance of the written program [m].
    margin : float
        What the rounding of the written numbers may add [m].

    Attributes
    ----------
    reader : Interpreter
        As given.
    tol, margin : float
        As given.
    """

    def __init__(self, reader: Interpreter, tol: float, margin: float):
        self.reader = reader
        self.tol = tol
        self.margin = margin
        self._digits = {(a, inch): (6 if inch else 4) if lin else 5
                        for a, lin in zip(reader.axes, reader.linear) for inch in (False, True)}
        self._zero = {d: "-0." + "0" * d for d in (4, 5, 6)}
        self._origin = [float(v) for v in reader.origin]

    # numbers --------------------------------------------------------------------
    def digits(self, axis: str, inch: bool) -> int:
        """Decimals written for an axis: 4 (mm: 0.1 um), 6 (inch: 0.025 um), 5 (deg).

        Parameters
        ----------
        axis : str
            The axis letter.
        inch : bool
            Whether linear values are written in inch.

        Returns
        -------
        int
            Decimals.
        """
        return self._digits[axis, inch]

    def fmt(self, axis: str, value: float, inch: bool) -> str:
        """A value written with the axis' decimals (never ``-0.0000``).

        Parameters
        ----------
        axis : str
            The axis letter.
        value : float
            The value in program units (mm, inch or deg).
        inch : bool
            Whether linear values are in inch.

        Returns
        -------
        str
            The number as written.
        """
        digits = self._digits[axis, inch]
        text = f"{value:.{digits}f}"
        return text[1:] if text == self._zero[digits] else text

    def values(self, end, prev, st: dict) -> dict[str, str]:
        """Coordinate words of a piece's end. Incremental values are differences of the
        rounded absolute positions, so rounding never accumulates along a G91 section.

        Parameters
        ----------
        end, prev : sequence of float, shape (n_axes,)
            Program coordinates of the piece's end and start [m, rad] (origin included).
        st : dict
            Output state.

        Returns
        -------
        dict of str to str
            The number of each axis as written.
        """
        reader, inch = self.reader, st["inch"]
        out = {}
        for j, axis in enumerate(reader.axes):
            d = self._digits[axis, inch]
            value = round(reader.from_si(axis, float(end[j]) - self._origin[j], inch), d)
            if not st["absolute"]:
                value -= round(reader.from_si(axis, float(prev[j]) - self._origin[j], inch), d)
            out[axis] = self.fmt(axis, value, inch)
        return out

    def written(self, q, inch: bool) -> np.ndarray:
        """Program coordinates [m, rad] as the written (rounded) numbers give them back.

        Parameters
        ----------
        q : array_like, shape (n_axes,)
            Program coordinates [m, rad].
        inch : bool
            Whether linear values are written in inch.

        Returns
        -------
        numpy.ndarray, shape (n_axes,)
            The coordinates the written numbers mean.
        """
        reader = self.reader
        out = [float(v) for v in q]  # Python floats: round() of a numpy scalar is ten times slower
        for j, axis in enumerate(reader.axes):
            v = round(reader.from_si(axis, out[j] - self._origin[j], inch), self._digits[axis, inch])
            out[j] = reader.to_si(axis, v, inch) + self._origin[j]
        return np.array(out)

    # moves ------------------------------------------------------------------------
    def write_move(self, block: Block, newline: str, eol: str, motion: int, coord_words: list[Word],
                   pieces: list, st: dict) -> tuple[list[str], list]:
        """The lines of a compensated move: the original block carries the first piece (so its
        F, S, T, M and modal words act where they did); the further pieces follow as new
        blocks with explicit G words, and M codes that act at the end of the move (M0, M1, M2,
        M5, M9, M30) move to the last.

        Parameters
        ----------
        block : Block
            The move's block.
        newline : str
            Its line ending (may be empty on the last line).
        eol : str
            The line ending of inserted lines.
        motion : int
            The block's motion mode (0-3).
        coord_words : list of Word
            Its coordinate words.
        pieces : list of Piece
            The compensated pieces (program coordinates).
        st : dict
            Output state (updated).

        Returns
        -------
        lines : list of str
            The text, line endings included.
        pieces : list of Piece
            The pieces as written (arcs the numbers cannot hold replaced by chords).
        """
        forms = self.forms(block, st) if motion in (2, 3) else set()
        if forms or any(p.kind == "arc" for p in pieces):
            pieces = self.writable(pieces, st, forms)
        late = [w for w in block.words if w.letter == "M" and w.value in LATE_M] if len(pieces) > 1 else []
        eol = newline if newline else eol
        prev = pieces[0].start
        first = self.rewrite(block, pieces[0], prev, st, motion, coord_words, drop=late,
                             append_missing=st["all_known"])
        lines = [first + (eol if len(pieces) > 1 else newline)]
        prev = pieces[0].end
        for n, piece in enumerate(pieces[1:], start=2):
            text = self.new_line(piece, prev, st, motion)
            lines.append(text + "".join(" " + w.text for w in late) + newline if n == len(pieces) else text + eol)
            prev = piece.end
        return lines, pieces

    @staticmethod
    def g_of(piece, motion: int) -> int:
        """The motion code a piece is written with.

        Parameters
        ----------
        piece : Piece
            The piece.
        motion : int
            The block's motion mode.

        Returns
        -------
        int
            2 or 3 for arcs, the block's 0 or 1 for straight pieces (1 for an arc turned straight).
        """
        if piece.kind == "arc":
            return 2 if piece.clockwise else 3
        return motion if motion in (0, 1) else 1

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
        return [f"{letter}{self.fmt(plane[0], value, st['inch'])}"
                for letter, value in self.centre_values(piece, prev, st, forms).items()]

    def new_line(self, piece, prev, st: dict, motion: int) -> str:
        """An inserted block for a further piece: G word, every axis, centre words of an arc.

        Parameters
        ----------
        piece : Piece
            The piece.
        prev : array_like, shape (n_axes,)
            Its start [m, rad].
        st : dict
            Output state (updated).
        motion : int
            The block's motion mode.

        Returns
        -------
        str
            The block, without line ending.
        """
        vals = self.values(piece.end, prev, st)
        g = self.g_of(piece, motion)
        words = [f"G{g}"] + [f"{a}{vals[a]}" for a in self.reader.axes]
        if piece.kind == "arc":
            words += self.centre_words(piece, prev, st, {"ijk"})
        st["out_motion"] = g
        return " ".join(words)

    def rewrite(self, block: Block, piece, prev, st: dict, motion: int, coord_words: list[Word], drop=(),
                append_missing: bool = True) -> str:
        """The original line with the numbers of its coordinate words replaced in place;
        axes it did not name are appended after its last coordinate word. For an arc the
        centre words are replaced likewise; an arc piece that had to become a line gets G1
        and loses its centre words. A block that relied on the modal motion gets an explicit
        motion word when the output's modal motion differs.

        Parameters
        ----------
        block : Block
            The block.
        piece : Piece
            Its first piece.
        prev : array_like, shape (n_axes,)
            The piece's start [m, rad].
        st : dict
            Output state (updated).
        motion : int
            The block's motion mode.
        coord_words : list of Word
            Its coordinate words.
        drop : sequence of Word
            Words to remove (with their separating space).
        append_missing : bool
            Append the axes the block does not name (false while some axes' positions are
            still unknown: those axes are not commanded).

        Returns
        -------
        str
            The block's new text, without line ending.
        """
        vals = self.values(piece.end, prev, st)
        text = block.text
        # a word keeps the case its letter is written in
        edits = [(w.start, w.end, text[w.start] + vals[w.letter]) for w in coord_words]
        present = {w.letter for w in coord_words}
        extra = [f"{a}{vals[a]}" for a in self.reader.axes if a not in present] if append_missing else []

        def remove(w):
            start = w.start
            if start > 0 and text[start - 1] in " \t":
                start -= 1  # a removed word takes its separating space with it
            edits.append((start, w.end, ""))

        for w in drop:
            remove(w)
        anchor = max(w.end for w in coord_words)
        g_new = self.g_of(piece, motion)
        motion_words = [w for w in block.words if w.letter == "G" and w.value in (0, 1, 2, 3)]
        if motion_words:
            last = motion_words[-1]
            if int(last.value) != g_new:
                edits.append((last.start, last.end, f"G{g_new}"))
        elif st["out_motion"] != g_new:
            first = min(w.start for w in coord_words)
            edits.append((first, first, f"G{g_new} "))
        st["out_motion"] = g_new
        if motion in (2, 3):
            plane = PLANES[st["plane"]]
            letters = (CENTRE[plane[0]], CENTRE[plane[1]], "R")
            centre_words = [w for w in block.words if w.letter in letters]
            new = ({t[0]: t for t in self.centre_words(piece, prev, st, self.forms(block, st))}
                   if piece.kind == "arc" else {})
            for w in centre_words:
                replacement = new.pop(w.letter, "")
                if replacement:
                    edits.append((w.start, w.end, text[w.start] + replacement[1:]))
                else:
                    remove(w)
            for w in block.words:  # turns (P): every piece is less than a quarter turn
                if w.letter == "P":
                    remove(w)
            extra += list(new.values())
            anchor = max([anchor] + [w.end for w in centre_words])
        if extra:
            edits.append((anchor, anchor, " " + " ".join(extra)))
        edits.sort(key=lambda e: (e[0], e[1]))
        parts, at = [], 0
        for start, end, rep in edits:
            parts.append(text[at:start])
            parts.append(rep)
            at = max(at, end)
        parts.append(text[at:])
        return "".join(parts)

    # arcs as written ------------------------------------------------------------
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

    def centre_values(self, piece, prev, st: dict, forms: set) -> dict[str, float]:
        """The centre words of an arc piece, rounded as written: offsets from the written
        start, and a radius that puts the centre where it is.

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
        dict of str to float
            ``I``/``J``/``K`` and/or ``R`` in program units.
        """
        reader, inch = self.reader, st["inch"]
        plane = PLANES[st["plane"]]
        i, j = reader.axes.index(plane[0]), reader.axes.index(plane[1])
        d = self._digits[plane[0], inch]
        s = self.written(prev, inch)
        out = {}
        if "ijk" in forms:
            for axis, c, p in ((plane[0], piece.center[0], s[i]), (plane[1], piece.center[1], s[j])):
                out[CENTRE[axis]] = round(reader.from_si(axis, float(c - p), inch), d)
        if "r" in forms:
            e = self.written(piece.end, inch)
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

    def arc_error(self, piece, prev, st: dict, forms: set) -> float:
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

        Returns
        -------
        float
            [m].
        """
        reader, inch = self.reader, st["inch"]
        plane = PLANES[st["plane"]]
        i, j, k = (reader.axes.index(a) for a in plane)
        vals = self.centre_values(piece, prev, st, forms)
        if any(abs(v) >= 10.0 ** (MAX_DIGITS - self._digits[plane[0], inch]) for v in vals.values()):
            return math.inf
        scale = INCH if inch else MM
        s, e = self.written(prev, inch), self.written(piece.end, inch)
        centre = None
        if "ijk" in forms:
            offset = np.array([vals[CENTRE[plane[0]]], vals[CENTRE[plane[1]]]]) * scale
            if math.hypot(*offset) <= ARC_SLACK:
                return math.inf
            centre = s[[i, j]] + offset
        if "r" in forms:
            r = vals["R"] * scale
            from_r = None if abs(r) <= ARC_SLACK else centre_from_radius(s[[i, j]], e[[i, j]], r, piece.clockwise)
            if from_r is None or (centre is not None and math.hypot(*(from_r - centre)) > ARC_SLACK):
                return math.inf
            centre = from_r if centre is None else centre
        try:
            arc = arc_from_center(s, e, centre, (i, j, k), piece.clockwise)
        except InputError:
            return math.inf
        if abs(arc.sweep - piece.turns) > math.pi / 2:
            return math.inf  # read as (nearly) the rest of the circle
        u = np.linspace(0.0, 1.0, 17)
        linear = np.array(reader.linear)
        gap = arc.point(u)[:, linear] - self.piece_points(piece, (i, j), u)[:, linear]
        return float(np.linalg.norm(gap, axis=1).max())

    def writable(self, pieces: list, st: dict, forms: set) -> list:
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

        Returns
        -------
        list of Piece
            The pieces as they can be written.
        """
        plane = PLANES[st["plane"]]
        rounding = 8 * 0.5 * 10.0 ** -self._digits[plane[0], st["inch"]] * (INCH if st["inch"] else MM)
        out = []
        prev = pieces[0].start
        for n, piece in enumerate(pieces):
            # the original block keeps its centre form; inserted blocks use I/J/K
            piece_forms = (forms or {"ijk"}) if n == 0 else {"ijk"}
            if piece.kind == "arc" and self.arc_error(piece, prev, st, piece_forms) > max(self.tol - piece.residual,
                                                                                         rounding):
                out.extend(self.chords(piece, st))
            else:
                out.append(piece)
            prev = piece.end
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
        i, j = self.reader.axes.index(plane[0]), self.reader.axes.index(plane[1])
        r = math.hypot(piece.start[i] - piece.center[0], piece.start[j] - piece.center[1])
        sweep = abs(piece.turns)
        allowed = max(self.tol - piece.residual - self.margin, 0.25 * self.margin)
        n = 1 if r <= allowed else max(1, math.ceil(sweep / (2 * math.acos(1 - allowed / r))))
        u = np.linspace(0.0, 1.0, n + 1)
        points = self.piece_points(piece, (i, j), u)
        points[0], points[-1] = piece.start, piece.end
        sagitta = r * (1 - math.cos(sweep / (2 * n)))
        ks = piece.k0 + u * (piece.k1 - piece.k0)
        return [Piece("line", points[m], points[m + 1], residual=piece.residual + sagitta, k0=ks[m], k1=ks[m + 1],
                      limited=piece.limited) for m in range(n)]
