"""Gear flank deviations beside seed 004's tables
==============================================

Seed 004's gear deviations from machine errors, side by side with the paper (Tables 2-5, section 4.2).

The gear is the paper's (Table 7): module 1.75 mm, 20 deg, 46 teeth, rolled by a 128-tooth
wheel; 20 mm face width (the paper's contact line length at the start of rolling). The
machine is the bundled ``gear_roller`` put in the paper's convention:

- the A and B errors act in the moving spindle frames (the paper's M = R_Z(A) E_A, so they
  turn with the spindle), and B's angular errors act about the gear's mid face on its axis
  (the paper's workpiece frame), not about the spindle nose where the bundled spec puts them;
- the paper's tables hold one value per error: tooth 0 (the tooth centred on the wheel's pitch
  point at A = B = 0), right flank.

Force-induced errors (section 4.2): the paper's spindle displacements of the rolling wheel are
applied as constant translations of the wheel spindle in the machine frame (a deflection
under the rolling force does not turn with the wheel).

Contact springback (section 3.3, Table 6): the paper's formula for the deformation of the
finite line contact and the CEB critical deformation, with its rolling forces and contact line
lengths; the material constants it does not give are assumed (40CrNiMo: E = 209 GPa,
nu = 0.3, yield strength 835 MPa; wheel steel: E = 210 GPa, nu = 0.3), and beside them the
equivalent modulus E_c that fits Table 6 best.

Run it with ``python examples/gear_flanks_seed004.py``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

import volerr_pin as vp
from volerr_pin.applications.gear import (REFERENCE_GEAR, contact_springback, contribution_degrees, flank_deviations,
                                          unit_error_study)
from volerr_pin.model import replace_terms
from volerr_pin.base import UM

# seed 004, Tables 2 and 4: total profile, total helix, single pitch deviation [mm]
PAPER = {"EXA": (0.973, 0.9611, 0.9575), "EYA": (0.3615, 0.29988, -0.2838), "EZA": (0.0, 0.0, 0.0),
         "EAA": (0.06262, 0.131, -0.0576), "EBA": (0.12358, 0.3267, -0.1189), "ECA": (1.8272, 1.82616, -1.8272),
         "EXB": (0.9746, 0.9526, -0.959), "EYB": (0.3608, 0.2859, -0.2684), "EZB": (0.0, 0.0, 0.0),
         "EAB": (0.04976, 0.1154, 0.0414), "EBB": (0.1031, 0.3355, 0.1026), "ECB": (0.2378, 0.2373, 0.2378)}
# seed 004, Tables 3 and 5: contribution degrees [%]
PAPER_SHARES = {"EXA": (72.9, 76.2, 77.1), "EYA": (27.1, 23.8, 22.9), "EZA": (0, 0, 0),
                "EAA": (3.11, 5.74, 2.87), "EBA": (6.14, 14.3, 5.93), "ECA": (90.75, 79.96, 91.2),
                "EXB": (73.0, 76.9, 78.1), "EYB": (27.0, 23.1, 21.9), "EZB": (0, 0, 0),
                "EAB": (59.3, 16.8, 10.8), "EBB": (12.3, 48.8, 26.9), "ECB": (28.4, 34.4, 62.3)}
# seed 004, section 4.2: the rolling wheel spindle's largest displacements [um] and the
# deviations the text reports for them [um] (profile, helix, single pitch)
FORCES = {"lead": {"x": 5.45, "y": 0.37}, "40CrNiMo": {"x": 34.3, "y": 2.328}}
PAPER_FORCE = {("lead", "x"): (4.39, 4.3, 4.3), ("lead", "y"): (0.13, 0.11, 0.11),
               ("40CrNiMo", "x"): (32.48, 32.13, 32.13), ("40CrNiMo", "y"): (0.84, 0.7, 0.7)}
# seed 004, Table 6: feeding time [s], surface contact force [kN], contact line length [mm],
# contact springback [um] (the last row, 28.6 s, is the unloaded end)
TABLE6 = np.array([[0, 30.79, 20, 25.94], [2.03, 30.5, 18.58, 25.8], [4, 30.21, 17.2, 25.9],
                   [6.93, 25.13, 15.15, 25.95], [9.16, 24.36, 13.59, 27.52], [13.59, 20.8, 10.49, 28.27],
                   [18.31, 15.35, 7.18, 26.44], [24.4, 6.79, 5.24, 17.61], [26.5, 3.01, 2.9, 7.31]])
MATERIALS = {"e_tool": 210e9, "e_work": 209e9, "nu_tool": 0.3, "nu_work": 0.3, "yield_strength": 835e6}
GEAR_MID_FACE_ON_B = (0.0, 0.0, 0.05)   # the workpiece frame's origin, 50 mm above the B spindle nose


def seed004_machine():
    machine = vp.load_machine("gear_roller")
    spec = machine.spec.with_axis("A", frame="moving").with_axis("B", frame="moving", reference=GEAR_MID_FACE_ON_B)
    return machine.with_spec(spec)


def unit_errors(machine) -> tuple[list, list]:
    rows = unit_error_study(machine, REFERENCE_GEAR, tooth_numbers=[0])
    return rows, contribution_degrees(rows, "right")


def paper_shares_from_table4(source: str) -> tuple[float, ...]:
    """The contribution degrees the paper's own Tables 2/4 give (s_i = |S_i| / sum |S_j|)."""
    axis = source[2]
    group = [f"E{d}{axis}" for d in ("ABC" if source[1] in "ABC" else "XYZ")]
    return tuple(100 * abs(PAPER[source][k]) / sum(abs(PAPER[s][k]) for s in group) for k in range(3))


