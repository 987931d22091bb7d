"""volerr testpiece: the contouring test piece as a program, for a machine's travel."""

from __future__ import annotations

import sys

from ..base.safeio import write_text
from .common import add_machine_args, add_out_arg, check_run_outputs, machine_of


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "testpiece"
HELP = "a test piece as an NC program, to predict like any program"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    p.add_argument("--kind", choices=["contouring"], default="contouring",
                   help="contouring: square, diamond and circle in the form of ISO 10791-7's contouring test piece")
    p.add_argument("--size", type=float, metavar="MM",
                   help="the square's side (default 160, or less to fit the X and Y travel)")
    p.add_argument("--feed", type=float, default=500.0, help="feed rate, mm/min (default 500)")
    add_out_arg(p, "program to write", what="an NC program", required=True)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..applications.part import contouring_test_piece

    machine = machine_of(args)
    check_run_outputs({"out": args.out}, machine=machine)
    text = contouring_test_piece(machine, None if args.size is None else args.size * 1e-3, feed=args.feed)
    write_text(args.out, text)
    print(f"wrote {args.out}: {text.splitlines()[0].strip('()')}", file=sys.stderr)
    return 0
