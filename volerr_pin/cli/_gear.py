"""volerr gear: profile, helix and pitch deviations of the gear a rolling machine generates."""

from __future__ import annotations

import math
import sys

from ..base import DEG, MM, InputError, transaction
from ..applications.gear import FLANKS, REFERENCE_GEAR, GearPair
from ._common import (add_json_arg, add_machine_args, add_state_arg, axis_config, check_run_outputs, dumps, machine_of,
                     positive, table_console)

DEFAULT = REFERENCE_GEAR


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "gear"
HELP = "gear flank deviations (profile, helix, pitch) per error source"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP,
                       description="Deviations of the spur gear a rolling machine generates: the total profile, "
                                   "total helix and single pitch deviation as the gear-rolling study defines "
                                   "them (Ma et al. 2025; the docs' references) and ISO 1328-1's F_alpha, "
                                   "F_beta, f_pt, F_p, for each error source of the machine alone and for all "
                                   "together; or, with --unit-errors, each error of an axis alone at a unit value.")
    add_machine_args(p)
    add_state_arg(p)
    g = p.add_argument_group("gear (default: the gear-rolling study's spur gear, its Table 7)")
    g.add_argument("--module-mm", type=float, default=DEFAULT.module / MM, help="module (default 1.75)")
    g.add_argument("--pressure-angle-deg", type=float, default=DEFAULT.pressure_angle / DEG,
                   help="pressure angle (default 20)")
    g.add_argument("--teeth", type=int, default=DEFAULT.teeth, help="teeth of the workpiece (default 46)")
    g.add_argument("--tool-teeth", type=int, default=DEFAULT.tool_teeth, help="teeth of the rolling wheel (default 128)")
    g.add_argument("--face-width-mm", type=float, default=DEFAULT.face_width / MM, help="face width (default 20)")
    p.add_argument("--spindles", default="B,A", help="workpiece spindle and wheel spindle (default B,A)")
    p.add_argument("--at", nargs="+", metavar="AXIS=VALUE",
                   help="positions of the other axes (mm, deg; default 0) during generation")
    p.add_argument("--feed", metavar="AXIS",
                   help="through rolling: each section finished as this linear axis carries it through the "
                        "wheel's mid plane (default: the whole face at one position)")
    p.add_argument("--flank", choices=list(FLANKS), default="right", help="flank the table shows (default right)")
    p.add_argument("--tooth", type=int, nargs="+", help="evaluate these teeth only (default every tooth)")
    p.add_argument("--profile-points", type=positive, default=21, help="points over the profile (odd, default 21)")
    p.add_argument("--face-points", type=positive, default=11, help="points over the face width (odd, default 11)")
    u = p.add_argument_group("unit-error study (each error alone at a unit value)")
    u.add_argument("--unit-errors", action="store_true",
                   help="each of the six errors of each --axes alone at a unit value, instead of the spec's errors")
    u.add_argument("--axes", help="axes studied (default A,B)")
    u.add_argument("--translation-mm", type=float, help="unit translation (default 1)")
    u.add_argument("--rotation-deg", type=float, help="unit rotation (default 1)")
    u.add_argument("--errors-frame", choices=["moving", "fixed"],
                   help="frame the studied axes' errors act in (default: the spec's)")
    p.add_argument("--reference", nargs="+", metavar="AXIS=X,Y,Z",
                   help="point (mm, in the axis' error frame) about which an axis' angular errors act")
    p.add_argument("--rrd", help="also write a Rerun recording: the flanks coloured by normal deviation, one error "
                                 "source per step of the 'source' timeline")
    p.add_argument("--png", help="also write maps of the normal deviations of all sources together and the "
                                 "teeth's flank positions")
    add_json_arg(p)
    p.set_defaults(func=run)


def _or(value, default):
    return default if value is None else value


