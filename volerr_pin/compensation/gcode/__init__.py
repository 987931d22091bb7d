"""NC programs (ISO 6983 / RS-274 style): read, compensate, write back.

Understood: G0, G1, G2, G3 (I/J/K centres relative to the start, or R with a negative value
for more than half a turn, or both if they agree; G17/G18/G19 planes; helical moves, P whole
turns), G4, G17-G21, G40, G43/G44/G49 (with a warning), G43.4 and TRAORI (tool-tip
programming) and G49 / TRAFOOF (its end), G54-G59 and the G10 L2 / L20 blocks that set them
(several set-ups, with a table of the controller's offsets: :func:`read_work_offsets`), G61/G64, G80, G90/G91,
G93-G99, F, S, T, H, D, M words, comments ``( ... )`` and ``; ...``, sequence numbers ``N``,
one program number ``O``, ``%`` lines, block delete ``/`` on blocks without moves or G codes,
blank lines. Everything that is not a compensated coordinate is copied byte for byte: a
compensated block keeps its text and only the numbers of its coordinate words change (missing
coordinate words are appended, since compensation moves every axis); the extra pieces of a
split move are inserted as new lines after it.

A program with parameters, expressions or LinuxCNC O-words (subroutines, loops, branches) is
expanded into the program as LinuxCNC runs it, and that is compensated and written
; LinuxCNC's polar words ``@`` / ``^`` are written as the X and Y they mean.

Nothing is guessed: a character that belongs to no word, a repeated word, two codes of one
group, a word that means nothing in its block (I/J/K/R off an arc, an axis the machine does
not have, an E word ...), a degenerate arc, or R and I/J/K that disagree stop the
compensation with an error naming the line (and column). Blocks that cannot be compensated
(canned cycles, macros, subprograms, and every block of a polar or cylindrical interpolation,
rotated, scaled, mirrored or shifted coordinates, up to the code that ends it) are kept
unchanged and named in the report's warnings, or refused with ``strict``; G codes the reader
does not know are refused unless ``pass_through``. A tool change (M6) and a kept block that
names axes make the position unknown.

Programs are read in a dialect (``dialect``: LinuxCNC's, FANUC's, Haas's, SINUMERIK's ISO
subset; told from the program where it says one): what its controller sets by default, as a
lathe's X as a diameter, machine M codes, ``%`` leaders, whole numbers as increments.

Parts, private modules: programs as LinuxCNC runs them (parameters, expressions, O-words) and
its polar words; the lexer (words, blocks, lines, code tables: :func:`parse_block`,
:func:`split_lines`); the modal state and the moves it gives; reading arcs; :func:`interpret`
(a program's moves as one :class:`~volerr_pin.compensation.MoveBatch`); reading a file line by
line (:class:`ProgramFile`); compensating as a stream (:class:`Program`,
:func:`compensate_program`); what cannot be compensated and the modes that change how later
coordinates read; the letters' checks against the modal state; writing pieces back; the
:class:`Report`.
"""

from ._lexer import Block, GcodeError, Word, parse_block, split_lines
from ._program import Program, compensate_program
from ._report import Report
from ._segments import interpret
from ._source import ProgramFile
from ._macros import MOST_BLOCKS, may_need
from ._dialect import NAMES as DIALECTS
from ._offsets import read_work_offsets

__all__ = ["Block", "compensate_program", "DIALECTS", "GcodeError", "interpret", "may_need",
           "MOST_BLOCKS", "parse_block", "Program", "ProgramFile", "read_work_offsets", "Report", "split_lines",
           "Word"]
