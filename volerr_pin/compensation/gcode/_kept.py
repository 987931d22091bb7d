"""What cannot be compensated: classifying blocks, following the ones kept unchanged.

Canned cycles, macro statements and variables, subprogram calls, reference returns, probing,
cutter compensation, block delete with moves, and every block under a mode that changes how
later coordinates read (:mod:`._regions`) are *problems*: kept byte for byte and named, or
refused with ``strict``. A G or M code the reader does not know is a problem whose effect cannot be
told (``Problem.unknown_code``). A kept block still sets its modal words, and one that may move
the machine makes the position unknown.
"""

from __future__ import annotations

from ._lexer import (OFFSET_DATA, CANNED, G_DIGITS, G_GROUPS, KEPT_MOTION, KEYWORD, LATHE_CYCLES, M_GROUPS, MACRO_G, NOT_MOVES,
                    TOOL_CHANGE_M, USER_M, WORK_OFFSETS, Block,
                    GcodeError, macro_statement, mask_comments, parse_block, uncommented, word_values)
from ._lexer import AXIS_LETTERS, BLANKS
from ._dialect import blank_statements, check_points, foreign
from ._modal import Interpreter, ModalState
from ._regions import follow, keyword_region, profile_region, region_of

__all__ = ["Problem", "classify", "named", "offset_notes", "skip", "unsupported"]


class Problem(str):
    """Why a block cannot be followed (a str for messages).

    Attributes
    ----------
    modes_unknown : bool
        The block may set a mode that changes how later blocks read, or move the machine
        somewhere not followed.
    unknown_code : bool
        The block holds a G or M code the reader does not know: what it changes cannot be told,
        so it is refused unless unknown codes are explicitly kept (``pass_through``).
    column : int
        1-based column of the word that makes the problem (0 if none).
    """

    modes_unknown = False
    unknown_code = False
    column = 0


def named(problem: Problem, kept: str = "") -> str:
    """A kept block as compensate's report and predict's ``not_predicted`` name it.

    Parameters
    ----------
    problem : Problem
        What the block holds.
    kept : str, optional
        What became of it (``"kept unchanged"``), after the construct.

    Returns
    -------
    str
        The construct, what became of it, and, where it may change how later blocks read, that
        what it changes is not followed.
    """
    return (f"{problem} {kept}" if kept else str(problem).rstrip(",")) + (
        "; what it changes is not followed, so the blocks after it may be misread" if problem.modes_unknown else "")


def offset_notes(block: Block, origin_given: bool, noted: set, known=()) -> list[str]:
    """What to tell (once a program) of the work and tool offsets a block selects, which the
    model does not know: compensate's report and predict's notes say it alike.

    Parameters
    ----------
    block : Block
        The block.
    origin_given : bool
        A program origin was given (then a work offset is what it stands for).
    noted : set
        What was told already (``"offset"``, ``"tool"``); updated in place.
    known : collection of str, optional
        Work offsets whose values the program set (G10): nothing to tell of them.

    Returns
    -------
    list of str
        The notes for this block (most often none).
    """
    out = []
    for w in block.words:
        if (w.letter == "G" and w.value in WORK_OFFSETS and "offset" not in noted and not origin_given
                and f"G{w.value:g}" not in known):
            noted.add("offset")
            out.append(f"work offset G{w.value:g}: program coordinates are taken as axis positions (give the work "
                       "offset as the program origin, in mm / deg)")
        if ((w.letter == "G" and w.value in (43, 44, 43.4)) or w.letter in "HD") and "tool" not in noted:
            noted.add("tool")
            what = f"G{w.value:g} tool length offset" if w.letter == "G" else f"tool offset word {w.name}"
            out.append(f"{what}: the errors are those of the model's tool point; a different tool length changes "
                       "the angular errors' lever arms")
    return out


def _unknown(text: str, column: int) -> Problem:
    problem = Problem(text)
    problem.modes_unknown = problem.unknown_code = True
    problem.column = column
    return problem


