"""Control flow a compensated program cannot follow: loops that run blocks again, jumps back,
and subroutine bodies, which run where they are called, not where they are defined.

The reader compensates each block once, for the one pass it reads. That is right for a block
that moves to absolute coordinates, wherever it runs from, but not for an incremental (G91)
move: run again by a loop (a Fanuc ``WHILE ... DOn`` / ``ENDn``, a LinuxCNC ``o100 while`` /
``do`` / ``repeat``) or after a jump back (``GOTO n``), it adds the correction of the pass it was
compensated for at every other place (three passes of a 10 mm G91 step left Z 4.1 um off).
Such a loop is refused, naming it and the incremental move in it. A LinuxCNC subroutine body
(``o100 sub`` ... ``o100 endsub``) is kept unchanged and not followed where it is defined; at a
call (``o100 call``) the modes the body leaves in force (G codes and M70-M72, unless it saves
them with M73 for its return) are applied, as LinuxCNC runs it there.
"""

from __future__ import annotations

import re

from ._lexer import AUTORESTORE_MODES, MOST_DIGITS, GcodeError, word_values

__all__ = ["Flow"]

#: a LinuxCNC O-word statement: its name (a number or <name>) and keyword
O_WORD = re.compile(r"[ \t]*(?:N[ \t]*[0-9]+[ \t]*)?O[ \t]*([0-9]+|<[^>]*>)[ \t]*(SUB|ENDSUB|CALL|WHILE|"
                    r"ENDWHILE|DO|REPEAT|ENDREPEAT|IF|ELSEIF|ELSE|ENDIF|RETURN|BREAK|CONTINUE)\b")
#: a label's or a loop's number (one of more than MOST_DIGITS digits is none: the reader refuses it)
WHOLE = rf"([0-9]{{1,{MOST_DIGITS}}})(?![0-9])"
#: a Fanuc macro loop's start (WHILE [...] DOn) and end (ENDn), and a jump (GOTO n)
FANUC_DO = re.compile(r"\bWHILE\b.*\bDO[ \t]*" + WHOLE)
FANUC_END = re.compile(r"^[ \t]*(?:N[ \t]*[0-9]+[ \t]*)?END[ \t]*" + WHOLE + r"\b")
GOTO = re.compile(r"\bGOTO[ \t]*" + WHOLE)
LABEL = re.compile(r"[ \t]*N[ \t]*" + WHOLE)


