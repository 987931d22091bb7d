"""volerr plan: the measurement campaign to take, what it will determine, and the files to run it."""

from __future__ import annotations

import os

import numpy as np
from rich.markup import escape

from ..base import InputError, read_json, sensible, transaction
from ._common import add_json_arg, add_machine_args, add_out_arg, check_run_outputs, dumps, machine_of, table_console


def _triple(text: str) -> tuple[float, float, float]:
    """argparse type: 'X,Y,Z' in mm."""
    import argparse

    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y,Z in mm, got {text!r}") from None
    if len(values) != 3 or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"expected three finite numbers X,Y,Z in mm, got {text!r}")
    return values


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "plan"
HELP = "plan a measurement campaign: poses, predicted uncertainties, NC program"


def add_parser(sub) -> None:
    from ..studies.plan import INSTRUMENTS

    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    p.add_argument("--instrument", required=True, choices=sorted(INSTRUMENTS), help="the instrument")
    p.add_argument("--budget", type=int, required=True,
                   help="number of units to measure: poses (tracker, probe), runs (interferometer), circles (ballbar)")
    add_out_arg(p, "the plan: the measurement file the instrument produces, deviations empty (CSV)", suffixes=(".csv",),
                what="a measurement file (CSV)")
    p.add_argument("--template", help="the results template identify reads once filled (CSV with comments)")
    p.add_argument("--nc", help="NC program visiting the poses with a dwell at each")
    p.add_argument("--zone", nargs="+", metavar="AXIS=LO:HI", help="working zone (mm, deg; default the travel)")
    p.add_argument("--targets", nargs="+", type=_triple, metavar="X,Y,Z",
                   help="reflector offsets from the tool point in the tool frame (mm; tracker)")
    p.add_argument("--tool-lengths", nargs="+", type=float, metavar="MM",
                   help="tool lengths beyond the tool point (mm): one target on the tool axis each (tracker)")
    p.add_argument("--station", type=_triple, metavar="X,Y,Z",
                   help="tracker position in the workpiece frame (mm): poses out of its line of sight are left out")
    p.add_argument("--acceptance-deg", type=float, default=30.0, help="reflector acceptance half-angle (deg)")
    p.add_argument("--sigma-um", type=float, help="instrument noise per observed value (um; default the instrument's)")
    p.add_argument("--terms", nargs="+", metavar="TERM", help="components to identify (default all)")
    p.add_argument("--criterion", choices=["D", "I"], default="D",
                   help="D-optimal (log det of the information, default) or I-optimal (mean predicted variance of "
                        "the volumetric error over the zone)")
    p.add_argument("--candidates", type=int, default=1024, help="candidate poses to choose from (default 1024)")
    p.add_argument("--seed", type=int, default=0, help="seed of candidates and simulations")
    p.add_argument("--compare", action="store_true",
                   help="also assess a grid and random poses of the same count, predicted and simulated")
    p.add_argument("--repeats", type=int, default=5, help="simulated campaigns per design with --compare")
    p.add_argument("--feed-mm-min", type=float, default=2000.0,
                   help="feed of the NC program (mm/min); a ballbar's circles run at it")
    p.add_argument("--dwell-s", type=float, default=3.0,
                   help="dwell per measurement (s): at each pose or run target, before each ballbar circle")
    p.add_argument("--after", metavar="DIAGNOSIS.json",
                   help="propose --budget extra poses that separate what this diagnosis left open")
    add_json_arg(p)
    p.set_defaults(func=run)


def _targets(args) -> np.ndarray | None:
    rows = [list(t) for t in args.targets or []]
    lengths = sensible("tool_lengths", np.array(args.tool_lengths or [], dtype=float) * 1e-3, "position_length",
                       "mm", 1e-3) * 1e3
    rows += [[0.0, 0.0, -float(length)] for length in lengths]  # tool z points into the spindle
    return np.array(rows) * 1e-3 if rows else None


