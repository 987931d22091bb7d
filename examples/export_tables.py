"""Controller tables, and what each leaves
=======================================

Compensation tables for every controller and every kind of table, on the three machines of
the papers, and the error each leaves as its controller applies it.

    python examples/export_tables.py OUT_FOLDER [--points N]

Writes ``OUT_FOLDER/<machine>/<controller>-<kind>/`` (the files a controller loads, read back
and checked) and prints one markdown table per machine: controller, kind, files, and the
simulated residual (max / RMS over points of the zone other than those fitted on), beside the
uncompensated error, the naive tables (component errors sampled at the nodes) and exact
point compensation. The tables of docs/guide/compensate.md come from this script.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import volerr_pin as vp
from volerr_pin.compensation.export import CONTROLLERS, export_tables

MACHINES = ("vmc500", "vmc700", "cgm4000")


def main(folder: str | Path, machines=MACHINES, points: int = 4096) -> dict[str, list[dict]]:
    """Export every controller's every kind for each machine; print and return the rows."""
    folder = Path(folder)
    out = {}
    for name in machines:
        machine = vp.load_machine(name)
        rows = []
        for controller, fmt in CONTROLLERS.items():
            for kind in fmt.kinds:
                result = export_tables(machine, controller, folder / name / f"{controller}-{kind}", kind=kind,
                                       points=points)
                s = result.summaries
                rows.append({"controller": controller, "kind": kind, "files": sorted(result.texts),
                             "residual_max_um": s["residual"].max_um, "residual_rms_um": s["residual"].rms_um,
                             "naive_max_um": s["naive"].max_um, "naive_rms_um": s["naive"].rms_um,
                             "node_max_um": s["node"].max_um, "uncompensated": s["uncompensated"],
                             "exact": s["exact"]})
        out[name] = rows
        first = rows[0]
        print(f"\n{name}: uncompensated {first['uncompensated'].max_um:.2f} um max, "
              f"{first['uncompensated'].rms_um:.2f} um RMS; exact point compensation {first['exact'].max_um:.1e} um\n")
        print("| controller | tables | files | residual max / RMS [um] | naive tables max / RMS [um] |")
        print("|---|---|---|---|---|")
        for r in rows:
            files = ", ".join(f"`{f}`" for f in r["files"])
            print(f"| {r['controller']} | {r['kind']} | {files} | {r['residual_max_um']:.3g} / "
                  f"{r['residual_rms_um']:.3g} | {r['naive_max_um']:.3g} / {r['naive_rms_um']:.3g} |")
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="Controller tables for every controller, and what each leaves")
    parser.add_argument("folder")
    parser.add_argument("--points", type=int, default=4096)
    args = parser.parse_args()
    main(args.folder, points=args.points)
