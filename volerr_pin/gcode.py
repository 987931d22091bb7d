"""NC programs (ISO 6983 / RS-274 style): read, compensate, write back.

Understood: G0, G1, G2, G3 (I/J/K centres relative to the start, or R with a negative value
for more than half a turn; G17/G18/G19 planes; helical moves), G90/G91, G20/G21, F, S, T,
M words, comments ``( ... )`` and ``; ...``, line numbers ``N``, blank lines. Everything that
is not a compensated coordinate is copied byte for byte: a compensated block keeps its text
and only the numbers of its coordinate words change (missing coordinate words are appended,
since compensation moves every axis); the extra pieces of a split move are inserted as new
lines before it. Canned cycles, macros and subprograms (G73-G89, G65, M98, M99, O-words,
``#`` variables, IF/WHILE/GOTO) stop the compensation with an error naming the line unless
``pass_through`` is set, in which case they are kept and listed as warnings.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from .compensate import PathCompensator, arc_from_center
from .errors import InputError
from .machine import Machine

WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
COMMENT = re.compile(r"\([^)]*\)|;.*$")
CANNED = {73, 74, 76, 81, 82, 83, 84, 85, 86, 87, 88, 89}
MACRO_G = {65, 66, 67}
# G codes whose axis words are not a move the program interpolates (data, reference returns,
# machine coordinates, probing) or that change the geometry in ways not modelled
NOT_MOVES = {10: "data setting", 27: "reference check", 28: "reference return", 29: "return from reference",
             30: "2nd reference return", 31: "probing skip", 53: "machine coordinates", 92: "coordinate shift",
             52: "local coordinate system", 68: "coordinate rotation", 51: "scaling", 41: "cutter compensation",
             42: "cutter compensation", 90.1: "absolute arc centres", 91.1: "incremental arc centres"}
WORK_OFFSETS = {54, 55, 56, 57, 58, 59, 54.1, 59.1, 59.2, 59.3}
LATE_M = (0, 1, 2, 5, 9, 30)  # M codes that act at the end of their block's move
PLANES = {17: ("X", "Y", "Z"), 18: ("Z", "X", "Y"), 19: ("Y", "Z", "X")}
CENTRE = {"X": "I", "Y": "J", "Z": "K"}


class GcodeError(InputError):
    """A program cannot be read or compensated (the message names the line)."""


@dataclass
class Word:
    letter: str
    value: float
    text: str
    start: int   # span in the line
    end: int


@dataclass
class Block:
    number: int          # 1-based line number
    text: str            # the line without its newline
    words: list[Word]
    code: str            # the line without comments (for checks)


def parse_block(line: str, number: int, source: str) -> Block:
    """Words of a line, with their spans in the original text (comments skipped)."""
    inside = False
    for ch in line:
        if ch == ";" and not inside:
            break
        if ch == "(" and not inside:
            inside = True
        elif ch == ")" and inside:
            inside = False
        elif ch in "()":
            inside = None
            break
    if inside is not False:
        raise GcodeError(f"{source}:{number}: unbalanced parenthesis in '{line.strip()}'")
    masked = list(line)
    for m in COMMENT.finditer(line):
        for i in range(m.start(), m.end()):
            masked[i] = " "
    code = "".join(masked)
    words = []
    pos = 0
    stripped = code.rstrip()
    for m in WORD.finditer(code):
        gap = code[pos:m.start()]
        if gap.strip():
            raise GcodeError(f"{source}:{number}: cannot read '{gap.strip()}' in '{line.strip()}'")
        words.append(Word(m.group(1).upper(), float(m.group(2)), m.group(0), m.start(), m.end()))
        pos = m.end()
    rest = code[pos:len(stripped)]
    if rest.strip() and not rest.strip().startswith("%"):
        raise GcodeError(f"{source}:{number}: cannot read '{rest.strip()}' in '{line.strip()}'")
    return Block(number, line, words, code)


def split_lines(text: str) -> list[tuple[str, str]]:
    """(body, line ending) per line; only LF and CR LF end a line (a form feed or other
    Unicode line separators inside a block stay part of it)."""
    out = []
    for raw in re.findall(r"[^\n]*\n|[^\n]+\Z", text):
        body = raw[:-1] if raw.endswith("\n") else raw
        newline = raw[len(body):]
        if body.endswith("\r") and newline:
            body, newline = body[:-1], "\r\n"
        out.append((body, newline))
    return out


@dataclass
class Report:
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
    # per move: (line, pieces, largest error before [um], largest residual after [um]);
    # kept out of the JSON (a long program has many moves), drawn by compensation_png
    detail: list[tuple[int, int, float, float]] = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        return {"blocks_in": self.blocks_in, "blocks_out": self.blocks_out, "moves": self.moves,
                "pieces": self.pieces, "max_residual_um": self.max_residual_um,
                "max_before_um": self.max_before_um, "tolerance_um": self.tolerance_um,
                "arcs_kept": self.arcs_kept, "arcs_as_lines": self.arcs_as_lines,
                "warnings": self.warnings}


def _modal_words(gs, st: dict) -> None:
    """Apply the modal G words (motion, plane, distance and unit modes) to the state."""
    for g in gs:
        if g in (0, 1, 2, 3):
            st["motion"] = int(g)
        elif g in CANNED or g == 80:
            st["motion"] = None  # a cycle, or its cancellation, ends the motion mode
        elif g in (17, 18, 19):
            st["plane"] = int(g)
        elif g == 90:
            st["absolute"] = True
        elif g == 91:
            st["absolute"] = False
        elif g == 20:
            st["inch"] = True
        elif g == 21:
            st["inch"] = False


class Program:
    """Compensates a program for a machine whose axes are NC letters (X, Y, Z, A, B, C)."""

    def __init__(self, machine: Machine, tol_um: float = 1.0, pass_through: bool = False,
                 start=None, method: str = "newton", source: str = "<program>", tol_urad: float | None = None,
                 origin=None):
        """``origin``: machine axis positions (SI) of the program's zero (the work offset,
        G54 ...); absolute program coordinates plus ``origin`` are the axis positions."""
        for axis in machine.axes:
            if not (len(axis) == 1 and axis in "XYZABCUVW"):
                raise GcodeError(f"{machine.name}: axis '{axis}' is not an NC address letter")
        self.m = machine
        self.axes = list(machine.axes)
        self.linear = [k == "linear" for k in machine.axis_kinds]
        if not tol_um > 0:
            raise GcodeError(f"the tolerance must be positive, got {tol_um} um")
        # the written numbers are rounded (0.05 um per linear axis at most): the paths are
        # compensated to the tolerance less that margin, so the program as written meets it
        self.tol_urad = 10.0 * tol_um if tol_urad is None else tol_urad
        margin = min(0.05 * math.sqrt(sum(self.linear)), 0.5 * tol_um)
        inner_urad = None if tol_urad is None else tol_urad * (tol_um - margin) / tol_um
        self.comp = PathCompensator(machine, tol_um=tol_um - margin, method=method, tol_urad=inner_urad)
        self.pass_through = pass_through
        self.source = source
        self.start = machine.mid_travel if start is None else np.asarray(start, float)
        self.report = Report(tolerance_um=tol_um)
        self.origin = np.zeros(len(self.axes)) if origin is None else np.asarray(origin, dtype=float)
        if self.origin.shape != (len(self.axes),) or not np.all(np.isfinite(self.origin)):
            raise GcodeError(f"origin must hold {len(self.axes)} finite values (axes {', '.join(self.axes)})")
        rounding = 0.05 * math.sqrt(sum(self.linear))
        if rounding > 0.5 * tol_um:
            self.report.warnings.append(
                f"the tolerance {tol_um:g} um is finer than the written numbers resolve (they round by up "
                f"to {rounding:.3f} um): the program as written may miss it by that much")

    # units ----------------------------------------------------------------------
    def _to_si(self, axis: str, value: float, inch: bool) -> float:
        j = self.axes.index(axis)
        if self.linear[j]:
            return value * (25.4e-3 if inch else 1e-3)
        return math.radians(value)

    def _position(self, axis: str, value: float, inch: bool) -> float:
        """Axis position (SI) of an absolute program coordinate."""
        return self._to_si(axis, value, inch) + self.origin[self.axes.index(axis)]

    def _from_si(self, axis: str, value: float, inch: bool) -> float:
        j = self.axes.index(axis)
        if self.linear[j]:
            return value / (25.4e-3 if inch else 1e-3)
        return math.degrees(value)

    def _fmt(self, axis: str, value: float, inch: bool) -> str:
        digits = self._digits(axis, inch)
        text = f"{value:.{digits}f}"
        return "0." + "0" * digits if text in ("-0." + "0" * digits,) else text

    # the run --------------------------------------------------------------------
    def compensate(self, text: str, progress=None) -> str:
        """The compensated program; ``progress(moves_done)`` is called as it goes.

        Three passes: read every block (modal state, desired moves, errors with their line);
        compensate all move end points in one batch and screen all straight moves in one
        batch (most short moves need no splitting); then split what needs it and write."""
        crlf = text.count("\r\n")
        self._eol = "\r\n" if crlf and crlf >= text.count("\n") - crlf else "\n"
        entries = self._read(text)
        moves = [e for e in entries if e[0] == "move"]
        self.report.moves = len(moves)
        results = self._compensate_moves([e[3] for e in moves], progress)
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
                wst.update(entry[3].state)
                out.extend(self._write(block_or_raw, newline, entry[3], next(it), wst))
        self.report.blocks_out = len(out)
        self.report.warnings.sort(key=lambda w: int(w.split(":")[0].split()[1]) if w.startswith("line ") else 0)
        return "".join(out)

    def _read(self, text: str) -> list[tuple]:
        entries = []
        st = self._initial_state()
        noted = set()
        for number, (body, newline) in enumerate(split_lines(text), start=1):
            raw = body + newline
            self.report.blocks_in += 1
            problem = self._unsupported(body, st)
            if problem:
                if not self.pass_through:
                    raise GcodeError(f"{self.source}:{number}: {problem} cannot be compensated "
                                     "(use --pass-through to keep it unchanged)")
                self.report.warnings.append(f"line {number}: {problem} kept unchanged")
                entries.append(("raw", raw, newline))
                self._follow_skipped(body, st)
                continue
            block = parse_block(body, number, self.source)
            for w in block.words:
                if w.letter == "G" and w.value in WORK_OFFSETS and "offset" not in noted and not self.origin.any():
                    noted.add("offset")
                    self.report.warnings.append(
                        f"line {number}: work offset G{w.value:g}: program coordinates are taken as axis "
                        "positions (give the offset as origin, --origin X=... in mm)")
                if w.letter == "G" and w.value == 43 and "g43" not in noted:
                    noted.add("g43")
                    self.report.warnings.append(
                        f"line {number}: G43 tool length offset: the errors are those of the model's tool "
                        "point; a different tool length changes the angular errors' lever arms")
            known_before = st["known"].copy()
            move = self._modal(block, st)
            if move is None:
                entries.append(("plain", block, newline))
                continue
            motion, start, target, coord_words = move
            kind = motion
            if not known_before.all():
                missing = [a for a, k in zip(self.axes, known_before) if not k]
                if motion in (2, 3):
                    raise GcodeError(f"{self.source}:{number}: an arc from an unknown position (axes "
                                     f"{', '.join(missing)} not yet programmed); move every axis to a known "
                                     "point with G0 or G1 first")
                self.report.warnings.append(
                    f"line {number}: the position before this move is not known (axes {', '.join(missing)} "
                    "not yet programmed); it is compensated at its end point only" +
                    (", taking the unprogrammed axes at mid-travel" if not st["known"].all() else ""))
                kind = 0
            arc = None
            if kind in (2, 3):
                arc = self._arc(block, start, target, kind == 2, st)
                outside = self._outside(arc.point(np.linspace(0.0, 1.0, 721)), slack=1e-9)
                if outside:
                    raise GcodeError(f"{self.source}:{number}: the arc leaves the travel ({outside})")
            state = {"absolute": st["absolute"], "inch": st["inch"], "plane": st["plane"],
                     "all_known": bool(st["known"].all())}
            entries.append(("move", block, newline, _Move(kind, motion, start, target, arc, coord_words, state, number)))
            st["pos"] = target
        return entries

    def _compensate_moves(self, moves: list, progress=None) -> list:
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
                raise GcodeError(f"{self.source}:{mv.line}: {err}") from None
            results.append(result)
            if progress is not None and i % 50 == 0:
                progress(i)
        return results

    def _unsupported(self, line: str, st: dict | None = None) -> str | None:
        """Why a block cannot be compensated (None if it can); ``st`` tracks canned cycles."""
        code = COMMENT.sub(" ", line).upper()
        if "#" in code:
            return "a macro variable (#)"
        keyword = re.search(r"\b(IF|WHILE|GOTO|DO\d*|END\d*)\b", code)
        if keyword:
            return f"a macro statement ({keyword.group(1)})"
        words = [(m.group(1).upper(), float(m.group(2))) for m in WORD.finditer(code)]
        has_axes = any(letter in self.axes for letter, _ in words)
        if code.lstrip().startswith("/") and has_axes:
            return "a move with block delete (/), whose execution depends on the operator's switch,"
        for letter, value in words:
            if letter == "G" and value in CANNED:
                if st is not None:
                    st["canned"] = True
                return f"G{value:g} (canned cycle)"
            if letter == "G" and value in MACRO_G:
                return f"G{value:g} (macro call)"
            if letter == "M" and value in (98, 99):
                return f"M{value:g} (subprogram call or return)"
            if letter == "G" and value in NOT_MOVES:
                return f"G{value:g} ({NOT_MOVES[value]})"
        if st is not None and st.get("canned"):
            if any(letter == "G" and value in (0, 1, 2, 3, 80) for letter, value in words):
                st["canned"] = False
            elif has_axes:
                return "a canned-cycle position (the cycle is still active)"
        return None

    def _initial_state(self) -> dict:
        """Modal state at the start of a program: no motion mode, G17, G90, G21, no axis
        position known (taken at ``start``), no canned cycle."""
        return {"motion": None, "plane": 17, "absolute": True, "inch": False,
                "known": np.zeros(len(self.axes), dtype=bool), "pos": self.start.copy(), "canned": False}

    def _follow_skipped(self, body: str, st: dict) -> None:
        """A block kept unchanged still sets its modal words (G91 G28 ... stays G91), and
        if it names axes it moves the machine somewhere we do not follow."""
        words = [(m.group(1).upper(), float(m.group(2))) for m in WORD.finditer(COMMENT.sub(" ", body).upper())]
        _modal_words([v for letter, v in words if letter == "G"], st)
        if any(letter in self.axes for letter, _ in words):
            st["known"][:] = False

    def _modal(self, block: Block, st: dict, check_travel: bool = True):
        """Update the modal state from a block; returns (motion, start, target, coordinate
        words) for a move, or None. ``check_travel`` rejects targets outside the travel (the
        desired program must lie inside it; a compensated one may leave it by micrometres)."""
        gs = [w.value for w in block.words if w.letter == "G"]
        _modal_words(gs, st)
        motion = st["motion"]
        coord_words = [w for w in block.words if w.letter in self.axes]
        if not coord_words or 4 in gs:  # G4: X or P is the dwell time
            return None
        if motion is None:
            raise GcodeError(f"{self.source}:{block.number}: coordinates without a motion mode (G0/G1/G2/G3)")
        target = st["pos"].copy()
        known = st.setdefault("known", np.zeros(len(self.axes), dtype=bool))
        for w in coord_words:
            j = self.axes.index(w.letter)
            if st["absolute"]:
                target[j] = self._position(w.letter, w.value, st["inch"])
            elif known[j]:
                target[j] = st["pos"][j] + self._to_si(w.letter, w.value, st["inch"])
            else:
                raise GcodeError(f"{self.source}:{block.number}: an incremental move of {w.letter} before its "
                                 "position is known; program it absolutely (G90) first")
            known[j] = True
        try:
            self.m.check_q(target[None, :], extrapolate=not check_travel)
        except InputError as err:
            raise GcodeError(f"{self.source}:{block.number}: {err}") from None
        return motion, st["pos"].copy(), target, coord_words

    def _write(self, block: Block, newline: str, mv, result, st: dict) -> list[str]:
        self.report.pieces += len(result.pieces)
        self.report.detail.append((block.number, len(result.pieces), result.max_before * 1e6,
                                   result.max_residual * 1e6))
        self.report.max_residual_um = max(self.report.max_residual_um, result.max_residual * 1e6)
        self.report.max_before_um = max(self.report.max_before_um, result.max_before * 1e6)
        if result.limited:
            what = (f"{self.report.tolerance_um:g} um / {self.tol_urad:g} urad" if self.comp.orientation
                    else f"{self.report.tolerance_um:g} um")
            self.report.warnings.append(
                f"line {block.number}: the residual stays at {result.max_residual * 1e6:.2f} um "
                f"(tolerance {what}); no command reaches the desired pose there (singular pose of "
                "the rotary axes, or an error the axes cannot undo)")
        outside = self._outside(np.array([p.end for p in result.pieces]))
        if outside:
            self.report.warnings.append(f"line {block.number}: the compensated command leaves the travel "
                                        f"({outside}); check the machine's soft limits")
        if mv.kind in (2, 3):
            if all(p.kind == "arc" for p in result.pieces):
                self.report.arcs_kept += 1
            else:
                self.report.arcs_as_lines += 1
        # the original block carries the first piece (so its F, S, T, M and modal words act
        # where they did); the further pieces follow as new blocks with explicit G words, and
        # M codes that act at the end of the move (M0, M1, M2, M5, M9, M30) move to the last
        late = [w for w in block.words if w.letter == "M" and w.value in LATE_M] if len(result.pieces) > 1 else []
        eol = newline if newline else self._eol
        prev = result.pieces[0].start
        first = self._rewrite(block, result.pieces[0], prev, st, mv.motion, mv.coord_words, drop=late,
                              append_missing=st["all_known"])
        lines = [first + (eol if len(result.pieces) > 1 else newline)]
        prev = result.pieces[0].end
        for n, piece in enumerate(result.pieces[1:], start=2):
            text = self._new_line(piece, prev, st, mv.motion)
            if n == len(result.pieces):
                lines.append(text + "".join(" " + w.text for w in late) + newline)
            else:
                lines.append(text + eol)
            prev = piece.end
        return lines

    @staticmethod
    def _g_of(piece, motion: int) -> int:
        if piece.kind == "arc":
            return 2 if piece.clockwise else 3
        return motion if motion in (0, 1) else 1

    def _outside(self, q: np.ndarray, slack: float = 0.0) -> str:
        """Which axes ``q`` takes beyond their travel and by how much ('' if none)."""
        travel = self.m.travel
        parts = []
        for j, axis in enumerate(self.axes):
            lo = travel[j, 0] - q[:, j].min()
            hi = q[:, j].max() - travel[j, 1]
            worst = max(lo, hi)
            if worst > slack:
                unit, scale = ("um", 1e6) if self.linear[j] else ("urad", 1e6)
                parts.append(f"{axis} by {worst * scale:.2f} {unit}")
        return ", ".join(parts)

    def _arc(self, block: Block, start, target, clockwise, st):
        plane = PLANES[st["plane"]]
        if not all(a in self.axes and self.linear[self.axes.index(a)] for a in plane):
            raise GcodeError(f"{self.source}:{block.number}: an arc needs linear axes {', '.join(plane)}")
        i, j, k = (self.axes.index(a) for a in plane)
        words = {w.letter: w.value for w in block.words}
        scale = 25.4e-3 if st["inch"] else 1e-3
        if "R" in words:
            r = abs(words["R"]) * scale
            d = target[[i, j]] - start[[i, j]]
            chord = math.hypot(*d)
            if chord < 1e-12 or chord > 2 * r * (1 + 1e-9):
                raise GcodeError(f"{self.source}:{block.number}: R{words['R']:g} cannot join these end points")
            h = math.sqrt(max(r * r - chord * chord / 4, 0.0))
            mid = start[[i, j]] + d / 2
            normal = np.array([-d[1], d[0]]) / chord
            big = words["R"] < 0
            side = (1 if clockwise else -1) * (-1 if big else 1)
            centre = mid - side * h * normal
        else:
            offs = [CENTRE[plane[0]], CENTRE[plane[1]]]
            if not any(o in words for o in offs):
                raise GcodeError(f"{self.source}:{block.number}: an arc needs {offs[0]}/{offs[1]} or R")
            centre = start[[i, j]] + np.array([words.get(offs[0], 0.0), words.get(offs[1], 0.0)]) * scale
        turns = words.get("P", 1.0)
        if turns != int(turns) or turns < 1:
            raise GcodeError(f"{self.source}:{block.number}: P{turns:g} on an arc must be a whole number of turns >= 1")
        try:
            return arc_from_center(start, target, centre, (i, j, k), clockwise, full_turns=int(turns) - 1)
        except InputError as err:
            raise GcodeError(f"{self.source}:{block.number}: {err}") from None

    def _digits(self, axis: str, inch: bool) -> int:
        """Output decimals: 0.1 um (mm), 0.025 um (inch), 0.00001 deg (rotary)."""
        if not self.linear[self.axes.index(axis)]:
            return 5
        return 6 if inch else 4

    def _values(self, piece, prev, st) -> dict[str, str]:
        """Coordinate words of a piece's end. Incremental values are differences of the
        rounded absolute positions, so rounding never accumulates along a G91 section."""
        vals = {}
        for j, axis in enumerate(self.axes):
            d = self._digits(axis, st["inch"])
            end = round(self._from_si(axis, piece.end[j] - self.origin[j], st["inch"]), d)
            if not st["absolute"]:
                end -= round(self._from_si(axis, prev[j] - self.origin[j], st["inch"]), d)
            vals[axis] = self._fmt(axis, end, st["inch"])
        return vals

    def _centre_words(self, piece, prev, st, radius_form: bool) -> list[str]:
        plane = PLANES[st["plane"]]
        i, j = self.axes.index(plane[0]), self.axes.index(plane[1])
        if radius_form:
            r = math.hypot(prev[i] - piece.center[0], prev[j] - piece.center[1])
            r = -r if abs(piece.turns) > math.pi else r
            return [f"R{self._fmt(plane[0], self._from_si(plane[0], r, st['inch']), st['inch'])}"]
        out = []
        for axis, c, p in ((plane[0], piece.center[0], prev[i]), (plane[1], piece.center[1], prev[j])):
            out.append(f"{CENTRE[axis]}{self._fmt(axis, self._from_si(axis, c - p, st['inch']), st['inch'])}")
        return out

    def _new_line(self, piece, prev, st, motion) -> str:
        vals = self._values(piece, prev, st)
        g = self._g_of(piece, motion)
        words = [f"G{g}"] + [f"{a}{vals[a]}" for a in self.axes]
        if piece.kind == "arc":
            words += self._centre_words(piece, prev, st, False)
        st["out_motion"] = g
        return " ".join(words)

    def _rewrite(self, block: Block, piece, prev, st, motion, coord_words, drop=(),
                 append_missing: bool = True) -> str:
        """The original line with the numbers of its coordinate words replaced in place;
        axes it did not name are appended after its last coordinate word. For an arc the
        centre words are replaced likewise; an arc piece that had to become a line gets G1
        and loses its centre words. A block that relied on the modal motion gets an explicit
        motion word when the output's modal motion differs. ``drop``: words to remove (with
        their separating space); ``append_missing`` false while some axes' positions are
        still unknown (those axes are not commanded)."""
        vals = self._values(piece, prev, st)
        edits = [(w.start, w.end, f"{w.letter}{vals[w.letter]}") for w in coord_words]
        present = {w.letter for w in coord_words}
        extra = [f"{a}{vals[a]}" for a in self.axes if a not in present] if append_missing else []

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
            radius_form = any(w.letter == "R" for w in centre_words)
            new = ({t[0]: t for t in self._centre_words(piece, prev, st, radius_form)}
                   if piece.kind == "arc" else {})
            for w in centre_words:
                replacement = new.pop(w.letter, "")
                if replacement:
                    edits.append((w.start, w.end, replacement))
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


@dataclass
class _Move:
    """A desired move read from a block (SI): ``kind`` 0 rapid / end point only, 1 line,
    2/3 arc; ``motion`` the block's motion mode; ``state`` the modal words it is written in."""

    kind: int
    motion: int
    start: np.ndarray
    target: np.ndarray
    arc: object
    coord_words: list
    state: dict
    line: int


