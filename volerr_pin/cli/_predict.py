"""volerr predict: the part a program cuts, its features, and the error sources deciding each."""

from __future__ import annotations

from pathlib import Path

from rich import box
from rich.markup import escape
from rich.table import Table

from ..base import transaction
from ._common import (add_dialect_args, add_json_arg, add_machine_args, add_program_position_args, add_state_arg, check_run_outputs, dumps,
                     machine_of, millimetre_list, millimetres, positive, program_reading, table_console, tolerance_um)


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "predict"
HELP = "the part a program cuts: deviation along the path, CMM features, their error sources"
#: runs of blocks not predicted the text lists (the JSON lists all)
SHOWN_RUNS = 10


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    p.add_argument("program", help="NC program (ISO 6983 / RS-274), read as compensate reads it")
    p.add_argument("--reference", metavar="PROGRAM",
                   help="the program that defines the part, for a compensated program: its circles and sides are "
                        "measured on what the given program cuts")
    p.add_argument("--tol-um", type=tolerance_um, default=0.01,
                   help="sampling tolerance of the path: the deviation between samples, interpolated, is within it "
                        "of the model (default 0.01)")
    add_program_position_args(p)
    add_dialect_args(p)
    p.add_argument("--plane", choices=["xy", "xz", "yz"],
                   help="the contour plane circles and sides are measured in (default: the plane that holds the most "
                        "cutting length: xy for a milled contour, xz for a lathe's profile)")
    p.add_argument("--tool-diameter", type=millimetres, default=0.0, metavar="MM",
                   help="the cutter's diameter: a cone cut by its flank lies its radius from the tool's axis "
                        "(default 0: the cone the tool's axis sweeps)")
    p.add_argument("--cone-heights", type=millimetre_list, default=(0.0,), metavar="MM,MM,...",
                   help="where a cone is measured: heights along its axis above the plane the tool's end cuts in "
                        "(default 0)")
    p.add_argument("--top", type=positive, default=3, help="error sources shown per feature (default 3)")
    p.add_argument("--png", help="draw the part: the path moved by its deviation, and the circle as a CMM prints it")
    p.add_argument("--rrd", metavar="FILE.rrd", help="record the part in 3D for Rerun: the path, the cut, the features")
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..applications.part import NOT_PREDICTED_SHARE, blocks_text, predict
    from ..compensation.gcode import ProgramFile

    machine = machine_of(args)
    path = Path(args.program)
    inputs = [path] + ([Path(args.reference)] if args.reference else []) + (
        [Path(args.work_offsets)] if args.work_offsets else [])
    check_run_outputs({"png": args.png, "rrd": args.rrd}, inputs, machine)
    # each file read once, line by line, its lines given to the NC reader as they are
    lines = list(ProgramFile(path).lines())
    reference = list(ProgramFile(args.reference).lines()) if args.reference else None
    prediction = predict(machine, lines, str(path), reference=reference, reference_source=args.reference or "",
                         tolerance=args.tol_um * 1e-6, **program_reading(machine, args),
                         plane=None if args.plane is None else tuple("xyz".index(c) for c in args.plane),
                         tool_diameter=args.tool_diameter * 1e-3, cone_heights=[h * 1e-3 for h in args.cone_heights])
    report = prediction.to_dict(top=args.top)
    with transaction() as tx:   # the picture and the recording are both written, or neither
        if args.png:
            from ..viz import part_png

            report["png"] = {"path": str(args.png), "factor": part_png(prediction, tx.path(args.png))["factor"]}
        if args.rrd:
            from ..viz import record_part

            report["rrd"] = {"path": str(args.rrd), "factor": record_part(prediction, tx.path(args.rrd))["factor"]}
    if args.json:
        print(dumps(report))
        return 0
    console = table_console()
    state = ", ".join(f"{k}={v}" for k, v in machine.state.items()) if machine.state else "no state"
    console.print(escape(f"{machine.name}: {path} ({state}); {report['samples']:,} samples along the cutting moves, "
                         f"to {report['tolerance_um']:g} um"
                         + (f"; the part as {args.reference} defines it" if args.reference else "")))
    missing = prediction.not_predicted_blocks
    if report["not_predicted_share"] > NOT_PREDICTED_SHARE:
        console.print(escape(f"{missing:,} of the program's blocks ({100 * report['not_predicted_share']:.1f} %) "
                             f"{'is' if missing == 1 else 'are'} not predicted: the deviation and the features below "
                             "lack their cuts (listed at the end)"))
    console.print(escape(f"largest deviation normal to the programmed path: {report['max_normal_deviation_um']:.3f} um, line "
                         f"{report['max_line']}" + (" (the given program's path: a compensated program is offset from "
                                                     "the part on purpose; the features measure the part)"
                                                     if args.reference else "")))
    table = Table(box=box.SIMPLE, title="features as a CMM reports them (um)")
    columns = ("feature", "blocks", "value") + (() if args.reference else ("decided by (share; alone)",))
    for column in columns:
        table.add_column(column)
    for feature in report["features"]:
        kind = feature["kind"]
        if kind in ("circle", "cone"):
            value = (f"roundness {feature['circularity_um']:.3f}, diameter {feature['diameter_error_um']:+.3f}, "
                     f"centre {feature['centre_error_um']:.3f}")
            if kind == "cone":
                kind = f"cone at {feature['height_mm']:g} mm ({feature['diameter_mm']:.3f} mm)"
        else:
            value = f"{feature[kind + '_um']:.3f}"
        sources = "; ".join(f"{s['component']} {100 * s['share']:.0f} % ({s['alone_um']:.2f})" for s in feature["drivers"])
        table.add_row(kind, blocks_text(feature["blocks"]), value,
                      *(() if args.reference else (escape(sources),)))
    console.print(table)
    for note in report["notes"]:
        console.print(escape(f"note: {note}"))
    runs = prediction.not_predicted
    if runs:
        console.print(escape(f"not predicted: {missing:,} block{'s' if missing != 1 else ''}"
                             + (" (--json lists every one)" if len(runs) > SHOWN_RUNS else "")))
    for run in runs[:SHOWN_RUNS]:
        times = f" ({run.blocks:,} blocks)" if run.blocks > 1 and run.line != run.last_line else ""
        console.print(escape(f"  {run.where}{times}: {run.reason}"))
    if len(runs) > SHOWN_RUNS:
        console.print(escape(f"  ... and {len(runs) - SHOWN_RUNS:,} more runs of blocks"))
    if prediction.cones and not args.tool_diameter:
        console.print("the cones are those the tool's axis sweeps: give the cutter's --tool-diameter for the part's")
    if args.reference:
        console.print("what is left is the compensation's (its tolerance, the written numbers' rounding), not an "
                      "error source's: no sources are ranked")
    for key in ("png", "rrd"):
        if getattr(args, key):
            console.print(f"wrote {getattr(args, key)} (deviation x{report[key]['factor']:g})"
                          + (f"; open it with: rerun {args.rrd}" if key == "rrd" else ""))
    return 0
