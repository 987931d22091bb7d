"""What every command shares: machine and state options, the AXIS=VALUE parser, JSON output,
consoles and progress bars."""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from rich.console import Console

from ..base import (PLAUSIBLE, InputError, VolerrError, axis_values_to_si, check_outputs, describe_range, parse_axis_values,
                    same_file)

if TYPE_CHECKING:   # the model loads Pinocchio, SciPy and Numba: imported where a command runs, not to parse
    from ..model import Machine

DEFAULT_MACHINE = "vmc500"

#: library names -> the options that give them, where the two are not spelled alike
#: (``pass_through`` -> ``--pass-through`` needs no entry)
OPTION_OF = {"Machine.with_state": "--state", "counts": "--grid", "run_axis": "--axis", "module": "--module-mm",
             "pressure_angle": "--pressure-angle-deg", "face_width": "--face-width-mm", "tooth_numbers": "--tooth",
             "translation": "--translation-mm", "rotation": "--rotation-deg", "package_dirs": "--package-dir",
             "rank_top": "--top", "tool": "--tool-frame", "base": "--base-frame",
             "points_per_axis": "--grid"}


def in_cli_words(err: VolerrError) -> str:
    """The message of a library error with the parameters it names (``holdout``,
    ``Machine.with_state``) said as the options that give them (``--holdout``, ``--state``):
    the first mention of each is the parameter; later ones may be plain words ("terms: EQQ
    not among the error terms")."""
    message = str(err)
    for name in getattr(err, "parameters", ()):
        option = OPTION_OF.get(name, "--" + name.replace("_", "-"))
        message = re.sub(rf"(?<![\w.-]){re.escape(name)}(?![\w-])", option, message, count=1)
    return message


