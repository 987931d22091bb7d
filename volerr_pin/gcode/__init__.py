"""NC programs (ISO 6983 / RS-274 style): read, compensate, write back.

Understood: G0, G1, G2, G3 (I/J/K centres relative to the start, or R with a negative value
for more than half a turn; G17/G18/G19 planes; helical moves), G90/G91, G20/G21, F, S, T,
M words, comments ``( ... )`` and ``; ...``, line numbers ``N``, blank lines. Everything that
is not a compensated coordinate is copied byte for byte: a compensated block keeps its text
and only the numbers of its coordinate words change (missing coordinate words are appended,
since compensation moves every axis); the extra pieces of a split move are inserted as new
lines before it. Canned cycles, macros and subprograms (G73-G89, G65, M98, M99, O-words,
``#`` variables, IF/WHILE/GOTO) stop the compensation with an error naming the line unless
``pass_through`` is set, in which case they are kept and listed as warnings.

Modules: :mod:`.lexer` (words, blocks, lines, code tables), :mod:`.modal` (the modal state
and the moves it gives, :func:`interpret`), :mod:`.rewrite` (compensating and writing back).
"""

from .lexer import Block, GcodeError, Word, parse_block, split_lines
from .modal import Segment, interpret
from .rewrite import Program, Report, compensate_program

__all__ = ["Block", "GcodeError", "Program", "Report", "Segment", "Word", "compensate_program", "interpret",
           "parse_block", "split_lines"]
