"""Public names of a package that load when first used (PEP 562): a package whose parts pull in
Pinocchio, Rerun or matplotlib names them all without paying for them until one is asked for
(the command line's help loads none of them)."""

from __future__ import annotations

import sys
from importlib import import_module

__all__ = ["lazy_exports"]


def lazy_exports(package: str, names: dict[str, tuple[str, ...]]):
    """A package's ``__getattr__``, ``__dir__`` and ``__all__`` for names loaded when first used.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : dict of str to tuple of str
        Part (a module or subpackage, relative to the package: ``"_plots"``, ``"fit.diagnosis"``)
        -> the public names it defines.

    Returns
    -------
    tuple
        ``__getattr__`` (loads the part of a name, and keeps the name on the package),
        ``__dir__`` and ``__all__`` (the names, in the order given).
    """
    where = {name: part for part, defined in names.items() for name in defined}
    public = list(where)

    def __getattr__(name: str):
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(f"{package}.{where[name]}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():
        return list(public)

    return __getattr__, __dir__, public
