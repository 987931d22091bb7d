"""volerr uncertainty: how uncertain the error map (and a compensation's residual) is, by
linear propagation and Monte Carlo side by side; and the options every study shares
(samples, grid, seed, Dask engine, progress bar)."""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import logging
import sys
from concurrent.futures import CancelledError

from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..base import UM, transaction
from ._common import (add_json_arg, add_machine_args, add_out_arg, add_state_arg, check_run_outputs, dumps, machine_of,
                     number_of, positive, table_console)


# ------------------------------------------------------------------ shared by the studies


def count(text: str) -> int:
    """argparse type: a positive whole number, also written as ``1e5``."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}") from None
    if not value.is_integer() or value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text}")
    return int(value)


def positive_float(text: str) -> float:
    """argparse type: a positive finite number."""
    value = number_of(text, "a positive number")
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text}")
    return value


def probability(text: str) -> float:
    """argparse type: a probability strictly between 0 and 1."""
    value = number_of(text, "a probability")
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"expected a probability between 0 and 1, got {text}")
    return value


def non_negative(text: str) -> int:
    """argparse type: a non-negative whole number."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative whole number, got {value}")
    return value


def add_study_args(p: argparse.ArgumentParser, samples: int, grid: int) -> None:
    """``--samples``, ``--grid``, ``--seed`` and the engine (``--workers`` | ``--scheduler``)."""
    p.add_argument("--samples", type=count, default=samples, help=f"Monte Carlo draws (default {samples}; 1e5 is read)")
    p.add_argument("--grid", type=positive, nargs="+", default=[grid], metavar="N",
                   help=f"grid points per axis over the travels: one count or one per axis (default {grid})")
    p.add_argument("--seed", type=non_negative, default=0, help="seed of the draws (default 0)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=non_negative, metavar="N",
                       help="worker processes of the embedded local Dask cluster (default: this machine's cores); "
                            "0 runs in this process, without a cluster (small studies: no start-up)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on an existing Dask cluster, e.g. tcp://10.0.0.5:8786 (its workers need volerr_pin)")


@contextlib.contextmanager
def engine_of(args):
    """The Dask engine the options ask for, closed (with its local cluster) at the end."""
    from ..studies import InProcess, connect, local_cluster

    engine = (connect(args.scheduler) if args.scheduler else InProcess() if args.workers == 0
              else local_cluster(args.workers))
    if args.scheduler or args.workers != 0:
        # the command says itself what went wrong with the cluster, in one line; distributed's
        # logs (a reconnection's tracebacks when the scheduler is lost) are not for its user
        # (set once distributed is imported: its import sets its loggers' levels)
        for name in ("distributed", "distributed.client", "distributed.core", "distributed.comm", "asyncio"):
            logging.getLogger(name).setLevel(logging.CRITICAL)
    try:
        yield engine
    except (OSError, CancelledError) as err:   # (a cluster lost outside a map: scattering, closing)
        lost = getattr(engine, "lost", None)
        if lost is None:
            raise
        raise lost(err) from None
    finally:
        engine.close()


class StudyProgress:
    """Progress bars on stderr, one per stage, with their totals (terminals only, never with
    ``--json``). ``with StudyProgress(enabled) as progress`` gives ``progress(stage, done, total)``
    or None."""

    def __init__(self, enabled: bool):
        self.console = Console(stderr=True, highlight=False)
        self.enabled = enabled and self.console.is_terminal

    def __enter__(self):
        if not self.enabled:
            return None
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                            console=self.console, transient=True)
        self.bar.__enter__()
        self.tasks = {}
        return self.update

    def update(self, stage: str, done: int, total: int) -> None:
        if stage not in self.tasks:
            self.tasks[stage] = self.bar.add_task(stage, total=total)
        self.bar.update(self.tasks[stage], completed=done)

    def __exit__(self, *exc):
        if self.enabled:
            self.bar.__exit__(*exc)
        return False


# ------------------------------------------------------------------ the command


#: the command's name, and its line in ``volerr --help`` (read without building its parser)
COMMAND = "uncertainty"
HELP = "uncertainty of the error map and of a compensation (linear and Monte Carlo)"


