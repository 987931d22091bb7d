"""Words, blocks and lines of an NC program, and the tables of the codes it knows.

The reader is strict: outside comments, every character of a block is a blank (space or
tab), part of a word (an ASCII address letter and a plain decimal number), the block delete
``/`` that begins a block, or the ``%`` of a tape start or end line. Anything else is an
error naming the line and the column: a reader that skips what it does not understand
compensates a program other than the one the controller runs.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ...base import InputError

NUMBER = r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)"  # ASCII digits only: no exponent, no inf/nan
WORD = re.compile(rf"([A-Za-z])[ \t]*({NUMBER})")
# a line of plain words only (no E, whose number may be an exponent); atomic and possessive, so
# that a long line that does not match fails in linear time
SIMPLE = re.compile(r"[ \t]*+(?:(?>[A-DF-Za-df-z][ \t]*+[-+]?+(?:[0-9]++(?:\.[0-9]*+)?+|\.[0-9]++))[ \t]*+)*+")
COMMENT = re.compile(r"\([^)]*\)|;.*$")
BLANKS = " \t"
BLANK_RUN = re.compile(r"[ \t]+")
DELIMITER = re.compile(r"[();]")
VARIABLE_WORD = re.compile(r"[A-Z][ \t]*[#\[]")  # X#1, X[#1+2], G#3
#: an assignment to a numbered variable (#5221 = ...)
ASSIGNMENT = re.compile(r"#[ \t]*([0-9]+)[ \t]*=")
#: the first system variable on Fanuc-style controls (#1000 and above: work and tool offsets, modes,
#: positions); writing one may change what later coordinates mean
SYSTEM_VARIABLES = 1000
#: the most digits a whole number (a line number, an o-word's or a parameter's) is read with:
#: beyond, it is too large a number (and Python would refuse to convert it past 4,300)
MOST_DIGITS = 18
PERCENT = re.compile(r"%(_[A-Za-z0-9_.]*)?")  # tape start/end, with a Siemens-style name
MACRO = re.compile(r"\b(IF|WHILE|GOTO|DO\d*|END\d*|SUB|ENDSUB|CALL|RETURN|ELSE|ELSEIF|ENDIF|ENDWHILE|REPEAT|"
                   r"ENDREPEAT|BREAK|CONTINUE|THEN)\b")
CANNED = {73, 74, 76, 81, 82, 83, 84, 85, 86, 87, 88, 89}
MACRO_G = {65, 66, 67}
#: LinuxCNC motions the model does not interpolate: kept unchanged, with every block after them
#: that names axes, up to the next G0-G3 or G80 (like a canned cycle); where they end is not
#: followed (a probe stops where it touches)
KEPT_MOTION = {33: "spindle-synchronized motion", 33.1: "rigid tapping", 38.2: "probing", 38.3: "probing",
               38.4: "probing", 38.5: "probing", 5: "cubic spline", 5.1: "quadratic spline", 5.2: "NURBS",
               5.3: "NURBS end"}
#: LinuxCNC's lathe cycles (their profile is the subroutine named by Q); without Q these codes
#: mean other things on other controls (Siemens: G70 inch, G71 mm), so they are refused
LATHE_CYCLES = {70: "lathe finishing cycle", 71: "lathe roughing cycle", 71.1: "lathe roughing cycle",
                71.2: "lathe roughing cycle", 72: "lathe facing cycle", 72.1: "lathe facing cycle",
                72.2: "lathe facing cycle"}
# G codes whose axis words are not a move the program interpolates (data, reference returns,
# machine coordinates, probing) or that change the geometry in ways not modelled
NOT_MOVES = {10: "data setting", 27: "reference check", 28: "reference return", 29: "return from reference",
             30: "2nd reference return", 31: "probing skip", 53: "machine coordinates", 52: "local coordinate system",
             92: "coordinate shift", 41: "cutter compensation",
             42: "cutter compensation"}
# G codes after which axis words are not axis positions or tool tips (polar and cylindrical
# interpolation, polar coordinates, rotated, scaled or mirrored coordinates, tool orientation
# as a vector): every block up to the code that cancels the mode is kept unchanged
REGIONS = {12.1: ("polar interpolation", (13.1,)), 112: ("polar interpolation", (113,)),
           7.1: ("cylindrical interpolation", ()), 16: ("polar coordinates", (15,)),
           68: ("coordinate rotation", (69,)), 68.1: ("tilted working plane", (69,)),
           68.2: ("tilted working plane", (69,)), 51: ("scaling", (50,)), 51.1: ("mirror image", (50.1,)),
           43.5: ("tool orientation given as a vector", (49, 43, 44, 43.4)),
           92: ("coordinate shift", (92.1, 92.2)),
           92.3: ("coordinate shift restored from the parameters", (92.1, 92.2)),
           # the controller offsets the path by the tool's radius and joins the offset pieces
           # itself: a move split into pieces would get corners it rounds or refuses
           **dict.fromkeys((41, 42, 41.1, 42.1), ("cutter radius compensation", (40,)))}
#: G codes that end every coordinate shift (LinuxCNC: G92.1 resets the G92 offsets, G92.2 sets
#: them aside): bare, they leave coordinates as the program's origin reads them. With axis words
#: the dialects part (LinuxCNC moves there in the modal motion; on Fanuc controls G92.1 presets
#: the workpiece coordinates to them), so such a block is refused
SHIFT_RESETS = (92.1, 92.2)
# shifts of the program's zero that last until a block of the same code sets them back to zero
# (G52 X0 Y0 Z0): every block while one axis is shifted is kept unchanged
SHIFTS = {52: "local coordinate system"}
# data settings that change a work offset (G10 L2 / L20): the program's zero is no longer the
# origin given, and every block after is kept unchanged
OFFSET_DATA = {2, 20}
#: G50: the end of scaling (G51) on mills; with axis words, a coordinate setting on Fanuc lathes
SCALING_OFF = 50
#: the longest G code: three digits and one decimal (G43.4, G112, G68.2)
G_DIGITS = re.compile(r"G[ \t]*[-+]?(?:[0-9]{1,3}(?:\.[0-9]?)?|\.[0-9])", re.IGNORECASE)  # a sign: check_words
CYLINDRICAL = 7.1  # cancelled by G7.1 with a zero rotary word (G7.1 C0)
# statements of Siemens controls: tool-tip programming on and off, and the transformations that
# start regions like those above (ended by TRAFOOF)
KEYWORD = re.compile(r"[ \t]*(?:N[0-9]+[ \t]+)?(TRAORI|TRAFOOF|TRANSMIT|TRACYL)\b", re.IGNORECASE)
TOOL_TIP_ON = (43.4,)  # G codes that select tool-tip programming (tool centre point control)
TOOL_TIP_OFF = (43, 44, 49)  # ... and that end it (the same modal group)
#: the address letters of axes
AXIS_LETTERS = "XYZABCUVW"
WORK_OFFSETS = {54, 55, 56, 57, 58, 59, 54.1, 59.1, 59.2, 59.3}
# the modal group of every G code the reader knows; a code not listed here is refused (or
# passed through with a warning), never read as a move
G_GROUPS = {
    **dict.fromkeys((0, 1, 2, 3), "motion"),
    **dict.fromkeys((4, 9, 10, 27, 28, 29, 30, 31, 52, 53, 65, 92, 92.1, 92.2, 92.3), "non-modal"),
    **dict.fromkeys((17, 18, 19), "plane"), **dict.fromkeys((20, 21), "units"),
    **dict.fromkeys((40, 41, 42, 41.1, 42.1), "cutter compensation"),
    **dict.fromkeys((43, 44, 43.4, 43.5, 49), "tool length offset"),
    **dict.fromkeys((51, 50), "scaling"), **dict.fromkeys((51.1, 50.1), "mirror image"),
    **dict.fromkeys((12.1, 13.1, 112, 113), "polar interpolation"), 7.1: "cylindrical interpolation",
    **dict.fromkeys((15, 16), "polar coordinates"), **dict.fromkeys(WORK_OFFSETS, "work offset"),
    **dict.fromkeys((61, 64), "path control"),
    **dict.fromkeys((66, 67), "modal macro"), **dict.fromkeys((68, 68.1, 68.2, 69), "coordinate rotation"),
    **dict.fromkeys(CANNED | {80}, "canned cycle"), **dict.fromkeys((90, 91), "distance"),
    **dict.fromkeys((90.1, 91.1), "arc centre distance"), **dict.fromkeys((7, 8), "lathe diameter"),
    **dict.fromkeys((93, 94, 95), "feed"),
    **dict.fromkeys((96, 97), "spindle speed"), **dict.fromkeys((98, 99), "canned cycle return")}
# M codes the reader knows, by group; two of one group in a block contradict each other
# (except mist and flood coolant, M7 M8, which run together). An M code not listed may change
# how later blocks read (LinuxCNC's M72 restores the distance, unit and plane modes), so it is
# refused unless kept explicitly, as an unknown G code is
M_GROUPS = {**dict.fromkeys((0, 1, 2, 30, 60), "stop"), **dict.fromkeys((3, 4, 5, 19), "spindle"),
            6: "tool change", 61: "tool number", **dict.fromkeys((7, 8, 9), "coolant"),
            **dict.fromkeys((48, 49, 50, 51, 52, 53), "override"), **dict.fromkeys((62, 63, 64, 65), "output"),
            66: "input", **dict.fromkeys((67, 68), "analog output"), **dict.fromkeys((70, 71, 72, 73), "modal state"),
            **dict.fromkeys((98, 99), "subprogram")}
#: LinuxCNC's user M codes run a program of the machine's configuration, which cannot change the
#: interpreter's modes or move the axes through it
USER_M = range(100, 200)
#: LinuxCNC's modal state: M70 saves the modes (units, distance, arc centre distance, plane, feed
#: mode), M71 forgets what was saved, M72 restores it (not the motion mode), M73 saves them to be
#: restored at the return from the subroutine it stands in
SAVE_MODES, FORGET_MODES, RESTORE_MODES, AUTORESTORE_MODES = 70, 71, 72, 73
TOOL_CHANGE_M = 6  # its macro moves the axes to the change position: the position is lost
PROGRAM_END = (2, 30)  # M codes that end the program: a controller reads nothing after them
#: the axis whose words are diameters in LinuxCNC's lathe diameter mode (G7; G8 radius mode),
#: its centre word I staying a radius
DIAMETER_AXIS = "X"
LATE_M = (0, 1, 2, 5, 9, 30)  # M codes that act at the end of their block's move
PLANES = {17: ("X", "Y", "Z"), 18: ("Z", "X", "Y"), 19: ("Y", "Z", "X")}  # arc plane axes, then the third
CENTRE = {"X": "I", "Y": "J", "Z": "K"}  # the arc centre word of each linear axis
WHOLE = "NOMTHD"  # letters whose number is a whole, unsigned code
UNSIGNED = "GFS"  # letters whose number has no sign (G codes, feed, spindle speed)


class GcodeError(InputError):
    """A program cannot be read or compensated (the message names the line)."""


@dataclass(slots=True)
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
        Span of the word in the line (0-based; the column is ``start + 1``).
    """

    letter: str
    value: float
    text: str
    start: int
    end: int

    @property
    def name(self) -> str:
        """The word without blanks, upper case, shortened for messages (str)."""
        return shortened(re.sub(r"[ \t]", "", self.text).upper())


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
    delete : bool
        The block starts with a block delete ``/``: the controller skips it when the
        operator's switch is on.
    statement : str
        A statement the block is instead of words (``"TRAORI"``, ``"TRAFOOF"``), else empty.
    """

    number: int
    text: str
    words: list[Word]
    code: str
    delete: bool = False
    statement: str = ""


def shortened(text: str) -> str:
    """A piece of a line as messages give it: whole up to 24 characters, else its first 20 and
    "...".

    Parameters
    ----------
    text : str
        The piece.

    Returns
    -------
    str
    """
    return text if len(text) <= 24 else text[:20] + "..."


def show(text: str) -> str:
    """A piece of a line for a message: quoted, control and non-ASCII characters named, shortened.

    Parameters
    ----------
    text : str
        The piece.

    Returns
    -------
    str
        E.g. ``'X--5'`` or ``U+2212 ('−')``.
    """
    if len(text) == 1 and (not text.isascii() or not text.isprintable()):
        shown = f" ({text!r})" if text.isprintable() else ""
        return f"U+{ord(text):04X}{shown}"
    return repr(shortened(text))


def _a(letter: str) -> str:
    return "an" if letter in "AEFHILMNORSX" else "a"


def _where(source: str, number: int, col: int) -> str:
    return f"{source}:{number}:{col + 1}"


def _stray(line: str, i: int, source: str, number: int) -> GcodeError:
    """The error for a character at ``i`` that does not begin a word."""
    ch = line[i]
    where = _where(source, number, i)
    if ch == "\r":
        return GcodeError(f"{where}: a carriage return (CR) inside a line; only LF and CR LF end lines")
    if not ch.isascii():
        hint = " (write '-' for a minus)" if ch in "\u2212\u2013\u2014\ufe63\uff0d" else ""
        return GcodeError(f"{where}: cannot read {show(ch)}, which is not an ASCII character{hint}")
    if ch.isalpha():
        context = re.match(r"[^ \t]*", line[i:]).group(0)
        shown = f" ({show(context)})" if len(context) > 1 else ""
        return GcodeError(f"{where}: '{ch}' is not followed by a number{shown}")
    if ch in "0123456789+-.":
        context = re.match(r"[^ \t]*", line[i:]).group(0)
        return GcodeError(f"{where}: a number without an address letter ({show(context)}); blanks do not join "
                          "digits")
    return GcodeError(f"{where}: cannot read {show(ch)}")


def mask_comments(line: str, number: int, source: str) -> str:
    """A line with its comments replaced by blanks (same length and spans).

    Comments are ``( ... )`` (not nested) and ``;`` to the end of the line.

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
    str
        The code of the line.

    Raises
    ------
    GcodeError
        A comment that is not closed, a ``(`` inside a comment or a ``)`` outside one,
        naming line and column.
    """
    if "(" not in line and ")" not in line and ";" not in line:
        return line
    out = list(line)
    i = 0
    for m in DELIMITER.finditer(line):
        at = m.start()
        if at < i:
            continue  # inside a comment already blanked
        ch = m.group(0)
        if ch == ";":
            out[at:] = " " * (len(line) - at)
            break
        if ch == ")":
            raise GcodeError(f"{_where(source, number, at)}: unbalanced parenthesis: ')' without '('")
        close = line.find(")", at + 1)
        if close < 0:
            raise GcodeError(f"{_where(source, number, at)}: unbalanced parenthesis: the comment opened "
                             "here is not closed on its line")
        inner = line.find("(", at + 1, close)
        if inner >= 0:
            raise GcodeError(f"{_where(source, number, inner)}: unbalanced parenthesis: '(' inside a "
                             "comment (comments do not nest)")
        out[at:close + 1] = " " * (close + 1 - at)
        i = close + 1
    return "".join(out)


def parse_block(line: str, number: int, source: str, code: str | None = None) -> Block:
    """Words of a line, with their spans in the original text (comments skipped).

    Parameters
    ----------
    line : str
        The line without its line ending.
    number : int
        Its 1-based line number, for messages (a byte order mark may begin line 1).
    source : str
        Name of the program, for messages.
    code : str, optional
        The line as :func:`mask_comments` returns it, when the caller has it already.

    Returns
    -------
    Block
        The line and its words.

    Raises
    ------
    GcodeError
        Naming line and column: unbalanced parentheses; a character that is not a blank and
        not part of a word (an address letter without a number, a second decimal point or
        sign, an exponent, a non-ASCII character, a CR); a number too large to hold; a ``/``
        that does not begin the block; a ``%`` that does not begin its line, or text after it.
    """
    if code is None:
        code = mask_comments(line, number, source)
    if SIMPLE.fullmatch(code):  # plain words only: the loop below would find exactly these
        words = []
        for m in WORD.finditer(code):
            letter, number_text = m.groups()
            start, end = m.span()
            words.append(Word(letter.upper(), float(number_text), m.group(), start, end))
        if all(math.isfinite(w.value) for w in words):
            return Block(number, line, words, code, False)
    words: list[Word] = []
    delete = False
    i = 1 if number == 1 and code.startswith("\ufeff") else 0  # a byte order mark
    n = len(code)
    first = True  # nothing but blanks (and comments) read yet
    while i < n:
        ch = code[i]
        if ch in BLANKS:
            i = BLANK_RUN.match(code, i).end()
            continue
        if ch == "/" and first:
            delete, first = True, False
            i += 2 if i + 1 < n and code[i + 1] in "123456789" else 1  # /1 ... /9 select a switch
            continue
        if ch == "%" and first:
            m = PERCENT.match(code, i)
            rest = code[m.end():]
            if rest.strip(BLANKS):
                j = m.end() + len(rest) - len(rest.lstrip(BLANKS))
                raise GcodeError(f"{_where(source, number, j)}: text after '%' (a tape start or end line holds "
                                 "nothing else)")
            break
        if ch == "/":
            raise GcodeError(f"{_where(source, number, i)}: a block delete '/' must begin the block")
        if ch == "%":
            raise GcodeError(f"{_where(source, number, i)}: a '%' must stand on its own line")
        m = WORD.match(code, i)
        if m is None:
            raise _stray(code, i, source, number)
        end = m.end()
        if end < n and code[end] in ".0123456789":
            run = re.match(r"[-+.0-9]*", code[end:]).group(0)
            raise GcodeError(f"{_where(source, number, end)}: {show(m.group(0) + run)} is not a number "
                             "(a second decimal point?)")
        if end < n and code[end] in "eE" and re.match(r"[eE][-+]?[0-9]", code[end:end + 3]):
            exp = re.match(r"[eE][-+]?[0-9]*", code[end:]).group(0)
            raise GcodeError(f"{_where(source, number, i)}: {show(m.group(0) + exp)}: NC numbers have no "
                             "exponent; write the value in full")
        value = float(m.group(2))
        if not math.isfinite(value):
            raise GcodeError(f"{_where(source, number, i)}: {show(m.group(0))} is too large a number")
        words.append(Word(m.group(1).upper(), value, m.group(0), i, end))
        first = False
        i = end
    return Block(number, line, words, code, delete)


def check_words(block: Block, source: str) -> None:
    """Check the words of a block against each other, whatever the machine and the modes.

    Each address appears once (G and M words once per code and group); N begins the block,
    O stands alone; N, O, M, T, H, D are whole numbers without a sign, and G, F, S have no
    sign.

    Parameters
    ----------
    block : Block
        The block.
    source : str
        Name of the program, for messages.

    Raises
    ------
    GcodeError
        Naming line, column and word: a repeated address, two codes of one group, a
        misplaced N or O, a code that is not a whole number, a sign where none belongs.
    """
    seen: dict[str, Word] = {}
    groups: dict[tuple[str, str], Word] = {}
    for k, w in enumerate(block.words):
        letter = w.letter
        problem = None
        if letter in WHOLE or letter in UNSIGNED:
            if "-" in w.text or "+" in w.text:
                problem = f"{w.name}: {_a(letter)} {letter} word has no sign"
            elif letter in WHOLE and w.value != int(w.value):
                problem = f"{w.name}: {_a(letter)} {letter} word is a whole number"
            elif letter == "N" and k > 0:
                problem = f"{w.name}: a sequence number begins its block"
            elif letter == "O" and (k > 0 or len(block.words) > 1):
                problem = f"{w.name}: a program number stands alone on its line"
        if problem is None and letter in "GM":
            table = G_GROUPS if letter == "G" else M_GROUPS
            key = (letter, table.get(w.value, f"{w.value!r}"))  # an unknown code is its own group
            other = groups.get(key)
            if other is not None and other.value == w.value:
                problem = f"{w.name} appears twice in the block"
            elif other is not None and {other.value, w.value} != {7, 8}:
                problem = f"{other.name} and {w.name} in one block: both are {key[1]} codes"
            groups[key] = w
        elif problem is None:
            if letter in seen:
                problem = f"{letter} appears twice in the block ({seen[letter].name} and {w.name})"
            seen[letter] = w
        if problem is not None:
            raise GcodeError(f"{_where(source, block.number, w.start)}: {problem}")


def check_tape(lines: list[tuple[str, str]], source: str) -> None:
    """Refuse text after the ``%`` that ends a program.

    A program that begins with a ``%`` line ends at the next one; one that does not ends at its
    first. LinuxCNC reads nothing after that line (and refuses a ``%`` in a program that did
    not begin with one), so a block there would be compensated or predicted although it never
    runs.

    Parameters
    ----------
    lines : list of (str, str)
        The program's lines and their endings.
    source : str
        Its name, for messages.

    Raises
    ------
    GcodeError
        A line with text after the closing ``%``, naming it and the ``%`` line.
    """
    opening, closing = None, None
    for k, (body, _) in enumerate(lines):
        if "%" not in body and closing is None:   # (most lines: one scan in C)
            if opening is None and body.strip(BLANKS):
                opening = False
            continue
        text = body.strip(BLANKS)
        if closing is not None:
            if text:
                raise GcodeError(f"{source}:{k + 1}: text after the '%' of line {closing + 1}, which ends the "
                                 "program: LinuxCNC reads nothing after it (remove the text, or that '%')")
            continue
        tape = text == "%"   # (a named one, %_N_PART_MPF, begins a program of a Siemens file)
        if opening is None and text:
            opening = tape
            if tape:
                continue
        if tape:
            closing = k


def split_lines(text: str) -> list[tuple[str, str]]:
    """The lines of a program with their endings.

    Only LF and CR LF end a line (a lone CR or other Unicode line separators inside a
    block stay part of it, and :func:`parse_block` refuses them).

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
        (letter, value) per word, in order; numbers too large to hold are left out.
    """
    out = []
    for m in WORD.finditer(code):
        value = float(m.group(2))
        if math.isfinite(value):
            out.append((m.group(1).upper(), value))
    return out


def macro_statement(code: str) -> tuple[str, bool] | None:
    """What makes a line a macro statement, if anything.

    Parameters
    ----------
    code : str
        The line with its comments blanked out.

    Returns
    -------
    (str, bool) or None
        What it is (``"a macro statement (IF)"``, ``"a macro variable (#)"`` ...), and whether
        it may move the machine, change which blocks run or what later coordinates mean (a
        jump, a loop, a call, a word whose value is a variable or an expression, a write to a
        system variable, #1000 and above) rather than only set a variable; None for a plain
        block.
    """
    upper = code.upper()
    keyword = MACRO.search(upper)
    if keyword:
        return f"a macro statement ({shortened(keyword.group(1))})", True
    word = VARIABLE_WORD.search(upper)
    if word:
        return f"a word whose value is a macro variable or expression ({word.group(0).replace(' ', '')}...)", True
    for assignment in ASSIGNMENT.finditer(code):
        if len(assignment.group(1)) > MOST_DIGITS or int(assignment.group(1)) >= SYSTEM_VARIABLES:
            return (f"a write to system variable #{int(assignment.group(1))} (work or tool offsets, modes or "
                    "positions on Fanuc-style controls)"), True
    if "#" in code:
        return "a macro variable (#)", False
    return None