def force_deviations(machine) -> dict:
    bare = machine.with_spec(machine.spec.without(*machine.components))
    out = {}
    for material, moves in FORCES.items():
        for direction, um in moves.items():
            name = "EXA" if direction == "x" else "EYA"
            one = replace_terms(bare, {name: {"kind": "constant", "value_um": um}})
            out[material, direction] = flank_deviations(one, REFERENCE_GEAR).values["right"]
    # the torsion angle the paper computes but leaves out, as a turn of the wheel about its axis
    one = replace_terms(bare, {"ECA": {"kind": "constant", "value_deg": 0.497}})
    out["lead", "torsion 0.497 deg"] = flank_deviations(one, REFERENCE_GEAR).values["right"]
    return out


def springback_table() -> dict:
    force, length, paper = TABLE6[:, 1] * 1e3, TABLE6[:, 2] * 1e-3, TABLE6[:, 3]
    assumed = contact_springback(force, length, REFERENCE_GEAR, **MATERIALS)
    fit = least_squares(lambda p: contact_springback(force, length, REFERENCE_GEAR, modulus=np.exp(p[0]), **MATERIALS)
                        .rebound / UM - paper, [np.log(assumed.modulus)])
    fitted = contact_springback(force, length, REFERENCE_GEAR, modulus=float(np.exp(fit.x[0])), **MATERIALS)
    print(f"Seed 004 Table 6: contact springback [um]; E_c {assumed.modulus / 1e9:.1f} GPa from the assumed "
          f"constants, {fitted.modulus / 1e9:.1f} GPa fitted to the table")
    print(f"{'t s':>6s} {'F kN':>6s} {'l mm':>6s}   {'paper':>6s} {'E_c':>6s} {'fitted':>6s}")
    for row, a, f in zip(TABLE6, assumed.rebound / UM, fitted.rebound / UM):
        print(f"{row[0]:6.2f} {row[1]:6.2f} {row[2]:6.2f}   {row[3]:6.2f} {a:6.2f} {f:6.2f}")
    return {"assumed_um": assumed.rebound / UM, "fitted_um": fitted.rebound / UM, "fitted_modulus": fitted.modulus,
            "assumed_modulus": assumed.modulus, "paper_um": paper}


def main() -> dict:
    fixed = vp.load_machine("gear_roller")
    machine = seed004_machine()
    rows, shares = unit_errors(machine)
    print("Seed 004 Tables 2 and 4: deviations from unit errors (1 mm, 1 deg), tooth 0, right flank [mm]")
    print(f"{'error':7s} {'profile':>8s} {'paper':>8s}   {'helix':>8s} {'paper':>8s}   {'pitch':>8s} {'paper':>8s}")
    ours = {}
    for row in rows:
        v = row.deviations.values["right"]
        ours[row.source] = (v["profile"] * 1e3, v["helix"] * 1e3, v["pitch"] * 1e3)
        p = PAPER[row.source]
        print(f"{row.label:7s} {ours[row.source][0]:8.4f} {p[0]:8.4f}   {ours[row.source][1]:8.4f} {p[1]:8.4f}   "
              f"{ours[row.source][2]:8.4f} {p[2]:8.4f}")
    print()
    print("Seed 004 Tables 3 and 5: contribution degree within each axis' translations / rotations [%]")
    print(f"{'error':7s} {'profile':>7s} {'paper':>6s} {'Tab.4':>6s}   {'helix':>6s} {'paper':>6s} {'Tab.4':>6s}   "
          f"{'pitch':>6s} {'paper':>6s} {'Tab.4':>6s}")
    share_table = {}
    for row, share in zip(rows, shares):
        s = tuple(100 * share[k] for k in ("profile", "helix", "pitch"))
        share_table[row.source] = s
        p, t = PAPER_SHARES[row.source], paper_shares_from_table4(row.source)
        print(f"{row.label:7s} {s[0]:7.1f} {p[0]:6.1f} {t[0]:6.1f}   {s[1]:6.1f} {p[1]:6.1f} {t[1]:6.1f}   "
              f"{s[2]:6.1f} {p[2]:6.1f} {t[2]:6.1f}")
    print()
    print("Seed 004 section 4.2: force-induced deviations from the wheel spindle's displacement, right flank [um]")
    print(f"{'material':9s} {'spindle':>18s}   {'profile':>7s} {'paper':>6s}   {'helix':>7s} {'paper':>6s}   "
          f"{'pitch':>7s} {'paper':>6s}")
    forces = force_deviations(fixed)
    for (material, direction), v in forces.items():
        what = direction if direction.startswith("torsion") else f"{direction} {FORCES[material][direction]:g} um"
        p = PAPER_FORCE.get((material, direction))
        cells = [f"{v[k] / UM:7.3f} {'' if p is None else f'{p[i]:6.2f}':>6s}"
                 for i, k in enumerate(("profile", "helix", "pitch"))]
        print(f"{material:9s} {what:>18s}   " + "   ".join(cells))
    print()
    springback = springback_table()
    return {"deviations_mm": ours, "shares_pct": share_table, "springback": springback,
            "forces_um": {k: {n: v[n] / UM for n in ("profile", "helix", "pitch")} for k, v in forces.items()}}


if __name__ == "__main__":
    main()
