"""Dialects: what a controller family sets by default, and telling a program's dialect.

The same words mean different things on different controllers. LinuxCNC refuses an M code it
does not define; on a FANUC control, every M code but a few is an auxiliary function of the
machine builder, sent to the machine's logic, which moves no axis of the program. A FANUC or
Haas lathe reads X as a diameter; LinuxCNC reads it as a radius unless G7 says otherwise. A
``%`` line may carry text on a FANUC tape (its leader), and ``:0097`` is a program number
there. G10 L20 sets an additional work offset on FANUC, and makes the current position read as
the given one on LinuxCNC.

A :class:`Dialect` holds what the reader needs of each; :func:`detect` tells the dialect of a
program where its own text says it unambiguously (a FANUC program number, a HEIDENHAIN
``BEGIN PGM``, a SINUMERIK ``DEF`` ...), and :func:`foreign` names the construct of a dialect
this reader does not read, for a refusal that says what the program is.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field

from ._lexer import GcodeError, shortened

__all__ = ["DIALECTS", "Dialect", "NAMES", "blank_statements", "choose", "detect", "dialect_of", "foreign"]

#: the dialects a program may be read in
NAMES = ("linuxcnc", "fanuc", "haas", "siemens", "heidenhain")
#: the lines :func:`detect` reads at most (a program says its dialect in its first blocks)
DETECT_LINES = 2_000

# Haas mill and lathe operator's manuals, M-code lists: the codes that move no axis of the program
# (brakes, clamps, coolant, chip conveyors, doors, relays, gear ranges, air blasts, spindle
# variation, display); tool and pallet changes and the turret move the machine; M46, M96, M97,
# M98, M99 jump, call and return
_HAAS_MOTIONLESS = {
    7: "shower coolant", 10: "4th axis brake (chuck clamp on lathes)", 11: "4th axis brake release (chuck unclamp)",
    12: "5th axis brake (air jet on lathes)", 13: "5th axis brake release (air jet off)",
    14: "main spindle brake", 15: "main spindle brake release",
    17: "pallet unclamp and door open", 18: "pallet clamp and door close",
    21: "optional user M with M-fin (tailstock advance on lathes)",
    22: "optional user M with M-fin (tailstock retract on lathes)",
    23: "optional user M with M-fin (chamfer out of thread on lathes)",
    24: "optional user M with M-fin (chamfer out of thread off on lathes)",
    **dict.fromkeys(range(25, 29), "optional user M with M-fin"), 29: "output relay with M-fin",
    31: "chip auger forward", 33: "chip auger stop", 34: "coolant spigot increment",
    35: "coolant spigot decrement (parts catcher on lathes)", 36: "pallet part ready (parts catcher off on lathes)",
    37: "parts catcher off", 38: "spindle speed variation on", 39: "spindle speed variation off",
    41: "low gear", 42: "high gear", 43: "turret unlock", 44: "turret lock", 48: "check of the program's validity",
    49: "pallet status", **dict.fromkeys(range(51, 59), "optional user M on"), 59: "output relay on",
    **dict.fromkeys(range(61, 69), "optional user M off"), 69: "output relay off",
    75: "reference point for G35 / G136", 76: "display off", 77: "display on",
    78: "alarm if skip signal found", 79: "alarm if skip signal not found",
    80: "door open", 81: "door close", 82: "tool unclamp", 83: "air gun on", 84: "air gun off", 85: "door open",
    86: "tool clamp (door close on lathes)", 88: "through-spindle coolant on", 89: "through-spindle coolant off",
    95: "sleep mode", 104: "probe arm extend", 105: "probe arm retract", 109: "interactive user input",
    110: "secondary spindle chuck clamp", 111: "secondary spindle chuck unclamp",
    **dict.fromkeys(range(121, 129), "optional user M with M-fin"), 130: "display media", 131: "display media off",
    133: "live tool forward", 134: "live tool reverse", 135: "live tool stop", 138: "spindle speed variation on",
    139: "spindle speed variation off", 143: "secondary spindle forward", 144: "secondary spindle reverse",
    145: "secondary spindle stop", 146: "steady rest clamp", 147: "steady rest unclamp",
    158: "mist condenser on", 159: "mist condenser off"}
# FANUC and Haas lathes (G code system A): the multiple repetitive cycles and the single cycles
_LATHE_CYCLES = {70: "finishing cycle", 71: "stock removal in turning", 72: "stock removal in facing",
                 73: "pattern repeating", 74: "end face peck drilling", 75: "outer diameter grooving",
                 76: "multiple threading cycle", 90: "outer diameter cutting cycle", 92: "threading cycle",
                 94: "end face turning cycle"}
# codes every ISO dialect shares: stops, spindle, coolant, tool change, end
_ISO_M = {0: "program stop", 1: "optional stop", 2: "program end", 3: "spindle clockwise",
          4: "spindle counter-clockwise", 5: "spindle stop", 6: "tool change", 8: "coolant on", 9: "coolant off",
          19: "spindle orientation", 30: "program end and rewind"}


@dataclass(frozen=True)
class Dialect:
    """What a controller family sets by default, as far as the reader needs it.

    Attributes
    ----------
    name : str
        One of :data:`NAMES`.
    title : str
        The controllers' name, for messages (``"FANUC"``).
    m_codes : dict of int to str
        M codes known to move no axis of the program, and what they do (beyond those the
        reader's tables follow).
    moving_m : dict of int to str
        M codes that move the machine somewhere the program does not say (tool and pallet
        changes): kept, and every axis position becomes unknown after them.
    call_m : dict of int to str
        M codes that call, jump or return (kept unchanged, and what follows them is not
        followed).
    builder_m : bool
        M codes in no table are the machine builder's auxiliary functions (FANUC: they move no
        axis of the program), kept and named; otherwise they are refused as unknown.
    linuxcnc_modes : bool
        LinuxCNC's M70-M73 (save and restore the modes), M100-M199 (user M codes) and G7 / G8
        (diameter and radius mode) hold.
    lathe_diameter : bool
        On a lathe, X words are diameters unless the program says otherwise.
    tape_text : bool
        A ``%`` line may carry text after its ``%`` (the tape's leader), which is not read.
    colon_numbers : bool
        ``:0097`` is a program number, as ``O0097``.
    offset_p0 : str or None
        What G10 L2 P0 sets: ``"current"`` (the offset in force, LinuxCNC), ``"external"`` (the
        external offset added to every work offset, FANUC) or None (not followed).
    l20_extended : bool
        G10 L20 Pn sets the additional work offset ``G54.1 Pn`` (FANUC, Haas's ``G154 Pn``), not
        LinuxCNC's "the current position reads as these values".
    offsets_incremental : bool
        G10 L2 in G91 adds its values to the offset (FANUC) rather than setting them.
    extended_offset : str
        The code of the additional work offsets, ``"G54.1"`` or ``"G154"``.
    g_codes : dict of float to str
        G codes of the dialect that move nothing and change nothing the reader follows (FANUC's
        look-ahead G8, AI contour control G5.1; Haas's accuracy control G187).
    lathe_cycles : dict of float to str
        G codes that are cycles on the dialect's lathes (FANUC and Haas: G70 - G76, and G90,
        G92, G94, which are absolute programming and a coordinate shift on mills): kept, with
        the blocks of their axis words that follow.
    g_aliases : dict of float to float
        G codes of the dialect that mean a code the reader follows (SINUMERIK's G70 / G71 and
        G700 / G710: inch and mm, G20 / G21).
    statements : bool
        SINUMERIK's statements that move nothing (SOFT, FFWON, COMPCAD, ORIWKS, CYCLE832, MSG,
        ``T="name"`` ...) stand in its blocks beside ISO words: they are kept as written and
        the words around them read (:func:`blank_statements`).
    expands : bool
        Its parameters, expressions and O-words are followed as LinuxCNC runs them (not
        SINUMERIK's, whose R parameters and statements are not LinuxCNC's).
    decimal_point : bool
        A number without a decimal point is a count of least input increments (FANUC's and
        Haas's standard input: ``X10`` is 0.010 mm or 0.0010 inch) unless the control is set to
        calculator-type input: such a coordinate (other than zero) is refused, naming it.
    reads : bool
        The reader reads its programs (HEIDENHAIN Klartext programs are refused; of SINUMERIK's,
        the ISO G-code subset is read and its own language refused, naming the construct).
    """

    name: str
    title: str
    m_codes: dict = field(default_factory=dict)
    moving_m: dict = field(default_factory=dict)
    call_m: dict = field(default_factory=dict)
    builder_m: bool = False
    linuxcnc_modes: bool = False
    lathe_diameter: bool = False
    tape_text: bool = False
    colon_numbers: bool = False
    offset_p0: str | None = None
    l20_extended: bool = False
    offsets_incremental: bool = False
    extended_offset: str = "G54.1"
    g_codes: dict = field(default_factory=dict)
    lathe_cycles: dict = field(default_factory=dict)
    g_aliases: dict = field(default_factory=dict)
    statements: bool = False
    expands: bool = True
    decimal_point: bool = False
    reads: bool = True

    def motionless(self, m: float) -> str | None:
        """What an M code that moves no axis does (None for one the dialect does not know as such).

        Parameters
        ----------
        m : float
            The code.

        Returns
        -------
        str or None
            What it does.
        """
        return self.m_codes.get(m) or _ISO_M.get(m) if m not in self.moving_m and m not in self.call_m else None


DIALECTS = {
    "linuxcnc": Dialect("linuxcnc", "LinuxCNC", moving_m={6: "tool change"},
                        call_m={98: "subprogram call", 99: "subprogram return"}, linuxcnc_modes=True,
                        offset_p0="current"),
    "fanuc": Dialect("fanuc", "FANUC", moving_m={6: "tool change", 60: "pallet change"},
                     call_m={98: "subprogram call", 99: "subprogram return", 198: "subprogram call from external "
                             "memory"},
                     m_codes={29: "rigid tapping mode"}, builder_m=True, lathe_diameter=True, tape_text=True,
                     colon_numbers=True, offset_p0="external", l20_extended=True, offsets_incremental=True,
                     g_codes={5: "high-speed machining (G5 P10000)", 5.1: "AI contour control",
                              8: "look-ahead control", 61.1: "tool path control", 62: "automatic corner override",
                              63: "tapping mode"},
                     lathe_cycles=_LATHE_CYCLES, decimal_point=True),
    "haas": Dialect("haas", "Haas", m_codes=_HAAS_MOTIONLESS,
                    moving_m={6: "tool change", 16: "tool change", 50: "pallet change", 154: "C axis engage",
                              155: "C axis disengage"},
                    call_m={46: "jump if the pallet is loaded", 96: "jump if no input", 97: "local subprogram call",
                            98: "subprogram call", 99: "subprogram return"},
                    lathe_diameter=True, tape_text=True, colon_numbers=False, offset_p0=None, l20_extended=True,
                    offsets_incremental=True, extended_offset="G154",
                    g_codes={187: "accuracy control", 103: "block look-ahead limit", 5.1: "AI contour control",
                             8: "look-ahead control"},
                    lathe_cycles=_LATHE_CYCLES, decimal_point=True),
    # its ISO G-code subset is read; its own language (DEF, R parameters, CR=, cycles ...) is refused by name
    "siemens": Dialect("siemens", "SINUMERIK", m_codes={**dict.fromkeys(range(40, 46), "gear stage")},
                       moving_m={6: "tool change"}, call_m={17: "subprogram end"}, builder_m=True,
                       lathe_diameter=True,
                       g_aliases={70: 20, 71: 21, 700: 20, 710: 21},
                       g_codes={60: "exact stop", 9: "exact stop, non-modal", 601: "exact stop window fine",
                                602: "exact stop window coarse", 603: "exact stop at interpolation end",
                                641: "continuous path, rounding by distance", 642: "continuous path, rounding by "
                                "tolerance", 643: "continuous path, block-internal rounding", 644: "continuous path, "
                                "rounding with dynamics", 645: "continuous path, tangential rounding",
                                450: "corner: arc", 451: "corner: intersection", 153: "machine coordinates, frames "
                                "off (non-modal)"}, extended_offset="G505", statements=True, expands=False),
    "heidenhain": Dialect("heidenhain", "HEIDENHAIN", reads=False),
}


#: SINUMERIK statements that move no axis and change nothing the reader follows (acceleration and
#: path modes, compressors, orientation references, the high-speed settings cycle CYCLE832 and
#: messages, whose arguments the comment mask has blanked, a tool selected by name or number)
_STATEMENTS = re.compile(r"(?<![A-Z0-9_$])(?:SOFT|BRISK|BRISKA|SOFTA|DRIVE|FFWON|FFWOF|COMPCAD|COMPCURV|COMPSURF|"
                         r"COMPOF|ORIWKS|ORIMKS|ORIAXES|ORIVECT|ORICONCW|ORICONCCW|UPATH|SPATH|STOPRE|CFTCP|CFC|CFIN|"
                         r"CYCLE832|MSG|WORKPIECE)(?![A-Z0-9_])|(?<![A-Z0-9_$])T[ \t]*=[ \t]*(?:\"[^\"]*\"|[0-9]+)",
                         re.IGNORECASE)


def blank_statements(code: str) -> str:
    """A SINUMERIK line's code with its motionless statements blanked (same length: the words
    around them keep their columns).

    Parameters
    ----------
    code : str
        The line with its comments masked.

    Returns
    -------
    str
        The code, each statement replaced by blanks.
    """
    if not any(c.isalpha() for c in code):
        return code
    return _STATEMENTS.sub(lambda m: " " * len(m.group()), code)


def check_points(dialect: Dialect, words, letters: str, where: str) -> None:
    """Refuse a coordinate without a decimal point where the dialect reads it as increments.

    Parameters
    ----------
    dialect : Dialect
        The program's dialect.
    words : iterable of Word
        A block's words.
    letters : str
        The letters whose words are coordinates (the machine's axes, I J K R, a lathe's U W).
    where : str
        ``source:line``, for messages.

    Raises
    ------
    GcodeError
        A coordinate other than zero written without a decimal point, naming its column.
    """
    if not dialect.decimal_point:
        return
    for w in words:
        if w.letter in letters and "." not in w.text and w.value:
            unit = "0.001 mm or 0.0001 inch" if w.letter not in "ABC" else "0.001 deg"
            raise GcodeError(f"{where}:{w.start + 1}: {w.text.strip()} has no decimal point: a {dialect.title} control "
                             f"reads it as {w.value:g} least input increments ({unit} each), or as {w.value:g} units "
                             "when set to calculator-type input (FANUC parameter 3401 DPI): write the decimal point "
                             f"({w.letter}{w.value:g}. for {w.value:g} units)")


_WHOLE_WORD = re.compile(r"(?<![A-Z#\]_$])([A-Z])[ \t]*([-+]?[0-9]+)(?![0-9.])", re.IGNORECASE)


def check_lines_points(dialect: Dialect, lines, letters: str, source: str) -> None:
    """:func:`check_points` on a program's lines as written, before its parameters are
    followed (a value computed from them is no count of increments).

    Parameters
    ----------
    dialect : Dialect
        The program's dialect.
    lines : iterable of (str, str)
        Its lines.
    letters : str
        The coordinate letters (the machine's axes, a lathe's U W).
    source : str
        Its name, for messages.

    Raises
    ------
    GcodeError
        A coordinate other than zero without a decimal point, naming line and column.
    """
    from ._lexer import mask_comments, Word

    if not dialect.decimal_point:
        return
    for k, (body, _) in enumerate(lines, start=1):
        if not any(ch.isdigit() for ch in body):
            continue
        code = mask_comments(body, k, source)
        words = [Word(m.group(1).upper(), float(m.group(2)), m.group(0), m.start(), m.end())
                 for m in _WHOLE_WORD.finditer(code) if m.group(1).upper() in letters]
        check_points(dialect, words, letters, f"{source}:{k}")


def dialect_of(name: str | Dialect | None) -> Dialect:
    """The dialect of a name.

    Parameters
    ----------
    name : str, Dialect or None
        One of :data:`NAMES` (None: LinuxCNC).

    Returns
    -------
    Dialect
        The dialect.

    Raises
    ------
    GcodeError
        Another name (naming ``dialect``).
    """
    if isinstance(name, Dialect):
        return name
    if name is None:
        return DIALECTS["linuxcnc"]
    found = DIALECTS.get(str(name).lower())
    if found is None:
        raise GcodeError(f"dialect must be one of {', '.join(NAMES)}, got {name!r}", parameters=("dialect",))
    return found


# what says a program's dialect; each (pattern, dialect, what it is), read on a line without
# comments in parentheses, upper case
_SIGNS = [
    (re.compile(r"^\s*(?:N?\d+\s*)?BEGIN\s+PGM\b"), "heidenhain", "BEGIN PGM (a HEIDENHAIN Klartext program)"),
    (re.compile(r"^\s*\d*\s*(?:L|CC|C|CR|CT|TOOL\s+CALL|CYCL\s+DEF|FN\s*\d+|LBL)\s.*(?:\bFMAX\b|\bR0\b|\bRL\b|\bRR\b|"
                r"\bDR[-+]|\bZ[-+]|\bX[-+]|\bY[-+])|^\s*\d*\s*(?:TOOL\s+CALL|CYCL\s+DEF|END\s+PGM|BLK\s+FORM)\b"),
     "heidenhain", "a HEIDENHAIN Klartext block"),
    (re.compile(r"^\s*%_N_"), "siemens", "a SINUMERIK program name (%_N_)"),
    (re.compile(r"(?<![A-Z0-9_])CYCLE800\b"), "siemens", "CYCLE800 (SINUMERIK's swivel: a tilted working plane)"),
    (re.compile(r"(?<![A-Z0-9_])(?:CR|AC|IC|AP|RP)\s*[=(]"), "siemens",
     "a SINUMERIK address with '=' or '(' (CR= arc radius, AC / IC absolute / incremental, AP / RP polar)"),
    (re.compile(r"\bDEF\s+(?:REAL|INT|BOOL|STRING|AXIS|FRAME|CHAR)\b"), "siemens", "DEF (a SINUMERIK variable definition)"),
    (re.compile(r"\b(?:MSG|CYCLE\d+|POCKET\d+|SLOT\d+|HOLES\d+|CYCL\d+)\s*\("), "siemens",
     "a SINUMERIK statement with arguments"),
    (re.compile(r"\$[A-Z]{1,3}_[A-Z]"), "siemens", "a SINUMERIK system variable ($...)"),
    (re.compile(r"(?<![A-Z#])R\d+\s*="), "siemens", "an R parameter assignment (SINUMERIK)"),
    (re.compile(r"^\s*(?:N\d+\s*)?G500\b|(?<![\w.\-\[<])(?:TRANS|ATRANS|ROT|AROT|SUPA|CFC|CFTCP|SOFT|BRISK|FFWON|"
                r"FFWOF|COMPCAD|COMPOF|CYCLE800|ORIWKS|ORIAXES|DIAMON|DIAMOF|DIAM90)(?![\w.\-\]>])"), "siemens",
     "a SINUMERIK statement"),
    (re.compile(r"\b(?:VC\d+|VS\d+)\s*=|\bNLOOP\b|^\s*O[A-Z][A-Z0-9]*\s*$"), "okuma", "an OKUMA OSP construct"),
    (re.compile(r"\bO\s*<|\(\s*(?:DEBUG|PRINT|LOGOPEN|PROBEOPEN)\s*,|#\s*<|\bO\s*\d+\s+(?:SUB|CALL|IF|WHILE|DO|"
                r"REPEAT|ENDSUB)\b|\bG64\s*P"), "linuxcnc", "a LinuxCNC construct"),
    (re.compile(r"\b(?:G187|G154|G11[014-9]|G12[0-9])\b|\bM97\b"), "haas", "a Haas code (G187, G154, G110-G129, M97)"),
    # (a program number O1000 alone LinuxCNC reads too: it says nothing)
    (re.compile(r"^\s*:\s*\d+|^\s*%.*[^\s_%]|\bG\s*0*(?:54\.1|65|50)\b|\bIF\s*\[.*\]\s*GOTO|\bGOTO\s*\d|"
                r"\bWHILE\s*\[.*\]\s*DO\s*\d"), "fanuc",
     "FANUC's (a ':' program number, a tape leader with text, G54.1, G65, G50, IF GOTO, WHILE DO)"),
]
_PARENS = re.compile(r"\([^)]*\)")
_TITLES = {"okuma": "OKUMA OSP", **{k: d.title for k, d in DIALECTS.items()}}


def detect(lines: Iterable[tuple[str, str]]) -> tuple[str, str] | None:
    """The dialect a program's text says, where it says one unambiguously.

    Reads at most :data:`DETECT_LINES` lines. A ``:0097`` program number, a tape leader with
    text, G54.1, G65, G50, ``IF [...] GOTO`` or ``WHILE [...] DOn`` says FANUC unless a Haas
    code (G187, G154, G110-G129, M97) says Haas; a HEIDENHAIN ``BEGIN PGM``, a SINUMERIK
    ``DEF``, R parameter or system variable, an OKUMA ``VC`` variable and a LinuxCNC
    ``o<name>``, named parameter or ``(debug, ...)`` each say theirs. A program number
    ``O1000`` alone says nothing: LinuxCNC reads it too.

    Parameters
    ----------
    lines : iterable of (str, str)
        The program's lines and their endings.

    Returns
    -------
    (str, str) or None
        The dialect (one of :data:`NAMES`, or ``"okuma"``) and what says it (``"line 2: :0097,
        FANUC's (...)"``); None when nothing says one, or two dialects are said (then
        the program is read as the caller's default).
    """
    said: dict[str, str] = {}
    for k, (body, _) in enumerate(lines, start=1):
        if k > DETECT_LINES:
            break
        raw = body.upper()
        text = _PARENS.sub(" ", raw).split(";")[0]
        for pattern, name, what in _SIGNS:
            if name not in said and pattern.search(raw if name == "linuxcnc" else text):
                said[name] = f"line {k}: {shortened(body.strip())}, {what}"
                break
    if "haas" in said:
        said.pop("fanuc", None)
    if len(said) != 1:
        return None
    (name, why), = said.items()
    return name, why


def foreign(dialect: Dialect, body: str, number: int, source: str) -> GcodeError | None:
    """The refusal of a line of a dialect the reader does not read, naming the dialect, the
    construct and the line (None if the line says nothing of another dialect).

    Parameters
    ----------
    dialect : Dialect
        The program's dialect.
    body : str
        The line.
    number : int
        Its line number.
    source : str
        The program's name.

    Returns
    -------
    GcodeError or None
        The error to raise.
    """
    text = _PARENS.sub(" ", body).upper().split(";")[0]
    for pattern, name, what in _SIGNS:
        if name in ("linuxcnc", "fanuc", "haas") or not pattern.search(text):
            continue
        return GcodeError(f"{source}:{number}: {shortened(body.strip())}: {what}; {_refusal(name)}")
    if not dialect.reads:
        return GcodeError(f"{source}:{number}: {_refusal(dialect.name)}", parameters=("dialect",))
    return None


def _refusal(name: str) -> str:
    """Why a dialect's construct or program is refused."""
    if name == "siemens":
        return ("SINUMERIK's own language is not read, only its ISO G-code subset (G0 - G3 with X Y Z A B C I J K R, "
                "G17 - G19, G54 ..., F S T M words, ';' comments, TRAORI / TRAFOOF); post the program in that form")
    return (f"{_TITLES[name]} programs are not read (the reader takes ISO G-code programs: LinuxCNC's, FANUC's, "
            "Haas's and SINUMERIK's ISO subset); post the program for one of them")


def choose(dialect: str | Dialect | None, lines: Iterable[tuple[str, str]] | None, source: str) -> tuple[Dialect, str]:
    """The dialect to read a program in, and what decided it.

    Parameters
    ----------
    dialect : str, Dialect or None
        The dialect given (None: told from the program, :func:`detect`, or LinuxCNC's when
        nothing in it says another).
    lines : iterable of (str, str) or None
        The program's lines (None: not available, as for a stream).
    source : str
        The program's name, for messages.

    Returns
    -------
    Dialect
        The dialect.
    str
        ``"given"``, ``"detected: <line and what>"`` or why it is the default.

    Raises
    ------
    GcodeError
        An unknown dialect name; a program of a dialect the reader does not read (SINUMERIK,
        HEIDENHAIN Klartext, OKUMA OSP), naming the line that says it.
    """
    if dialect is not None:
        chosen, said = dialect_of(dialect), "given"
    elif lines is None:
        chosen, said = DIALECTS["linuxcnc"], "the default: the program was given as a stream, not read for its dialect"
    else:
        found = detect(lines)
        if found is None:
            chosen, said = DIALECTS["linuxcnc"], "the default: nothing in the program says another dialect"
        elif found[0] not in DIALECTS or not DIALECTS[found[0]].reads:
            raise GcodeError(f"{source}:{found[1].removeprefix('line ')}; {_refusal(found[0])}",
                             parameters=("dialect",))
        else:
            chosen, said = DIALECTS[found[0]], f"detected: {found[1]}"
    if not chosen.reads:
        raise GcodeError(f"{source}: dialect {chosen.name}: {_refusal(chosen.name)}", parameters=("dialect",))
    return chosen, said
