"""Benchmarks of volerr_pin, measured in one run on this machine and reported as ratios.

    python benchmarks/run.py [--quick] [--json FILE] [--markdown FILE]

1. Volumetric error on vmc500 and cgm4000 for 1e4, 1e5, 1e6 points: the compiled batch
   evaluator against (a) a per-point loop of Pinocchio calls (what a Pinocchio user would
   write: frame placements for the actual and the nominal configuration, relative pose,
   log3), (b) a naive per-point numpy product of 4x4 homogeneous matrices along the same
   chain (what the papers' authors write), (c) for the 3-axis vmc500, the classic 21-term
   first-order expression vectorised by hand over all points (a near-limit reference: it
   still has to evaluate the component errors). Peak memory of a 1e6-point evaluation is
   measured in a separate process.
2. Sensitivities: the full Jacobian w.r.t. every coefficient against a per-point loop of
   Pinocchio frame Jacobians chained to the coefficients, both writing the same array.
3. End to end: identification with 1e4 points and the full coefficient set, diagnosis of
   400- and 4,000-point sets (one core, CPU seconds; geometry exactly the spec's, or off its
   function space), compensation of a 10,000-block NC program at 1 um.
4. Scaling of the batch evaluator with N (1e3 .. 1e6).

5. The benchmarks of the other parts, each a script of its own in this folder that also runs
   alone (``SECTIONS``): controller exports, uncertainty and tolerance studies, measurement
   planning, NC programs, diagnosis threads, predicted parts. Each gives
   ``section(quick) -> str``, its Markdown, appended under its own heading.

Every loop is checked against the batch result before it is timed; the loops get their
joint configurations precomputed (not timed), so the ratios are, if anything, modest.
Tests never assert wall-clock times; this script reports them.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

import volerr_pin as vp
from volerr_pin.model import _kinematics as K, check_covariates, parameter_jacobian, sample


def best_of(fn, repeat=3):
    """Best of ``repeat`` timed runs after one untimed warm-up run (steady state: the
    allocator has settled, the threads of the parallel kernels are up)."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


# ------------------------------------------------------------------ the alternatives
def pinocchio_loop(machine, actual, nominal):
    model = machine.model.pinocchio
    data = model.createData()
    tool = model.getFrameId(machine.tool_frame)
    work = model.getFrameId(machine.workpiece_frame)
    out = np.empty((len(actual), 6))
    for i in range(len(actual)):
        # the least a Pinocchio user writes: joint placements, then the two frames' only
        pin.forwardKinematics(model, data, actual[i])
        a = pin.updateFramePlacement(model, data, work).actInv(pin.updateFramePlacement(model, data, tool))
        pin.forwardKinematics(model, data, nominal[i])
        n = pin.updateFramePlacement(model, data, work).actInv(pin.updateFramePlacement(model, data, tool))
        out[i, :3] = a.translation - n.translation
        out[i, 3:] = pin.log3(a.rotation @ n.rotation.T)
    return out


