"""Parameters, expressions and O-word control flow, followed as LinuxCNC's interpreter runs
them, so that the program's moves can be compensated where they run.

A program whose words are parameters (``X#1``, ``Y#<width>``) or expressions
(``Z[#<depth> * 2]``), or whose blocks run in loops and subroutines (``o100 while`` ...
``o100 endwhile``, ``o100 call [1] [2]``), is expanded into the program as run: every block
in the order LinuxCNC executes it, every value a number. A loop body appears once per pass, a
subroutine's body at each call (with the modes it sets, where it runs), settings of a call's
local parameters and O-word lines are gone, comments stay, a value computed from parameters
or expressions is written as its number and every other word as written; a subroutine no call runs stays defined
where it was (a lathe cycle's Q names it). That flat program is what is compensated and
written. The rules are LinuxCNC's (rs274ngc):

- values: numbers, ``#n`` and ``#<name>`` (spaces and case ignored), ``[expressions]``,
  ``+`` / ``-`` before a value, and the functions ABS ACOS ASIN ATAN[y]/[x] COS EXISTS EXP
  FIX FUP LN ROUND SIN SQRT TAN (angles in degrees);
- binary operators by precedence, left to right within one: ``**``; ``* / MOD``; ``+ -``;
  ``EQ NE GT GE LT LE`` (EQ within 1e-6); ``AND OR XOR``;
- parameter settings on a line take effect after the line is read (all at once); settings of
  global parameters and of the main program's stay in the program as run, values computed
  from parameters or expressions written as numbers;
- ``#1`` ... ``#30`` and names without a leading ``_`` are local to a subroutine call; the
  arguments of ``call`` are ``#1`` ..., the rest 0; ``return`` / ``endsub`` with a value set
  ``#<_value>``; other numbered parameters and ``_`` names are global; numbered parameters
  never set read as 0;
- ``sub`` / ``endsub`` / ``return`` / ``call`` (at most 9 calls deep; passing over a
  definition clears ``#<_value>``), ``while`` / ``endwhile``, ``do`` / ``while``, ``repeat`` /
  ``endrepeat``, ``if`` / ``elseif`` / ``else`` / ``endif``; M2 / M30 ends the run.

What only the running machine knows cannot be followed: parameters from 5000 up that the
program did not set (positions, probe results, offsets, tool data), LinuxCNC's predefined
``#<_...>`` names, subroutines in other files, M73 (whose restore happens at a return the flat
program does not have), Fanuc-style macros, and what LinuxCNC runs by state of its own
(``break`` / ``continue``, a ``return`` from inside a ``repeat``, ``EXISTS`` of a ``_`` name, a
label opening two blocks of one subroutine) or differently by version (LE / GE within 1e-6). Such a program is not expanded: it is read as
before, its macro blocks kept unchanged and named, and the report says what stopped the
expansion. Expansion is bounded: a program that would run more than ``most_blocks`` blocks is
refused, naming the loop or call that was running.
"""

from __future__ import annotations

import re
from array import array
from collections.abc import Iterable
from dataclasses import dataclass


from ._expressions import LITERAL, Frame, Line, Refused, Unfollowable, Values, number_text
from ._lexer import LATHE_CYCLES, MOST_DIGITS, GcodeError, check_tape, mask_comments, uncommented, word_values

__all__ = ["Expansion", "MOST_BLOCKS", "Unfollowable", "expand", "may_need", "renamed"]

#: the most blocks an expanded program may run (a million-block program is the largest the
#: product is measured on)
MOST_BLOCKS = 1_000_000
#: LinuxCNC's INTERP_SUB_ROUTINE_LEVELS: the main program and at most 9 nested calls
MOST_DEPTH = 10
#: a quick test for a line that may hold a parameter, an expression or an O-word
MARK = re.compile(r"[#\[]|^[ \t]*(?:/[ \t]*)?(?:N[ \t]*[0-9]+[ \t]*)?O", re.IGNORECASE)

KEYWORDS = ("ENDSUB", "SUB", "CALL", "ENDWHILE", "WHILE", "DO", "ENDREPEAT", "REPEAT", "ELSEIF", "ELSE",
            "ENDIF", "IF", "RETURN", "BREAK", "CONTINUE")
