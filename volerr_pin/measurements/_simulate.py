"""Simulated measurement campaigns, for examples, tests and trying the tools out.

:func:`campaign` visits commanded positions in random order over a few hours and records
every covariate column the product reads: time, three temperature sensors with different
dynamics (a spindle bearing warming up, a column following a slow cycle, the room), process
forces on half of the points, and random approach directions. The measured deviations are
a machine's volumetric error plus independent noise.
"""

from __future__ import annotations

import numpy as np

from ..model import Machine, axis_jacobian, check_covariates, to_engineering, tool_poses, volumetric_error
from ._ballbar import BallbarRun, ballbar_positions
from ._points import PointMeasurements
from ._tracker import TrackerMeasurements
from ..base import AXIS_UNIT, axis_scale, write_text


def covariates(n: int, rng: np.random.Generator, hours: float = 6.0, n_axes: int = 3) -> dict:
    """Time [s], temperatures [degC], forces [N] and directions (+1/-1) for ``n`` points.

    Times are sorted uniform draws over ``hours``; three temperature sensors with different
    dynamics (``spindle`` warming up, ``column`` following a slow cycle, ``ambient``) plus
    0.1 degC noise; normal process forces (150 N standard deviation) on about half of the
    points, 0 on the others; random approach directions.

    Parameters
    ----------
    n : int
        Number of points.
    rng : numpy.random.Generator
        The random generator (advanced by the draws).
    hours : float, default 6.0
        Length of the campaign [h].
    n_axes : int, default 3
        Number of axes (columns of ``directions``).

    Returns
    -------
    dict
        ``t`` (n,) [s], ``temperatures`` {"spindle", "column", "ambient": (n,)} [degC],
        ``forces`` (n, 3) [N], ``directions`` (n, n_axes) of +1/-1.
    """
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
    """``n`` tool-point measurements (dx, dy, dz) of the machine ``truth`` with noise.

    Positions are uniform over the travels (one turn, -pi to pi, for endless axes), the
    covariates those of :func:`covariates`.

    Parameters
    ----------
    truth : Machine
        The machine measured.
    n : int, default 400
        Number of points.
    noise_um : float, default 0.3
        Standard deviation of the independent noise on each deviation [um].
    seed : int, default 0
        Seed of all draws.
    hours : float, default 6.0
        Length of the campaign [h].
    source : str, default "simulated"
        Label recorded as the source.

    Returns
    -------
    PointMeasurements
        Positions [m, rad], deviations dx, dy, dz [m] (rotations NaN: not measured), the
        covariates, and lines 0..n-1.
    """
    rng = np.random.default_rng(seed)
    travel = truth.travel
    travel = np.where(np.isfinite(travel), travel, np.array([-np.pi, np.pi]))
    q = rng.uniform(travel[:, 0], travel[:, 1], (n, len(truth.axes)))   # within the travel
    cov = covariates(n, rng, hours, len(truth.axes))
    values = np.full((n, 6), np.nan)
    error = volumetric_error(truth.model, q, truth.theta, check_covariates(truth.model, n, cov, truth.state))
    values[:, :3] = error[:, :3] + rng.normal(0.0, noise_um * 1e-6, (n, 3))
    return PointMeasurements(source, q, values, cov, np.arange(n))


def write_points(data: PointMeasurements, machine: Machine, path) -> None:
    """Write point measurements in the format :func:`~volerr_pin.measurements.read_points` reads.

    Positions in mm / deg, deviations in um (urad for rotations), covariate columns ``t`` [s],
    ``T_<sensor>`` [degC], ``Fx, Fy, Fz`` [N] and ``dir_<axis>``, those the data have.
    Deviation columns that are NaN throughout are left out.

    Parameters
    ----------
    data : PointMeasurements
        The measurements.
    machine : Machine
        The machine (its axes name the position columns).
    path : str or Path
        The file to write.
    """
    cols = [a.lower() for a in machine.axes]
    positions = to_engineering(machine, data.q)
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
        row = [f"{v:.6f}" for v in positions[i]]
        row += ["" if np.isnan(data.values[i, k]) else f"{data.values[i, k] * 1e6:.5f}" for k in measured]
        if "t" in cov:
            row.append(f"{cov['t'][i]:.3f}")
        row += [f"{cov['temperatures'][s][i]:.4f}" for s in sensors]
        if cov.get("forces") is not None:
            row += [f"{v:.3f}" for v in cov["forces"][i]]
        if cov.get("directions") is not None:
            row += [f"{int(v)}" for v in cov["directions"][i]]
        lines.append(",".join(row))
    write_text(path, "\n".join(lines) + "\n")