def _motion(kind, axis, v):
    """4x4 homogeneous matrix of a joint motion (Rodrigues for revolute joints)."""
    T = np.eye(4)
    if kind in (K.PX, K.PY, K.PZ, K.PG):
        T[:3, 3] = axis * v
        return T
    x, y, z = axis
    s, c = math.sin(v), math.cos(v)
    t = 1.0 - c
    T[:3, :3] = [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                 [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                 [t * x * z - s * y, t * y * z + s * x, t * z * z + c]]
    return T


def _homogeneous(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def naive_numpy_loop(machine, values):
    """Per point: multiply 4x4 matrices along the workpiece -> tool chain, once with the
    error joints and once without, then the relative pose and its rotation vector."""
    ch = machine.model.chain
    consts = [_homogeneous(ch.C_R[k], ch.C_p[k]) for k in range(len(ch.kind))]
    end = _homogeneous(ch.end_R[0], ch.end_p[0])
    out = np.empty((len(values), 6))
    for i in range(len(values)):
        Ta, Tn = np.eye(4), np.eye(4)
        for k in range(len(ch.kind)):
            M = _motion(ch.kind[k], ch.axis[k], ch.sign[k] * values[i, ch.col[k]])
            Ta = Ta @ consts[k] @ M
            Tn = Tn @ consts[k] @ (np.eye(4) if ch.is_error[k] else M)
        Ta, Tn = Ta @ end, Tn @ end
        D = Ta[:3, :3] @ Tn[:3, :3].T
        w = 0.5 * np.array([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])
        s = np.linalg.norm(w)
        angle = math.atan2(s, 0.5 * (np.trace(D) - 1.0))
        out[i, :3] = Ta[:3, 3] - Tn[:3, 3]
        out[i, 3:] = w * (angle / s if s > 1e-12 else 1.0)
    return out


TOOL_LENGTH_VMC500 = 0.2  # m, machines/vmc500/README.md


def closed_form_vmc500(machine, q):
    """The classic 21-term first-order volumetric error of vmc500, vectorised by hand."""
    X, Y, Z = q.T
    L = TOOL_LENGTH_VMC500
    e = dict(zip(machine.components, machine.component_values(q).T))
    dx = (e["EXX"] + e["EXY"] + e["EXZ"] + (e["EBX"] + e["EBY"]) * Z - e["ECY"] * Y
          - e["EBZ"] * L + e["EB0Z"] * (Z - L))
    dy = (e["EYX"] + e["EYY"] + e["EYZ"] + e["ECX"] * X - e["EAX"] * Z + e["ECY"] * X
          - e["EAY"] * Z + e["EAZ"] * L + e["EC0Y"] * X - e["EA0Z"] * (Z - L))
    dz = e["EZX"] + e["EZY"] + e["EZZ"] - e["EBX"] * X + e["EAY"] * Y - e["EBY"] * X
    rx = e["EAX"] + e["EAY"] + e["EAZ"] + e["EA0Z"]
    ry = e["EBX"] + e["EBY"] + e["EBZ"] + e["EB0Z"]
    rz = e["ECX"] + e["ECY"] + e["ECZ"] + e["EC0Y"]
    return np.column_stack([dx, dy, dz, rx, ry, rz])


def pinocchio_sensitivity_loop(machine, configs, basis, pcol, out):
    """Per point: joint Jacobians, the frame Jacobians of tool and workpiece, the relative
    Jacobian in the workpiece frame (GUIDE section 6), the inverse left Jacobian of the
    rotation error, and the chain rule to the coefficients (one joint column per
    coefficient, scaled by the term's basis value), written into ``out`` (N, 6, P)."""
    model = machine.model.pinocchio
    data = model.createData()
    T, W = model.getFrameId(machine.tool_frame), model.getFrameId(machine.workpiece_frame)
    J = np.empty((6, model.nv))
    for i, qc in enumerate(configs):
        pin.computeJointJacobians(model, data, qc)
        oMt = pin.updateFramePlacement(model, data, T)
        oMw = pin.updateFramePlacement(model, data, W)
        Jt = pin.getFrameJacobian(model, data, T, pin.LOCAL_WORLD_ALIGNED)
        Jw = pin.getFrameJacobian(model, data, W, pin.LOCAL_WORLD_ALIGNED)
        Rt = oMw.rotation.T
        J[:3] = Rt @ (Jt[:3] - Jw[:3] + pin.skew(oMt.translation - oMw.translation) @ Jw[3:])
        J[3:] = Rt @ (Jt[3:] - Jw[3:])
        np.multiply(J[:, pcol], basis[i], out=out[i])
    return out


# ------------------------------------------------------------------ measurements
def bench_volumetric(name, sizes, n_loop, n_naive):
    m = vp.load_machine(name)
    m.volumetric_error(sample(m, 16))  # compile / load the kernels outside the timing
    rows = []
    q_loop = sample(m, n_loop, seed=1)
    actual = m.pinocchio_configuration(q_loop)
    nominal = m.pinocchio_configuration(q_loop, np.zeros_like(m.theta))
    batch_loop = m.volumetric_error(q_loop)
    assert np.abs(pinocchio_loop(m, actual, nominal) - batch_loop).max() < 1e-12
    values = m.joint_values(q_loop[:n_naive])
    assert np.abs(naive_numpy_loop(m, values) - batch_loop[:n_naive]).max() < 1e-12
    t_pin = best_of(lambda: pinocchio_loop(m, actual, nominal), repeat=2) / n_loop
    t_naive = best_of(lambda: naive_numpy_loop(m, values), repeat=2) / n_naive
    closed = name == "vmc500"
    if closed:
        q_check = sample(m, 200, seed=5)
        assert np.abs(closed_form_vmc500(m, q_check) - m.volumetric_error(q_check, order=1)).max() < 1e-15
    for n in sizes:
        q = sample(m, n, seed=2)
        t = best_of(lambda: m.volumetric_error(q), repeat=5 if n <= 100_000 else 3) / n
        row = {"machine": name, "task": "volumetric error", "points": n, "batch_us": t * 1e6,
               "pinocchio_loop_us": t_pin * 1e6, "naive_numpy_us": t_naive * 1e6,
               "speedup_vs_pinocchio": t_pin / t, "speedup_vs_naive_numpy": t_naive / t}
        if closed:
            t_closed = best_of(lambda: closed_form_vmc500(m, q), repeat=5 if n <= 100_000 else 3) / n
            t_first = best_of(lambda: m.volumetric_error(q, order=1), repeat=5 if n <= 100_000 else 3) / n
            row.update(closed_form_us=t_closed * 1e6, batch_first_order_us=t_first * 1e6,
                       ratio_to_closed_form=t / t_closed, first_order_ratio_to_closed_form=t_first / t_closed)
        rows.append(row)
    return rows


def bench_sensitivity(name, n, n_loop):
    m = vp.load_machine(name)
    m.sensitivity(sample(m, 16))
    q_loop = sample(m, n_loop, seed=3)
    configs = m.pinocchio_configuration(q_loop)
    values = m.joint_values(q_loop).T
    theta = m.theta
    cov = check_covariates(m.model, n_loop)
    basis = parameter_jacobian(m.model, q_loop, theta, cov)
    pcol = m.model.param_column
    # the batch's rotation rows carry Jl^-1 of the rotation error; apply it to the loop's
    # relative Jacobian the same way so that both compute the same numbers
    phi = K.pose_error(m.model.chain, values, None)[:, 3:]
    Jl_inv = K.log3_left_jacobian_inverse(phi)
    out = np.empty((n_loop, 6, len(theta)))
    pinocchio_sensitivity_loop(m, configs, basis, pcol, out)
    out[:, 3:] = np.einsum("nij,njp->nip", Jl_inv, out[:, 3:])
    assert np.abs(out - m.sensitivity(q_loop)).max() < 1e-9
    # the loop's time includes the coefficient basis it needs (the terms' values at the points)
    t_loop = best_of(lambda: pinocchio_sensitivity_loop(m, configs, parameter_jacobian(m.model, q_loop, theta, cov),
                                                        pcol, np.empty_like(out)), repeat=2) / n_loop
    q = sample(m, n, seed=4)
    t = best_of(lambda: m.sensitivity(q), repeat=2) / n
    return [{"machine": name, "task": f"sensitivity ({len(theta)} coefficients)", "points": n,
             "batch_us": t * 1e6, "pinocchio_loop_us": t_loop * 1e6, "speedup_vs_pinocchio": t_loop / t}]


def peak_memory(name, n):
    """Peak resident memory (MB) of a fresh process evaluating ``n`` points, and its peak
    before the evaluation (interpreter, Pinocchio, numba, the machine, the q array). Read
    from /proc/self/status (VmHWM), which starts afresh in the new process, where
    ru_maxrss would carry over the parent's peak across fork and exec."""
    code = (
        "import numpy as np, volerr_pin as vp\n"
        "def hwm():\n"
        "    for line in open('/proc/self/status'):\n"
        "        if line.startswith('VmHWM:'):\n"
        "            return float(line.split()[1]) / 1024\n"
        f"m = vp.load_machine({name!r})\n"
        "m.volumetric_error(np.tile(m.travel.mean(axis=1), (16, 1)))\n"
        "rng = np.random.default_rng(0); t = m.travel\n"
        f"q = t[:, 0] + rng.random(({n}, t.shape[0])) * (t[:, 1] - t[:, 0])\n"
        "before = hwm()\n"
        "e = m.volumetric_error(q)\n"
        "print(before, hwm())\n")
    if not os.path.exists("/proc/self/status"):
        return {"machine": name, "points": n, "peak_rss_mb": float("nan"), "rss_before_evaluation_mb": float("nan"),
                "result_array_mb": n * 6 * 8 / 2**20}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    before, after = map(float, out.stdout.split())
    return {"machine": name, "points": n, "peak_rss_mb": after, "rss_before_evaluation_mb": before,
            "result_array_mb": n * 6 * 8 / 2**20}


def bench_identification(n):
    from volerr_pin.fit.identify import identify
    from volerr_pin.measurements import campaign

    truth = vp.load_machine("vmc500")
    data = campaign(truth, n=n, noise_um=0.3, seed=1)
    start = truth.with_theta(np.zeros_like(truth.theta))
    t0 = time.perf_counter()
    result = identify(start, [data], folds=0)
    seconds = time.perf_counter() - t0
    return {"task": "identification", "machine": "vmc500", "points": n,
            "parameters": len(truth.theta), "seconds": seconds,
            "rms_fit_um": result.to_dict()["rms_fit_um"]}


DIAGNOSIS = """
import json, sys, time
import volerr_pin as vp
from volerr_pin.fit.diagnosis import diagnose
from volerr_pin.measurements import campaign, off_model_geometry
from volerr_pin.model import add_terms

n, style = int(sys.argv[1]), sys.argv[2]
m = vp.load_machine("vmc500")
truth = m if style == "spec" else off_model_geometry(m, 1, style, 1.0, 1.0)
truth = add_terms(truth, {
    "EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 4.0},
    "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [6.0],
            "time_constants_min": [50.0]}})
data = campaign(truth, n=n, noise_um=0.3, seed=2)
diagnose(m, [campaign(m, n=40, noise_um=0.3, seed=0)])  # warm-up: numba's cache, imports
cpu, wall = time.process_time(), time.perf_counter()
result = diagnose(m, [data])
print(json.dumps({"cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall,
                  "effects": sorted(e.name for e in result.effects),
                  "raised": len(result.under_modelled), "rounds": len(result.steps),
                  "rms_after_um": result.rms_after_um}))
"""


def bench_diagnosis(n, style="cubic"):
    """The model lacks two effects the simulated machine has (a 4 um backlash of Y and a
    6 um thermal drift along z with a 50 min time constant), and the machine's geometry is
    off the spec's function space (``style`` "cubic" or "spline" on every component; "spec":
    exactly the spec's). Run on one core (a fresh process with one thread for BLAS, OpenMP
    and numba); CPU seconds are the process's."""
    one = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", DIAGNOSIS, str(n), style], capture_output=True, text=True,
                         check=True, env={**os.environ, **one})
    r = json.loads(out.stdout.strip().splitlines()[-1])
    found = r["effects"] == ["backlash", "thermal_drift"]
    return {"task": "diagnosis", "machine": "vmc500", "points": n, "geometry": style, "seconds": r["wall"],
            "cpu_seconds": r["cpu"], "effects_found": len(r["effects"]), "exactly_the_hidden": found,
            "raised": r["raised"], "rounds": r["rounds"], "rms_after_um": r["rms_after_um"]}


def nc_program(n_blocks: int) -> str:
    """A finishing program as CAM writes it: a rising spiral of short G1 moves (about 1-10 mm)
    with an arc every 20 blocks, over the vmc500 workspace."""
    lines = ["%", "O2000 (benchmark)", "G21 G90 G17", "T1 M6", "S12000 M3", "G0 X250 Y200 Z150",
             "G1 Z60 F2000"]
    x, y, ang = 250.0, 200.0, 0.0
    while len(lines) < n_blocks - 2:
        r = 20 + (0.02 * len(lines)) % 170
        if len(lines) % 20 == 0:
            rr = math.hypot(x - 250, y - 200)
            a1 = math.atan2(y - 200, x - 250) + 0.3
            x2, y2 = 250 + rr * math.cos(a1), 200 + rr * math.sin(a1)
            lines.append(f"G3 X{x2:.4f} Y{y2:.4f} I{250 - x:.4f} J{200 - y:.4f}")
            x, y, ang = x2, y2, a1
            continue
        ang += 0.05
        x, y = 250 + r * math.cos(ang), 200 + r * math.sin(ang)
        lines.append(f"G1 X{x:.4f} Y{y:.4f} Z{60 + 10 * math.sin(ang / 7):.4f}")
    lines += ["M5", "M30"]
    return "\n".join(lines) + "\n"


def bench_compensation(n_blocks):
    from volerr_pin.compensation.gcode import compensate_program

    m = vp.load_machine("vmc500")
    compensate_program(m, nc_program(60))
    text = nc_program(n_blocks)
    t0 = time.perf_counter()
    _, report = compensate_program(m, text, tol_um=1.0)
    seconds = time.perf_counter() - t0
    return {"task": "NC compensation", "machine": "vmc500", "blocks": report.blocks_in,
            "blocks_out": report.blocks_out, "seconds": seconds,
            "max_before_um": report.max_before_um, "max_residual_um": report.max_residual_um}


def bench_scaling(sizes):
    m = vp.load_machine("vmc500")
    m.volumetric_error(sample(m, 16))
    rows = []
    for n in sizes:
        q = sample(m, n, seed=6)
        t = best_of(lambda: m.volumetric_error(q), repeat=5 if n < 1e5 else 2)
        rows.append({"points": n, "seconds": t, "us_per_point": t / n * 1e6})
    return rows


# ------------------------------------------------------------------ report
SECTIONS = {"export": "Controller exports", "studies": "Uncertainty and tolerance studies",
            "plan": "Measurement planning", "nc": "NC programs (volerr compensate)",
            "diagnose": "Diagnosis: its own threads against a one-thread environment",
            "predict": "Predicted parts (volerr predict)"}


def run_section(name: str, quick: bool) -> str:
    """The Markdown of ``benchmarks/<name>.py``'s ``section(quick)``, loaded from this folder."""
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.section(quick)


PAGE_HEAD = """# Benchmarks

<!-- This page is what `python benchmarks/run.py --markdown docs/benchmarks.md` writes; regenerate
it with that command on the machine named below rather than editing the figures by hand. -->

Measured on {machine}, {date}{quick}. Regenerated, on the machine it then names, by

```text
python benchmarks/run.py --markdown docs/benchmarks.md
```

A quick run (small sizes; CI runs it on every change, so that the script never rots):

```text
python benchmarks/run.py --quick --markdown benchmarks_quick.md
```

The script measures everything in one run on one machine and reports ratios and absolute
times (tests never assert times). Every alternative is checked against the batch result
before it is timed:

- **Pinocchio loop**: the least a Pinocchio user writes: per point `forwardKinematics` for the
  actual and the nominal configuration (with and without the error joints' values), the two
  frames' placements (`updateFramePlacement`), relative pose, `log3`; for sensitivities per
  point `computeJointJacobians`, both frame Jacobians, the relative Jacobian, the chain rule
  to every coefficient, written into the same (N, 6, P) array, its time including the
  coefficient basis it needs (the terms' values at the points);
- **naive numpy**: per point, 4x4 homogeneous matrices multiplied along the same chain (what
  the papers' authors write);
- **closed form**: the 21-term first-order expression of vmc500 vectorised by hand over all
  points (it still evaluates the component errors; the exact batch also computes second-order
  terms and the exact rotation).

## Results
"""


def _span(values, fmt="{:.1f}") -> str:
    lo, hi = min(values), max(values)
    return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else f"{fmt.format(lo)}-{fmt.format(hi)}"


def reading(info) -> list[str]:
    """The page's reading of this run's core tables: the ratios against their targets."""
    vol = [r for r in info["volumetric"]]
    sens = info["sensitivity"]
    closed = [r["ratio_to_closed_form"] for r in vol if "ratio_to_closed_form" in r]
    first = [r["first_order_ratio_to_closed_form"] for r in vol if "first_order_ratio_to_closed_form" in r]
    naive = [r["speedup_vs_naive_numpy"] for r in vol if "speedup_vs_naive_numpy" in r]
    scaling = {r["points"]: r["us_per_point"] for r in info["scaling"]}
    big, small = max(scaling), 10_000 if 10_000 in scaling else min(scaling)
    text = [f"This run (the machine may be shared; timings move from run to run): the batch evaluator is "
            f"{_span([r['speedup_vs_pinocchio'] for r in vol])}x faster than the Pinocchio loop (target 10x)"]
    if naive:
        text[-1] += f", {_span(naive, '{:.0f}')}x faster than naive numpy (target 50x)"
    if closed:
        text[-1] += (f", and {_span(closed, '{:.2f}')}x the time of the hand-written first-order closed form "
                     f"(target at most 1.5x; its own first-order mode {_span(first, '{:.2f}')}x)")
    text[-1] += ". Sensitivities: " + ", ".join(f"{r['speedup_vs_pinocchio']:.1f}x ({r['machine']})" for r in sens)
    text[-1] += " faster than the Pinocchio loop (target 5x)."
    if info["memory"]:
        text.append(f"A million points peak at {_span([r['peak_rss_mb'] for r in info['memory']], '{:.0f}')} MB for "
                    "the whole process (target 1 GB).")
    text.append(f"Time per point at {big:,} points is {scaling[big] / scaling[small]:.2f}x that at {small:,} "
                "(1.00 is linear scaling); below about 1e4 points the fixed cost of a call (input checks, term "
                "set-up: about 0.5 ms) shows.")
    return ["", "## Reading it", "", " ".join(text)]


def markdown(info) -> str:
    lines = [PAGE_HEAD.format(machine=info["machine"], date=info["date"], quick=" (--quick)" if info["quick"] else ""),
             "| task | machine | points | batch [us/pt] | Pinocchio loop [us/pt] | vs Pinocchio | naive numpy "
             "[us/pt] | vs naive numpy | closed form [us/pt] | batch / closed form |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in info["volumetric"] + info["sensitivity"]:
        naive = (f"{r['naive_numpy_us']:.1f} | {r['speedup_vs_naive_numpy']:.0f}x" if "naive_numpy_us" in r
                 else "- | -")
        closed = (f"{r['closed_form_us']:.3f} | {r['ratio_to_closed_form']:.2f} (first order "
                  f"{r['first_order_ratio_to_closed_form']:.2f})" if "closed_form_us" in r else "- | -")
        lines.append(f"| {r['task']} | {r['machine']} | {r['points']:,} | {r['batch_us']:.3f} | "
                     f"{r['pinocchio_loop_us']:.1f} | {r['speedup_vs_pinocchio']:.1f}x | {naive} | {closed} |")
    lines += ["", "| memory | points | peak RSS [MB] | before evaluating [MB] | result array [MB] |",
              "|---|---|---|---|---|"]
    for r in info["memory"]:
        lines.append(f"| {r['machine']} | {r['points']:,} | {r['peak_rss_mb']:.0f} | "
                     f"{r['rss_before_evaluation_mb']:.0f} | {r['result_array_mb']:.0f} |")
    lines += ["", "| end to end | size | seconds | note |", "|---|---|---|---|"]
    for r in info["end_to_end"]:
        if r["task"] == "identification":
            size, note = f"{r['points']:,} points, {r['parameters']} coefficients", f"RMS fit {r['rms_fit_um']:.3f} um"
        elif r["task"] == "diagnosis":
            geometry = {"spec": "geometry of the spec", "cubic": "cubic geometry",
                        "spline": "spline geometry"}[r["geometry"]]
            size = f"{r['points']:,} points, {geometry}"
            note = (f"{r['cpu_seconds']:.2f} s CPU on one core; "
                    + ("exactly the 2 hidden effects named" if r["exactly_the_hidden"]
                       else f"{r['effects_found']} effects named (2 hidden)")
                    + f", {r['raised']} components raised, {r['rounds']} rounds, "
                    f"held-out RMS {r['rms_after_um']:.2f} um")
        else:
            size = f"{r['blocks']:,} blocks -> {r['blocks_out']:,}"
            note = f"max error {r['max_before_um']:.1f} -> {r['max_residual_um']:.2f} um at 1 um"
        lines.append(f"| {r['task']} ({r['machine']}) | {size} | {r['seconds']:.2f} | {note} |")
    lines += ["", "| scaling (vmc500) | " + " | ".join(f"{r['points']:,}" for r in info["scaling"]) + " |",
              "|---|" + "---|" * len(info["scaling"]),
              "| us per point | " + " | ".join(f"{r['us_per_point']:.3f}" for r in info["scaling"]) + " |"]
    lines += reading(info)
    for name, text in info.get("sections", {}).items():
        lines += ["", f"## {SECTIONS[name]}", "", text.strip()]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (CI)")
    parser.add_argument("--json", help="write the results to this file")
    parser.add_argument("--markdown", help="write the Markdown tables to this file")
    args = parser.parse_args(argv)
    q = args.quick
    sizes = [10_000] if q else [10_000, 100_000, 1_000_000]
    n_loop, n_naive = (300, 100) if q else (5_000, 1_000)
    info = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                       f"Python {platform.python_version()}, pin {pin.__version__}, "
                       f"numba {__import__('numba').__version__}", "quick": q,
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
    steps = [
        ("volumetric", lambda: [r for name in ("vmc500", "cgm4000")
                                for r in bench_volumetric(name, sizes, n_loop, n_naive)]),
        ("sensitivity", lambda: [r for name in ("vmc500", "cgm4000")
                                 for r in bench_sensitivity(name, 10_000 if q else 100_000, n_loop)]),
        ("memory", lambda: [peak_memory(name, 1_000_000) for name in ("vmc500", "cgm4000")]),
        ("end_to_end", lambda: [bench_identification(2_000 if q else 10_000), bench_diagnosis(400, "spec"),
                                bench_diagnosis(400)]
         + ([] if q else [bench_diagnosis(400, "spline"), bench_diagnosis(4_000)])
         + [bench_compensation(1_000 if q else 10_000)]),
        ("scaling", lambda: bench_scaling([1_000, 10_000, 100_000] + ([] if q else [1_000_000]))),
    ]
    for key, fn in steps:
        t0 = time.perf_counter()
        info[key] = fn()
        print(f"# {key}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    info["sections"] = {}
    for name in SECTIONS:
        t0 = time.perf_counter()
        info["sections"][name] = run_section(name, q)
        print(f"# {name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    text = markdown(info)
    print(text)
    if args.markdown:
        from volerr_pin.base import write_text

        write_text(args.markdown, text + "\n")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(info, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
