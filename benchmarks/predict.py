"""Time and memory of ``volerr predict`` on programs of 1e3 to 1e6 blocks, and what sampling the
path in batches gains over sampling it move by move.

    python benchmarks/predict.py [--quick] [--sizes 1000 10000 ...] [--kinds short 5axis-tip] [--markdown FILE]

1. Programs of random moves (``benchmarks/nc.py``'s generator, fixed seeds: ``short`` G1 moves
   of about 1 mm on vmc500, ``5axis-tip`` moves of about 1 mm and 0.05 deg on cgm4000 in
   tool-tip programming), and cgm4000's cone frustum test piece (1,440 moves, three sections
   ranked), each predicted by the command line, ``volerr predict MACHINE PROGRAM --json``, in a
   subprocess of its own: the command's time (reading the machine, reading the program,
   sampling the path to 0.01 um, measuring and ranking the features) and its peak resident
   memory (``VmHWM``).
2. Batches against a loop: the deviation along a 2,000-block program (``short``), sampled by
   :func:`volerr_pin.applications.part.deviation_along` (every move's midpoints in one call
   per round) and by the same function called move by move (what sampling each move until it
   meets the tolerance costs when the moves are not batched). Both give the same samples
   (checked before timing); the best of three runs of each, in this process.

``--quick`` runs 1e3 and 1e4 blocks. Nothing here is asserted; tests never check times.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

KINDS = ("short", "5axis-tip")
SIZES = (1_000, 10_000, 100_000, 990_000)   # the NC reader follows at most 1,000,000 blocks of a program
QUICK_SIZES = (1_000, 10_000)

def _nc():
    """``benchmarks/nc.py``, for its program generator."""
    spec = importlib.util.spec_from_file_location("_bench_nc", Path(__file__).with_name("nc.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _child(argv: list[str]) -> dict:
    """``volerr ARGV`` in a process of its own (``benchmarks/nc.py``'s): its time, peak memory and
    the report's figures."""
    child = _nc().run_command(argv)
    report = child["report"]
    return {"seconds": child["seconds"], "peak_rss_mb": child["peak_rss_mb"], "samples": report["samples"],
            "features": len(report["features"]), "max_um": report["max_normal_deviation_um"]}


def programs(sizes, kinds) -> list[dict]:
    """One row per program (see the module docstring)."""
    nc = _nc()
    rows = []
    with tempfile.TemporaryDirectory(prefix="volerr-predict-bench-") as tmp:
        for kind in kinds:
            for n in sizes:
                path = Path(tmp) / f"{kind}_{n}.nc"
                nc.write_program(path, kind, n)
                if kind == "5axis-tip":   # the generator's moves, read as tool tips (G43.4 after the rapid)
                    path.write_text(path.read_text().replace("G1 F2000", "G43.4 H1\nG1 F2000", 1))
                child = _child(["predict", nc.MACHINE[kind], str(path), "--json"])
                rows.append({"program": kind, "machine": nc.MACHINE[kind], "blocks": n, **child})
                path.unlink()
                print(f"{kind} {n}: {child['seconds']:.1f} s, {child['peak_rss_mb']:.0f} MB", file=sys.stderr, flush=True)
    return rows


def _cone_row() -> dict:
    """cgm4000's cone frustum test piece, its sections measured and ranked."""
    import contextlib
    import io

    from volerr_pin.cli import main

    with tempfile.TemporaryDirectory(prefix="volerr-predict-bench-") as tmp:
        cone = Path(tmp) / "cone.nc"
        with contextlib.redirect_stderr(io.StringIO()):
            main(["testpiece", "cgm4000", "--kind", "cone-frustum", "-o", str(cone)])
        child = _child(["predict", "cgm4000", str(cone), "--tool-diameter", "20", "--cone-heights", "2,10,18", "--json"])
        return {"program": "cone frustum", "machine": "cgm4000", "blocks": len(cone.read_text().splitlines()), **child}


def batches_against_a_loop(blocks: int = 2_000) -> dict:
    """The deviation along a ``short`` program, batched and move by move (see the docstring)."""
    import volerr_pin as vp
    from volerr_pin.applications.part import deviation_along
    from volerr_pin.compensation.gcode import interpret
    from volerr_pin.compensation import POINT

    nc = _nc()
    with tempfile.TemporaryDirectory(prefix="volerr-predict-bench-") as tmp:
        path = Path(tmp) / "short.nc"
        nc.write_program(path, "short", blocks)
        text = path.read_text()
    machine = vp.load_machine("vmc500")
    moves = interpret(machine, text)
    cutting = np.flatnonzero(moves.kind != POINT)   # (rapids cut nothing)

    def batched():
        return deviation_along(machine, moves)

    def by_move():
        return [deviation_along(machine, moves.take(cutting[i:i + 1])) for i in range(len(cutting))]

    whole, parts = batched(), by_move()
    assert np.array_equal(whole.fraction, np.concatenate([p.fraction for p in parts]))
    assert np.allclose(whole.normal, np.concatenate([p.normal for p in parts]), rtol=0, atol=1e-15)

    def best(fn):
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return min(times)

    t_batch, t_loop = best(batched), best(by_move)
    return {"blocks": len(cutting), "samples": int(len(whole.line)), "batched_s": t_batch, "by_move_s": t_loop,
            "ratio": t_loop / t_batch}


def markdown(rows: list[dict], gain: dict) -> str:
    lines = [f"Measured on {platform.machine()}, Python {platform.python_version()}, {os.cpu_count()} CPUs; "
             "`volerr predict --json` (sampled to 0.01 um), one process per program (time from the command's call to "
             "its return, machine loading included; peak RSS of the whole process).", "",
             "| program | machine | blocks | samples | features | time [s] | blocks/s | peak RSS [MB] |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['program']} | {r['machine']} | {r['blocks']:,} | {r['samples']:,} | {r['features']} | "
                     f"{r['seconds']:.1f} | {r['blocks'] / r['seconds']:,.0f} | {r['peak_rss_mb']:.0f} |")
    lines += ["", f"The path of a {gain['blocks']:,}-block program (`short`, {gain['samples']:,} samples), sampled in "
                  f"batches: {gain['batched_s']:.3f} s; move by move: {gain['by_move_s']:.2f} s "
                  f"(**{gain['ratio']:.0f} x**; the same samples, best of three each)."]
    return "\n".join(lines) + "\n"


def bench(sizes=SIZES, kinds=KINDS) -> tuple[list[dict], dict]:
    rows = programs(sizes, kinds)
    rows.append(_cone_row())
    return rows, batches_against_a_loop()


def section(quick: bool = False) -> str:
    """This benchmark's Markdown for ``benchmarks/run.py`` (1e3 and 1e4 blocks with ``quick``)."""
    return markdown(*bench(QUICK_SIZES if quick else SIZES))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1e3 and 1e4 blocks only")
    parser.add_argument("--sizes", type=int, nargs="+", help="program sizes [blocks]")
    parser.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS))
    parser.add_argument("--markdown", help="also write the table here")
    args = parser.parse_args(argv)
    text = markdown(*bench(args.sizes or (QUICK_SIZES if args.quick else SIZES), args.kinds))
    print(text)
    if args.markdown:
        from volerr_pin.base import write_text

        write_text(args.markdown, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
