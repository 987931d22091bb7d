"""volerr dh: a URDF from a Denavit-Hartenberg table."""

from __future__ import annotations

from pathlib import Path

from ..base import InputError, write_text
from ._common import add_out_arg, check_run_outputs


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "dh"
HELP = "a URDF from a Denavit-Hartenberg table (standard or modified)"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    p.add_argument("table", help="DH table: joint,type,a_mm,alpha_deg,d_mm,theta_deg,lower,upper "
                                 "with '# convention:' and '# tool:' header lines")
    add_out_arg(p, "URDF file to write", suffixes=(".urdf", ".xml"), what="a URDF", required=True)
    p.add_argument("--name", help="robot name (default: the table's file name)")
    p.add_argument("--base-frame", default="base", help="name of the base frame (default base)")
    p.add_argument("--tool-frame", default="tool0", help="name of the tool frame (default tool0)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..applications.dh import dh_to_urdf, read_dh

    check_run_outputs({"out": args.out}, [args.table])
    rows, convention, tool = read_dh(args.table)
    try:
        text = dh_to_urdf(rows, convention, name=args.name or Path(args.table).stem, base=args.base_frame,
                          tool=args.tool_frame, tool_transform=tool)
    except InputError as err:
        if err.parameters:  # an option's value
            raise
        raise InputError(f"{args.table}: {err}") from None
    except ValueError as err:
        raise InputError(f"{args.table}: {err}") from None
    write_text(args.out, text)
    print(f"wrote {args.out}: {len(rows)} joints ({convention} DH), frames '{args.base_frame}' and "
          f"'{args.tool_frame}'; load it with: volerr info {args.out} --tool-frame {args.tool_frame} "
          f"--workpiece-frame {args.base_frame}")
    return 0
