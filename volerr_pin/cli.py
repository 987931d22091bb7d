"""volerr: volumetric error of machine tools on Pinocchio - evaluate, rank, record, identify, diagnose, compensate.

Each command parses its arguments, calls the library and prints; every number comes from
the library.

Exit status 0 on success, 2 on bad input (one line on stderr naming the culprit).
``--json`` prints exactly one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from . import __version__
from .describe import machine_info
from .errors import VolerrError
from .machine import load_machine
from .errors import InputError
from .ranking import rank, read_tolerances, tool_identifiability
from .workspace import error_summary, grid, sample

DEFAULT_MACHINE = "vmc500"


def _finite(value):
    """JSON has no NaN or infinity: non-finite numbers become null (numpy values plain)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _dumps(value, **kwargs) -> str:
    """Strict JSON (no NaN / Infinity tokens) of a report."""
    return json.dumps(_finite(value), allow_nan=False, **kwargs)


def _console() -> Console:
    # tables are wide: give files and pipes room instead of rich's 80-column default
    width = None if sys.stdout.isatty() else 160
    return Console(highlight=False, soft_wrap=True, width=width)


def _print_info(console: Console, info: dict) -> None:
    console.print(f"[bold]{escape(info['machine'])}[/bold]"
                  + (f": {escape(info['description'])}" if info["description"] else
                     " (a bare URDF: no error terms until a spec gives them)" if not info.get("components") else ""))
    if info["source"]:
        console.print(f"source: {escape(info['source'])}")
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
    if info["ranges_of"] != "all terms":
        console.print(escape(f"ranges over travel: of the {info['ranges_of']}"))
    by_kind = ", ".join(f"{k}: {len(v)}" for k, v in info["terms_by_kind"].items())
    console.print(f"terms by kind: {by_kind}")


def _print_summary(console: Console, summary: dict, axes) -> None:
    worst = ", ".join(f"{a}={v:.1f}" for a, v in zip(axes, summary["worst_q"]))
    console.print(
        f"volumetric error over {summary['points']} workspace points (full grid): "
        f"max {summary['max_position_um']:.2f} um, RMS {summary['rms_position_um']:.2f} um "
        f"(max |dx| {summary['max_abs_um']['x']:.2f}, |dy| {summary['max_abs_um']['y']:.2f}, "
        f"|dz| {summary['max_abs_um']['z']:.2f} um); worst at {worst}; "
        f"max orientation error {summary['max_orientation_arcsec']:.2f} arcsec")


def _print_ranking(console: Console, ranking: dict, title: str) -> None:
    table = Table(box=box.SIMPLE, title=title)
    for col, justify in (("#", "right"), ("term", "left"), ("axis", "left"), ("max um", "right"),
                         ("RMS um", "right"), ("share", "right"), ("per unit (RMS)", "right"),
                         ("contribution degree", "right"), ("orientation share", "right")):
        table.add_column(col, justify=justify)
    for i, r in enumerate(ranking["ranking"], 1):
        degree = "" if r["contribution_degree"] is None else f"{100 * r['contribution_degree']:.1f} %"
        table.add_row(str(i), r["parameter"], r["axis"], f"{r['max_um']:.2f}", f"{r['rms_um']:.2f}",
                      f"{100 * r.get('share_of_all', r['share']):.1f} %", f"{r['per_unit_rms']:.3f} {r['per_unit']}", degree,
                      f"{100 * r['orientation_share']:.1f} %")
    console.print(table)


def _print_groups(console: Console, groups: list[dict], header: bool = True, units: dict | None = None) -> None:
    """Groups of coefficients the data cannot separate; with ``units`` (name -> (SI per
    unit, unit)) the factors are shown for the coefficients in their spec units."""
    if not groups:
        if header:
            console.print("identifiability at the tool: every coefficient has its own effect")
        return
    if header:
        console.print("identifiability at the tool (no tool-point measurement separates these; "
                      + ("factors for the coefficients in their spec units, um and arcsec):" if units
                         else "factors for the coefficients in SI units, m and rad):"))
    for g in groups:
        factors = list(g["factors"])
        si = ""
        if units and all(p in units for p in g["parameters"]):
            # A_dep = sum f_k A_k per SI unit  ->  per display unit: f_k * u_dep / u_k
            u_dep = units[g["parameters"][0]][0]
            factors = [f * u_dep / units[p][0] for p, f in zip(g["parameters"], factors)]
        elif units:
            si = " (factors in SI units: instrument terms have no spec unit)"
        pairs = list(zip(g["parameters"], factors))
        parts = escape(", ".join(f"{f:+.3g} {p}" for p, f in pairs[:8]))
        more = f", ... ({len(pairs) - 8} more; --json lists all)" if len(pairs) > 8 else ""
        console.print(f"  {g['kind']:<11} {parts}{more}{si}")


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


