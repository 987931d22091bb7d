"""volerr compensate: a compensated NC program, read, compensated and written as a stream."""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console

from ..base import transaction
from ._common import (add_dialect_args, add_json_arg, add_machine_args, add_out_arg, add_program_position_args,
                     add_state_arg, check_run_outputs, dumps, machine_of, program_reading, tolerance_um)


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "compensate"
HELP = "compensated NC program"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    p.add_argument("program", help="NC program (ISO 6983 / RS-274)")
    add_out_arg(p, "compensated program to write", what="an NC program", required=True)
    p.add_argument("--tol-um", type=tolerance_um, default=1.0, help="position tolerance along every move (default 1)")
    p.add_argument("--tol-urad", type=float,
                   help="tool-axis tolerance on machines with rotary axes (default 10 per um of --tol-um)")
    p.add_argument("--report", help="write the report (JSON) here")
    kept = p.add_mutually_exclusive_group()
    kept.add_argument("--strict", action="store_true",
                      help="refuse blocks that cannot be compensated (canned cycles, macros, subprograms, polar or "
                           "cylindrical interpolation ...) instead of keeping them unchanged and naming them")
    kept.add_argument("--pass-through", action="store_true",
                      help="also keep G codes the reader does not know (refused by default: they may change how "
                           "the blocks after them read); blocks that cannot be compensated are kept and named "
                           "anyway")
    p.add_argument("--programming", choices=["axes", "tool-tip"], default="axes",
                   help="what the coordinates are when the program starts: axis positions (default), or the tool "
                        "tip in the workpiece frame with rotary axis positions (RTCP on); G43.4 / TRAORI and G49 / "
                        "TRAFOOF in the program switch")
    p.add_argument("--method", choices=["newton", "recursive"], default="newton",
                   help="point compensation scheme (default newton)")
    p.add_argument("--png", help="also draw the error along each move before and after (PNG)")
    add_program_position_args(p)
    add_dialect_args(p)
    p.add_argument("--most-blocks", type=int, default=None, metavar="N",
                   help="the most blocks a program whose loops and subroutine calls are followed may run "
                        "(default: a million); a program that would run more is refused, naming the loop")
    add_json_arg(p, "print the report as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.progress import BarColumn, DownloadColumn, Progress, TextColumn, TimeRemainingColumn

    from ..compensation.gcode import Program, ProgramFile
    from ..compensation.gcode import MOST_BLOCKS, may_need

    machine = machine_of(args)
    path = Path(args.program)
    check_run_outputs({"out": args.out, "report": args.report, "png": args.png},
                      [path] + ([Path(args.work_offsets)] if args.work_offsets else []), machine)
    source = ProgramFile(path)  # a regular file; read as UTF-8 line by line
    program = Program(machine, tol_um=args.tol_um, tol_urad=args.tol_urad, strict=args.strict,
                      pass_through=args.pass_through, method=args.method, source=str(path),
                      programming=args.programming, detail=bool(args.png),
                      most_blocks=MOST_BLOCKS if args.most_blocks is None else args.most_blocks,
                      **program_reading(machine, args))
    program.decide(source.lines())   # the dialect given, or what the program's first lines say
    console = Console(stderr=True, highlight=False)
    with transaction() as tx:  # the program, its report and picture are all written, or none
        with open(tx.path(args.out), "w", encoding="utf-8", newline="") as out, \
                Progress(TextColumn("compensating"), BarColumn(), DownloadColumn(), TimeRemainingColumn(),
                         console=console, transient=True, disable=args.json or not console.is_terminal) as bar:
            task = bar.add_task("", total=max(source.size, 1))
            lines = source.lines()
            if may_need(source.lines(), str(path)):   # parameters, expressions or O-words: follow them
                lines = program.expand(list(source.lines()))
            program.run(lines, out.write, progress=lambda n: bar.update(task, completed=source.done))
        report = {"machine": machine.name, "input": str(path), "output": str(args.out),
                  **program.report.to_dict()}
        if args.png:
            from ..viz import compensation_png

            compensation_png(program.report, tx.path(args.png), title=f"{machine.name}: {path.name}")
            report["png"] = str(args.png)
        if args.report:
            tx.path(args.report).write_text(dumps(report, indent=2) + "\n", encoding="utf-8")
    if args.json:
        print(dumps(report))
        return 0
    r = program.report
    print(f"read as a {r.dialect} program ({r.dialect_said})")
    print(f"{path} -> {args.out}: {r.blocks_in} blocks in, {r.blocks_out} out; {r.moves} moves in "
          f"{r.pieces} pieces ({r.arcs_kept} arcs kept as arcs, {r.arcs_as_lines} as lines)")
    print(f"largest error along the moves: {r.max_before_um:.2f} um before, {r.max_residual_um:.3f} um after "
          f"compensation (tolerance {r.tolerance_um:g} um)")
    if r.passed_through:
        print(f"{r.passed_through} line(s) kept unchanged: they cannot be compensated (named below)")
    if r.expanded and r.expanded["profiles"]:
        print(f"{r.expanded['profiles']} lathe cycle(s) compensated through their profiles")
    if r.motion_compensated is not None:
        print(f"moves compensated: {r.moves} of {r.moves + r.moves_kept} ({100 * r.motion_compensated:.1f} %)")
    for w in r.warnings:
        print(f"warning: {w}")
    for key in ("report", "png"):
        if getattr(args, key):
            print(f"wrote {getattr(args, key)}")
    return 0

