"""Reading a program file line by line, in bounded memory, as strictly as a whole file is read.

The file must be a regular file of UTF-8 text without NUL bytes (a byte order mark is kept on
the first line, which the lexer reads past); an error names the line, column and byte. Only
LF and CR LF end lines, as in :func:`~volerr_pin.compensation.gcode.split_lines`.
"""

from __future__ import annotations

import stat
from collections.abc import Iterator
from pathlib import Path

from ._lexer import GcodeError

__all__ = ["BLOCK", "MAX_LINE", "ProgramFile"]

#: bytes read at a time
BLOCK = 1 << 20
#: the longest line read [bytes]
MAX_LINE = 16 << 20


class ProgramFile:
    """A program file, checked before it is read.

    Parameters
    ----------
    path : str or path
        The file.
    what : str, default "program file"
        What it is, for messages.

    Attributes
    ----------
    path : Path
        The file.
    size : int
        Its size [bytes].
    done : int
        Bytes read so far.

    Raises
    ------
    GcodeError
        If the file cannot be read, is a folder, or is not a regular file (a device, pipe or
        socket).
    """

    def __init__(self, path, what: str = "program file"):
        self.path = Path(path)
        self.what = what
        try:
            info = self.path.stat()
        except OSError as err:
            raise GcodeError(f"{self.path}: cannot read {what}: {err.strerror}") from None
        if stat.S_ISDIR(info.st_mode):
            raise GcodeError(f"{self.path}: is a folder, not a {what}")
        if not stat.S_ISREG(info.st_mode):
            raise GcodeError(f"{self.path}: not a regular file (a device, pipe or socket); give a {what}")
        self.size = info.st_size
        self.done = 0

    def lines(self) -> Iterator[tuple[str, str]]:
        """The lines of the file with their endings, read a block at a time.

        Yields
        ------
        (str, str)
            The line without its ending, and the ending (``"\\n"``, ``"\\r\\n"`` or ``""`` on a
            last line without one).

        Raises
        ------
        GcodeError
            Naming line, column and byte: bytes that are not UTF-8, or a NUL byte.
        """
        try:
            fh = open(self.path, "rb")
        except OSError as err:
            raise GcodeError(f"{self.path}: cannot read {self.what}: {err.strerror}") from None
        with fh:
            line_no = 1  # line number of the first line of ``pending``
            pending = b""
            offset = 0  # file offset of ``pending``
            while True:
                try:
                    data = fh.read(BLOCK)
                except OSError as err:
                    raise GcodeError(f"{self.path}: cannot read {self.what}: {err.strerror}") from None
                final = not data
                if final and not pending:
                    break
                pending += data
                cut = len(pending) if final else pending.rfind(b"\n") + 1
                if cut <= 0:
                    if len(pending) > MAX_LINE:
                        raise GcodeError(f"{self.path}:{line_no}: a line longer than {MAX_LINE >> 20} MB; this is "
                                         f"not an NC program")
                    continue
                part, pending = pending[:cut], pending[cut:]
                self._check(part, line_no, offset)
                lines = part.decode("utf-8").split("\n")
                last = lines.pop()  # after the last LF: empty unless the file ends without one
                for raw in lines:
                    yield (raw[:-1], "\r\n") if raw.endswith("\r") else (raw, "\n")
                if last:
                    yield last, ""
                line_no += len(lines)
                offset += cut
                self.done = offset
                if final:
                    break

    def _check(self, part: bytes, line_no: int, offset: int) -> None:
        try:
            part.decode("utf-8")
        except UnicodeDecodeError as err:
            line, column = _line_and_column(part, err.start, line_no)
            raise GcodeError(f"{self.path}:{line}:{column}: not UTF-8 text (byte 0x{part[err.start]:02x} at offset "
                             f"{offset + err.start}); save the {self.what} as UTF-8") from None
        nul = part.find(b"\x00")
        if nul >= 0:
            line, column = _line_and_column(part, nul, line_no)
            raise GcodeError(f"{self.path}:{line}:{column}: a NUL byte; this is not a text file")


def _line_and_column(data: bytes, at: int, first_line: int) -> tuple[int, int]:
    """1-based line and character column of a byte offset (the bytes before it are UTF-8)."""
    start = data.rfind(b"\n", 0, at) + 1
    return first_line + data.count(b"\n", 0, at), len(data[start:at].decode("utf-8", "replace")) + 1
