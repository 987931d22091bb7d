"""Issue 22, second adversarial pass: hostile inputs written before the fixes.

Every case is one bad, extreme or careless input that is not among the 49 the issue lists.
They are of the issue's five kinds: outputs that collide with inputs or cannot be written
(``loss-``), files a URDF or spec must not reach (``reach-``), requests too large for the
machine (``size-``), NC programs read wrongly (``nc-``) and values accepted without sense
(``value-``); ``lib-`` cases call the library directly.

One oracle holds for every command-line case, whatever wording the messages have:

* no traceback, no crash (a signal, exit >= 128), no hang (a timeout) and no memory beyond a
  cap (the dangerous cases run as subprocesses under ``RLIMIT_AS``);
* exit 0 or 2; on 2, stderr holds one ``volerr: error:`` line (notes aside; argparse's usage
  and ``volerr <cmd>: error:`` line for argparse-level type errors) naming the culprit the case
  expects (a file, ``file:line``, an option or a key);
* no file present before the run changes, and on exit 2 nothing is created or changed (no
  output, no temporary file) in the case's folder; on exit 0 only the outputs the run asked
  for (and numbered backups of replaced specs) appear;
* what a case expects on exit 0: ``ERROR`` cases must not succeed (the input makes no sense),
  ``NOTE`` cases may succeed only with a ``volerr: note:`` line (or a compensation ``warning:``)
  naming the culprit, ``ANY`` cases may succeed, ``OK`` cases must succeed; a ``result`` check
  says what the right result is.

The file was run against the code as it was before any fix of issue 22. To run it against
another copy of the package, put that copy first on the path, e.g.
``PYTHONPATH=<copy> python -P -m pytest tests/cli/test_hostile.py -m "slow or not slow"``
(``-P``: without it ``python -m`` puts the current folder, this checkout, first).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import resource
import shlex
import signal
import stat
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.applications import dh, iso230
from volerr_pin.compensation import _errormap as errormap, compensate_points
from volerr_pin import measurements, model as workspace
from volerr_pin.cli import main
from volerr_pin.model import machines_dir

from conftest import needs_device

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "data"
#: the folder that holds the package under test: subprocesses import the same copy
PACKAGE_HOME = Path(vp.__file__).resolve().parents[1]

ERROR, NOTE, ANY, OK = "error", "note", "any", "ok"

#: caps of the subprocess cases
MEMORY_CAP = 4 << 30
FILE_SIZE_CAP = 2 << 30
TIMEOUT = 60
FIFO_TIMEOUT = 30
#: files larger than this are compared by size and time, not by content
HASH_LIMIT = 64 << 20

MARKER = b"OUTSIDE_THE_URDF_FOLDER_7f3a"


# ----------------------------------------------------------------------------- files


def example(name: str) -> bytes:
    return (EXAMPLES / name).read_bytes()


def machine_files(name: str, dest: str, edit: Callable[[str], str] | None = None) -> dict:
    """A copy of a bundled machine in the folder ``dest``, its spec passed through ``edit``
    (made when the case runs, so that an edit that no longer applies fails that case only)."""
    def make(folder_path, folder):
        folder_path.mkdir(parents=True, exist_ok=True)
        for path in sorted((machines_dir() / name).iterdir()):
            if path.is_file():
                data = path.read_bytes()
                if path.name == "errors.toml" and edit is not None:
                    text = edit(data.decode("utf-8"))
                    assert text != data.decode("utf-8"), f"the edit of {name}'s spec changed nothing"
                    data = text.encode("utf-8")
                (folder_path / path.name).write_bytes(data)
    return {dest: make}


def replace(old: str, new: str) -> Callable[[str], str]:
    return lambda text: text.replace(old, new, 1)


def append(extra: str) -> Callable[[str], str]:
    return lambda text: text + "\n" + extra + "\n"


def eyx_terms(extra: str) -> Callable[[str], str]:
    """vmc500's EYX as a term list with one more term."""
    old = '[errors.EYX]            # straightness in y\nkind = "legendre"\ncoefficients_um = [0.0, 0.0, 1.5, -0.4]'
    new = ('[errors.EYX]\nterms = [{ kind = "legendre", coefficients_um = [0.0, 0.0, 1.5, -0.4] }, '
           + extra + "]")
    return replace(old, new)


def symlink(target: str):
    def make(path, folder):
        path.symlink_to(target)

    make.device = target if target.startswith("/dev/") else None
    return make


def hardlink(target: str):
    return lambda path, folder: os.link(folder / target, path)


def fifo():
    return lambda path, folder: os.mkfifo(path)


def sparse(size: int):
    def make(path, folder):
        with open(path, "wb") as fh:
            fh.truncate(size)
    return make


def directory():
    return lambda path, folder: path.mkdir(parents=True, exist_ok=True)


def make_files(folder: Path, files: dict) -> None:
    for name, content in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if callable(content):
            content(path, folder)
        elif isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8", newline="")


def snapshot(folder: Path) -> dict[str, tuple]:
    """Every entry under ``folder``: kind and content hash (links: their target)."""
    state = {}
    for top, dirs, names in os.walk(folder, followlinks=False):
        for name in dirs + names:
            path = Path(top) / name
            rel = path.relative_to(folder).as_posix()
            st = path.lstat()
            if stat.S_ISLNK(st.st_mode):
                state[rel] = ("link", os.readlink(path))
            elif stat.S_ISDIR(st.st_mode):
                state[rel] = ("dir",)
            elif stat.S_ISREG(st.st_mode):
                if st.st_size > HASH_LIMIT:
                    state[rel] = ("big", st.st_size, st.st_mtime_ns)
                else:
                    state[rel] = ("file", hashlib.sha256(path.read_bytes()).hexdigest())
            else:
                state[rel] = ("special", stat.S_IFMT(st.st_mode))
    return state


def is_backup(rel: str) -> bool:
    return ".bak" in Path(rel).name


# ----------------------------------------------------------------------------- cases


@dataclass(frozen=True)
class Case:
    """One hostile command line.

    ``argv`` is split like a shell line and run in the case's folder, where ``files`` are
    made first (text, bytes, or a callable ``(path, folder)`` for links, FIFOs, sparse
    files). ``culprit``: on exit 2 the error line names one of these (case-insensitive).
    ``outputs``: the files a successful run may create or replace. ``result``: a check of a
    successful run, ``(folder, stdout, stderr) -> None``.
    """

    id: str
    argv: str
    files: dict = field(default_factory=dict)
    culprit: tuple = ()
    expect: str = ERROR
    outputs: tuple = ()
    result: Callable | None = None
    timeout: float = TIMEOUT

    def param(self, *marks):
        return pytest.param(self, id=self.id, marks=marks)


def judge(case: Case, folder: Path, code, out: str, err: str, before: dict, after: dict) -> None:
    """The oracle (module docstring); fails with one line saying what went wrong."""
    if code == "timeout":
        pytest.fail(f"hang: no answer within {case.timeout:g} s")
    if "Traceback (most recent call last)" in err:
        pytest.fail("traceback: " + err.strip().splitlines()[-1][:300])
    if not isinstance(code, int) or code < 0 or code >= 128:
        pytest.fail(f"crash: exit status {code} ({err.strip()[-200:]!r})")
    if code not in (0, 2):
        pytest.fail(f"exit status {code}: {err.strip()[-300:]!r}")
    changed = sorted(p for p in before if after.get(p) != before[p])
    created = sorted(set(after) - set(before))
    if code == 2:
        if changed or created:
            pytest.fail(f"data loss: the refused run changed {changed} and created {created}")
        lines = err.strip().splitlines()
        if "usage:" in err and lines and re.match(r"volerr [\w-]+: error: ", lines[-1]):
            line = lines[-1]
        else:
            errors = [ln for ln in lines if ln.startswith("volerr: error:")]
            others = [ln for ln in lines if not ln.startswith(("volerr: error:", "volerr: note:"))]
            if len(errors) != 1 or others:
                pytest.fail(f"not one clean error line: {err.strip()[-400:]!r}")
            line = errors[0]
        if case.culprit and not any(c.lower() in line.lower() for c in case.culprit):
            pytest.fail(f"the error does not name {' or '.join(case.culprit)}: {line[:300]!r}")
        if case.expect == OK:
            pytest.fail(f"refused a valid input: {line[:300]!r}")
        return
    touched = [p for p in changed if p not in case.outputs]
    if touched:
        pytest.fail(f"data loss: an input changed: {touched}")
    if case.expect == ERROR:  # what it wrote is the outputs of a run that should not have run
        pytest.fail("silent: exit 0 where the input makes no sense (expected exit 2 naming "
                    f"{' or '.join(case.culprit)})")
    stray = [p for p in created if p not in case.outputs and not is_backup(p)]
    if stray:
        pytest.fail(f"stray files: {stray}")
    if case.expect == NOTE:
        notes = [ln for ln in err.splitlines() if ln.startswith("volerr: note:")]
        notes += [ln for ln in out.splitlines() if ln.startswith("warning:")]
        if not any(c.lower() in ln.lower() for ln in notes for c in case.culprit):
            pytest.fail(f"silent: exit 0 without a note naming {' or '.join(case.culprit)}")
    if case.result is not None:
        case.result(folder, out, err)


