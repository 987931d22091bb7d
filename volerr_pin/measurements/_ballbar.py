"""Circular tests with a ballbar (ISO 230-4): reading, evaluation, and the machine model.

A ballbar joins a ball at the tool to a ball on the table and logs its length while two
linear axes run a circle around the table ball. The file gives the **radial deviation**
(measured length minus the nominal radius) against the **angle** on the circle:

.. code-block:: text

    # plane: X, Y              two linear axes of the machine, in this order
    # radius: 100              nominal radius, mm
    # centre: X=250, Y=200, Z=200   axis positions at the circle's centre (mm / deg)
    angle_deg,deviation_um,direction
    0.0,1.23,1
    1.0,1.31,1

``angle_deg`` runs from the first plane axis towards the second, in the axes' own
(program) coordinates; ``direction`` is +1 for increasing angles (G3 in the XY plane) and
-1 for decreasing (G2), or the words ``ccw`` / ``cw``; without it every row is +1.
Deviations may be in um, nm or mm (``deviation_mm``).

The samples of each direction run must number at least 4 and cover an arc of at least
:data:`MIN_ARC_DEG` (90 deg): the least-squares circle's centre and radius are determined
to a condition number of 20 over a quarter circle, of 7,000 over 5 deg, where a micrometre of
noise becomes millimetres of radius error. A radial deviation is smaller than the radius.

:func:`evaluate_circular` gives ISO 230-4's figures: the circular deviation G of each
direction and G(b) of both, about the least-squares circle's centre; the radial deviations
F_max / F_min about the nominal centre (the set-up's offset included); the circular
hysteresis H (the largest radial difference between the two directions at one angle). The
least-squares centre is the linearised fit ``r(a) = r0 + cx cos a + cy sin a``, exact to
(offset / radius)^2 of the offset - 1e-10 of it for 10 um on 100 mm.

As observations (:meth:`BallbarRun.observations`), a ballbar sample is the
tool's error relative to the workpiece projected on the radial direction at the commanded
position, with three nuisance terms per file: the set-up's centre offset along both plane
directions and the bar's length error. Approach directions of the two axes come from the
motion (for backlash terms); so identification and :func:`volerr_pin.fit.diagnosis.diagnose`
see squareness, scale mismatch, backlash and straightness through the same model as
every other measurement.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..base import DEG, LENGTH, MM, PLAUSIBLE, InputError, parse_number
from ..model import axis_jacobian, check_q, config_from_file
from ._protocol import Measurement, MeasurementKind, NuisanceTerm, ObservationBlock, ObservationOptions
from ._table import DIRECTION_WORDS, MeasurementError, Table, axis_values, read_table

__all__ = ["KIND", "MIN_ARC_DEG", "MIN_SAMPLES", "BallbarRun", "ballbar_positions", "check_circle", "covered_arc",
           "evaluate_circular", "is_ballbar_file", "radial_about", "read_ballbar"]

DEVIATION_RE = re.compile(r"^(?:deviation|radial|dr)_(um|nm|mm)$")
RADIUS_RE = re.compile(r"^(?P<value>[^\s]+?)\s*(?:mm)?$")
#: the smallest arc [deg] the samples of one direction must cover (see the module docstring)
MIN_ARC_DEG = 90.0
#: the fewest samples of one direction
MIN_SAMPLES = 4


@dataclass(frozen=True)
class BallbarRun(Measurement):
    """One circular test in SI.

    ``angle`` (N,) rad, ``deviation`` (N,) m, ``direction`` (N,) +1/-1, ``radius`` m,
    ``plane`` two axis names, ``centre`` axis positions in file units (mm / deg).

    Attributes
    ----------
    source : str
        The file (or a label for simulated data).
    angle : ndarray, shape (N,)
        Angle on the circle, from the first plane axis towards the second [rad].
    deviation : ndarray, shape (N,)
        Radial deviation: measured length minus the nominal radius [m].
    direction : ndarray, shape (N,)
        +1 for increasing angles (G3 in the XY plane), -1 for decreasing (G2).
    radius : float
        Nominal radius [m].
    plane : tuple of str (2,)
        The two linear axes that ran the circle, in order.
    centre : dict of str to float
        Axis positions at the circle's centre [mm, deg], by axis name.
    lines : ndarray of int, shape (N,)
        File line of each sample.
    unit : str, default "um"
        Unit of the deviations in the file (um, nm or mm).
    unused : tuple of str
        Columns present but not used.

    Notes
    -----
    The methods of :class:`~volerr_pin.measurements.Measurement` (documented there) do here:

    - ``observations``: one row per sample: the tool's error along the radius at the commanded
      position; three nuisance terms: the set-up's centre offset along both plane axes and the
      bar's length error. Approach directions come from the motion (see
      :func:`ballbar_positions`).
    """

    source: str
    angle: np.ndarray
    deviation: np.ndarray
    direction: np.ndarray
    radius: float
    plane: tuple[str, str]
    centre: dict
    lines: np.ndarray
    unit: str = "um"
    unused: tuple[str, ...] = ()

    def observations(self, machine, options: ObservationOptions) -> ObservationBlock:
        q, radial, directions = ballbar_positions(machine, self)
        tag = f"ballbar {self.source}"
        terms = (NuisanceTerm(f"centre_{self.plane[0]}[{tag}]", False),
                 NuisanceTerm(f"centre_{self.plane[1]}[{tag}]", False), NuisanceTerm(f"length[{tag}]", False))
        n = len(q)
        w = np.zeros((n, 6))
        w[:, :3] = radial
        angle = np.asarray(self.angle, dtype=float)
        return ObservationBlock(self.source, q, {"directions": directions}, np.arange(n), w,
                                np.asarray(self.deviation, dtype=float), np.full(n, options.sigma_um * 1e-6),
                                np.zeros(n, bool), np.asarray(self.lines),
                                np.column_stack([np.cos(angle), np.sin(angle), np.ones(n)]), terms)


def is_ballbar_file(header: list[str]) -> bool:
    """Whether a header is that of a ballbar file.

    Parameters
    ----------
    header : list of str
        Column names.

    Returns
    -------
    bool
        True if the columns include ``angle_deg`` and a radial deviation column
        (``deviation``, ``radial`` or ``dr`` with unit um, nm or mm).
    """
    return "angle_deg" in header and any(DEVIATION_RE.match(h) for h in header)


def read_ballbar(path: str | Path | Table) -> BallbarRun:
    """Read a ballbar file (see the module docstring); every error names file, line, column.

    Parameters
    ----------
    path : str, Path or Table
        The file, or a table read already.

    Returns
    -------
    BallbarRun
        The run in SI.

    Raises
    ------
    MeasurementError
        If the table is malformed, ``angle_deg`` or the single deviation column is missing, a
        direction is not a direction word, the ``# plane:`` or ``# radius:`` header line
        is missing or invalid (the radius is in mm, positive, at most 1 km), a deviation is
        not smaller than the radius or beyond 1 m, or a direction has fewer than 4 samples or
        covers less than :data:`MIN_ARC_DEG` of the circle.
    """
    table = read_table(path)
    header = table.header
    if "angle_deg" not in header:
        raise MeasurementError(f"{table.path}:{table.header_line}: a ballbar file needs the column angle_deg")
    dev_cols = [c for c, h in enumerate(header) if DEVIATION_RE.match(h)]
    if len(dev_cols) != 1:
        raise MeasurementError(f"{table.path}:{table.header_line}: a ballbar file needs exactly one radial "
                               "deviation column: deviation_um (or _nm, _mm)")
    acol, vcol = header.index("angle_deg"), dev_cols[0]
    unit = DEVIATION_RE.match(header[vcol]).group(1)
    dcol = header.index("direction") if "direction" in header else None
    angle = np.radians(table.column(acol, limit="position_angle", unit="deg", unit_scale=DEG))
    file_value = table.column(vcol, limit="error_length", unit=unit, unit_scale=LENGTH[unit])
    if dcol is None:
        direction = np.ones(len(angle))
    else:
        words = {**DIRECTION_WORDS, "ccw": "1", "cw": "-1", "g3": "1", "g2": "-1"}
        direction = np.empty(len(angle))
        for r, cells in enumerate(table.rows):
            word = cells[dcol].strip().lower()
            if word not in words:
                raise MeasurementError(f"{table.where(r, dcol)}: column 'direction': '{cells[dcol].strip()}' "
                                       "is not a direction (+1/-1, ccw/cw)")
            direction[r] = float(words[word])
    meta = table.meta
    if "plane" not in meta:
        raise MeasurementError(f"{table.path}: which axes ran the circle? Give '# plane: X, Y' in the header")
    plane = tuple(p.strip() for p in re.split(r"[,\s]+", meta["plane"].strip()) if p.strip())
    if len(plane) != 2 or plane[0] == plane[1]:
        raise MeasurementError(f"{table.path}: header '# plane: {meta['plane']}': two different axes expected")
    if "radius" not in meta:
        raise MeasurementError(f"{table.path}: give the nominal radius: '# radius: 100' (mm)")
    match = RADIUS_RE.match(meta["radius"])
    try:
        radius = parse_number(match.group("value")) * MM if match else math.nan
    except ValueError:
        radius = math.nan
    if math.isnan(radius):
        raise MeasurementError(f"{table.path}: header '# radius: {meta['radius']}': not a number of mm")
    if not 0.0 < radius <= PLAUSIBLE["position_length"][1]:
        raise MeasurementError(f"{table.path}: header '# radius: {meta['radius']}': must be positive and at most "
                               f"{PLAUSIBLE['position_length'][1] / MM:g} mm")
    deviation = file_value * LENGTH[unit]
    beyond = np.flatnonzero(np.abs(deviation) >= radius)
    if beyond.size:
        r = int(beyond[0])
        raise MeasurementError(f"{table.where(r, vcol)}: column '{header[vcol]}': a radial deviation of "
                               f"{file_value[r]:g} {unit} is not smaller than the radius {radius / MM:g} mm")
    centre = axis_values(table, "centre") or axis_values(table, "center")
    unused = tuple(h for c, h in enumerate(header) if c not in {acol, vcol, dcol})
    run = BallbarRun(table.path, angle, deviation, direction, radius, plane, centre, np.array(table.lines), unit,
                     unused)
    check_circle(run, MeasurementError)
    return run


def covered_arc(angle: np.ndarray) -> float:
    """The arc of the circle that angles cover, rad: 2 pi less the largest gap between them.

    Parameters
    ----------
    angle : ndarray, shape (n,)
        Angles [rad], any order, any number of turns.

    Returns
    -------
    float
        In [0, 2 pi): 0 for one angle (or all at one angle), nearly 2 pi for a full circle.
    """
    a = np.unique(np.mod(np.asarray(angle, dtype=float), 2 * np.pi))
    if a.size < 2:
        return 0.0
    gaps = np.diff(np.r_[a, a[0] + 2 * np.pi])
    return float(2 * np.pi - gaps.max())


def check_circle(run: BallbarRun, error: type[InputError] = InputError) -> None:
    """Refuse a circular test whose geometry cannot be evaluated: too few samples, or samples
    of one direction covering less than :data:`MIN_ARC_DEG` of the circle.

    Parameters
    ----------
    run : BallbarRun
        The circular test.
    error : type, default InputError
        Exception class raised (``MeasurementError`` for a file).

    Raises
    ------
    InputError
        (or ``error``) Naming the file (``run.source``), the direction and what it covers.
    """
    for d, name in ((1.0, "counter-clockwise (+1)"), (-1.0, "clockwise (-1)")):
        mask = run.direction == d
        if not np.any(mask):
            continue
        count = int(mask.sum())
        if count < MIN_SAMPLES:
            raise error(f"{run.source}: {count} {name} sample(s); a circular test needs at least {MIN_SAMPLES} "
                        "per direction")
        arc = np.degrees(covered_arc(run.angle[mask]))
        if arc < MIN_ARC_DEG:
            raise error(f"{run.source}: the {name} samples cover {arc:.3g} deg of the circle; a circular test "
                        f"needs at least {MIN_ARC_DEG:g} deg (the centre and radius of a shorter arc are not "
                        "determined)")


def _lsc(angle: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Least-squares circle (linearised): r0, cx, cy."""
    A = np.column_stack([np.ones_like(angle), np.cos(angle), np.sin(angle)])
    return np.linalg.lstsq(A, r, rcond=None)[0]


