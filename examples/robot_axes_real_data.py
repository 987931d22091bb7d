"""Robot axes from real laser-tracker data
=======================================

Circle-point analysis of a real industrial robot from laser-tracker data (read in place).

The data (Boby and Klimchik, RCIM 2021; beside the repository, never copied): a laser
tracker measured three reflectors (SMRs) on the end effector of a large 6-axis arm
(R-2000iC class) at 36 poses, six per joint, each block moving one joint. The controller
reports J3 Fanuc-style, relative to the horizontal: the physical elbow angle is J3 + J2,
which is why the J2 block commands J3 = -J2 (the elbow stays put while the shoulder turns).

For every joint this fits the three SMR circles and the axis line
(:func:`volerr_pin.applications.axisfit.fit_axis`). It prints how far the points lie from their circles
(the per-axis fit residual), how far the turned angles are from the commanded ones (joint
angle transmission error and scale), and the geometry between consecutive axes (their
angle and distance along the common normal, the DH alpha and a of the arm as built). The
J2 block's circles check the coupling: had the elbow moved, its points would not lie on
circles about one axis. Then it rebuilds the whole arm from the six axes, places the
reflectors on its tool, and identifies every joint's constant errors from all 36 poses
through the tracker model.

Run it with ``python examples/robot_axes_real_data.py``; set ``VOLERR_REAL_DATA`` if the data
are not at ``shared/real-data`` beside the repository. Source:
github.com/RABKKK/LaserTrackerPoseData4KinIdent (no licence stated, so not in this repository;
docs/real-data.md gives the layout).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

from volerr_pin.applications.axisfit import axis_relation, fit_axis

ARCSEC = 180.0 / math.pi * 3600.0


def data_file() -> Path | None:
    env = os.environ.get("VOLERR_REAL_DATA")
    root = Path(env) if env else Path(__file__).resolve().parents[2] / "shared" / "real-data"
    path = root / "laser_tracker_robot_rabkkk" / "N1N2N3Jval.csv"
    return path if path.is_file() else None


def sweeps(table: np.ndarray) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(joint index, SMR positions (3, n, 3) in m, physical joint values (n,) rad) per block."""
    joints = table[:, 15:21].copy()                  # J1..J6 as the controller reports them, deg
    joints[:, 2] += joints[:, 1]                     # Fanuc J3 is relative to the horizontal
    smr = table[:, :9].reshape(len(table), 3, 3).transpose(1, 0, 2) * 1e-3
    out = []
    for start in range(0, len(table), 6):
        block = slice(start, start + 6)
        moving = np.flatnonzero(np.ptp(joints[block], axis=0) > 1e-9)
        if len(moving) != 1:
            raise ValueError(f"rows {start + 1}-{start + 6}: joints {moving + 1} move together")
        j = int(moving[0])
        out.append((j, smr[:, block], np.radians(joints[block, j])))
    return out


def main() -> dict | None:
    path = data_file()
    if path is None:
        print("real data not found: this example needs laser_tracker_robot_rabkkk/N1N2N3Jval.csv from its public "
              "source (docs/real-data.md says where and how to lay it out), in the folder named by VOLERR_REAL_DATA "
              "or in shared/real-data beside the repository")
        return None
    table = np.loadtxt(path)
    axes = {}
    print(f"{path.name}: {len(table)} poses, 3 SMRs; one joint per block of 6 (J3 taken as J3 + J2)")
    print("joint  circle RMS per SMR [um]   max [um]   angle residual RMS [arcsec]   turned / commanded - 1 [ppm]")
    for j, targets, q in sweeps(table):
        axis = fit_axis(list(targets), q)
        axes[j] = axis
        per_smr = " ".join(f"{c.rms * 1e6:6.1f}" for c in axis.circles)
        print(f"  J{j + 1}   {per_smr}         {axis.max * 1e6:6.1f}      {np.sqrt(np.mean(axis.angle_residual ** 2)) * ARCSEC:8.1f}"
              f"                     {(axis.angle_scale - 1) * 1e6:+9.0f}")
    print("consecutive axes as built (angle between them, distance along the common normal):")
    relations = {}
    for j in range(5):
        r = axis_relation(axes[j], axes[j + 1])
        relations[j] = r
        print(f"  J{j + 1} -> J{j + 2}: {math.degrees(r['angle']):8.3f} deg, {r['distance'] * 1e3:9.3f} mm"
              + ("  (parallel: distance between the lines)" if r["parallel"] else ""))
    rms = float(np.sqrt(np.mean(np.concatenate([c.distance ** 2 for a in axes.values() for c in a.circles]))))
    print(f"all joints: circle RMS {rms * 1e6:.1f} um over {sum(len(c.distance) for a in axes.values() for c in a.circles)} points")
    model = whole_robot(table, [axes[j] for j in range(6)])
    return {"axes": axes, "relations": relations, "rms": rms, **model}