def run(args) -> int:
    from ..compensation.export import parse_zone
    from ..studies.plan import instrument, make_setup, plan
    from ..studies.plan import after_diagnosis
    from ..studies.plan import check_axes, time_estimate

    machine = machine_of(args)
    inputs = [args.after] if args.after else []
    kind = instrument(args.instrument)
    if args.budget < 1:
        raise InputError(f"budget must be a whole number >= 1, got {args.budget}", parameters=("budget",))
    planned = {name: kind.outputs(path, args.budget) if path else [] for name, path in
               (("out", args.out), ("template", args.template))}
    seen: dict = {}
    for name, path in [("nc", args.nc), *((n, p) for n, paths in planned.items() for p in paths)]:
        if path is None:
            continue
        check_run_outputs({name: path}, inputs, machine)   # one file at a time: an instrument may write several
        key = os.path.realpath(path)
        if key in seen:
            raise InputError(f"{name}: {path} is also written for {seen[key]}", parameters=(name, seen[key]))
        seen[key] = name
    zone = parse_zone(machine, args.zone).ranges if args.zone else None
    setup = make_setup(machine, kind, zone=zone, sigma_um=args.sigma_um, targets=_targets(args),
                       station=None if args.station is None else np.array(args.station) * 1e-3,
                       acceptance_deg=args.acceptance_deg)
    time_estimate(machine, np.zeros((1, len(machine.axes))), args.feed_mm_min, args.dwell_s)  # checks, before work
    if args.nc:
        check_axes(machine)
    if args.after:
        report = read_json(args.after, what="diagnosis report")
        result = after_diagnosis(machine, kind, setup, report, args.budget, candidates=args.candidates,
                                 seed=args.seed, source=str(args.after))
        units = result.units
        out = {"machine": machine.name, "instrument": kind.name, "budget": args.budget, "unit": kind.unit,
               "after": result.to_dict()}
        visits = kind.visits(machine, units) if units else np.zeros((0, len(machine.axes)))
        out["poses"] = _poses(machine, visits)
        out["predicted"] = {}
        out["not_separable"] = out["after"]["not_separable"]
    else:
        result = plan(machine, kind, args.budget, setup, terms=args.terms, candidates=args.candidates,
                      seed=args.seed, compare=args.compare, repeats=args.repeats, criterion=args.criterion)
        units = result.units
        out = result.to_dict()
        out["sigma_stated"] = args.sigma_um is not None
        out["criterion"] = args.criterion
    out["time"] = kind.duration(machine, units, args.feed_mm_min, args.dwell_s) if units else None
    if units and (args.nc or args.out or args.template):
        title = f"volerr plan: {machine.name}, {kind.name}, {len(units)} {kind.unit}s"
        program = kind.program(machine, units, args.feed_mm_min, args.dwell_s, title) if args.nc else None
        texts = kind.files(machine, setup, units)
        notes = (f"# results of the campaign planned by volerr plan for {machine.name} with a {kind.name}\n"
                 "# fill the empty measured columns (units in docs/measurements.md) and give the file to volerr identify\n")
        with transaction() as tx:
            for path, text in zip(planned["out"], texts):
                tx.path(path).write_text(text)
            for path, text in zip(planned["template"], texts):
                tx.path(path).write_text(notes + text)
            if program is not None:
                tx.path(args.nc).write_text(program)
    out["files"] = {k: [str(p) for p in v] for k, v in planned.items() if v}
    if args.nc:
        out["files"]["nc"] = [str(args.nc)]
    if args.json:
        print(dumps(out))
        return 0
    _print(out)
    return 0


def _poses(machine, visits) -> list[dict]:
    from ..base import axis_scales

    scale = axis_scales(machine.axis_kinds)
    return [dict(zip(machine.axes, (float(v) for v in row / scale))) for row in visits]


