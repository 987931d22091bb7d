"""Ballbar round trip on vmc500 (ISO 230-4)
========================================

Known errors in, circles simulated, errors out.

The story: a vmc500 has, beyond its spec, 4 um of backlash in X and 2 um in Y, a
squareness of X and Y 8 arcsec off the spec's, and a Y scale 12 um/m long. A ballbar of
100 mm runs one circle each way in the XY plane, set up 3 um / -2 um off centre with a bar
0.8 um long. The example

1. simulates the circles exactly (bar length between the balls, not the model's radial
   projection) with 0.1 um of noise and writes them as a ballbar file;
2. evaluates them as ISO 230-4 does (circular deviation G, hysteresis H, radial deviation F)
   and draws the polar picture;
3. identifies the four errors and the set-up through the machine model - the same one every
   other measurement goes through - and compares them with the truth;
4. lets ``diagnose`` find, from the circles alone, what the bundled spec is missing.

Run it with ``python examples/ballbar_round_trip.py [OUTPUT_DIR]``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

import volerr_pin as vp
from volerr_pin.measurements import ballbar_run, evaluate_circular, read_ballbar, write_ballbar
from volerr_pin.fit.identify import identify
from volerr_pin.viz import ballbar_png
from volerr_pin.model import add_terms

CENTRE = {"X": 250.0, "Y": 200.0, "Z": 200.0}
TRUTH = {"EXX.rev.b": 4.0, "EYY.rev.b": 2.0, "EC0Y.c0": None, "EYY.scale.c1": 12.0 * 0.2}  # um, um, arcsec, um


def machines() -> tuple[vp.Machine, vp.Machine]:
    """(the model to fit: spec plus zero-valued extra terms, the simulated truth)."""
    spec = vp.load_machine("vmc500")
    model = add_terms(spec, {
        "EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 0.0},
        "EYY": [{"kind": "backlash", "prefix": "rev", "reversal_um": 0.0},
                # a scale error: linear over Y's travel, +-12 um/m x 200 mm at the travel ends
                {"kind": "legendre", "prefix": "scale", "coefficients_um": [0.0, 0.0]}]})
    names = list(model.parameter_names)
    theta = model.theta.copy()
    TRUTH["EC0Y.c0"] = float(np.degrees(theta[names.index("EC0Y.c0")]) * 3600 + 8.0)
    for name, value in TRUTH.items():
        theta[names.index(name)] = np.radians(value / 3600) if name == "EC0Y.c0" else value * 1e-6
    return model, model.with_theta(theta)


def main(out: Path) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    model, truth = machines()
    path = out / "vmc500_circle_xy.csv"
    write_ballbar(ballbar_run(truth, plane=("X", "Y"), radius_mm=100.0, centre_mm=CENTRE, noise_um=0.1,
                              seed=7, setup_offset_um=(3.0, -2.0), length_error_um=0.8), path)
    run = read_ballbar(path)
    iso = evaluate_circular(run)
    ballbar_png(run, iso, out / "circle_xy.png", title="ISO 230-4: simulated vmc500, XY, 100 mm")
    print(f"ISO 230-4 on {path.name}: G {iso['G']:.2f} um (ccw {iso['G_ccw']:.2f}, cw {iso['G_cw']:.2f}), "
          f"H {iso['H']:.2f} um, F {iso['F_min']:+.2f} .. {iso['F_max']:+.2f} um")

    names = list(model.parameter_names)
    fit = identify(model, [run], free=[names.index(n) for n in TRUTH], folds=5, sigma_um=0.1).to_dict()
    print("identified through the model (truth, fitted +- standard uncertainty):")
    worst = 0.0
    for name, value in TRUTH.items():
        p = fit["parameters"][name]
        z = abs(p["value"] - value) / p["uncertainty"]
        worst = max(worst, z)
        print(f"  {name:<14} {value:9.3f}  {p['value']:9.3f} +- {p['uncertainty']:.3f} {p['unit']}  ({z:.1f} sigma)")
    setup = {k.split("[")[0]: v["value"] for k, v in fit["nuisance"].items()}
    print(f"  set-up: centre {setup['centre_X']:+.2f}, {setup['centre_Y']:+.2f} um (the ball sits +3, -2 um off: "
          f"the bar reads minus that), bar length {setup['length']:+.2f} um (0.8); residual "
          f"{fit['rms_fit_um']:.3f} um, held out {fit['rms_holdout_um']:.3f} um")

    found = vp.diagnose(vp.load_machine("vmc500"), [run])
    print("diagnose from the circles alone, on the bundled spec: "
          + "; ".join(f"{e.name} of {e.axis or e.direction}: "
                      + ", ".join(f"{k} = {v['value']:.2f} +- {v['uncertainty']:.2f} {v['unit']}"
                                  for k, v in e.parameters.items()) for e in found.effects)
          + f"; held-out RMS {found.rms_before_um:.2f} -> {found.rms_after_um:.2f} um")
    return {"iso": iso, "fit": fit, "worst_sigma": worst, "diagnosis": found.to_dict(), "path": path}


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()))
