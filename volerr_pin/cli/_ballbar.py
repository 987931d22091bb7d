"""volerr ballbar: ISO 230-4 circular test evaluation."""

from __future__ import annotations

from pathlib import Path

from rich import box
from rich.markup import escape
from rich.table import Table

from ..base import transaction
from ._common import add_json_arg, add_png_arg, check_run_outputs, dumps, note_unused, table_console


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "ballbar"
HELP = "ISO 230-4 circular test: circular deviation, hysteresis, radial deviation"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    p.add_argument("file", help="ballbar file: angle_deg, deviation_um[, direction] with '# plane:' and "
                                "'# radius:' header lines")
    add_json_arg(p)
    add_png_arg(p, "write the ISO 230-4 polar picture (PNG)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..measurements import evaluate_circular, read_ballbar

    check_run_outputs({"png": args.png}, [args.file])
    run = read_ballbar(args.file)
    note_unused(args.file, run.unused)
    result = evaluate_circular(run)
    if args.png:
        from ..viz import ballbar_png

        with transaction() as tx:
            ballbar_png(run, result, tx.path(args.png), title=f"ISO 230-4: {Path(args.file).name}")
        result["png"] = str(args.png)
    if args.json:
        print(dumps(result))
        return 0
    out = table_console()
    out.print(escape(f"circular test {result['source']}: plane {', '.join(result['plane'])}, radius "
                     f"{result['radius_mm']:g} mm, {result['n_ccw']} samples counter-clockwise, "
                     f"{result['n_cw']} clockwise"))
    table = Table(box=box.SIMPLE, title=escape("ISO 230-4 [um]"))
    for col in ("figure", "value", "meaning"):
        table.add_column(col, justify="right" if col == "value" else "left")
    rows = [("G", "circular deviation, both directions, about the least-squares centre"),
            ("G_ccw", "circular deviation, counter-clockwise"), ("G_cw", "circular deviation, clockwise"),
            ("H", "circular hysteresis (largest radial gap between the directions)"),
            ("F_max", "largest radial deviation about the nominal centre"),
            ("F_min", "smallest radial deviation about the nominal centre"),
            ("radius_error_um", "mean radius minus nominal (bar length and scale together)")]
    for key, meaning in rows:
        if result.get(key) is not None:
            table.add_row(key, f"{result[key]:.3f}", meaning)
    out.print(table)
    cx, cy = result["centre_offset_um"]
    out.print(f"least-squares centre off the nominal one by {cx:+.3f} um along {result['plane'][0]}, "
              f"{cy:+.3f} um along {result['plane'][1]} (the set-up, mostly)")
    if args.png:
        print(f"wrote {args.png}")
    return 0
