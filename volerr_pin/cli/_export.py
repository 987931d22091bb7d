"""volerr export: compensation tables a controller loads, with the residual it leaves."""

from __future__ import annotations

from pathlib import Path

from rich import box
from rich.markup import escape
from rich.table import Table

from ..base import check_output_folder, transaction
from ._common import (FitProgress, add_json_arg, add_machine_args, add_out_arg, add_state_arg, check_run_outputs, dumps,
                     machine_of, positive, table_console)


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "export"
HELP = "compensation tables a controller loads, with the residual it leaves"


def add_parser(sub) -> None:
    from ..compensation.export import CONTROLLERS

    kinds = "; ".join(f"{name}: {', '.join(f.kinds)}" for name, f in CONTROLLERS.items())
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    p.add_argument("--controller", required=True, choices=list(CONTROLLERS), help="the controller whose files to write")
    add_out_arg(p, "folder to write the files into", required=True, metavar="DIR")
    p.add_argument("--kind", help=f"kind of tables (default the controller's most capable that fits): {kinds}")
    p.add_argument("--zone", nargs="+", metavar="KEY=RANGE",
                   help="working zone: AXIS=LO:HI (mm, deg) or AXIS=V per axis, tool=LO:HI or tool=L (mm, the tool "
                        "beyond the machine's tool point); axes not named keep their travel")
    p.add_argument("--nodes", type=positive, help="table nodes per axis (default: the format's)")
    p.add_argument("--points", type=positive, default=4096,
                   help="points judged on, and as many others fitted on (at least 8 per table value; default 4096)")
    p.add_argument("--seed", type=int, default=0, help="seed of the points")
    p.add_argument("--png", help="also draw the error before and after (PNG)")
    p.add_argument("--rrd", help="also write a Rerun recording of the error before and after")
    add_json_arg(p, "print the report as one JSON object")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..compensation.export import export_tables, layout_files, parse_zone, write_export

    machine = machine_of(args)
    check_output_folder("out", args.out)
    check_run_outputs({"png": args.png, "rrd": args.rrd}, machine=machine)
    zone = parse_zone(machine, args.zone)
    names = layout_files(machine, args.controller, zone=zone, kind=args.kind, nodes=args.nodes)  # refusals first
    if Path(args.out).is_dir():
        for name in names:
            check_run_outputs({"out": Path(args.out) / name}, machine=machine)
    with FitProgress(not args.json) as progress:
        result = export_tables(machine, args.controller, zone=zone, kind=args.kind, nodes=args.nodes,
                               points=args.points, seed=args.seed,
                               progress=(lambda stage: progress(stage, 0)) if progress else None)
    with transaction() as tx:                  # tables, picture and recording: all written, or none
        write_export(result, args.out, tx)
        if args.png:
            from ..viz import export_png

            export_png(result, tx.path(args.png))
        if args.rrd:
            from ..viz import record_export

            record_export(result, tx.path(args.rrd))
    report = result.to_dict()
    for key in ("png", "rrd"):
        if getattr(args, key):
            report[key] = str(getattr(args, key))
    if args.json:
        print(dumps(report))
        return 0
    console = table_console()
    console.print(f"{machine.name} -> {args.controller} ({result.kind}): {len(result.files)} file(s) in {args.out}, "
                  "read back as written")
    table = Table(box=box.SIMPLE, title=f"tool-point position error over {report['points']} points of the zone, "
                                        "each position reached from both directions")
    for col in ("", "max [um]", "RMS [um]"):
        table.add_column(escape(col), justify="right")
    for label, key in (("uncompensated", "uncompensated"), ("naive tables (components at the nodes)", "naive_residual"),
                       ("written tables, as the controller applies them", "residual"),
                       ("the same, positions visited once in a random order", "random_order_residual"),
                       ("exact point compensation", "exact_residual")):
        table.add_row(escape(label), f"{report[key + '_max_um']:.4g}", f"{report[key + '_rms_um']:.4g}")
    console.print(table)
    console.print(f"at {report['node_points']} points on the table nodes: {report['node_residual_max_um']:.4g} um max "
                  f"(exact: {report['node_exact_residual_max_um']:.3g})")
    console.print(f"files hold: {escape(report['convention'])}")
    for line in report["tables"] + report["notes"]:
        console.print(f"  {escape(line)}")
    for path in result.files + [report[k] for k in ("png", "rrd") if k in report]:
        print(f"wrote {path}")
    return 0
