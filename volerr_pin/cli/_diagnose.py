"""volerr diagnose: find, name and add what the model is missing."""

from __future__ import annotations

import shlex

from rich import box
from rich.markup import escape
from rich.table import Table

from ..base import transaction
from ._common import (FitProgress, add_json_arg, add_machine_args, add_out_arg, check_run_outputs, distinct_inputs,
                     dumps, machine_of, table_console)


def plan_argv(machine: str, separate_by: dict) -> list[str]:
    """The ``volerr plan`` command of a measurement a diagnosis asks for (a possible finding's
    ``separate_by``: ``instrument``, ``budget``, ``zone`` of held axes in mm / deg, ``terms``).

    Parameters
    ----------
    machine : str
        The machine as the user named it.
    separate_by : dict
        The measurement.

    Returns
    -------
    list of str
        The command's words.
    """
    zone = [f"{axis}={value:g}" for axis, value in separate_by["zone"].items()]
    return ["volerr", "plan", machine, "--instrument", separate_by["instrument"], "--budget",
            str(separate_by["budget"]), *(["--zone", *zone] if zone else []), "--terms", *separate_by["terms"]]


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "diagnose"
HELP = "find, name and add the missing effect"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    p.add_argument("data", nargs="+", help="point measurements (CSV) with any covariate columns")
    p.add_argument("--fixed", action="store_true", help="keep the spec's geometric values (do not refit them)")
    p.add_argument("--max-effects", type=int, default=5, help="stop after this many effects (default 5)")
    p.add_argument("--max-rounds", type=int, default=None,
                   help="rounds that may accept a change, at most (default max-effects + 8); the report "
                        "says when candidates still passed at the limit")
    p.add_argument("--alpha", type=float, default=0.01,
                   help="family-wise significance per round (Bonferroni over candidates; default 0.01)")
    p.add_argument("--folds", type=int, default=5,
                   help="k of the k-fold cross-validation over poses (default 5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the cross-validation split")
    p.add_argument("--sigma-um", type=float, default=None,
                   help="the noise of position data, std. deviation per component (um): weights the data and is "
                        "what the final residual is compared with (default: not stated - data weighted at 1 um, "
                        "and without repeated points the noise floor is unknown)")
    p.add_argument("--sigma-urad", type=float, default=None,
                   help="the noise of rotation data, std. deviation (urad; default 1)")
    add_out_arg(p, "write the final model as a spec (TOML)", suffixes=(".toml",), what="a spec (TOML)")
    p.add_argument("--rrd", help="write a Rerun recording of the steps")
    p.add_argument("--png", help="write a one-page summary figure")
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..fit.diagnosis import Alternative, Separation, ThermalModel, diagnose
    from ..fit.diagnosis import effect_kind
    from ..measurements import read_any
    from ..model import write_spec

    machine = machine_of(args)
    distinct_inputs(args.data, "DATA")
    check_run_outputs({"out": args.out, "rrd": args.rrd, "png": args.png}, args.data, machine)
    data = [read_any(path, machine) for path in args.data]
    with FitProgress(not args.json) as progress:
        result = diagnose(machine, data, fixed=args.fixed, max_effects=args.max_effects,
                          alpha=args.alpha, folds=args.folds, seed=args.seed, sigma_um=args.sigma_um,
                          sigma_urad=args.sigma_urad, max_rounds=args.max_rounds, progress=progress)
    report = result.to_dict()
    report["notes"] = [f"{d.source}: columns not used: {', '.join(d.unused)}" for d in data if d.unused]
    with transaction() as tx:  # the spec, recording and picture are all written, or none
        if args.out:
            write_spec(result.machine, tx.path(args.out, backup=True), {
                "data": [str(p) for p in args.data], "diagnosis": [e.label for e in result.effects],
                "rms_before_um": result.rms_before_um, "rms_after_um": result.rms_after_um,
                "noise_floor_um": result.noise_floor_um}, backup=False)  # the transaction keeps the backup
            report["out"] = str(args.out)
        if args.rrd:
            from ..viz import record_diagnosis

            report["recording"] = tx.final(record_diagnosis(result, tx.path(args.rrd)))
        if args.png:
            from ..viz import diagnosis_png

            diagnosis_png(result, tx.path(args.png))
            report["png"] = args.png
    if args.out:
        report["backup"] = str(tx.backups[0]) if tx.backups else None
    if args.json:
        print(dumps(report))
        return 0
    out = table_console()
    out.print(f"[bold]{escape(result.machine.name)}[/bold]: {result.observations.n_points} points; held-out "
              f"RMS {result.rms_before_um:.3f} um before, {result.rms_after_um:.3f} um after "
              f"({len(result.effects)} effect(s) found; {escape(result.off_spec()['label'])})")
    table = Table(box=box.SIMPLE, title="effects found, in order")
    for col in ("#", "effect", "axis", "direction", "driver", "modelled as", "held-out RMS before -> after [um]",
                "p-value"):
        table.add_column(col)
    for i, e in enumerate(result.effects, 1):
        twins = e.same_at_tool_as
        site = e.component + (f" (the same at the tool as {', '.join(twins)})" if twins else "")
        table.add_row(str(i), e.name, e.axis or "-", e.direction or "-", escape(e.driver or "-"), escape(site),
                      f"{e.rms_before_um:.3f} -> {e.rms_after_um:.3f}",
                      f"{e.p_value:.2g}" if e.p_value > 0 else "< 1e-300")
    out.print(table)
    def parameters(e, lead="  "):
        for name, p in e.parameters.items():
            u = "" if p["uncertainty"] is None else f" +- {p['uncertainty']:.3g}"
            out.print(escape(f"{lead}{name} = {p['value']:.5g}{u} {p['unit']}{effect_kind(e.name).parameter_note(name)}"))

    for e in result.effects:
        out.print(escape(f"{e.label}:"))
        parameters(e)
        if isinstance(e.details, ThermalModel):
            for line in e.details.lines():
                out.print(escape(line))
        if e.kept_jointly:
            out.print(escape(f"  {e.kept_jointly}"))
    for e in result.possible:
        head, _, why = e.note.partition(": ")
        out.print(escape(f"{head}: {e.label} ({why})"))
        if isinstance(e.details, Separation):
            out.print(escape("  to plan it: " + shlex.join(plan_argv(args.machine, e.details.separate_by))))
        if isinstance(e.details, Alternative):
            parameters(e, "  under this reading: ")
    if result.under_modelled:
        out.print(escape(result.off_spec()["label"]) + " (raised; not physical effects): "
                  + escape(", ".join(f"{u.component} ({u.form_before} -> {u.form_after})" for u in result.under_modelled)))
    for e in result.dropped:
        out.print(escape(f"dropped: {e.label} ({e.note})"))
    if result.stopped.get("reason") == "round_limit":
        out.print(escape(result.stopped["label"].replace("max_rounds", "--max-rounds")))
    floor = "noise floor at most" if result.noise_floor_upper_bound else "noise floor"
    verdict = {True: "the final model reaches it", False: "the final model does not reach it",
               None: "whether the final model reaches it is unknown: state the noise (--sigma-um) or measure "
                     "repeated points"}[result.reaches_noise_floor]
    out.print(f"{floor} {result.noise_floor_um:.3f} um ({escape(result.noise_floor_source)}); {verdict}. "
              f"Test: {escape(report['test'])}; {result.seconds:.1f} s")
    for note in report["notes"]:
        print(f"note: {note}")
    for key in ("out", "recording", "png"):
        if key in report:
            value = report[key]["path"] if isinstance(report[key], dict) else report[key]
            print(f"wrote {value}" + (f" (open it with: rerun {value})" if key == "recording" else "")
                  + (f"; the spec it replaced is kept as {report['backup']}" if key == "out" and report["backup"] else ""))
    return 0
