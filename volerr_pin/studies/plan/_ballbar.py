"""A telescoping ballbar (ISO 230-4 circular tests): one circle per unit, one file per circle.

A circle lies in one of the planes XY, YZ, ZX of the machine's linear axes (the planes G17,
G19 and G18 select, in the order their arcs are counted: the angle runs from the first axis
towards the second, so +1 is G3 in each), has one of the stated ballbar lengths as its radius
(50, 100, 150, 300 mm by default, the common bar lengths) and is run in both directions (the
difference between them is what reversal errors leave). Its centre is a layout point of the
zone (Sobol', grid, random) with the two plane axes drawn over ``[lower + r, upper - r]``, so
the whole circle stays inside the zone; the other axes stand at the layout point's positions.
Candidates cycle through the (plane, radius) pairs that fit in the zone.

Each circle is observed through :class:`~volerr_pin.measurements.BallbarRun`, the
object ``volerr identify`` builds from a ballbar file: ``samples`` radial deviations per
direction at equal angle steps, three nuisance terms of the circle's own (the set-up's centre
offset along both plane axes and the bar's length error, projected out of its rows by
:mod:`~volerr_pin.studies.plan`). The file written per circle is the ballbar layout
(docs/measurements.md): ``# plane:``, ``# radius:``, ``# centre:`` header lines, then
``angle_deg,deviation_um,direction`` with the deviations empty.

The feed does not enter the model (the model is quasi-static: it holds geometric errors,
not servo dynamics); it sets the NC program and the time. The program (ISO 6983 style, mm,
absolute): per circle and direction, a feed move to the lead-in point ``lead_deg`` before
angle 0 on the circle, a dwell ``G4 P<s>`` (the ballbar is seated and logging starts), a
lead-in arc to angle 0, the data circle as two half-circle arcs (I/J/K centre offsets), and a
lead-out arc of ``lead_deg``. Time: the path length (moves and arcs) divided by the feed,
plus the dwells; acceleration neglected; the move to the first circle not counted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...base import InputError, axis_scales, positive
from ...measurements import BallbarRun
from ._nc import check_axes
from ._poses import pose_candidates
from ._protocol import Instrument, numbered_files, Setup

__all__ = ["BALLBAR", "PLANES", "Ballbar", "Circle"]

#: the circle planes, by axis names, with the G code selecting each; the angle runs from the
#: first axis towards the second, so G3 (counter-clockwise) increases it in every one
PLANES = {("X", "Y"): "G17", ("Z", "X"): "G18", ("Y", "Z"): "G19"}
#: centre positions are written with 4 decimals of mm (0.1 um): the planned circle is the written one
DECIMALS = 4


@dataclass(frozen=True)
class Circle:
    """One planned circular test (SI).

    Attributes
    ----------
    plane : tuple of int (2,)
        Indices of the two plane axes, in the order the angle is counted.
    centre : ndarray, shape (n_axes,)
        Axis positions at the circle's centre [m, rad].
    radius : float
        Nominal radius: the ballbar's length [m].
    directions : tuple of int
        The runs, in order: +1 counter-clockwise (increasing angle, G3), -1 clockwise (G2).
    """

    plane: tuple[int, int]
    centre: np.ndarray
    radius: float
    directions: tuple[int, ...] = (1, -1)


@dataclass(frozen=True)
class Ballbar(Instrument):
    """The ballbar instrument (see the module docstring).

    Attributes
    ----------
    name : str
        "ballbar".
    unit : str
        "circle".
    default_sigma_um : float
        0.7 um per radial sample, as a default of the order of a micrometre that ballbar
        makers state as accuracy (+-1.25 um read as the bounds of a uniform distribution:
        1.25 / sqrt(3)); the instrument's own figure belongs in ``Setup.sigma``.
    radii : tuple of float
        Ballbar lengths to choose from [m].
    samples : int
        Samples per direction, at equal angle steps over the full circle (72: every 5 deg).
    directions : tuple of int
        Directions run on every circle (+1 counter-clockwise, -1 clockwise).
    lead_deg : float
        Lead-in and lead-out arc of each run [deg].

    Notes
    -----
    The methods of :class:`~volerr_pin.studies.plan.Instrument` (documented there) do here:

    - ``candidates``: circles cycling through the (plane, radius) pairs that fit, centres at the
      layout's points.
    - ``measurements``: one ballbar run object per circle, as identify reads its file.
    - ``outputs``: the files a plan of ``count`` circles writes for ``out``:
      ``STEM_circle01.csv`` ...
    - ``files``: one ballbar file per circle, deviations empty.
    - ``visits``: every sample of every circle, in the order measured.
    - ``program``: the NC program that runs the circles in order (module docstring).
    - ``duration``: time to run the circles in order (module docstring).
    """

    name: str = "ballbar"
    unit: str = "circle"
    default_sigma_um: float = 0.7
    radii: tuple[float, ...] = (0.05, 0.1, 0.15, 0.3)
    samples: int = 72
    directions: tuple[int, ...] = (1, -1)
    lead_deg: float = 45.0

    # ------------------------------------------------------------------ candidates

    def kinds(self, machine, zone: np.ndarray) -> list[tuple[tuple[int, int], float]]:
        """The (plane, radius) pairs whose circles fit in the zone.

        Parameters
        ----------
        machine : Machine
            The machine.
        zone : ndarray, shape (n_axes, 2)
            Lower and upper NC positions [m, rad].

        Returns
        -------
        list of ((int, int), float)
            Plane axis indices and radius [m], planes in the order XY, YZ, ZX, radii increasing.

        Raises
        ------
        InputError
            Naming ``zone``, if no circle of the stated radii fits in any plane of the zone.
        """
        out = []
        for names in (("X", "Y"), ("Y", "Z"), ("Z", "X")):
            if not all(a in machine.axes for a in names):
                continue
            j = tuple(machine.axes.index(a) for a in names)
            if any(machine.axis_kinds[k] != "linear" for k in j):
                continue
            span = min(zone[k, 1] - zone[k, 0] for k in j)
            out += [(j, float(r)) for r in sorted(self.radii) if 2 * r <= span + 1e-12]
        if not out:
            radii = ", ".join(f"{r * 1e3:g}" for r in sorted(self.radii))
            raise InputError(f"zone: no ballbar circle of radius {radii} mm fits in a plane of two of the linear axes "
                             f"X, Y, Z of {machine.name} inside the zone", parameters=("zone",))
        return out

    def candidates(self, machine, setup: Setup, count: int, layout: str, seed: int) -> list:
        if np.any(setup.targets != 0):
            raise InputError("targets: a ballbar's ball sits at the tool point", parameters=("targets",))
        kinds = self.kinds(machine, setup.zone)
        base = pose_candidates(setup.zone, machine.axis_kinds, count, layout, seed)
        scale = axis_scales(machine.axis_kinds)
        out = []
        for i, q in enumerate(base):
            plane, r = kinds[i % len(kinds)]
            centre = q.copy()
            for k in plane:   # the layout's point, mapped into the range that keeps the circle inside
                lo, hi = setup.zone[k, 0] + r, setup.zone[k, 1] - r
                span = setup.zone[k, 1] - setup.zone[k, 0]
                u = (q[k] - setup.zone[k, 0]) / span if span > 0 else 0.5
                centre[k] = lo + u * (hi - lo)
            centre = np.round(centre / scale, DECIMALS) * scale
            for k in plane:   # rounding must not push the circle out of the zone
                centre[k] = np.clip(centre[k], setup.zone[k, 0] + r, setup.zone[k, 1] - r)
            out.append(Circle(plane, centre, r, tuple(self.directions)))
        return out

    # ------------------------------------------------------------------ as identify sees it

    def angles(self, direction: int) -> np.ndarray:
        """Sample angles of one run, in the order sampled [deg]: from 0, ``samples`` equal steps.

        Parameters
        ----------
        direction : int
            +1 (increasing) or -1 (decreasing).

        Returns
        -------
        ndarray, shape (samples,)
            Angles in [0, 360) [deg].
        """
        return np.mod(direction * np.arange(self.samples) * 360.0 / self.samples, 360.0)

    def _samples(self, circle: Circle) -> tuple[np.ndarray, np.ndarray]:
        angle = np.concatenate([self.angles(d) for d in circle.directions])
        direction = np.concatenate([np.full(self.samples, d, dtype=int) for d in circle.directions])
        return angle, direction

    def _centre(self, machine, circle: Circle) -> dict:
        scale = axis_scales(machine.axis_kinds)
        return {a: float(np.round(circle.centre[k] / scale[k], DECIMALS)) for k, a in enumerate(machine.axes)}

    def measurements(self, machine, setup: Setup, units: list, values: np.ndarray | None = None
                     ) -> tuple[list, np.ndarray]:
        out, owner, start = [], [], 0
        for i, circle in enumerate(units):
            angle, direction = self._samples(circle)
            n = len(angle)
            value = np.zeros(n) if values is None else np.asarray(values[start:start + n], dtype=float)
            start += n
            out.append(BallbarRun(f"planned circle {i + 1}", np.radians(angle), value, direction.astype(float),
                                  circle.radius, tuple(machine.axes[k] for k in circle.plane),
                                  self._centre(machine, circle), np.arange(n) + 5))
            owner.append(np.full(n, i))
        return out, np.concatenate(owner) if owner else np.zeros(0, int)

    # ------------------------------------------------------------------ files

    def outputs(self, out: str | Path, count: int) -> list[Path]:
        return numbered_files(out, count, "circle")

    def files(self, machine, setup: Setup, units: list) -> list[str]:
        texts = []
        for circle in units:
            angle, direction = self._samples(circle)
            centre = ", ".join(f"{a}={v:.{DECIMALS}f}" for a, v in self._centre(machine, circle).items())
            lines = [f"# plane: {machine.axes[circle.plane[0]]}, {machine.axes[circle.plane[1]]}",
                     f"# radius: {circle.radius * 1e3:.{DECIMALS}f}", f"# centre: {centre}",
                     "angle_deg,deviation_um,direction"]
            lines += [f"{a:.4f},,{d}" for a, d in zip(angle, direction)]
            texts.append("\n".join(lines) + "\n")
        return texts

    def visits(self, machine, units: list) -> np.ndarray:
        rows = []
        for circle in units:
            angle, _ = self._samples(circle)
            a = np.radians(angle)
            q = np.tile(circle.centre, (len(a), 1))
            q[:, circle.plane[0]] += circle.radius * np.cos(a)
            q[:, circle.plane[1]] += circle.radius * np.sin(a)
            rows.append(q)
        return np.vstack(rows) if rows else np.zeros((0, len(machine.axes)))

    # ------------------------------------------------------------------ NC program and time

    def _path(self, machine, units: list):
        """The runs as pieces: ("line", start, end) and ("arc", circle, from_deg, sweep_deg), in mm."""
        scale = axis_scales(machine.axis_kinds)
        lead = float(self.lead_deg)
        for i, circle in enumerate(units):
            centre = circle.centre / scale
            r = circle.radius * 1e3
            for d in circle.directions:
                start = -d * lead   # the lead-in starts lead_deg before angle 0, against the run's sense
                p = centre.copy()
                p[circle.plane[0]] += r * math.cos(math.radians(start))
                p[circle.plane[1]] += r * math.sin(math.radians(start))
                yield i, d, p, [(start, d * lead), (0.0, d * 180.0), (d * 180.0, d * 180.0), (d * 360.0, d * lead)]

    def program(self, machine, units: list, feed_mm_min: float, dwell_s: float, title: str = "") -> str:
        check_axes(machine)
        feed = positive("feed_mm_min", feed_mm_min)
        _check_dwell(dwell_s)
        scale = axis_scales(machine.axis_kinds)
        clean = title.replace("(", "").replace(")", "")
        lines = ["%", f"({clean})" if clean else "(ballbar circles)",
                 "(per circle and direction: a move to the lead-in point, a dwell G4 P in seconds while the bar is "
                 "seated, a lead-in arc, the data circle in two halves, a lead-out arc)", "G21 G90 G94"]
        for i, d, p, arcs in self._path(machine, units):
            circle = units[i]
            names = tuple(machine.axes[k] for k in circle.plane)
            code = PLANES.get(names) or PLANES.get(names[::-1])
            centre = circle.centre / scale
            r = circle.radius * 1e3
            words = " ".join(f"{a}{v:.4f}" for a, v in zip(machine.axes, p))
            lines.append(f"{code} G1 {words} F{feed:g} (circle {i + 1} {'ccw G3' if d > 0 else 'cw G2'})")
            lines.append(f"G4 P{dwell_s:g}")
            for a0, sweep in arcs:
                start = centre.copy()
                start[circle.plane[0]] += r * math.cos(math.radians(a0))
                start[circle.plane[1]] += r * math.sin(math.radians(a0))
                end = centre.copy()
                end[circle.plane[0]] += r * math.cos(math.radians(a0 + sweep))
                end[circle.plane[1]] += r * math.sin(math.radians(a0 + sweep))
                offset = " ".join(f"{'IJK'['XYZ'.index(machine.axes[k])]}{_zero(centre[k] - start[k]):.4f}"
                                  for k in circle.plane)
                ends = " ".join(f"{machine.axes[k]}{end[k]:.4f}" for k in circle.plane)
                lines.append(f"{'G3' if d > 0 else 'G2'} {ends} {offset}")
        lines += ["M30", "%"]
        return "\n".join(lines) + "\n"

    def duration(self, machine, units: list, feed_mm_min: float, dwell_s: float) -> dict:
        feed = positive("feed_mm_min", feed_mm_min)
        _check_dwell(dwell_s)
        scale = axis_scales(machine.axis_kinds)
        linear = np.array([k == "linear" for k in machine.axis_kinds])
        length, runs, last = 0.0, 0, None
        for i, _, p, arcs in self._path(machine, units):
            if last is not None:
                step = p - last
                length += float(np.linalg.norm(step[linear]))
            r = units[i].radius * 1e3
            length += sum(abs(math.radians(sweep)) * r for _, sweep in arcs)
            last = units[i].centre / scale
            last[units[i].plane[0]] += r * math.cos(math.radians(arcs[-1][0] + arcs[-1][1]))
            last[units[i].plane[1]] += r * math.sin(math.radians(arcs[-1][0] + arcs[-1][1]))
            runs += 1
        moves = length / feed * 60.0
        dwell = float(dwell_s * runs)
        return {"moves_s": moves, "dwell_s": dwell, "total_s": moves + dwell, "total_min": (moves + dwell) / 60.0,
                "feed_mm_min": feed, "dwell_per_pose_s": float(dwell_s), "path_mm": length,
                "model": f"per run: a dwell, a {self.lead_deg:g} deg lead-in arc, the 360 deg circle and a "
                         f"{self.lead_deg:g} deg lead-out arc at the feed, straight moves at the feed between "
                         "runs; acceleration neglected; the move to the first run not counted"}


def _zero(value: float) -> float:
    """The value, with what rounds to zero at 4 decimals written as 0 rather than -0."""
    return 0.0 if abs(value) < 5e-5 else value


def _check_dwell(dwell_s: float) -> None:
    if not (np.isfinite(dwell_s) and dwell_s >= 0):
        raise InputError(f"dwell_s must be a non-negative number of seconds, got {dwell_s!r}", parameters=("dwell_s",))


#: the ballbar
BALLBAR = Ballbar()
