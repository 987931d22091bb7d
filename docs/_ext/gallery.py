"""The gallery of examples (sphinx-gallery): each example runs once in the build, and the
pictures it writes are shown above its code with what it printed.

The examples are programs that write their results into a folder given on their command line
(``python examples/NAME.py OUT``), not scripts that leave matplotlib figures open. So
:func:`argv` gives each one a fresh folder of its own in a temporary directory (nothing is
written beside the examples or into the sources), and :func:`pictures`, the gallery's image
scraper, shows the PNG files that appeared there, in the order they were written. Examples
that need data from other groups (``*_real_data.py``) are shown without running; the one that
writes the sample data into ``examples/data/`` is not in the gallery.

sphinx-gallery names both functions by their import path (``gallery.argv``), which keeps the
configuration cacheable.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

#: every example's output folder lives here; the directory goes when the build's process ends
_SCRATCH = tempfile.TemporaryDirectory(prefix="volerr_gallery_")

#: examples whose command line names a file rather than a folder: the file's name in their folder
_FILE_ARGUMENT = {"lathe_cold_start": "lathe_cold_start.rrd"}

#: PNG files of an example's folder already shown, by example
_SHOWN: dict[str, set[Path]] = {}


def _folder(src_file: str) -> Path:
    return Path(_SCRATCH.name) / Path(src_file).stem


def argv(gallery_conf, script_vars) -> list[str]:
    """The command line an example runs with in the build: its own fresh output folder."""
    stem = Path(script_vars["src_file"]).stem
    folder = _folder(script_vars["src_file"])
    shutil.rmtree(folder, ignore_errors=True)
    _SHOWN[stem] = set()
    return [str(folder / _FILE_ARGUMENT[stem])] if stem in _FILE_ARGUMENT else [str(folder)]


def pictures(block, block_vars, gallery_conf) -> str:
    """The image scraper: the PNG files the example wrote since the last block, copied where
    sphinx-gallery keeps its images, as reST."""
    from sphinx_gallery.scrapers import figure_rst

    stem = Path(block_vars["src_file"]).stem
    folder = _folder(block_vars["src_file"])
    written = sorted(folder.rglob("*.png"), key=lambda p: (p.stat().st_mtime_ns, p.name)) if folder.is_dir() else []
    new = [p for p in written if p not in _SHOWN.setdefault(stem, set())]
    shown = []
    for path, target in zip(new, block_vars["image_path_iterator"]):
        shutil.copyfile(path, target)
        _SHOWN[stem].add(path)
        shown.append(target)
    return figure_rst(shown, gallery_conf["src_dir"]) if shown else ""