def add_parser(sub) -> None:
    from ..compensation.export import CONTROLLERS

    p = sub.add_parser(COMMAND, help=HELP)
    add_machine_args(p)
    add_state_arg(p)
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--from", dest="from_report", metavar="IDENTIFY.json",
                        help="what volerr identify --json printed: values and standard uncertainties")
    source.add_argument("--instrument-sigma", type=positive_float, metavar="UM",
                        help="instrument standard uncertainty per coordinate [um], propagated through the "
                             "least-squares fit of a tool-point campaign (--campaign-points poses)")
    p.add_argument("--campaign-points", type=positive, default=200,
                   help="poses of the stated campaign with --instrument-sigma (Sobol', default 200)")
    add_study_args(p, samples=2000, grid=7)
    p.add_argument("--interval-samples", type=count,
                   help="draws behind the per-point 95 %% intervals (default min(samples, 1000))")
    p.add_argument("--compensation", choices=["none", "point", *CONTROLLERS], default="none",
                   help="also the residual after this compensation, computed on the estimate: exact point "
                        "compensation, or a controller's tables as volerr export writes them and the controller "
                        "applies them (default none)")
    add_out_arg(p, "write every point's numbers (positions mm/deg, errors um)", suffixes=(".csv",), what="a table (CSV)",
                metavar="FIELD.csv")
    p.add_argument("--rrd", metavar="FILE.rrd", help="write a Rerun recording of the uncertainty field")
    p.add_argument("--png", metavar="FILE.png", help="write a picture: each field's largest error over the draws "
                                                     "beside the linear interval, and every point's uncertainty both ways")
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..studies import covariance_from_campaign, covariance_from_report
    from ..studies import grid_points
    from ..studies import check_arguments, study_uncertainty

    machine = machine_of(args)
    check_run_outputs({"out": args.out, "rrd": args.rrd, "png": args.png}, [args.from_report], machine)
    check_arguments(args.samples, args.seed, args.interval_samples)
    if args.from_report:
        covariance = covariance_from_report(machine, args.from_report)
    else:
        covariance = covariance_from_campaign(machine, args.instrument_sigma * UM, points=args.campaign_points,
                                              seed=args.seed)
    q = grid_points(covariance.machine, args.grid)
    compensation = None if args.compensation == "none" else args.compensation
    with engine_of(args) as engine, StudyProgress(not args.json) as progress:
        study = study_uncertainty(covariance, q, samples=args.samples, seed=args.seed,
                                  interval_samples=args.interval_samples, compensation=compensation, engine=engine,
                                  progress=progress)
    report = study.to_dict()
    report["grid"] = list(args.grid)
    report["engine"] = engine.where
    with transaction() as tx:
        if args.out:
            tx_path = tx.path(args.out)
            tx_path.write_text(_field_csv(study))
            report["out"] = args.out
        if args.rrd:
            from ..viz import record_uncertainty

            record_uncertainty(study, tx.path(args.rrd))
            report["rrd"] = args.rrd
        if args.png:
            from ..viz import uncertainty_png

            uncertainty_png(study, tx.path(args.png))
            report["png"] = args.png
    if args.json:
        print(dumps(report))
        return 0
    _print(study, report)
    for name in ("out", "rrd", "png"):
        if name in report:
            print(f"wrote {report[name]}", file=sys.stderr)
    return 0


def _field_csv(study) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    fields = [("map", study.map)] + ([("compensation", study.compensated)] if study.compensated is not None else [])
    header, _ = study.map.table(study.machine)
    writer.writerow(["field", *header])
    for name, field in fields:
        _, rows = field.table(study.machine)
        for row in rows:
            writer.writerow([name, *(f"{v:.6g}" for v in row[:-1]), int(row[-1])])
    return buffer.getvalue()