O_LINE = re.compile(r"(?:N[0-9.]+)?O([0-9]+|<[^>]*>)(" + "|".join(KEYWORDS) + ")(.*)$")
#: word letters of a block (LinuxCNC's, with the polar ``@`` and ``^``, and O for a Fanuc-style
#: program number, which the reader judges)
LETTERS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ@^")
#: the words of a lathe cycle's profile as the product compensates it: the motions G0 - G3 in
#: X and Z, arcs by I K or R, and F S N, which the cycle ignores (LinuxCNC reads nothing else of
#: a profile: its other G codes, fillets A and chamfers C, U and W, keep the profile as written)
PROFILE_WORDS = frozenset("GXZIKRFSN")
#: the largest subroutine file read beside a program, and the most all of them may hold [bytes]
MOST_SUBROUTINE_FILE = 4 << 20
MOST_SUBROUTINE_BYTES = 8 << 20
#: a call of a named subroutine, which LinuxCNC looks up in a file of its name when the program
#: does not define it (``o<rcone> call`` runs rcone.ngc's ``o<rcone> sub``)
NAMED_CALL = re.compile(r"^\s*(?:N[0-9.]+\s*)?O\s*<\s*([^>]*?)\s*>\s*CALL\b", re.IGNORECASE)
NAMED_SUB = re.compile(r"^\s*(?:N[0-9.]+\s*)?O\s*<\s*([^>]*?)\s*>\s*(SUB|ENDSUB)\b", re.IGNORECASE)
#: a subroutine file's name: what LinuxCNC's names hold (no folder, no '..')
FILE_NAME = re.compile(r"[a-z0-9_][a-z0-9_.\-]*")
#: a LinuxCNC message that prints parameters: the keyword and comma, then the text
MESSAGE = re.compile(r"(\(\s*(?:debug|print|log|logappend)\s*,)([^)]*)\)", re.IGNORECASE)
#: a parameter in a message: #<name> or #number
MESSAGE_PARAMETER = re.compile(r"#(<[^>]*>)|#([0-9]+)")
#: a lathe cycle's Q word, as run (a number)
Q_WORD = re.compile(r"Q[ \t]*[-+]?[ \t]*[0-9.]+")


@dataclass
class Expansion:
    """A program expanded as it runs.

    Attributes
    ----------
    lines : list of (str, str)
        The blocks as run, each with its line ending.
    origin : array of int
        For each of them, the line of the program it comes from (1-based).
    calls, passes : int
        Subroutine calls followed, and loop passes run.
    profiles : dict of str to str
        Lathe cycles (G70 - G72) whose profile ran as a new subroutine written before the
        cycle: its name, and the cycle's block as run (see :meth:`_Expander.profile`).
    """

    lines: list
    origin: array
    calls: int = 0
    passes: int = 0
    profiles: dict = None


def may_need(lines: Iterable[tuple[str, str]], source: str = "<program>") -> bool:
    """Whether a program may hold a parameter, an expression or an O-word (read as a stream).

    Parameters
    ----------
    lines : iterable of (str, str)
        The lines and their endings.
    source : str
        The program's name, for messages.

    Returns
    -------
    bool
        False when no line does (such a program is compensated as a stream, line by line).
    """
    for number, (body, _) in enumerate(lines, start=1):
        # (substring tests first: a plain move has none of these characters, and a million-block
        # program is scanned in a fraction of a second)
        if ("#" in body or "[" in body or "O" in body or "o" in body) and MARK.search(body) \
                and MARK.search(mask_comments(body, number, source)):
            return True
    return False


def _no_comment_inside(body: str, masked: str, number: int, source: str) -> None:
    """LinuxCNC refuses a comment inside an expression ("Unknown operation")."""
    depth = 0
    for col, (c, m) in enumerate(zip(body, masked)):
        if c == "(" and m != "(" and depth > 0:
            raise GcodeError(f"{source}:{number}:{col + 1}: a comment inside an expression; LinuxCNC refuses it")
        depth += (m == "[") - (m == "]")


class _Signal(Exception):
    """A return (to its call) or the program's end (to the top), carried up to what handles it."""

    def __init__(self, kind: str, value: float | None = None):
        super().__init__(kind)
        self.kind = kind
        self.value = value


