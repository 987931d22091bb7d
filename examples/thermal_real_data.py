"""Thermal models on real measurements
===================================

Thermal models on real measurements from other groups (read in place, never copied).

Looks for the data in ``$VOLERR_REAL_DATA`` or in ``shared/real-data`` beside the repository;
docs/real-data.md gives their public sources (no licence is stated, so they are not in this
repository) and the layout:

- ``sjtu_spindle_thermal`` (R. Du, github.com/ruoheng-du/thermal-expansion-error-prediction):
  a motorised spindle over 78 h at 1 min, thermal elongation
  ``delta L`` [um] and 16 temperatures. The published one-step-ahead linear model
  ``delta_L(t) ~ 1 + T0..T15(t-1) + delta_L(t-1)`` has residual SE 0.125 um and R^2 0.9987.
- ``gooddash_thermal_batches`` (github.com/GOODDASH/soft_py): five batches of 22 temperature rises and a thermal error;
  fit on four batches, predict the fifth.

Run it with ``python examples/thermal_real_data.py``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

from volerr_pin.measurements import read_series
from volerr_pin.applications.thermalfit import thermal_fit


def data_dir() -> Path | None:
    env = os.environ.get("VOLERR_REAL_DATA")
    candidates = [Path(env)] if env else []
    candidates.append(Path(__file__).resolve().parents[2] / "shared" / "real-data")
    return next((c for c in candidates if c.is_dir()), None)


def spindle(root: Path) -> dict:
    data = read_series(root / "sjtu_spindle_thermal" / "spindle_thermal_original.csv")
    out = {}
    full = thermal_fit(data, "delta L", lag=1)
    out["published_model"] = full
    print(f"SJTU spindle, one-step linear model on all {full['n_fit']} rows: residual SE "
          f"{full['residual_se']:.6f} um, R^2 {full['r2']:.5f} (published 0.124949, 0.99872)")
    for label, kw in (("one-step linear, lag 1", {"lag": 1}), ("static linear, lag 0", {"lag": 0}),
                      ("GM(1,N) one step", {"method": "gm1n"}), ("variable-weight GM(1,N)", {"method": "vwgm1n"}),
                      ("GM(1,1)", {"method": "gm11"})):
        r = thermal_fit(data, "delta L", holdout=0.2, **kw)
        out[label] = r
        print(f"  {label:<26} fit on the first 80 %: R^2 {r['r2']:.5f}, SE {r['residual_se']:.3f} um; "
              f"last 20 % ({r['n_holdout']} rows): RMSE {r['rmse_holdout']:.3f} um")
    top = thermal_fit(data, "delta L", lag=0)["sensor_ranking"]
    print("  most informative sensors for the static model: "
          + ", ".join(f"{s['sensor']} (R^2 {s['r2']:.3f})" for s in top))
    return out


def batches(root: Path) -> dict:
    files = sorted((root / "gooddash_thermal_batches").glob("data_ex*.csv"))
    published_tsp = ["dT3", "dT7", "dT10", "dT13", "dT20", "dT21"]
    rows = {}
    spread = [np.ptp(read_series(f).columns["error"]) for f in files]
    print(f"GOODDASH batches: thermal error range per batch {', '.join(f'{s:.1f}' for s in spread)} "
          "(unit not stated, presumably um); fit on four, predict the fifth:")
    for label, sensors, kw in (("static linear, 22 sensors", None, {"lag": 0}),
                               ("static linear, 6 published TSPs", published_tsp, {"lag": 0}),
                               ("one-step linear, 22 sensors", None, {"lag": 1}),
                               ("GM(1,N), 6 TSPs", published_tsp, {"method": "gm1n"}),
                               ("variable-weight GM(1,N), 6 TSPs", published_tsp, {"method": "vwgm1n"})):
        rmse = []
        for i, test in enumerate(files):
            train = read_series([f for f in files if f != test])
            rmse.append(thermal_fit(train, "error", sensors, test=read_series(test), **kw)["rmse_holdout"])
        rows[label] = rmse
        print(f"  {label:<34} held-out RMSE per batch: {' '.join(f'{v:6.2f}' for v in rmse)}")
    return rows


def main() -> int:
    root = data_dir()
    if root is None:
        print("real data not found: this example needs sjtu_spindle_thermal/spindle_thermal_original.csv and "
              "gooddash_thermal_batches/data_ex1.csv ... data_ex5.csv from their public sources (docs/real-data.md says where and how to lay them out), in the folder named by VOLERR_REAL_DATA "
              "or in shared/real-data beside the repository")
        return 0
    spindle(root)
    batches(root)
    return 0


if __name__ == "__main__":
    sys.exit(main())
