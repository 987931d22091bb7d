"""volerr iso230-2: ISO 230-2 evaluation of positioning runs."""

from __future__ import annotations

from pathlib import Path

from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..base import transaction
from ._common import add_json_arg, add_png_arg, check_run_outputs, dumps, note_unused, table_console


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "iso230-2"
HELP = "ISO 230-2 evaluation of positioning runs"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    p.add_argument("runs", help="CSV: target_mm,cycle,direction,deviation_um (or _deg / _arcsec)")
    add_png_arg(p, "write the standard's picture (PNG)")
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..applications.iso230 import evaluate_runs
    from ..measurements import read_runs

    check_run_outputs({"png": args.png}, [args.runs])
    runs = read_runs(args.runs)
    note_unused(args.runs, runs.unused)
    result = evaluate_runs(runs)
    if args.png:
        from ..viz import iso230_png

        with transaction() as tx:
            iso230_png(result, tx.path(args.png), title=f"ISO 230-2: {Path(args.runs).name}")
    if args.json:
        print(dumps({k: v for k, v in result.items() if k != "source"} | {"source": result["source"]}))
    else:
        _print_iso(table_console(), result)
        if args.png:
            print(f"wrote {args.png}")
    return 0


def _print_iso(console: Console, result: dict) -> None:
    unit = result["unit"]
    table = Table(box=box.SIMPLE, title=escape(f"ISO 230-2 per target ({result['source']}; deviations in {unit})"))
    cols = ["target", "n up", "mean up", "s up", "n down", "mean down", "s down", "B_i", "R_i"]
    for col in cols:
        table.add_column(col, justify="right")
    fmt = lambda v: "" if v is None else f"{v:.4g}"
    for p in result["positions"]:
        table.add_row(f"{p['target']:g} {result['target_unit']}", str(p.get("n_up", "")),
                      fmt(p.get("mean_up")), fmt(p.get("s_up")), str(p.get("n_down", "")),
                      fmt(p.get("mean_down")), fmt(p.get("s_down")), fmt(p.get("B")), fmt(p.get("R")))
    console.print(table)
    summary = Table(box=box.SIMPLE, title=escape(f"ISO 230-2 parameters [{unit}]"))
    for col in ("", "bidirectional", "positive (up)", "negative (down)"):
        summary.add_column(col, justify="right")
    summary.add_row("A  accuracy", fmt(result["A"]), fmt(result["A_up"]), fmt(result["A_down"]))
    summary.add_row("E  systematic deviation", fmt(result["E"]), fmt(result["E_up"]), fmt(result["E_down"]))
    summary.add_row("R  repeatability", fmt(result["R"]), fmt(result["R_up"]), fmt(result["R_down"]))
    summary.add_row("M  mean deviation", fmt(result["M"]), "", "")
    summary.add_row("B  reversal (max |B_i|)", fmt(result["B"]), "", "")
    summary.add_row("mean reversal", fmt(result["B_mean"]), "", "")
    console.print(summary)
