"""volerr urdf: the URDF with error joints injected."""

from __future__ import annotations

import sys

from ..safeio import write_text
from .common import add_machine_args, check_run_outputs, machine_of


def add_parser(sub) -> None:
    p = sub.add_parser("urdf", help="the URDF with error joints injected")
    add_machine_args(p)
    p.add_argument("-o", "--output", help="file to write (default: stdout)")
    p.set_defaults(func=run)


def run(args) -> int:
    machine = machine_of(args)
    check_run_outputs({"output": args.output}, machine=machine)
    text = machine.injected_urdf()
    if args.output:
        write_text(args.output, text)
        print(f"wrote {args.output}: {len(machine.error_joints)} error joints in "
              f"{len(machine.error_joints) // 6} groups", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0
