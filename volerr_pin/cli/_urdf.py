"""volerr urdf: the URDF with error joints injected."""

from __future__ import annotations

import sys

from ..base import write_text
from ._common import add_machine_args, add_out_arg, check_run_outputs, machine_of


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "urdf"
HELP = "the URDF with error joints injected"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_out_arg(p, "file to write (default: stdout)", suffixes=(".urdf", ".xml"), what="a URDF")
    p.set_defaults(func=run)


def run(args) -> int:
    machine = machine_of(args)
    check_run_outputs({"out": args.out}, machine=machine)
    text = machine.injected_urdf()
    if args.out:
        write_text(args.out, text)
        print(f"wrote {args.out}: {len(machine.error_joints)} error joints in "
              f"{len(machine.error_joints) // 6} groups", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