def finite(value):
    """JSON has no NaN or infinity: non-finite numbers become null (numpy values plain)."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def dumps(value, **kwargs) -> str:
    """Strict JSON (no NaN / Infinity tokens) of a report."""
    return json.dumps(finite(value), allow_nan=False, **kwargs)


def table_console() -> Console:
    """The console for tables on stdout."""
    # tables are wide: give files and pipes room instead of rich's 80-column default
    width = None if sys.stdout.isatty() else 160
    return Console(highlight=False, soft_wrap=True, width=width)


def note_unused(path: str, unused) -> None:
    """One line on stderr naming what a file gives that the command does not use."""
    if unused:
        print(f"volerr: note: {path}: not used: {', '.join(unused)}", file=sys.stderr)


class FitProgress:
    """A progress bar on stderr for fits that take more than a moment (terminals only).

    ``with FitProgress(enabled) as progress`` gives ``progress(stage, step)`` or None. The bar is
    drawn by the updates, at most every :attr:`REFRESH_S`, not by a thread of its own.
    """

    REFRESH_S = 0.1

    def __init__(self, enabled: bool):
        self.console = Console(stderr=True, highlight=False)
        self.enabled = enabled and self.console.is_terminal

    def __enter__(self):
        if not self.enabled:
            return None
        from rich.progress import Progress

        self.bar = Progress(console=self.console, transient=True, auto_refresh=False)
        self.bar.__enter__()
        self.tasks = {}
        self.drawn = -math.inf
        return self.update

    def update(self, stage: str, step: int) -> None:
        if stage not in self.tasks:
            self.tasks[stage] = self.bar.add_task(stage, total=None)
            self.drawn = -math.inf
        self.bar.update(self.tasks[stage], completed=step)
        now = time.monotonic()
        if now - self.drawn >= self.REFRESH_S:
            self.bar.refresh()
            self.drawn = now

    def __exit__(self, *exc):
        if self.enabled:
            self.bar.__exit__(*exc)
        return False


# ------------------------------------------------------------------ files

#: options whose file is a picture: its suffix must be a format the pictures can be written in
PICTURES = ("png",)

#: the suffixes of the files the commands write, and what each holds
WRITTEN = {".toml": "a spec or tolerance file (TOML)", ".rrd": "a Rerun recording", ".csv": "a table (CSV)",
           ".json": "a report (JSON)", ".urdf": "a URDF", ".png": "a picture", ".svg": "a picture",
           ".pdf": "a picture"}


def machine_files(machine: Machine) -> list[Path]:
    """The files a machine was read from (its spec and URDF): inputs no command may write over."""
    return [Path(p) for p in {os.fspath(machine.spec.source), os.fspath(machine.spec.urdf)} if Path(p).is_file()]


def distinct_inputs(paths, option: str) -> None:
    """Refuse a file given twice among ``paths`` (by path, link or hard link): its data would
    count twice."""
    paths = list(paths)
    for i, a in enumerate(paths):
        for b in paths[:i]:
            if same_file(a, b):
                raise InputError(f"{option}: {a} is given twice" + ("" if str(a) == str(b) else f" (as {b})")
                                 + "; its data would count twice")


def check_run_outputs(outputs: dict, inputs=(), machine: Machine | None = None) -> dict[str, Path]:
    """Every file a command will write, checked before it does any work (``safeio.check_outputs``):
    none is an input (``inputs`` and the machine's own files), a folder or a device, or lies in
    a missing or read-only folder; pictures have a suffix they can be written in.

    ``outputs`` maps the option's name as Python spells it (``"out"``, ``"png"``) to its value;
    the names are said as options (``--out``) in messages."""
    checked = check_outputs(outputs, [*inputs, *(machine_files(machine) if machine is not None else ())])
    for name in PICTURES:
        if name in checked:
            from ..viz import picture_format

            picture_format(checked[name], name)
    return checked


# ------------------------------------------------------------------ options


def check_out_name(args: argparse.Namespace) -> None:
    """Refuse an ``-o/--out`` named as another kind of file than the command writes (its suffix
    against :func:`add_out_arg`'s ``suffixes``), before any work."""
    out, kind = getattr(args, "out", None), getattr(args, "out_kind", None)
    if out is None or kind is None:
        return
    suffixes, what = kind
    suffix = Path(out).suffix.lower()
    if suffixes is None and suffix in WRITTEN:
        raise InputError(f"out: {out} is named as {WRITTEN[suffix]}, but this writes {what}", parameters=("out",))
    if suffixes is not None and suffix not in suffixes:
        raise InputError(f"out: this writes {what}: its name ends in {' or '.join(suffixes)}, got {out}",
                         parameters=("out",))


def add_out_arg(parser: argparse.ArgumentParser, help: str, *, suffixes: tuple[str, ...] | None = None,
                what: str = "", required: bool = False, metavar: str = "FILE", default: str | None = None) -> None:
    """``-o/--out``, the file (or folder, with ``what`` empty) a command writes: the one
    spelling of every command. Its suffix is checked against ``suffixes`` (None: a file of
    none of the kinds the commands write elsewhere) by :func:`check_out_name`, before any work."""
    parser.add_argument("-o", "--out", metavar=metavar, help=help, default=default, required=required)
    if what:
        parser.set_defaults(out_kind=(suffixes, what))


def add_png_arg(parser: argparse.ArgumentParser, help: str) -> None:
    """``--png``, the picture a command draws (its format checked with the outputs)."""
    parser.add_argument("--png", metavar="FILE.png", help=help)


def positive(text: str) -> int:
    """argparse type: a positive integer."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def number_of(text: str, what: str) -> float:
    """An option's text as a float, or argparse's refusal ``expected WHAT, got 'TEXT'``."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None


def _plausible(text: str, value: float, limit: str, unit: str, scale: float) -> float:
    """``value`` unless beyond what a spec's value of the kind may be (``PLAUSIBLE[limit]``)."""
    if abs(value) * scale > PLAUSIBLE[limit][1]:
        raise argparse.ArgumentTypeError(f"{text} {unit} is implausible: {describe_range(limit, unit, scale)}")
    return value


def millimetres(text: str) -> float:
    """argparse type: a finite length in mm, not negative, within what a position may be (1 km)."""
    value = number_of(text, "a length in mm")
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"expected a finite length in mm, not negative, got {text!r}")
    return _plausible(text, value, "position_length", "mm", 1e-3)


def tolerance_um(text: str) -> float:
    """argparse type: a tolerance in um: positive, finite, within what a deviation may be (1 m)."""
    value = number_of(text, "a tolerance in um")
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive, finite tolerance in um, got {text!r}")
    return _plausible(text, value, "error_length", "um", 1e-6)


def millimetre_list(text: str) -> tuple[float, ...]:
    """argparse type: 'A,B,...' lengths in mm, not negative."""
    return tuple(millimetres(v) for v in text.split(","))


def add_machine_args(parser: argparse.ArgumentParser, positional: bool = True) -> None:
    """The machine (positional, or ``--machine`` with the default machine) and the frames of a
    bare URDF."""
    if positional:
        action = parser.add_argument("machine", help="bundled machine name, machine folder, spec (.toml) or URDF")
    else:
        action = parser.add_argument("--machine", default=DEFAULT_MACHINE, help=f"machine (default {DEFAULT_MACHINE})")
    action.completer = complete_machine
    parser.add_argument("--tool-frame", help="tool frame (bare URDF only)")
    parser.add_argument("--workpiece-frame", help="workpiece frame (bare URDF only)")
    parser.add_argument("--package-dir", action="append", metavar="DIR",
                        help="folder holding the packages that package:// meshes name (repeatable); meshes are read "
                             "only from there and from the URDF's own folder")


def complete_machine(prefix: str, **kwargs) -> list[str]:
    """Shell completion of a machine: the bundled machines' names, then folders, specs and URDFs
    (argcomplete calls it with the word typed so far)."""
    from argcomplete.completers import FilesCompleter

    from ..model import bundled_machines

    names = [n for n in bundled_machines() if n.startswith(prefix)]
    return names + list(FilesCompleter(("toml", "urdf"))(prefix, **kwargs))


def add_state_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--state", nargs="+", metavar="KEY=VALUE",
                        help="machine state for time-, temperature-, load- or direction-dependent terms: "
                             "t=SECONDS, SENSOR=DEGC, forces=FX,FY,FZ (N), directions=+1,-1,...")


