"""volerr identify: fit error terms to measurements."""

from __future__ import annotations

from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..base import transaction
from ._common import (FitProgress, add_json_arg, add_machine_args, add_out_arg, axis_components, axis_config,
                     check_run_outputs, distinct_inputs, dumps, machine_of, table_console)
from ._tables import print_groups


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "identify"
HELP = "fit error terms to measurements"


def add_parser(sub) -> None:
    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    p.add_argument("data", nargs="+", help="measurement files (points, positioning or component runs)")
    p.add_argument("--terms", nargs="+", metavar="TERM", help="components to fit (default: all)")
    p.add_argument("--degree", type=int, help="refit the terms as Legendre polynomials of this degree")
    add_out_arg(p, "write the identified spec (TOML) here", suffixes=(".toml",), what="a spec (TOML)")
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
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..fit.identify import identify
    from ..measurements import read_any
    from ..model import legendre_terms, write_spec

    machine = machine_of(args)
    distinct_inputs(args.data, "DATA")
    check_run_outputs({"out": args.out}, args.data, machine)
    if args.degree is not None:
        targets = args.terms or [c for c in machine.components if c in axis_components(machine)]
        spec = machine.spec
        for name, term in legendre_terms(machine, targets, args.degree).items():
            spec = spec.with_component(name, term)
        machine = machine.with_spec(spec)
    data = [read_any(path, machine, args.axis) for path in args.data]
    notes = [f"{d.source}: columns not used: {', '.join(d.unused)}" for d in data if d.unused]
    with FitProgress(not args.json) as progress:
        result = identify(machine, data, terms=args.terms, convention=args.convention,
                          folds=args.folds, holdout=args.holdout, seed=args.seed,
                          sigma_um=args.sigma_um, sigma_urad=args.sigma_urad, run_axis=args.axis,
                          at=axis_config(machine, args.at, "--at"), progress=progress)
    report = result.to_dict()
    report["data"] = [str(p) for p in args.data]
    report["notes"] = notes
    if args.out:
        provenance = {"data": [str(p) for p in args.data], "n_points": report["n_points"], "rank": report["rank"],
                      "n_parameters": report["n_parameters"], "convention": report["convention"],
                      "rms_fit_um": report["rms_fit_um"], "rms_holdout_um": report["rms_holdout_um"],
                      "holdout": report["holdout"],
                      "held_at_prior": [result.machine.parameter_names[k] for k in result.held]}
        with transaction() as tx:
            write_spec(result.machine, tx.path(args.out, backup=True), provenance, backup=False)  # tx keeps it
        report["out"] = str(args.out)
        report["backup"] = str(tx.backups[0]) if tx.backups else None
    if args.json:
        print(dumps(report))
        return 0
    from ..fit.identify import parameter_units

    _print_identification(table_console(), report, parameter_units(machine))
    for note in notes:
        print(f"note: {note}")
    if args.out:
        kept = f"; the spec it replaced is kept as {report['backup']}" if report["backup"] else ""
        print(f"wrote {args.out} (load it with vp.load_machine or any volerr command){kept}")
    return 0


def _print_identification(console: Console, r: dict, units: dict | None = None) -> None:
    console.print(f"[bold]{r['machine']}[/bold]: identification from {len(r['data'])} file(s), "
                  f"{r['n_points']} points, {r['n_observations']} observations")
    console.print(f"identifiability: rank {r['rank']} of {r['n_parameters']} free coefficients; "
                  f"condition number {r['condition_number']:.3g} (column-scaled)")
    if r["unidentifiable"]:
        held = "held at their prior values" if r["convention"] == "prior" else "minimum-norm update"
        console.print(f"the data cannot determine these ({held}; factors for the coefficients in "
                      f"{'their spec units' if units else 'SI units'}):")
        print_groups(console, r["unidentifiable"], header=False, units=units)
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
