"""The values of LinuxCNC's rs274ngc: numbers, parameters, ``[expressions]`` and functions, as
its interpreter computes them (see :mod:`._macros` for the rules and where they are checked).
"""

from __future__ import annotations

import math
import re

import numpy as np

__all__ = ["Frame", "Line", "Unfollowable", "Values", "number_text"]

#: LinuxCNC's TOLERANCE_EQUAL: EQ / NE / LE / GE compare within it
TOLERANCE_EQUAL = 1e-6
FUNCTIONS = ("ABS", "ACOS", "ASIN", "ATAN", "COS", "EXISTS", "EXP", "FIX", "FUP", "LN", "ROUND", "SIN", "SQRT",
             "TAN")
OPERATORS = {"**": 6, "*": 5, "/": 5, "MOD": 5, "+": 4, "-": 4, "EQ": 3, "NE": 3, "GT": 3, "GE": 3, "LT": 3,
             "LE": 3, "AND": 2, "OR": 2, "XOR": 2}
OPERATOR = re.compile(r"\*\*|[*/+-]|MOD|EQ|NE|GT|GE|LT|LE|AND|XOR|OR")
NUMBER = re.compile(r"[+-]*(?:[0-9]+\.?[0-9]*|\.[0-9]+)")
LITERAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)")


class Unfollowable(Exception):
    """What stops a program from being expanded: the product reads it as before.

    Attributes
    ----------
    line : int
        The line (1-based).
    """

    def __init__(self, line: int, text: str):
        super().__init__(text)
        self.line = line


class Refused(Unfollowable):
    """A value the controller itself refuses (a division by zero, the square root of a negative
    number, a value beyond any number, brackets nested too deep): the program stops there, so
    the reader refuses it rather than read the program as it is."""


#: the deepest brackets a value may nest: LinuxCNC reads at most 256 characters a line, which
#: holds at most about 125 pairs around a number
MOST_NESTING = 128


def number_text(value: float) -> str:
    """A value as a plain decimal number (no exponent), exactly as Python's repr rounds it."""
    text = np.format_float_positional(value, trim="-")
    return "0" if text in ("-0", "0") else text


class Line:
    """One line's code without blanks (upper case), with the column of each character."""

    __slots__ = ("code", "cols", "number")

    def __init__(self, masked: str, number: int):
        cols = [i for i, c in enumerate(masked) if c not in " \t"]
        self.code = "".join(masked[i] for i in cols).upper()
        self.cols = cols
        self.number = number


class Frame:
    """One level of subroutine calls: its numbered #1-#30 and its local names."""

    __slots__ = ("numbered", "named", "name", "line")

    def __init__(self, args: list[float], name: str, line: int):
        self.numbered = {i + 1: v for i, v in enumerate(args)}
        self.named: dict[str, float] = {}
        self.name = name
        self.line = line


