"""The picture of docs/layout.md: the package's layers, drawn from the page's own tables.

:func:`svg` reads the layer table ("| 6 command line | `cli/` |") and the table of every
package's parts, top first, and draws one band per layer, top layer first, with a box per
package listing its parts level by level. The picture is committed beside the page
(``docs/images/layers.svg``) so it shows wherever the page is read; ``tests/test_layout.py``
holds that it is what the tables draw, and ``python docs/_ext/layers.py`` draws it again.
"""

from __future__ import annotations

import re
import sys
from html import escape
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "layout.md"
PICTURE = ROOT / "docs" / "images" / "layers.svg"

WIDTH, LABEL, GAP, LINE, PAD = 1100, 190, 10, 15, 8
CHAR = 6.4   # mean advance of the 11 px sans-serif font [px], for wrapping


def tables(text: str) -> tuple[list[tuple[int, str, list[str]]], dict[str, list[list[str]]]]:
    """The layers (number, name, entries) top first, and each package's parts by level.

    Parameters
    ----------
    text : str
        docs/layout.md.

    Returns
    -------
    layers : list of tuple of (int, str, list of str)
    parts : dict of str to list of list of str
        Package (``fit/identify/``) -> its parts, top level first.
    """
    layers = [(int(n), name.strip(), re.findall(r"`([^`]+)`", cell))
              for n, name, cell in re.findall(r"^\| (\d+) ([^|]*)\| (.*) \|$", text, re.M)]
    parts = {}
    for package, cell in re.findall(r"^\| `([\w/]+/)` \| (`__init__`[^|]* > [^|]*) \|$", text, re.M):
        parts[package] = [re.findall(r"`([^`]+)`", level) for level in cell.split(">")]
    return sorted(layers, reverse=True), parts


def _wrap(words: list[str], width: float) -> list[str]:
    lines, line = [], ""
    for word in words:
        trial = f"{line} {word}" if line else word
        if line and len(trial) * CHAR > width:
            lines.append(line)
            line = word
        else:
            line = trial
    return lines + ([line] if line else [])


def _box_lines(entry: str, parts: dict[str, list[list[str]]], width: float) -> list[tuple[str, str]]:
    """(style, text) lines of one package's box: its name, then its parts level by level, top
    first (a sub-package written name/)."""
    out = [("name", "volerr_pin" if entry == "__init__" else entry)]
    if entry == "__init__":
        return out + [("part", line) for line in _wrap(["load_machine, Machine, diagnose, the exceptions"], width)]
    for level in parts.get(entry, []):
        words = [f"{p}/" if f"{entry}{p}/" in parts else p for p in level if p != "__init__"]
        out += [("part", line) for line in _wrap([w + "," for w in words[:-1]] + words[-1:], width)]
    return out


def svg(text: str) -> str:
    """The picture of the layers as SVG text (deterministic: the same tables draw the same bytes).

    Parameters
    ----------
    text : str
        docs/layout.md.

    Returns
    -------
    str
    """
    layers, parts = tables(text)
    body, y = [], 62
    for number, name, entries in layers:
        width = (WIDTH - LABEL - GAP * (len(entries) + 1)) / len(entries)
        boxes = [_box_lines(e, parts, width - 2 * PAD) for e in entries]
        height = max(len(b) for b in boxes) * LINE + 2 * PAD
        body.append(f'<rect x="4" y="{y - 4}" width="{WIDTH - 8}" height="{height + 8}" rx="6" '
                    f'fill="{"#f3f6fb" if number % 2 else "#ffffff"}" stroke="#c9d3e3"/>')
        body.append(f'<text x="14" y="{y + 18}" class="layer">{number}</text>')
        for k, line in enumerate(_wrap(name.split(), LABEL - 40)):
            body.append(f'<text x="36" y="{y + 18 + k * LINE}" class="label">{escape(line)}</text>')
        for i, lines in enumerate(boxes):
            x = LABEL + GAP + i * (width + GAP)
            body.append(f'<rect x="{x:.1f}" y="{y}" width="{width:.1f}" height="{height}" rx="4" '
                        'fill="#ffffff" stroke="#4a6fb4"/>')
            for k, (style, line) in enumerate(lines):
                body.append(f'<text x="{x + PAD:.1f}" y="{y + PAD + 11 + k * LINE}" class="{style}">'
                            f'{escape(line)}</text>')
        y += height + 16
    head = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{y}" viewBox="0 0 {WIDTH} {y}" '
            'font-family="DejaVu Sans, Helvetica, Arial, sans-serif">\n'
            '<style>.layer{font-size:18px;font-weight:bold;fill:#4a6fb4}.label{font-size:12px;fill:#333}'
            '.name{font-size:12px;font-weight:bold;fill:#1f2d4d}.part{font-size:11px;fill:#333}'
            '.title{font-size:12px;fill:#333}</style>\n'
            '<rect width="100%" height="100%" fill="#ffffff"/>\n'
            '<text x="8" y="22" class="name">volerr_pin, layer by layer</text>\n'
            '<text x="8" y="42" class="title">A module imports only from its own layer or the layers below it; '
            'inside a package, a line of parts imports only from its own line or the lines below it.</text>\n')
    return head + "\n".join(body) + "\n</svg>\n"


def draw(page: Path = PAGE, picture: Path = PICTURE) -> Path:
    """Draw the picture of ``page`` into ``picture`` (through a temporary file beside it)."""
    tmp = picture.with_name(picture.name + ".tmp")
    tmp.write_text(svg(page.read_text(encoding="utf-8")), encoding="utf-8")
    tmp.replace(picture)
    return picture


if __name__ == "__main__":
    print(draw(*(Path(a) for a in sys.argv[1:3])))
