"""Read the library's numpydoc docstrings as the plain text they are written as.

The docstrings write absolute values and norms as ``|x|`` (``|B_i|``, ``|error|``), which
reStructuredText would take for substitution references (an error under ``-W``). This hook
escapes a ``|`` outside inline literals, on lines that are not a table or a line block, before
numpydoc and autodoc read the docstring. Nothing else of the docstring is changed.
"""

from __future__ import annotations

import re

LITERAL = re.compile(r"(``.*?``)")


def escape_bars(line: str) -> str:
    """``line`` with every ``|`` outside ````...```` escaped, unless it starts a table row or
    a line block."""
    if line.lstrip().startswith(("| ", "+-", "+=")):
        return line
    parts = LITERAL.split(line)
    return "".join(p if p.startswith("``") and p.endswith("``") and len(p) >= 4 else p.replace("|", r"\|")
                   for p in parts)


def _process(app, what, name, obj, options, lines):
    lines[:] = [escape_bars(line) for line in lines]


def setup(app):
    app.connect("autodoc-process-docstring", _process, priority=100)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
