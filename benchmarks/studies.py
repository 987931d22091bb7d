"""Benchmarks of the Monte Carlo studies, measured in one run on this machine.

    python benchmarks/studies.py [--quick] [--json FILE] [--markdown FILE]

1. The evaluator (many coefficient vectors at the same points, bases reused, one kernel call
   for many vectors) against one call of the algorithm :func:`volerr_pin.model.volumetric_error`
   per vector (inputs checked once, as a loop of the library calls it), in this process (after
   checking that both give the same errors).
2. A tolerance study's Monte Carlo (the largest and RMS error over a grid per draw) on an
   embedded local Dask cluster of 1 and of 2 worker processes (one thread each, loopback):
   draws per second, per worker, and the scaling from 1 to 2 workers. Cluster start-up and
   the workers' first task (imports, compiled kernels, the machine rebuilt) are timed apart
   and left out of the rates; the runs alternate between the two clusters and the best of
   three is kept; both give the same numbers to the bit (checked).
3. What that rate means for the issue's case: 1e5 draws x 40^3 points on the workers measured.
4. Scaling as a user meets it: the whole study ``volerr tolerance vmc500 --samples 80000``
   runs (Monte Carlo and Sobol' indices, 343 grid points) on 1 and on 2 worker processes,
   alternating, ``repeat`` times: the ratio of the wall times in each repeat, their median and
   spread. Beside it the cost model of docs/studies.md: Dask's cost per task (a no-op task
   round trip on the same cluster), the workers' busy time and the rest (the client's share),
   and the 2-worker time the model predicts from the 1-worker run.

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
from volerr_pin.model import check_inputs, volumetric_error  # noqa: E402
from volerr_pin.studies import available_cores, local_cluster  # noqa: E402
from volerr_pin.studies import Evaluator  # noqa: E402
from volerr_pin.studies import grid_points, make_points, run_monte_carlo  # noqa: E402
from volerr_pin.studies import study_tolerances, tolerance_source  # noqa: E402
from volerr_pin.studies import read_tolerance_file  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TOLERANCES = ROOT / "examples" / "data" / "vmc500_tolerances.toml"


def bench_evaluator(name: str, points: int, draws: int) -> dict:
    """Point-draws per second: the evaluator against a loop of volumetric_error calls."""
    machine = vp.load_machine(name)
    q, _, cov = check_inputs(machine.model, grid_points(machine, [max(2, round(points ** (1 / len(machine.axes))))]),
                             state=machine.state)
    rng = np.random.default_rng(0)
    thetas = machine.theta + rng.normal(size=(draws, len(machine.theta))) * 1e-6
    ev = Evaluator(machine)
    got = ev.errors(q, thetas, key="bench")                   # also builds the bases (timed apart)
    want = np.stack([volumetric_error(machine.model, q, t, cov)[:, :3] for t in thetas[:5]])
    assert np.abs(got[:5] - want).max() < 1e-14
    t0 = time.perf_counter()
    ev.errors(q, thetas, key="bench")
    fast = time.perf_counter() - t0
    t0 = time.perf_counter()
    for t in thetas:
        volumetric_error(machine.model, q, t, cov)
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


def _noop(x):
    return x


def task_overhead(engine, count: int = 400) -> float:
    """Seconds per task Dask spends on ``count`` no-op tasks submitted at once (scheduling,
    moving arguments and results, the client's bookkeeping), on ``engine``'s cluster."""
    client = engine.client
    client.gather(client.map(_noop, range(8), pure=False))         # connections made
    t0 = time.perf_counter()
    client.gather(client.map(_noop, range(count), pure=False))
    return (time.perf_counter() - t0) / count


def client_seconds(machine, tol, points: int, sobol: int) -> tuple[float, float]:
    """What the client does itself in a tolerance study, timed in this process: the study's
    machine, the points' reference errors and the work-offset test at ``points`` grid points;
    and the Sobol' analysis (SALib's estimators and bootstrap) of ``sobol`` base samples."""
    from SALib.analyze import sobol as salib_sobol

    from volerr_pin.studies import work_offset_components

    q = grid_points(machine, [max(2, round(points ** (1 / len(machine.axes))))])
    t0 = time.perf_counter()
    shaped, source = tolerance_source(machine, tol, 0)
    pts = make_points(shaped, q)
    work_offset_components(shaped, source.columns, pts.q, source.shapes)
    prepare = time.perf_counter() - t0
    active = [k for k in range(len(tol.entries)) if tol.values[k] > 0]
    problem = source.design_problem(active, [tol.entries[k].component for k in active])
    Y = np.random.default_rng(0).random(sobol * (len(active) + 2))
    t0 = time.perf_counter()
    salib_sobol.analyze(problem, Y, calc_second_order=False, num_resamples=200, seed=1, print_to_console=False)
    return prepare / len(q), time.perf_counter() - t0


def bench_scaling(samples: int = 80_000, grid: int = 7, sobol: int = 256, repeat: int = 5) -> dict:
    """The whole tolerance study on 1 and 2 worker processes, alternating, ``repeat`` times,
    and the cost model's terms measured beside it."""
    machine = vp.load_machine("vmc500")
    tol = read_tolerance_file(TOLERANCES, machine)
    q = grid_points(machine, [grid])
    kwargs = dict(samples=samples, seed=0, sobol_samples=sobol, reallocation=False)
    engines, start = {}, {}
    times, busy, pieces = {1: [], 2: []}, {1: [], 2: []}, {1: [], 2: []}
    reports = {}
    try:
        for workers in (1, 2):
            t0 = time.perf_counter()
            engines[workers] = local_cluster(workers)
            start[workers] = time.perf_counter() - t0
            study_tolerances(machine, tol, q, samples=512, sobol_samples=None, reallocation=False,
                             engine=engines[workers])      # imports, compiled kernels, machine rebuilt
        overhead = task_overhead(engines[2])
        for r in range(repeat):
            for workers in ((1, 2) if r % 2 == 0 else (2, 1)):
                engine = engines[workers]
                b0, p0 = engine.busy_seconds, engine.pieces
                t0 = time.perf_counter()
                study = study_tolerances(machine, tol, q, engine=engine, **kwargs)
                times[workers].append(time.perf_counter() - t0)
                busy[workers].append(engine.busy_seconds - b0)
                pieces[workers].append(engine.pieces - p0)
                report = study.to_dict()
                report.pop("workers")
                reports.setdefault(workers, report)
    finally:
        for engine in engines.values():
            engine.close()
    assert reports[1] == reports[2]       # the same numbers on 1 and 2 workers
    per_point, analysis = client_seconds(machine, tol, len(q), sobol)
    per_point_large, _ = client_seconds(machine, tol, 100_000, sobol)
    ratios = [b / a for a, b in zip(times[1], times[2])]
    draws = samples + sobol * (len(tol.entries) + 2)            # Monte Carlo and Sobol' design
    row = {"task": "scaling", "machine": "vmc500", "points": len(q), "draws": samples, "sobol_samples": sobol,
           "model_draws": draws, "repeat": repeat, "start_s": start, "seconds_1": times[1], "seconds_2": times[2],
           "ratios": ratios, "ratio_median": float(np.median(ratios)), "ratio_min": min(ratios),
           "ratio_max": max(ratios), "task_overhead_ms": overhead * 1e3, "busy_1": float(np.median(busy[1])),
           "busy_2": float(np.median(busy[2])), "pieces_1": float(np.median(pieces[1])),
           "pieces_2": float(np.median(pieces[2])), "client_s_per_point": per_point,
           "client_s_per_point_1e5": per_point_large, "analysis_s": analysis,
           "measured_1": float(np.median(times[1])), "measured_2": float(np.median(times[2]))}
    row["us_per_pair"] = row["busy_1"] / (draws * len(q)) * 1e6
    row["predicted_1"] = predict(row, samples, len(q), 1)
    row["predicted_2"] = predict(row, samples, len(q), 2)
    row["efficiency_2"] = row["measured_1"] / (2 * row["measured_2"])
    return row