def add_json_arg(parser, help: str = "print one JSON object") -> None:
    parser.add_argument("--json", action="store_true", help=help)


def machine_of(args) -> Machine:
    """The machine the options name, held in the ``--state`` given (when the command has one)."""
    from ..model import load_machine   # the model (Pinocchio, SciPy, Numba): only when a command runs

    machine = load_machine(args.machine, tool_frame=args.tool_frame, workpiece_frame=args.workpiece_frame,
                           package_dirs=args.package_dir or ())
    return with_state(machine, getattr(args, "state", None))


def with_state(machine: Machine, items: list[str] | None) -> Machine:
    """``--state t=3600 spindle=24.5 forces=0,0,-150 directions=1,-1,1`` -> the machine in
    that state (t in s, temperatures in degC by sensor name, forces in N)."""
    if not items:
        return machine
    t, temps, forces, directions = None, {}, None, None
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise InputError(f"--state {item!r}: expected KEY=VALUE (t=SECONDS, SENSOR=DEGC, "
                             "forces=FX,FY,FZ, directions=+1,-1,...)")
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            raise InputError(f"--state {item!r}: '{text}' is not a number (or comma-separated numbers)") from None
        if name in ("forces", "directions"):
            forces, directions = (values, directions) if name == "forces" else (forces, values)
        elif len(values) != 1:
            raise InputError(f"--state {item!r}: one value expected")
        elif name == "t":
            t = values[0]
        else:
            temps[name] = values[0]
    read = machine.covariates_used
    unused = [f"sensor '{name}'" for name in temps if name not in machine.sensors]
    unused += [what for what, value, key in (("t", t, "t"), ("forces", forces, "forces"),
                                             ("directions", directions, "directions"))
               if value is not None and key not in read]
    if unused:
        print(f"volerr: note: --state: {machine.name} does not read {', '.join(unused)}, which change nothing "
              f"(temperature sensors it reads: {', '.join(machine.sensors) or 'none'})", file=sys.stderr)
    return machine.with_state(t=t, temperatures=temps, forces=forces, directions=directions)


def axis_positions(machine: Machine, items: list[str] | None, option: str) -> dict[str, float]:
    """``AXIS=VALUE`` items of ``option`` in mm (linear) or deg (rotary) -> {axis: value}."""
    return parse_axis_values(items or [], option, axes=machine.axes)


def axis_config(machine: Machine, items: list[str] | None, option: str) -> dict[str, float]:
    """``AXIS=VALUE`` items of ``option`` in mm / deg -> {axis: SI value (m / rad)}."""
    return axis_values_to_si(machine.axes, machine.axis_kinds, axis_positions(machine, items, option),
                             option, machine.name)