def _print(study, report: dict) -> None:
    console = table_console()
    console.print(f"[bold]{study.machine.name}[/bold]: uncertainty from {report['source']}; {report['samples']:,} draws "
                  f"(seed {report['seed']}) on {report['engine']}; {report['n_parameters']} uncertain coefficients"
                  + (f", {len(report['not_propagated'])} without uncertainty" if report["not_propagated"] else ""))
    for name in ("map", "compensation"):
        field = report[name]
        if field is None:
            continue
        title = ("volumetric error" if name == "map" else
                 f"residual after {report['compensation_method']} compensation") + f" over {field['points']} points (um)"
        table = Table(box=box.SIMPLE, title=title)
        for col in ("", "estimate", "u linear", "95 % linear", "mean MC", "u MC", "95 % MC", "agree"):
            table.add_column(col, justify="right")
        summaries = (("max_error_um", "max |e|"), ("rms_error_um", "RMS |e|"))
        for key, label in summaries:
            s = field[key]
            lin, mc = s["linear"], s["monte_carlo"]
            if lin["applicable"]:
                linear = (f"{lin['u']:.3f}", f"{lin['low']:.3f} .. {lin['high']:.3f}", "yes" if s["agree"] else "NO")
            else:
                linear = ("n/a", "not applicable", "-")
            table.add_row(label, f"{s['value']:.3f}", linear[0], linear[1], f"{mc['mean']:.3f}", f"{mc['u']:.3f}",
                          f"{mc['low']:.3f} .. {mc['high']:.3f}", linear[2])
        console.print(table)
        for line in _verdict(field, summaries, report["samples"]):
            console.print(escape(line))


def _verdict(field: dict, summaries, samples: int) -> list[str]:
    """What the table says, in sentences: where a linear interval does not apply, whether the
    two methods agree at the points and for the summaries, how fine that test is."""
    out = []
    off = [(label, field[key]) for key, label in summaries if not field[key]["linear"]["applicable"]]
    on = [(label, field[key]) for key, label in summaries if field[key]["linear"]["applicable"]]
    for label, s in off:
        mc = s["monte_carlo"]
        out.append(f"  {label} {s['value']:.3f} um lies within the uncertainty of zero: a norm has no derivative "
                   "there (GUM 5.1.2, Supplement 1 5.8), so it has no linear interval; by Monte Carlo it is "
                   f"{mc['mean']:.3f} +- {mc['u']:.3f} um, below {mc['upper']:.3f} um with 95 % probability")
    u = field["u_position_um"]
    out.append(f"  position uncertainty sqrt(u_x^2 + u_y^2 + u_z^2) (the root of the trace of each point's "
               f"covariance): largest {u['monte_carlo_max']:.3f} um (linear {u['linear_max']:.3f}), RMS "
               f"{u['monte_carlo_rms']:.3f} um (linear {u['linear_rms']:.3f})")
    worst = field["worst_disagreement"]
    differ = [label for label, s in on if not s["agree"]]
    named = " and ".join(label for label, _ in on)
    if worst is None:
        if not on:
            out.append("  Monte Carlo and linear propagation agree at every point's x, y and z")
        elif not differ:
            out.append(f"  Monte Carlo and linear propagation agree at every point's x, y and z and for the {named}")
        else:
            out.append(f"  Monte Carlo and linear propagation agree at every point's x, y and z but not for the "
                       f"{' and '.join(differ)}: a maximum or RMS of magnitudes is not linear in the errors, even "
                       "where the errors are; use the Monte Carlo interval there")
    else:
        out.append(f"  per point: they disagree at {field['points_disagreeing']} points; the most at "
                   f"{', '.join(f'{v:g}' for v in worst['q'])}: u {worst['monte_carlo_u_um']:.3f} um (MC) "
                   f"vs {worst['linear_u_um']:.3f} um (linear), mean shifted {worst['bias_um']:.3f} um "
                   "(non-linear there: see docs/studies.md)"
                   + (f"; the {' and '.join(differ)} disagree too" if differ else ""))
    coarse = [s for _, s in on if s["draws_needed"] > samples]
    if coarse:
        s = max(coarse, key=lambda s: s["draws_needed"])
        known = max(s["tolerance_low"], s["tolerance_high"])
        out.append(f"  agree: both ends of the two 95 % intervals within the larger of delta = {s['delta']:.2g} um (half a "
                   "unit in u's second digit) and the Monte Carlo ends' sampling error (GUM S1 8); with "
                   f"{samples:,} draws that is +-{known:.3f} um, and smaller differences go unseen (about "
                   f"{s['draws_needed']:,} draws would resolve delta, GUM S1 7.9)")
    return out