class _Expander(Values):
    def __init__(self, lines: list[tuple[str, str]], source: str, most_blocks: int, n_main: int | None = None,
                 where_of: dict[int, str] | None = None):
        super().__init__()
        self.raw = lines
        # the program's lines, then (from n_main on) subroutines of files beside it, each line's
        # place in its file by its number here (``"rcone.ngc:12"``)
        self.n_main = len(lines) if n_main is None else n_main
        self.where_of = where_of or {}
        self.anchor = 0   # the program's line of the call running a subroutine file's blocks
        self.source = source
        self.most = most_blocks
        self.coded: list[Line] = []
        self.control: dict[int, tuple[str, str, str, int]] = {}  # line index -> (name, keyword, rest, col)
        for k, (body, _) in enumerate(lines):
            masked = mask_comments(body, k + 1, source)
            if "(" in body and "[" in body:
                _no_comment_inside(body, masked, k + 1, source)
            line = Line(masked, k + 1)
            self.coded.append(line)
            code = line.code[1:] if line.code.startswith("/") else line.code
            m = O_LINE.match(code)
            if m:
                if m.group(1).isdigit() and len(m.group(1)) > MOST_DIGITS:   # (not a name: o<...>)
                    raise GcodeError(f"{source}:{k + 1}: o-word number of {len(m.group(1)):,} digits: too large a "
                                     f"number (an o-word is numbered with at most {MOST_DIGITS} digits)")
                self.control[k] = (m.group(1), m.group(2), m.group(3), m.start(3) + (len(line.code) - len(code)))
        self.out: list[tuple[str, str]] = []
        self.origin = array("q")
        self.calls = 0
        self.passes = 0
        self.running: list[tuple[str, int]] = []   # loops and calls running: (what, line)
        self.changed = False
        self.called: set[str] = set()
        self.needed: set[str] = set()            # subroutines a cycle names as written
        self.profiles: dict[str, str] = {}
        self.steps = 0
        self._structure()
        # the new subroutines' numbers (lathe cycles' profiles): above every O-word number used
        self.fresh = 1 + max((int(n.strip("<> \t")) for n, *_ in self.control.values() if n.strip("<> \t").isdigit()),
                             default=0)

    # the structure: subroutines, loops and branches matched by name ----------------------
    def _structure(self) -> None:
        self.subs: dict[str, tuple[int, int]] = {}
        self.end_of: dict[int, int] = {}        # start of a block -> its end line index
        self.branches: dict[int, list[int]] = {}  # if -> its elseif / else lines, then endif
        self.do_end: dict[int, int] = {}        # do -> its closing while
        stack: list[tuple[str, str, int]] = []
        closes = {"ENDSUB": "SUB", "ENDWHILE": "WHILE", "ENDREPEAT": "REPEAT", "ENDIF": "IF"}
        starts: dict[tuple[str, str], int] = {}
        for k in sorted(self.control):
            name, kw, rest, col = self.control[k]
            if rest and (kw in ("SUB", "DO", "ELSE", "ENDIF", "ENDWHILE", "ENDREPEAT", "BREAK", "CONTINUE")
                         or (kw == "WHILE" and stack and stack[-1][:2] == (name, "DO") and not rest.startswith("["))):
                self._nothing_after(k, col)
            if kw in ("WHILE", "DO", "REPEAT", "IF") and not (
                    kw == "WHILE" and stack and stack[-1][:2] == (name, "DO")):
                # LinuxCNC refuses a label that opens two blocks of one subroutine (or of the main
                # program): "duplicate O-word label"
                scope = next((s[0] for s in reversed(stack) if s[1] == "SUB"), "")
                if (scope, name) in starts:
                    raise Unfollowable(k + 1, f"label o{name.lower()} opens two blocks (lines "
                                              f"{starts[scope, name] + 1} and {k + 1})")
                starts[scope, name] = k
            if kw in ("SUB", "WHILE", "DO", "REPEAT", "IF"):
                if kw == "WHILE" and stack and stack[-1][:2] == (name, "DO"):
                    _, _, start = stack.pop()
                    self.do_end[start] = k
                    continue
                if kw == "SUB" and any(s[1] == "SUB" for s in stack):
                    raise Unfollowable(k + 1, f"o{name.lower()} sub inside another subroutine's body")
                stack.append((name, kw, k))
                if kw == "IF":
                    self.branches[k] = []
            elif kw in ("ELSEIF", "ELSE"):
                if not stack or stack[-1][:2] != (name, "IF"):
                    raise Unfollowable(k + 1, f"o{name.lower()} {kw.lower()} without its o{name.lower()} if")
                self.branches[stack[-1][2]].append(k)
            elif kw in closes:
                if not stack or stack[-1][:2] != (name, closes[kw]):
                    raise Unfollowable(k + 1, f"o{name.lower()} {kw.lower()} without its o{name.lower()} "
                                              f"{closes[kw].lower()}")
                _, _, start = stack.pop()
                self.end_of[start] = k
                if kw == "ENDSUB":
                    if name in self.subs:
                        raise Unfollowable(k + 1, f"subroutine o{name.lower()} defined twice")
                    self.subs[name] = (start, k)
                if kw == "ENDIF":
                    self.branches[start].append(k)
        if stack:
            name, kw, start = stack[-1]
            raise Unfollowable(start + 1, f"o{name.lower()} {kw.lower()} is never closed")

    # values ------------------------------------------------------------------------------
    def block(self, k: int) -> bool:
        """Run an ordinary line: write it with its values as numbers; True at M2 / M30."""
        line = self.coded[k]
        s = line.code
        body, newline = self.raw[k]
        spans: list[tuple[int, int, str]] = []   # (from, to) in the compact code, and the new text
        settings: list[tuple[str, float]] = []
        ends = False
        i = 1 if s.startswith("/") else 0
        if s.startswith("%"):
            i = len(s)
        while i < len(s):
            c = s[i]
            if c == "#":
                key, j = self.parameter_key(line, i)
                if s[j:j + 1] != "=":
                    raise self._error(line, j, "a parameter where a word should be (a setting needs '=')")
                at = j + 1
                v, j = self.value(line, at)
                settings.append((key, v))
                # a global, or any parameter of the main program, stays set in the program as
                # run, as a number (a subroutine kept for a lathe cycle's Q, or a message, may
                # read it); a local of a call is gone with it
                glob = key.startswith("<_") or (not key.startswith("<") and int(key) > 30)
                if not glob and len(self.frames) > 1:
                    spans.append((i, j, ""))
                elif self._computed(s, at, j):
                    spans.append((at, j, number_text(v)))
                i = j
                continue
            if c not in LETTERS:
                raise self._error(line, i, f"'{c}' where a word should be")
            m = LITERAL.match(s, i + 1)
            if m and not (m.end() < len(s) and s[m.end()] in "#["):
                j = m.end()
                v = float(m.group())
            else:
                v, j = self.value(line, i + 1)
                if not self._computed(s, i + 1, j):   # a number as written stays for the reader to judge
                    i = j
                    continue
                spans.append((i + 1, j, number_text(v)))
            if c == "M" and v in (2.0, 30.0):
                ends = True
            if c == "M" and v == 73.0 and len(self.frames) > 1:
                raise self._error(line, i, "M73 in a subroutine restores its modes at the return, which the "
                                           "program as run does not have")
            i = j
        for key, v in settings:
            self._store(key, v)
        if "#" in body and MESSAGE.search(body):
            body, before = self._messages(body, line), body
            if body != before:   # its numbers now stand where its parameters were
                self.changed = True
                if not spans:
                    self._cycle_or_emit(body, newline, k)
                    return ends
        if spans:
            self.changed = True
            parts, last = [], 0
            for a, b, text in spans:
                start, stop = line.cols[a], line.cols[b - 1] + 1
                parts += [body[last:start], text]
                last = stop
            parts.append(body[last:])
            body = "".join(parts)
            if body.strip():   # a line that only set locals of a call is gone
                self._cycle_or_emit(body, newline, k)
        elif body.strip() or len(self.frames) == 1:   # blank lines of a body are not repeated at each call
            self._cycle_or_emit(body, newline, k)
        return ends

    def _messages(self, body: str, line: Line) -> str:
        """A line's messages (``(debug, ...)``, ``(print, ...)``, ``(log, ...)``) with the values of
        their parameters written in, as LinuxCNC prints them (six decimals): the program as run
        may lack the settings they read (a call's locals, a loop's counter)."""
        def value(m: re.Match) -> str:
            key = m.group(1) if m.group(1) else str(int(m.group(2)))
            if not key.startswith("<") and not 1 <= int(key) <= 5602:
                return m.group(0)
            try:
                return f"{self._lookup(key.replace(' ', '').replace(chr(9), ''), line, 0):.6f}"
            except Unfollowable:   # known only to the machine, or never set: it prints it as it stands
                return m.group(0)

        return MESSAGE.sub(lambda m: m.group(1) + MESSAGE_PARAMETER.sub(value, m.group(2)) + ")", body)

    def _cycle_or_emit(self, body: str, newline: str, k: int) -> None:
        if not (("7" in body and ("Q" in body or "q" in body)) and self.profile(body, newline, k)):
            self._emit(body, newline, k)

    def profile(self, body: str, newline: str, k: int) -> bool:
        """Write a lathe cycle (G70 - G72 with Q) whose profile is a subroutine of this program
        with its profile as run: a new subroutine, written before the cycle, which then names it.

        LinuxCNC's cycle runs the profile as a call, in the cycle's modes, reading of each block
        only its motion (G0 as G1) and X Z I K R (A C U W too). A profile of those words alone is
        written as run, every value a number, where the compensation reads it as the path the
        cycle follows; any other keeps the cycle naming its subroutine as written.

        Returns
        -------
        bool
            True if the cycle was written with its profile (False: nothing was written).
        """
        masked = mask_comments(body, k + 1, self.source)
        words = word_values(uncommented(masked))
        q = [v for letter, v in words if letter == "Q"]
        if not any(letter == "G" and v in LATHE_CYCLES for letter, v in words) or len(q) != 1:
            return False
        name = next((n for n in self.subs if n.isdigit() and int(n) == q[0]), None)
        where = Q_WORD.search(masked.upper())
        if name is None or where is None:
            return False
        n0, called = len(self.out), name in self.called
        self.call(k, name, "", len(self.coded[k].code))   # the cycle's call: its settings stand
        profile, origin = self.out[n0:], self.origin[n0:]
        del self.out[n0:], self.origin[n0:]
        if not _plain_profile(profile, self.source):
            if not called:
                self.called.discard(name)
            self.needed.add(name)
            return False
        new, eol = str(self.fresh), newline or "\n"
        self.fresh += 1
        cycle = body[:where.start()] + f"Q{new}" + body[where.end():]
        self.profiles[new] = cycle
        self._emit(f"o{new} sub", eol, k)
        self.out += profile
        self.origin.extend(origin)
        self._emit(f"o{new} endsub", eol, k)
        self._emit(cycle, newline, k)
        self.changed = True
        return True

    @staticmethod
    def _computed(s: str, a: int, b: int) -> bool:
        """Whether the value s[a:b] reads a parameter or computes (else it is a number as written)."""
        return "#" in s[a:b] or "[" in s[a:b]

    def _emit(self, body: str, newline: str, k: int) -> None:
        self.out.append((body, newline))
        # (a block of a subroutine file comes from the program's line that called it)
        self.origin.append(k + 1 if k < self.n_main else self.anchor)

    def condition(self, k: int) -> float:
        name, kw, rest, col = self.control[k]
        line = self.coded[k]
        if not rest.startswith("["):
            raise self._error(line, col, f"o{name.lower()} {kw.lower()} needs a condition in [ ]")
        v, j = self.expression(line, col)
        self._nothing_after(k, j)
        return v

    def _nothing_after(self, k: int, j: int) -> None:
        """LinuxCNC refuses anything after an O-word's statement ("Unexpected character after
        O-word")."""
        line = self.coded[k]
        if j < len(line.code):
            col = line.cols[j] + 1
            raise GcodeError(f"{self.source}:{k + 1}:{col}: '{line.code[j:j + 12]}' after an O-word statement; "
                             "LinuxCNC refuses it")

    def step(self, k: int) -> None:
        """Count a line run, or a loop's pass: past ``most`` the program is refused."""
        self.steps += 1
        if self.steps > self.most:
            what = ", ".join(f"{w} (line {n})" for w, n in self.running[-2:]) or "the program"
            raise GcodeError(f"{self.source}:{k + 1}: following {what} would run more than {self.most:,} blocks; "
                             "the program is not expanded past that (most_blocks)", parameters=("most_blocks",))

    def run(self, lo: int, hi: int) -> None:
        """Run the lines lo .. hi - 1 (indices); control lines steer."""
        k = lo
        while k < hi:
            self.step(k)
            if k not in self.control:
                if self.block(k):
                    raise _Signal("end")
                k += 1
                continue
            self.changed = True
            name, kw, rest, col = self.control[k]
            label = f"o{name.lower()} {kw.lower()}"
            if kw == "SUB":   # a definition: kept as written unless a call runs it (see expand)
                # LinuxCNC reads its endsub in passing, which clears the value a call returned
                self.globals_named["_value"] = self.globals_named["_value_returned"] = 0.0
                self.out.append((None, name))
                self.origin.append(k + 1 if k < self.n_main else self.anchor)
                k = self.end_of[k] + 1
            elif kw == "CALL":
                self.call(k, name, rest, col)
                k += 1
            elif kw == "WHILE":
                k = self.loop(k, self.end_of[k], label, before=lambda k=k: self.condition(k))
            elif kw == "DO":   # the test is at the end: one pass at least
                end = self.do_end[k]
                k = self.loop(k, end, label, after=lambda: self.condition(end))
            elif kw == "REPEAT":
                count = iter(range(max(round(self.condition(k)), 0)))
                k = self.loop(k, self.end_of[k], label, before=lambda: next(count, None) is not None)
            elif kw == "IF":
                marks = self.branches[k]
                heads = [k] + marks[:-1]
                for head, stop in zip(heads, marks):
                    if self.control[head][1] == "ELSE" or self.condition(head):
                        self.run(head + 1, stop)
                        break
                k = marks[-1] + 1
            elif kw in ("BREAK", "CONTINUE"):
                # LinuxCNC keeps a break's or continue's state past its loop (a later do loop runs
                # once, a later break loops back), and a named one leaves the loop it names
                raise Unfollowable(k + 1, f"{label}: LinuxCNC's break and continue leave state that later loops "
                                          "depend on")
            elif kw in ("RETURN", "ENDSUB"):
                if len(self.frames) == 1:
                    raise self._error(self.coded[k], col, f"{label} outside a subroutine")
                value = None
                if rest.startswith("["):
                    value, j = self.expression(self.coded[k], col)
                    self._nothing_after(k, j)
                raise _Signal("return", value)
            else:   # a stray end (matched ones are jumped over) cannot be reached in a valid program
                raise self._error(self.coded[k], 0, f"{label} where no block of it is open")

    def loop(self, k: int, end: int, label: str, before=None, after=None) -> int:
        """Run a loop's body (lines k + 1 .. end - 1) pass after pass, until ``before()`` is false
        before a pass or ``after()`` after one; the line after the loop."""
        self.running.append((label, k + 1))
        while before is None or before():
            self.passes += 1
            self.step(k)
            try:
                self.run(k + 1, end)
            except _Signal as sig:
                if sig.kind == "return" and label.endswith("repeat"):
                    # LinuxCNC keeps a repeat's count past a return from inside it
                    raise Unfollowable(k + 1, f"{label}: a return from inside it leaves its count for the next "
                                              "call (LinuxCNC)") from None
                raise
            if after is not None and not after():
                break
        self.running.pop()
        return end + 1

    def call(self, k: int, name: str, rest: str, col: int) -> None:
        line = self.coded[k]
        if name not in self.subs:
            raise self._error(line, 0, f"o{name.lower()} is not defined in this program (a subroutine file is "
                                       "looked up by the running machine; give its folder, subroutines, to follow it)")
        if len(self.frames) >= MOST_DEPTH:
            raise self._error(line, 0, f"calls nested deeper than {MOST_DEPTH} (LinuxCNC's limit)")
        args, j = [], col
        while j < len(line.code):
            if line.code[j] != "[":
                raise self._error(line, j, "a call's arguments are values in [ ]")
            v, j = self.expression(line, j)
            args.append(v)
        if len(args) > 30:
            raise self._error(line, col, "more than 30 arguments")
        start, end = self.subs[name]
        self.calls += 1
        self.called.add(name)
        self.frames.append(Frame(args, name, k + 1))
        self.running.append((f"o{name.lower()} call", k + 1))
        value = None
        anchor = self.anchor
        if k < self.n_main:
            self.anchor = k + 1
        try:
            self.run(start + 1, end)
            _, _, tail, tcol = self.control[end]
            if tail.startswith("["):
                value, j = self.expression(self.coded[end], tcol)
                self._nothing_after(end, j)
        except _Signal as sig:
            if sig.kind != "return":   # the program's end
                raise
            value = sig.value
        except Unfollowable as why:
            if why.line <= self.n_main or k >= self.n_main:
                raise
            # a line of a subroutine file: named in its file, and at the program's call
            error = type(why)(k + 1, f"in o{name.lower()} ({self.where_of.get(why.line, 'its file')}): {why}")
            if hasattr(why, "column"):
                error.column = 1   # (the call's line: the column is the file's, in the text)
            raise error from None
        finally:
            self.frames.pop()
            self.running.pop()
            self.anchor = anchor
        self.globals_named["_value"] = 0.0 if value is None else value
        self.globals_named["_value_returned"] = float(value is not None)