def off_model_geometry(machine: Machine, seed: int = 0, style: str = "spline",
                       size_um: float = 2.0, size_arcsec: float = 2.0) -> Machine:
    """A machine whose geometry lies outside ``machine``'s function space.

    Every component error of an axis (positioning, straightness, angular) is replaced by a
    random smooth function of the axis position: ``style`` "cubic" gives Legendre
    polynomials of degree 3 (one above the quadratics of typical angular terms), "spline"
    cubic splines through 7 random values at uneven positions (each within a
    quarter spacing of even), which no polynomial or
    table of the spec reproduces exactly. Coefficients / node values are normal with
    standard deviation ``size_um`` (translations) or ``size_arcsec`` (rotations).
    Location errors (squareness, offsets) keep their values: they are constants by nature.
    Real machines are like this: their geometry is never exactly the spec's.
    All six component errors of every axis with a bounded travel get such a function (those the
    spec lacks are added); endless axes are left unchanged.

    Parameters
    ----------
    machine : Machine
        The machine to start from.
    seed : int, default 0
        Seed of the random functions.
    style : str, default "spline"
        "cubic" or "spline".
    size_um : float, default 2.0
        Standard deviation of translational coefficients or node values [um].
    size_arcsec : float, default 2.0
        Standard deviation of rotational coefficients or node values [arcsec].

    Returns
    -------
    Machine
        The machine with the replaced terms (:func:`~volerr_pin.model.replace_terms`).

    Raises
    ------
    ValueError
        If ``style`` is neither "cubic" nor "spline".
    """
    if style not in ("cubic", "spline"):
        raise ValueError(f"style must be 'cubic' or 'spline', got {style!r}")
    rng = np.random.default_rng(seed)
    tables = {}
    for j, (axis, kind) in enumerate(zip(machine.axes, machine.axis_kinds)):
        lo, hi = machine.travel[j]
        if not np.isfinite(lo) or not np.isfinite(hi):
            continue
        position_unit, scale = AXIS_UNIT[kind], 1.0 / axis_scale(kind)
        for d in "XYZABC":
            unit, size = ("um", size_um) if d in "XYZ" else ("arcsec", size_arcsec)
            name = f"E{d}{axis}"
            if style == "cubic":
                tables[name] = {"kind": "legendre",
                                f"coefficients_{unit}": [float(v) for v in rng.normal(0.0, size, 4)]}
            else:
                u = np.linspace(0.0, 1.0, 7)
                u[1:-1] += rng.uniform(-0.25, 0.25, 5) / 6  # uneven, but never crowded
                nodes = lo + (hi - lo) * u
                tables[name] = {"kind": "table", "interpolation": "cubic",
                                f"positions_{position_unit}": [float(x * scale) for x in nodes],
                                f"values_{unit}": [float(v) for v in rng.normal(0.0, size, 7)]}
    from ..model import replace_terms
    return replace_terms(machine, tables)


