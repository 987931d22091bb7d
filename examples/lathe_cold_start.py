"""A lathe's cold start (seed 000)
===============================

Seed 000's cold-start scenario on lathe_2axis, recorded in Rerun on a ``time`` timeline.

Seed 000 runs its turning centre through a 20-hour load cycle and finds the resultant
volumetric error near 65 um at cold start, settling near 10 um after about two hours. Here
the bundled lathe_2axis gets thermal-drift terms on its spindle (body S) that reproduce that
behaviour: an axial and a radial offset at cold start that settle to small warm offsets with
time constants of 30 and 40 minutes (``thermal_drift`` driven by time: the cold-start offset
as a constant plus a saturating term towards the warm value). The example

- prints the resultant error at the reference point over the cycle, and draws it beside the
  recording (``OUTPUT.png``: the resultant and its components over the 20 hours),
- writes a Rerun recording: the machine, the error field over the (Z, X) travel on the
  ``time`` timeline (one frame every 10 minutes), and the resultant and component errors at
  the reference point as bulk time series (``send_columns``).

Run it with ``python examples/lathe_cold_start.py [OUTPUT.rrd]`` and open the file with
``rerun OUTPUT.rrd``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import rerun.blueprint as rrb

import volerr_pin as vp
from volerr_pin.viz import save
from volerr_pin.viz import (eye_on, log_field, log_machine, log_time_series, new_recording, opened_paused, streaming,
                            whole_range)
from volerr_pin.model import add_terms, default_config, evaluate_field, field_grid

HOURS = 20.0
REFERENCE_MM = (-250.0, 100.0)  # Z, X: mid-length of a part, 100 mm radius
COLD_START = {  # spindle offsets at cold start and when warm [um], time constant [min]
    "EZS": (65.8, -3.0, 30.0),
    "EXS": (25.0, 4.0, 40.0),
}


def cold_start_machine() -> vp.Machine:
    """lathe_2axis with a cold-start offset on the spindle that decays as it warms up."""
    machine = vp.load_machine("lathe_2axis")
    tables = {}
    for name, (cold, warm, tau) in COLD_START.items():
        tables[name] = [
            {"kind": "constant", "prefix": "cold", "value_um": cold},
            {"kind": "thermal_drift", "driver": "time", "prefix": "warmup",
             "amplitudes_um": [warm - cold], "time_constants_min": [tau]},
        ]
    return add_terms(machine, tables)


def cold_start_png(t: np.ndarray, resultant: np.ndarray, error: np.ndarray, path: Path) -> None:
    """The error at the reference point over the cycle: the resultant and its x and z parts."""
    hours = t / 3600.0
    fig, ax = plt.subplots(figsize=(8.0, 4.0), dpi=120, constrained_layout=True)
    ax.plot(hours, resultant, color="black", lw=1.6, label="resultant")
    ax.plot(hours, error[:, 2], color="#1f6fb2", lw=1.0, label="dz (axial)")
    ax.plot(hours, error[:, 0], color="#c0392b", lw=1.0, label="dx (radial)")
    ax.axhline(0.0, color="grey", lw=0.5)
    ax.set_xlabel("time since cold start [h]")
    ax.set_ylabel("error at the reference point [um]")
    ax.set_title(f"lathe_2axis cold start at Z {REFERENCE_MM[0]:g}, X {REFERENCE_MM[1]:g} mm: "
                 f"{resultant[0]:.0f} um cold, {resultant[-1]:.0f} um warm", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save(fig, path)   # through a temporary file beside it
    print(f"wrote {path}")


def main(out: Path) -> dict:
    out.parent.mkdir(parents=True, exist_ok=True)
    machine = cold_start_machine()
    t = np.arange(0.0, HOURS * 3600.0 + 1.0, 60.0)               # one sample a minute
    q_ref = np.tile(np.array(REFERENCE_MM) * 1e-3, (len(t), 1))
    error = machine.volumetric_error(q_ref, t=t) * 1e6           # um (and urad)
    resultant = np.linalg.norm(error[:, :3], axis=1)
    for hours in (0.0, 0.5, 1.0, 2.0, 5.0, 20.0):
        k = int(round(hours * 60))
        print(f"t = {hours:4.1f} h: resultant error {resultant[k]:5.1f} um "
              f"(dx {error[k, 0]:+.1f}, dy {error[k, 1]:+.1f}, dz {error[k, 2]:+.1f})")

    cold_start_png(t, resultant, error, out.with_suffix(".png"))

    rec = new_recording("volerr_pin_lathe_cold_start")
    q = field_grid(machine, [9, 5])
    # opens paused at t = 0 (cold), the field framed from outside the machine, the whole 20 hours plotted
    blueprint = rrb.Blueprint(
        rrb.Horizontal(rrb.Spatial3DView(origin="/", contents=["+ machine/**", "+ field/**", "- field/components/**"],
                                         name="machine and error field at the time cursor",
                                         eye_controls=eye_on(machine, default_config(machine),
                                                             machine.tool_poses(q, nominal=True)[1])),
                       rrb.TimeSeriesView(origin="thermal", name="error at the reference point [um], 20 h",
                                          **whole_range("time")),
                       column_shares=[3, 2]),
        opened_paused(timeline="time", state="expanded"))
    with streaming(rec, out, blueprint):   # a temporary file beside out, renamed on success
        log_machine(rec, machine, np.array(REFERENCE_MM) * 1e-3)
        log_time_series(rec, t, {"resultant_um": resultant, "dx_um": error[:, 0], "dz_um": error[:, 2]})
        frames = t[::10]
        peak = max(np.linalg.norm(machine.volumetric_error(q, t=np.full(len(q), s))[:, :3], axis=1).max()
                   for s in frames[:3]) * 1e6
        scale = 500.0
        for s in frames:
            rec.set_time("time", duration=float(s))
            field = evaluate_field(machine, q, scale, t=np.full(len(q), s))
            log_field(rec, machine, field, static=False, legend=s == frames[0], colour_max=peak)
    print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB): field on the 'time' timeline "
          f"({len(frames)} frames), arrows x{scale:g}; open it with: rerun {out}")
    return {"t": t, "resultant_um": resultant, "path": out, "frames": len(frames)}


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()) / "lathe_cold_start.rrd"
    main(target)
