"""Planning a tracker campaign on vmc500
=====================================

Plan a tracker campaign on vmc500, run it in simulation, and settle what a diagnosis left open.

The story: a calibration engineer has a laser tracker (5 um per coordinate) and two
reflectors on the spindle, one at the tool point and one 100 mm off it along x. The example

1. plans 40 poses (D-optimal over what the tracker can identify), compares them with a grid
   and random poses of the same count, and writes the plan, the results template and the NC
   program that visits the poses;
2. fills the template with a simulated measurement of the machine (exact kinematics, 5 um
   of noise, the tracker 1.5 m away) and identifies the machine from it;
3. takes a diagnosis that could not tell the roll of Z (EAZ) from the y straightness of X and
   Z (EYX, EYZ) at the tool, and plans the 12 extra poses with a second tool length (100 mm)
   that separate them, shown by simulation.

Run it with ``python examples/plan_vmc500.py [OUTPUT_DIR]``.
"""

from __future__ import annotations

import csv
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

import volerr_pin as vp
from volerr_pin.fit.identify import identify
from volerr_pin.measurements import read_any
from volerr_pin.studies.plan import after_diagnosis, instrument, make_setup, nc_program, plan, time_estimate
from volerr_pin.base import write_text

TARGETS_M = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])
TRACKER_AT_MM = np.array([1500.0, -800.0, 300.0])


def fill(machine, template: Path, out: Path, noise_um: float, seed: int) -> None:
    """The template's empty tx, ty, tz filled with the targets' actual positions (exact
    kinematics) seen from a tracker at TRACKER_AT_MM, plus noise."""
    lines = template.read_text().splitlines()
    rows = list(csv.reader(ln for ln in lines if not ln.startswith("#")))
    header, body = rows[0], rows[1:]
    q = np.array([[float(r[header.index(a.lower())]) for a in machine.axes] for r in body]) * 1e-3
    o = np.array([[float(r[header.index(c)]) for c in ("ox", "oy", "oz")] for r in body]) * 1e-3
    R, p = machine.tool_poses(q)
    xyz = (p + np.einsum("nij,nj->ni", R, o)) * 1e3 - TRACKER_AT_MM
    xyz += np.random.default_rng(seed).normal(0.0, noise_um * 1e-3, xyz.shape)
    for r, v in zip(body, xyz):
        for c, x in zip(("tx", "ty", "tz"), v):
            r[header.index(c)] = f"{x:.5f}"
    write_text(out, "\n".join([*(ln for ln in lines if ln.startswith("#")), *(",".join(r) for r in [header, *body])])
               + "\n")


def main(out_dir: Path) -> dict:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    m = vp.load_machine("vmc500")
    tracker = instrument("tracker")
    setup = make_setup(m, tracker, targets=TARGETS_M)
    p = plan(m, tracker, 40, setup, candidates=512, compare=True, repeats=3)
    report = p.to_dict()
    print(f"plan: {len(p.units)} poses, predicted uncertainty of the volumetric error over the zone "
          f"{report['predicted']['zone_rms_um']:.2f} um RMS; {len(p.not_separable)} groups no tracker plan separates")
    for label in ("grid", "random"):
        c = report["comparison"][label]
        what = (f"leaves {len(c['not_identified'])} coefficients undetermined" if c["not_identified"] else
                f"plan / {label}: zone RMS predicted {c['ratios']['predicted_zone_rms']:.2f}, "
                f"simulated {c['ratios']['simulated_zone_rms']:.2f}")
        print(f"{label} of 40 poses: {what}")
    visits = tracker.visits(m, p.units)
    write_text(out_dir / "plan.csv", tracker.table(m, setup, p.units))
    write_text(out_dir / "results.csv", "# fill tx, ty, tz (mm, tracker frame)\n" + tracker.table(m, setup, p.units))
    write_text(out_dir / "plan.nc", nc_program(m, visits, 2000.0, 3.0, "vmc500 tracker campaign"))
    time = time_estimate(m, visits, 2000.0, 3.0)
    print(f"machine time: {time['total_min']:.1f} min ({time['path_mm']:.0f} mm of path at 2000 mm/min, 3 s dwells)")

    fill(m, out_dir / "results.csv", out_dir / "measured.csv", 5.0, seed=1)
    prior = m.with_theta(np.zeros(len(m.theta)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = identify(prior, [read_any(out_dir / "measured.csv", m)], folds=0, sigma_um=5.0, initialise=False)
    print(f"identified from the simulated campaign: residual {fit.rms_fit_um:.2f} um RMS of the 3D norm "
          f"(5 um of noise per coordinate), residual / stated sigma {fit.residual_sigma:.2f}")

    diagnosis = {"machine": "vmc500", "effects": [{"name": "straightness", "component": "EAZ",
                                                   "same_at_tool_as": ["EYX", "EYZ"]}], "under_modelled": []}
    two_tools = make_setup(m, tracker, targets=[[0.0, 0.0, 0.0], [0.0, 0.0, -0.1]])
    after = after_diagnosis(m, tracker, two_tools, diagnosis, 12, candidates=512)
    print(f"after the diagnosis: 12 extra poses with a 100 mm longer tool separate "
          f"{sum(r['separated'] for r in after.simulation.values())} of {len(after.simulation)} coefficients; "
          f"still inseparable: {[g.parameters for g in after.not_separable]}")
    return {"plan": report, "fit_rms_um": fit.rms_fit_um, "after": after.to_dict()}


if __name__ == "__main__":
    if len(sys.argv) > 1:
        main(Path(sys.argv[1]))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            main(Path(tmp))
