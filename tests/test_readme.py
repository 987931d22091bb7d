"""The README as written: every command and Python block runs, every quoted output is real.

Blocks run in README order in one scratch directory (later blocks read what earlier ones
wrote, as a reader following along would), with ``examples/`` and ``benchmarks/`` of this
checkout beside them:

- a ```sh block: each command (``&&`` chains split; the quick start's venv / pip / pytest
  steps skipped, the suite is what runs this) must exit with status 0;
- a ```python block: executed in one namespace shared by all Python blocks;
- a ```text block that starts with ``$ COMMAND``: a transcript. The command runs, and every
  quoted line (spaces collapsed; ``...`` lines skipped) must appear in its output, in order.
  A transcript may shorten a line with a trailing ``...``: then the line must start so.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\s*$", re.M | re.S)
SETUP = ("python -m venv", "pip ", ". .venv/bin/activate", "pytest")


def blocks() -> list[tuple[int, str, str]]:
    text = README.read_text()
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


def runnable() -> list:
    params = []
    for line, lang, body in blocks():
        if lang == "sh" or lang == "python" or (lang == "text" and body.startswith("$ ")):
            params.append(pytest.param(lang, body, line, id=f"README.md:{line}:{lang}"))
    return params


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    work = tmp_path_factory.mktemp("readme")
    for name in ("examples", "benchmarks"):
        (work / name).symlink_to(ROOT / name)
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["MPLBACKEND"] = "Agg"
    return {"dir": work, "env": env, "namespace": {"__name__": "readme"}}


def run(command: str, scratch: dict) -> str:
    done = subprocess.run(command, shell=True, cwd=scratch["dir"], env=scratch["env"],
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"{command!r} exited with {done.returncode}:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def test_readme_has_runnable_blocks():
    kinds = [p.values[0] for p in runnable()]
    assert kinds.count("sh") >= 8 and kinds.count("python") >= 2 and kinds.count("text") >= 3


def test_commands_parsing():
    body = "python -m venv .venv && . .venv/bin/activate && pip install -e \".[test]\" && volerr demo\n" \
           "# a comment\nvolerr rank vmc500 \\\n  --top 3\n"
    assert commands(body) == ["volerr demo", "volerr rank vmc500 --top 3"]


@pytest.mark.slow
@pytest.mark.parametrize("lang, body, line", runnable())
def test_readme_block(lang, body, line, scratch, monkeypatch):
    if lang == "sh":
        for command in commands(body):
            run(command, scratch)
    elif lang == "python":
        monkeypatch.chdir(scratch["dir"])
        exec(compile("\n" * line + body, str(README), "exec"), scratch["namespace"])  # README's line numbers
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
            assert found is not None, f"README quotes a line the command does not print: {want!r}"
            at = found + 1


def test_links_in_the_docs_resolve():
    """Every relative link of the README and docs/ names a file of the repository."""
    for page in [README, *sorted((ROOT / "docs").glob("*.md"))]:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
            if "://" in target:
                continue
            assert (page.parent / target).exists(), f"{page.name}: link to missing {target}"


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
    pytest.param(["diagnose", "vmc500", "examples/data/vmc500_tracker.csv", "--json"], marks=pytest.mark.slow),
]


@pytest.mark.parametrize("argv", REPORTS, ids=[(a.values[0] if hasattr(a, "values") else a)[0] for a in REPORTS])
def test_every_report_field_is_documented(argv, tmp_path, capsys, monkeypatch):
    import json

    from volerr_pin.cli import main

    monkeypatch.chdir(ROOT)
    assert main([a.format(tmp=tmp_path) for a in argv]) == 0
    fields = _keys(json.loads(capsys.readouterr().out), set())
    documented = set(re.findall(r"`([a-z][a-z0-9_]*)`", (ROOT / "docs" / "reports.md").read_text()))
    assert fields and not fields - documented, f"undocumented in docs/reports.md: {sorted(fields - documented)}"
