"""The layout holds: the layers of docs/layout.md (no module imports from a layer above its
own), the order inside the packages, and no import cycle. Every kind of import counts: at the
top, inside functions, under ``if TYPE_CHECKING:`` (a type named for annotations is a
dependency a reader must follow too) and a module loaded by name through ``importlib``.
Sizes are a review guideline, not a test.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "volerr_pin"
LAYOUT = ROOT / "docs" / "layout.md"
def module_name(path: Path) -> str:
    """``identify.fit`` for volerr_pin/fit/identify/fit.py, ``identify`` for its __init__, ``__init__``
    for the package's own."""
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _loaded_by_name(node: ast.AST, package: str) -> str | None:
    """The module an ``importlib.import_module("...")`` call loads (a relative name resolved
    against ``package``; the constant start of an f-string), or None for another node."""
    if not (isinstance(node, ast.Call) and node.args
            and getattr(node.func, "attr", getattr(node.func, "id", None)) in ("import_module", "_import_module")):
        return None
    arg = node.args[0]
    if isinstance(arg, ast.JoinedStr):
        arg = arg.values[0] if arg.values else None
    if not (isinstance(arg, ast.Constant) and isinstance(arg.value, str)):
        return None
    text = arg.value.rstrip(".")
    if text.startswith("volerr_pin"):
        return text.removeprefix("volerr_pin").lstrip(".") or "__init__"
    if not text.startswith("."):
        return None
    level = len(text) - len(text.lstrip("."))
    base = package.split(".") if package else []
    return ".".join(base[:len(base) - level + 1] + [text.lstrip(".")]) or "__init__"


def imports(name: str) -> set[str]:
    """The library modules a module imports (at any depth of its code, under TYPE_CHECKING too,
    and loaded by name through importlib), by module name."""
    path = MODULES[name]
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" and name != "__init__" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        loaded = _loaded_by_name(node, package)
        if loaded is not None:
            out.add(loaded if loaded in MODULES else loaded.rpartition(".")[0] or "__init__")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".") if package else []
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.startswith("volerr_pin"):
                target = node.module.removeprefix("volerr_pin").lstrip(".")
            else:
                continue
            for alias in node.names:
                full = f"{target}.{alias.name}" if target else alias.name
                out.add(full if full in MODULES else (target or "__init__"))
                part = _lazy_parts(target).get(alias.name)   # a name a package loads when first used
                if part is not None:
                    out.add(part)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("volerr_pin"):
                    out.add(alias.name.removeprefix("volerr_pin").lstrip(".") or "__init__")
    out.discard(name)
    return out


def _lazy_parts(package: str) -> dict[str, str]:
    """Name -> the module that defines it, for a package that loads its public names when first
    used (a literal ``_NAMES = {part: (names, ...)}`` in its ``__init__``); empty for others."""
    path = MODULES.get(package or "__init__")
    if path is None or path.name != "__init__.py":
        return {}
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "_NAMES" for t in node.targets):
            parts = ast.literal_eval(node.value)
            prefix = f"{package}." if package else ""
            return {name: f"{prefix}{part}" for part, names in parts.items() for name in names
                    if f"{prefix}{part}" in MODULES}
    return {}


