"""volerr field: a Rerun recording of the error field (and a PNG slice)."""

from __future__ import annotations

import sys

from ..base import InputError, transaction
from ._common import (add_json_arg, add_machine_args, add_out_arg, add_state_arg, axis_config, check_run_outputs, dumps,
                     machine_of, positive)
from ._tables import print_recording


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "field"
HELP = "Rerun recording of the error field"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    add_out_arg(p, "recording file (.rrd)", suffixes=(".rrd",), what="a Rerun recording", required=True)
    p.add_argument("--grid", type=positive, nargs="+", metavar="N",
                   help="points per linear axis (one value for all, or one per linear axis; default 9)")
    p.add_argument("--scale", type=float, help="arrow magnification (default: a round factor "
                                               "making the largest arrow ~8 %% of the workspace)")
    p.add_argument("--config", nargs="+", metavar="AXIS=VALUE",
                   help="axis positions (mm, deg) of the machine drawn in the recording, and of the axes the "
                        "--png slice does not span (default mid travel)")
    p.add_argument("--slice", nargs=2, metavar="AXIS",
                   help="the two linear axes the --png slice spans (default the first two, e.g. X Y)")
    p.add_argument("--sweep-steps", type=int, default=24,
                   help="steps of the rotary-axis sweep (0: none; default 24)")
    p.add_argument("--png", help="also write a static picture of an error-field slice")
    viewer = p.add_mutually_exclusive_group()
    viewer.add_argument("--spawn", action="store_true", help="also stream to a new Rerun viewer")
    viewer.add_argument("--connect", metavar="URL", help="also stream to a running viewer (gRPC URL)")
    add_json_arg(p)
    p.set_defaults(func=run)


def _plane(machine, names, png) -> tuple[str, str] | None:
    """The two linear axes of ``--slice``, checked (None for the default)."""
    if names is None:
        return None
    if not png:
        raise InputError("--slice: it chooses the plane of the --png picture; give --png too", parameters=("slice",))
    kinds = dict(zip(machine.axes, machine.axis_kinds))
    for name in names:
        if name not in kinds:
            raise InputError(f"--slice: {name!r} is not an axis of {machine.name} (axes: {', '.join(machine.axes)})",
                             parameters=("slice",))
        if kinds[name] != "linear":
            raise InputError(f"--slice: {name} is a rotary axis; a slice spans two linear axes", parameters=("slice",))
    if names[0] == names[1]:
        raise InputError(f"--slice: give two different axes, got {names[0]} twice", parameters=("slice",))
    return tuple(names)


def run(args) -> int:
    from ..fit import rank
    from ..model import sample

    from ..viz import record_field

    machine = machine_of(args)
    check_run_outputs({"out": args.out, "png": args.png}, machine=machine)
    config = axis_config(machine, args.config, "--config")
    plane = _plane(machine, args.slice, args.png)
    if args.scale is not None and not args.scale > 0:
        raise InputError(f"--scale must be positive, got {args.scale}")
    ranking = rank(machine, sample(machine, 1024)).to_dict(top=15)
    with transaction() as tx:  # the recording and the picture are both written, or neither
        summary = record_field(machine, tx.path(args.out), counts=args.grid, config=config, scale=args.scale,
                               ranking=ranking, sweep_steps=args.sweep_steps, spawn=args.spawn,
                               connect=args.connect)
        if args.png:
            from ..viz import field_slice_png

            field_slice_png(machine, tx.path(args.png), config, plane=plane)
            summary["png"] = args.png
        summary = tx.final(summary)
    if args.png and config:
        spanned = plane or tuple(a for a, k in zip(machine.axes, machine.axis_kinds) if k == "linear")[:2]
        inside = [a for a in config if a in spanned]
        if inside:
            print(f"volerr: note: --config {', '.join(inside)}: the --png slice spans "
                  f"{' and '.join(spanned)} over their whole travel; --config places the recording's machine "
                  "and the axes the slice does not span", file=sys.stderr)
    if args.json:
        print(dumps(summary))
    else:
        print_recording(summary)
        if args.png:
            print(f"wrote {args.png}")
    return 0
