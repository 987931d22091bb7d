"""Compensating a program and writing the compensated blocks back into its text."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..compensate import Arc, PathCompensator, Piece, arc_from_center
from ..errors import InputError
from ..machine import Machine
from ..units import INCH, MM
from .lexer import CENTRE, LATE_M, PLANES, WORK_OFFSETS, Block, GcodeError, Word, split_lines
from .modal import ARC_SLACK, Interpreter, check_axes, centre_from_radius

#: the finest tolerance taken [um]: the point compensation itself stops at 0.01 um, and the
#: written numbers resolve 0.05 um
MIN_TOL_UM = 0.01
#: digits a written number may have (controllers read nine: 99999.9999 mm)
MAX_DIGITS = 9


@dataclass
class Report:
    """What a compensation did.

    Attributes
    ----------
    blocks_in, blocks_out : int
        Lines of the program and of the compensated program.
    moves : int
        Moves compensated.
    pieces : int
        Commanded pieces written for them (a split move has several).
    max_residual_um : float
        Largest remaining tool error along the compensated moves [um].
    max_before_um : float
        Largest tool error along the moves run uncompensated [um].
    tolerance_um : float
        The position tolerance asked for [um].
    arcs_kept, arcs_as_lines : int
        Arcs written as arcs only, and arcs some of whose pieces became lines.
    warnings : list of str
        Messages, in line order (``"line N: ..."``).
    detail : list of (int, int, float, float)
        Per move: line, pieces, largest error before [um], largest residual after [um];
        kept out of :meth:`to_dict` (a long program has many moves), drawn by
        ``compensation_png``.
    """

    blocks_in: int = 0
    blocks_out: int = 0
    moves: int = 0
    pieces: int = 0
    max_residual_um: float = 0.0
    max_before_um: float = 0.0
    tolerance_um: float = 1.0
    arcs_kept: int = 0
    arcs_as_lines: int = 0
    warnings: list[str] = field(default_factory=list)
    detail: list[tuple[int, int, float, float]] = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        """The report for JSON.

        Returns
        -------
        dict
            Every field but ``detail``.
        """
        return {"blocks_in": self.blocks_in, "blocks_out": self.blocks_out, "moves": self.moves,
                "pieces": self.pieces, "max_residual_um": self.max_residual_um,
                "max_before_um": self.max_before_um, "tolerance_um": self.tolerance_um,
                "arcs_kept": self.arcs_kept, "arcs_as_lines": self.arcs_as_lines,
                "warnings": self.warnings}


@dataclass
class _Move:
    """A desired move read from a block (SI): ``kind`` 0 rapid / end point only, 1 line,
    2/3 arc; ``motion`` the block's motion mode; ``modes`` the modal words it is written in."""

    kind: int
    motion: int
    start: np.ndarray
    target: np.ndarray
    arc: Arc | None
    coord_words: list[Word]
    modes: dict
    line: int


