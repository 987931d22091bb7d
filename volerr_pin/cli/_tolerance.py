"""volerr tolerance: the distribution of the largest and RMS volumetric error when every
component error is drawn within its tolerance; the probability of meeting a target; the
components that drive it; a least-cost re-allocation that meets it."""

from __future__ import annotations

import sys

from rich import box
from rich.markup import escape
from rich.table import Table

from ..base import UM, transaction
from ._common import (add_json_arg, add_machine_args, add_out_arg, add_state_arg, check_run_outputs, dumps, machine_of,
                     table_console)
from ._uncertainty import StudyProgress, add_study_args, count, engine_of, positive_float, probability


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "tolerance"
HELP = "Monte Carlo tolerance study: max error distribution, drivers, re-allocation"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    p.add_argument("--tolerances", required=True, metavar="FILE",
                   help="TOML: COMPONENT_um / COMPONENT_arcsec = tolerance, or { value, distribution, cost }")
    add_study_args(p, samples=10000, grid=7)
    p.add_argument("--target-um", type=positive_float, metavar="T",
                   help="largest admissible position error over the grid [um]")
    p.add_argument("--target-probability", type=probability, default=0.95,
                   help="probability the re-allocation must meet T with (default 0.95)")
    p.add_argument("--sobol-samples", type=count, default=256,
                   help="base samples N of the Sobol' design, a power of 2: N (D + 2) runs (default 256)")
    p.add_argument("--no-sobol", action="store_true", help="skip the sensitivity indices")
    p.add_argument("--no-reallocation", action="store_true", help="skip the re-allocation")
    add_out_arg(p, "write the suggested tolerances as a tolerance file", suffixes=(".toml",),
                what="a tolerance file (TOML)", metavar="FILE.toml")
    p.add_argument("--png", help="write the distribution of the largest error, with T marked")
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..studies import grid_points
    from ..studies import check_arguments, study_tolerances
    from ..studies import read_tolerance_file, tolerances_toml

    machine = machine_of(args)
    check_run_outputs({"out": args.out, "png": args.png}, [args.tolerances], machine)
    check_arguments(args.samples, args.seed, None, args.target_probability,
                    None if args.no_sobol else args.sobol_samples)
    tolerances = read_tolerance_file(args.tolerances, machine)
    q = grid_points(machine, args.grid)
    target = None if args.target_um is None else args.target_um * UM
    with engine_of(args) as engine, StudyProgress(not args.json) as progress:
        study = study_tolerances(machine, tolerances, q, samples=args.samples, seed=args.seed, target=target,
                                 target_probability=args.target_probability,
                                 sobol_samples=None if args.no_sobol else args.sobol_samples,
                                 reallocation=not args.no_reallocation, engine=engine, progress=progress)
    report = study.to_dict()
    report["grid"] = list(args.grid)
    report["engine"] = engine.where
    with transaction() as tx:
        if args.out and study.reallocation is not None:
            tx.path(args.out).write_text(tolerances_toml(
                study.reallocation.tolerances,
                f"Tolerances re-allocated by volerr tolerance for {machine.name} from {args.tolerances}:\n"
                f"P(max error <= {args.target_um:g} um) = {study.reallocation.probability:.4f} re-simulated "
                f"({study.reallocation.samples} draws, seed {study.reallocation.seed})"))
            report["out"] = args.out
        if args.png:
            from ..viz import max_error_png

            max_error_png(study.run.max / UM, tx.path(args.png), args.target_um,
                          f"{machine.name}: largest error over {study.points:,} points, {study.samples:,} draws")
            report["png"] = args.png
    if args.json:
        print(dumps(report))
        return 0
    _print(report)
    if args.out and study.reallocation is None:
        print("volerr: note: --out: no re-allocation (it needs --target-um), nothing written", file=sys.stderr)
    for name in ("out", "png"):
        if name in report:
            print(f"wrote {report[name]}", file=sys.stderr)
    return 0


#: rows of the Sobol' table in the text report
TOP = 12


def _resolution(resolution: dict, shown: list[dict]) -> list[str]:
    """Warnings where the indices' intervals do not separate them from zero."""
    names = {d["component"] for d in shown}
    out = []
    first = [n for n in resolution["first_order_unresolved"] if n in names]
    total = [n for n in resolution["total_unresolved"] if n in names]
    if first:
        out.append(f"  warning: the first-order intervals of {len(first)} of these {len(shown)} components include "
                   f"zero ({', '.join(first)}): at --sobol-samples {resolution['samples']} their first-order indices "
                   "are noise (a negative one, or a total below its first-order one, is that noise)")
        if resolution["samples_needed"]:
            lead = max(shown, key=lambda d: d["first_order"])
            out.append(f"  about --sobol-samples {resolution['samples_needed']:,} would separate the largest, "
                       f"{lead['component']}'s ({lead['first_order']:.3f} +- {lead['first_order_conf']:.3f}), from zero")
    if total:
        out.append(f"  warning: the total-index intervals of {', '.join(total)} include zero: their order is not "
                   "determined")
    return out