def expand(lines: list[tuple[str, str]], source: str = "<program>", most_blocks: int = MOST_BLOCKS,
           subroutines=None) -> Expansion | None:
    """A program expanded as LinuxCNC runs it.

    Parameters
    ----------
    lines : list of (str, str)
        The program's lines and their endings.
    source : str
        Its name, for messages.
    most_blocks : int
        The most blocks the program may run (every line run counts, parameter settings and
        O-word lines too, and every loop pass: a loop that writes nothing cannot spin forever).
    subroutines : str or Path, optional
        The folder where LinuxCNC finds the subroutines a program calls and does not define
        (``o<rcone> call`` runs ``rcone.ngc``'s ``o<rcone> sub``; see :func:`subroutine_files`).
        None: such a call is not followed.

    Returns
    -------
    Expansion or None
        None if the program has no parameter, expression or O-word (nothing to expand).

    Raises
    ------
    Unfollowable
        What stops the expansion (the program is then read as it is).
    GcodeError
        A value the controller refuses (a division by zero, ...; naming its line and column),
        text after the ``%`` that ends the program, an o-word number of more than
        :data:`MOST_DIGITS` digits, or a program that would run more than ``most_blocks``
        blocks, naming the loop or call.
    """
    check_tape(lines, source)
    n_main = len(lines)
    if subroutines is not None:
        extra, where_of = subroutine_files(lines, source, subroutines)
        lines = lines + extra
        ex = _Expander(lines, source, most_blocks, n_main, where_of)
    else:
        ex = _Expander(lines, source, most_blocks)
    try:
        ex.run(0, len(lines))
    except Refused as why:
        raise GcodeError(f"{source}:{why.line}:{why.column}: {why}: LinuxCNC stops the program there, so it is "
                         "refused") from None
    except _Signal:   # the program's end (a return outside a call is refused where it stands)
        last = ex.origin[-1]   # the M2 / M30: what follows is never read; it is kept as written
        for k in range(last, n_main):
            ex.out.append(lines[k])
            ex.origin.append(k + 1)
    except RecursionError:
        raise Unfollowable(1, "blocks nested too deeply to follow") from None
    if not ex.changed:
        return None
    # a subroutine stays defined where it was, as written (a lathe cycle's Q names its profile,
    # and a program of other files may call it: LinuxCNC finds o<name> in name.ngc); the blocks
    # of the calls that ran stand where they ran
    out, origin = [], array("q")
    for (body, newline), n in zip(ex.out, ex.origin):
        if body is not None:
            out.append((body, newline))
            origin.append(n)
        elif ex.subs[newline][0] < n_main:   # (a subroutine file's stays in its file)
            start, end = ex.subs[newline]
            out += lines[start:end + 1]
            origin.extend(range(start + 1, end + 2))
    return Expansion(out, origin, ex.calls, ex.passes, ex.profiles)



