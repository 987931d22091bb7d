"""The README and the guide as written: every command and Python block runs, every quoted
output is real, every link resolves, every report field is documented, the site builds.

The pages checked (``PAGES``) are the README, the site's home page, every page of
``docs/guide/`` and the benchmarks page. Each page's blocks run in page order in a scratch
directory of the page's own (later blocks read what earlier ones wrote, as a reader following
along would; a page never relies on another, so a reader who lands on it can follow it
alone), with ``examples/`` and ``benchmarks/`` of this checkout beside them:

- a ```sh block: each command (``&&`` chains split; the quick start's venv / pip / pytest
  steps and the site build skipped: the suite is what runs this, and ``test_site_builds``
  builds the site) must exit with status 0;
- a ```python block: executed in one namespace shared by the page's Python blocks;
- a ```text block that starts with ``$ COMMAND``: a transcript. The command runs, and every
  quoted line (spaces collapsed; ``...`` lines skipped) must appear in its output, in order.
  A transcript may shorten a line with a trailing ``...``: then the line must start so.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
GUIDE = sorted(p for p in (DOCS / "guide").glob("*.md") if p.name != "index.md")   # index.md: the pages' list
PAGES = [README, DOCS / "index.md", *GUIDE, DOCS / "benchmarks.md"]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\s*$", re.M | re.S)
SETUP = ("python -m venv", "pip ", ". .venv/bin/activate", "pytest", "sphinx-build")
SKIP_DIRS = {"_build", "_generated", "gallery"}   # built by the docs build, not written


def _ext(name: str):
    """A module of ``docs/_ext`` (the docs build's own code), loaded by path."""
    spec = importlib.util.spec_from_file_location(f"_docs_ext_{name}", DOCS / "_ext" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _name(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


def blocks(page: Path = README) -> list[tuple[int, str, str]]:
    text = page.read_text()
    return [(text.count("\n", 0, m.start()) + 1, m.group(1), m.group(2)) for m in FENCE.finditer(text)]


def commands(body: str) -> list[str]:
    """Shell commands of a block: continuation lines joined, ``&&`` chains split, comments and
    the quick start's environment set-up dropped."""
    out = []
    for line in body.replace("\\\n", " ").splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        for part in line.split("&&"):
            part = part.strip()
            if part and not part.startswith(SETUP):
                out.append(" ".join(part.split()))
    return out


def _flat(line: str) -> str:
    return " ".join(line.split())


def _is_runnable(lang: str, body: str) -> bool:
    return lang == "sh" or lang == "python" or (lang == "text" and body.startswith("$ "))


def runnable(pages=None) -> list:
    params = []
    for page in pages or PAGES:
        for line, lang, body in blocks(page):
            if _is_runnable(lang, body):
                params.append(pytest.param(_name(page), lang, body, line, id=f"{_name(page)}:{line}:{lang}"))
    return params


@pytest.fixture(scope="module")
def scratches(tmp_path_factory):
    """One scratch directory and one Python namespace per page, made when first asked for."""
    made = {}

    def get(page: str) -> dict:
        if page not in made:
            work = tmp_path_factory.mktemp(Path(page).stem)
            for name in ("examples", "benchmarks", "tests"):   # tests: the diagnosis guide's test machine
                (work / name).symlink_to(ROOT / name)
            env = dict(os.environ)
            env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
            env["MPLBACKEND"] = "Agg"
            made[page] = {"dir": work, "env": env, "namespace": {"__name__": Path(page).stem}}
        return made[page]

    return get


def run(command: str, scratch: dict) -> str:
    done = subprocess.run(command, shell=True, cwd=scratch["dir"], env=scratch["env"],
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"{command!r} exited with {done.returncode}:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def test_pages_have_runnable_blocks():
    """The README keeps its quick start and Python example; the pages together keep every
    kind of block the README had before the guide was split out of it; every guide page
    has a block that runs."""
    readme = [p.values[1] for p in runnable([README])]
    assert readme.count("sh") >= 2 and readme.count("python") >= 1
    kinds = [p.values[1] for p in runnable()]
    assert kinds.count("sh") >= 18 and kinds.count("python") >= 4 and kinds.count("text") >= 13  # the README's, before
    assert len(GUIDE) >= 9
    for page in GUIDE:
        assert runnable([page]), f"{_name(page)} has no block that runs"


def test_readme_is_short():
    assert len(README.read_text().splitlines()) <= 160


def test_commands_parsing():
    body = "python -m venv .venv && . .venv/bin/activate && pip install -e \".[test]\" && volerr demo\n" \
           "# a comment\nvolerr rank vmc500 \\\n  --top 3\n" \
           "pip install -e \".[docs]\" && sphinx-build -W -b html docs docs/_build/html\n"
    assert commands(body) == ["volerr demo", "volerr rank vmc500 --top 3"]


def test_blocks_of_a_page(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# t\n\n```sh\nvolerr demo\n```\n\n```text\nnot run\n```\n\n```text\n$ volerr info vmc500\nx\n```\n")
    found = [(line, lang) for line, lang, body in blocks(page) if _is_runnable(lang, body)]
    assert found == [(3, "sh"), (11, "text")]


@pytest.mark.slow
@pytest.mark.parametrize("page, lang, body, line", runnable())
def test_page_block(page, lang, body, line, scratches, monkeypatch):
    scratch = scratches(page)
    if lang == "sh":
        for command in commands(body):
            run(command, scratch)
    elif lang == "python":
        monkeypatch.chdir(scratch["dir"])
        exec(compile("\n" * line + body, str(ROOT / page), "exec"), scratch["namespace"])  # the page's line numbers
    else:
        first, *quoted = body.splitlines()
        actual = [_flat(x) for x in run(first[2:], scratch).splitlines()]
        at = 0
        for want in quoted:
            want = _flat(want)
            if not want or want == "...":
                continue
            prefix = want.endswith("...")
            stem = want[:-3].rstrip() if prefix else want
            found = next((k for k in range(at, len(actual))
                          if (actual[k].startswith(stem) if prefix else actual[k] == stem)), None)
            assert found is not None, f"{page} quotes a line the command does not print: {want!r}"
            at = found + 1


def _doc_pages() -> list[Path]:
    return [README, *sorted(p for p in DOCS.rglob("*.md") if not SKIP_DIRS & set(p.relative_to(DOCS).parts))]


def test_links_in_the_docs_resolve():
    """Every relative link of the README and docs/ (guide included) names a file of the
    repository, or a picture the docs build draws (``docs/_ext/figures.py``)."""
    drawn = set(_ext("figures").FIGURES)
    for page in _doc_pages():
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
            if "://" in target:
                continue
            path = (page.parent / target).resolve()
            if path.parent == (DOCS / "images" / "guide").resolve():
                assert path.name in drawn, f"{_name(page)}: picture {target} is not drawn by the docs build"
            assert path.exists(), f"{_name(page)}: link to missing {target}"


def test_the_guides_pictures_are_committed_where_the_pages_link_them():
    """The guide's pictures show on the repository's web view too: each one the docs build draws
    is in the repository, at the path the pages link."""
    for name in _ext("figures").FIGURES:
        png = DOCS / "images" / "guide" / name
        assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", png


INLINE = re.compile(r"(?<!`)`([^`\n]+)`(?!`)")
#: an inline span that names the library: ``vp.diagnose(machine, [data])``, ``volerr_pin.fit.diagnosis.Diagnosis``
LIBRARY_SPAN = re.compile(r"^(vp|volerr_pin)(\.[A-Za-z_]\w*)+(\(.*\))?$")


def _inline_library_spans() -> list[tuple[str, int, str]]:
    """(page, line, span) of every inline code span of the README and docs/ that names the
    library (``vp.`` or ``volerr_pin.``), outside fenced blocks."""
    out = []
    for page in _doc_pages():
        text = FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), page.read_text())
        for m in INLINE.finditer(text):
            span = m.group(1).strip()
            if LIBRARY_SPAN.match(span):
                out.append((_name(page), text.count("\n", 0, m.start()) + 1, span))
    return out


def _resolve(dotted: str):
    """The object a dotted name of the library names, importing submodules as needed."""
    import importlib

    import volerr_pin

    parts = dotted.split(".")
    obj, path = volerr_pin, "volerr_pin"
    for part in parts[1:]:
        path = f"{path}.{part}"
        if hasattr(obj, part):
            obj = getattr(obj, part)
        else:
            obj = importlib.import_module(path)
    return obj


def test_inline_code_that_names_the_library_runs_as_written():
    """Inline code that names the library resolves: every dotted name is there, and a call
    (``vp.diagnose(machine, [data])``) calls something that takes those arguments. The guide's
    own call of the diagnosis then runs on the sample data, as a reader would type it."""
    import ast
    import inspect

    spans = _inline_library_spans()
    assert any(span.startswith("vp.diagnose(") for _, _, span in spans)
    for page, line, span in spans:
        dotted, _, call = span.partition("(")
        try:
            obj = _resolve(dotted.replace("vp.", "volerr_pin.", 1) if dotted.startswith("vp.") else dotted)
        except (AttributeError, ImportError) as err:
            raise AssertionError(f"{page}:{line}: `{span}` names nothing: {err}") from err
        if call:
            node = ast.parse(span, mode="eval").body
            assert isinstance(node, ast.Call) and callable(obj), f"{page}:{line}: `{span}` is not a call"
            try:
                inspect.signature(obj).bind(*node.args, **{k.arg: k.value for k in node.keywords})
            except TypeError as err:
                raise AssertionError(f"{page}:{line}: `{span}` does not fit {dotted}'s signature: {err}") from err


def test_the_guides_diagnosis_call_runs_as_written():
    """docs/guide/diagnose.md: ``vp.diagnose(machine, [data])``, with the machine loaded and the
    data a file of the sample data, as the page's command uses it."""
    import volerr_pin as vp

    machine = vp.load_machine("vmc500")
    data = str(ROOT / "examples" / "data" / "vmc500_tracker.csv")
    report = vp.diagnose(machine, [data])
    assert sorted(e.name for e in report.effects) == ["backlash", "thermal_drift"]


def test_every_drawn_picture_is_a_valid_command():
    """The docs build's pictures are drawn by commands the CLI accepts, each writing its PNG."""
    from volerr_pin.cli import build_parser

    parser = build_parser()
    for name, argv in _ext("figures").FIGURES.items():
        args = [a.format(png=f"/x/{name}", tmp="/x") for a in argv]
        assert f"/x/{name}" in args
        parser.parse_args(args)   # exits (SystemExit) on an option the command does not have


def test_docstring_bars_are_escaped_outside_literals():
    escape = _ext("docstrings").escape_bars
    assert escape("largest |value| / uncertainty") == r"largest \|value\| / uncertainty"
    assert escape("as ``|e|`` and |e|") == r"as ``|e|`` and \|e\|"
    assert escape("| a line block") == "| a line block"
    assert escape("+----+----+") == "+----+----+"


def test_api_reference_documents_every_public_name():
    """The API reference is the public API: a page per public package (no part of its name
    private), every name of its ``__all__`` documented on it or, where another package defines
    it, linked to that package's page, which documents it; its public subpackages listed; no
    private module gets a page."""
    pages = _ext("apipages")
    found = pages.packages()
    on_disk = {".".join(p.relative_to(ROOT).parent.parts) for p in (ROOT / "volerr_pin").rglob("__init__.py")}
    assert set(found) == {n for n in on_disk if not any(part.startswith("_") for part in n.split("."))}
    text = {package: pages.package_page(package, found) for package in found}
    documented = {package: set(re.findall(r"^\.\. auto(?:function|class|data):: ([\w.]+)$", page, re.M))
                  for package, page in text.items()}
    for package, page in text.items():
        linked = dict((f"{package}.{name}", target) for name, target
                      in re.findall(rf"^- :py:\w+:`{re.escape(package)}\.(\w+) <([\w.]+)>`", page, re.M))
        assert documented[package] | set(linked) == {f"{package}.{n}" for n in pages.public_names(package)}, package
        assert not documented[package] & set(linked), package
        for name, target in linked.items():
            owner = target.rpartition(".")[0]
            assert target in documented.get(owner, ()), f"{name} links to {target}, which no page documents"
        children = {p for p in found if p.rpartition(".")[0] == package}
        assert children <= set(re.findall(r"^- :doc:`([\w.]+)`", page, re.M)), package
        assert not re.search(r"\w\._(?!_)", page), package   # no private module named


@pytest.mark.slow
def test_site_builds(tmp_path):
    """The documentation site builds with warnings as errors (CI also runs this build)."""
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    pytest.importorskip("numpydoc")
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(tmp_path / "doctrees"), str(DOCS), str(tmp_path / "html")],
                          cwd=ROOT, capture_output=True, text=True, timeout=1800,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-5000:]
    for page in ["index.html", "guide/diagnose.html", "api/index.html", "gallery/index.html"]:
        assert (tmp_path / "html" / page).exists()
    # the gallery: every example but the sample-data writer; those that draw show their pictures
    shown = {p.stem for p in (tmp_path / "html" / "gallery").glob("*.html")} - {"index"}
    assert shown == {p.stem for p in (ROOT / "examples").glob("*.py")} - {"make_sample_data"}
    for name in ("ballbar_round_trip", "diagnose_vmc500", "lathe_cold_start", "seed001_z_axis"):
        page = (tmp_path / "html" / "gallery" / f"{name}.html").read_text()
        assert f"sphx_glr_{name}_001.png" in page, name
    real = (tmp_path / "html" / "gallery" / "thermal_real_data.html").read_text()
    assert "sphx_glr_thermal_real_data_001.png" not in real   # shown, not run: its data is not in the repository


def _keys(value, out: set) -> set:
    """Field names of a report (lower-case identifiers; data keys such as coefficient or
    sensor names are left out)."""
    if isinstance(value, dict):
        for k, v in value.items():
            if re.fullmatch(r"[a-z][a-z0-9_]*", k):
                out.add(k)
            _keys(v, out)
    elif isinstance(value, list):
        for v in value:
            _keys(v, out)
    return out


REPORTS = [
    ["info", "cgm4000", "--json"],
    ["rank", "vmc500", "--points", "64", "--top", "3", "--json"],
    ["iso230-2", "examples/data/vmc500_x_positioning.csv", "--json"],
    ["thermal-fit", "examples/data/vmc500_spindle_thermal.csv", "--target", "dz_um", "--holdout", "0.25", "--json"],
    ["identify", "vmc500", "examples/data/vmc500_tracker.csv", "examples/data/vmc500_x_positioning.csv",
     "--folds", "0", "--json"],
    ["compensate", "vmc700", "examples/data/part.nc", "-o", "{tmp}/part.nc", "--json"],
    ["errormap", "vmc500", "--elements", "2", "--points", "100", "--json"],
    ["export", "vmc500", "--controller", "linuxcnc", "-o", "{tmp}/comp", "--points", "256", "--json"],
    ["ballbar", "examples/data/vmc500_ballbar_xy.csv", "--json"],
    ["gear", "gear_roller", "--profile-points", "5", "--face-points", "3", "--json"],
    ["demo", "--grid", "3", "--out", "{tmp}/demo.rrd", "--json"],
    ["field", "cgm4000", "--grid", "3", "3", "3", "--sweep-steps", "2", "--out", "{tmp}/f.rrd", "--json"],
    ["plan", "vmc500", "--instrument", "probe", "--budget", "8", "--candidates", "64", "--json"],
    ["predict", "vmc700", "examples/data/part.nc", "--png", "{tmp}/part.png", "--json"],
    ["predict", "cgm4000", "examples/data/cgm4000_cone.nc", "--tool-diameter", "20", "--json"],
    pytest.param(["diagnose", "vmc500", "examples/data/vmc500_tracker.csv", "--json"], marks=pytest.mark.slow),
]


@pytest.mark.parametrize("argv", REPORTS, ids=[" ".join((a.values[0] if hasattr(a, "values") else a)[:2]) for a in REPORTS])
def test_every_report_field_is_documented(argv, tmp_path, capsys, monkeypatch):
    import json

    from volerr_pin.cli import main

    monkeypatch.chdir(ROOT)
    assert main([a.format(tmp=tmp_path) for a in argv]) == 0
    fields = _keys(json.loads(capsys.readouterr().out), set())
    documented = set(re.findall(r"`([a-z][a-z0-9_]*)`", (ROOT / "docs" / "reports.md").read_text()))
    assert fields and not fields - documented, f"undocumented in docs/reports.md: {sorted(fields - documented)}"


def test_the_gallery_runs_each_example_in_a_folder_of_its_own_and_shows_what_it_drew(tmp_path):
    """The gallery's command line and image scraper (docs/_ext/gallery.py), with sphinx-gallery's
    block variables: each run gets a fresh folder (a file in it for the cold start), and the
    scraper shows the PNG files written since the last block, in the order they were written."""
    pytest.importorskip("sphinx_gallery")
    gallery = _ext("gallery")
    src = str(ROOT / "examples" / "ballbar_round_trip.py")
    (folder,) = gallery.argv({}, {"src_file": src})
    assert Path(folder).name == "ballbar_round_trip" and not Path(folder).exists()
    assert Path(gallery.argv({}, {"src_file": str(ROOT / "examples" / "lathe_cold_start.py")})[0]).name \
        == "lathe_cold_start.rrd"
    targets = iter(tmp_path / f"sphx_glr_ballbar_round_trip_{k:03d}.png" for k in range(1, 9))
    block_vars = {"src_file": src, "image_path_iterator": targets}
    conf = {"src_dir": str(tmp_path)}
    assert gallery.pictures(None, block_vars, conf) == ""            # nothing written yet
    Path(folder).mkdir(parents=True)
    (Path(folder) / "b.png").write_bytes(b"first")
    os.utime(Path(folder) / "b.png", ns=(1, 1))
    (Path(folder) / "a.png").write_bytes(b"second")
    (Path(folder) / "data.csv").write_text("not a picture")
    shown = gallery.pictures(None, block_vars, conf)
    assert shown.count("image-sg::") == 2 and shown.index("_001.png") < shown.index("_002.png")
    assert (tmp_path / "sphx_glr_ballbar_round_trip_001.png").read_bytes() == b"first"   # written first
    assert (tmp_path / "sphx_glr_ballbar_round_trip_002.png").read_bytes() == b"second"
    assert gallery.pictures(None, block_vars, conf) == ""            # each shown once
    gallery.argv({}, {"src_file": src})                               # a new run starts afresh
    assert not Path(folder).exists()
