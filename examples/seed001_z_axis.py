"""vmc500's Z axis from seed 001's measurements
============================================

Seed 001's Z-axis measurements on the VMC-500: ISO 230-2 figures, EZZ identified, residual.

The paper (Table 1) gives the Z-axis error at 20 points, measured twice before compensation
and once after (Renishaw ML10; 1 ct = 0.01 um). This example

1. evaluates the two runs before compensation as an ISO 230-2 unidirectional run, and draws
   the standard's picture (``iso230_z_before.png``),
2. identifies EZZ of the bundled vmc500 (re-parametrised as a Legendre polynomial of degree 6)
   from both runs, with the interferometer's zero as a nuisance term,
3. shows the predicted residual (data minus the identified model), next to the run measured
   after the paper's own compensation, and checks the model on a run it did not see
   (fit on run 1, predict run 2),
4. writes the identified spec.

Run it with ``python examples/seed001_z_axis.py [OUTPUT_DIR]``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

import volerr_pin as vp
from volerr_pin.fit.identify import identify
from volerr_pin.applications.iso230 import evaluate_runs
from volerr_pin.measurements import Runs, read_runs
from volerr_pin.model import legendre_terms, replace_terms, write_spec
from volerr_pin.viz import iso230_png

# this file's folder: the docs' gallery (sphinx-gallery) runs the examples without __file__, naming the file in argv[0]
DATA = Path(globals().get("__file__") or sys.argv[0]).resolve().parent / "data"
DEGREE = 6


def one_cycle(runs: Runs, cycle: int) -> Runs:
    keep = runs.cycle == cycle
    fields = {name: getattr(runs, name)[keep] for name in
              ("target", "cycle", "direction", "value", "file_target", "file_value", "lines")}
    return Runs(**{**runs.__dict__, **fields, "source": f"{runs.source} (cycle {cycle})"})


def residual_um(machine: vp.Machine, runs: Runs, offset_um: float) -> np.ndarray:
    """Measured minus predicted deviation [um] along Z at the run's targets."""
    q = np.tile([runs.at["X"] * 1e-3, runs.at["Y"] * 1e-3, 0.0], (len(runs.target), 1))
    q[:, 2] = runs.target
    predicted = machine.volumetric_error(q)[:, 2] * 1e6 + offset_um
    return runs.file_value - predicted


def main(out_dir: Path) -> dict:
    out_dir.mkdir(parents=True, exist_ok=True)
    before = read_runs(DATA / "seed001_table1_before.csv")
    after = read_runs(DATA / "seed001_table1_after.csv")
    iso = evaluate_runs(before)
    print(f"ISO 230-2, before compensation (2 runs, unidirectional): E_up {iso['E_up']:.3f} um, "
          f"R_up {iso['R_up']:.3f} um, A_up {iso['A_up']:.3f} um")
    iso230_png(iso, out_dir / "iso230_z_before.png", title="ISO 230-2: seed 001, vmc500 Z before compensation")

    machine = vp.load_machine("vmc500")
    machine = replace_terms(machine, legendre_terms(machine, ["EZZ"], DEGREE))
    result = identify(machine, [before], terms=["EZZ"], folds=5)
    report = result.to_dict()
    offset = next(v["value"] for v in report["nuisance"].values())
    print(f"identified EZZ (Legendre degree {DEGREE}): rank {report['rank']} of "
          f"{report['n_parameters']} coefficients; EZZ.c0 cannot be told from the interferometer "
          f"zero and stays at its prior value")
    res = residual_um(result.machine, before, offset)
    print(f"predicted residual after compensating with the model: RMS {np.sqrt(np.mean(res**2)):.4f} um "
          f"(fit), {report['rms_holdout_um']:.4f} um (5-fold held out)")

    # a run the fit did not see: fit on cycle 1, predict cycle 2
    first = identify(machine, [one_cycle(before, 1)], terms=["EZZ"], folds=0)
    offset1 = next(iter(first.nuisance.values())) * 1e6
    unseen = residual_um(first.machine, one_cycle(before, 2), offset1)
    raw = one_cycle(before, 2).file_value
    print(f"run 2 predicted from run 1: RMS {np.sqrt(np.mean((raw - raw.mean())**2)):.4f} um before, "
          f"{np.sqrt(np.mean(unseen**2)):.4f} um after model compensation")
    measured_after = after.file_value - after.file_value.mean()
    print(f"paper's run after its own compensation: RMS {np.sqrt(np.mean(measured_after**2)):.4f} um "
          "about its mean")
    std_ct = [np.std(before.file_value[before.cycle == c], ddof=1) * 100 for c in (1, 2)]
    print(f"sample std of the runs in ct: {std_ct[0]:.3f}, {std_ct[1]:.3f} before, "
          f"{np.std(after.file_value, ddof=1) * 100:.3f} after (the paper prints 'variance' 6.4534, "
          "5.8352, 3.061)")
    out = write_spec(result.machine, out_dir / "vmc500_seed001_z.toml",
                     {"data": [str(before.source)], "rms_fit_um": report["rms_fit_um"],
                      "rms_holdout_um": report["rms_holdout_um"]})
    print(f"wrote {out}")
    return {"iso": iso, "report": report, "unseen_rms_um": float(np.sqrt(np.mean(unseen**2))),
            "raw_rms_um": float(np.sqrt(np.mean((raw - raw.mean())**2))), "spec": out}


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
    main(target)