def _shape_lines(report: dict) -> list[str]:
    """What each tolerance was taken to mean, by shape, and what was left out."""
    groups: dict[tuple[str, str], list[str]] = {}
    for s in report["shapes"]:
        groups.setdefault((s["shape"], s["excludes"]), []).append(s["component"])
    out = ["each tolerance bounds what ISO 230 means by it (the range of the error over the travel, or a constant):"]
    for (shape, excludes), names in groups.items():
        out.append(f"  {shape} ({', '.join(names)})" + (f": less {excludes}" if excludes else ""))
    if report["left_out"]:
        out.append(f"  left out, a work offset removes them (the same translation at every point): "
                   f"{', '.join(r['component'] for r in report['left_out'])}")
    return out


def _print(report: dict) -> None:
    console = table_console()
    mx, rms = report["max_error_um"], report["rms_error_um"]
    console.print(f"[bold]{report['machine']}[/bold]: {report['samples']:,} draws (seed {report['seed']}) over "
                  f"{report['points']:,} grid points on {report['engine']}")
    console.print(f"largest position error over the grid: mean {mx['mean']:.3f} um, std {mx['std']:.3f}, "
                  f"p50 {mx['p50']:.3f}, p95 {mx['p95']:.3f}, p99 {mx['p99']:.3f} um")
    console.print(f"RMS position error over the grid: mean {rms['mean']:.3f} um, std {rms['std']:.3f}, "
                  f"p95 {rms['p95']:.3f} um")
    for line in _shape_lines(report):
        console.print(escape(line))
    if report["target_um"] is not None:
        console.print(f"P(largest error <= {report['target_um']:g} um) = {report['probability_within_target']:.4f} "
                      f"(standard error {report['probability_se']:.4f})")
    if report["drivers"]:
        drivers = report["drivers"]
        shown = drivers[:TOP]
        more = (f"; the {len(shown)} of {len(drivers)} components with the largest total index, --json gives all"
                if len(drivers) > len(shown) else "")
        table = Table(box=box.SIMPLE, title=f"what drives the largest error (Sobol' indices, 95 % intervals, "
                                            f"{report['sobol_runs']:,} runs{more})")
        for col in ("component", "first order", "total"):
            table.add_column(col, justify="right")
        for d in shown:
            table.add_row(d["component"], f"{d['first_order']:.3f} +- {d['first_order_conf']:.3f}",
                          f"{d['total']:.3f} +- {d['total_conf']:.3f}")
        console.print(table)
        for line in _resolution(report["sobol_resolution"], shown):
            console.print(escape(line))
    r = report["reallocation"]
    if r is not None:
        table = Table(box=box.SIMPLE, title=f"least-cost tolerances for P >= {report['target_probability']:g} "
                                            f"(cost {r['cost_before']:.2f} -> {r['cost_after']:.2f}; one factor for "
                                            "all would cost " + (f"{r['uniform_cost']:.2f})" if r["uniform_cost"]
                                                                  is not None else "more than the bounds allow)"))
        for col in ("component", "before", "after", "unit", "distribution"):
            table.add_column(col, justify="right")
        for t in r["tolerances"]:
            table.add_row(t["component"], f"{t['before']:.3g}", f"{t['after']:.3g}", t["unit"], t["distribution"])
        console.print(table)
        kept = [t["component"] for t in r["tolerances"] if t["reason"].startswith("not re-allocated")]
        for t in r["tolerances"]:
            if t["reason"] and t["component"] not in kept:
                console.print(escape(f"  {t['component']} {t['before']:.3g} -> {t['after']:.3g} {t['unit']}: {t['reason']}"))
        for reason in dict.fromkeys(t["reason"] for t in r["tolerances"] if t["component"] in kept):
            names = [t["component"] for t in r["tolerances"] if t["reason"] == reason]
            console.print(escape(f"  {', '.join(names)}: {reason}"))
        console.print(f"re-simulated: P = {r['probability']:.4f} (95 % lower bound {r['probability_lower']:.4f}) over "
                      f"{r['samples']:,} fresh draws: " + ("meets the target" if r["met"] else "does NOT meet it"))