def ballbar_run(machine: Machine, plane=("X", "Y"), radius_mm: float = 100.0, centre_mm: dict | None = None,
                directions=(1, -1), n: int = 360, noise_um: float = 0.1, seed: int = 0,
                setup_offset_um=(0.0, 0.0), length_error_um: float = 0.0, source: str = "simulated"):
    """A simulated circular test (ISO 230-4) of ``machine``: ``n`` samples per direction.

    The bar's length is computed exactly - the distance between the tool ball and a table
    ball that sits ``setup_offset_um`` off the nominal centre (along the two plane axes'
    directions), minus the nominal radius, plus the bar's ``length_error_um`` and noise - not
    from the linearised radial projection the model uses, so that a fit checks that too.

    Parameters
    ----------
    machine : Machine
        The machine.
    plane : tuple of str (2,), default ("X", "Y")
        The two linear axes that run the circle.
    radius_mm : float, default 100.0
        Nominal radius [mm].
    centre_mm : dict of str to float, optional
        Axis positions at the centre [mm, deg] (default: the default configuration).
    directions : sequence of int, default (1, -1)
        Directions run, in order: +1 counter-clockwise, -1 clockwise.
    n : int, default 360
        Samples per direction, evenly spaced in angle.
    noise_um : float, default 0.1
        Standard deviation of the noise [um].
    seed : int, default 0
        Seed of the noise.
    setup_offset_um : tuple of float (2,), default (0.0, 0.0)
        Offset of the table ball from the nominal centre along the two plane axes [um].
    length_error_um : float, default 0.0
        Length error of the bar [um].
    source : str, default "simulated"
        Label recorded as the source.

    Returns
    -------
    BallbarRun
        The run in SI (lines 0..N-1).

    Raises
    ------
    InputError
        If the plane axes are not linear axes of the machine or the circle leaves the travel.
    """
    rng = np.random.default_rng(seed)
    angles = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    angle = np.concatenate([angles if d > 0 else angles[::-1] for d in directions])
    direction = np.concatenate([np.full(n, float(d)) for d in directions])
    run = BallbarRun(source, angle, np.zeros(len(angle)), direction, radius_mm * 1e-3, tuple(plane),
                     dict(centre_mm or {}), np.arange(len(angle)))
    q, _, dirs = ballbar_positions(machine, run)   # checked against the travel
    j1, j2 = (machine.axes.index(a) for a in plane)
    model = machine.model
    J = axis_jacobian(model, q, nominal=True)[:, :3, :]
    centre_q = q.copy()
    centre_q[:, j1] -= run.radius * np.cos(angle)
    centre_q[:, j2] -= run.radius * np.sin(angle)
    offset = (J[:, :, j1] * setup_offset_um[0] + J[:, :, j2] * setup_offset_um[1]) * 1e-6
    d = (J[:, :, j1] * (q[:, j1] - centre_q[:, j1])[:, None] + J[:, :, j2] * (q[:, j2] - centre_q[:, j2])[:, None]
         + volumetric_error(model, q, machine.theta,
                            check_covariates(model, len(q), {"directions": dirs}, machine.state))[:, :3] - offset)
    deviation = (np.linalg.norm(d, axis=1) - run.radius + length_error_um * 1e-6
                 + rng.normal(0.0, noise_um * 1e-6, len(angle)))
    return BallbarRun(source, angle, deviation, direction, run.radius, tuple(plane), dict(centre_mm or {}),
                      np.arange(len(angle)))


def write_ballbar(run, path) -> None:
    """Write a circular test in the format :func:`volerr_pin.measurements.read_ballbar` reads.

    Header lines ``# plane:``, ``# radius:`` [mm] and ``# centre:`` (when given), then
    ``angle_deg,deviation_um,direction``.

    Parameters
    ----------
    run : BallbarRun
        The circular test.
    path : str or Path
        The file to write.
    """
    centre = ", ".join(f"{k}={v:g}" for k, v in run.centre.items())
    lines = [f"# plane: {run.plane[0]}, {run.plane[1]}", f"# radius: {run.radius * 1e3:g}"]
    lines += [f"# centre: {centre}"] if centre else []
    lines.append("angle_deg,deviation_um,direction")
    lines += [f"{np.degrees(a):.4f},{v * 1e6:.5f},{int(d)}"
              for a, v, d in zip(run.angle, run.deviation, run.direction)]
    write_text(path, "\n".join(lines) + "\n")