def _print(out: dict) -> None:
    console = table_console()
    stops = f" ({len(out['poses'])} stops)" if len(out["poses"]) != out["budget"] else ""
    console.print(f"[bold]{out['machine']}[/bold]: {out['budget']} {out['instrument']} {out.get('unit', 'pose')}s "
                  f"planned{stops}")
    pred = out.get("predicted") or {}
    if out.get("sigma_um") is not None and "after" not in out:
        stated = "" if out.get("sigma_stated") else f" (the {out['instrument']}'s default; --sigma-um states yours)"
        console.print(f"assumed: instrument noise {out['sigma_um']:g} um per observed value{stated}; the best "
                      f"{out['budget']} of {out['candidates']:,} candidate {out.get('unit', 'pose')}s by criterion "
                      f"{out.get('criterion', 'D')}")
    if pred.get("determinable_rms_um") is not None:
        console.print(f"predicted uncertainty of what a {out['instrument']} determines over the zone (the volumetric "
                      f"error less its best rigid fit): RMS {pred['determinable_rms_um']:.3g} um, largest "
                      f"{pred['determinable_max_um']:.3g} um ({pred['n_identifiable']} coefficients identified), for "
                      f"such an error of RMS {pred['determinable_error_rms_um']:.3g} um there")
        console.print(f"a rigid motion of the whole map is what the {out['instrument']}'s registration leaves open: "
                      f"RMS {pred['rigid_rms_um']:.3g} um ({pred['zone_rms_um']:.3g} um with it, in quadrature)")
    elif pred.get("zone_rms_um") is not None:
        console.print(f"predicted uncertainty of the volumetric error over the zone: RMS {pred['zone_rms_um']:.3g} um, "
                      f"largest {pred['zone_max_um']:.3g} um ({pred['n_identifiable']} coefficients identified), "
                      f"for an error the model puts at RMS {pred['error_rms_um']:.3g} um, largest "
                      f"{pred['error_max_um']:.3g} um there")
    combined = [n for n, c in (pred.get("coefficients") or {}).items() if c.get("stands_for")]
    if combined:
        console.print(escape(f"{len(combined)} of the identified coefficients stand for a combination with coefficients "
                             "held at their priors (their predicted uncertainty is the combination's; JSON: "
                             f"stands_for): {', '.join(combined[:8])}{', ...' if len(combined) > 8 else ''}"))
    if out.get("not_separable"):
        console.print("no plan with this instrument separates:")
        for g in out["not_separable"]:
            console.print(escape(f"  {g['kind']}: {', '.join(g['parameters'])}"))
    for label, c in (out.get("comparison") or {}).items():
        if label == "plan":
            continue
        r = c["ratios"]
        if c.get("not_comparable"):
            console.print(escape(f"plan / {label}: not comparable: {c['not_comparable']} (its simulated map error, "
                                 f"fitting what it can: {c['simulated_zone_rms_um']:.4g} um RMS)"))
            continue
        which = f" (the median of {c['sets']['count']} random sets)" if "sets" in c else ""
        console.print(f"plan / {label}{which}: predicted zone RMS ratio {r['predicted_zone_rms']}, simulated "
                      f"{r['simulated_zone_rms']}; not identified by the {label}: {len(c['not_identified'])}")
    sets = ((out.get("comparison") or {}).get("random") or {}).get("sets")
    if sets and sets["predicted_zone_rms_um"]:
        z = sets["predicted_zone_rms_um"]
        console.print(f"random sets: predicted zone RMS {z['p10']:.3g} um (best tenth), {z['median']:.3g} (median), "
                      f"{z['p90']:.3g} (worst tenth) over {sets['count']} sets"
                      + (f", {sets['not_determining']} leaving coefficients undetermined" if sets["not_determining"]
                         else "")
                      + f"; the plan is {sets['plan_over_p10']:.2f} of the best tenth's")
    if "after" in out:
        a = out["after"]
        console.print(f"after the diagnosis: {a['extra']} extra {out['unit']}s; separated in simulation: "
                      f"{a['separated']}")
    if out.get("time"):
        console.print(f"time: {out['time']['total_min']:.1f} min at {out['time']['feed_mm_min']:g} mm/min "
                      f"with {out['time']['dwell_per_pose_s']:g} s dwells")
    for note in out.get("notes") or []:
        console.print(escape(f"note: {note}"))
    for what, paths in out["files"].items():
        console.print(f"wrote {', '.join(paths)} ({what})")