class Values:
    """Reads values on a line against the parameters of the calls running (``frames``, the
    innermost last) and the globals."""

    def __init__(self):
        self.globals_numbered: dict[int, float] = {}
        self.globals_named: dict[str, float] = {}
        self.frames = [Frame([], "", 0)]
        self.depth = 0   # of the brackets being read

    def _error(self, line: Line, at: int, text: str, refused: bool = False) -> Unfollowable:
        col = line.cols[at] + 1 if at < len(line.cols) else (line.cols[-1] + 2 if line.cols else 1)
        if refused:
            error = Refused(line.number, text)
            error.column = col
            return error
        return Unfollowable(line.number, f"{text} (column {col})")

    def value(self, line: Line, i: int) -> tuple[float, int]:
        """The real value that starts at ``i``, and where it ends."""
        s = line.code
        if i >= len(s):
            raise self._error(line, i, "a value is missing at the end of the line", refused=self.depth > 0)
        c = s[i]
        nxt = s[i + 1] if i + 1 < len(s) else ""
        if c == "[":
            return self.expression(line, i)
        if c == "#":
            return self.parameter(line, i)
        if c in "+-" and nxt and not (nxt.isdigit() or nxt == "."):
            v, j = self.value(line, i + 1)
            return (-v if c == "-" else v), j
        if c.isalpha():
            for name in FUNCTIONS:
                if s.startswith(name, i) and s[i + len(name):i + len(name) + 1] == "[":
                    return self.function(line, i, name)
            raise self._error(line, i, f"'{s[i:i + 8]}' is not a value this reader knows")
        m = NUMBER.match(s, i)
        if not m:
            raise self._error(line, i, f"'{c}' does not start a value", refused=self.depth > 0)
        try:
            v = float(m.group())
        except ValueError:
            raise self._error(line, i, f"'{m.group()}' is not a number") from None
        if not math.isfinite(v):
            raise self._error(line, i, f"'{m.group()[:20]}...' is beyond any number", refused=True)
        return v, m.end()

    def expression(self, line: Line, i: int) -> tuple[float, int]:
        """``[ ... ]`` starting at ``i`` (LinuxCNC's precedence, left to right)."""
        s = line.code
        self.depth += 1
        if self.depth > MOST_NESTING:
            raise self._error(line, i, f"brackets nested more than {MOST_NESTING} deep", refused=True)
        values, ops = [], []
        v, j = self.value(line, i + 1)
        values.append(v)
        while True:
            if j >= len(s):
                raise self._error(line, i, "an expression whose ']' is missing", refused=True)
            if s[j] == "]":
                j += 1
                break
            m = OPERATOR.match(s, j)
            if not m:
                raise self._error(line, j, f"'{s[j]}' where an operator or ']' should be", refused=True)
            op = m.group()
            while ops and OPERATORS[ops[-1]] >= OPERATORS[op]:
                self._reduce(line, j, values, ops)
            ops.append(op)
            v, j = self.value(line, m.end())
            values.append(v)
        while ops:
            self._reduce(line, j, values, ops)
        self.depth -= 1
        return values[0], j

    def _reduce(self, line: Line, at: int, values: list, ops: list) -> None:
        right, left, op = values.pop(), values.pop(), ops.pop()
        if op == "/" and right == 0.0:
            raise self._error(line, at, "a division by zero", refused=True)
        if op == "**" and left < 0 and math.floor(right) != right:
            raise self._error(line, at, "a negative number raised to a fractional power", refused=True)
        if op in ("LE", "GE") and 0 < abs(left - right) < TOLERANCE_EQUAL and (left <= right) != (op == "LE"):
            # LinuxCNC 2.9.0 and later compare LE / GE within TOLERANCE_EQUAL, earlier versions
            # (Debian 12's 2.9.0~pre1 among them) exactly: here they disagree, so how the
            # program runs depends on the controller's version
            raise self._error(line, at, f"{number_text(left)} {op} {number_text(right)} (equal within "
                                        f"{TOLERANCE_EQUAL:g}) is true for LinuxCNC 2.9.0 and later and false "
                                        "for earlier versions: how the program runs depends on the controller")
        if op == "MOD":
            v = math.fmod(left, right) if right else math.nan
            v = v + abs(right) if v < 0 else v
        else:
            pick = {"**": lambda: math.pow(left, right), "*": lambda: left * right, "/": lambda: left / right,
                 "+": lambda: left + right, "-": lambda: left - right,
                 "EQ": lambda: float(abs(left - right) < TOLERANCE_EQUAL),
                 "NE": lambda: float(abs(left - right) >= TOLERANCE_EQUAL),
                 "GT": lambda: float(left > right), "LT": lambda: float(left < right),
                 "GE": lambda: float(abs(left - right) < TOLERANCE_EQUAL or left >= right),
                 "LE": lambda: float(abs(left - right) < TOLERANCE_EQUAL or left <= right),
                 "AND": lambda: float(left != 0 and right != 0), "OR": lambda: float(left != 0 or right != 0),
                 "XOR": lambda: float((left != 0) != (right != 0))}[op]
            try:
                v = pick()
            except (ValueError, OverflowError):   # 0 ** -1, 10 ** 400
                v = math.inf
        if not math.isfinite(v):
            raise self._error(line, at, f"{number_text(left)} {op} {number_text(right)} is not a finite number",
                              refused=True)
        values.append(v)

    def function(self, line: Line, i: int, name: str) -> tuple[float, int]:
        s = line.code
        j = i + len(name)
        if name == "EXISTS":
            m = re.compile(r"\[#(<[^>]*>|[0-9]+)\]").match(s, j)
            if not m:
                raise self._error(line, j, "EXISTS takes a parameter: EXISTS[#<name>]")
            return float(self._lookup(m.group(1), line, i, exists=True) is not None), m.end()
        v, j = self.expression(line, j)
        if name == "ATAN":
            if s[j:j + 2] != "/[":
                raise self._error(line, j, "ATAN takes two values: ATAN[y]/[x]")
            x, j = self.expression(line, j + 1)
            return math.degrees(math.atan2(v, x)), j
        if name in ("ACOS", "ASIN") and not -1.0 <= v <= 1.0:
            raise self._error(line, i, f"{name} of {number_text(v)}, outside -1 .. 1", refused=True)
        if name == "LN" and v <= 0:
            raise self._error(line, i, f"LN of {number_text(v)}, not positive", refused=True)
        if name == "SQRT" and v < 0:
            raise self._error(line, i, f"SQRT of {number_text(v)}, negative", refused=True)
        out = {"ABS": abs, "ACOS": lambda a: math.degrees(math.acos(a)), "ASIN": lambda a: math.degrees(math.asin(a)),
               "COS": lambda a: math.cos(math.radians(a)), "SIN": lambda a: math.sin(math.radians(a)),
               "TAN": lambda a: math.tan(math.radians(a)), "EXP": math.exp, "FIX": math.floor, "FUP": math.ceil,
               "LN": math.log, "SQRT": math.sqrt,
               "ROUND": lambda a: float(int(a + (-0.5 if a < 0 else 0.5)))}[name]
        try:
            out = float(out(v))
        except (ValueError, OverflowError):   # EXP[800]
            out = math.inf
        if not math.isfinite(out):
            raise self._error(line, i, f"{name} of {number_text(v)} is not a finite number", refused=True)
        return out, j

    def parameter(self, line: Line, i: int) -> tuple[float, int]:
        """``#n``, ``#<name>``, ``#[expr]`` or ``##n`` at ``i``: its value."""
        key, j = self.parameter_key(line, i)
        value = self._lookup(key, line, i)
        return value, j

    def parameter_key(self, line: Line, i: int) -> tuple[str, int]:
        s = line.code
        if s[i + 1:i + 2] == "<":
            end = s.find(">", i + 2)
            if end < 0:
                raise self._error(line, i, "a parameter name whose '>' is missing")
            return s[i + 1:end + 1], end + 1
        v, j = self.value(line, i + 1)
        n = round(v)
        if abs(v - n) > 1e-4 or not 1 <= n <= 5602:
            raise self._error(line, i, f"parameter number {number_text(v)} is not a whole number from 1 to 5602")
        return str(n), j

    def _lookup(self, key: str, line: Line, i: int, exists: bool = False) -> float | None:
        frame = self.frames[-1]
        if key.startswith("<"):
            name = key[1:-1].lower()
            table = self.globals_named if name.startswith("_") else frame.named
            if name in table:
                return table[name]
            if exists and name.startswith("_"):   # LinuxCNC predefines many such names (_metric, _x ...)
                raise self._error(line, i, f"EXISTS[#<{name}>]: LinuxCNC predefines names beginning with _, which "
                                           "only the running machine knows")
            if exists:
                return None
            if name.startswith("_"):
                raise self._error(line, i, f"#<{name}> is known only to the running machine (or never set)")
            raise self._error(line, i, f"#<{name}> is read before it is set")
        n = int(key)
        if n <= 30:
            return frame.numbered.get(n, 0.0)
        if n >= 5000:   # the machine writes them too (a probe, G10, G92, a tool change), so even one
            # the program set may have changed by the time it is read
            raise self._error(line, i, f"#{n} is known only to the running machine (positions, offsets, probe "
                                       "and tool data)")
        return self.globals_numbered.get(n, 0.0)

    def _store(self, key: str, value: float) -> None:
        frame = self.frames[-1]
        if key.startswith("<"):
            name = key[1:-1].lower()
            (self.globals_named if name.startswith("_") else frame.named)[name] = value
        elif int(key) <= 30:
            frame.numbered[int(key)] = value
        else:
            self.globals_numbered[int(key)] = value

    # lines -------------------------------------------------------------------------------