def cmd_rank(args) -> int:
    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    machine = _with_state(machine, args.state)
    tolerances = read_tolerances(args.tolerances, machine) if args.tolerances else None
    q = sample(machine, args.points, seed=args.seed)
    ranking = rank(machine, q, tolerances=tolerances, direction=args.direction, by=args.by)
    result = ranking.to_dict(top=args.top)
    groups = [g.to_dict() for g in tool_identifiability(machine, q)]
    if args.png:
        from .plots import ranking_png

        ranking_png(result, args.png, top=args.top or 15)
        print(f"wrote {args.png}", file=sys.stderr)
    if args.json:
        result["identifiability"] = groups
        print(_dumps(result))
    elif args.csv:
        sys.stdout.write(_ranking_csv(result))
    else:
        console = _console()
        what = "tolerances" if tolerances else "current error values"
        _print_ranking(console, result, f"{machine.name}: tool-point error by {args.by} "
                                        f"({args.points} points, direction {args.direction}, {what})")
        from .identify import parameter_units

        _print_groups(console, groups, units=parameter_units(machine))
    return 0


def _config(machine, items: list[str] | None) -> dict[str, float]:
    """``AXIS=VALUE`` in mm (linear) or deg (rotary) -> {axis: SI value}."""
    out = {}
    for item in items or []:
        name, sep, text = item.partition("=")
        if not sep or name not in machine.axes:
            raise InputError(f"{item!r}: expected AXIS=VALUE with AXIS one of "
                             f"{', '.join(machine.axes)}")
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"{item!r}: '{text}' is not a number") from None
        linear = machine.axis_kinds[machine.axes.index(name)] == "linear"
        out[name] = value * (1e-3 if linear else 3.141592653589793 / 180.0)
    return out


