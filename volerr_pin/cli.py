"""Command-line interface: ``volerr <command>``. It wires library calls; it computes nothing.

Exit status 0 on success, 2 on bad input (one line on stderr naming the culprit).
``--json`` prints exactly one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rich import box
from rich.console import Console
from rich.table import Table

from . import __version__
from .describe import machine_info
from .errors import VolerrError
from .machine import load_machine
from .workspace import error_summary, grid

DEFAULT_MACHINE = "vmc500"


def _console() -> Console:
    return Console(highlight=False, soft_wrap=True)


def _print_info(console: Console, info: dict) -> None:
    console.print(f"[bold]{info['machine']}[/bold]: {info['description']}")
    console.print(f"source: {info['source']}")
    console.print(f"tool frame '{info['tool_frame']}', workpiece frame '{info['workpiece_frame']}'")
    chains = info["chains"]
    console.print(f"tool chain: bed - {' - '.join(chains['tool']) or '(no axis)'} - tool;  "
                  f"workpiece chain: bed - {' - '.join(chains['workpiece']) or '(no axis)'} - workpiece")
    table = Table(box=box.SIMPLE, title="axes")
    for col in ("axis", "joint", "kind", "travel", "chain", "errors frame"):
        table.add_column(col)
    for a in info["axes"]:
        table.add_row(a["name"], a["joint"], a["kind"],
                      f"{a['travel'][0]:g} .. {a['travel'][1]:g} {a['unit']}", a["chain"],
                      a["errors_frame"])
    console.print(table)
    terms = Table(box=box.SIMPLE, title=f"error terms ({len(info['components'])} components, "
                                        f"{info['n_parameters']} coefficients)")
    for col in ("component", "of", "kind", "range over travel", "coefficients"):
        terms.add_column(col)
    for c in info["components"]:
        terms.add_row(c["name"], c["owner"], "+".join(c["kinds"]),
                      f"{c['min']:+.2f} .. {c['max']:+.2f} {c['unit']}", str(len(c["parameters"])))
    console.print(terms)
    by_kind = ", ".join(f"{k}: {len(v)}" for k, v in info["terms_by_kind"].items())
    console.print(f"terms by kind: {by_kind}")


def _print_summary(console: Console, summary: dict, axes) -> None:
    worst = ", ".join(f"{a}={v:.1f}" for a, v in zip(axes, summary["worst_q"]))
    console.print(
        f"volumetric error over {summary['points']} workspace points: "
        f"max {summary['max_position_um']:.2f} um, RMS {summary['rms_position_um']:.2f} um "
        f"(max |dx| {summary['max_abs_um']['x']:.2f}, |dy| {summary['max_abs_um']['y']:.2f}, "
        f"|dz| {summary['max_abs_um']['z']:.2f} um); worst at {worst}; "
        f"max orientation error {summary['max_orientation_arcsec']:.2f} arcsec")


def cmd_info(args) -> int:
    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    info = machine_info(machine)
    if args.json:
        print(json.dumps(info))
    else:
        _print_info(_console(), info)
    return 0


def cmd_urdf(args) -> int:
    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    text = machine.injected_urdf()
    if args.output:
        Path(args.output).write_text(text)
        print(f"wrote {args.output}: {len(machine.error_joints)} error joints in "
              f"{len(machine.error_joints) // 6} groups", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


def cmd_demo(args) -> int:
    machine = load_machine(args.machine)
    info = machine_info(machine)
    summary = error_summary(machine, grid(machine, args.grid))
    if args.json:
        print(json.dumps({"machine": info, "summary": summary}))
        return 0
    console = _console()
    _print_info(console, info)
    _print_summary(console, summary, machine.axes)
    return 0


def _machine_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("machine", help="bundled machine name, machine folder, spec (.toml) or URDF")
    parser.add_argument("--tool-frame", help="tool frame (bare URDF only)")
    parser.add_argument("--workpiece-frame", help="workpiece frame (bare URDF only)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="volerr", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"volerr_pin {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("demo", help="the main job on the default machine")
    p.add_argument("--machine", default=DEFAULT_MACHINE, help=f"machine (default {DEFAULT_MACHINE})")
    p.add_argument("--grid", type=int, default=11, help="grid points per axis (default 11)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("info", help="axes, chains, error terms by kind, travels")
    _machine_args(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("urdf", help="the URDF with error joints injected")
    _machine_args(p)
    p.add_argument("-o", "--output", help="file to write (default: stdout)")
    p.set_defaults(func=cmd_urdf)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except VolerrError as err:
        print(f"volerr: error: {err}", file=sys.stderr)
        return 2
    except OSError as err:
        print(f"volerr: error: {err.filename or ''}: {err.strerror}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
