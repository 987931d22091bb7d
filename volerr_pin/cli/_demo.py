"""volerr demo: the main job on one machine: info, error summary, ranking, recording, compensation."""

from __future__ import annotations

import sys

import numpy as np

from ..base import transaction
from ._common import (add_json_arg, add_machine_args, add_out_arg, add_state_arg, check_run_outputs, dumps, machine_of,
                     table_console)
from ._tables import print_info, print_ranking, print_recording, print_summary


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "demo"
HELP = "the main job on the default machine"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p, positional=False)
    p.add_argument("--grid", type=int, default=11, help="grid points per axis (default 11)")
    p.add_argument("--top", type=int, default=5, help="ranking rows to show (default 5)")
    add_out_arg(p, "Rerun recording to write (default volerr_demo.rrd)", suffixes=(".rrd",), what="a Rerun recording",
                default="volerr_demo.rrd")
    add_json_arg(p)
    add_state_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..fit import rank
    from ..model import machine_info
    from ..model import error_summary, grid, sample

    machine = machine_of(args)
    check_run_outputs({"out": args.out}, machine=machine)
    info = machine_info(machine)
    points = grid(machine, args.grid)          # one grid for the summary, field and compensation
    summary = error_summary(machine, points)
    from ..viz import record_field

    ranked = rank(machine, sample(machine, 1024))
    ranking = ranked.to_dict(top=args.top)
    linear = sum(k == "linear" for k in machine.axis_kinds)
    with transaction() as tx:
        recording = tx.final(record_field(machine, tx.path(args.out), ranking=ranked.to_dict(top=15),
                                          counts=[args.grid] * linear if linear else None))
    from ..compensation import evaluate_compensation

    compensation = evaluate_compensation(machine, points)
    if args.json:
        print(dumps({"machine": info, "summary": summary, "ranking": ranking,
                          "recording": recording, "compensation": compensation}))
        return 0
    console = table_console()
    print_info(console, info)
    print_summary(console, summary, machine.axes)
    if not np.any(machine.theta):
        print(f"volerr: note: {machine.name} has no error values: every error term is zero (a bare URDF gets "
              "zero-valued terms), so the field is zero and the ranking has no shares; give a spec with values "
              "(docs/spec-format.md) to see its errors", file=sys.stderr)
        console.print("no error values: the ranking below lists the terms, every one with a zero share")
    print_ranking(console, ranking, f"top {args.top} error sources at the tool "
                                     f"({ranking['points']} Sobol' points; share of all terms)")
    c = compensation
    beyond = (f"{c['points'] - c['reachable']} points need commands beyond the travel"
              if c["reachable"] < c["points"] else "")
    if c["max_after_um"] is None:
        console.print(f"compensation: every one of the {c['points']} grid points needs commands beyond the travel")
    elif c["reduction_percent"] is None:
        console.print(f"compensation: nothing to compensate at the {c['points']} grid points (the model's "
                      "errors are zero there)" + (f"; {beyond}" if beyond else ""))
    else:
        console.print(f"compensation (exact point compensation at the same {c['points']} grid points): max error "
                      f"{c['max_before_um']:.2f} -> {c['max_after_um']:.4f} um, RMS {c['rms_before_um']:.2f} -> "
                      f"{c['rms_after_um']:.4f} um ({c['reduction_percent']:.2f} % reduction"
                      + (f"; {beyond})" if beyond else ")"))
    print_recording(recording)
    return 0
