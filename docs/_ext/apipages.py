"""The API reference, a page per package, written before the pages are read.

The library's public API is what each package names in its ``__all__`` (its modules are
private, ``_name.py``, as SciPy's are): each public package (found by
:func:`pkgutil.walk_packages`, no part of its name private) gets
``docs/api/generated/<package>.rst`` (ignored by git) with the first paragraph of its
docstring, its public subpackages, and every public name documented in full (``autofunction``,
``autoclass`` with its members, ``autodata``), in the order of its ``__all__``. The top
package's page groups the packages by the layers of ``docs/layout.md``; the pages nest as the
packages do, under ``volerr_pin``'s, which ``docs/api/index.md`` lists, so a new package or
public name appears without an edit.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
OUT = DOCS / "api" / "generated"


def packages(package: str = "volerr_pin") -> list[str]:
    """The public packages: the top one and every subpackage no part of whose name is private.

    Parameters
    ----------
    package : str
        Importable package name.

    Returns
    -------
    list of str
        Dotted package names, sorted (the top package first).
    """
    root = importlib.import_module(package)
    found = [m.name for m in pkgutil.walk_packages(root.__path__, package + ".")
             if m.ispkg and not any(part.startswith("_") for part in m.name.split("."))]
    return sorted([package] + found)


def public_names(package: str) -> list[str]:
    """The names a package makes public: its ``__all__``, in order (its subpackages left out:
    they have pages of their own).

    Parameters
    ----------
    package : str
        Dotted package name.

    Returns
    -------
    list of str
        The names.
    """
    module = importlib.import_module(package)
    return [n for n in getattr(module, "__all__", []) if not inspect.ismodule(getattr(module, n))]


def summary(name: str) -> str:
    """The first paragraph of a package's docstring, on one line.

    Parameters
    ----------
    name : str
        Dotted package name.

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


def _package_line(name: str) -> str:
    text = summary(name)
    return f"- :doc:`{name}`" + (f": {text}" if text else "")


def home(obj, package: str) -> str:
    """The public package whose private modules define ``obj``: the one page that documents it
    (a package that also names it links there). Data without a module of their own stay where
    they are named.

    Parameters
    ----------
    obj : object
        A public name's value.
    package : str
        The package that names it.

    Returns
    -------
    str
        Dotted package name.
    """
    module = getattr(obj, "__module__", None) if (inspect.isclass(obj) or callable(obj)) else None
    if not module or not module.startswith("volerr_pin"):
        return package
    parts = module.split(".")
    while parts and parts[-1].startswith("_"):
        parts.pop()
    owner = ".".join(parts)
    names = getattr(importlib.import_module(owner), "__all__", []) if owner else []
    return owner if any(getattr(importlib.import_module(owner), n, None) is obj for n in names) else package


def _directive(package: str, name: str) -> list[str]:
    """The autodoc directive that documents ``package.name``, or a link to its home's page."""
    obj = getattr(importlib.import_module(package), name)
    owner = home(obj, package)
    if owner != package:
        role = "class" if inspect.isclass(obj) else "func"
        return [f"- :py:{role}:`{package}.{name} <{owner}.{name}>` (documented in :doc:`{owner}`)", ""]
    target = f"{package}.{name}"
    if inspect.isclass(obj):
        return [f".. autoclass:: {target}", "   :members:", ""]
    if inspect.isfunction(obj) or inspect.isbuiltin(obj):
        return [f".. autofunction:: {target}", ""]
    return [f".. autodata:: {target}", "   :annotation:", ""]


def package_page(package: str, all_packages: list[str]) -> str:
    """The reStructuredText of a package's page.

    Parameters
    ----------
    package : str
        Dotted package name.
    all_packages : list of str
        Every public package (:func:`packages`).

    Returns
    -------
    str
        The page: its summary, its subpackages (by layer for the top package), its public names.
    """
    inner = [p for p in all_packages if p.rpartition(".")[0] == package]
    lines = [package, "=" * len(package), "", summary(package), ""]
    if package == "volerr_pin":
        placed = set()
        for title, entries in layers():
            here = [f"volerr_pin.{e.rstrip('/')}" for e in entries if e != "__init__"]
            here = [p for p in here if p in all_packages]
            if not here:
                continue
            placed |= set(here)
            lines += [f"**Layer {title}**", ""] + [_package_line(p) for p in here] + [""]
        rest = [p for p in inner if p not in placed]
        if rest:
            lines += ["**Elsewhere**", ""] + [_package_line(p) for p in rest] + [""]
    elif inner:
        lines += ["**Subpackages**", ""] + [_package_line(p) for p in inner] + [""]
    if inner:
        lines += [".. toctree::", "   :hidden:", ""] + [f"   {p}" for p in inner] + [""]
    names = public_names(package)
    if names:
        lines += ["**Public names**", "", ".. currentmodule:: " + package, ""]
        for name in names:
            lines += _directive(package, name)
    return "\n".join(lines)


def write_pages(out: Path = OUT) -> list[Path]:
    """Write one page per public package into ``out``, replacing pages of packages that are gone.

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
    found = packages()
    pages = []
    for name in found:
        page = out / f"{name}.rst"
        text = package_page(name, found)
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