@dataclass
class Segment:
    """One interpolated move of a program (SI): ``kind`` "rapid", "line" or "arc"."""

    line: int
    kind: str
    start: np.ndarray
    end: np.ndarray
    arc: object = None

    def sample(self, n: int) -> np.ndarray:
        k = np.linspace(0.0, 1.0, n)
        if self.kind == "arc":
            return self.arc.point(k)
        return self.start + np.outer(k, self.end - self.start)


def interpret(machine: Machine, text: str, source: str = "<program>", start=None, origin=None) -> list[Segment]:
    """The moves of a program as the controller interpolates them (lines in axis space,
    arcs about their centres), in SI axis positions; moves before every axis' position is
    known, and blocks it cannot follow (canned cycles ...), are skipped or taken as rapids."""
    program = Program(machine, source=source, start=start, origin=origin)
    st = program._initial_state()
    out = []
    for number, (body, _) in enumerate(split_lines(text), start=1):
        if program._unsupported(body, st):
            program._follow_skipped(body, st)
            continue
        known_before = st["known"].copy()
        block = parse_block(body, number, source)
        move = program._modal(block, st, check_travel=False)
        if move is None:
            continue
        motion, begin, target, _ = move
        if not known_before.all() or motion == 0:
            out.append(Segment(number, "rapid", begin, target))
        elif motion == 1:
            out.append(Segment(number, "line", begin, target))
        else:
            out.append(Segment(number, "arc", begin, target, program._arc(block, begin, target, motion == 2, st)))
        st["pos"] = target
    return out


def compensate_program(machine: Machine, text: str, *, tol_um: float = 1.0, pass_through: bool = False,
                       method: str = "newton", source: str = "<program>",
                       tol_urad: float | None = None, origin=None) -> tuple[str, Report]:
    """Compensate an NC program; returns the new text and the report.

    ``tol_um``: position tolerance along every move; ``tol_urad``: tool-axis tolerance on
    machines with rotary axes (default 10 urad per um of ``tol_um``)."""
    program = Program(machine, tol_um=tol_um, pass_through=pass_through, method=method, source=source,
                      tol_urad=tol_urad, origin=origin)
    return program.compensate(text), program.report
