"""Benchmarks of the Monte Carlo studies, measured in one run on this machine.

    python benchmarks/studies.py [--quick] [--json FILE] [--markdown FILE]

1. The evaluator (many coefficient vectors at the same points, bases reused, one kernel call
   for many vectors) against one :meth:`Machine.volumetric_error` call per vector, in this
   process (after checking that both give the same errors).
2. A tolerance study's Monte Carlo (the largest and RMS error over a grid per draw) on an
   embedded local Dask cluster of 1 and of 2 worker processes (one thread each, loopback):
   draws per second, per worker, and the scaling from 1 to 2 workers. Cluster start-up and
   the workers' first task (imports, compiled kernels, the machine rebuilt) are timed apart
   and left out of the rates; the runs alternate between the two clusters and the best of
   three is kept; both give the same numbers to the bit (checked).
3. What that rate means for the issue's case: 1e5 draws x 40^3 points on the workers measured.

``bench_studies`` returns the rows; tests never assert times.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import volerr_pin as vp  # noqa: E402
from volerr_pin.studies.engine import available_cores, local_cluster  # noqa: E402
from volerr_pin.studies.evaluator import Evaluator  # noqa: E402
from volerr_pin.studies.montecarlo import grid_points, make_points, run_monte_carlo  # noqa: E402
from volerr_pin.studies.tolerance import tolerance_source  # noqa: E402
from volerr_pin.studies.tolerances import read_tolerance_file  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TOLERANCES = ROOT / "examples" / "data" / "vmc500_tolerances.toml"


def bench_evaluator(name: str, points: int, draws: int) -> dict:
    """Point-draws per second: the evaluator against a loop of volumetric_error calls."""
    machine = vp.load_machine(name)
    q = grid_points(machine, [max(2, round(points ** (1 / len(machine.axes))))])
    rng = np.random.default_rng(0)
    thetas = machine.theta + rng.normal(size=(draws, len(machine.theta))) * 1e-6
    ev = Evaluator(machine)
    got = ev.errors(q, thetas, key="bench")                   # also builds the bases (timed apart)
    want = np.stack([machine.volumetric_error(q, t)[:, :3] for t in thetas[:5]])
    assert np.abs(got[:5] - want).max() < 1e-14
    t0 = time.perf_counter()
    ev.errors(q, thetas, key="bench")
    fast = time.perf_counter() - t0
    t0 = time.perf_counter()
    for t in thetas:
        machine.volumetric_error(q, t)
    slow = time.perf_counter() - t0
    pairs = len(q) * draws
    return {"task": "evaluator vs one call per draw", "machine": name, "points": len(q), "draws": draws,
            "evaluator_us_per_pair": fast / pairs * 1e6, "calls_us_per_pair": slow / pairs * 1e6,
            "speedup": slow / fast}


def bench_cluster(grid: int, samples: int, workers_list=(1, 2), repeat: int = 3) -> list[dict]:
    """A tolerance Monte Carlo on local clusters of 1 and 2 worker processes, both started
    first, the runs interleaved (1, 2, 1, 2, ...) and the best of ``repeat`` kept: the machine
    is shared, and interleaving exposes both to the same load."""
    machine = vp.load_machine("vmc500")
    tol = read_tolerance_file(TOLERANCES, machine)
    constant, source = tolerance_source(machine, tol, 0)
    q = grid_points(constant, grid)
    points = make_points(constant, q)
    engines, start, warm = {}, {}, {}
    try:
        for workers in workers_list:
            t0 = time.perf_counter()
            engines[workers] = local_cluster(workers)
            start[workers] = time.perf_counter() - t0
            t0 = time.perf_counter()
            run_monte_carlo(constant, source, points, 256 * workers, engine=engines[workers], per_point=False)
            warm[workers] = time.perf_counter() - t0
        best = {w: math.inf for w in workers_list}
        results = {}
        for _ in range(repeat):
            for workers in workers_list:
                t0 = time.perf_counter()
                results[workers] = run_monte_carlo(constant, source, points, samples, engine=engines[workers],
                                                   per_point=False)
                best[workers] = min(best[workers], time.perf_counter() - t0)
    finally:
        for engine in engines.values():
            engine.close()
    first = results[workers_list[0]]
    for workers in workers_list[1:]:   # the same numbers, whatever the workers
        assert np.array_equal(results[workers].max, first.max) and np.array_equal(results[workers].rms, first.rms)
    rows = []
    for workers in workers_list:
        rate = samples / best[workers]
        rows.append({"task": "tolerance Monte Carlo", "machine": "vmc500", "points": len(q), "draws": samples,
                     "workers": workers, "start_s": start[workers], "first_task_s": warm[workers],
                     "seconds": best[workers], "draws_per_s": rate, "draws_per_s_per_worker": rate / workers,
                     "us_per_pair_per_worker": best[workers] * workers / (samples * len(q)) * 1e6})
    base = rows[0]["draws_per_s"]
    for row in rows:
        row["scaling"] = row["draws_per_s"] / base
        row["efficiency"] = row["scaling"] / row["workers"]
    return rows


def bench_studies(quick: bool = False) -> list[dict]:
    """Every row of this benchmark, measured now.

    Parameters
    ----------
    quick : bool
        Small sizes (CI).

    Returns
    -------
    list of dict
        One row per measurement.
    """
    rows = [bench_evaluator("vmc500", 300 if quick else 1000, 64 if quick else 512),
            bench_evaluator("cgm4000", 300 if quick else 3000, 32 if quick else 256)]
    cluster = bench_cluster(8 if quick else 20, 512 if quick else 2048, repeat=1 if quick else 3)
    rows += cluster
    per_pair = cluster[0]["us_per_pair_per_worker"] * 1e-6
    for row in cluster:
        total = 1e5 * 40**3 * per_pair / row["workers"] / row["efficiency"]
        rows.append({"task": "extrapolated: 1e5 draws x 40^3 points", "machine": "vmc500", "workers": row["workers"],
                     "hours": total / 3600})
    return rows


def markdown(rows: list[dict], info: dict) -> str:
    """The rows as Markdown tables."""
    load = ("" if info.get("load_before") is None else
            f" Load average of the machine (shared) {info['load_before']:.1f} before, {info['load_after']:.1f} after.")
    out = [f"Measured on {info['machine']}, {info['cores']} cores, Python {info['python']}.{load}", "",
           "| evaluator | machine | points | draws | evaluator [us/pair] | one call per draw [us/pair] | speed-up |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["task"].startswith("evaluator"):
            out.append(f"| many draws, same points | {r['machine']} | {r['points']:,} | {r['draws']:,} | "
                       f"{r['evaluator_us_per_pair']:.3f} | {r['calls_us_per_pair']:.3f} | {r['speedup']:.1f}x |")
    out += ["", "| tolerance Monte Carlo (vmc500) | points | draws | workers | start [s] | first task [s] | run [s] | "
                "draws/s | draws/s per worker | us per point-draw per worker | scaling 1 -> N |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["task"] == "tolerance Monte Carlo":
            out.append(f"| local cluster | {r['points']:,} | {r['draws']:,} | {r['workers']} | {r['start_s']:.1f} | "
                       f"{r['first_task_s']:.1f} | {r['seconds']:.2f} | {r['draws_per_s']:.0f} | "
                       f"{r['draws_per_s_per_worker']:.0f} | {r['us_per_pair_per_worker']:.3f} | "
                       f"{r['scaling']:.2f} ({100 * r['efficiency']:.0f} %) |")
    for r in rows:
        if r["task"].startswith("extrapolated"):
            out.append(f"\n1e5 draws x 40^3 points at the measured rate, {r['workers']} worker"
                       f"{'s' if r['workers'] > 1 else ''}: {r['hours']:.1f} h")
    return "\n".join(out) + "\n"


def machine_info() -> dict:
    """Where the run took place (the load average says whether the machine was shared)."""
    return {"machine": platform.machine(), "cores": available_cores(), "python": platform.python_version(),
            "numba_threads": os.environ.get("NUMBA_NUM_THREADS", "default"),
            "load_before": os.getloadavg()[0] if hasattr(os, "getloadavg") else None}


def section(quick: bool = False) -> str:
    """This benchmark's Markdown for ``benchmarks/run.py``."""
    info = machine_info()
    rows = bench_studies(quick)
    info["load_after"] = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    return markdown(rows, info)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (CI)")
    parser.add_argument("--json", help="write the rows to this file")
    parser.add_argument("--markdown", help="write the Markdown tables to this file")
    args = parser.parse_args(argv)
    info = machine_info()
    rows = bench_studies(args.quick)
    info["load_after"] = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    text = markdown(rows, info)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps({"info": info, "rows": rows}, indent=1))
    if args.markdown:
        Path(args.markdown).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
