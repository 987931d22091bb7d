"""Simulated measurement campaigns, for examples, tests and trying the tools out.

:func:`campaign` visits commanded positions in random order over a few hours and records
every covariate column the product reads: time, three temperature sensors with different
dynamics (a spindle bearing warming up, a column following a slow cycle, the room), process
forces on half of the points, and random approach directions. The measured deviations are
a machine's volumetric error plus independent noise.
"""

from __future__ import annotations

import numpy as np

from .machine import Machine
from .measurements import PointMeasurements


def covariates(n: int, rng: np.random.Generator, hours: float = 6.0, n_axes: int = 3) -> dict:
    """Time [s], temperatures [degC], forces [N] and directions (+1/-1) for ``n`` points."""
    t = np.sort(rng.uniform(0.0, hours * 3600.0, n))
    temps = {"spindle": 22.0 + 8.0 * (1 - np.exp(-t / 2700.0)) + rng.normal(0, 0.1, n),
             "column": 21.0 + 2.0 * np.sin(2 * np.pi * t / (5 * 3600.0)) + rng.normal(0, 0.1, n),
             "ambient": 20.0 + 1.5 * np.cos(2 * np.pi * t / (3 * 3600.0) + 1.0) + rng.normal(0, 0.1, n)}
    loaded = rng.random(n) < 0.5
    forces = np.where(loaded[:, None], rng.normal(0.0, 150.0, (n, 3)), 0.0)
    directions = rng.choice([-1.0, 1.0], (n, n_axes))
    return {"t": t, "temperatures": temps, "forces": forces, "directions": directions}


def campaign(truth: Machine, n: int = 400, noise_um: float = 0.3, seed: int = 0, hours: float = 6.0,
             source: str = "simulated") -> PointMeasurements:
    """``n`` tool-point measurements (dx, dy, dz) of the machine ``truth`` with noise."""
    rng = np.random.default_rng(seed)
    travel = truth.travel
    travel = np.where(np.isfinite(travel), travel, np.array([-np.pi, np.pi]))
    q = rng.uniform(travel[:, 0], travel[:, 1], (n, len(truth.axes)))
    cov = covariates(n, rng, hours, len(truth.axes))
    values = np.full((n, 6), np.nan)
    values[:, :3] = truth.volumetric_error(q, **cov)[:, :3] + rng.normal(0.0, noise_um * 1e-6, (n, 3))
    return PointMeasurements(source, q, values, cov, np.arange(n))


def write_points(data: PointMeasurements, machine: Machine, path) -> None:
    """Write point measurements in the CONTRACT format (mm / deg, um, covariate columns)."""
    cols = [a.lower() for a in machine.axes]
    factors = [1e3 if k == "linear" else 180.0 / np.pi for k in machine.axis_kinds]
    measured = [k for k in range(6) if not np.all(np.isnan(data.values[:, k]))]
    names = ["dx", "dy", "dz", "rx", "ry", "rz"]
    header = cols + [names[k] for k in measured]
    cov = data.covariates
    if "t" in cov:
        header.append("t")
    sensors = list((cov.get("temperatures") or {}))
    header += [f"T_{s}" for s in sensors]
    if cov.get("forces") is not None:
        header += ["Fx", "Fy", "Fz"]
    if cov.get("directions") is not None:
        header += [f"dir_{a.lower()}" for a in machine.axes]
    lines = [",".join(header)]
    for i in range(len(data.q)):
        row = [f"{data.q[i, j] * factors[j]:.6f}" for j in range(len(machine.axes))]
        row += ["" if np.isnan(data.values[i, k]) else f"{data.values[i, k] * 1e6:.5f}" for k in measured]
        if "t" in cov:
            row.append(f"{cov['t'][i]:.3f}")
        row += [f"{cov['temperatures'][s][i]:.4f}" for s in sensors]
        if cov.get("forces") is not None:
            row += [f"{v:.3f}" for v in cov["forces"][i]]
        if cov.get("directions") is not None:
            row += [f"{int(v)}" for v in cov["directions"][i]]
        lines.append(",".join(row))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
