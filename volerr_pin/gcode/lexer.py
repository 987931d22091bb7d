"""Words, blocks and lines of an NC program, and the tables of the codes it knows."""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import InputError

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
PLANES = {17: ("X", "Y", "Z"), 18: ("Z", "X", "Y"), 19: ("Y", "Z", "X")}  # arc plane axes, then the third
CENTRE = {"X": "I", "Y": "J", "Z": "K"}  # the arc centre word of each linear axis


class GcodeError(InputError):
    """A program cannot be read or compensated (the message names the line)."""


@dataclass
class Word:
    """One address word of a block, e.g. ``X-12.5``.

    Attributes
    ----------
    letter : str
        The address letter, upper case.
    value : float
        The number as written (mm, inch or deg for coordinates; the code for G and M).
    text : str
        The word as written in the line.
    start, end : int
        Span of the word in the line.
    """

    letter: str
    value: float
    text: str
    start: int
    end: int


@dataclass
class Block:
    """One line of a program.

    Attributes
    ----------
    number : int
        1-based line number.
    text : str
        The line without its line ending.
    words : list of Word
        The words of the line, in order, comments skipped.
    code : str
        The line with its comments blanked out (same spans as ``text``).
    """

    number: int
    text: str
    words: list[Word]
    code: str


def parse_block(line: str, number: int, source: str) -> Block:
    """Words of a line, with their spans in the original text (comments skipped).

    Parameters
    ----------
    line : str
        The line without its line ending.
    number : int
        Its 1-based line number, for messages.
    source : str
        Name of the program, for messages.

    Returns
    -------
    Block
        The line and its words.

    Raises
    ------
    GcodeError
        Unbalanced parentheses, or text that is not a word (a ``%`` ending the line is allowed).
    """
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
    """The lines of a program with their endings.

    Only LF and CR LF end a line (a form feed or other Unicode line separators inside a
    block stay part of it).

    Parameters
    ----------
    text : str
        The whole program.

    Returns
    -------
    list of (str, str)
        (body, line ending) per line; the ending is ``"\\n"``, ``"\\r\\n"`` or ``""`` (last
        line without one).
    """
    out = []
    for raw in re.findall(r"[^\n]*\n|[^\n]+\Z", text):
        body = raw[:-1] if raw.endswith("\n") else raw
        newline = raw[len(body):]
        if body.endswith("\r") and newline:
            body, newline = body[:-1], "\r\n"
        out.append((body, newline))
    return out


def uncommented(line: str) -> str:
    """A line in upper case with each comment replaced by one space.

    Parameters
    ----------
    line : str
        The line without its line ending.

    Returns
    -------
    str
        The code of the line, for checks on blocks :func:`parse_block` may not read
        (macro statements, cycles).
    """
    return COMMENT.sub(" ", line).upper()


def word_values(code: str) -> list[tuple[str, float]]:
    """The words found in ``code``, without :func:`parse_block`'s checks.

    Parameters
    ----------
    code : str
        A line as returned by :func:`uncommented`.

    Returns
    -------
    list of (str, float)
        (letter, value) per word, in order.
    """
    return [(m.group(1).upper(), float(m.group(2))) for m in WORD.finditer(code)]