def radial_about(angle, r, fit):
    """Radial deviations about a centre.

    Parameters
    ----------
    angle : ndarray, shape (n,)
        Angles of the samples, rad.
    r : ndarray, shape (n,)
        Radial deviations about the nominal centre (any length unit).
    fit : array_like, shape (3,)
        ``(radius change, centre offset along the first plane axis, along the second)`` in the
        unit of ``r``.

    Returns
    -------
    ndarray, shape (n,)
        ``r`` about the shifted centre (first order in the offset).
    """
    return r - fit[1] * np.cos(angle) - fit[2] * np.sin(angle)


def _on_grid(angle, r, grid):
    """A trace interpolated at ``grid`` angles (periodic in 2 pi)."""
    a = np.mod(angle, 2 * np.pi)
    order = np.argsort(a)
    a, r = a[order], r[order]
    return np.interp(grid, np.concatenate([a - 2 * np.pi, a, a + 2 * np.pi]), np.tile(r, 3))


def evaluate_circular(run: BallbarRun) -> dict:
    """ISO 230-4 figures of a circular test, in um (see the module docstring).

    Parameters
    ----------
    run : BallbarRun
        The circular test.

    Returns
    -------
    dict
        ``source``, ``plane``, ``radius_mm``, ``unit`` ("um"), ``n_points``, ``G``
        (circular deviation; of both directions together when both were run), ``G_ccw`` /
        ``G_cw`` (None for a direction not run), ``F_max`` / ``F_min``
        (radial deviation about the nominal centre), ``H`` (circular hysteresis, both
        directions only, else None), ``centre_offset_um`` (the least-squares centre from the
        nominal one, along the two plane axes' directions), ``radius_error_um`` and the counts
        per direction ``n_ccw`` / ``n_cw``. Lengths in um.

    Raises
    ------
    InputError
        If a direction has fewer than 4 samples or covers less than :data:`MIN_ARC_DEG` of
        the circle (:func:`check_circle`).
    """
    check_circle(run)
    r = run.deviation * 1e6
    out: dict = {"source": run.source, "plane": list(run.plane), "radius_mm": run.radius * 1e3,
                 "unit": "um", "n_points": int(len(r))}
    present = {d: run.direction == d for d in (1.0, -1.0) if np.any(run.direction == d)}
    for d, name in ((1.0, "ccw"), (-1.0, "cw")):
        mask = present.get(d)
        if mask is None:
            out[f"G_{name}"] = None
            out[f"n_{name}"] = 0
            continue
        fit = _lsc(run.angle[mask], r[mask])
        about = radial_about(run.angle[mask], r[mask], fit)
        out[f"G_{name}"] = float(about.max() - about.min())
        out[f"n_{name}"] = int(mask.sum())
    fit = _lsc(run.angle, r)
    about = radial_about(run.angle, r, fit)
    out["G"] = float(about.max() - about.min())
    out["F_max"], out["F_min"] = float(r.max()), float(r.min())
    out["centre_offset_um"] = [float(fit[1]), float(fit[2])]
    out["radius_error_um"] = float(fit[0])
    if out["G_ccw"] is not None and out["G_cw"] is not None:
        grid = np.linspace(0.0, 2 * np.pi, 721)[:-1]
        ccw = _on_grid(run.angle[present[1.0]], about[present[1.0]], grid)
        cw = _on_grid(run.angle[present[-1.0]], about[present[-1.0]], grid)
        out["H"] = float(np.max(np.abs(ccw - cw)))
    else:
        out["H"] = None
    return out