class Program:
    """Compensates a program for a machine whose axes are NC letters (X, Y, Z, A, B, C).

    Parameters
    ----------
    machine : Machine
        The machine, in the state (time, temperatures ...) to compensate for.
    tol_um : float
        Position tolerance along every move [um].
    pass_through : bool
        Keep blocks that cannot be compensated (canned cycles, macros, subprograms ...)
        unchanged and list them as warnings, instead of stopping with an error.
    start : array_like, shape (n_axes,), optional
        Axis positions [m, rad] before the program (default: mid-travel).
    method : str
        Solver of the compensated commands (see :class:`~volerr_pin.compensate.PathCompensator`).
    source : str
        Name of the program, for messages.
    tol_urad : float, optional
        Tool-axis tolerance on machines with rotary axes [urad] (default 10 urad per um of
        ``tol_um``).
    origin : array_like, shape (n_axes,), optional
        Axis positions [m, rad] of the program's zero (the work offset, G54 ...): absolute
        program coordinates plus ``origin`` are the axis positions. Default zero.

    Raises
    ------
    GcodeError
        An axis that is not an NC address letter, a tolerance that is not finite or finer
        than :data:`MIN_TOL_UM`, a ``tol_urad`` that is not positive and finite, or an
        invalid ``start`` or ``origin``.
    """

    def __init__(self, machine: Machine, tol_um: float = 1.0, pass_through: bool = False,
                 start=None, method: str = "newton", source: str = "<program>", tol_urad: float | None = None,
                 origin=None):
        check_axes(machine)  # the machine is reported before the tolerance
        if not (math.isfinite(tol_um) and tol_um >= MIN_TOL_UM):
            raise GcodeError(f"tol_um must be finite and at least {MIN_TOL_UM:g} um (what the point compensation "
                             f"resolves), got {tol_um}", parameters=("tol_um",))
        if tol_urad is not None and not (math.isfinite(tol_urad) and tol_urad > 0):
            raise GcodeError(f"tol_urad must be positive and finite, got {tol_urad}", parameters=("tol_urad",))
        self.reader = Interpreter(machine, source=source, start=start, origin=origin)
        # the written numbers are rounded (0.05 um per linear axis at most): the paths are
        # compensated to the tolerance less that margin, so the program as written meets it
        rounding = 0.05 * math.sqrt(sum(self.reader.linear))
        margin = min(rounding, 0.5 * tol_um)
        self.margin = margin * 1e-6
        self.tol_urad = 10.0 * tol_um if tol_urad is None else tol_urad
        inner_urad = None if tol_urad is None else tol_urad * (tol_um - margin) / tol_um
        self.comp = PathCompensator(machine, tol_um=tol_um - margin, method=method, tol_urad=inner_urad)
        self.pass_through = pass_through
        self.report = Report(tolerance_um=tol_um)
        if rounding > 0.5 * tol_um:
            self.report.warnings.append(
                f"the tolerance {tol_um:g} um is finer than the written numbers resolve (they round by up "
                f"to {rounding:.3f} um): the program as written may miss it by that much")

    # the run --------------------------------------------------------------------
    def compensate(self, text: str, progress=None) -> str:
        """The compensated program.

        Three passes: read every block (modal state, desired moves, errors with their line);
        compensate all move end points in one batch and screen all straight moves in one
        batch (most short moves need no splitting); then split what needs it and write.

        Parameters
        ----------
        text : str
            The program (mm, inch and deg as it selects); its line endings are kept.
        progress : callable, optional
            Called as ``progress(moves_done)`` as the moves are compensated.

        Returns
        -------
        str
            The compensated program; :attr:`report` describes it.

        Raises
        ------
        GcodeError
            A block that cannot be read or compensated, naming its line.
        """
        crlf = text.count("\r\n")
        self._eol = "\r\n" if crlf and crlf >= text.count("\n") - crlf else "\n"
        entries = self._read(text)
        moves = [e[3] for e in entries if e[0] == "move"]
        self.report.moves = len(moves)
        results = self._compensate_moves(moves, progress)
        out: list[str] = []
        wst = {"out_motion": None}
        it = iter(results)
        for entry in entries:
            kind, block_or_raw, newline = entry[0], entry[1], entry[2]
            if kind == "raw":
                out.append(block_or_raw)
            elif kind == "plain":
                gs = [int(w.value) for w in block_or_raw.words if w.letter == "G" and w.value in (0, 1, 2, 3)]
                if gs:
                    wst["out_motion"] = gs[-1]
                out.append(block_or_raw.text + newline)
            else:
                wst.update(entry[3].modes)
                out.extend(self._write(block_or_raw, newline, entry[3], next(it), wst))
        self.report.blocks_out = len(out)
        self.report.warnings.sort(key=lambda w: int(w.split(":")[0].split()[1]) if w.startswith("line ") else 0)
        return "".join(out)

    def _read(self, text: str) -> list[tuple]:
        """Every line as ("raw", text, newline) (kept unchanged), ("plain", block, newline)
        (no move) or ("move", block, newline, _Move)."""
        reader = self.reader
        source = reader.source
        entries = []
        state = reader.initial_state()
        noted = set()
        for number, (body, newline) in enumerate(split_lines(text), start=1):
            raw = body + newline
            self.report.blocks_in += 1
            block, problem = reader.classify(body, number, state)
            if problem:
                if not self.pass_through:
                    raise GcodeError(f"{source}:{number}: {problem} cannot be compensated "
                                     "(pass_through keeps it unchanged)", parameters=("pass_through",))
                self.report.warnings.append(
                    f"line {number}: {problem} kept unchanged" +
                    ("; what it changes is not followed, so the blocks after it may be misread" if problem.modes_unknown
                     else ""))
                entries.append(("raw", raw, newline))
                reader.skip(body, state, block, number)
                continue
            self._note_offsets(block, noted)
            lost = state.lost
            move = reader.advance(block, state)
            if move is None:
                entries.append(("plain", block, newline))
                continue
            kind = move.motion
            if not move.start_known.all():
                missing = ", ".join(a for a, k in zip(reader.axes, move.start_known) if not k)
                why = f"axes {missing} not known since {lost}" if lost else f"axes {missing} not yet programmed"
                if move.motion in (2, 3):
                    raise GcodeError(f"{source}:{number}: an arc from an unknown position ({why}); move every "
                                     "axis to a known point with G0 or G1 first")
                rest = ""
                if not state.known.all():
                    rest = (", taking the axes it does not name where they were last programmed" if lost else
                            ", taking the unprogrammed axes at " +
                            ("the start position given" if reader.start_given else "mid-travel"))
                self.report.warnings.append(f"line {number}: the position before this move is not known ({why}); "
                                            f"it is compensated at its end point only{rest}")
                kind = 0
            arc = None
            if kind in (2, 3):
                arc = reader.arc(block, move.start, move.target, kind == 2, state)
                outside = self._outside(arc.point(np.linspace(0.0, 1.0, 721)), slack=1e-9)
                if outside:
                    raise GcodeError(f"{source}:{number}: the arc leaves the travel ({outside})")
            modes = {"absolute": state.absolute, "inch": state.inch, "plane": state.plane,
                     "all_known": bool(state.known.all())}
            entries.append(("move", block, newline,
                            _Move(kind, move.motion, move.start, move.target, arc, move.coord_words, modes, number)))
        self.report.warnings.extend(reader.warnings)
        return entries

    def _note_offsets(self, block: Block, noted: set) -> None:
        """Warn (once) of work and tool offsets, which the model does not know."""
        for w in block.words:
            if (w.letter == "G" and w.value in WORK_OFFSETS and "offset" not in noted
                    and not self.reader.origin.any()):
                noted.add("offset")
                self.report.warnings.append(
                    f"line {block.number}: work offset G{w.value:g}: program coordinates are taken as axis "
                    "positions (give the work offset as the program origin, in mm / deg)")
            if ((w.letter == "G" and w.value in (43, 44)) or w.letter in "HD") and "tool" not in noted:
                noted.add("tool")
                what = f"G{w.value:g} tool length offset" if w.letter == "G" else f"tool offset word {w.name}"
                self.report.warnings.append(
                    f"line {block.number}: {what}: the errors are those of the model's tool point; a "
                    "different tool length changes the angular errors' lever arms")

    def _compensate_moves(self, moves: list[_Move], progress=None) -> list:
        if not moves:
            return []
        comp = self.comp
        ends = comp.points(np.array([mv.target for mv in moves]))
        starts_c = [None] + list(ends[:-1])
        lines = [i for i, mv in enumerate(moves) if mv.kind == 1]
        screened = {}
        if lines:
            idx = np.array(lines)
            after, before = comp.screen_lines(np.array([moves[i].start for i in lines]),
                                              np.array([moves[i].target for i in lines]),
                                              np.array([starts_c[i] for i in lines]), ends[idx])
            for i, a, b in zip(lines, after, before):
                screened[i] = (a, b)
        # the first-level points of every arc in one batch too
        arcs = [i for i, mv in enumerate(moves) if mv.kind in (2, 3)]
        known = {i: {} for i in arcs}
        if arcs:
            ks = {i: comp.arc_points(moves[i].arc) for i in arcs}
            todo = [(i, k) for i in arcs for k in ks[i]]
            if todo:
                cmds = comp.points(np.array([moves[i].arc.point(k)[0] for i, k in todo]))
                for (i, k), c in zip(todo, cmds):
                    known[i][k] = c
        results = []
        for i, mv in enumerate(moves):
            try:
                if mv.kind == 0:
                    result = comp.rapid(mv.start, mv.target, end_c=ends[i], start_c=starts_c[i])
                elif mv.kind == 1 and screened[i][0] <= 0.9 * comp.tol:
                    result = comp.accept_line(mv.start, mv.target, starts_c[i], ends[i], *screened[i])
                elif mv.kind == 1:
                    result = comp.line(mv.start, mv.target, starts_c[i], end_c=ends[i])
                else:
                    result = comp.arc(mv.arc, starts_c[i], end_c=ends[i], known=known[i])
            except InputError as err:
                raise GcodeError(f"{self.reader.source}:{mv.line}: {err}") from None
            results.append(result)
            if progress is not None and i % 50 == 0:
                progress(i)
        return results

    def _outside(self, q: np.ndarray, slack: float = 0.0) -> str:
        """Which axes ``q`` takes beyond their travel and by how much ('' if none)."""
        travel = self.reader.machine.travel
        parts = []
        for j, axis in enumerate(self.reader.axes):
            lo = travel[j, 0] - q[:, j].min()
            hi = q[:, j].max() - travel[j, 1]
            worst = max(lo, hi)
            if worst > slack:
                unit, scale = ("um", 1e6) if self.reader.linear[j] else ("urad", 1e6)
                parts.append(f"{axis} by {worst * scale:.2f} {unit}")
        return ", ".join(parts)

    # writing --------------------------------------------------------------------
    # ``st`` below is the output state: the modes the block is written in ("absolute",
    # "inch", "plane", "all_known") and the output's modal motion ("out_motion", updated)
    def _write(self, block: Block, newline: str, mv: _Move, result, st: dict) -> list[str]:
        forms = self._forms(block, st) if mv.kind in (2, 3) else set()
        pieces = self._writable(result.pieces, st, forms)
        max_residual = max(p.residual for p in pieces)
        self.report.pieces += len(pieces)
        self.report.detail.append((block.number, len(pieces), result.max_before * 1e6, max_residual * 1e6))
        self.report.max_residual_um = max(self.report.max_residual_um, max_residual * 1e6)
        self.report.max_before_um = max(self.report.max_before_um, result.max_before * 1e6)
        if result.limited:
            what = (f"{self.report.tolerance_um:g} um / {self.tol_urad:g} urad" if self.comp.orientation
                    else f"{self.report.tolerance_um:g} um")
            self.report.warnings.append(
                f"line {block.number}: the residual stays at {max_residual * 1e6:.2f} um "
                f"(tolerance {what}); no command reaches the desired pose there (singular pose of "
                "the rotary axes, or an error the axes cannot undo)")
        outside = self._outside(np.array([p.end for p in pieces]))
        if outside:
            self.report.warnings.append(f"line {block.number}: the compensated command leaves the travel "
                                        f"({outside}); check the machine's soft limits")
        if mv.kind in (2, 3):
            if all(p.kind == "arc" for p in pieces):
                self.report.arcs_kept += 1
            else:
                self.report.arcs_as_lines += 1
        # the original block carries the first piece (so its F, S, T, M and modal words act
        # where they did); the further pieces follow as new blocks with explicit G words, and
        # M codes that act at the end of the move (M0, M1, M2, M5, M9, M30) move to the last
        late = [w for w in block.words if w.letter == "M" and w.value in LATE_M] if len(pieces) > 1 else []
        eol = newline if newline else self._eol
        prev = pieces[0].start
        first = self._rewrite(block, pieces[0], prev, st, mv.motion, mv.coord_words, drop=late,
                              append_missing=st["all_known"])
        lines = [first + (eol if len(pieces) > 1 else newline)]
        prev = pieces[0].end
        for n, piece in enumerate(pieces[1:], start=2):
            text = self._new_line(piece, prev, st, mv.motion)
            if n == len(pieces):
                lines.append(text + "".join(" " + w.text for w in late) + newline)
            else:
                lines.append(text + eol)
            prev = piece.end
        return lines

    # arcs as written ------------------------------------------------------------
    # The numbers of an arc block are rounded like every other; a small arc's centre words
    # can round to zero, or to a centre whose circle misses the written end points, or turn
    # a short arc into nearly a full circle. Every arc piece is read back from its written
    # numbers, as a controller reads it, and one whose path leaves the piece's by more than
    # the tolerance allows is written as straight pieces instead.
    @staticmethod
    def _forms(block: Block, st: dict) -> set:
        """The centre forms an arc block is written in: "ijk" (centre offsets), "r" (radius)."""
        plane = PLANES[st["plane"]]
        letters = {w.letter for w in block.words}
        forms = {"r"} if "R" in letters else set()
        if letters & {CENTRE[plane[0]], CENTRE[plane[1]]}:
            forms.add("ijk")
        return forms

    def _written(self, q: np.ndarray, inch: bool) -> np.ndarray:
        """Axis positions [m, rad] as the written (rounded) program numbers give them back."""
        reader = self.reader
        out = np.array(q, dtype=float)
        for j, axis in enumerate(reader.axes):
            v = round(reader.from_si(axis, q[j] - reader.origin[j], inch), self._digits(axis, inch))
            out[j] = reader.to_si(axis, v, inch) + reader.origin[j]
        return out

    def _centre_values(self, piece, prev, st: dict, forms: set) -> dict[str, float]:
        """The centre words of an arc piece, rounded as written: offsets from the written
        start, and a radius that puts the centre where it is."""
        reader, inch = self.reader, st["inch"]
        plane = PLANES[st["plane"]]
        i, j = reader.axes.index(plane[0]), reader.axes.index(plane[1])
        d = self._digits(plane[0], inch)
        s = self._written(prev, inch)
        out = {}
        if "ijk" in forms:
            for axis, c, p in ((plane[0], piece.center[0], s[i]), (plane[1], piece.center[1], s[j])):
                out[CENTRE[axis]] = round(reader.from_si(axis, c - p, inch), d)
        if "r" in forms:
            e = self._written(piece.end, inch)
            r = 0.5 * (math.hypot(s[i] - piece.center[0], s[j] - piece.center[1]) +
                       math.hypot(e[i] - piece.center[0], e[j] - piece.center[1]))
            out["R"] = round(reader.from_si(plane[0], -r if abs(piece.turns) > math.pi else r, inch), d)
        return out

    def _piece_points(self, piece, plane: tuple[int, int], u: np.ndarray) -> np.ndarray:
        """Points of an arc piece's commanded path at fractions ``u``, shape (len(u), n_axes)."""
        i, j = plane
        c = piece.center
        a0 = math.atan2(piece.start[j] - c[1], piece.start[i] - c[0])
        r = math.hypot(piece.start[i] - c[0], piece.start[j] - c[1])
        out = piece.start + np.outer(u, piece.end - piece.start)
        out[:, i] = c[0] + r * np.cos(a0 + u * piece.turns)
        out[:, j] = c[1] + r * np.sin(a0 + u * piece.turns)
        return out

    def _arc_error(self, piece, prev, st: dict, forms: set) -> float:
        """How far the arc a controller reads from a piece's written numbers leaves the
        piece's path [m] (inf if the numbers define no arc, or have too many digits)."""
        reader, inch = self.reader, st["inch"]
        plane = PLANES[st["plane"]]
        i, j, k = (reader.axes.index(a) for a in plane)
        vals = self._centre_values(piece, prev, st, forms)
        if any(abs(v) >= 10.0 ** (MAX_DIGITS - self._digits(plane[0], inch)) for v in vals.values()):
            return math.inf
        scale = INCH if inch else MM
        s, e = self._written(prev, inch), self._written(piece.end, inch)
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
        gap = arc.point(u)[:, linear] - self._piece_points(piece, (i, j), u)[:, linear]
        return float(np.linalg.norm(gap, axis=1).max())

    def _writable(self, pieces: list, st: dict, forms: set) -> list:
        """The pieces of a move with every arc the written numbers cannot hold within the
        tolerance replaced by straight pieces (chords) along it.

        Rounding moves a well-formed written arc by a few half-units of the last digit (its
        centre, radius and ends each by up to 0.07 um in mm): that much is always accepted,
        so that only arcs the numbers define badly become chords."""
        tol = self.report.tolerance_um * 1e-6
        plane = PLANES[st["plane"]]
        rounding = 8 * 0.5 * 10.0 ** -self._digits(plane[0], st["inch"]) * (INCH if st["inch"] else MM)
        out = []
        prev = pieces[0].start
        for n, piece in enumerate(pieces):
            # the original block keeps its centre form; inserted blocks use I/J/K
            piece_forms = (forms or {"ijk"}) if n == 0 else {"ijk"}
            if piece.kind == "arc" and self._arc_error(piece, prev, st, piece_forms) > max(tol - piece.residual,
                                                                                          rounding):
                out.extend(self._chords(piece, st, tol))
            else:
                out.append(piece)
            prev = piece.end
        return out

    def _chords(self, piece, st: dict, tol: float) -> list:
        """An arc piece as straight pieces whose sagitta keeps the tolerance."""
        plane = PLANES[st["plane"]]
        i, j = self.reader.axes.index(plane[0]), self.reader.axes.index(plane[1])
        r = math.hypot(piece.start[i] - piece.center[0], piece.start[j] - piece.center[1])
        sweep = abs(piece.turns)
        allowed = max(tol - piece.residual - self.margin, 0.25 * self.margin)
        n = 1 if r <= allowed else max(1, math.ceil(sweep / (2 * math.acos(1 - allowed / r))))
        u = np.linspace(0.0, 1.0, n + 1)
        points = self._piece_points(piece, (i, j), u)
        points[0], points[-1] = piece.start, piece.end
        sagitta = r * (1 - math.cos(sweep / (2 * n)))
        ks = piece.k0 + u * (piece.k1 - piece.k0)
        return [Piece("line", points[m], points[m + 1], residual=piece.residual + sagitta, k0=ks[m], k1=ks[m + 1],
                      limited=piece.limited) for m in range(n)]

    @staticmethod
    def _g_of(piece, motion: int) -> int:
        if piece.kind == "arc":
            return 2 if piece.clockwise else 3
        return motion if motion in (0, 1) else 1

    def _digits(self, axis: str, inch: bool) -> int:
        """Output decimals: 0.1 um (mm), 0.025 um (inch), 0.00001 deg (rotary)."""
        if not self.reader.linear[self.reader.axes.index(axis)]:
            return 5
        return 6 if inch else 4

    def _fmt(self, axis: str, value: float, inch: bool) -> str:
        digits = self._digits(axis, inch)
        text = f"{value:.{digits}f}"
        return "0." + "0" * digits if text in ("-0." + "0" * digits,) else text

    def _values(self, piece, prev, st: dict) -> dict[str, str]:
        """Coordinate words of a piece's end. Incremental values are differences of the
        rounded absolute positions, so rounding never accumulates along a G91 section."""
        reader = self.reader
        vals = {}
        for j, axis in enumerate(reader.axes):
            d = self._digits(axis, st["inch"])
            end = round(reader.from_si(axis, piece.end[j] - reader.origin[j], st["inch"]), d)
            if not st["absolute"]:
                end -= round(reader.from_si(axis, prev[j] - reader.origin[j], st["inch"]), d)
            vals[axis] = self._fmt(axis, end, st["inch"])
        return vals

    def _centre_words(self, piece, prev, st: dict, forms: set) -> list[str]:
        plane = PLANES[st["plane"]]
        return [f"{letter}{self._fmt(plane[0], value, st['inch'])}"
                for letter, value in self._centre_values(piece, prev, st, forms).items()]

    def _new_line(self, piece, prev, st: dict, motion: int) -> str:
        vals = self._values(piece, prev, st)
        g = self._g_of(piece, motion)
        words = [f"G{g}"] + [f"{a}{vals[a]}" for a in self.reader.axes]
        if piece.kind == "arc":
            words += self._centre_words(piece, prev, st, {"ijk"})
        st["out_motion"] = g
        return " ".join(words)

    def _rewrite(self, block: Block, piece, prev, st: dict, motion: int, coord_words: list[Word], drop=(),
                 append_missing: bool = True) -> str:
        """The original line with the numbers of its coordinate words replaced in place;
        axes it did not name are appended after its last coordinate word. For an arc the
        centre words are replaced likewise; an arc piece that had to become a line gets G1
        and loses its centre words. A block that relied on the modal motion gets an explicit
        motion word when the output's modal motion differs. ``drop``: words to remove (with
        their separating space); ``append_missing`` false while some axes' positions are
        still unknown (those axes are not commanded)."""
        vals = self._values(piece, prev, st)
        # a word keeps the case its letter is written in
        edits = [(w.start, w.end, f"{block.text[w.start]}{vals[w.letter]}") for w in coord_words]
        present = {w.letter for w in coord_words}
        extra = [f"{a}{vals[a]}" for a in self.reader.axes if a not in present] if append_missing else []

        def remove(w):
            start = w.start
            if start > 0 and block.text[start - 1] in " \t":
                start -= 1  # a removed word takes its separating space with it
            edits.append((start, w.end, ""))

        for w in drop:
            remove(w)
        anchor = max(w.end for w in coord_words)
        g_new = self._g_of(piece, motion)
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
            new = ({t[0]: t for t in self._centre_words(piece, prev, st, self._forms(block, st))}
                   if piece.kind == "arc" else {})
            for w in centre_words:
                replacement = new.pop(w.letter, "")
                if replacement:
                    edits.append((w.start, w.end, block.text[w.start] + replacement[1:]))
                else:
                    remove(w)
            for w in block.words:  # turns (P): every piece is less than a quarter turn
                if w.letter == "P":
                    remove(w)
            extra += list(new.values())
            anchor = max([anchor] + [w.end for w in centre_words])
        text = block.text
        if extra:
            edits.append((anchor, anchor, " " + " ".join(extra)))
        for start, end, rep in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
            text = text[:start] + rep + text[end:]
        return text


