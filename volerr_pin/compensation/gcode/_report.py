"""What a compensation did: the report, with warnings that name their lines in bounded memory."""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Detail", "Report", "Warnings"]

#: line ranges kept per warning text; beyond, lines are counted only
MOST_RANGES = 2000
#: different warning texts kept; beyond, warnings are counted only
MOST_TEXTS = 5000


class Warnings:
    """Warnings of a program by text, each with the lines it concerns (as ranges).

    A text that concerns many lines is one warning (``"lines 12-40 and 55: G81 ... kept
    unchanged"``): a program of millions of lines gives a readable report in bounded memory.

    Attributes
    ----------
    general : list of str
        Warnings about no line in particular, in the order given.
    """

    def __init__(self):
        self._lines: dict[str, array] = {}
        self._more: dict[str, int] = {}
        self._first: dict[str, int] = {}
        self._worst: dict[str, float] = {}
        self._dropped = 0
        self.general: list[str] = []
        self.origin = None   # for an expanded program: the line each block as run comes from

    def add(self, line: int, text: str, worst: float | None = None) -> None:
        """Note ``text`` about a line.

        Parameters
        ----------
        line : int
            1-based line number.
        text : str
            The warning, without the ``line N:`` prefix; with ``worst``, a template with a
            ``{worst}`` field (``"by up to {worst:.2f} um"``).
        worst : float, optional
            A value the warning gives the largest of over all its lines.
        """
        if self.origin is not None and 1 <= line <= len(self.origin):
            line = self.origin[line - 1]
        ranges = self._lines.get(text)
        if ranges is None:
            if len(self._lines) >= MOST_TEXTS:
                self._dropped += 1
                return
            ranges = self._lines[text] = array("q")
            self._first[text] = line
        if worst is not None:
            self._worst[text] = max(self._worst.get(text, worst), worst)
        if len(ranges) and ranges[-1] in (line, line - 1):
            ranges[-1] = line
        elif len(ranges) < 2 * MOST_RANGES:
            ranges.extend((line, line))
        else:
            self._more[text] = self._more.get(text, 0) + 1

    def note(self, text: str) -> None:
        """Note a warning about no line in particular.

        Parameters
        ----------
        text : str
            The warning.
        """
        self.general.append(text)

    def __contains__(self, text: str) -> bool:
        return text in self._lines

    def render(self) -> list[str]:
        """Every warning as a line of text, general ones first, then by first line.

        Returns
        -------
        list of str
            ``"line N: text"``, ``"lines N, M-K and L: text"`` (with ``"... and n more"`` when
            more lines than :data:`MOST_RANGES` ranges).
        """
        out = list(self.general)
        if self._dropped:
            out.append(f"{self._dropped:,} more warnings of other kinds are not listed (more than {MOST_TEXTS:,} "
                       "kinds)")
        for text in sorted(self._lines, key=lambda t: self._first[t]):
            r = self._lines[text]
            parts = [str(r[i]) if r[i] == r[i + 1] else f"{r[i]}-{r[i + 1]}" for i in range(0, len(r), 2)]
            single = len(parts) == 1 and "-" not in parts[0] and not self._more.get(text)
            if len(parts) > 1:
                parts = [", ".join(parts[:-1]), parts[-1]]
            where = " and ".join(parts)
            more = self._more.get(text)
            if more:
                where += f" and {more:,} more"
            shown = text.format(worst=self._worst[text]) if text in self._worst else text
            out.append(f"{'line' if single else 'lines'} {where}: {shown}")
        return out


class Detail:
    """Per move: line, pieces, largest error before and residual after [um] (for pictures),
    kept as compact arrays (16 bytes a move).

    Attributes
    ----------
    size : int
        Moves noted.
    """

    def __init__(self):
        self._line = array("q")
        self._pieces = array("q")
        self._before = array("f")
        self._after = array("f")
        self.size = 0

    def extend(self, line, pieces, before_um, after_um) -> None:
        """Note moves.

        Parameters
        ----------
        line, pieces : array_like of int, shape (M,)
            Line of each move and the pieces written for it.
        before_um, after_um : array_like, shape (M,)
            Largest error along it before, residual after compensation [um].
        """
        self._line.extend(np.asarray(line, dtype=np.int64).tolist())
        self._pieces.extend(np.asarray(pieces, dtype=np.int64).tolist())
        self._before.extend(np.asarray(before_um, dtype=np.float32).tolist())
        self._after.extend(np.asarray(after_um, dtype=np.float32).tolist())
        self.size = len(self._line)

    def __len__(self) -> int:
        return self.size

    def __array__(self, dtype=None, copy=None):
        out = np.column_stack([np.frombuffer(self._line, dtype=np.int64).astype(float),
                               np.frombuffer(self._pieces, dtype=np.int64).astype(float),
                               np.frombuffer(self._before, dtype=np.float32).astype(float),
                               np.frombuffer(self._after, dtype=np.float32).astype(float)]) if self.size \
            else np.zeros((0, 4))
        return out if dtype is None else out.astype(dtype)


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
        Largest remaining tool error along the compensated moves [um] (a bound: the sampled
        maximum plus what may hide between samples).
    max_before_um : float
        Largest tool error along the moves run uncompensated [um].
    tolerance_um : float
        The position tolerance asked for [um].
    arcs_kept, arcs_as_lines : int
        Arcs written as arcs only, and arcs some of whose pieces became lines.
    passed_through : int
        Lines kept unchanged because they cannot be compensated (named in the warnings).
    moves_kept : int
        Of those, the lines that name an axis (moves run uncompensated).
    motion_compensated : float or None
        ``moves / (moves + moves_kept)``: the share of the program's moves compensated (None
        for a program without moves).
    expanded : dict or None
        For a program whose parameters, expressions and O-words were followed (see
        :mod:`._macros`): ``blocks_run``, ``calls``, ``loop_passes``.
    programming : list of str
        Programming modes the moves were read in (``"axes"``, ``"tool-tip"``).
    dialect : str
        The dialect the program was read in (``"linuxcnc"``, ``"fanuc"``, ``"haas"``).
    dialect_said : str
        What decided it: ``"given"``, what in the program says it (``"detected: line 1: O1000,
        a FANUC program number"``), or that nothing says another.
    warnings : list of str
        Messages, in line order (``"line N: ..."``, ``"lines N-M and K: ..."``).
    detail : Detail
        Per move: line, pieces, largest error before [um], largest residual after [um];
        kept out of :meth:`to_dict`, drawn by ``compensation_png``; filled only when asked for.
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
    passed_through: int = 0
    moves_kept: int = 0
    expanded: dict | None = None
    programming: list[str] = field(default_factory=list)
    dialect: str = "linuxcnc"
    dialect_said: str = ""
    warnings: list[str] = field(default_factory=list)
    detail: Detail = field(default_factory=Detail, repr=False)

    @property
    def motion_compensated(self) -> float | None:
        """The share of the program's moves compensated (None without moves)."""
        total = self.moves + self.moves_kept
        return self.moves / total if total else None

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
                "passed_through": self.passed_through, "moves_kept": self.moves_kept,
                "motion_compensated": self.motion_compensated, "expanded": self.expanded,
                "programming": list(self.programming), "dialect": self.dialect,
                "dialect_said": self.dialect_said, "warnings": list(self.warnings)}