def ballbar_positions(machine, run: BallbarRun) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Commanded positions, radial directions and approach directions of a circular test.

    Parameters
    ----------
    machine : Machine
        The machine; the run's plane axes must be two of its linear axes.
    run : BallbarRun
        The circular test; the centre comes from its ``centre`` (other axes at their default
        configuration, see :func:`~volerr_pin.model.config_from_file`).

    Returns
    -------
    q : ndarray, shape (N, n_axes)
        Commanded NC positions [m, rad].
    radial : ndarray, shape (N, 3)
        Unit radial vectors of the tool relative to the workpiece, in the workpiece frame.
    directions : ndarray, shape (N, n_axes)
        Approach direction of every axis (+1 / -1): from the motion for the two plane axes
        (at a reversal point the direction it came with), +1 for the others.

    Raises
    ------
    InputError
        If a plane axis is not an axis of the machine or not linear, the centre is invalid,
        the circle leaves the travel, or the samples cannot be evaluated (:func:`check_circle`).
    """
    check_circle(run)
    for name in run.plane:
        if name not in machine.axes:
            raise InputError(f"{run.source}: '# plane:' names '{name}', not an axis of {machine.name} "
                             f"({', '.join(machine.axes)})")
    j1, j2 = (machine.axes.index(a) for a in run.plane)
    if machine.axis_kinds[j1] != "linear" or machine.axis_kinds[j2] != "linear":
        raise InputError(f"{run.source}: a ballbar circle needs two linear axes, not {run.plane[0]}, {run.plane[1]}")
    centre = config_from_file(machine, run.centre, f"{run.source}: '# centre:'")
    q = np.tile(centre, (len(run.angle), 1))
    q[:, j1] += run.radius * np.cos(run.angle)
    q[:, j2] += run.radius * np.sin(run.angle)
    try:
        q = check_q(machine.model, q)
    except InputError as err:
        raise InputError(f"{run.source}: the circle leaves the travel: {err}") from None
    J = axis_jacobian(machine.model, q, nominal=True)[:, :3, :]
    radial = J[:, :, j1] * np.cos(run.angle)[:, None] + J[:, :, j2] * np.sin(run.angle)[:, None]
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    # direction of motion of each plane axis: d/da of (cos a, sin a), times the run's sense;
    # at a reversal point (velocity zero) the axis still carries the direction it came with
    directions = np.ones_like(q)
    for j, velocity, before in ((j1, -np.sin(run.angle), -np.sin(run.angle - 1e-6 * run.direction)),
                                (j2, np.cos(run.angle), np.cos(run.angle - 1e-6 * run.direction))):
        v = velocity * run.direction
        v = np.where(np.abs(v) < 1e-12, before * run.direction, v)
        directions[:, j] = np.where(v >= 0.0, 1.0, -1.0)
    return q, radial, directions


#: circular tests (ISO 230-4): radial deviation against the angle
KIND = MeasurementKind("ballbar", "circular tests", False, recognises=is_ballbar_file,
                       read=lambda table, machine=None, axis=None: read_ballbar(table))
