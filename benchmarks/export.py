"""Time and reach of controller exports, measured in one run.

    python benchmarks/export.py [--points N] [--markdown FILE]

For each machine and controller (default kind) it times one export (fit, rounding, writing
and reading back as text, simulation), the fit alone, and reports how far the fitted tables
and the naive ones (component errors sampled at the nodes) bring the RMS error, as ratios
measured in the same run. Nothing here is asserted; tests never check times.
"""

from __future__ import annotations

import argparse
import platform
import time

import volerr_pin as vp
from volerr_pin.compensation.export import CONTROLLERS, FIT_POINTS_PER_VALUE, Zone, export_tables, fit

MACHINES = ("vmc500", "cgm4000")


def bench(points: int = 4096) -> list[dict]:
    """One row per machine and controller."""
    rows = []
    for name in MACHINES:
        machine = vp.load_machine(name)
        export_tables(machine, "linuxcnc", points=256)                    # compile and cache the kernels
        zone = Zone.workspace(machine)
        for controller, fmt in CONTROLLERS.items():
            start = time.perf_counter()
            result = export_tables(machine, controller, points=points)
            total = time.perf_counter() - start
            layout = fmt.layout(machine, zone, result.kind, None)
            sample = zone.sample(max(points, FIT_POINTS_PER_VALUE * layout.values.size), 0)
            start = time.perf_counter()
            fit(machine, layout, sample)
            fitting = time.perf_counter() - start
            s = result.summaries
            rows.append({"machine": name, "controller": controller, "kind": result.kind,
                         "values": result.to_dict()["values"], "fit_points": result.fit_points, "seconds": total,
                         "fit_seconds": fitting, "fit_share": fitting / total,
                         "residual_over_uncompensated": s["residual"].rms_um / s["uncompensated"].rms_um,
                         "fitted_over_naive": s["residual"].rms_um / s["naive"].rms_um})
    return rows


def markdown(rows: list[dict]) -> str:
    """The rows as a markdown table."""
    lines = [f"Measured on {platform.machine()}, Python {platform.python_version()}.", "",
             "| machine | controller | kind | values | fit points | export [s] | fit share | RMS after / before | "
             "fitted / naive RMS |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['machine']} | {r['controller']} | {r['kind']} | {r['values']} | {r['fit_points']} | "
                     f"{r['seconds']:.2f} | {r['fit_share']:.0%} | {r['residual_over_uncompensated']:.2e} | "
                     f"{r['fitted_over_naive']:.3f} |")
    return "\n".join(lines) + "\n"


def section(quick: bool = False) -> str:
    """This benchmark's Markdown for ``benchmarks/run.py`` (fewer fit points with ``quick``)."""
    return markdown(bench(1024 if quick else 4096))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4096)
    parser.add_argument("--markdown")
    args = parser.parse_args()
    text = markdown(bench(args.points))
    print(text)
    if args.markdown:
        from volerr_pin.base import write_text

        write_text(args.markdown, text)