def subroutine_files(lines: list[tuple[str, str]], source: str, folder) -> tuple[list, dict[int, str]]:
    """The subroutines a program calls and does not define, from the files LinuxCNC reads them
    from: ``name.ngc`` in ``folder`` (the name in lower case), each from its ``o<name> sub`` to
    its ``o<name> endsub``, and those they call in turn.

    Hostile files are refused: a name that is no plain file name (a folder, ``..``), a file that
    resolves outside ``folder`` (a link), one that is not a regular file, larger than
    :data:`MOST_SUBROUTINE_FILE` or not UTF-8 text. A file not there leaves the call not
    followed (the running machine may find it elsewhere). All the files a program calls hold at
    most :data:`MOST_SUBROUTINE_BYTES`.

    Parameters
    ----------
    lines : list of (str, str)
        The program's lines and their endings.
    source : str
        Its name, for messages.
    folder : str or Path
        Where the files are.

    Returns
    -------
    list of (str, str)
        The subroutines' lines, to follow the program's.
    dict of int to str
        Each of those lines' place in its file, by its 1-based number after the program's
        (``"rcone.ngc:12"``).

    Raises
    ------
    GcodeError
        A hostile file (above), naming it and the call.
    """
    from pathlib import Path

    from ._source import ProgramFile

    folder = Path(folder)
    root = folder.resolve()
    defined = {m.group(1).lower() for body, _ in lines if (m := NAMED_SUB.match(body)) and m.group(2).upper() == "SUB"}
    wanted = [(m.group(1).lower(), f"{source}:{k}") for k, (body, _) in enumerate(lines, start=1)
              if (m := NAMED_CALL.match(body))]
    extra: list[tuple[str, str]] = []
    where_of: dict[int, str] = {}
    total = 0
    while wanted:
        name, caller = wanted.pop(0)
        if name in defined:
            continue
        defined.add(name)
        if not FILE_NAME.fullmatch(name) or name.strip(".") == "":
            raise GcodeError(f"{caller}: o<{name}> call: a subroutine file is named by its o-word, and "
                             f"{name!r} is no plain file name")
        path = folder / f"{name}.ngc"
        if not path.exists():
            continue
        if path.resolve().parent != root:
            raise GcodeError(f"{caller}: o<{name}> call: {path} leads outside {folder} (a link): not read")
        file = ProgramFile(path, "subroutine file")
        total += file.size
        if file.size > MOST_SUBROUTINE_FILE or total > MOST_SUBROUTINE_BYTES:
            raise GcodeError(f"{path}: {file.size:,} bytes, more than a subroutine file read beside a program "
                             f"({MOST_SUBROUTINE_FILE:,}, and {MOST_SUBROUTINE_BYTES:,} for all a program calls)")
        body_lines = list(file.lines())
        start = next((k for k, (body, _) in enumerate(body_lines)
                      if (m := NAMED_SUB.match(body)) and m.group(1).lower() == name and m.group(2).upper() == "SUB"),
                     None)
        end = next((k for k, (body, _) in enumerate(body_lines) if start is not None and k > start
                    and (m := NAMED_SUB.match(body)) and m.group(1).lower() == name
                    and m.group(2).upper() == "ENDSUB"), None)
        if start is None or end is None:
            raise GcodeError(f"{path}: no o<{name}> sub ... o<{name}> endsub in it, which {caller} calls")
        for k in range(start, end + 1):
            where_of[len(lines) + len(extra) + 1] = f"{path.name}:{k + 1}"
            extra.append(body_lines[k])
            m = NAMED_CALL.match(body_lines[k][0])
            if m:
                wanted.append((m.group(1).lower(), f"{path}:{k + 1}"))
    return extra, where_of