def _with_state(machine, items: list[str] | None):
    """``--state t=3600 spindle=24.5 force=0,0,-150 directions=1,-1,1`` -> the machine in
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
    return machine.with_state(t=t, temperatures=temps, forces=forces, directions=directions)


def _state_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--state", nargs="+", metavar="KEY=VALUE",
                        help="machine state for time-, temperature-, load- or direction-dependent terms: "
                             "t=SECONDS, SENSOR=DEGC, forces=FX,FY,FZ (N), directions=+1,-1,...")


def _print_recording(summary: dict, stream=None) -> None:
    stream = stream or sys.stdout
    sweep = (f"; rotary sweep of {', '.join(summary['sweep_axes'])} in {summary['sweep_steps']} steps "
             "on the 'sweep' timeline" if summary["sweep_steps"] else "")
    size = f", {summary['bytes'] / 1e6:.2f} MB" if summary.get("bytes") else ""
    print(f"wrote {summary['path']}: {summary['points']} points, arrows x{summary['scale']:g}, "
          f"max {summary['max_um']:.2f} um{sweep}{size}", file=stream)
    print(f"open it with: rerun {summary['path']}", file=stream)


def cmd_field(args) -> int:
    from .recording import record_field

    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    machine = _with_state(machine, args.state)
    config = _config(machine, args.config)
    if args.scale is not None and not args.scale > 0:
        raise InputError(f"--scale must be positive, got {args.scale}")
    ranking = rank(machine, sample(machine, 1024)).to_dict(top=15)
    summary = record_field(machine, args.out, counts=args.grid, config=config, scale=args.scale,
                           ranking=ranking, sweep_steps=args.sweep_steps, spawn=args.spawn,
                           connect=args.connect)
    if args.png:
        from .plots import field_slice_png

        field_slice_png(machine, args.png, config)
        summary["png"] = args.png
    if args.json:
        print(_dumps(summary))
    else:
        _print_recording(summary)
        if args.png:
            print(f"wrote {args.png}")
    return 0


def _print_iso(console: Console, result: dict) -> None:
    unit = result["unit"]
    table = Table(box=box.SIMPLE, title=escape(f"ISO 230-2 per target ({result['source']}; deviations in {unit})"))
    cols = ["target", "n up", "mean up", "s up", "n down", "mean down", "s down", "B_i", "R_i"]
    for col in cols:
        table.add_column(col, justify="right")
    fmt = lambda v: "" if v is None else f"{v:.4g}"
    for p in result["positions"]:
        table.add_row(f"{p['target']:g} {result['target_unit']}", str(p.get("n_up", "")),
                      fmt(p.get("mean_up")), fmt(p.get("s_up")), str(p.get("n_down", "")),
                      fmt(p.get("mean_down")), fmt(p.get("s_down")), fmt(p.get("B")), fmt(p.get("R")))
    console.print(table)
    summary = Table(box=box.SIMPLE, title=escape(f"ISO 230-2 parameters [{unit}]"))
    for col in ("", "bidirectional", "positive (up)", "negative (down)"):
        summary.add_column(col, justify="right")
    summary.add_row("A  accuracy", fmt(result["A"]), fmt(result["A_up"]), fmt(result["A_down"]))
    summary.add_row("E  systematic deviation", fmt(result["E"]), fmt(result["E_up"]), fmt(result["E_down"]))
    summary.add_row("R  repeatability", fmt(result["R"]), fmt(result["R_up"]), fmt(result["R_down"]))
    summary.add_row("M  mean deviation", fmt(result["M"]), "", "")
    summary.add_row("B  reversal (max |B_i|)", fmt(result["B"]), "", "")
    summary.add_row("mean reversal", fmt(result["B_mean"]), "", "")
    console.print(summary)


def _note_unused(path: str, unused) -> None:
    """One line on stderr naming what a file gives that the command does not use."""
    if unused:
        print(f"volerr: note: {path}: not used: {', '.join(unused)}", file=sys.stderr)


def cmd_iso230(args) -> int:
    from .iso230 import evaluate_runs
    from .measurements import read_runs

    runs = read_runs(args.runs)
    _note_unused(args.runs, runs.unused)
    result = evaluate_runs(runs)
    if args.plot:
        from .plots import iso230_png

        iso230_png(result, args.plot, title=f"ISO 230-2: {Path(args.runs).name}")
    if args.json:
        print(_dumps({k: v for k, v in result.items() if k != "source"} | {"source": result["source"]}))
    else:
        _print_iso(_console(), result)
        if args.plot:
            print(f"wrote {args.plot}")
    return 0


def cmd_ballbar(args) -> int:
    from .ballbar import evaluate_circular, read_ballbar

    run = read_ballbar(args.file)
    _note_unused(args.file, run.unused)
    result = evaluate_circular(run)
    if args.plot:
        from .plots import ballbar_png

        result["plot"] = ballbar_png(run, result, args.plot, title=f"ISO 230-4: {Path(args.file).name}")["path"]
    if args.json:
        print(_dumps(result))
        return 0
    out = _console()
    out.print(escape(f"circular test {result['source']}: plane {', '.join(result['plane'])}, radius "
                     f"{result['radius_mm']:g} mm, {result['n_ccw']} samples counter-clockwise, "
                     f"{result['n_cw']} clockwise"))
    table = Table(box=box.SIMPLE, title=escape("ISO 230-4 [um]"))
    for col in ("figure", "value", "meaning"):
        table.add_column(col, justify="right" if col == "value" else "left")
    rows = [("G", "circular deviation, both directions, about the least-squares centre"),
            ("G_ccw", "circular deviation, counter-clockwise"), ("G_cw", "circular deviation, clockwise"),
            ("H", "circular hysteresis (largest radial gap between the directions)"),
            ("F_max", "largest radial deviation about the nominal centre"),
            ("F_min", "smallest radial deviation about the nominal centre"),
            ("radius_error_um", "mean radius minus nominal (bar length and scale together)")]
    for key, meaning in rows:
        if result.get(key) is not None:
            table.add_row(key, f"{result[key]:.3f}", meaning)
    out.print(table)
    cx, cy = result["centre_offset_um"]
    out.print(f"least-squares centre off the nominal one by {cx:+.3f} um along {result['plane'][0]}, "
              f"{cy:+.3f} um along {result['plane'][1]} (the set-up, mostly)")
    if args.plot:
        print(f"wrote {args.plot}")
    return 0


def cmd_dh(args) -> int:
    from .dh import dh_to_urdf, read_dh

    rows, convention, tool = read_dh(args.table)
    try:
        text = dh_to_urdf(rows, convention, name=args.name or Path(args.table).stem, base=args.base_frame,
                          tool=args.tool_frame, tool_transform=tool)
    except ValueError as err:
        raise InputError(f"{args.table}: {err}") from None
    Path(args.output).write_text(text)
    print(f"wrote {args.output}: {len(rows)} joints ({convention} DH), frames '{args.base_frame}' and "
          f"'{args.tool_frame}'; load it with: volerr info {args.output} --tool-frame {args.tool_frame} "
          f"--workpiece-frame {args.base_frame}")
    return 0


def _at(items: list[str] | None) -> dict[str, float]:
    out = {}
    for item in items or []:
        name, sep, text = item.partition("=")
        try:
            out[name] = float(text)
        except ValueError:
            raise InputError(f"--at {item!r}: expected AXIS=VALUE (mm or deg)") from None
        if not sep:
            raise InputError(f"--at {item!r}: expected AXIS=VALUE (mm or deg)")
    return out


def cmd_identify(args) -> int:
    from .identify import identify
    from .measurements import read_any
    from .specio import legendre_terms, replace_terms, write_spec

    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    if args.degree is not None:
        targets = args.terms or [c for c in machine.components if c in _axis_components(machine)]
        machine = replace_terms(machine, legendre_terms(machine, targets, args.degree))
    data = [read_any(path, machine, args.axis) for path in args.data]
    console = Console(stderr=True, highlight=False)
    notes = [f"{d.source}: columns not used: {', '.join(d.unused)}" for d in data if d.unused]
    with _progress(console, not args.json) as progress:
        result = identify(machine, data, terms=args.terms, convention=args.convention,
                          folds=args.folds, holdout=args.holdout, seed=args.seed,
                          sigma_um=args.sigma_um, sigma_urad=args.sigma_urad, run_axis=args.axis,
                          run_at=_at(args.at), progress=progress)
    report = result.to_dict()
    report["data"] = [str(p) for p in args.data]
    report["notes"] = notes
    if args.out:
        write_spec(result.machine, args.out, {
            "data": [str(p) for p in args.data], "n_points": report["n_points"],
            "rank": report["rank"], "n_parameters": report["n_parameters"],
            "convention": report["convention"], "rms_fit_um": report["rms_fit_um"],
            "rms_holdout_um": report["rms_holdout_um"], "holdout": report["holdout"],
            "held_at_prior": [result.machine.parameter_names[k] for k in result.held]})
        report["out"] = str(args.out)
    if args.json:
        print(_dumps(report))
        return 0
    from .identify import parameter_units

    _print_identification(_console(), report, parameter_units(machine))
    for note in notes:
        print(f"note: {note}")
    if args.out:
        print(f"wrote {args.out} (load it with vp.load_machine or any volerr command)")
    return 0


def _axis_components(machine) -> set[str]:
    from .spec import parse_component_name

    return {c for c in machine.components
            if not parse_component_name(c)[1] and parse_component_name(c)[2] in machine.axes}


class _progress:
    """A progress bar on stderr for fits that take more than a moment (terminals only)."""

    def __init__(self, console: Console, enabled: bool):
        self.enabled = enabled and console.is_terminal
        self.console = console

    def __enter__(self):
        if not self.enabled:
            return None
        from rich.progress import Progress

        self.bar = Progress(console=self.console, transient=True)
        self.bar.__enter__()
        self.tasks = {}
        return self.update

    def update(self, stage: str, step: int) -> None:
        if stage not in self.tasks:
            self.tasks[stage] = self.bar.add_task(stage, total=None)
        self.bar.update(self.tasks[stage], completed=step)

    def __exit__(self, *exc):
        if self.enabled:
            self.bar.__exit__(*exc)
        return False


def _print_identification(console: Console, r: dict, units: dict | None = None) -> None:
    console.print(f"[bold]{r['machine']}[/bold]: identification from {len(r['data'])} file(s), "
                  f"{r['n_points']} points, {r['n_observations']} observations")
    console.print(f"identifiability: rank {r['rank']} of {r['n_parameters']} free coefficients; "
                  f"condition number {r['condition_number']:.3g} (column-scaled)")
    if r["unidentifiable"]:
        held = "held at their prior values" if r["convention"] == "prior" else "minimum-norm update"
        console.print(f"the data cannot determine these ({held}; factors for the coefficients in "
                      f"{'their spec units' if units else 'SI units'}):")
        _print_groups(console, r["unidentifiable"], header=False, units=units)
    holdout = (f"{r['rms_holdout_um']:.4g} um held out ({r['holdout']})"
               if r["rms_holdout_um"] is not None else f"no held-out RMS ({r['holdout']})")
    console.print(f"fit: {r['iterations']} Gauss-Newton iteration(s); residual RMS {r['rms_fit_um']:.4g} um "
                  f"at the fitted points, {holdout}; residual / stated sigma = {r['residual_sigma']:.3g}")
    if r["solver"] != "converged":
        console.print(f"[bold]the fit did not converge ({r['solver']})[/bold]: the values below are where it "
                      "stopped, not estimates; try other start values, fewer free terms, or more data")
    undetermined = [n for n, p in r["parameters"].items() if p["status"].startswith("fitted, not determined")]
    if undetermined:
        console.print(escape(f"not determined by these data (standard uncertainty beyond any plausible value): "
                             f"{', '.join(undetermined)}"))
    table = Table(box=box.SIMPLE, title="coefficients")
    for col, justify in (("coefficient", "left"), ("value", "right"), ("std. uncertainty", "right"),
                         ("unit", "left"), ("prior", "right"), ("status", "left")):
        table.add_column(col, justify=justify)
    for name, p in r["parameters"].items():
        if p["status"] == "fixed (not selected)":
            continue
        u = "" if p["uncertainty"] is None else f"{p['uncertainty']:.3g}"
        table.add_row(name, f"{p['value']:.5g}", u, p["unit"], f"{p['prior']:.5g}", p["status"])
    console.print(table)
    for name, value in r["nuisance"].items():
        console.print(escape(f"nuisance {name} = {value['value']:.4g} {value['unit']}"))


def cmd_thermal_fit(args) -> int:
    from .thermalfit import read_series, thermal_fit

    data = read_series(args.data)
    test = read_series(args.test) if args.test else None
    result = thermal_fit(data, args.target, args.sensors, lag=args.lag, method=args.method,
                         holdout=args.holdout, test=test, rank_top=args.top)
    if args.plot:
        from .plots import thermal_fit_png

        thermal_fit_png(result, data if test is None else None, args.plot)
    if args.json:
        print(_dumps({k: v for k, v in result.items() if k not in ("fitted", "predicted_holdout")}))
        return 0
    console = _console()
    lag = f", lag {result['lag']}" if result["lag"] is not None else ""
    console.print(escape(f"{result['method']} model of '{result['target']}'{lag} from "
                         f"{len(result['sensors'])} sensor(s); {result['n_fit']} fitted rows"))
    console.print(f"R^2 {result['r2']:.5f}, residual standard error {result['residual_se']:.4g} "
                  "(unit of the target)")
    if result["n_holdout"]:
        where = "the test file(s)" if test is not None else "the last rows"
        console.print(f"held out: {result['n_holdout']} rows of {where}, RMSE {result['rmse_holdout']:.4g}")
    table = Table(box=box.SIMPLE, title="most informative sensors (greedy forward selection)")
    table.add_column("#", justify="right")
    table.add_column("sensor")
    table.add_column("R^2 with the sensors so far", justify="right")
    for i, row in enumerate(result["sensor_ranking"], 1):
        table.add_row(str(i), escape(row["sensor"]), f"{row['r2']:.5f}")
    console.print(table)
    if args.plot:
        print(f"wrote {args.plot}")
    return 0


def cmd_diagnose(args) -> int:
    from .diagnose import diagnose
    from .measurements import read_any
    from .specio import write_spec

    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    data = [read_any(path, machine) for path in args.data]
    console = Console(stderr=True, highlight=False)
    with _progress(console, not args.json) as progress:
        result = diagnose(machine, data, fixed=args.fixed, max_effects=args.max_effects,
                          alpha=args.alpha, folds=args.folds, seed=args.seed, sigma_um=args.sigma_um,
                          sigma_urad=args.sigma_urad, progress=progress)
    report = result.to_dict()
    report["notes"] = [f"{d.source}: columns not used: {', '.join(d.unused)}" for d in data if d.unused]
    if args.out:
        write_spec(result.machine, args.out, {
            "data": [str(p) for p in args.data], "diagnosis": [e["label"] for e in result.effects],
            "rms_before_um": result.rms_before_um, "rms_after_um": result.rms_after_um,
            "noise_floor_um": result.noise_floor_um})
        report["out"] = str(args.out)
    if args.rrd:
        from .recording import record_diagnosis

        report["recording"] = record_diagnosis(result, args.rrd)
    if args.png:
        from .plots import diagnosis_png

        diagnosis_png(result, args.png)
        report["png"] = args.png
    if args.json:
        print(_dumps(report))
        return 0
    out = _console()
    out.print(f"[bold]{escape(result.machine.name)}[/bold]: {result.observations.n_points} points; held-out "
              f"RMS {result.rms_before_um:.3f} um before, {result.rms_after_um:.3f} um after "
              f"({len(result.effects)} effect(s) added, {len(result.under_modelled)} component(s) raised)")
    table = Table(box=box.SIMPLE, title="effects found, in order")
    for col in ("#", "effect", "axis", "direction", "driver", "modelled as", "held-out RMS before -> after [um]",
                "p-value"):
        table.add_column(col)
    for i, e in enumerate(result.effects, 1):
        twins = e.get("same_at_tool_as") or []
        site = e["component"] + (f" (the same at the tool as {', '.join(twins)})" if twins else "")
        table.add_row(str(i), e["name"], e["axis"] or "-", e["direction"] or "-", escape(e["driver"] or "-"),
                      escape(site),
                      f"{e['rms_before_um']:.3f} -> {e['rms_after_um']:.3f}", f"{e['p_value']:.2g}")
    out.print(table)
    for e in result.effects:
        for name, p in e["parameters"].items():
            u = "" if p["uncertainty"] is None else f" +- {p['uncertainty']:.3g}"
            out.print(escape(f"  {name} = {p['value']:.5g}{u} {p['unit']}"))
    if result.under_modelled:
        out.print("geometric components under-modelled by the spec (raised; not physical effects): "
                  + escape(", ".join(f"{u['component']} ({u['from']} -> {u['to']})" for u in result.under_modelled)))
    for e in result.dropped:
        out.print(escape(f"dropped: {e['label']} ({e['note']})"))
    verdict = "reaches" if result.reaches_noise_floor else "does not reach"
    floor = "noise floor at most" if result.noise_floor_upper_bound else "noise floor"
    out.print(f"{floor} {result.noise_floor_um:.3f} um ({escape(result.noise_floor_source)}); the final model "
              f"{verdict} it. Test: {escape(report['test'])}; {result.seconds:.1f} s")
    for note in report["notes"]:
        print(f"note: {note}")
    for key in ("out", "recording", "png"):
        if key in report:
            value = report[key]["path"] if isinstance(report[key], dict) else report[key]
            print(f"wrote {value}" + (f" (open it with: rerun {value})" if key == "recording" else ""))
    return 0


def cmd_compensate(args) -> int:
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from .gcode import Program

    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    machine = _with_state(machine, args.state)
    path = Path(args.program)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not UTF-8/ASCII text (byte {err.start})") from None
    offset = _config(machine, args.origin)
    origin = [offset.get(axis, 0.0) for axis in machine.axes] if offset else None
    program = Program(machine, tol_um=args.tol_um, tol_urad=args.tol_urad, pass_through=args.pass_through,
                      method=args.method, source=str(path), origin=origin)
    console = Console(stderr=True, highlight=False)
    with Progress(TextColumn("compensating"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                  console=console, transient=True, disable=args.json or not console.is_terminal) as bar:
        task = bar.add_task("", total=text.count("\n") + 1)
        result = program.compensate(text, progress=lambda n: bar.update(task, completed=n))
    Path(args.output).write_text(result, encoding="utf-8", newline="")
    report = {"machine": machine.name, "input": str(path), "output": str(args.output), **program.report.to_dict()}
    if args.report:
        Path(args.report).write_text(_dumps(report, indent=2) + "\n")
    if args.png:
        from .plots import compensation_png

        report["png"] = compensation_png(program.report, args.png, title=f"{machine.name}: {path.name}")["path"]
    if args.json:
        print(_dumps(report))
        return 0
    r = program.report
    print(f"{path} -> {args.output}: {r.blocks_in} blocks in, {r.blocks_out} out; {r.moves} moves in "
          f"{r.pieces} pieces ({r.arcs_kept} arcs kept as arcs, {r.arcs_as_lines} as lines)")
    print(f"largest error along the moves: {r.max_before_um:.2f} um before, {r.max_residual_um:.3f} um after "
          f"compensation (tolerance {r.tolerance_um:g} um)")
    for w in r.warnings:
        print(f"warning: {w}")
    for key in ("report", "png"):
        if getattr(args, key):
            print(f"wrote {getattr(args, key)}")
    return 0


def cmd_errormap(args) -> int:
    from .errormap import ErrorMap, axis_tables, compensation_table

    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    machine = _with_state(machine, args.state)
    config = _config(machine, args.config)
    elements = args.elements * 3 if len(args.elements) == 1 else args.elements
    if len(elements) != 3:
        raise InputError(f"--elements takes 1 or 3 values, got {len(elements)}")
    rows = [ErrorMap.build(machine, elements, order, config=config).interpolation_error(args.points, args.seed)
            for order in args.order]
    report = {"machine": machine.name, "elements": list(elements), "orders": rows}
    if args.table:
        nodes = args.nodes * 3 if len(args.nodes) == 1 else args.nodes
        if len(nodes) != 3:
            raise InputError(f"--nodes takes 1 or 3 values, got {len(nodes)}")
        report["table"] = compensation_table(machine, args.table, nodes, config=config)
    if args.axis_tables:
        report["axis_tables"] = axis_tables(machine, args.axis_tables)
    if args.json:
        print(_dumps(report))
        return 0
    console = _console()
    table = Table(box=box.SIMPLE, title=f"{machine.name}: error map interpolation vs the direct model "
                                        f"({args.points} random points)")
    for col in ("element", "elements", "nodes", "max [um]", "RMS [um]", "RMS / error RMS"):
        table.add_column(escape(col), justify="right")
    for r in rows:
        table.add_row(f"{r['nodes_per_element']}-node", "x".join(map(str, r["elements"])), str(r["nodes"]),
                      f"{r['max_um']:.4f}", f"{r['rms_um']:.4f}", f"{100 * r['relative']:.2f} %")
    console.print(table)
    console.print(f"volumetric error RMS over the map: {rows[0]['error_rms_um']:.3f} um")
    if args.table:
        t = report["table"]
        print(f"wrote {t['file']}: {t['rows']} nodes, corrections up to {t['max_correction_um']:.2f} um; with "
              f"trilinear interpolation the residual is {t['residual_with_table_max_um']:.3f} um max, "
              f"{t['residual_with_table_rms_um']:.3f} um RMS")
    for f in report.get("axis_tables", []):
        print(f"wrote {f}")
    return 0


def cmd_info(args) -> int:
    machine = load_machine(args.machine, tool_frame=args.tool_frame,
                           workpiece_frame=args.workpiece_frame)
    info = machine_info(_with_state(machine, args.state))
    if args.json:
        print(_dumps(info))
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
    machine = load_machine(args.machine, tool_frame=args.tool_frame, workpiece_frame=args.workpiece_frame)
    machine = _with_state(machine, args.state)
    info = machine_info(machine)
    points = grid(machine, args.grid)          # one grid for the summary, field and compensation
    summary = error_summary(machine, points)
    from .recording import record_field

    ranked = rank(machine, sample(machine, 1024))
    ranking = ranked.to_dict(top=args.top)
    linear = sum(k == "linear" for k in machine.axis_kinds)
    recording = record_field(machine, args.out, ranking=ranked.to_dict(top=15),
                             counts=[args.grid] * linear if linear else None)
    from .compensate import evaluate_compensation

    compensation = evaluate_compensation(machine, points)
    if args.json:
        print(_dumps({"machine": info, "summary": summary, "ranking": ranking,
                          "recording": recording, "compensation": compensation}))
        return 0
    console = _console()
    _print_info(console, info)
    _print_summary(console, summary, machine.axes)
    _print_ranking(console, ranking, f"top {args.top} error sources at the tool "
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
    _print_recording(recording)
    return 0


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


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
    p.add_argument("--tool-frame", help="tool frame (bare URDF only)")
    p.add_argument("--workpiece-frame", help="workpiece frame (bare URDF only)")
    p.add_argument("--grid", type=int, default=11, help="grid points per axis (default 11)")
    p.add_argument("--top", type=int, default=5, help="ranking rows to show (default 5)")
    p.add_argument("--out", default="volerr_demo.rrd",
                   help="Rerun recording to write (default volerr_demo.rrd)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    _state_arg(p)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("field", help="Rerun recording of the error field")
    _machine_args(p)
    _state_arg(p)
    p.add_argument("--out", required=True, help="recording file (.rrd)")
    p.add_argument("--grid", type=_positive, nargs="+", metavar="N",
                   help="points per linear axis (one value for all, or one per linear axis; default 9)")
    p.add_argument("--scale", type=float, help="arrow magnification (default: a round factor "
                                               "making the largest arrow ~8 %% of the workspace)")
    p.add_argument("--config", nargs="+", metavar="AXIS=VALUE",
                   help="axis positions for the machine and the fixed axes (mm, deg)")
    p.add_argument("--sweep-steps", type=int, default=24,
                   help="steps of the rotary-axis sweep (0: none; default 24)")
    p.add_argument("--png", help="also write a static picture of an error-field slice")
    viewer = p.add_mutually_exclusive_group()
    viewer.add_argument("--spawn", action="store_true", help="also stream to a new Rerun viewer")
    viewer.add_argument("--connect", metavar="URL", help="also stream to a running viewer (gRPC URL)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_field)

    p = sub.add_parser("rank", help="sensitivity ranking of the error sources")
    _machine_args(p)
    _state_arg(p)
    p.add_argument("--points", type=_positive, default=2048, help="workspace points (Sobol', default 2048)")
    p.add_argument("--seed", type=int, default=0, help="seed of the workspace sample")
    p.add_argument("--tolerances", help="TOML file: term -> expected magnitude (EXX_um = 5, ...)")
    p.add_argument("--top", type=_positive, help="show the K most influential only")
    p.add_argument("--direction", choices=["x", "y", "z", "all"], default="all",
                   help="tool error direction to measure (default all)")
    p.add_argument("--by", choices=["component", "parameter"], default="component",
                   help="rank component errors or single coefficients")
    p.add_argument("--png", help="also write a bar chart of the ranking")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print one JSON object")
    out.add_argument("--csv", action="store_true", help="print the ranking as CSV")
    p.set_defaults(func=cmd_rank)

    p = sub.add_parser("iso230-2", help="ISO 230-2 evaluation of positioning runs")
    p.add_argument("runs", help="CSV: target_mm,cycle,direction,deviation_um (or _deg / _arcsec)")
    p.add_argument("--plot", help="write the standard's picture (PNG)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_iso230)

    p = sub.add_parser("identify", help="fit error terms to measurements")
    _machine_args(p)
    p.add_argument("data", nargs="+", help="measurement files (points, positioning or component runs)")
    p.add_argument("--terms", nargs="+", metavar="TERM", help="components to fit (default: all)")
    p.add_argument("--degree", type=int, help="refit the terms as Legendre polynomials of this degree")
    p.add_argument("--out", help="write the identified spec (TOML) here")
    p.add_argument("--axis", help="axis of runs that do not name it ('# axis: X')")
    p.add_argument("--at", nargs="+", metavar="AXIS=VALUE", help="other axes' positions during runs (mm, deg)")
    cv = p.add_mutually_exclusive_group()
    cv.add_argument("--folds", type=int, default=5,
                    help="k-fold cross-validation over poses: the points at one pose leave together (default 5; 0: none)")
    cv.add_argument("--holdout", type=float, help="hold out this fraction of the poses instead")
    p.add_argument("--seed", type=int, default=0, help="seed of the cross-validation split")
    p.add_argument("--convention", choices=["prior", "min-norm"], default="prior",
                   help="what the data cannot determine: held at prior values (default) or min-norm")
    p.add_argument("--sigma-um", type=float, default=1.0, help="std. deviation of position data (um)")
    p.add_argument("--sigma-urad", type=float, default=1.0, help="std. deviation of rotation data (urad)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_identify)

    p = sub.add_parser("thermal-fit", help="thermal drift model from sensor data")
    p.add_argument("data", nargs="+", help="CSV files (one per experiment/batch), numeric columns")
    p.add_argument("--target", required=True, help="column to model (e.g. a thermal error)")
    p.add_argument("--sensors", nargs="+", help="columns to use (default: every other column)")
    p.add_argument("--lag", type=int, default=1, help="linear: target lags (0: static model; default 1)")
    p.add_argument("--method", choices=["linear", "gm11", "gm1n", "vwgm1n"], default="linear",
                   help="linear: least squares on the sensors (with --lag target lags; default); "
                        "gm11: grey model GM(1,1) of the target alone; gm1n: GM(1,N) with the sensors; "
                        "vwgm1n: GM(1,N) with its background weight chosen by one-step error")
    held = p.add_mutually_exclusive_group()
    held.add_argument("--holdout", type=float, default=0.0, help="hold out the last fraction of rows")
    held.add_argument("--test", nargs="+", help="held-out files (fit on DATA, predict these)")
    p.add_argument("--top", type=int, default=5, help="sensors to rank (default 5)")
    p.add_argument("--plot", help="write measured vs modelled (PNG)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_thermal_fit)

    p = sub.add_parser("diagnose", help="find, name and add the missing effect")
    _machine_args(p)
    p.add_argument("data", nargs="+", help="point measurements (CSV) with any covariate columns")
    p.add_argument("--fixed", action="store_true", help="keep the spec's geometric values (do not refit them)")
    p.add_argument("--max-effects", type=int, default=5, help="stop after this many effects (default 5)")
    p.add_argument("--alpha", type=float, default=0.01,
                   help="family-wise significance per round (Bonferroni over candidates; default 0.01)")
    p.add_argument("--folds", type=int, default=5,
                   help="k of the k-fold cross-validation over poses (default 5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the cross-validation split")
    p.add_argument("--sigma-um", type=float, default=1.0, help="std. deviation of position data (um)")
    p.add_argument("--sigma-urad", type=float, default=1.0, help="std. deviation of rotation data (urad)")
    p.add_argument("--out", help="write the final model as a spec (TOML)")
    p.add_argument("--rrd", help="write a Rerun recording of the steps")
    p.add_argument("--png", help="write a one-page summary figure")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_diagnose)

    p = sub.add_parser("compensate", help="compensated NC program")
    _machine_args(p)
    _state_arg(p)
    p.add_argument("program", help="NC program (ISO 6983 / RS-274)")
    p.add_argument("-o", "--output", required=True, help="compensated program to write")
    p.add_argument("--tol-um", type=float, default=1.0, help="position tolerance along every move (default 1)")
    p.add_argument("--tol-urad", type=float,
                   help="tool-axis tolerance on machines with rotary axes (default 10 per um of --tol-um)")
    p.add_argument("--report", help="write the report (JSON) here")
    p.add_argument("--pass-through", action="store_true",
                   help="keep blocks that cannot be compensated (canned cycles, macros) and warn")
    p.add_argument("--method", choices=["newton", "recursive"], default="newton",
                   help="point compensation scheme (default newton)")
    p.add_argument("--png", help="also draw the error along each move before and after (PNG)")
    p.add_argument("--origin", nargs="+", metavar="AXIS=VALUE",
                   help="axis positions of the program zero (the work offset, G54 ...; mm, deg)")
    p.add_argument("--json", action="store_true", help="print the report as one JSON object")
    p.set_defaults(func=cmd_compensate)

    p = sub.add_parser("errormap", help="error map accuracy per element order; compensation tables")
    _machine_args(p)
    _state_arg(p)
    p.add_argument("--elements", type=_positive, nargs="+", default=[4], metavar="N",
                   help="elements per linear axis (1 or 3 values; default 4)")
    p.add_argument("--order", type=int, nargs="+", choices=[1, 2, 3], default=[1, 2, 3],
                   help="element orders: 1 = 8-node, 2 = 20-node, 3 = 32-node (default all)")
    p.add_argument("--points", type=_positive, default=2000, help="random test points (default 2000)")
    p.add_argument("--seed", type=int, default=0, help="seed of the test points")
    p.add_argument("--config", nargs="+", metavar="AXIS=VALUE", help="positions of the other axes (mm, deg)")
    p.add_argument("--table", help="write a trilinear compensation table (CSV) here")
    p.add_argument("--nodes", type=_positive, nargs="+", default=[11], metavar="N",
                   help="table nodes per axis (1 or 3 values; default 11)")
    p.add_argument("--axis-tables", metavar="DIR", help="write ISO 230-1-named per-axis tables here")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_errormap)

    p = sub.add_parser("ballbar", help="ISO 230-4 circular test: circular deviation, hysteresis, radial deviation")
    p.add_argument("file", help="ballbar file: angle_deg, deviation_um[, direction] with '# plane:' and "
                                "'# radius:' header lines")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", help="write the ISO 230-4 polar picture (PNG)")
    p.set_defaults(func=cmd_ballbar)

    p = sub.add_parser("dh", help="a URDF from a Denavit-Hartenberg table (standard or modified)")
    p.add_argument("table", help="DH table: joint,type,a_mm,alpha_deg,d_mm,theta_deg,lower,upper "
                                 "with '# convention:' and '# tool:' header lines")
    p.add_argument("-o", "--output", required=True, help="URDF file to write")
    p.add_argument("--name", help="robot name (default: the table's file name)")
    p.add_argument("--base-frame", default="base", help="name of the base frame (default base)")
    p.add_argument("--tool-frame", default="tool0", help="name of the tool frame (default tool0)")
    p.set_defaults(func=cmd_dh)

    p = sub.add_parser("info", help="axes, chains, error terms by kind, travels")
    _machine_args(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    _state_arg(p)
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("urdf", help="the URDF with error joints injected")
    _machine_args(p)
    p.add_argument("-o", "--output", help="file to write (default: stdout)")
    p.set_defaults(func=cmd_urdf)
    return parser


def _note(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"volerr: note: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():
            # the library's warnings are notes for the user: one line each, no source location
            warnings.showwarning = _note
            return args.func(args)
    except VolerrError as err:
        print(f"volerr: error: {err}", file=sys.stderr)
        return 2
    except OSError as err:
        print(f"volerr: error: {err.filename or ''}: {err.strerror}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
