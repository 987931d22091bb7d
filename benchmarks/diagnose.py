"""Time of a diagnosis in its own process, quiet and beside a busy process, with the thread
environment free and limited to one thread, measured in one run.

    python benchmarks/diagnose.py [--sizes 400 4000] [--markdown FILE] [--json FILE]

Every measurement runs in a fresh process on a held-out set of vmc500 with every covariate
column (t, three temperatures, three forces, three approach directions; off-spec geometry and a
hidden backlash, :func:`volerr_pin.measurements.heldout_set`). A diagnosis runs in one process on
one BLAS thread, which it sets itself: "default" runs it with the environment as a user has it,
"one thread" with BLAS, OpenMP and numba limited to one thread through the environment, and the
two should take the same time (their ratio near 1: a diagnosis that let BLAS spin threads on its
small matrices would show here, beside a busy process most). "busy" runs the same beside one
process spinning on a core (as on CI or a shared workstation). Also reported: time(10x points) /
time(points) (at most 10). Nothing here is asserted; tests never check times.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ONE_THREAD = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")}

CHILD = r"""
import json, resource, sys, time
import volerr_pin as vp
from volerr_pin.fit.diagnosis import diagnose
from volerr_pin.measurements import read_any
m = vp.load_machine("vmc500")
data = [read_any(sys.argv[1], m)]
def cpu():
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime
c0, t0 = cpu(), time.perf_counter()
r = diagnose(m, data)
print(json.dumps({"wall_s": time.perf_counter() - t0, "cpu_s": cpu() - c0,
                  "effects": [e.name for e in r.effects]}))
"""


def _write_set(n: int, folder: Path) -> Path:
    import volerr_pin as vp
    from volerr_pin.measurements import heldout_set, write_points

    machine = vp.load_machine("vmc500")
    _, data = heldout_set(machine, {"EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 4.0}}, n, 0.3, 7)
    path = folder / f"vmc500_{n}.csv"
    write_points(data, machine, path)
    return path


def _start(path: Path, mode: str) -> subprocess.Popen:
    """A diagnosis of ``path`` in a fresh process, with the default threading or on one thread."""
    env = dict(os.environ)
    for k in ONE_THREAD:
        env.pop(k, None)
    if mode == "one":
        env.update(ONE_THREAD)
    return subprocess.Popen([sys.executable, "-c", CHILD, str(path), mode], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _result(proc: subprocess.Popen) -> dict:
    """What a process of :func:`_start` measured."""
    out, err = proc.communicate()
    if proc.returncode != 0:
        raise subprocess.CalledProcessError(proc.returncode, proc.args, out, err)
    return json.loads(out.strip().splitlines()[-1])


def _run(path: Path, mode: str) -> dict:
    return _result(_start(path, mode))


def bench(sizes=(400, 4000), repeat: int = 1, loads=("quiet", "busy")) -> list[dict]:
    """One row per (load, size, mode) and one row of ratios per (load, size); best of ``repeat``."""
    rows = [{"mode": "machine", "load_before": os.getloadavg()[0] if hasattr(os, "getloadavg") else None}]
    with tempfile.TemporaryDirectory() as tmp:
        paths = {n: _write_set(n, Path(tmp)) for n in sizes}
        _run(paths[sizes[0]], "default")   # compile and cache the kernels
        for load in loads:
            spinner = (subprocess.Popen([sys.executable, "-c", "while True: pass"]) if load == "busy" else None)
            try:
                times = {}
                for n in sizes:
                    # the modes in turn, repeat times: the machine's speed drifts by a tenth or more
                    # within minutes, and each ratio should compare runs of the same minutes
                    modes = ("default", "one")
                    runs = {mode: [] for mode in modes}
                    for _ in range(repeat):
                        for mode in modes:
                            runs[mode].append(_run(paths[n], mode))
                    for mode in modes:
                        best = min(runs[mode], key=lambda r: r["wall_s"])
                        times[n, mode] = best
                        rows.append({"load": load, "points": n, "mode": mode, "wall_s": best["wall_s"],
                                     "cpu_s": best["cpu_s"], "effects": best["effects"]})
                for n in sizes:
                    d, o = times[n, "default"], times[n, "one"]
                    row = {"load": load, "points": n, "mode": "ratios", "cpu_default_over_one": d["cpu_s"] / o["cpu_s"],
                           "wall_default_over_one": d["wall_s"] / o["wall_s"]}
                    if n != sizes[0]:
                        row["wall_over_smallest"] = d["wall_s"] / times[sizes[0], "default"]["wall_s"]
                        row["size_over_smallest"] = n / sizes[0]
                    rows.append(row)
            finally:
                if spinner is not None:
                    spinner.kill()
                    spinner.wait()
    return rows


def markdown(rows: list[dict]) -> str:
    """The rows as markdown tables."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load = next((r["load_before"] for r in rows if r["mode"] == "machine"), None)
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [f"Measured on {platform.machine()} ({_cpu_model()}) with {cores} cores, Python {platform.python_version()}, "
             f"{when}"
             + (f", load average before the run {load:.2f}." if load is not None else "."), "",
             "| load | points | mode | wall [s] | CPU [s] | effects |", "|---|---|---|---|---|---|"]
    for r in rows:
        if r["mode"] not in ("ratios", "machine"):
            lines.append(f"| {r['load']} | {r['points']} | {r['mode']} | {r['wall_s']:.2f} | {r['cpu_s']:.2f} | "
                         f"{', '.join(r['effects']) or '-'} |")
    lines += ["", "| load | points | CPU default / one thread (expected about 1) | wall default / one thread "
              "(expected about 1) | wall / wall at the smallest size (target <= size ratio) |",
              "|---|---|---|---|---|"]
    for r in rows:
        if r["mode"] == "ratios":
            grow = (f"{r['wall_over_smallest']:.2f} for {r['size_over_smallest']:g}x the points"
                    if "wall_over_smallest" in r else "-")
            lines.append(f"| {r['load']} | {r['points']} | {r['cpu_default_over_one']:.2f} | "
                         f"{r['wall_default_over_one']:.2f} | {grow} |")
    return "\n".join(lines) + "\n"


def _cpu_model() -> str:
    """The processor's model name, where the system says it."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "processor unknown"


def section(quick: bool = False) -> str:
    """This benchmark's Markdown for ``benchmarks/run.py``: 400 points quiet with ``quick`` (CI keeps the
    script alive), 400 and 4,000 points quiet and beside a busy process, best of two, otherwise."""
    rows = bench((400,), 1, ("quiet",)) if quick else bench((400, 4000), 2, ("quiet", "busy"))
    return markdown(rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[400, 4000])
    parser.add_argument("--repeat", type=int, default=1, help="runs per case, the fastest kept")
    parser.add_argument("--loads", nargs="+", default=["quiet", "busy"], choices=["quiet", "busy"])
    parser.add_argument("--markdown")
    parser.add_argument("--json")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rows = bench(tuple(args.sizes), args.repeat, tuple(args.loads))
    text = markdown(rows)
    print(text)
    print(f"({time.perf_counter() - start:.0f} s)")
    if args.markdown:
        Path(args.markdown).write_text(text)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