def _plain_profile(profile: list[tuple[str, str]], source: str) -> bool:
    """Whether a profile as run is read by LinuxCNC's lathe cycles as the compensation reads it:
    only :data:`PROFILE_WORDS`, motion codes G0 - G3, a motion code before the first axis word,
    at least one move, and no block delete."""
    motion = moves = False
    for n, (body, _) in enumerate(profile, start=1):
        code = uncommented(mask_comments(body, n, source))
        if code.lstrip().startswith("/"):
            return False
        words = word_values(code)
        if any(letter not in PROFILE_WORDS or (letter == "G" and v not in (0, 1, 2, 3)) for letter, v in words):
            return False
        motion = motion or any(letter == "G" for letter, _ in words)
        if any(letter in "XZ" for letter, _ in words):
            if not motion:
                return False
            moves = True
    return moves


def renamed(err: GcodeError, source: str, origin) -> GcodeError:
    """An error about a block of an expanded program, naming the line it comes from.

    Parameters
    ----------
    err : GcodeError
        The error, naming ``source:block`` of the program as run.
    source : str
        The program's name.
    origin : array of int
        The line each block as run comes from (:attr:`Expansion.origin`).

    Returns
    -------
    GcodeError
        ``source:line: (block N of the program as run) ...``, or ``err`` if it names no block.
    """
    text = str(err)
    m = re.match(re.escape(source) + r":([0-9]+)(?::[0-9]+)?: ", text)
    if not m or not 1 <= int(m.group(1)) <= len(origin):
        return err
    n = int(m.group(1))
    return GcodeError(f"{source}:{origin[n - 1]}: (block {n:,} of the program as run) {text[m.end():]}",
                      parameters=err.parameters)