def tracker_campaign(truth: Machine, n: int = 100, offsets_mm=((0.0, 0.0, 0.0),), noise_um: float = 5.0,
                     seed: int = 0, rotation=None, translation_mm=(2000.0, -1000.0, 300.0),
                     source: str = "simulated"):
    """Laser-tracker measurements of ``truth``.

    ``n`` random poses, every target of ``offsets_mm`` (tool frame) measured at each, in a
    tracker frame placed by ``rotation`` (3x3; default 30 deg about z and 5 deg about x) and
    ``translation_mm``, with isotropic noise. Exact: actual tool poses, not the model's
    first-order projection. Covariates are drawn (as :func:`covariates`) only when the
    machine reads them.

    Parameters
    ----------
    truth : Machine
        The machine measured.
    n : int, default 100
        Number of poses, uniform over the travels.
    offsets_mm : array_like, shape (n_targets, 3), default ((0, 0, 0),)
        Target offsets in the tool frame [mm].
    noise_um : float, default 5.0
        Standard deviation of the noise on each coordinate [um].
    seed : int, default 0
        Seed of all draws.
    rotation : array_like, shape (3, 3), optional
        Rotation of the workpiece frame into the tracker frame.
    translation_mm : array_like, shape (3,), default (2000, -1000, 300)
        Translation of the tracker frame [mm].
    source : str, default "simulated"
        Label recorded as the source.

    Returns
    -------
    TrackerMeasurements
        N = n x n_targets rows (the targets of a pose together, named T1, T2, ...), in SI.
    """
    rng = np.random.default_rng(seed)
    travel = np.where(np.isfinite(truth.travel), truth.travel, np.array([-np.pi, np.pi]))
    q0 = rng.uniform(travel[:, 0], travel[:, 1], (n, len(truth.axes)))   # within the travel
    offsets = np.asarray(offsets_mm, dtype=float) * 1e-3
    q = np.repeat(q0, len(offsets), axis=0)
    o = np.tile(offsets, (n, 1))
    cov = covariates(n, rng, n_axes=len(truth.axes)) if truth.covariates_used else {}
    cov = {k: (np.repeat(v, len(offsets), axis=0) if not isinstance(v, dict)
               else {s: np.repeat(a, len(offsets)) for s, a in v.items()}) for k, v in cov.items()}
    if rotation is None:
        cz, sz, cx, sx = np.cos(np.radians(30)), np.sin(np.radians(30)), np.cos(np.radians(5)), np.sin(np.radians(5))
        rotation = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]) @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    R_act, p_act = tool_poses(truth.model, q, truth.theta, check_covariates(truth.model, len(q), cov, truth.state))
    target = p_act + np.einsum("nij,nj->ni", R_act, o)
    measured = target @ np.asarray(rotation).T + np.asarray(translation_mm) * 1e-3
    measured += rng.normal(0.0, noise_um * 1e-6, measured.shape)
    names = tuple(f"T{k + 1}" for k in range(len(offsets))) * n
    return TrackerMeasurements(source, q, measured, o, names, cov, np.arange(len(q)))


def write_tracker(data, machine: Machine, path) -> None:
    """Write tracker measurements in the format :func:`volerr_pin.measurements.read_tracker` reads.

    Positions (mm / deg), targets, offsets and coordinates (mm); covariates are not written.

    Parameters
    ----------
    data : TrackerMeasurements
        The measurements.
    machine : Machine
        The machine (its axes name the position columns).
    path : str or Path
        The file to write.
    """
    cols = [a.lower() for a in machine.axes]
    positions = to_engineering(machine, data.q)
    lines = [",".join(cols + ["target", "ox", "oy", "oz", "tx", "ty", "tz"])]
    for i in range(len(data.q)):
        row = [f"{v:.6f}" for v in positions[i]] + [data.targets[i]]
        row += [f"{v * 1e3:.4f}" for v in data.offsets[i]] + [f"{v * 1e3:.6f}" for v in data.coordinates[i]]
        lines.append(",".join(row))
    write_text(path, "\n".join(lines) + "\n")


def heldout_set(machine: Machine, hidden: dict | None = None, n: int = 400, noise_um: float = 0.3, seed: int = 0,
                style: str = "spline", hours: float = 6.0) -> tuple[Machine, PointMeasurements]:
    """A held-out test set for a diagnosis: geometry off ``machine``'s function space
    (:func:`off_model_geometry`, seeded by ``seed``), the ``hidden`` effect terms added, and a
    campaign of ``n`` points with every covariate column (:func:`campaign`: time, three
    temperatures, three forces, every axis' approach direction).

    Parameters
    ----------
    machine : Machine
        The model that will be diagnosed (the truth starts from it).
    hidden : dict, optional
        Component -> term table (or list of tables), as :func:`~volerr_pin.model.add_terms`
        takes them; none by default.
    n : int, default 400
        Points.
    noise_um : float, default 0.3
        Noise per deviation component [um].
    seed : int, default 0
        Seed of the geometry and of the campaign (the campaign's is ``seed + 1000``).
    style : str, default "spline"
        Off-spec geometry style (see :func:`off_model_geometry`).
    hours : float, default 6.0
        Length of the campaign [h].

    Returns
    -------
    tuple of (Machine, PointMeasurements)
        The true machine and its measurements.
    """
    from ..model import add_terms

    truth = off_model_geometry(machine, seed, style)
    if hidden:
        truth = add_terms(truth, hidden)
    return truth, campaign(truth, n, noise_um, seed + 1000, hours)
