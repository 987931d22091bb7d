"""Benchmarks of volerr_pin, measured in one run on this machine and reported as ratios.

    python benchmarks/run.py [--quick] [--json FILE]

Volumetric error: the compiled batch evaluator against a per-point loop of Pinocchio calls
(what a Pinocchio user would write: frame placements for the actual and the nominal
configuration, relative pose, log3), on vmc500 and cgm4000. Sensitivities: the full
Jacobian w.r.t. all coefficients against per-point Pinocchio frame Jacobians of the tool
relative to the workpiece. The loops get their configurations precomputed (not timed), so
the ratios are, if anything, modest.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np
import pinocchio as pin

import volerr_pin as vp
from volerr_pin.workspace import sample


def best_of(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def pinocchio_loop(machine, actual, nominal):
    model = machine.model
    data = model.createData()
    tool = model.getFrameId(machine.tool_frame)
    work = model.getFrameId(machine.workpiece_frame)
    out = np.empty((len(actual), 6))
    for i in range(len(actual)):
        pin.framesForwardKinematics(model, data, actual[i])
        a = data.oMf[work].actInv(data.oMf[tool])
        pin.framesForwardKinematics(model, data, nominal[i])
        n = data.oMf[work].actInv(data.oMf[tool])
        out[i, :3] = a.translation - n.translation
        out[i, 3:] = pin.log3(a.rotation @ n.rotation.T)
    return out


def bench_volumetric(name, sizes, n_loop):
    m = vp.load_machine(name)
    m.volumetric_error(sample(m, 16))  # compile / load the kernels outside the timing
    rows = []
    q_loop = sample(m, n_loop, seed=1)
    actual = m.pinocchio_configuration(q_loop)
    nominal = m.pinocchio_configuration(q_loop, np.zeros_like(m.theta))
    reference = pinocchio_loop(m, actual, nominal)
    assert np.abs(reference - m.volumetric_error(q_loop)).max() < 1e-12
    t_loop = best_of(lambda: pinocchio_loop(m, actual, nominal), repeat=2) / n_loop
    for n in sizes:
        q = sample(m, n, seed=2)
        t = best_of(lambda: m.volumetric_error(q)) / n
        rows.append({"machine": name, "task": "volumetric_error", "points": n,
                     "batch_us_per_point": t * 1e6, "pinocchio_loop_us_per_point": t_loop * 1e6,
                     "speedup_vs_pinocchio_loop": t_loop / t})
    return rows


def pinocchio_jacobian_loop(machine, configs):
    """Per point: joint Jacobians, the two frame Jacobians and the relative Jacobian of the
    tool in the workpiece frame (GUIDE section 6). The chain rule to the coefficients is not
    timed, so the comparison favours the loop."""
    model = machine.model
    data = model.createData()
    T, W = model.getFrameId(machine.tool_frame), model.getFrameId(machine.workpiece_frame)
    out = np.empty((len(configs), 6, model.nv))
    for i, qc in enumerate(configs):
        pin.computeJointJacobians(model, data, qc)
        oMt = pin.updateFramePlacement(model, data, T)
        oMw = pin.updateFramePlacement(model, data, W)
        Jt = pin.getFrameJacobian(model, data, T, pin.LOCAL_WORLD_ALIGNED)
        Jw = pin.getFrameJacobian(model, data, W, pin.LOCAL_WORLD_ALIGNED)
        Rt = oMw.rotation.T
        out[i, :3] = Rt @ (Jt[:3] - Jw[:3] + pin.skew(oMt.translation - oMw.translation) @ Jw[3:])
        out[i, 3:] = Rt @ (Jt[3:] - Jw[3:])
    return out


def bench_sensitivity(name, n, n_loop):
    m = vp.load_machine(name)
    m.sensitivity(sample(m, 16))
    q_loop = sample(m, n_loop, seed=3)
    configs = m.pinocchio_configuration(q_loop)
    t_loop = best_of(lambda: pinocchio_jacobian_loop(m, configs), repeat=2) / n_loop
    q = sample(m, n, seed=4)
    t = best_of(lambda: m.sensitivity(q), repeat=2) / n
    return [{"machine": name, "task": "sensitivity", "points": n, "parameters": len(m.theta),
             "batch_us_per_point": t * 1e6, "pinocchio_loop_us_per_point": t_loop * 1e6,
             "speedup_vs_pinocchio_loop": t_loop / t}]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (CI)")
    parser.add_argument("--json", help="write the results to this file")
    args = parser.parse_args(argv)
    sizes = [10_000] if args.quick else [10_000, 100_000, 1_000_000]
    n_loop = 500 if args.quick else 5_000
    results = []
    for name in ("vmc500", "cgm4000"):
        results += bench_volumetric(name, sizes, n_loop)
    for name in ("vmc500", "cgm4000"):
        results += bench_sensitivity(name, 10_000 if args.quick else 100_000, n_loop)
    info = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                       f"Python {platform.python_version()}, pin {pin.__version__}",
            "results": results}
    print(f"# {info['machine']}")
    print("| task | machine | points | batch [us/point] | Pinocchio loop [us/point] | speed-up |")
    print("|---|---|---|---|---|---|")
    for r in results:
        print(f"| {r['task']} | {r['machine']} | {r['points']:,} | {r['batch_us_per_point']:.3f} | "
              f"{r['pinocchio_loop_us_per_point']:.2f} | {r['speedup_vs_pinocchio_loop']:.1f}x |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(info, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