class Flow:
    """The loops, jumps and subroutine bodies of a program read line by line.

    Parameters
    ----------
    source : str
        The program's name, for messages.

    Attributes
    ----------
    body : tuple of (str, int) or None
        The subroutine whose body is being read (its name and the line of its ``sub``), if any.
    """

    def __init__(self, source: str):
        self.source = source
        self.body: tuple[str, int] | None = None
        self._labels: dict[int, int] = {}           # N label -> the line it stands on
        self._incremental: list[int] = []           # lines of incremental moves compensated
        self._loops: list[tuple[str, int]] = []     # open loops: (key, line of their start)
        self._jumps: list[tuple[int, int]] = []     # jumps to labels not seen yet: (label, line)
        self._bodies: dict[str, list[tuple[str, float]]] = {}   # subroutine -> its G and M words
        self._words: list[tuple[str, float]] = []

    def incremental(self, number: int) -> None:
        """Note an incremental move compensated for one pass.

        Parameters
        ----------
        number : int
            Its line.
        """
        self._incremental.append(number)

    def line(self, code: str, number: int) -> bool:
        """Follow a line that is read one by one (not in a run of plain lines).

        Parameters
        ----------
        code : str
            The line with its comments blanked out, upper case.
        number : int
            Its line.

        Returns
        -------
        bool
            True for a line of a subroutine body (its ``sub`` and ``endsub`` included): kept
            unchanged and not followed here.

        Raises
        ------
        GcodeError
            A loop's end or a jump back over an incremental move compensated for one pass.
        """
        o_word = O_WORD.match(code)
        if self.body is not None:
            if o_word and o_word.group(2) == "ENDSUB" and o_word.group(1) == self.body[0]:
                self._bodies[self.body[0]] = self._words
                self.body = None
            else:
                self._words += [(letter, v) for letter, v in word_values(code) if letter in "GM"]
            return True
        label = LABEL.match(code)
        if label:
            self._arrive(int(label.group(1)), number)
        if o_word:
            name, keyword = o_word.groups()
            if keyword == "SUB":
                self.body, self._words = (name, number), []
                return True
            if keyword in ("WHILE", "DO", "REPEAT") and not (keyword == "WHILE" and self._open(f"O{name} DO")):
                self._loops.append((f"O{name} {'DO' if keyword == 'DO' else 'LOOP'}", number))
            elif keyword in ("ENDWHILE", "ENDREPEAT", "WHILE"):
                key = f"O{name} {'DO' if keyword == 'WHILE' else 'LOOP'}"
                self._close(key, number, f"o{name.lower()} {keyword.lower()}")
            return False
        do = FANUC_DO.search(code)
        if do:
            self._loops.append((f"DO{int(do.group(1))}", number))
        end = FANUC_END.match(code)
        if end:
            self._close(f"DO{int(end.group(1))}", number, f"END{int(end.group(1))}")
        goto = GOTO.search(code)
        if goto:
            target = int(goto.group(1))
            if target in self._labels and self._labels[target] < number:
                self._check(self._labels[target], number, f"GOTO {target}")
            else:
                self._jumps.append((target, number))
        return False

    def called(self, code: str, state, where: str) -> None:
        """Apply the modes a subroutine call leaves in force, as LinuxCNC runs the body there: the
        G and M words of a body read before, in order (none when it saves the modes with M73,
        which its return restores).

        Parameters
        ----------
        code : str
            The line with its comments blanked out, upper case (nothing happens unless it calls
            a body read before).
        state : ModalState
            Updated in place.
        where : str
            ``source:line``, for messages.
        """
        o_word = O_WORD.match(code)
        if not o_word or o_word.group(2) != "CALL" or o_word.group(1) not in self._bodies:
            return
        words = self._bodies[o_word.group(1)]
        if ("M", AUTORESTORE_MODES) in words:
            return
        for letter, value in words:
            if letter == "G":
                state.apply_g([value])
            else:
                state.apply_m([value], where)

    def finish(self, number: int) -> None:
        """Check the jumps whose labels were not seen on a line read one by one after them: the
        label may stand on an earlier line read in a run, so the jump may go back.

        Parameters
        ----------
        number : int
            The program's last line.

        Raises
        ------
        GcodeError
            Such a jump after an incremental move compensated for one pass.
        """
        for target, line in self._jumps:
            self._check(1, line, f"GOTO {target} (to a label not found after it, so perhaps before it)")

    # ---------------------------------------------------------------------------------
    def _arrive(self, label: int, number: int) -> None:
        self._labels[label] = number
        self._jumps = [(t, n) for t, n in self._jumps if t != label]   # a jump forward to it

    def _open(self, key: str) -> bool:
        return any(k == key for k, _ in self._loops)

    def _close(self, key: str, number: int, what: str) -> None:
        for k in range(len(self._loops) - 1, -1, -1):
            if self._loops[k][0] == key:
                start = self._loops.pop(k)[1]
                self._check(start, number, what)
                return

    def _check(self, start: int, number: int, what: str) -> None:
        inside = [n for n in self._incremental if start <= n <= number]
        if inside:
            raise GcodeError(f"{self.source}:{number}: {what} runs lines {start}-{number} again, and line {inside[0]} "
                             "among them moves incrementally (G91): it is compensated for one pass, and each further "
                             "pass would add that pass's correction at another place; program the moves in the loop "
                             "absolutely (G90), or give the program with the loop written out")