def classify(reader: Interpreter, line: str, number: int, state: ModalState,
             code: str | None = None) -> tuple[Block | None, Problem | None]:
    """Read a line, and say whether it can be followed.

    Parameters
    ----------
    reader : Interpreter
        The program's interpreter.
    line : str
        The line without its line ending.
    number : int
        Its 1-based line number.
    state : ModalState
        The modal state before the block (``canned``, ``programs`` and ``region`` are
        updated).
    code : str, optional
        The line with its comments blanked out
        (:func:`~volerr_pin.compensation.gcode._lexer.mask_comments`), when the caller has it.

    Returns
    -------
    block : Block or None
        The block (None for a macro statement, which is not read, and for a line inside
        a kept region).
    problem : Problem or None
        What the block holds that cannot be followed (canned cycles, macros,
        subprograms, codes the reader does not know, a block inside polar interpolation
        ...); None if it can be.

    Raises
    ------
    GcodeError
        A line that cannot be read (see :func:`~volerr_pin.compensation.gcode.parse_block`).
    """
    code = mask_comments(line, number, reader.source) if code is None else code
    if state.regions:
        return None, _in_region(reader, code, number, state)
    keyword = KEYWORD.match(code)
    if keyword:
        word = keyword.group(1).upper()
        region = keyword_region(word, number)
        if region is not None:
            state.regions = [region]
            return None, Problem(f"{word} (a transformation of the axes)")
        return Block(number, line, [], code, statement=word), None
    macro = macro_statement(code)
    if macro:
        problem = Problem(macro[0])
        problem.modes_unknown = macro[1]
        return None, problem
    dialect = reader.dialect
    if dialect.tape_text and code.lstrip(BLANKS).startswith("%"):
        return Block(number, line, [], code), None   # a tape's start or end, its leader's text not read
    if dialect.statements:
        code = blank_statements(code)   # (SOFT, CYCLE832(...), T="tool": kept as written)
    if dialect.colon_numbers and code.lstrip(BLANKS).startswith(":"):
        at = code.index(":")
        code = code[:at] + "O" + code[at + 1:]   # ':0097' is the program number O0097
    try:
        block = parse_block(line, number, reader.source, code)
    except GcodeError as err:
        raise (foreign(dialect, line, number, reader.source) or err) from None
    if dialect.decimal_point and not reader.points_checked:
        letters = reader.coordinate_letters
        gs = [w.value for w in block.words if w.letter == "G"]
        if any(g in (2, 3) for g in gs) or (state.motion in (2, 3) and not any(
                g in CANNED or g in dialect.lathe_cycles or g in (0, 1, 10) for g in gs)):
            letters += "IJKR"   # an arc's centre and radius (elsewhere K and R may be counts: G81 K3, G73 R3)
        check_points(dialect, block.words, letters, f"{reader.source}:{number}")
    return block, _problem(reader, block, state)

def _in_region(reader: Interpreter, code: str, number: int, state: ModalState) -> Problem:
    what, first = state.regions[0][:2]
    keyword = KEYWORD.match(code)
    words = word_values(uncommented(code))
    state.regions = follow(state.regions, words, keyword.group(1).upper() if keyword else "", number)
    if not state.regions:
        state.lose_position(f"line {number}")
    return Problem(f"in the {what} of line {first}")

def unsupported(reader: Interpreter, line: str, state: ModalState) -> str | None:
    """Why a block cannot be followed (canned cycles, macros, subprograms, ...).

    Also tracks canned cycles in ``state``: a cycle starts one, and a motion word or G80
    ends it; until then the axis words of a block are positions of the cycle.

    Parameters
    ----------
    reader : Interpreter
        The program's interpreter.
    line : str
        The line without its line ending.
    state : ModalState
        The modal state before the block (``canned`` is updated).

    Returns
    -------
    str or None
        What the block holds that cannot be followed, for a message; None if it can.

    Raises
    ------
    GcodeError
        A line that cannot be read.
    """
    return classify(reader, line, 0, state)[1]

