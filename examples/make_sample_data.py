"""Write the sample data files in ``examples/data/`` (all of the project's own making).

Every file is simulated from a "true" machine that differs from the bundled spec the way a
real one does, so that the commands in the README and the guide have something to find:

- the true vmc500's geometry is a random cubic per component (the spec has tables and
  quadratics), 1 um / 1 arcsec per coefficient, squareness and offsets as in the spec;
- it has a 3 um reversal (backlash) of X and a spindle that grows along z with time
  (-6 um, time constant 40 min) - neither is in the bundled spec.

Files (mm / deg, um / arcsec, s, degC, N, as the readers expect):

``vmc500_tracker.csv``
    300 tool-point measurements (dx, dy, dz) visited in random order over six hours, with
    time, three temperatures, process forces and approach directions; 0.3 um noise.
``vmc500_x_positioning.csv``
    An ISO 230-2 positioning run of X (11 targets, 5 bidirectional cycles) at Y 200, Z 200
    on the same machine, as a laser interferometer measures it (0.2 um noise, an unknown
    zero of the instrument).
``vmc500_spindle_thermal.csv``
    Eight hours of four temperature sensors and the spindle's z drift every 5 minutes, for
    ``volerr thermal-fit``.
``vmc500_ballbar_xy.csv``
    A ballbar circle (ISO 230-4) of 100 mm radius in the XY plane, both directions, on the
    same machine once warm, with the table ball 3 um / -2 um off the centre.
``vmc500_tolerances.toml``
    Tolerances for ``volerr rank --tolerances``.
``part.nc``
    A vmc700 program with seed 002's line and arc examples, for ``volerr compensate``.
``two_link_arm.urdf``
    A planar two-link arm whose joint limits give no effort or velocity, for loading a bare
    URDF (frames ``world`` and ``tool0``).

Run ``python examples/make_sample_data.py [DIR]`` (default: ``examples/data``); the output is
the same on every run (fixed seeds), and a test checks that the shipped files are.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import volerr_pin as vp
from volerr_pin.measurements import ballbar_run, campaign, off_model_geometry, write_ballbar, write_points
from volerr_pin.model import add_terms

HERE = Path(__file__).resolve().parent
HIDDEN = {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 3.0},
          "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "growth",
                  "amplitudes_um": [-6.0], "time_constants_min": [40.0]}}


def true_vmc500() -> vp.Machine:
    """The simulated machine behind the vmc500 files."""
    spec = vp.load_machine("vmc500")
    return add_terms(off_model_geometry(spec, seed=2026, style="cubic", size_um=1.0, size_arcsec=1.0),
                     HIDDEN)


def tracker(truth: vp.Machine, out: Path) -> None:
    data = campaign(truth, n=300, noise_um=0.3, seed=1, hours=6.0, source=str(out))
    write_points(data, vp.load_machine("vmc500"), out)


def x_positioning(truth: vp.Machine, out: Path) -> None:
    """ISO 230-2 run of X: the error along X's own motion, as ``identify`` reads such a run."""
    rng = np.random.default_rng(2)
    targets = np.linspace(0.0, 500.0, 11)
    lines = ["# ISO 230-2 positioning run of the X axis, laser interferometer on the table",
             "# simulated by examples/make_sample_data.py",
             "# axis: X", "# at: Y=200, Z=200", "target_mm,cycle,direction,deviation_um"]
    zero = 0.8  # the interferometer's zero is not the model's: identify fits it as an offset
    for cycle in range(1, 6):
        for direction, order in ((1, targets), (-1, targets[::-1])):
            q = np.column_stack([order * 1e-3, np.full(len(order), 0.2), np.full(len(order), 0.2)])
            dirs = np.column_stack([np.full(len(order), float(direction)), np.ones(len(order)),
                                    np.ones(len(order))])
            error = truth.volumetric_error(q, directions=dirs, t=np.full(len(order), 6 * 3600.0))
            along = truth.axis_jacobian(q, nominal=True)[:, :, 0]
            along = along / np.linalg.norm(along, axis=1, keepdims=True)
            deviation = np.einsum("ij,ij->i", error, along) * 1e6 + zero + rng.normal(0.0, 0.2, len(order))
            lines += [f"{t:.1f},{cycle},{direction},{d:.3f}" for t, d in zip(order, deviation)]
    out.write_text("\n".join(lines) + "\n")


def ballbar(truth: vp.Machine, out: Path) -> None:
    run = ballbar_run(truth.with_state(t=6 * 3600.0), plane=("X", "Y"), radius_mm=100.0,
                      centre_mm={"X": 250.0, "Y": 200.0, "Z": 200.0}, n=360, noise_um=0.1, seed=4,
                      setup_offset_um=(3.0, -2.0), length_error_um=0.6)
    write_ballbar(run, out)


