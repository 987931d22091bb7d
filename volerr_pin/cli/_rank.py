"""volerr rank: which error sources matter at the tool."""

from __future__ import annotations

import sys

from ..base import transaction
from ._common import (add_json_arg, add_machine_args, add_state_arg, check_run_outputs, dumps, machine_of, positive,
                     table_console)
from ._tables import print_groups, print_ranking


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "rank"
HELP = "sensitivity ranking of the error sources"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    p.add_argument("--points", type=positive, default=2048, help="workspace points (Sobol', default 2048)")
    p.add_argument("--seed", type=int, default=0, help="seed of the workspace sample")
    p.add_argument("--tolerances", help="TOML file: term -> expected magnitude (EXX_um = 5, ...)")
    p.add_argument("--top", type=positive, help="show the K most influential only")
    p.add_argument("--direction", choices=["x", "y", "z", "all"], default="all",
                   help="tool error direction to measure (default all)")
    p.add_argument("--by", choices=["component", "parameter"], default="component",
                   help="rank component errors or single coefficients")
    p.add_argument("--png", help="also write a bar chart of the ranking")
    out = p.add_mutually_exclusive_group()
    add_json_arg(out)
    out.add_argument("--csv", action="store_true", help="print the ranking as CSV")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..fit import rank, read_tolerances, tool_identifiability

    machine = machine_of(args)
    check_run_outputs({"png": args.png}, [args.tolerances], machine)
    tolerances = read_tolerances(args.tolerances, machine) if args.tolerances else None
    # both sample the same points (Sobol', same seed), each sized against the free memory first
    ranking = rank(machine, points=args.points, seed=args.seed, tolerances=tolerances, direction=args.direction,
                   by=args.by)
    result = ranking.to_dict(top=args.top)
    groups = [g.to_dict() for g in tool_identifiability(machine, points=args.points, seed=args.seed)]
    if args.png:
        from ..viz import ranking_png

        with transaction() as tx:
            ranking_png(result, tx.path(args.png), top=args.top or 15)
        print(f"wrote {args.png}", file=sys.stderr)
    if args.json:
        result["identifiability"] = groups
        print(dumps(result))
    elif args.csv:
        sys.stdout.write(_ranking_csv(result))
    else:
        console = table_console()
        what = "tolerances" if tolerances else "current error values"
        if args.state:
            what += ", state " + " ".join(args.state)
        if "directions" in machine.covariates_used and "directions" not in machine.state:
            what += "; backlash at its mean: no directions in --state"
            print("volerr: note: no directions in --state: backlash terms are taken at their mean, half-way "
                  "between the two approach directions (add directions=+1,-1,... to rank one side)", file=sys.stderr)
        print_ranking(console, result, f"{machine.name}: tool-point error by {args.by} "
                                        f"({args.points} points, direction {args.direction}, {what})")
        from ..fit.identify import parameter_units

        print_groups(console, groups, units=parameter_units(machine))
    return 0


def _ranking_csv(ranking: dict) -> str:
    import csv
    import io

    buffer = io.StringIO()
    fields = ["parameter", "term", "axis", "max_um", "rms_um", "share_of_all", "share", "per_unit_max",
              "per_unit_rms", "per_unit", "contribution_degree", "orientation_max_arcsec",
              "orientation_share"]
    writer = csv.DictWriter(buffer, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in ranking["ranking"]:
        writer.writerow(row)
    return buffer.getvalue()
