"""The API reference, grouped by package, written before the pages are read.

Every module found by :func:`pkgutil.walk_packages` (``__main__`` left out: importing it runs
the command line) gets
``docs/api/generated/<module>.rst`` (ignored by git) with an ``automodule`` of its documented
members. Each package gets a page ``docs/api/generated/<package>.rst``: the first paragraph
of its docstring, what it exports, and a summary of each of its modules (the first paragraph
of the module's docstring) linking to the module's page. The package's own modules at the top
of ``volerr_pin`` are grouped by the layers of ``docs/layout.md``; the pages nest as the
packages do, under ``volerr_pin``'s, which ``docs/api/index.md`` lists, so a new module or
package appears without an edit.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
OUT = DOCS / "api" / "generated"


def modules(package: str = "volerr_pin") -> list[str]:
    """Names of the package's modules and subpackages (``__main__`` left out),
    sorted.

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
                         if m.name.rsplit(".", 1)[-1] != "__main__"]
    return sorted(names)


def packages(names: list[str]) -> list[str]:
    """The packages among ``names``: those that have modules under them.

    Parameters
    ----------
    names : list of str
        Dotted module names (:func:`modules`).

    Returns
    -------
    list of str
        The packages, sorted.
    """
    return sorted({n for n in names if any(m.startswith(n + ".") for m in names)})


def summary(name: str) -> str:
    """The first paragraph of a module's docstring, on one line.

    Parameters
    ----------
    name : str
        Dotted module name.

    Returns
    -------
    str
        The paragraph (empty without a docstring).
    """
    doc = importlib.import_module(name).__doc__ or ""
    return " ".join(doc.strip().split("\n\n")[0].split())


def layers(layout: Path = DOCS / "layout.md") -> list[tuple[str, list[str]]]:
    """The layers of ``docs/layout.md``, top first: (title, entries), an entry a module name or
    a package name ending in ``/``.

    Parameters
    ----------
    layout : Path
        The layout page.

    Returns
    -------
    list of (str, list of str)
        Every layer's title and entries.
    """
    out = []
    for title, cell in re.findall(r"^\| (\d+ [^|]*?) \| (`[^|]*) \|$", layout.read_text(), re.M):
        out.append((title, re.findall(r"`([\w/]+)`", cell)))
    return out


def _module_line(name: str) -> str:
    text = summary(name)
    return f"- :doc:`{name}`" + (f": {text}" if text else "")


def package_page(package: str, names: list[str]) -> str:
    """The reStructuredText of a package's page.

    Parameters
    ----------
    package : str
        Dotted package name.
    names : list of str
        Every module name (:func:`modules`).

    Returns
    -------
    str
        The page: its summary, its modules (by layer for the top package), its exports.
    """
    inner = [n for n in names if n.rpartition(".")[0] == package]
    lines = [package, "=" * len(package), "", summary(package), ""]
    if package == "volerr_pin":
        placed = set()
        for title, entries in layers():
            here = [f"volerr_pin.{e.rstrip('/')}" for e in entries if e != "__init__"]
            here = [n for n in here if n in names]
            if not here:
                continue
            placed |= set(here)
            lines += [f"**Layer {title}**", ""]
            lines += [_module_line(n) for n in here] + [""]
        rest = [n for n in inner if n not in placed]
        if rest:
            lines += ["**Elsewhere**", ""] + [_module_line(n) for n in rest] + [""]
    else:
        lines += ["**Modules**", ""] + [_module_line(n) for n in inner] + [""]
    lines += [".. toctree::", "   :hidden:", ""]
    lines += [f"   {n}" for n in inner] + [""]
    lines += ["**What the package exports**", "", f".. automodule:: {package}", "   :members:", ""]
    return "\n".join(lines)


def write_pages(out: Path = OUT) -> list[Path]:
    """Write one page per package and per module into ``out``, replacing pages of modules
    that are gone.

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
    names = modules()
    groups = set(packages(names))
    pages = []
    for name in names:
        page = out / f"{name}.rst"
        if name in groups:
            text = package_page(name, names)
        else:
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