def _names(text: str, option: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise InputError(f"{option}: give axis names separated by commas")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(f"{option}: axis {twice[0]} is named twice")
    return names


def _references(machine, items: list[str] | None) -> dict[str, dict]:
    out: dict[str, dict] = {}
    for item in items or []:
        axis, sep, value = item.partition("=")
        try:
            point = tuple(float(v) * MM for v in value.split(","))
        except ValueError:
            point = ()
        if not sep or len(point) != 3 or not all(math.isfinite(v) for v in point):
            raise InputError(f"--reference: {item!r} is not AXIS=X,Y,Z (mm)")
        if axis not in machine.axes:
            raise InputError(f"--reference: {axis!r} is not an axis of {machine.name} ({', '.join(machine.axes)})")
        out[axis] = {"reference": point}
    return out


def _with_axis_errors(machine, changes: dict):
    """The machine with the axes' errors placed as ``changes`` says ({axis: {"frame", "reference"}})."""
    if not changes:
        return machine
    spec = machine.spec
    for axis, change in changes.items():
        spec = spec.with_axis(axis, frame=change.get("frame"), reference=change.get("reference"))
    return machine.with_spec(spec)


def run(args) -> int:
    from ..applications.gear import contribution_degrees, deviations_by_source, unit_error_study
    machine = machine_of(args)
    check_run_outputs({"png": args.png, "rrd": args.rrd}, machine=machine)
    gear = GearPair(module=args.module_mm * MM, pressure_angle=args.pressure_angle_deg * DEG, teeth=args.teeth,
                    tool_teeth=args.tool_teeth, face_width=args.face_width_mm * MM)
    options = {"spindles": _names(args.spindles, "--spindles"), "at": axis_config(machine, args.at, "--at"),
               "profile_points": args.profile_points, "face_points": args.face_points, "tooth_numbers": args.tooth,
               "feed": args.feed}
    changes = _references(machine, args.reference)
    if args.png and args.unit_errors:
        raise InputError("--png draws all sources together: leave out --unit-errors")
    if args.errors_frame and not args.unit_errors:
        raise InputError("--errors-frame goes with --unit-errors (the spec sets the frames of its own errors)")
    study = [o for o, v in (("--axes", args.axes), ("--translation-mm", args.translation_mm),
                            ("--rotation-deg", args.rotation_deg)) if v is not None]
    if study and not args.unit_errors:
        raise InputError(f"{study[0]} goes with --unit-errors (it sets the unit-error study)")
    if args.unit_errors:
        axes = _names(args.axes or "A,B", "--axes")
        if args.errors_frame:
            for axis in axes:
                changes.setdefault(axis, {})["frame"] = args.errors_frame
        machine = _with_axis_errors(machine, changes)
        rows = unit_error_study(machine, gear, axes=axes, translation=_or(args.translation_mm, 1.0) * MM,
                                rotation=_or(args.rotation_deg, 1.0) * DEG, **options)
    else:
        machine = _with_axis_errors(machine, changes)
        rows = deviations_by_source(machine, gear, **options)
    with transaction() as tx:  # the picture and the recording are both written, or neither
        if args.png:
            from ..viz import gear_png

            gear_png(rows[-1].deviations, tx.path(args.png), f"{machine.name}: normal deviations of the generated "
                                                            f"flanks, all error sources")
        if args.rrd:
            from ..viz import record_gear

            summary = record_gear(rows, tx.path(args.rrd))
    if args.png:
        print(f"wrote {args.png}", file=sys.stderr)
    if args.rrd:
        print(f"wrote {args.rrd} ({summary['sources']} sources, {summary['points']} flank points, arrows "
              f"x{summary['scale']:g})", file=sys.stderr)
    shares = contribution_degrees(rows, args.flank)
    report = {"machine": machine.name, "gear": gear.to_dict(), "mode": "unit errors" if args.unit_errors else "spec",
              "flank": args.flank, "teeth_evaluated": len(rows[0].deviations.teeth), "feed": args.feed,
              "frames": {a.name: {"errors_frame": a.frame, "reference_mm": [v / MM for v in a.reference]}
                         for a in machine.spec.axes},
              "sources": []}
    for row, share in zip(rows, shares):
        entry = row.to_dict()
        entry["group"] = row.group
        entry["contribution"] = share
        report["sources"].append(entry)
    if args.json:
        print(dumps(report))
        return 0
    _print(report, args.flank)
    return 0


def _um(value) -> str:
    if value is None:
        return "-"
    return f"{0.0 if abs(value) < 5e-4 else value:.3f}"      # no "-0.000"


def _pct(value) -> str:
    return "" if value is None else f"{100 * value:.1f} %"


def _print(report: dict, flank: str) -> None:
    from rich import box
    from rich.table import Table

    gear = report["gear"]
    console = table_console()
    unit = report["mode"] == "unit errors"
    title = (f"{report['machine']}: {flank} flanks of a {gear['teeth']}-tooth gear, module {gear['module_mm']:g} mm, "
             f"{gear['pressure_angle_deg']:g} deg, {gear['face_width_mm']:g} mm face "
             f"({report['teeth_evaluated']} teeth; "
             f"{'unit errors, each alone' if unit else 'each error source alone, then all'})")
    table = Table(box=box.SIMPLE, title=title, title_justify="left")
    for name, justify in (("source", "left"), ("error", "left"), ("value", "right"), ("profile um", "right"),
                          ("share", "right"), ("helix um", "right"), ("share", "right"), ("pitch um", "right"),
                          ("share", "right"), ("F_alpha um", "right"), ("F_beta um", "right"), ("f_pt um", "right"),
                          ("seam um", "right")):
        table.add_column(name, justify=justify)
    for entry in report["sources"]:
        d, c = entry["flanks"][flank], entry["contribution"]
        table.add_row(entry["source"], entry["label"], entry["value"], _um(d["profile_um"]), _pct(c["profile"]),
                      _um(d["helix_um"]), _pct(c["helix"]), _um(d["pitch_um"]), _pct(c["pitch"]),
                      _um(d["F_alpha_um"]), _um(d["F_beta_um"]), _um(d["f_pt_um"]), _um(d["seam_um"]))
    console.print(table)
    print("profile, helix: |largest +| + |largest -| normal deviation; pitch: signed normal deviation "
          "on the pitch circle at mid face; share: contribution degree (per-unit RMS over their sum) within "
          + ("the axis' translations or rotations" if unit else "the single sources")
          + "; F_alpha, F_beta (worst tooth), f_pt (worst pair of adjacent teeth): ISO 1328-1 over the whole "
            "active flank; seam: step between the teeth generated last and first, a turn apart.")