def predict(row: dict, draws: float, points: float, workers: int) -> float:
    """The cost model's wall time [s] of a tolerance study (Monte Carlo of ``draws`` and the
    Sobol' design of the measured base samples) over ``points`` on ``workers`` processes:

    ``T = t_client(points) + t_analysis + W c / workers + (W / TASK_SECONDS) o / workers``

    ``W c`` the work, point-draws times the measured seconds per point-draw on one worker;
    ``o`` Dask's measured cost per piece of work, ``W / TASK_SECONDS`` the pieces; the client's
    own time per point (its machine, reference errors, work-offset test) and the Sobol'
    analysis as measured. Cluster start-up is apart."""
    from volerr_pin.studies import TASK_SECONDS

    total = draws + row["model_draws"] - row["draws"]
    work = total * points * row["us_per_pair"] * 1e-6
    per_point = row["client_s_per_point"] if points < 10_000 else row["client_s_per_point_1e5"]
    pieces = max(work / TASK_SECONDS, 1.0)
    return per_point * points + row["analysis_s"] + work / workers + pieces * row["task_overhead_ms"] * 1e-3 / workers


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
    scaling = bench_scaling(4000 if quick else 80_000, 7, 16 if quick else 256, repeat=1 if quick else 5)
    rows.append(scaling)
    for workers in (1, 2, 16, 64):
        rows.append({"task": "predicted: 1e5 draws x 1e5 points", "machine": "vmc500", "workers": workers,
                     "hours": predict(scaling, 1e5, 1e5, workers) / 3600})
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
    out = [f"Measured on {info['machine']}, {info['cores']} cores, Python {info['python']}.{load}"]
    if any(r["task"].startswith("evaluator") for r in rows):
        out += ["", "| evaluator | machine | points | draws | evaluator [us/pair] | one call per draw [us/pair] | "
                    "speed-up |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["task"].startswith("evaluator"):
            out.append(f"| many draws, same points | {r['machine']} | {r['points']:,} | {r['draws']:,} | "
                       f"{r['evaluator_us_per_pair']:.3f} | {r['calls_us_per_pair']:.3f} | {r['speedup']:.1f}x |")
    if any(r["task"] == "tolerance Monte Carlo" for r in rows):
        out += ["", "| tolerance Monte Carlo (vmc500) | points | draws | workers | start [s] | first task [s] | "
                    "run [s] | draws/s | draws/s per worker | us per point-draw per worker | scaling 1 -> N |",
                "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["task"] == "tolerance Monte Carlo":
            out.append(f"| local cluster | {r['points']:,} | {r['draws']:,} | {r['workers']} | {r['start_s']:.1f} | "
                       f"{r['first_task_s']:.1f} | {r['seconds']:.2f} | {r['draws_per_s']:.0f} | "
                       f"{r['draws_per_s_per_worker']:.0f} | {r['us_per_pair_per_worker']:.3f} | "
                       f"{r['scaling']:.2f} ({100 * r['efficiency']:.0f} %) |")
    for r in rows:
        if r["task"] == "scaling":
            runs = ", ".join(f"{a:.1f} / {b:.1f} s ({b / a:.2f})" for a, b in zip(r["seconds_1"], r["seconds_2"]))
            out += ["", f"Scaling of the whole study (vmc500, {r['draws']:,} draws, Sobol' N = {r['sobol_samples']}, "
                        f"{r['points']} points), 1 / 2 worker processes, alternating: {runs}. "
                        f"2 workers take {r['ratio_median']:.2f} of 1 worker's time (median of {r['repeat']}; "
                        f"{r['ratio_min']:.2f} .. {r['ratio_max']:.2f}); parallel efficiency "
                        f"{100 * r['efficiency_2']:.0f} %.", "",
                    "| cost model term | measured |", "|---|---|",
                    f"| Dask's cost per task (no-op round trip, 2 workers) | {r['task_overhead_ms']:.2f} ms |",
                    f"| work per point-draw on one worker | {r['us_per_pair']:.2f} us |",
                    f"| pieces of work per run (1 / 2 workers) | {r['pieces_1']:.0f} / {r['pieces_2']:.0f} |",
                    f"| the client's own time per grid point (343 / 1e5 points) | "
                    f"{r['client_s_per_point'] * 1e3:.3f} / {r['client_s_per_point_1e5'] * 1e3:.3f} ms |",
                    f"| Sobol' analysis (SALib, bootstrap) | {r['analysis_s']:.2f} s |",
                    f"| cluster start (1 / 2 workers) | {r['start_s'][1]:.1f} / {r['start_s'][2]:.1f} s |",
                    f"| 1 worker: predicted / measured | {r['predicted_1']:.1f} / {r['measured_1']:.1f} s |",
                    f"| 2 workers: predicted / measured | {r['predicted_2']:.1f} / {r['measured_2']:.1f} s |"]
    for r in rows:
        if r["task"].startswith("predicted"):
            out.append(f"\nPredicted by the cost model, 1e5 draws x 1e5 points on {r['workers']} worker"
                       f"{'s' if r['workers'] > 1 else ''}: {r['hours']:.2f} h")
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
    parser.add_argument("--scaling", action="store_true", help="only the scaling of the whole study (4.)")
    parser.add_argument("--repeat", type=int, default=5, help="repeats of the scaling runs (default 5)")
    parser.add_argument("--json", help="write the rows to this file")
    parser.add_argument("--markdown", help="write the Markdown tables to this file")
    args = parser.parse_args(argv)
    info = machine_info()
    if args.scaling:
        scaling = bench_scaling(4000 if args.quick else 80_000, 7, 16 if args.quick else 256,
                                repeat=1 if args.quick else args.repeat)
        rows = [scaling] + [{"task": "predicted: 1e5 draws x 1e5 points", "machine": "vmc500", "workers": w,
                             "hours": predict(scaling, 1e5, 1e5, w) / 3600} for w in (1, 2, 16, 64)]
    else:
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