def _problem(reader: Interpreter, block: Block, state: ModalState) -> Problem | None:
    words = block.words
    if block.delete:
        if any(w.letter in reader.axes for w in words):
            return Problem("a move with block delete (/), whose execution depends on the operator's switch,")
        if any(w.letter == "G" for w in words):
            return Problem("G codes with block delete (/), whose effect depends on the operator's switch,")
    dialect = reader.dialect
    lathe_system_a = bool(dialect.lathe_cycles) and reader.lathe
    for w in words:
        letter = w.letter
        if letter == "G":
            g = w.value
            if g in dialect.g_codes or g in dialect.g_aliases or (g != 10 and reader.is_offset(g)):
                continue
            if lathe_system_a and g in dialect.lathe_cycles:
                what = f"{w.name} ({dialect.title} lathe {dialect.lathe_cycles[g]})"
                state.canned = what
                pq = {v.letter: v.value for v in words if v.letter in "PQ"}
                if g in (71, 72, 73) and len(pq) == 2:   # its profile, blocks N(P) to N(Q), follows: the cycle cuts it
                    state.regions = [profile_region(what, pq["P"], pq["Q"], block.number)]
                return Problem(what)
            if g == 7 and not dialect.linuxcnc_modes:
                return _unknown(f"{w.name} (not LinuxCNC's diameter mode in the {dialect.name} dialect: a G code "
                                "this reader does not know there)", w.start + 1)
            if g == 10 and any(v.letter == "L" and v.value in OFFSET_DATA for v in words):
                done = reader.set_offset([(v.letter, v.value) for v in words], block.number, state)
                if done is not None:
                    reader.tell(block.number, f"{w.name} sets {done}: followed")
                    return None
            if g in CANNED:
                state.canned = True
                return Problem(f"{w.name} (canned cycle)")
            if not G_DIGITS.fullmatch(w.text):
                raise GcodeError(f"{reader.source}:{block.number}:{w.start + 1}: {w.name} is not a G code (at "
                                 "most three digits and one decimal, as G43.4)")
            region = region_of(g, [(v.letter, v.value) for v in words], block.number)
            if region is not None:
                state.regions = [region]
                return Problem(f"{w.name} ({region[0].rsplit(' (', 1)[0]})")
            if g in MACRO_G:
                return Problem(f"{w.name} (macro call)")
            if g in NOT_MOVES:  # G52 X0 (no shift), G10 of tool data ...
                return Problem(f"{w.name} ({NOT_MOVES[g]})")
            if g in KEPT_MOTION or (g in LATHE_CYCLES and any(v.letter == "Q" for v in words)):
                what = f"{w.name} ({KEPT_MOTION.get(g) or LATHE_CYCLES[g]})"
                state.canned = what   # (true: its axis words after it are its, as a cycle's)
                return Problem(what)
            if g not in G_GROUPS:
                return _unknown(f"{w.name} (a G code this reader does not know)", w.start + 1)
        elif letter == "M" and (w.value in (98, 99) or w.value in dialect.call_m):
            return Problem(f"{w.name} ({dialect.call_m.get(w.value, 'subprogram call or return')})")
        elif letter == "M" and w.value == int(w.value):
            problem = _m_code(reader, w, block.number)
            if problem is not None:
                return problem
        elif letter in "UW" and lathe_system_a and letter not in reader.axes:
            return Problem(f"{w.name} (an incremental {'X' if letter == 'U' else 'Z'} of {dialect.title} lathes, "
                           "not yet compensated)")
        elif letter == "O":
            if state.programs:
                return Problem(f"{w.name} (a second program number: the start of a subprogram)")
            state.programs += 1
    if state.canned:
        if any(w.letter == "G" and w.value in (0, 1, 2, 3, 80) for w in words):
            state.canned = False
        elif any(w.letter in reader.axes or w.letter in AXIS_LETTERS + "IJKRQPL" for w in words):
            if isinstance(state.canned, str):
                return Problem(f"a block of the {state.canned} still in force")
            return Problem("a canned-cycle position (the cycle is still active)")
    return None

def _m_code(reader: Interpreter, w, number: int) -> Problem | None:
    """The problem of an M code in the program's dialect, if any (a code it does not know)."""
    dialect, m = reader.dialect, w.value
    if dialect.linuxcnc_modes:
        if m in M_GROUPS or m in USER_M:
            return None
        return _unknown(f"{w.name} (an M code this reader does not know)", w.start + 1)
    elif dialect.motionless(m) or m in dialect.moving_m:
        return None
    elif dialect.builder_m:
        reader.tell(number, f"{w.name}: an auxiliary function of the machine builder ({dialect.title} leaves M codes "
                    "other than M0 - M9, M19, M29, M30, M98, M99 to the builder): kept as written, taken to move no "
                    "axis (a code the builder made a macro call that moves axes would be misread)", key=("M", m))
        return None
    return _unknown(f"{w.name} (an M code this reader does not know in the {dialect.title} dialect)", w.start + 1)


def skip(reader: Interpreter, line: str, state: ModalState, block: Block | None = None, number: int = 0) -> None:
    """Follow a block that is kept unchanged rather than interpreted.

    It still sets its modal words (G91 G28 ... stays G91), and if it names axes (or
    changes tools, calls or returns from a subprogram or macro, starts another program,
    jumps or loops, or has a word whose value is a macro variable) it moves the machine
    somewhere not followed: every axis position becomes unknown.

    Parameters
    ----------
    reader : Interpreter
        The program's interpreter.
    line : str
        The line without its line ending.
    state : ModalState
        Updated in place.
    block : Block, optional
        The line read already (None for a macro statement: its words are guessed).
    number : int
        Its line number, for messages.
    """
    if block is not None:
        words = [(w.letter, w.value) for w in block.words]
    else:
        words = word_values(uncommented(line))
        macro = macro_statement(mask_comments(line, number, reader.source))
        if macro and macro[1]:  # a jump, loop or variable word: where the machine goes is not known
            state.lose_position(f"line {number}")
    reader.work_offset(words, number, state)
    ms = [v for letter, v in words if letter == "M"]
    state.apply_m(ms, f"{reader.source}:{number}")
    reader.restored(ms, state)
    gs = [reader.dialect.g_aliases.get(v, v) for letter, v in words if letter == "G"]
    state.apply_g(gs)
    reader.tool_tip_codes(gs, state, number)
    dialect = reader.dialect
    calls = ({("M", TOOL_CHANGE_M), ("M", 98), ("M", 99)} | {("M", m) for m in dialect.moving_m}
             | {("M", m) for m in dialect.call_m} | {("G", g) for g in MACRO_G})
    if ("G", 10) in words:   # data: nothing moves
        words = [(letter, v) for letter, v in words if letter not in AXIS_LETTERS]
    if any(letter in reader.axes or letter in AXIS_LETTERS + "O" or (letter, v) in calls for letter, v in words):
        state.lose_position(f"line {number}")
