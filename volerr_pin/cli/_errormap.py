"""volerr errormap: error-map accuracy per element order; compensation tables."""

from __future__ import annotations

from rich import box
from rich.markup import escape
from rich.table import Table

from ..base import InputError, check_output_folder
from ._common import (add_json_arg, add_machine_args, add_state_arg, axis_config, check_run_outputs, dumps, machine_of,
                     positive, table_console)


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "errormap"
HELP = "error map accuracy per element order; compensation tables"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    p.add_argument("--elements", type=positive, nargs="+", default=[4], metavar="N",
                   help="elements per linear axis (1 or 3 values; default 4)")
    p.add_argument("--order", type=int, nargs="+", choices=[1, 2, 3], default=[1, 2, 3],
                   help="element orders: 1 = 8-node, 2 = 20-node, 3 = 32-node (default all)")
    p.add_argument("--points", type=positive, default=2000, help="random test points (default 2000)")
    p.add_argument("--seed", type=int, default=0, help="seed of the test points")
    p.add_argument("--config", nargs="+", metavar="AXIS=VALUE", help="positions of the other axes (mm, deg)")
    p.add_argument("--table", help="write a trilinear compensation table (CSV) here")
    p.add_argument("--nodes", type=positive, nargs="+", default=[11], metavar="N",
                   help="table nodes per axis (1 or 3 values; default 11)")
    p.add_argument("--axis-tables", metavar="DIR", help="write ISO 230-1-named per-axis tables here")
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..compensation import ErrorMap, axis_tables, compensation_table

    machine = machine_of(args)
    check_run_outputs({"table": args.table}, machine=machine)
    check_output_folder("axis_tables", args.axis_tables)
    config = axis_config(machine, args.config, "--config")
    elements = args.elements * 3 if len(args.elements) == 1 else args.elements
    if len(elements) != 3:
        raise InputError(f"--elements takes 1 or 3 values, got {len(elements)}")
    rows = [ErrorMap.build(machine, elements, order, config=config).interpolation_error(args.points, args.seed)
            for order in args.order]
    report = {"machine": machine.name, "elements": list(elements), "orders": rows}
    if args.table:
        nodes = args.nodes * 3 if len(args.nodes) == 1 else args.nodes
        if len(nodes) != 3:
            raise InputError(f"--nodes takes 1 or 3 values, got {len(nodes)}")
        report["table"] = compensation_table(machine, args.table, nodes, config=config)
    if args.axis_tables:
        report["axis_tables"] = axis_tables(machine, args.axis_tables)
    if args.json:
        print(dumps(report))
        return 0
    console = table_console()
    table = Table(box=box.SIMPLE, title=f"{machine.name}: error map interpolation vs the direct model "
                                        f"({args.points} random points)")
    for col in ("element", "elements", "nodes", "max [um]", "RMS [um]", "RMS / error RMS"):
        table.add_column(escape(col), justify="right")
    for r in rows:
        table.add_row(f"{r['nodes_per_element']}-node", "x".join(map(str, r["elements"])), str(r["nodes"]),
                      f"{r['max_um']:.4f}", f"{r['rms_um']:.4f}", f"{100 * r['relative']:.2f} %")
    console.print(table)
    console.print(f"volumetric error RMS over the map: {rows[0]['error_rms_um']:.3f} um")
    if args.table:
        t = report["table"]
        print(f"wrote {t['file']}: {t['rows']} nodes, corrections up to {t['max_correction_um']:.2f} um; with "
              f"trilinear interpolation the residual is {t['residual_with_table_max_um']:.3f} um max, "
              f"{t['residual_with_table_rms_um']:.3f} um RMS")
    for f in report.get("axis_tables", []):
        print(f"wrote {f}")
    return 0
