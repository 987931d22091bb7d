"""volerr compensate: a compensated NC program."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from ..errors import InputError
from ..safeio import read_text, require_memory, transaction
from .common import add_json_arg, add_machine_args, add_state_arg, axis_config, check_run_outputs, dumps, machine_of

#: memory the compensation holds per byte of program (about 25 kB per block of about 25 bytes)
BYTES_PER_PROGRAM_BYTE = 1000


def add_parser(sub) -> None:
    p = sub.add_parser("compensate", help="compensated NC program")
    add_machine_args(p)
    add_state_arg(p)
    p.add_argument("program", help="NC program (ISO 6983 / RS-274)")
    p.add_argument("-o", "--output", required=True, help="compensated program to write")
    p.add_argument("--tol-um", type=float, default=1.0, help="position tolerance along every move (default 1)")
    p.add_argument("--tol-urad", type=float,
                   help="tool-axis tolerance on machines with rotary axes (default 10 per um of --tol-um)")
    p.add_argument("--report", help="write the report (JSON) here")
    p.add_argument("--pass-through", action="store_true",
                   help="keep blocks that cannot be compensated (canned cycles, macros) and warn")
    p.add_argument("--method", choices=["newton", "recursive"], default="newton",
                   help="point compensation scheme (default newton)")
    p.add_argument("--png", help="also draw the error along each move before and after (PNG)")
    p.add_argument("--origin", nargs="+", metavar="AXIS=VALUE",
                   help="axis positions of the program zero (the work offset, G54 ...; mm, deg)")
    add_json_arg(p, "print the report as one JSON object")
    p.set_defaults(func=run)


def run(args) -> int:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from ..gcode import Program

    machine = machine_of(args)
    path = Path(args.program)
    check_run_outputs({"output": args.output, "report": args.report, "png": args.png}, [path], machine)
    text = read_text(path, InputError, "program file")  # a regular UTF-8 file, line ends as written
    require_memory(len(text) * BYTES_PER_PROGRAM_BYTE, f"compensating {path}")
    offset = axis_config(machine, args.origin, "--origin")
    origin = [offset.get(axis, 0.0) for axis in machine.axes] if offset else None
    program = Program(machine, tol_um=args.tol_um, tol_urad=args.tol_urad, pass_through=args.pass_through,
                      method=args.method, source=str(path), origin=origin)
    console = Console(stderr=True, highlight=False)
    with Progress(TextColumn("compensating"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                  console=console, transient=True, disable=args.json or not console.is_terminal) as bar:
        task = bar.add_task("", total=text.count("\n") + 1)
        result = program.compensate(text, progress=lambda n: bar.update(task, completed=n))
    report = {"machine": machine.name, "input": str(path), "output": str(args.output), **program.report.to_dict()}
    with transaction() as tx:  # the program, its report and picture are all written, or none
        tx.path(args.output).write_text(result, encoding="utf-8", newline="")
        if args.png:
            from ..viz.plots import compensation_png

            compensation_png(program.report, tx.path(args.png), title=f"{machine.name}: {path.name}")
            report["png"] = str(args.png)
        if args.report:
            tx.path(args.report).write_text(dumps(report, indent=2) + "\n", encoding="utf-8")
    if args.json:
        print(dumps(report))
        return 0
    r = program.report
    print(f"{path} -> {args.output}: {r.blocks_in} blocks in, {r.blocks_out} out; {r.moves} moves in "
          f"{r.pieces} pieces ({r.arcs_kept} arcs kept as arcs, {r.arcs_as_lines} as lines)")
    print(f"largest error along the moves: {r.max_before_um:.2f} um before, {r.max_residual_um:.3f} um after "
          f"compensation (tolerance {r.tolerance_um:g} um)")
    for w in r.warnings:
        print(f"warning: {w}")
    for key in ("report", "png"):
        if getattr(args, key):
            print(f"wrote {getattr(args, key)}")
    return 0
