"""The public API of the library modules has numpydoc docstrings: a summary line, ``Parameters``
naming every parameter, ``Returns`` for whatever returns a value, ``Attributes`` naming every
field of a dataclass."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import pkgutil
import re
import textwrap

import pytest

def _public_modules() -> list[str]:
    """Every public package and public module of the library (no part of its name private), by
    name relative to ``volerr_pin``: the public API is what they name in ``__all__``."""
    import pkgutil

    import volerr_pin

    names = [m.name for m in pkgutil.walk_packages(volerr_pin.__path__, "volerr_pin.")
             if not any(part.startswith("_") for part in m.name.split(".")) and ".cli" not in m.name]
    return sorted(n.removeprefix("volerr_pin.") for n in names)


MODULES = tuple(_public_modules())

SECTION_RE = re.compile(r"^(\w[\w ]*)\n-{3,}$", re.MULTILINE)


def public_objects(module) -> list[tuple[str, object]]:
    """Functions and classes a module offers: those of its ``__all__`` (which may re-export the
    library's own from the modules that define them: a curated entry point), else every
    top-level name without a leading underscore that it defines itself."""
    names = getattr(module, "__all__", None)
    if names is None:
        return [(n, obj) for n, obj in vars(module).items() if not n.startswith("_")
                and (inspect.isfunction(obj) or inspect.isclass(obj)) and obj.__module__ == module.__name__]
    return [(n, obj) for n in names for obj in [getattr(module, n)]
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and obj.__module__.startswith("volerr_pin")]


def sections(doc: str) -> dict[str, str]:
    """Section title -> body of a cleaned numpydoc docstring."""
    marks = list(SECTION_RE.finditer(doc))
    return {m.group(1): doc[m.end():marks[k + 1].start() if k + 1 < len(marks) else len(doc)]
            for k, m in enumerate(marks)}


def documented_names(body: str) -> set[str]:
    """Names of the entries of a Parameters / Attributes section (``a, b : type`` lines)."""
    names = set()
    for line in body.splitlines():
        if line and not line[0].isspace():
            names.update(n.strip().lstrip("*") for n in line.split(" : ")[0].split(","))
    return names


def returns_value(fn) -> bool:
    """Whether ``fn`` returns something: by its annotation, else by a ``return <value>`` in its body."""
    annotation = inspect.signature(fn).return_annotation
    if annotation is not inspect.Signature.empty:
        return annotation not in (None, "None")
    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))

    def walk(node):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
                continue
            if isinstance(child, (ast.Yield, ast.YieldFrom)):
                return True
            if isinstance(child, ast.Return) and child.value is not None and not (
                    isinstance(child.value, ast.Constant) and child.value.value is None):
                return True
            if walk(child):
                return True
        return False

    return walk(tree.body[0])


def parameters(fn, bound: bool) -> list[str]:
    names = list(inspect.signature(fn).parameters)
    return names[1:] if bound and names else names


def function_problems(name: str, fn, bound: bool = False, doc: str | None = None) -> list[str]:
    """What ``fn``'s docstring (or ``doc``, the one it inherits) lacks."""
    if doc is None:
        doc = inspect.getdoc(fn) if fn.__doc__ else None
    if not doc or not doc.splitlines()[0].strip() or SECTION_RE.match(doc):
        return [f"{name}: no docstring with a one-line summary"]
    found = sections(doc)
    problems = []
    params = parameters(fn, bound)
    if params:
        if "Parameters" not in found:
            problems.append(f"{name}: no Parameters section")
        else:
            missing = [p for p in params if p not in documented_names(found["Parameters"])]
            if missing:
                problems.append(f"{name}: Parameters does not name {', '.join(missing)}")
    if returns_value(fn) and "Returns" not in found and "Yields" not in found:
        problems.append(f"{name}: no Returns section")
    return problems


def class_problems(name: str, cls) -> list[str]:
    doc = inspect.getdoc(cls) if cls.__doc__ else None
    if not doc or not doc.splitlines()[0].strip() or doc.startswith(f"{cls.__name__}("):
        return [f"{name}: no docstring with a one-line summary"]  # (dataclasses make one up)
    found = sections(doc)
    problems = []
    if dataclasses.is_dataclass(cls):
        fields = [f.name for f in dataclasses.fields(cls)]
        if fields and "Attributes" not in found:
            problems.append(f"{name}: no Attributes section")
        elif fields:
            missing = [f for f in fields if f not in documented_names(found["Attributes"])]
            if missing:
                problems.append(f"{name}: Attributes does not name {', '.join(missing)}")
    # a Protocol has no constructor; typing gives a class that subclasses one object's own
    elif "__init__" in vars(cls) and not getattr(cls, "_is_protocol", False) and cls.__init__ is not object.__init__:
        params = parameters(cls.__init__, bound=True)
        if params and "Parameters" not in found:
            problems.append(f"{name}: no Parameters section for the constructor")
        elif params:
            missing = [p for p in params if p not in documented_names(found["Parameters"])]
            if missing:
                problems.append(f"{name}: Parameters does not name {', '.join(missing)}")
    for member, value in vars(cls).items():
        if member.startswith("_"):
            continue
        label = f"{name}.{member}"
        inherited = protocol_doc(cls, member)   # an override shows its protocol's docstring
        if isinstance(value, property):
            if not (value.fget.__doc__ or "").strip() and not inherited:
                problems.append(f"{label}: property without a docstring")
        elif isinstance(value, staticmethod):
            problems += function_problems(label, value.__func__, doc=_own(value.__func__) or inherited)
        elif isinstance(value, classmethod):
            problems += function_problems(label, value.__func__, bound=True, doc=_own(value.__func__) or inherited)
        elif inspect.isfunction(value):
            problems += function_problems(label, value, bound=True, doc=_own(value) or inherited)
    return problems


def _own(fn) -> str | None:
    return inspect.getdoc(fn) if fn.__doc__ else None


def _function(value):
    if isinstance(value, (staticmethod, classmethod)):
        return value.__func__
    return value.fget if isinstance(value, property) else value


def protocol_doc(cls, member: str) -> str | None:
    """The docstring ``cls.member`` inherits: that of the nearest base of the library that
    defines and documents it (a protocol or a base class), else None."""
    for base in cls.__mro__[1:]:
        if base.__module__.startswith("volerr_pin") and member in vars(base):
            fn = _function(vars(base)[member])
            if callable(fn) and fn.__doc__:
                return inspect.getdoc(fn)
    return None


def _library_classes() -> list[type]:
    import volerr_pin

    out = []
    for info in pkgutil.walk_packages(volerr_pin.__path__, "volerr_pin."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        out += [c for c in vars(module).values() if inspect.isclass(c) and c.__module__ == info.name]
    return out


def test_overrides_inherit_their_protocols_docstring():
    """A method that implements a documented method of a protocol or base class, with its
    parameters, does not copy the docstring: it inherits it (``help``, ``inspect.getdoc`` and
    the API pages show the protocol's), and what the class does differently is said in the
    class docstring. A parameter named otherwise keeps its own docstring."""
    copies = []
    for cls in _library_classes():
        for member, value in vars(cls).items():
            fn = _function(value)
            if member.startswith("_") or not callable(fn) or not fn.__doc__ or not protocol_doc(cls, member):
                continue
            base = next(b for b in cls.__mro__[1:] if member in vars(b))
            mine, theirs = (list(inspect.signature(f).parameters) for f in (fn, _function(vars(base)[member])))
            if mine == theirs:
                copies.append(f"{cls.__module__}.{cls.__name__}.{member} (from {base.__name__})")
    assert not copies, "docstrings copied from their protocol:\n  " + "\n  ".join(copies)


def problems_of(module) -> list[str]:
    out = []
    for name, obj in public_objects(module):
        out += class_problems(name, obj) if inspect.isclass(obj) else function_problems(name, obj)
    return out


@pytest.mark.parametrize("name", MODULES)
def test_public_api_has_numpydoc_sections(name):
    module = importlib.import_module(f"volerr_pin.{name}")
    has_parts = any(not m.name.startswith("_") for m in pkgutil.iter_modules(getattr(module, "__path__", [])))
    assert public_objects(module) or has_parts, f"volerr_pin.{name} has no public functions, classes or parts?"
    problems = problems_of(module)
    assert not problems, f"volerr_pin.{name}:\n  " + "\n  ".join(problems)


def test_the_check_finds_what_is_missing():
    """The checker itself: undocumented or half-documented callables are reported."""

    def bare(x):
        return x

    def no_returns(x, *, scale=1.0):
        """Scale ``x``.

        Parameters
        ----------
        x : float
            A value [m].
        """
        return x * scale

    def fine(x) -> None:
        """Print ``x``.

        Parameters
        ----------
        x : float
            A value [m].
        """
        print(x)

    @dataclasses.dataclass
    class Fields:
        """Two fields.

        Attributes
        ----------
        a : float
            A length [m].
        """

        a: float
        b: float

        @property
        def total(self) -> float:
            return self.a + self.b

    assert function_problems("bare", bare) == ["bare: no docstring with a one-line summary"]
    assert function_problems("no_returns", no_returns) == [
        "no_returns: Parameters does not name scale", "no_returns: no Returns section"]
    assert function_problems("fine", fine) == []
    assert class_problems("Fields", Fields) == ["Fields: Attributes does not name b",
                                                "Fields.total: property without a docstring"]