def run_in_process(case: Case, folder: Path, capfd, monkeypatch):
    make_files(folder, case.files)
    before = snapshot(folder)
    monkeypatch.chdir(folder)
    capfd.readouterr()
    try:
        code = main(shlex.split(case.argv))
    except SystemExit as exit:
        code = exit.code if isinstance(exit.code, int) else (0 if exit.code is None else 1)
    except Exception as exc:  # an uncaught exception is a traceback for the user
        capfd.readouterr()
        pytest.fail(f"traceback: {type(exc).__name__}: {str(exc)[:300]}")
    captured = capfd.readouterr()
    return code, captured.out, captured.err, before, snapshot(folder)


def _limits():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_SIZE_CAP, FILE_SIZE_CAP))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def run_subprocess(case: Case, folder: Path):
    make_files(folder, case.files)
    before = snapshot(folder)
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1",
               NUMBA_NUM_THREADS="1")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(PACKAGE_HOME), os.environ.get("PYTHONPATH")) if p)
    proc = subprocess.Popen([sys.executable, "-m", "volerr_pin.cli", *shlex.split(case.argv)], cwd=folder,
                            env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, errors="replace", preexec_fn=_limits, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=case.timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        code = "timeout"
    if isinstance(code, int) and code < 0:
        code = 128 - code  # killed by a signal
    return code, out, err, before, snapshot(folder)


# ----------------------------------------------------------------------------- result checks


def output_has_crlf(name: str):
    def check(folder, out, err):
        data = (folder / name).read_bytes()
        assert data.count(b"\n") >= 3 and data.count(b"\n") == data.count(b"\r\n"), \
            f"wrong result: {name} lost the program's CR LF line endings"
    return check


def kept_unchanged(name: str, first: int, last: int, source: str = "prog.nc"):
    """Lines ``first``..``last`` (1-based) of the output are those of the program byte for byte,
    and the warnings name every one of them (the moves under a mode that changes how
    coordinates read are kept, never compensated as if untransformed)."""
    def check(folder, out, err):
        written = (folder / name).read_bytes().split(b"\n")
        given = (folder / source).read_bytes().split(b"\n")
        assert written[first - 1:last] == given[first - 1:last], \
            f"wrong result: lines {first}-{last} of {name} were changed"
        named = set()
        for a, b in re.findall(r"^warning: lines? (\d+)(?:-(\d+))?:", out, re.MULTILINE):
            named.update(range(int(a), int(b or a) + 1))
        missing = sorted(set(range(first, last + 1)) - named)
        assert not missing, f"wrong result: lines {missing} kept without a warning naming them"
    return check


def compensated_near(name: str, line: int, word: str, value: float):
    """Line ``line`` of the output was compensated: ``word`` changed, by less than 0.05 mm."""
    def check(folder, out, err):
        text = (folder / name).read_text().splitlines()[line - 1]
        found = re.search(rf"{word}(-?[0-9.]+)", text)
        assert found and float(found.group(1)) != value and abs(float(found.group(1)) - value) < 0.05, \
            f"wrong result: line {line} of {name} is {text!r}, not {word}{value:g} compensated"
    return check


def output_is_ascii(name: str):
    def check(folder, out, err):
        assert (folder / name).read_bytes().isascii(), f"wrong result: {name} is not plain ASCII"
    return check


def output_equals(name: str, data: bytes):
    def check(folder, out, err):
        assert (folder / name).read_bytes() == data, f"wrong result: {name} differs"
    return check


def urdf_loads(name: str, tool: str, base: str):
    def check(folder, out, err):
        try:
            vp.load_machine(folder / name, tool_frame=tool, workpiece_frame=base)
        except vp.VolerrError as exc:
            pytest.fail(f"silent: exit 0 but the URDF it wrote does not load: {str(exc)[:200]}")
    return check


def recording_without_marker(name: str):
    def check(folder, out, err):
        data = (folder / name).read_bytes() if (folder / name).exists() else b""
        assert MARKER not in data, f"reached: the file outside the URDF's folder is inside {name}"
    return check


def not_in_stdout(marker: bytes):
    def check(folder, out, err):
        assert marker.decode() not in out, "reached: the file outside the URDF's folder is in the output"
    return check


def spec_backed_up(name: str, old: bytes):
    def check(folder, out, err):
        target = folder / name
        backups = [p for p in target.parent.iterdir() if p.name != target.name and ".bak" in p.name]
        assert any(p.read_bytes() == old for p in backups), \
            f"data loss: {name} was replaced and no backup holds the old spec"
    return check


def json_close(key: str, reference: float):
    def check(folder, out, err):
        value = json.loads(out)[key]
        assert value == pytest.approx(reference, rel=1e-9), f"wrong result: {key} = {value}, expected {reference}"
    return check


def json_is(key: str, reference):
    def check(folder, out, err):
        value = json.loads(out)[key]
        assert value == reference, f"wrong result: {key} = {value!r}, expected {reference!r}"
    return check


# ----------------------------------------------------------------------------- shared inputs

NC_START = "G21 G90 G17\nG0 X100 Y100 Z100\n"


def program(body: str, name: str = "prog.nc") -> dict:
    """An NC program for vmc700 whose third line on is ``body``."""
    return {name: NC_START + body}


RUNS = example("vmc500_x_positioning.csv")
CIRCLE = example("vmc500_ballbar_xy.csv").decode()
SERIES = example("vmc500_spindle_thermal.csv").decode()
POINTS40 = "".join(example("vmc500_tracker.csv").decode().splitlines(keepends=True)[:41])
PART = example("part.nc")
#: a program of one short move, for the cases about anything but the moves
SHORT = "G21 G90 G17\nG0 X100 Y100 Z100\nG1 X110 F500\nM30\n"

DH = ("# convention: standard\n# tool: 0, 0, 100\njoint,type,a_mm,alpha_deg,d_mm,theta_deg,lower,upper\n"
      "J1,revolute,312,-90,0,0,-180,180\nJ2,revolute,1075,0,0,-90,-60,76\n")


def slide_urdf(mesh: str | None = None) -> str:
    """A one-axis machine whose base carries ``mesh`` (or a box)."""
    geometry = f'<mesh filename="{mesh}"/>' if mesh is not None else '<box size="0.2 0.2 0.1"/>'
    return f"""<?xml version="1.0"?>
<robot name="slide">
  <link name="base"><visual><geometry>{geometry}</geometry></visual></link>
  <link name="carriage"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>
  <link name="tool"/>
  <joint name="x" type="prismatic">
    <parent link="base"/><child link="carriage"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <joint name="t" type="fixed"><parent link="carriage"/><child link="tool"/><origin xyz="0 0 0.1"/></joint>
</robot>
"""


SECRET_STL = (b"solid " + MARKER + b"\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
              b"vertex 0 1 0\nendloop\nendfacet\nendsolid " + MARKER + b"\n")
SLIDE = "--tool-frame tool --workpiece-frame base"
FIELD = f"{SLIDE} --grid 2 --sweep-steps 0"


def mesh_case(id, mesh, culprit, extra_files=None, command="field robot/slide.urdf {frames} --out f.rrd"):
    """A URDF in ``robot/`` whose mesh points at ``mesh``; a file outside its folder,
    ``secret/stolen.stl``, holds a marker that must not reach the recording."""
    files = {"secret/stolen.stl": SECRET_STL, "robot/slide.urdf": slide_urdf(mesh)}
    files.update(extra_files or {})
    out = "f.rrd" if "f.rrd" in command else "d.rrd"
    return Case(id, command.format(frames=FIELD if command.startswith("field") else SLIDE), files, culprit, NOTE,
                outputs=(out,), result=recording_without_marker(out))


def deep_toml(depth: int) -> Callable[[str], str]:
    return append("[machine_extra]\nnested = " + "[" * depth + "]" * depth)


# ----------------------------------------------------------------------------- the cases

CASES = [
    # --- outputs that collide with inputs, or cannot be written -----------------------------
    Case("loss-compensate-report-is-the-program", "compensate vmc700 part.nc -o out.nc --report part.nc",
         {"part.nc": SHORT}, ("--report", "part.nc")),
    Case("loss-compensate-output-symlink-to-the-program", "compensate vmc700 part.nc -o link.nc",
         {"part.nc": SHORT, "link.nc": symlink("part.nc")}, ("--out", "link.nc")),
    Case("loss-compensate-output-hardlink-to-the-program", "compensate vmc700 part.nc -o hard.nc",
         {"part.nc": SHORT, "hard.nc": hardlink("part.nc")}, ("--out", "hard.nc"), outputs=("hard.nc",)),
    Case("loss-compensate-report-equals-output", "compensate vmc700 part.nc -o out.nc --report out.nc",
         {"part.nc": SHORT}, ("--report", "out.nc")),
    Case("loss-compensate-report-equals-output-through-dotdot",
         "compensate vmc700 part.nc -o out.nc --report sub/../out.nc",
         {"part.nc": SHORT, "sub": directory()}, ("--report", "out.nc")),
    Case("loss-compensate-png-equals-output", "compensate vmc700 part.nc -o out.png --png out.png",
         {"part.nc": SHORT}, ("--png", "out.png")),
    Case("loss-compensate-report-on-a-full-device", "compensate vmc700 part.nc -o out.nc --report full.json",
         {"part.nc": SHORT, "full.json": symlink("/dev/full")}, ("--report", "full.json")),
    Case("loss-compensate-output-is-a-folder", "compensate vmc700 part.nc -o outdir",
         {"part.nc": SHORT, "outdir": directory()}, ("--out", "outdir")),
    Case("loss-compensate-report-symlink-to-null-device", "compensate vmc700 part.nc -o out.nc --report null.json",
         {"part.nc": SHORT, "null.json": symlink("/dev/null")}, ("--report", "null.json"), ANY,
         outputs=("out.nc", "null.json")),
    Case("loss-identify-out-is-the-data", "identify vmc500 runs.csv --folds 0 --out runs.csv",
         {"runs.csv": RUNS}, ("--out", "runs.csv")),
    Case("loss-identify-out-symlink-to-the-spec", "identify m runs.csv --folds 0 --out spec.toml",
         {**machine_files("vmc500", "m"), "runs.csv": RUNS, "spec.toml": symlink("m/errors.toml")},
         ("--out", "spec.toml")),
    Case("loss-identify-out-replaces-another-spec-without-backup",
         "identify vmc500 runs.csv --folds 0 --out other/errors.toml",
         {"runs.csv": RUNS, **machine_files("vmc700", "other")}, ("--out", "--force", "errors.toml"), ANY,
         outputs=("other/errors.toml",),
         result=spec_backed_up("other/errors.toml", (machines_dir() / "vmc700" / "errors.toml").read_bytes())),
    Case("loss-diagnose-out-is-the-data", "diagnose vmc500 pts.csv --max-effects 1 --folds 2 --out pts.csv",
         {"pts.csv": POINTS40}, ("--out", "pts.csv")),
    Case("loss-diagnose-png-equals-rrd",
         "diagnose vmc500 pts.csv --max-effects 1 --folds 2 --rrd d.rrd --png d.rrd",
         {"pts.csv": POINTS40}, ("--png", "--rrd", "d.rrd")),
    Case("loss-diagnose-out-written-before-rrd-fails",
         "diagnose vmc500 pts.csv --max-effects 1 --folds 2 --out new.toml --rrd nofolder/d.rrd",
         {"pts.csv": POINTS40}, ("--rrd", "nofolder")),
    Case("loss-errormap-table-is-the-spec",
         "errormap m --points 10 --order 1 --elements 1 --table m/errors.toml --nodes 2",
         machine_files("vmc500", "m"), ("--table", "errors.toml")),
    Case("loss-errormap-table-written-before-axis-tables-fail",
         "errormap vmc500 --points 10 --order 1 --elements 1 --table t.csv --nodes 2 --axis-tables taken.txt",
         {"taken.txt": "a file, not a folder\n"}, ("--axis-tables", "taken.txt")),
    Case("loss-iso230-plot-is-the-runs", "iso230-2 runs.csv --png runs.csv", {"runs.csv": RUNS},
         ("--png", "runs.csv")),
    Case("loss-iso230-plot-unknown-picture-format", "iso230-2 runs.csv --png plot.txt", {"runs.csv": RUNS},
         ("--png", "plot.txt")),
    Case("loss-ballbar-plot-hardlink-to-the-data", "ballbar circle.csv --png circle.png",
         {"circle.csv": CIRCLE, "circle.png": hardlink("circle.csv")}, ("--png", "circle.png"),
         outputs=("circle.png",)),
    Case("loss-ballbar-plot-on-a-full-device", "ballbar circle.csv --png full.png",
         {"circle.csv": CIRCLE, "full.png": symlink("/dev/full")}, ("--png", "full.png")),
    Case("loss-thermal-fit-plot-symlink-to-the-test-file",
         "thermal-fit a.csv --target dz_um --test b.csv --png plot.png",
         {"a.csv": SERIES, "b.csv": SERIES.replace("0.306", "0.307"), "plot.png": symlink("b.csv")},
         ("--png", "plot.png")),
    Case("loss-rank-png-is-the-tolerances", "rank vmc500 --points 16 --tolerances tol.toml --png tol.toml",
         {"tol.toml": example("vmc500_tolerances.toml")}, ("--png", "tol.toml")),
    Case("loss-field-out-is-the-urdf", f"field robot/slide.urdf {FIELD} --out robot/slide.urdf",
         {"robot/slide.urdf": slide_urdf()}, ("--out", "slide.urdf")),
    Case("loss-demo-out-is-the-spec", "demo --machine m --grid 2 --out m/errors.toml",
         machine_files("vmc500", "m"), ("--out", "errors.toml")),
    Case("loss-urdf-output-is-the-spec", "urdf m -o m/errors.toml", machine_files("vmc500", "m"),
         ("--out", "errors.toml")),
    Case("loss-dh-output-hardlink-to-the-table", "dh robot.csv -o robot.urdf",
         {"robot.csv": DH, "robot.urdf": hardlink("robot.csv")}, ("--out", "robot.urdf"),
         outputs=("robot.urdf",)),
    Case("loss-gear-rrd-equals-png",
         "gear gear_roller --tooth 1 --profile-points 5 --face-points 3 --png g.png --rrd g.png", {},
         ("--rrd", "--png", "g.png")),
    Case("loss-gear-png-written-before-rrd-fails",
         "gear gear_roller --tooth 1 --profile-points 5 --face-points 3 --png g.png --rrd nofolder/g.rrd", {},
         ("--rrd", "nofolder")),

    # --- files a URDF or a spec must not reach -------------------------------------------------
    mesh_case("reach-field-mesh-file-uri-outside", "file://{abs}/secret/stolen.stl", ("stolen.stl",)),
    mesh_case("reach-field-mesh-absolute-path-outside", "{abs}/secret/stolen.stl", ("stolen.stl",)),
    mesh_case("reach-field-mesh-symlink-escaping-the-folder", "meshes/escape.stl", ("escape.stl",),
              {"robot/meshes/escape.stl": symlink("../../secret/stolen.stl")}),
    mesh_case("reach-field-mesh-package-uri-without-a-root", "package://nopkg/meshes/a.stl",
              ("package://nopkg", "a.stl")),
    mesh_case("reach-field-mesh-is-a-folder", "meshes", ("meshes",), {"robot/meshes": directory()}),
    mesh_case("reach-field-mesh-empty-filename", "", ("mesh",)),
    mesh_case("reach-field-mesh-missing", "meshes/missing.stl", ("missing.stl",)),
    mesh_case("reach-demo-mesh-absolute-path-outside", "{abs}/secret/stolen.stl", ("stolen.stl",),
              command="demo --machine robot/slide.urdf {frames} --grid 2 --out d.rrd"),
    Case("reach-info-urdf-external-entity", f"info robot/xxe.urdf {SLIDE} --json",
         {"secret/stolen.stl": SECRET_STL,
          "robot/xxe.urdf": slide_urdf().replace(
              '<?xml version="1.0"?>',
              '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY sec SYSTEM "../secret/stolen.stl">]>')
          .replace('joint name="x"', 'joint name="x&sec;"')},
         ("xxe.urdf",), ANY, result=not_in_stdout(MARKER)),
    Case("reach-info-urdf-entity-expansion-bomb", f"info robot/lol.urdf {SLIDE}",
         {"robot/lol.urdf": slide_urdf().replace(
             '<?xml version="1.0"?>',
             '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa">'
             + "".join(f'<!ENTITY {chr(98 + i)} "' + f"&{chr(97 + i)};" * 10 + '">' for i in range(9)) + "]>")
          .replace('<robot name="slide">', '<robot name="slide&j;">')},
         ("lol.urdf",)),
    Case("reach-info-urdf-100000-deep", f"info robot/deep.urdf {SLIDE}",
         {"robot/deep.urdf": slide_urdf().replace('<link name="tool"/>',
                                                   '<link name="tool">' + "<a>" * 100_000 + "</a>" * 100_000
                                                   + "</link>")},
         ("deep.urdf",)),
    Case("reach-info-spec-urdf-is-the-spec-itself", "info m",
         machine_files("vmc500", "m", replace('urdf = "vmc500.urdf"', 'urdf = "errors.toml"')),
         ("errors.toml",)),
    Case("reach-info-spec-urdf-is-a-folder", "info m",
         machine_files("vmc500", "m", replace('urdf = "vmc500.urdf"', 'urdf = "."')), ("urdf",)),

    # --- sizes (in process: the ones that fail fast or read small files) -------------------------
    Case("size-info-spec-nested-100000-deep", "info m", machine_files("vmc500", "m", deep_toml(100_000)),
         ("errors.toml",)),
    Case("size-thermal-fit-lag-beyond-the-data", "thermal-fit s.csv --target dz_um --lag 1000000",
         {"s.csv": SERIES}, ("--lag",)),

    # --- NC programs ------------------------------------------------------------------------------
    Case("nc-plane-conflict-g17-g18-in-one-block", "compensate vmc700 prog.nc -o out.nc",
         program("G17 G18 G2 X200 Y100 I50 J0\n"), ("prog.nc:3",)),
    Case("nc-distance-mode-conflict-g90-g91", "compensate vmc700 prog.nc -o out.nc",
         program("G90 G91 G1 X200\n"), ("prog.nc:3",)),
    Case("nc-unit-conflict-g20-g21", "compensate vmc700 prog.nc -o out.nc", program("G20 G21 G1 X200\n"),
         ("prog.nc:3",)),
    Case("nc-motion-and-dwell-without-p-in-one-block", "compensate vmc700 prog.nc -o out.nc",
         program("G1 X200 G4\n"), ("prog.nc:3",)),
    Case("nc-dwell-then-move-in-one-block", "compensate vmc700 prog.nc -o out.nc",   # as LinuxCNC reads it
         program("G4 P1 G1 X200\n"), expect=OK, outputs=("out.nc",)),
    Case("nc-arc-and-dwell-in-one-block", "compensate vmc700 prog.nc -o out.nc",
         program("G4 P1 G2 X200 Y100 R60\n"), ("prog.nc:3",)),
    Case("nc-axis-word-the-machine-does-not-have", "compensate vmc700 prog.nc -o out.nc",
         program("G1 X200 A10\n"), ("prog.nc:3", "A10"), NOTE, outputs=("out.nc",)),
    Case("nc-coordinate-of-400-digits", "compensate vmc700 prog.nc -o out.nc",
         program("G1 X1" + "0" * 400 + "\n"), ("prog.nc:3",)),
    Case("nc-g18-arc-with-a-j-word-outside-its-plane", "compensate vmc700 prog.nc -o out.nc",
         program("G18 G2 X200 Z100 I50 J7\n"), ("prog.nc:3", "J7"), NOTE, outputs=("out.nc",)),
    Case("nc-zero-radius-full-circle", "compensate vmc700 prog.nc -o out.nc",
         program("G1 X100 Y100\nG2 X100 Y100 I0 J0\n"), ("prog.nc:4",)),
    # a mode that changes how later coordinates read: it and every block up to its end are kept
    # byte for byte and named (never compensated as if untransformed); the move after the end is
    # compensated
    Case("nc-tilted-plane-g68.2", "compensate vmc700 prog.nc -o out.nc",
         program("G68.2 X0 Y0 Z0 I0 J45 K0\nG1 X200\nG69\nG1 X150\n"), ("G68.2",), NOTE, outputs=("out.nc",),
         result=kept_unchanged("out.nc", 3, 5)),
    Case("nc-tool-centre-point-g43.4", "compensate vmc700 prog.nc -o out.nc",
         program("G43.4 H1\nG1 X200\n"), ("G43.4",), NOTE, outputs=("out.nc",),
         result=compensated_near("out.nc", 4, "X", 200)),
    Case("nc-mirror-image-g51.1", "compensate vmc700 prog.nc -o out.nc",
         program("G51.1 X150\nG1 X200\nG1 Y120\n"), ("G51.1",), NOTE, outputs=("out.nc",),
         result=kept_unchanged("out.nc", 3, 5)),
    Case("nc-polar-coordinates-g16", "compensate vmc700 prog.nc -o out.nc", program("G16\nG1 X200 Y45\n"),
         ("G16",), NOTE, outputs=("out.nc",), result=kept_unchanged("out.nc", 3, 4)),
    Case("nc-polar-interpolation-g12.1", "compensate vmc700 prog.nc -o out.nc", program("G12.1\nG1 X200\n"),
         ("G12.1",), NOTE, outputs=("out.nc",), result=kept_unchanged("out.nc", 3, 4)),
    Case("nc-local-coordinates-g52-until-cancelled", "compensate vmc700 prog.nc -o out.nc",
         program("G52 X10 Y5\nG1 X200\nG52 X0\nG1 X150\nG52 Y0\nG1 X120\n"), ("G52",), NOTE,
         outputs=("out.nc",), result=kept_unchanged("out.nc", 3, 7)),
    Case("nc-g-code-of-22-digits", "compensate vmc700 prog.nc -o out.nc",
         program("G1000000000000000000000 X200\n"), ("prog.nc:3:1",)),
    Case("nc-unknown-g-code", "compensate vmc700 prog.nc -o out.nc", program("G5.7 Q1\nG1 X200\n"),
         ("prog.nc:3:1",)),
    Case("nc-radius-word-on-a-line", "compensate vmc700 prog.nc -o out.nc", program("G1 X200 R5\n"),
         ("prog.nc:3", "R5"), NOTE, outputs=("out.nc",)),
    Case("nc-negative-feed", "compensate vmc700 prog.nc -o out.nc", program("G1 X200 F-100\n"),
         ("prog.nc:3", "F-100"), NOTE, outputs=("out.nc",)),
    Case("nc-two-sequence-numbers", "compensate vmc700 prog.nc -o out.nc", program("N10 N20 G1 X200\n"),
         ("prog.nc:3",)),
    Case("nc-crlf-line-endings-kept", "compensate vmc700 prog.nc -o out.nc",
         {"prog.nc": "G21 G90 G17\r\nG0 X100 Y100 Z100\r\nG1 X200 Y150\r\nM30\r\n"}, ("prog.nc",), OK,
         outputs=("out.nc",), result=output_has_crlf("out.nc")),
    Case("nc-byte-order-mark", "compensate vmc700 prog.nc -o out.nc",
         {"prog.nc": "\ufeff" + NC_START + "G1 X200\n"}, ("prog.nc",), ANY, outputs=("out.nc",)),
    Case("nc-unicode-minus-sign", "compensate vmc700 prog.nc -o out.nc", program("G1 X\u2212100\n"),
         ("prog.nc:3",)),
    Case("nc-full-width-digits", "compensate vmc700 prog.nc -o out.nc", program("G1 X\uff12\uff10\uff10\n"),
         ("prog.nc:3",), ANY, outputs=("out.nc",), result=output_is_ascii("out.nc")),
    Case("nc-zero-width-space-in-a-number", "compensate vmc700 prog.nc -o out.nc", program("G1 X2\u200b00\n"),
         ("prog.nc:3",)),
    Case("nc-nul-byte", "compensate vmc700 prog.nc -o out.nc", program("G1 X200\x00\n"), ("prog.nc:3",)),
    Case("nc-utf16-program", "compensate vmc700 prog.nc -o out.nc",
         {"prog.nc": (NC_START + "G1 X200\n").encode("utf-16")}, ("prog.nc",)),
    Case("nc-empty-program", "compensate vmc700 prog.nc -o out.nc", {"prog.nc": ""}, ("prog.nc",), ANY,
         outputs=("out.nc",), result=output_equals("out.nc", b"")),
    Case("nc-two-decimal-points", "compensate vmc700 prog.nc -o out.nc", program("G1 X1.2.3\n"),
         ("prog.nc:3",)),
    Case("nc-two-signs", "compensate vmc700 prog.nc -o out.nc", program("G1 X--5\n"), ("prog.nc:3",)),
    Case("nc-address-without-a-number", "compensate vmc700 prog.nc -o out.nc", program("G1 X200 Y\n"),
         ("prog.nc:3",)),
    Case("nc-fractional-arc-turns", "compensate vmc700 prog.nc -o out.nc",
         program("G1 X100 Y100\nG2 X150 Y100 I25 J0 P1.5\n"), ("prog.nc:4",)),
    Case("nc-unclosed-comment", "compensate vmc700 prog.nc -o out.nc", program("G1 X200 (to the left\n"),
         ("prog.nc:3",)),
    Case("nc-incremental-before-any-position", "compensate vmc700 prog.nc -o out.nc",
         {"prog.nc": "G21 G91 G17\nG1 X10\n"}, ("prog.nc:2",)),
    Case("nc-origin-infinite", "compensate vmc700 part.nc -o out.nc --origin X=inf", {"part.nc": SHORT},
         ("origin",)),
    Case("nc-origin-unknown-axis", "compensate vmc700 part.nc -o out.nc --origin Q=1", {"part.nc": SHORT},
         ("--origin",)),
    # dialects and work offsets (issue 62)
    Case("nc-work-offsets-with-origin", "compensate vmc700 part.nc -o out.nc --origin X=1 --work-offsets o.csv",
         {"part.nc": SHORT, "o.csv": "offset,X_mm,Y_mm,Z_mm\nG54,1,2,3\n"}, ("--origin", "--work-offsets")),
    Case("nc-work-offsets-var-without-unit", "compensate vmc700 part.nc -o out.nc --work-offsets linuxcnc.var",
         {"part.nc": SHORT, "linuxcnc.var": "5221 1.0\n5222 2.0\n5223 3.0\n"}, ("--work-offsets-unit",)),
    Case("nc-work-offsets-unit-alone", "compensate vmc700 part.nc -o out.nc --work-offsets-unit mm",
         {"part.nc": SHORT}, ("--work-offsets-unit",)),
    Case("nc-work-offsets-bad-column", "compensate vmc700 part.nc -o out.nc --work-offsets o.csv",
         {"part.nc": SHORT, "o.csv": "offset,X_mm,Q_mm,Z_mm\nG54,1,2,3\n"}, ("o.csv:1:3",)),
    Case("nc-work-offsets-written-over", "compensate vmc700 part.nc -o o.nc --work-offsets o.nc",
         {"part.nc": SHORT, "o.nc": "offset,X_mm,Y_mm,Z_mm\nG54,1,2,3\n"}, ("o.nc",)),
    Case("nc-work-offsets-missing-file", "compensate vmc700 part.nc -o out.nc --work-offsets none.csv",
         {"part.nc": SHORT}, ("none.csv",)),
    Case("nc-second-set-up-unknown", "compensate vmc700 part.nc -o out.nc",
         {"part.nc": "G21 G90 G54\nG0 X100 Y100 Z100\nG55 G0 X10\nM30\n"}, ("part.nc:3", "--work-offsets")),
    Case("nc-second-set-up-from-a-table", "compensate vmc700 part.nc -o out.nc --work-offsets o.csv",
         {"part.nc": "G21 G90 G54\nG0 X100 Y100 Z100\nG55 G0 X10 Y10 Z10\nM30\n",
          "o.csv": "offset,X_mm,Y_mm,Z_mm\nG54,0,0,0\nG55,200,100,50\n"}, (), OK, outputs=("out.nc",)),
    Case("nc-heidenhain-program", "compensate vmc700 part.h -o out.nc",
         {"part.h": "0 BEGIN PGM PART MM\n1 L X+10 Y+5 R0 FMAX\n2 END PGM PART MM\n"}, ("part.h:1",)),
    Case("nc-dialect-heidenhain", "compensate vmc700 part.nc -o out.nc --dialect heidenhain", {"part.nc": SHORT},
         ("--dialect",)),
    Case("nc-fanuc-whole-number", "compensate vmc700 part.nc -o out.nc --dialect fanuc",
         {"part.nc": "G21 G90\nG0 X100. Y100. Z100.\nG1 X110 F500\nM30\n"}, ("part.nc:3:4",)),
    Case("nc-tol-um-zero", "compensate vmc700 part.nc -o out.nc --tol-um 0", {"part.nc": SHORT},
         ("--tol-um", "tolerance")),
    Case("nc-tol-urad-negative", "compensate vmc700 part.nc -o out.nc --tol-urad -1", {"part.nc": SHORT},
         ("--tol-urad",)),

    # --- values and arguments ----------------------------------------------------------------------
    Case("value-rank-seed-negative", "rank vmc500 --points 16 --seed -1", {}, ("--seed",)),
    Case("value-errormap-seed-negative", "errormap vmc500 --points 10 --order 1 --elements 1 --seed -1", {},
         ("--seed",)),
    Case("value-identify-seed-negative", "identify vmc500 runs.csv --folds 2 --seed -1", {"runs.csv": RUNS},
         ("--seed",)),
    Case("value-identify-folds-negative", "identify vmc500 runs.csv --folds -3", {"runs.csv": RUNS},
         ("--folds",)),
    Case("value-identify-sigma-urad-negative", "identify vmc500 runs.csv --folds 0 --sigma-urad -1",
         {"runs.csv": RUNS}, ("--sigma-urad",)),
    Case("value-identify-at-nan", "identify vmc500 runs.csv --folds 0 --at Y=nan", {"runs.csv": RUNS},
         ("--at",)),
    Case("value-identify-axis-contradicts-the-file", "identify vmc500 runs.csv --folds 0 --axis Y",
         {"runs.csv": RUNS}, ("--axis",)),
    Case("value-identify-runs-at-names-an-axis-twice", "identify vmc500 runs.csv --folds 0",
         {"runs.csv": RUNS.replace(b"# at: Y=200, Z=200", b"# at: Y=200, Y=100, Z=200")}, ("runs.csv",)),
    Case("value-identify-terms-unknown", "identify vmc500 runs.csv --folds 0 --terms EQQ", {"runs.csv": RUNS},
         ("--terms",)),
    Case("value-identify-points-position-minus-infinity", "identify vmc500 p.csv --folds 0",
         {"p.csv": "x,y,z,dx,dy,dz\n-Infinity,100,100,1,2,3\n200,200,200,1,1,1\n"}, ("p.csv:2",)),
    Case("value-identify-points-semicolons", "identify vmc500 p.csv --folds 0",
         {"p.csv": "x;y;z;dx;dy;dz\n100;100;100;1;2;3\n"}, ("p.csv",)),
    Case("value-identify-points-deviation-in-mm", "identify vmc500 p.csv --folds 0",
         {"p.csv": "x,y,z,dx_mm,dy,dz\n100,100,100,1,2,3\n200,200,200,1,1,1\n"}, ("dx_mm",)),
    Case("value-identify-points-position-in-metres", "identify vmc500 p.csv --folds 0",
         {"p.csv": "x_m,y,z,dx,dy,dz\n0.1,100,100,1,2,3\n"}, ("x_m",)),
    Case("value-identify-points-row-too-short", "identify vmc500 p.csv --folds 0",
         {"p.csv": "x,y,z,dx,dy,dz\n100,100,100,1,2,3\n200,200,200,1,1\n"}, ("p.csv:3",)),
    Case("value-identify-points-header-only", "identify vmc500 p.csv --folds 0", {"p.csv": "x,y,z,dx,dy,dz\n"},
         ("p.csv",)),
    Case("value-identify-points-direction-zero", "identify vmc500 p.csv --folds 0",
         {"p.csv": "x,y,z,dx,dy,dz,dir_x\n100,100,100,1,2,3,0\n200,200,200,1,1,1,1\n"}, ("p.csv:2",)),
    Case("value-identify-points-no-deviation-measured", "identify vmc500 p.csv --folds 0",
         {"p.csv": "x,y,z,dx,dy,dz\n100,100,100,,,\n200,200,200,,,\n"}, ("p.csv",)),
    Case("value-identify-points-bom-and-crlf", "identify vmc500 p.csv --folds 0 --json",
         {"p.csv": "\ufeff" + POINTS40.replace("\n", "\r\n")}, ("p.csv",), OK),
    Case("value-diagnose-alpha-zero", "diagnose vmc500 pts.csv --max-effects 1 --folds 2 --alpha 0",
         {"pts.csv": POINTS40}, ("--alpha",)),
    Case("value-thermal-fit-top-negative", "thermal-fit s.csv --target dz_um --top -2", {"s.csv": SERIES},
         ("--top",)),
    Case("value-thermal-fit-sensor-given-twice", "thermal-fit s.csv --target dz_um --sensors T_bearing T_bearing",
         {"s.csv": SERIES}, ("T_bearing",), NOTE),
    Case("value-thermal-fit-test-file-is-the-data", "thermal-fit s.csv --target dz_um --test s.csv",
         {"s.csv": SERIES}, ("s.csv", "--test"), NOTE),
    Case("value-thermal-fit-same-batch-twice", "thermal-fit s.csv s.csv --target dz_um", {"s.csv": SERIES},
         ("s.csv",), NOTE),
    Case("value-thermal-fit-two-rows", "thermal-fit s.csv --target dz_um",
         {"s.csv": "".join(SERIES.splitlines(keepends=True)[:4])}, ("s.csv", "--lag")),
    Case("value-thermal-fit-empty-cell", "thermal-fit s.csv --target dz_um",
         {"s.csv": SERIES.replace("23.213,21.196,21.154", "23.213,21.196,", 1)}, ("s.csv:",)),
    Case("value-field-config-nan", "field vmc500 --out f.rrd --grid 2 --sweep-steps 0 --config X=nan", {},
         ("config",)),
    Case("value-field-config-unknown-axis", "field vmc500 --out f.rrd --grid 2 --sweep-steps 0 --config Q=5", {},
         ("--config",)),
    Case("value-errormap-config-infinite", "errormap vmc500 --points 10 --order 1 --elements 1 --config X=1e309",
         {}, ("--config",)),
    Case("value-rank-state-t-nan", "rank vmc500 --points 16 --state t=nan", {}, ("--state", "state 't'")),
    Case("value-rank-state-two-forces", "rank vmc500 --points 16 --state forces=1,2", {}, ("--state", "forces")),
    Case("value-rank-state-direction-zero", "rank vmc500 --points 16 --state directions=0,1,1", {},
         ("--state", "directions")),
    Case("value-rank-state-sensor-the-machine-does-not-read", "rank vmc500 --points 16 --state nosuch=25", {},
         ("nosuch",), NOTE),
    Case("value-rank-tolerance-negative", "rank vmc500 --points 16 --tolerances tol.toml",
         {"tol.toml": "EXX_um = -5\ndefault_um = 1\ndefault_arcsec = 1\n"}, ("EXX_um",)),
    Case("value-rank-tolerance-angle-on-a-length", "rank vmc500 --points 16 --tolerances tol.toml",
         {"tol.toml": "EXX_arcsec = 5\ndefault_um = 1\ndefault_arcsec = 1\n"}, ("EXX_arcsec",)),
    Case("value-rank-tolerance-string", "rank vmc500 --points 16 --tolerances tol.toml",
         {"tol.toml": 'EXX_um = "5"\ndefault_um = 1\ndefault_arcsec = 1\n'}, ("EXX_um",)),
    Case("value-demo-top-negative", "demo --grid 2 --top -1 --out d.rrd", {}, ("--top",)),
    Case("value-gear-axes-twice", "gear gear_roller --tooth 1 --profile-points 5 --face-points 3 --unit-errors "
         "--axes A,A", {}, ("--axes",)),
    Case("value-gear-axes-without-unit-errors", "gear gear_roller --tooth 1 --profile-points 5 --face-points 3 "
         "--axes A", {}, ("--axes",), NOTE),
    Case("value-gear-at-nan", "gear gear_roller --tooth 1 --profile-points 5 --face-points 3 --at Z=nan", {},
         ("--at",)),
    Case("value-gear-tooth-out-of-range", "gear gear_roller --profile-points 5 --face-points 3 --tooth 46", {},
         ("--tooth",)),
    Case("value-dh-empty-joint-name", "dh robot.csv -o robot.urdf",
         {"robot.csv": DH.replace("J2,revolute", ",revolute")}, ("robot.csv",), ANY, outputs=("robot.urdf",),
         result=urdf_loads("robot.urdf", "tool0", "base")),
    Case("value-dh-tool-nan", "dh robot.csv -o robot.urdf",
         {"robot.csv": DH.replace("# tool: 0, 0, 100", "# tool: 0, nan, 100")}, ("tool",)),
    Case("value-dh-convention-given-twice", "dh robot.csv -o robot.urdf",
         {"robot.csv": DH.replace("# convention: standard", "# convention: standard\n# convention: modified")},
         ("convention",)),
    Case("value-dh-tool-frame-is-the-base-frame", "dh robot.csv -o robot.urdf --tool-frame base",
         {"robot.csv": DH}, ("--tool-frame", "base"), ANY, outputs=("robot.urdf",),
         result=urdf_loads("robot.urdf", "base", "base")),
    Case("value-dh-tool-frame-clashes-with-a-link", "dh robot.csv -o robot.urdf --tool-frame J1_link",
         {"robot.csv": DH}, ("--tool-frame", "J1_link"), ANY, outputs=("robot.urdf",),
         result=urdf_loads("robot.urdf", "J1_link", "base")),
    Case("value-dh-bom-and-crlf", "dh robot.csv -o robot.urdf", {"robot.csv": "\ufeff" + DH.replace("\n", "\r\n")},
         ("robot.csv",), OK, outputs=("robot.urdf",), result=urdf_loads("robot.urdf", "tool0", "base")),
    Case("value-iso230-axis-named-twice", "iso230-2 runs.csv",
         {"runs.csv": RUNS.replace(b"# axis: X", b"# axis: X\n# axis: Y")}, ("axis",)),
    Case("value-iso230-bom-and-crlf", "iso230-2 runs.csv --json",
         {"runs.csv": b"\xef\xbb\xbf" + RUNS.replace(b"\n", b"\r\n")}, ("runs.csv",), OK),
    Case("value-iso230-key-value-unit-inch", "iso230-2 run.dat",
         {"run.dat": "UNIT=inch\nTGT_DATA[1]=0\nREF_DATA_FWD[1,1]=0.001\nREF_DATA_BWD[1,1]=0.0\n"}, ("run.dat",)),
    Case("value-iso230-cycle-columns-of-two-kinds", "iso230-2 runs.csv",
         {"runs.csv": "direction,i,target_mm,ref_c1,dev_c2_um\nfwd,1,0,0.001,0.002\nbwd,1,0,0.0,0.001\n"
                      "fwd,2,10,10.001,10.002\nbwd,2,10,10.0,10.001\n"}, ("runs.csv",)),
    Case("value-iso230-direction-word", "iso230-2 runs.csv",
         {"runs.csv": RUNS.replace(b"\n100.0,1,1,", b"\n100.0,1,sideways,", 1)}, ("runs.csv:",)),
    Case("value-ballbar-centre-nan", "ballbar circle.csv",
         {"circle.csv": CIRCLE.replace("# centre: X=250", "# centre: X=nan")}, ("centre",)),
    Case("value-ballbar-centre-axis-twice", "ballbar circle.csv",
         {"circle.csv": CIRCLE.replace("Z=200", "Z=200, X=100", 1)}, ("centre",)),
    Case("value-ballbar-radius-twice", "ballbar circle.csv",
         {"circle.csv": CIRCLE.replace("# radius: 100", "# radius: 100\n# radius: 150")}, ("radius",)),
    Case("value-ballbar-angle-1e300-degrees", "ballbar circle.csv",
         {"circle.csv": CIRCLE.replace("\n1.0000,", "\n1e300,", 1)}, ("circle.csv:6",)),
    Case("value-ballbar-deviation-longer-than-the-bar", "ballbar circle.csv",
         {"circle.csv": CIRCLE.replace("\n1.0000,0.22305,", "\n1.0000,-200000,", 1)}, ("circle.csv:6",)),
    Case("value-ballbar-radius-with-its-unit", "ballbar circle.csv --json",
         {"circle.csv": CIRCLE.replace("# radius: 100", "# radius: 100 mm")}, ("radius",), ANY,
         result=json_is("radius_mm", 100.0)),
    Case("value-ballbar-two-samples", "ballbar circle.csv",
         {"circle.csv": "".join(CIRCLE.splitlines(keepends=True)[:6])}, ("circle.csv",)),
    Case("value-spec-thermal-stop-negative", "info m",
         machine_files("vmc500", "m", eyx_terms('{ kind = "thermal_drift", prefix = "d", driver = "time", '
                                               'amplitudes_um = [-5.0], time_constants_s = [60.0], stop_s = -5 }')),
         ("stop_s",)),
    Case("value-spec-reference-below-absolute-zero", "info m",
         machine_files("vmc500", "m", eyx_terms('{ kind = "thermal_expansion", prefix = "d", driver = '
                                               '"temperature", sensor = "s", coefficient_ppm_per_K = 11.5, '
                                               'reference_degC = -300 }')),
         ("reference_degC",)),
    Case("value-spec-time-constant-zero", "info m",
         machine_files("vmc500", "m", eyx_terms('{ kind = "thermal_drift", prefix = "d", driver = "time", '
                                               'amplitudes_um = [-5.0], time_constants_s = [0.0] }')),
         ("time_constants_s",)),
    Case("value-spec-period-and-period-in-um", "info m",
         machine_files("vmc500", "m", eyx_terms('{ kind = "periodic_pitch", prefix = "p", period_mm = 10.0, '
                                               'period_um = 10000.0, sine_um = [0.6], cosine_um = [0.2] }')),
         ("period",)),
    Case("value-spec-toml-nan", "info m",
         machine_files("vmc500", "m", replace("value_arcsec = 4.0", "value_arcsec = nan")), ("EC0Y",)),
    Case("value-spec-sign-zero", "info m",
         machine_files("vmc500", "m", replace('joint = "x_axis"', 'joint = "x_axis"\nsign = 0')), ("sign",)),
    Case("value-spec-two-axes-on-one-joint", "info m",
         machine_files("vmc500", "m", replace('joint = "y_axis"', 'joint = "x_axis"')), ("x_axis",)),
    Case("value-spec-table-position-repeated", "info m",
         machine_files("vmc500", "m", replace("positions_mm = [0, 50, 100,", "positions_mm = [0, 50, 50,")),
         ("positions_mm",)),
    Case("value-spec-byte-order-mark", "info m",
         machine_files("vmc500", "m", lambda text: "\ufeff" + text), ("errors.toml",), ANY),
    Case("value-spec-crlf", "info m", machine_files("vmc500", "m", lambda text: text.replace("\n", "\r\n")),
         ("errors.toml",), OK),
]


def _marks(case: Case) -> list:
    """Skip marks for the system devices a case's argv or files name."""
    text = case.argv + " " + " ".join(str(v) for v in case.files.values() if isinstance(v, str))
    devices = {d for d in ("/dev/zero", "/dev/full", "/dev/null") if d in text}
    devices |= {getattr(v, "device", None) for v in case.files.values()} - {None}
    return [needs_device(d) for d in sorted(devices)]


@pytest.mark.parametrize("case", [c.param(*_marks(c)) for c in CASES])
def test_hostile_cli(case, tmp_path, capfd, monkeypatch):
    folder = tmp_path / "case"
    folder.mkdir()
    case = _with_paths(case, folder)
    judge(case, folder, *run_in_process(case, folder, capfd, monkeypatch))


def _with_paths(case: Case, folder: Path) -> Case:
    """``{abs}`` in a URDF's text is the case folder (for absolute mesh paths)."""
    files = {name: (content.replace("{abs}", str(folder)) if isinstance(content, str) else content)
             for name, content in case.files.items()}
    return Case(case.id, case.argv, files, case.culprit, case.expect, case.outputs, case.result, case.timeout)


# ----------------------------------------------------------------------------- subprocesses

WIDE = ("x,y,z,dx,dy,dz," + ",".join(f"c{i}" for i in range(1_000_000)) + "\n"
        + "".join(f"{v},{v},{v},1,2,3," + ",".join(["0"] * 1_000_000) + "\n" for v in (100, 200, 300)))

SLOW_CASES = [
    Case("size-rank-a-billion-points", "rank vmc500 --points 1000000000", {}, ("--points",)),
    Case("size-errormap-a-billion-test-points", "errormap vmc500 --points 1000000000 --order 1 --elements 1", {},
         ("--points",)),
    Case("size-errormap-2000-elements-per-axis", "errormap vmc500 --elements 2000 --order 3 --points 10", {},
         ("--elements",)),
    Case("size-demo-grid-5000", "demo --grid 5000 --out d.rrd", {}, ("--grid",)),
    Case("size-field-a-billion-sweep-steps", "field cgm4000 --out f.rrd --grid 2 --sweep-steps 1000000000", {},
         ("--sweep-steps",)),
    Case("size-gear-100001-profile-and-face-points",
         "gear gear_roller --tooth 1 --profile-points 100001 --face-points 100001", {},
         ("--profile-points", "--face-points")),
    Case("size-gear-100-million-teeth", "gear gear_roller --teeth 100000000", {}, ("--teeth",)),
    Case("size-identify-degree-100000", "identify vmc500 runs.csv --folds 0 --degree 100000", {"runs.csv": RUNS},
         ("--degree",)),
    Case("size-compensate-tolerance-1e-9-um", "compensate vmc700 part.nc -o out.nc --tol-um 1e-9",
         {"part.nc": PART}, ("--tol-um",), ANY, outputs=("out.nc",)),
    Case("size-nc-arc-of-a-billion-turns", "compensate vmc700 prog.nc -o out.nc",
         program("G1 X100 Y100\nG2 X150 Y100 I25 J0 P1000000000\n"), ("prog.nc:4",)),
    # 9 MB: a reader linear in the columns takes about a minute on a loaded 2-core machine
    Case("size-points-file-of-a-million-columns", "identify vmc500 wide.csv --folds 0", {"wide.csv": WIDE},
         ("wide.csv",), ANY, timeout=180),
    Case("size-ballbar-file-of-3-gb", "ballbar huge.csv", {"huge.csv": sparse(3 << 30)}, ("huge.csv",)),
    Case("reach-spec-urdf-is-dev-zero", "info m",
         machine_files("vmc500", "m", replace('urdf = "vmc500.urdf"', 'urdf = "/dev/zero"')),
         ("/dev/zero", "urdf")),
    Case("reach-spec-urdf-is-a-fifo", "info m",
         {**machine_files("vmc500", "m", replace('urdf = "vmc500.urdf"', 'urdf = "pipe.urdf"')),
          "m/pipe.urdf": fifo()}, ("pipe.urdf",), timeout=FIFO_TIMEOUT),
    Case("reach-identify-data-is-dev-zero", "identify vmc500 zero.csv --folds 0",
         {"zero.csv": symlink("/dev/zero")}, ("zero.csv",)),
    Case("reach-compensate-program-is-a-fifo", "compensate vmc700 prog.nc -o out.nc", {"prog.nc": fifo()},
         ("prog.nc",), timeout=FIFO_TIMEOUT),
    Case("reach-field-mesh-is-a-fifo", f"field robot/slide.urdf {FIELD} --out f.rrd",
         {"robot/slide.urdf": slide_urdf("meshes/pipe.stl"), "robot/meshes/pipe.stl": fifo()}, ("pipe.stl",),
         NOTE, outputs=("f.rrd",), timeout=FIFO_TIMEOUT),
    Case("reach-field-mesh-of-20-gb", f"field robot/slide.urdf {FIELD} --out f.rrd",
         {"robot/slide.urdf": slide_urdf("meshes/huge.stl"), "robot/meshes/huge.stl": sparse(20 << 30)},
         ("huge.stl",), NOTE, outputs=("f.rrd",)),
    Case("loss-compensate-output-is-a-fifo", "compensate vmc700 part.nc -o out.nc",
         {"part.nc": PART, "out.nc": fifo()}, ("--out", "out.nc"), timeout=FIFO_TIMEOUT),
]


@pytest.mark.slow
@pytest.mark.parametrize("case", [c.param(*_marks(c)) for c in SLOW_CASES])
def test_hostile_subprocess(case, tmp_path):
    folder = tmp_path / "case"
    folder.mkdir()
    judge(case, folder, *run_subprocess(case, folder))


# ----------------------------------------------------------------------------- the library


@pytest.fixture(scope="module")
def vmc500():
    return vp.load_machine("vmc500")


def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


LIBRARY = [
    # (id, call, culprit): the call must raise the project's error naming the culprit
    ("lib-sensitivity-parameters-by-name", lambda m, d: m.sensitivity(m.mid_travel, parameters=["EXX.n0"]),
     "parameters"),
    ("lib-sensitivity-parameter-index-out-of-range",
     lambda m, d: m.sensitivity(m.mid_travel, parameters=[10**6]), "parameters"),
    ("lib-sensitivity-parameter-index-negative", lambda m, d: m.sensitivity(m.mid_travel, parameters=[-1]),
     "parameters"),
    ("lib-with-state-temperature-text", lambda m, d: m.with_state(temperatures={"spindle": "hot"}),
     "temperatures"),
    ("lib-volumetric-error-ragged-rows", lambda m, d: m.volumetric_error([[0.1, 0.1], [0.1, 0.1, 0.1]]), "q"),
    ("lib-with-state-forces-nan", lambda m, d: m.with_state(forces=[np.nan, 0.0, 0.0]), "forces"),
    ("lib-volumetric-error-complex-positions",
     lambda m, d: m.volumetric_error(np.array([[0.1 + 1j, 0.1, 0.1]])), "q"),
    ("lib-volumetric-error-theta-text", lambda m, d: m.volumetric_error(m.mid_travel, ["a"] * len(m.theta)),
     "theta"),
    ("lib-volumetric-error-order-two", lambda m, d: m.volumetric_error(m.mid_travel, order=2), "order"),
    ("lib-with-theta-wrong-length", lambda m, d: m.with_theta(m.theta[:-1]), "theta"),
    ("lib-load-machine-empty-name", lambda m, d: vp.load_machine(""), "errors.toml"),
    ("lib-load-machine-urdf-same-frames",
     lambda m, d: vp.load_machine(EXAMPLES / "two_link_arm.urdf", tool_frame="world", workpiece_frame="world"),
     "world"),
    ("lib-read-points-binary-file",
     lambda m, d: measurements.read_points(_write(d / "bin.csv", b"\x89PNG\r\n\x1a\n\x00\xff\xfe"), m),
     "bin.csv"),
    ("lib-read-runs-at-names-the-moving-axis",
     lambda m, d: measurements.read_runs(_write(d / "runs.csv", RUNS.replace(b"# at: Y", b"# at: X=100, Y"))),
     ("# at", "X=100")),
    ("lib-dh-to-urdf-no-joints", lambda m, d: dh.dh_to_urdf([]), "joint"),
    ("lib-iso230-evaluate-nan-deviation",
     lambda m, d: iso230.evaluate([0, 10, 0, 10] * 2, [1, 1, -1, -1] * 2, [1.0, 2.0, 3.0, np.nan, 1.0, 2.0, 3.0, 4.0]),
     "deviations"),
    ("lib-compensate-points-negative-tolerance",
     lambda m, d: compensate_points(m, np.array([[0.3, 0.1, 0.1]]), tol_um=-1.0), "tol_um"),
    ("lib-sample-zero-points", lambda m, d: workspace.sample(m, 0), "0"),
    ("lib-errormap-zero-elements", lambda m, d: errormap.ErrorMap.build(m, (0, 1, 1), 1), "elements"),
    ("lib-read-series-no-files", lambda m, d: measurements.read_series([]), "files"),
]


@pytest.mark.parametrize("call, culprit", [pytest.param(call, culprit, id=id) for id, call, culprit in LIBRARY])
def test_hostile_library(call, culprit, vmc500, tmp_path):
    try:
        value = call(vmc500, tmp_path)
    except vp.VolerrError as exc:
        names = (culprit,) if isinstance(culprit, str) else culprit
        assert any(c.lower() in str(exc).lower() for c in names), \
            f"the error does not name {' or '.join(names)}: {str(exc)[:300]!r}"
        return
    except Exception as exc:
        pytest.fail(f"not the project's error: {type(exc).__name__}: {str(exc)[:300]}")
    pytest.fail(f"silent: returned {str(value)[:200]!r} (expected an error naming {culprit})")


def test_empty_positions_give_an_empty_result(vmc500):
    """Zero points is a valid request: the right result is zero rows, not an error."""
    assert vmc500.volumetric_error(np.zeros((0, 3))).shape == (0, 6)
    assert vmc500.sensitivity(np.zeros((0, 3))).shape == (0, 6, len(vmc500.parameter_names))


def test_the_pass_has_a_hundred_new_cases():
    ids = [c.id for c in CASES + SLOW_CASES] + [c[0] for c in LIBRARY]
    assert len(ids) == len(set(ids)) and len(ids) >= 100
    kinds = {i.split("-", 1)[0] for i in ids}
    assert kinds == {"loss", "reach", "size", "nc", "value", "lib"}