def _names(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


def layers() -> dict[str, int]:
    """Package (``fit/``) or module (``__init__``) -> layer, from the table of docs/layout.md."""
    out = {}
    for number, cell in re.findall(r"^\| (\d+) [^|]*\| (.*) \|$", LAYOUT.read_text(), re.M):
        for entry in _names(cell):
            assert entry not in out, f"docs/layout.md places {entry} twice"
            out[entry] = int(number)
    return out


def package_order() -> dict[str, dict[str, int]]:
    """Package (dotted: ``fit.identify``) -> {part: level} from the table of docs/layout.md (top
    first, '>' between levels; a part is a module or a package inside it)."""
    out = {}
    for package, cell in re.findall(r"^\| `([\w/]+)/` \| (`__init__`[^|]* > [^|]*) \|$", LAYOUT.read_text(), re.M):
        levels = cell.split(">")
        out[package.replace("/", ".")] = {part: len(levels) - k for k, level in enumerate(levels)
                                          for part in _names(level)}
    return out


def layer_of(name: str, table: dict[str, int]) -> int | None:
    if name in table:
        return table[name]
    top = name.split(".")[0]
    return table.get(f"{top}/")


def test_the_layout_table_is_read():
    table, order = layers(), package_order()
    assert table["cli/"] == 6 and table["base/"] == 0 and table["measurements/"] == 2 and table["__init__"] == 4
    assert order["measurements"]["_registry"] > order["measurements"]["_points"] > order["measurements"]["_table"]
    assert order["model"]["_machine"] > order["model"]["_algorithms"] > order["model"]["_model"]
    assert order["fit"]["diagnosis"] > order["fit"]["identify"] and "_lexer" in order["compensation.gcode"]


def test_the_package_root_shows_the_layers():
    """At most 12 entries at the root of the package, and every folder there is a layer."""
    entries = sorted(p.name for p in PACKAGE.iterdir() if p.name != "__pycache__" and not p.name.endswith(".egg-info"))
    assert len(entries) <= 12, entries
    table = layers()
    assert {e + "/" for e in entries if (PACKAGE / e).is_dir()} == {k for k in table if k.endswith("/")}


def test_every_module_has_a_layer():
    table = layers()
    unplaced = [name for name in MODULES if layer_of(name, table) is None]
    assert not unplaced, f"docs/layout.md does not place {unplaced}: add them to its layer table"
    missing = [entry for entry in table if entry.rstrip("/") not in MODULES]
    assert not missing, f"docs/layout.md places modules that do not exist: {missing}"


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_imports_from_a_layer_above(name):
    table = layers()
    own = layer_of(name, table)
    above = sorted(f"{t} (layer {layer_of(t, table)})" for t in imports(name) if layer_of(t, table) > own)
    assert not above, f"{name} (layer {own}) imports from above: {', '.join(above)}"


@pytest.mark.parametrize("package", sorted(package_order()))
def test_no_part_of_a_package_imports_one_above_it(package):
    order = package_order()[package]

    def part(name):
        rest = name.removeprefix(package).lstrip(".")
        return rest.split(".")[0] if rest else "__init__"

    parts = {name for name in MODULES if name == package or name.startswith(package + ".")}
    unlisted = sorted(p for p in parts if part(p) not in order)
    assert not unlisted, f"docs/layout.md does not order {unlisted} in {package}/"
    for name in parts:
        for target in imports(name) & parts:
            if part(target) == part(name):
                continue   # inside one part (a package's own modules): its own row orders them
            assert order[part(target)] <= order[part(name)], \
                f"{name} imports {target}, which stands above it in {package}/"


def test_no_import_cycle():
    graph = {name: imports(name) & MODULES.keys() for name in MODULES}
    state: dict[str, int] = {}

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycle = path[path.index(nxt):] + [nxt] if nxt in path else [node, nxt]
                raise AssertionError(f"import cycle: {' -> '.join(cycle)}")
            if nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])


def test_the_checker_sees_every_kind_of_import(tmp_path, monkeypatch):
    """A function-level import, one under TYPE_CHECKING and a module loaded by name through
    importlib (a constant or the start of an f-string) are all found."""
    (tmp_path / "state.py").write_text(
        "import importlib\nfrom typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ._machine import Machine\n"
        "def f():\n    from ..viz import part_png\n    from ..cli import main\n"
        "def g(kind):\n    importlib.import_module(f'..studies.{kind}', __package__)\n"
        "    return importlib.import_module('volerr_pin.compensation.export._registry')\n")
    monkeypatch.setitem(MODULES, "model.state", tmp_path / "state.py")
    assert imports("model.state") == {"model._machine", "viz", "viz._plots", "cli", "studies",
                                      "compensation.export._registry"}
    table = layers()
    assert {layer_of(t, table) for t in imports("model.state")} == {1, 3, 4, 5, 6}   # all but its own above model/'s 1


