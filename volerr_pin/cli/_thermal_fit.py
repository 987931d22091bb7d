"""volerr thermal-fit: a thermal drift model from sensor series."""

from __future__ import annotations

import sys

from rich import box
from rich.markup import escape
from rich.table import Table

from ..base import transaction
from ._common import add_json_arg, add_png_arg, check_run_outputs, dumps, table_console


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "thermal-fit"
HELP = "thermal drift model from sensor data"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    p.add_argument("data", nargs="+", help="CSV files (one per experiment/batch), numeric columns")
    p.add_argument("--target", required=True, help="column to model (e.g. a thermal error)")
    p.add_argument("--sensors", nargs="+", help="columns to use (default: every other column)")
    p.add_argument("--lag", type=int, default=1, help="linear: target lags (0: static model; default 1)")
    p.add_argument("--method", choices=["linear", "gm11", "gm1n", "vwgm1n"], default="linear",
                   help="linear: least squares on the sensors (with --lag target lags; default); "
                        "gm11: grey model GM(1,1) of the target alone; gm1n: GM(1,N) with the sensors; "
                        "vwgm1n: GM(1,N) with its background weight chosen by one-step error")
    held = p.add_mutually_exclusive_group()
    held.add_argument("--holdout", type=float, default=0.0, help="hold out the last fraction of rows")
    held.add_argument("--test", nargs="+", help="held-out files (fit on DATA, predict these)")
    p.add_argument("--top", type=int, default=5, help="sensors to rank (default 5)")
    add_png_arg(p, "write measured vs modelled (PNG)")
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..measurements import read_series
    from ..applications.thermalfit import thermal_fit

    check_run_outputs({"png": args.png}, [*args.data, *(args.test or ())])
    data = read_series(args.data)
    test = read_series(args.test) if args.test else None
    result = thermal_fit(data, args.target, args.sensors, lag=args.lag, method=args.method,
                         holdout=args.holdout, test=test, rank_top=args.top)
    if args.png:
        from ..viz import thermal_fit_png

        with transaction() as tx:
            thermal_fit_png(result, data if test is None else None, tx.path(args.png))
    if args.json:
        print(dumps({k: v for k, v in result.items() if k not in ("fitted", "predicted_holdout")}))
        return 0
    for left in result["left_out"]:
        print(f"volerr: note: sensor '{left['sensor']}' left out: {left['reason']}", file=sys.stderr)
    console = table_console()
    lag = f", lag {result['lag']}" if result["lag"] is not None else ""
    console.print(escape(f"{result['method']} model of '{result['target']}'{lag} from "
                         f"{len(result['sensors'])} sensor(s); {result['n_fit']} fitted rows"))
    console.print(f"R^2 {result['r2']:.5f}, residual standard error {result['residual_se']:.4g} "
                  "(unit of the target)")
    coefficients = result.get("coefficients") or {}
    if coefficients:
        console.print(escape("fitted model: " + ", ".join(f"{name} {value:+.5g}" for name, value in coefficients.items())
                             + " (the constant in the target's unit, the others per unit of their column)"))
    if result["n_holdout"]:
        where = "of the test file(s)" if test is not None else f"the last {args.holdout * 100:g} % of the file"
        console.print(f"held out: {result['n_holdout']} rows, {where}; RMSE {result['rmse_holdout']:.4g}")
    table = Table(box=box.SIMPLE, title="most informative sensors (greedy forward selection)")
    table.add_column("#", justify="right")
    table.add_column("sensor")
    table.add_column("R^2 with the sensors so far", justify="right")
    for i, row in enumerate(result["sensor_ranking"], 1):
        table.add_row(str(i), escape(row["sensor"]), f"{row['r2']:.5f}")
    console.print(table)
    if args.png:
        print(f"wrote {args.png}")
    return 0
