"""One API reference page per module of ``volerr_pin``, written before the pages are read.

Every module found by :func:`pkgutil.walk_packages` (``__main__`` left out: importing it runs
the command line) gets ``docs/api/generated/<module>.rst`` (ignored by git) with an
``automodule`` of its documented members; ``docs/api/index.md`` lists them through a glob, so
a new module appears without an edit. The pages document members in full rather than in
autosummary tables, whose one-line summaries are cut out of the docstrings at the first
period and can split an inline literal.
"""

from __future__ import annotations

import pkgutil
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "api" / "generated"
#: old names kept for one release, importing what lives elsewhere now (and warning): no page
ALIASES = {"volerr_pin.compensate"}


def modules(package: str = "volerr_pin") -> list[str]:
    """Names of the package's modules and subpackages (``__main__`` left out), sorted.

    Parameters
    ----------
    package : str
        Importable package name.

    Returns
    -------
    list of str
        Dotted module names, the package itself first.
    """
    root = __import__(package)
    names = [package] + [m.name for m in pkgutil.walk_packages(root.__path__, package + ".")
                         if m.name.rsplit(".", 1)[-1] != "__main__" and m.name not in ALIASES]
    return sorted(names)


def write_pages(out: Path = OUT) -> list[Path]:
    """Write one page per module into ``out``, replacing pages of modules that are gone.

    Parameters
    ----------
    out : Path
        Folder of the generated pages (created).

    Returns
    -------
    list of Path
        The pages written.
    """
    out.mkdir(parents=True, exist_ok=True)
    pages = []
    for name in modules():
        page = out / f"{name}.rst"
        text = f"{name}\n{'=' * len(name)}\n\n.. automodule:: {name}\n   :members:\n"
        if not page.exists() or page.read_text() != text:   # unchanged pages keep their time: no rebuild
            page.write_text(text)
        pages.append(page)
    for stale in set(out.glob("*.rst")) - set(pages):
        stale.unlink()
    return pages


def _builder_inited(app):
    write_pages()


def setup(app):
    app.connect("builder-inited", _builder_inited)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