def test_every_package_is_in_the_distribution():
    """An editable install finds a package missing from pyproject's list; a wheel would not ship it."""
    import tomllib

    listed = set(tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    on_disk = {".".join(("volerr_pin",) + p.parent.relative_to(PACKAGE).parts).rstrip(".")
               for p in PACKAGE.rglob("__init__.py") if "__pycache__" not in p.parts}
    assert not on_disk - listed, f"add to [tool.setuptools] packages in pyproject.toml: {sorted(on_disk - listed)}"


def test_every_bundled_machine_is_in_the_distribution():
    """The machines' folders hold data only; unlisted, the build warns and a future setuptools may
    leave them out of the wheel (the package data's glob is what ships their files)."""
    import tomllib

    root = PACKAGE.parent
    setup = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    machines = root / setup["package-dir"]["volerr_pin.machines"]
    folders = {f"volerr_pin.machines.{p.name}" for p in machines.iterdir()
               if p.is_dir() and p.name.isidentifier() and not p.name.startswith("_")}
    assert folders, f"no machine folders found in {machines}"
    missing = folders - set(setup["packages"])
    assert not missing, f"add to [tool.setuptools] packages in pyproject.toml: {sorted(missing)}"


def test_no_old_module_names_and_no_import_hook():
    """No hidden aliases before a first release: importing the package adds no finder to
    sys.meta_path, and the modules' names before the layout do not import."""
    import subprocess
    import sys

    code = ("import sys; hooks = list(sys.meta_path); import volerr_pin\n"
            "assert sys.meta_path == hooks, sys.meta_path\n"
            "for old in ('volerr_pin.machine', 'volerr_pin.compensate'):\n"
            "    try:\n"
            "        __import__(old)\n"
            "    except ModuleNotFoundError:\n"
            "        continue\n"
            "    raise SystemExit(old + ' imports')\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


LAZY_PACKAGES = [p for p in ("" if name == "__init__" else name for name in MODULES) if _lazy_parts(p)]


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_names_loaded_when_first_used_are_public(package):
    """A package that loads its names when first used still names every one of them in
    ``__all__`` and ``dir()`` (``from volerr_pin import *``, completion and the API pages read
    those), and each loads from the part the package says."""
    module = importlib.import_module("volerr_pin" + (f".{package}" if package else ""))
    for name, part in _lazy_parts(package).items():
        assert name in module.__all__ and name in dir(module), f"{module.__name__}.{name} is not public"
        where = getattr(getattr(module, name), "__module__", None) or f"volerr_pin.{part}"
        assert (where + ".").startswith(f"volerr_pin.{part}."), f"{name} comes from {where}, not {part}"


def test_the_picture_is_what_the_tables_draw():
    """docs/images/layers.svg, shown at the top of docs/layout.md, is drawn from the page's own
    tables: a layer or a part added to them and not drawn again fails here."""
    spec = importlib.util.spec_from_file_location("layers", ROOT / "docs" / "_ext" / "layers.py")
    layers_ext = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(layers_ext)
    text = LAYOUT.read_text()
    drawn = layers_ext.svg(text)
    assert (ROOT / "docs" / "images" / "layers.svg").read_text() == drawn, "draw it again: python docs/_ext/layers.py"
    assert "](images/layers.svg)" in text
    shown = set(re.findall(r'class="(?:name|part)">([^<]+)<', drawn))
    for package, parts in package_order().items():   # every part of every top package is in the picture
        if "." in package:
            continue   # a sub-package is one part of its package (name/); its own parts are in the table
        for part in parts:
            if part != "__init__":
                assert any(part in line.replace(",", " ").replace("/", " ").split() for line in shown), part


def test_the_tests_mirror_the_packages():
    """A test file sits in the folder of the package it tests (tests/fit/ for volerr_pin/fit/);
    at the top are only the tests of the project as a whole (its layout, docstrings, README and
    examples); every package has its folder."""
    packages = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}
    tests = ROOT / "tests"
    whole = {"test_layout.py", "test_docstrings.py", "test_readme.py", "test_examples.py"}
    for path in tests.rglob("test_*.py"):
        parts = path.relative_to(tests).parts
        assert (len(parts) == 1 and parts[0] in whole) or (len(parts) == 2 and parts[0] in packages), \
            f"tests/{'/'.join(parts)}: a test belongs in the folder of its package"
    assert packages <= {p.name for p in tests.iterdir() if p.is_dir() and any(p.glob("test_*.py"))}