def add_program_position_args(parser: argparse.ArgumentParser) -> None:
    """``--origin`` and ``--start`` of a command that reads an NC program."""
    parser.add_argument("--origin", nargs="+", metavar="AXIS=VALUE",
                        help="program coordinates of the program zero (the work offset, G54 ...; mm, deg)")
    parser.add_argument("--start", nargs="+", metavar="AXIS=VALUE",
                        help="where axes stand when the program starts (mm, deg): moves from them are read whole "
                             "(a 2-D program never writes Z: give Z=...); axes not named are not known until "
                             "programmed")


def add_dialect_args(parser: argparse.ArgumentParser) -> None:
    """``--dialect``, ``--work-offsets`` and ``--work-offsets-unit`` of a command that reads an NC program."""
    from ..compensation.gcode import DIALECTS

    parser.add_argument("--dialect", choices=list(DIALECTS),
                        help="the program's dialect: what its controller sets by default (lathe diameters, machine M "
                             "codes, work offsets, tape lines, whole numbers as increments); default: told from the "
                             "program where it says one (a FANUC ':' program number or G65, a Haas G187, a LinuxCNC "
                             "o-word ...), else linuxcnc. siemens reads SINUMERIK's ISO subset; heidenhain (Klartext) "
                             "programs are refused")
    parser.add_argument("--work-offsets", metavar="FILE",
                        help="the controller's work offsets, for a program with several set-ups (G54, G55 ...): a CSV "
                             "(offset,X_mm,Y_mm,...), LinuxCNC's parameter file (linuxcnc.var) or a FANUC offset "
                             "listing (G10 L2 Pn lines); not with --origin")
    parser.add_argument("--work-offsets-unit", choices=["mm", "inch"],
                        help="the length unit of a LinuxCNC parameter file or a FANUC listing (the controller's)")
    parser.add_argument("--subroutines", metavar="DIR",
                        help="where LinuxCNC finds the subroutine files the program calls (o<rcone> call runs "
                             "rcone.ngc); default: the program's folder")


def program_reading(machine: Machine, args) -> dict:
    """The keywords of the NC reader from :func:`add_program_position_args` and
    :func:`add_dialect_args`: ``start``, ``origin``, ``dialect``, ``work_offsets``, ``subroutines``
    (the program's folder unless ``--subroutines`` names another)."""
    from ..compensation.gcode import read_work_offsets

    start, origin = program_positions(machine, args)
    if args.work_offsets and args.origin:
        raise InputError("--origin stands for the work offset in force when no table is given: give --origin or "
                         "--work-offsets, not both", parameters=("--origin", "--work-offsets"))
    if args.work_offsets_unit and not args.work_offsets:
        raise InputError("--work-offsets-unit says the unit of --work-offsets, which is not given",
                         parameters=("--work-offsets-unit",))
    offsets = None
    if args.work_offsets:
        offsets = read_work_offsets(args.work_offsets, list(machine.axes), list(machine.axis_kinds),
                                    unit=args.work_offsets_unit)
    folder = Path(args.subroutines) if args.subroutines else Path(args.program).parent
    if not folder.is_dir():
        raise InputError(f"--subroutines: {folder} is not a folder", parameters=("--subroutines",))
    return {"start": start, "origin": origin, "dialect": args.dialect, "work_offsets": offsets,
            "subroutines": folder}


def program_positions(machine: Machine, args) -> tuple[list[float] | None, list[float] | None]:
    """``(start, origin)`` of :func:`add_program_position_args` as the NC reader takes them [m, rad]:
    axes not named in ``--start`` unknown (NaN), in ``--origin`` at 0; None when not given."""
    stands = axis_config(machine, args.start, "--start")
    offset = axis_config(machine, args.origin, "--origin")
    return ([stands.get(axis, float("nan")) for axis in machine.axes] if stands else None,
            [offset.get(axis, 0.0) for axis in machine.axes] if offset else None)


def axis_components(machine: Machine) -> set[str]:
    """Names of the component errors of the machine's axes (not location errors)."""
    from ..model import parse_component_name

    return {c for c in machine.components
            if not parse_component_name(c)[1] and parse_component_name(c)[2] in machine.axes}
