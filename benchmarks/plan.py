"""Planned campaigns against a grid and random poses of the same count, measured in one run.

    python benchmarks/plan.py [--quick] [--markdown FILE] [--instruments tracker probe ballbar]

For vmc500, vmc700, cgm4000 and ur5, ``volerr_pin.studies.plan.plan`` chooses N poses for a laser
tracker (two reflectors: one at the tool point, one 100 mm off it along the tool's x axis,
5 um per coordinate) and for a probe at the tool point (1 um), and, on the machines with
linear X, Y, Z axes, M circles for a ballbar (radii 50 to 300 mm, both directions, 72
samples per direction, 0.7 um), and compares them with a grid and uniform random units of
the same count: the predicted standard uncertainty of the volumetric error over the zone
(RMS over 512 Sobol' points), the geometric mean of the coefficients' predicted standard
uncertainties, and the same two found by simulating the campaign (10 repeats, fixed seeds)
and identifying from it with ``volerr_pin.fit.identify``. A ratio below 1 means the plan is
better; "not identified" means the reference design leaves coefficients that the plan
identifies undetermined. Also a section of ``benchmarks/run.py``
(``section(quick) -> str``).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import volerr_pin as vp
from volerr_pin.studies.plan import instrument, make_setup, plan

#: machine -> budget N per instrument (about twice the poses that the identifiable
#: coefficients need)
CASES = {"vmc500": 40, "vmc700": 50, "cgm4000": 80, "ur5": 40}
#: machine -> circles M for the ballbar (a circle gives 144 samples; its set-up takes 3 of them)
BALLBAR_CASES = {"vmc500": 8, "vmc700": 10, "cgm4000": 12}
#: instrument -> machine -> count, in the table's order (the ballbar needs linear X, Y, Z axes)
BUDGETS = {"tracker": CASES, "probe": CASES, "ballbar": BALLBAR_CASES}
KINDS = tuple(BUDGETS)


def _row(name: str, kind: str, n: int, quick: bool) -> str:
    m = vp.load_machine(name)
    inst = instrument(kind)
    targets = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]) if kind == "tracker" else None
    setup = make_setup(m, inst, targets=targets)
    t0 = time.perf_counter()
    candidates = (128 if kind == "ballbar" else 512) if quick else 1024
    p = plan(m, inst, n, setup, compare=True, repeats=2 if quick else 10, candidates=candidates)
    seconds = time.perf_counter() - t0
    c = p.comparison

    def fmt(x):
        return "n/a" if x is None else f"{x:.2f}"

    def ref(label):
        r = c[label]
        if r["not_identified"]:
            return f"not identified: {len(r['not_identified'])}", f"{r['ratios']['predicted_lower_share']:.0%}"
        return (f"{fmt(r['ratios']['predicted_zone_rms'])} / {fmt(r['ratios']['simulated_zone_rms'])}, "
                f"{fmt(r['ratios']['predicted_std_geomean'])} / {fmt(r['ratios']['simulated_std_geomean'])}",
                f"{r['ratios']['predicted_lower_share']:.0%}")
    g, gs = ref("grid")
    r, rs = ref("random")
    return (f"| {name} | {kind} | {n} | {len(p.identifiable)} | {c['plan']['zone_rms_um']:.3g} / "
            f"{c['plan']['simulated_zone_rms_um']:.3g} | {g} | {gs} | {r} | {rs} | {seconds:.0f} |")


def section(quick: bool = False, kinds=KINDS) -> str:
    """The comparison as a Markdown table.

    Parameters
    ----------
    quick : bool, default False
        vmc500 only, fewer candidates and simulated repeats (CI: the script must not rot).
    kinds : sequence of str, default all
        The instruments of the table ("tracker", "probe", "ballbar").

    Returns
    -------
    str
        Markdown.
    """
    lines = ["Zone: plan's predicted / simulated RMS uncertainty of the volumetric error [um]; ratios plan / "
             "reference: zone RMS predicted / simulated, geometric mean of the coefficients' uncertainties "
             "predicted / simulated; share: coefficients with a lower predicted uncertainty in the plan.", "",
             "| machine | instrument | N | identifiable | plan zone (um) | vs grid | share | vs random | share | s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name in ("vmc500",) if quick else CASES:
        for kind in kinds:
            if name in BUDGETS[kind]:
                lines.append(_row(name, kind, BUDGETS[kind][name], quick))
            print(lines[-1], file=sys.stderr, flush=True)   # progress
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--markdown", help="write the table here as well")
    parser.add_argument("--instruments", nargs="+", choices=KINDS, default=list(KINDS), help="rows to run")
    args = parser.parse_args()
    text = section(args.quick, args.instruments)
    print(text)
    if args.markdown:
        from volerr_pin.base import write_text

        write_text(args.markdown, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