def whole_robot(table: np.ndarray, axes: list, out: Path | None = None) -> dict:
    """The arm rebuilt from its measured axes (every sweep but J1's ran at J1 = 47 deg, the
    rest at 0: that is the reference configuration), the reflectors placed on its tool by
    least squares, then every joint's six constant errors identified from all 36 poses
    through the tracker model (the tracker's placement a nuisance of the fit)."""
    import tempfile

    import volerr_pin as vp
    from volerr_pin.applications.axisfit import axes_to_urdf
    from volerr_pin.fit.identify import identify
    from volerr_pin.measurements import read_tracker

    joints = table[:, 15:21].copy()
    joints[:, 2] += joints[:, 1]
    reference = np.array([47.0, 0, 0, 0, 0, 0])
    names = [f"J{k + 1}" for k in range(6)]
    out = Path(tempfile.mkdtemp()) if out is None else out
    q = np.radians(joints - reference)
    # travels: the measured range of each joint (polynomial terms are scaled to it)
    limits = [(float(lo) - 0.02, float(hi) + 0.02) for lo, hi in zip(q.min(axis=0), q.max(axis=0))]
    text, _ = axes_to_urdf(axes, names, limits, name="r2000ic_as_measured")
    (out / "robot_measured.urdf").write_text(text)
    robot = vp.load_machine(out / "robot_measured.urdf", tool_frame="tool0", workpiece_frame="world")
    R, p = robot.tool_poses(q, nominal=True)
    smr = table[:, :9].reshape(len(table), 3, 3) * 1e-3
    offsets = np.array([np.mean(np.einsum("nji,nj->ni", R, smr[:, k] - p), axis=0) for k in range(3)])
    before = np.linalg.norm(p[:, None, :] + np.einsum("nij,kj->nki", R, offsets) - smr, axis=2)
    lines = ["j1,j2,j3,j4,j5,j6,target,ox,oy,oz,tx,ty,tz"]
    for i in range(len(table)):
        for k in range(3):
            cells = [f"{v:.6f}" for v in np.degrees(q[i])] + [f"SMR{k + 1}"]
            cells += [f"{v * 1e3:.6f}" for v in offsets[k]] + [f"{v * 1e3:.6f}" for v in smr[i, k]]
            lines.append(",".join(cells))
    (out / "robot_tracker.csv").write_text("\n".join(lines) + "\n")
    data = read_tracker(out / "robot_tracker.csv", robot)
    fit = identify(robot, [data], folds=6, seed=0, sigma_um=30.0)
    report = fit.to_dict()
    print(f"whole arm from the measured axes, reflectors placed by least squares: {np.sqrt(np.mean(before**2)) * 1e6:.1f} um "
          f"RMS (max {before.max() * 1e6:.1f} um) over the 108 reflector positions")
    print(f"every joint's 6 constant errors identified through the tracker model: {report['rank']} of "
          f"{report['n_parameters']} determined, solver {report['solver']}; residual {report['rms_fit_um']:.1f} um RMS "
          f"per reflector position, {report['rms_holdout_um']:.1f} um held out ({report['holdout']})")
    found = vp.diagnose(robot, [data], sigma_um=30.0)
    print("what the rest is (volerr diagnose on the same data; held out: whole poses): "
          + "; ".join(f"{u.component} {u.form_before} -> {u.form_after}" for u in found.under_modelled)
          + (("; " + "; ".join(e.label for e in found.effects)) if found.effects else "")
          + f"; held-out RMS {found.rms_before_um:.0f} -> {found.rms_after_um:.0f} um")
    return {"model_rms_um": float(np.sqrt(np.mean(before**2)) * 1e6), "identification": report,
            "diagnosis": found.to_dict()}


if __name__ == "__main__":
    main()
    sys.exit(0)
