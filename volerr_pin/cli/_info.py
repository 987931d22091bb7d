"""volerr info: axes, chains, error terms by kind, travels."""

from __future__ import annotations

from ._common import add_json_arg, add_machine_args, add_state_arg, dumps, machine_of, table_console
from ._tables import print_info


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "info"
HELP = "axes, chains, error terms by kind, travels"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_json_arg(p)
    add_state_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..model import machine_info

    machine = machine_of(args)
    info = machine_info(machine)
    if args.json:
        print(dumps(info))
    else:
        print_info(table_console(), info)
    return 0