def compensate_program(machine: Machine, text: str, *, tol_um: float = 1.0, pass_through: bool = False,
                       method: str = "newton", source: str = "<program>",
                       tol_urad: float | None = None, origin=None) -> tuple[str, Report]:
    """Compensate an NC program.

    Parameters
    ----------
    machine : Machine
        The machine; its axes are NC address letters.
    text : str
        The program (mm, inch and deg as it selects).
    tol_um : float
        Position tolerance along every move [um].
    pass_through : bool
        Keep blocks that cannot be compensated unchanged (listed as warnings) instead of
        stopping with an error.
    method : str
        Solver of the compensated commands.
    source : str
        Name of the program, for messages.
    tol_urad : float, optional
        Tool-axis tolerance on machines with rotary axes [urad] (default 10 urad per um of
        ``tol_um``).
    origin : array_like, shape (n_axes,), optional
        Axis positions [m, rad] of the program's zero (default zero).

    Returns
    -------
    text : str
        The compensated program.
    report : Report
        What the compensation did.

    Raises
    ------
    GcodeError
        Invalid arguments, or a block that cannot be read or compensated, naming its line.
    """
    program = Program(machine, tol_um=tol_um, pass_through=pass_through, method=method, source=source,
                      tol_urad=tol_urad, origin=origin)
    return program.compensate(text), program.report
