"""volerr testpiece: a test piece (contouring, cone frustum) as a program, for a machine's travel."""

from __future__ import annotations

import sys

from ..base import write_text
from ._common import add_machine_args, add_out_arg, check_run_outputs, machine_of, millimetres


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "testpiece"
HELP = "a test piece as an NC program, to predict like any program"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    p.add_argument("--kind", choices=["contouring", "cone-frustum"], default="contouring",
                   help="contouring: square, diamond and circle in the form of ISO 10791-7's contouring test piece; "
                        "cone-frustum: the cone of NAS 979 (ISO 10791-7:2020), cut by the tool's flank on a "
                        "five-axis machine in tool-tip programming")
    p.add_argument("--size", type=millimetres, metavar="MM",
                   help="contouring: the square's side (default 160, or less to fit the X and Y travel); "
                        "cone-frustum: the base diameter (default 80)")
    p.add_argument("--tool-diameter", type=millimetres, default=20.0, metavar="MM",
                   help="cone-frustum: the end mill's diameter (default 20)")
    p.add_argument("--feed", type=float, default=500.0, help="feed rate, mm/min (default 500)")
    add_out_arg(p, "program to write", what="an NC program", required=True)
    p.set_defaults(func=run)


def run(args) -> int:
    machine = machine_of(args)
    check_run_outputs({"out": args.out}, machine=machine)
    size = None if args.size is None else args.size * 1e-3
    advice = ""
    if args.kind == "cone-frustum":
        from ..applications.part import cone_frustum_test_piece, section_heights

        text = cone_frustum_test_piece(machine, size, tool_diameter=args.tool_diameter * 1e-3, feed=args.feed)
        heights = ",".join(f"{h * 1e3:g}" for h in (section_heights(size) if size else section_heights()))
        advice = f"\npredict it with: --tool-diameter {args.tool_diameter:g} --cone-heights {heights}"
    else:
        from ..applications.part import contouring_test_piece

        text = contouring_test_piece(machine, size, feed=args.feed)
    write_text(args.out, text)
    print(f"wrote {args.out}: {text.splitlines()[0].strip('()')}{advice}", file=sys.stderr)
    return 0
