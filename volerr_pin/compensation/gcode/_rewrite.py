"""Writing compensated pieces back into the text of a program.

A compensated block keeps its text: only the numbers of its coordinate words change (axes it
did not name are appended, since compensation moves every axis; an arc's centre words are
replaced likewise), and the further pieces of a split move follow as new blocks with explicit
G words. Numbers are written to 0.1 um (mm), 0.025 um (inch) and 1e-5 deg. Arc pieces'
centre words, and the check of the arcs they give back, are :mod:`._arc_words`'.
"""

from __future__ import annotations

import numpy as np

from ._arc_words import MAX_DIGITS, ArcWords
from ._lexer import CENTRE, DIAMETER_AXIS, LATE_M, PLANES, Block, Word
from ._modal import Interpreter

__all__ = ["MAX_DIGITS", "Writer"]



class Writer:
    """Writes the pieces of compensated moves as program text.

    ``st`` in the methods is the output state: the modes the block is written in
    (``"absolute"``, ``"inch"``, ``"plane"``, ``"all_known"``, ``"centres_absolute"``,
    ``"diameter"``) and the output's modal motion (``"out_motion"``, updated as lines are written).

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
    arcs : ArcWords
        Writes arc pieces and reads them back.
    origin : numpy.ndarray, shape (n_axes,)
        The program's origin [m, rad] (absolute arc centres are written from it).
    """

    def __init__(self, reader: Interpreter, tol: float, margin: float):
        self.reader = reader
        self.tol = tol
        self.margin = margin
        self._digits = {(a, inch): (6 if inch else 4) if lin else 5
                        for a, lin in zip(reader.axes, reader.linear) for inch in (False, True)}
        self._zero = {d: "-0." + "0" * d for d in (4, 5, 6)}
        self.set_origin(reader.origin)
        self.arcs = ArcWords(self)

    def set_origin(self, origin: np.ndarray) -> None:
        """Write the pieces that follow from another program zero (a work offset the program
        selects: the pieces before it are written already).

        Parameters
        ----------
        origin : numpy.ndarray, shape (n_axes,)
            The program's zero [m, rad].
        """
        reader = self.reader
        self._origin = [float(v) for v in origin]
        self.origin = np.asarray(self._origin)   # [m, rad], for absolute arc centres (G90.1)
        # per output unit (inch or not) and diameter mode (G7: an X word is twice the radius): each
        # axis' letter, decimals, scale [m or rad per unit], origin [m, rad] and the text of a
        # negative zero
        self._spec = {(inch, diameter): [
            (a, self._digits[a, inch], reader._scale[a, inch] * (0.5 if diameter and a == DIAMETER_AXIS else 1.0), o,
             self._zero[self._digits[a, inch]]) for a, o in zip(reader.axes, self._origin)]
            for inch in (False, True) for diameter in (False, True)}

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
        # the arithmetic of fmt(axis, round(from_si(axis, end - origin), digits)), per axis in
        # one loop over plain floats (this runs for every piece written)
        out = {}
        spec = self._spec[st["inch"], st.get("diameter", False)]
        end = end.tolist() if isinstance(end, np.ndarray) else [float(v) for v in end]
        if st["absolute"]:
            # (formatting to d decimals rounds as round(value, d) does: both give the decimal
            # nearest the double, so the rounding is left to the format)
            for (axis, d, scale, origin, zero), e in zip(spec, end):
                text = f"{(e - origin) / scale:.{d}f}"
                out[axis] = text[1:] if text == zero else text
            return out
        prev = prev.tolist() if isinstance(prev, np.ndarray) else [float(v) for v in prev]
        for (axis, d, scale, origin, zero), e, p in zip(spec, end, prev):
            value = round((e - origin) / scale, d) - round((p - origin) / scale, d)
            text = f"{value:.{d}f}"
            out[axis] = text[1:] if text == zero else text
        return out

    def written(self, q, inch: bool, diameter: bool = False) -> np.ndarray:
        """Program coordinates [m, rad] as the written (rounded) numbers give them back.

        Parameters
        ----------
        q : array_like, shape (n_axes,)
            Program coordinates [m, rad].
        inch : bool
            Whether linear values are written in inch.
        diameter : bool, default False
            Whether X is written as a diameter (G7).

        Returns
        -------
        numpy.ndarray, shape (n_axes,)
            The coordinates the written numbers mean.
        """
        # to_si(round(from_si(q - origin), digits)) + origin per axis, on plain floats (round()
        # of a numpy scalar is ten times slower)
        q = q.tolist() if isinstance(q, np.ndarray) else [float(v) for v in q]
        return np.array([round((v - origin) / scale, d) * scale + origin
                         for (_, d, scale, origin, _), v in zip(self._spec[inch, diameter], q)])

    # moves ------------------------------------------------------------------------
    def write_move(self, block: Block, newline: str, eol: str, motion: int, coord_words: list[Word],
                   pieces: list, st: dict, errors=None) -> tuple[list[str], list]:
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
        errors : sequence of float, optional
            Per piece, how far an arc piece written with centre offsets is read back off its
            path (:func:`~volerr_pin.compensation.gcode._arc_words.arc_errors`), if known.

        Returns
        -------
        lines : list of str
            The text, line endings included.
        pieces : list of Piece
            The pieces as written (arcs the numbers cannot hold replaced by chords).
        """
        forms = self.arcs.forms(block, st) if motion in (2, 3) else set()
        if forms or any(p.kind == "arc" for p in pieces):
            pieces = self.arcs.writable(pieces, st, forms, errors)
        late = [w for w in block.words if w.letter == "M" and w.value in LATE_M] if len(pieces) > 1 else []
        eol = newline if newline else eol
        feeds = self.inverse_feeds(block, pieces) if st.get("inverse") and len(pieces) > 1 else None
        prev = pieces[0].start
        first = self.rewrite(block, pieces[0], prev, st, motion, coord_words, drop=late,
                             append_missing=st["all_known"], feed=feeds[0] if feeds else None)
        lines = [first + (eol if len(pieces) > 1 else newline)]
        prev = pieces[0].end
        for n, piece in enumerate(pieces[1:], start=2):
            text = self.new_line(piece, prev, st, motion) + (f" F{feeds[n - 1]}" if feeds else "")
            lines.append(text + "".join(" " + w.text for w in late) + newline if n == len(pieces) else text + eol)
            prev = piece.end
        return lines, pieces

    @staticmethod
    def inverse_feeds(block: Block, pieces: list) -> list[str] | None:
        """Under inverse time feed (G93) the F word of a block is the reciprocal of its time:
        each piece of a split move gets the share of that time its part of the move takes
        (the fraction ``k1 - k0`` of the move's parameter), so the move takes as long as
        programmed.

        Parameters
        ----------
        block : Block
            The move's block.
        pieces : list of Piece
            Its pieces as written.

        Returns
        -------
        list of str or None
            The F number of each piece (written with up to 4 decimals), or None if the block
            has no F word (a controller refuses such a G93 block; it is kept as it is).
        """
        feed = next((w.value for w in block.words if w.letter == "F"), None)
        if feed is None:
            return None
        out = []
        for piece in pieces:
            share = max(piece.k1 - piece.k0, 1e-12)
            out.append(f"{feed / share:.4f}".rstrip("0").rstrip("."))
        return out

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
            words += self.arcs.centre_words(piece, prev, st, {"ijk"})
        st["out_motion"] = g
        return " ".join(words)

    def rewrite(self, block: Block, piece, prev, st: dict, motion: int, coord_words: list[Word], drop=(),
                append_missing: bool = True, feed: str | None = None) -> str:
        """The original line with the numbers of its coordinate words replaced in place;
        axes it did not name are appended after its last coordinate word (a full circle
        without end words gets them before its centre words). For an arc the
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
        feed : str, optional
            A new number for the block's F word (inverse time feed of a split move).

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
        if feed is not None:
            edits.extend((w.start, w.end, text[w.start] + feed) for w in block.words if w.letter == "F")
        # a full circle without end words (G2 I10) gets its end words before its centre words
        lead = None if coord_words else min(w.start for w in block.words if w.letter in "IJK")
        anchor = max(w.end for w in coord_words) if coord_words else lead
        g_new = self.g_of(piece, motion)
        motion_words = [w for w in block.words if w.letter == "G" and w.value in (0, 1, 2, 3)]
        if motion_words:
            last = motion_words[-1]
            if int(last.value) != g_new:
                edits.append((last.start, last.end, f"G{g_new}"))
        elif st["out_motion"] != g_new:
            first = min(w.start for w in coord_words) if coord_words else lead
            edits.append((first, first, f"G{g_new} "))
        st["out_motion"] = g_new
        if motion in (2, 3):
            plane = PLANES[st["plane"]]
            letters = (CENTRE[plane[0]], CENTRE[plane[1]], "R")
            centre_words = [w for w in block.words if w.letter in letters]
            new = ({t[0]: t for t in self.arcs.centre_words(piece, prev, st, self.arcs.forms(block, st))}
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
            if lead is not None and extra:
                edits.append((lead, lead, " ".join(extra) + " "))
                extra = []
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