def spindle_thermal(out: Path) -> None:
    """Spindle z drift following the spindle housing with a lag, plus the column's slow cycle."""
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 8 * 3600.0 + 1.0, 300.0)
    running = t < 6 * 3600.0  # six hours of cutting, then two of cooling
    bearing = np.empty_like(t)
    housing = np.empty_like(t)
    bearing[0] = housing[0] = 21.0
    for k in range(1, len(t)):
        target = 33.0 if running[k] else 21.0
        bearing[k] = bearing[k - 1] + (target - bearing[k - 1]) * (1 - np.exp(-300.0 / 1500.0))
        housing[k] = housing[k - 1] + (bearing[k] - housing[k - 1]) * (1 - np.exp(-300.0 / 2400.0))
    column = 21.0 + 1.2 * np.sin(2 * np.pi * t / (10 * 3600.0))
    ambient = 20.0 + 0.8 * np.cos(2 * np.pi * t / (24 * 3600.0) + 2.0)
    dz = -1.1 * (housing - 21.0) - 0.9 * (column - 21.0) + rng.normal(0.0, 0.15, len(t))
    temps = [bearing, housing, column, ambient] + [rng.normal(0.0, 0.05, len(t)) for _ in range(4)]
    temps = [x + n for x, n in zip(temps[:4], temps[4:])]
    lines = ["# spindle z drift (um, measured against a test mandrel) and four temperatures (degC)",
             "# every 5 minutes (t in s); simulated by examples/make_sample_data.py",
             "t,T_bearing,T_housing,T_column,T_ambient,dz_um"]
    lines += [f"{time:.0f}," + ",".join(f"{v:.3f}" for v in row) for time, *row in zip(t, *temps, dz)]
    out.write_text("\n".join(lines) + "\n")


TOLERANCES = """\
# Tolerances for `volerr rank vmc500 --tolerances ...`: every component either has its own
# (COMPONENT_um for a length, COMPONENT_arcsec for an angle) or takes the default of its kind.
EXX_um = 5
EYY_um = 5
EZZ_um = 4
EBX_arcsec = 2
EC0Y_arcsec = 3
default_um = 1
default_arcsec = 1
"""

PROGRAM = """\
%
(vmc700 sample part: seed 002's two worked moves, coordinates in axis positions, mm)
N10 G21 G90 G17
N20 T1 M6
N30 S6000 M3
N40 G0 X10 Y10 Z10
N50 G1 X680 Y240 Z190 F800
N60 G0 X500 Y10 Z50
N70 G3 X100 Y30 Z150 I-200 J10
N80 G1 X100 Y200 Z150
N90 G3 X300 Y200 R100
N100 G0 Z190
N110 M5
N120 M30
%
"""

#: a square on vmc500 whose last two sides run under a local offset (G52), which predict lists as
#: not predicted (docs/guide/part.md)
LOCAL_OFFSET = """\
(a square whose last two sides run under a local offset, G52: not predicted, and listed)
G21 G90 G17
G0 X200 Y150 Z100
G1 X300 F500
G1 Y250
G52 X5 Y5
G1 X200
G1 Y150
G52 X0 Y0
G0 X200 Y150 Z100
G1 X300
M30
"""

ARM = """\
<?xml version="1.0"?>
<!-- A planar two-link arm (sample for loading a bare URDF; limits give no effort or velocity) -->
<robot name="two_link_arm">
  <link name="world"/>
  <link name="base">
    <visual><geometry><cylinder radius="0.05" length="0.1"/></geometry></visual>
  </link>
  <link name="upper_arm">
    <visual><origin xyz="0.2 0 0"/><geometry><box size="0.4 0.04 0.04"/></geometry></visual>
  </link>
  <link name="forearm">
    <visual><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.03 0.03"/></geometry></visual>
  </link>
  <link name="tool0"/>
  <joint name="base_fixed" type="fixed">
    <parent link="world"/><child link="base"/><origin xyz="0 0 0.05"/>
  </joint>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper_arm"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 0 1"/><limit lower="-2.5" upper="2.5"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper_arm"/><child link="forearm"/><origin xyz="0.4 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-2.0" upper="2.0"/>
  </joint>
  <joint name="tool_fixed" type="fixed">
    <parent link="forearm"/><child link="tool0"/><origin xyz="0.3 0 0"/>
  </joint>
</robot>
"""


def test_piece(path: Path) -> None:
    """The contouring test piece for vmc500, as ``volerr testpiece vmc500`` writes it."""
    from volerr_pin.applications.part import contouring_test_piece

    path.write_text(contouring_test_piece(vp.load_machine("vmc500")))


def cone_frustum(path: Path) -> None:
    """The cone frustum test piece for cgm4000, as ``volerr testpiece cgm4000 --kind cone-frustum``
    writes it."""
    from volerr_pin.applications.part import cone_frustum_test_piece

    path.write_text(cone_frustum_test_piece(vp.load_machine("cgm4000")))


def main(out: Path = HERE / "data") -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    truth = true_vmc500()
    written = []
    for name, write in (("vmc500_tracker.csv", lambda p: tracker(truth, p)),
                        ("vmc500_x_positioning.csv", lambda p: x_positioning(truth, p)),
                        ("vmc500_ballbar_xy.csv", lambda p: ballbar(truth, p)),
                        ("vmc500_spindle_thermal.csv", spindle_thermal),
                        ("vmc500_tolerances.toml", lambda p: p.write_text(TOLERANCES)),
                        ("part.nc", lambda p: p.write_text(PROGRAM)),
                        ("vmc500_testpiece.nc", test_piece),
                        ("cgm4000_cone.nc", cone_frustum),
                        ("vmc500_local_offset.nc", lambda p: p.write_text(LOCAL_OFFSET)),
                        ("two_link_arm.urdf", lambda p: p.write_text(ARM))):
        write(out / name)
        written.append(out / name)
        print(f"wrote {out / name}")
    return written


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "data")
