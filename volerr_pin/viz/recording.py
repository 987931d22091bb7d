"""Rerun recordings of machines, error fields, sensitivity rankings and timelines.

Every function takes an explicit :class:`rerun.RecordingStream` (no global recording),
logs constant data with ``static=True`` and writes under hierarchical entity paths:

- ``machine/...``: the nominal URDF (visuals from the URDF, boxes where it has no meshes)
  and ``machine/transforms``, the axis-joint transforms of the displayed configuration;
- ``field/...``: ``points`` coloured by the error magnitude (with ``dx_um``, ``dy_um``,
  ``dz_um``, ``norm_um`` attached to every point), ``arrows`` magnified by a stated
  factor, ``components/dx|dy|dz`` scalar fields, ``legend`` and ``about``;
- ``sensitivity/...``: the ranking as a bar chart and its table;
- ``thermal/...``: time series on the ``time`` timeline (bulk, with ``send_columns``).

Field data sit in the URDF's workpiece frame (``CoordinateFrame``), so they move with the
table in the 3D view. Rotary axes get a sweep on the ``sweep`` timeline.

Recordings are shared, so Rerun's URDF importer (which embeds every mesh file a URDF names)
is only ever given a copy of the URDF whose meshes passed :func:`volerr_pin.model.urdf.checked_meshes`:
inside the URDF's folder or a package folder named, regular files, limited in size; other
visuals are dropped with a warning. Files are written through a temporary file beside the
target, renamed over it once Rerun has closed it (footer written), so a failed run leaves an
existing file as it was.
"""

from __future__ import annotations

import contextlib
import copy
import math
import numbers
import tempfile
import warnings
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from matplotlib import colormaps

from ..base.errors import InputError
from ..model.machine import Machine
from ..base.safeio import check_outputs, replacing, require_memory
from ..model.urdf import checked_meshes, complete_limits, package_folders
from ..model.workspace import FieldData, default_config, evaluate_field, field_grid, nice_scale, to_engineering
from ..base.units import UM_PER_M

#: memory a field point takes while it is evaluated and logged, and per sweep step held [bytes]
#: (measured: about 0.6 kB per point and step for a 5-axis machine; doubled for headroom)
FIELD_POINT_BYTES = 1200


def new_recording(app_id: str = "volerr_pin", recording_id: str | None = None) -> rr.RecordingStream:
    """A fresh recording stream (not global)."""
    return rr.RecordingStream(app_id, recording_id=recording_id)


def default_blueprint(time_series: bool = False, sweep: bool = False) -> rrb.Blueprint:
    """3D view of machine and field, beside the ranking (and the time series, if any)."""
    side = [rrb.BarChartView(origin="sensitivity/ranking", name="error sources (RMS um at the tool)"),
            rrb.TextDocumentView(origin="sensitivity/table", name="ranking")]
    if time_series:
        side.append(rrb.TimeSeriesView(origin="thermal", name="time-dependent errors"))
    main = rrb.Spatial3DView(origin="/", contents=["machine/**", "field/**"],
                             name="machine and error field")
    return rrb.Blueprint(
        rrb.Horizontal(main, rrb.Vertical(*side), column_shares=[3, 2]),
        rrb.TimePanel(state="expanded" if (time_series or sweep) else "collapsed"),
    )


def log_machine(rec: rr.RecordingStream, machine: Machine, q: np.ndarray,
                prefix: str = "machine", moving: tuple[str, ...] = (), package_dirs=None) -> None:
    """The nominal URDF (static) and the axis-joint transforms at NC positions ``q`` (SI),
    static except for the axes named in ``moving`` (those are logged on the active timeline
    by :func:`log_joint_transforms`).

    Meshes are read only as :func:`volerr_pin.model.urdf.checked_meshes` allows, from the machine's
    :attr:`~volerr_pin.model.machine.Machine.package_dirs` and ``package_dirs``; a visual whose mesh
    is refused is left out with a warning naming the URDF, its line and the mesh."""
    from rerun.urdf import UrdfTree

    with _rerun_urdf(machine, package_dirs) as path:
        tree = UrdfTree.from_file_path(path, entity_path_prefix=prefix)
        tree.log_urdf_to_recording(rec)
    still = [a for a in machine.axes if a not in moving]
    log_joint_transforms(rec, machine, q, prefix, static=True, axes=still, tree=tree)


def log_joint_transforms(rec, machine: Machine, q: np.ndarray, prefix: str = "machine",
                         static: bool = True, axes=None, tree=None) -> None:
    """Transforms of the axis joints (all, or those of ``axes``) at ``q`` on
    ``{prefix}/transforms/<joint>``."""
    from rerun.urdf import UrdfTree

    if tree is None:
        with _rerun_urdf(machine, meshes=False) as path:
            tree = UrdfTree.from_file_path(path, entity_path_prefix=prefix)
    for axis, value in zip(machine.spec.axes, q):
        if axes is not None and axis.name not in axes:
            continue
        joint = tree.get_joint_by_name(axis.joint)
        rec.log(f"{prefix}/transforms/{axis.joint}",
                joint.compute_transform(float(axis.sign * value), clamp=False), static=static)


@contextlib.contextmanager
def _rerun_urdf(machine: Machine, package_dirs=None, meshes: bool = True):
    """The path of a copy of the machine's URDF that Rerun's importer may read, in a temporary
    folder for the duration of the block: every ``<limit>`` with ``effort`` and ``velocity`` (URDF
    allows leaving them out, the importer does not), and every mesh a checked copy beside it
    (:func:`volerr_pin.model.urdf.checked_meshes`; refused ones dropped with a warning), or no visuals
    at all when ``meshes`` is False."""
    with tempfile.TemporaryDirectory(prefix="volerr_urdf_") as folder:
        if meshes:
            roots = machine.package_dirs + package_folders(package_dirs)
            document, notes = checked_meshes(machine.urdf, folder, roots, path=machine.spec.urdf)
            for note in notes:
                warnings.warn(note, stacklevel=2)
        else:
            document = copy.deepcopy(machine.urdf.document)
            for element in list(document.getroot().iter("visual", "collision", "texture")):
                if element.getparent() is not None:
                    element.getparent().remove(element)
        complete_limits(document.getroot())
        path = Path(folder) / f"{Path(machine.spec.urdf).stem or 'machine'}.urdf"
        document.write(str(path), xml_declaration=True, encoding="utf-8")
        yield path


@contextlib.contextmanager
def streaming(rec: rr.RecordingStream, path, blueprint, spawn: bool = False, connect: str | None = None):
    """Send what ``rec`` logs in the block to ``path`` and to the viewers asked for.

    The file is a temporary one beside ``path``, renamed over it when the block ends without an
    exception and Rerun has closed it (``disconnect`` writes the footer and returns when the file
    is complete); otherwise it is removed and an existing ``path`` stays as it was. One
    ``set_sinks`` call tees file and viewers: ``save`` followed by ``spawn`` or ``connect_grpc``
    would replace the file with the viewer.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording; it is disconnected when the block ends.
    path : str, Path or None
        The ``.rrd`` file to write (None: viewers only).
    blueprint : rerun.blueprint.Blueprint or None
        The default blueprint sent with the recording.
    spawn : bool, default False
        Also send to a viewer started for it.
    connect : str, optional
        Also send to the viewer at this address (``rerun+http://host:port/proxy``).

    Yields
    ------
    None
        Log to ``rec`` inside the block.

    Raises
    ------
    InputError
        Naming ``spawn`` or ``connect`` when no viewer can be reached there, or ``path`` when
        the recording cannot be flushed.
    """
    with contextlib.ExitStack() as stack:
        sinks = []
        if path is not None:
            sinks.append(rr.FileSink(str(stack.enter_context(replacing(path)))))
        viewer = ("connect",) if connect else ("spawn",) if spawn else ()
        try:
            if spawn:
                rec.spawn(connect=False)
                sinks.append(rr.GrpcSink())
            if connect:
                sinks.append(rr.GrpcSink(connect))
                _check_viewer(connect)
        except (RuntimeError, ValueError, OSError) as err:
            raise InputError(f"{viewer[0]}: cannot reach a Rerun viewer: {err}", parameters=viewer) from err
        if sinks:
            rec.set_sinks(*sinks, default_blueprint=blueprint)
        try:
            yield
            try:
                rec.flush()
            except RuntimeError as err:  # the viewer could not be reached
                raise InputError(f"{viewer[0] if viewer else 'path'}: {err}",
                                 parameters=viewer or ("path",)) from err
        finally:
            rec.disconnect()


def _check_viewer(url: str, timeout: float = 3.0) -> None:
    """Fail at once when nothing listens at a viewer's address (Rerun itself would retry for
    seconds, then fail only when the recording is flushed)."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(url.replace("rerun+", "", 1))
    secure = parts.scheme in ("https", "rerun")
    port = parts.port or (443 if secure else 80)
    try:
        with socket.create_connection((parts.hostname or "127.0.0.1", port), timeout=timeout):
            pass
    except OSError as err:
        raise OSError(f"nothing answers at {url} ({err.strerror or err})") from err


def colours(values: np.ndarray, lo: float, hi: float, cmap: str = "viridis") -> np.ndarray:
    """(N, 3) uint8 colours of ``values`` on a matplotlib colour map over [lo, hi]."""
    span = hi - lo if hi > lo else 1.0
    rgba = colormaps[cmap](np.clip((values - lo) / span, 0.0, 1.0))
    return (rgba[:, :3] * 255).astype(np.uint8)


def log_field(rec: rr.RecordingStream, machine: Machine, field: FieldData, prefix: str = "field",
              static: bool = True, legend: bool = True, colour_max: float | None = None) -> None:
    """Points coloured by |error| (0 .. ``colour_max`` um, default the field's maximum), arrows
    magnified ``field.scale`` times, per-component fields, the numbers attached to every
    point, a colour legend and an explanation."""
    e_um = field.error[:, :3] * UM_PER_M
    norm = np.linalg.norm(e_um, axis=1)
    hi = colour_max if colour_max is not None else (float(norm.max()) if len(norm) else 1.0)
    frame = rr.CoordinateFrame(machine.workpiece_frame)
    extent = float(np.ptp(field.positions, axis=0).max()) if len(field.positions) > 1 else 0.1
    radius = max(extent / 300.0, 1e-4)
    rec.log(f"{prefix}/points", frame, rr.Points3D(field.positions, colors=colours(norm, 0.0, hi),
                                                   radii=radius),
            rr.AnyValues(dx_um=e_um[:, 0], dy_um=e_um[:, 1], dz_um=e_um[:, 2], norm_um=norm),
            static=static)
    rec.log(f"{prefix}/arrows", frame,
            rr.Arrows3D(origins=field.positions, vectors=field.error[:, :3] * field.scale,
                        colors=colours(norm, 0.0, hi), radii=radius / 2),
            static=static)
    bound = hi
    for i, name in enumerate(("dx", "dy", "dz")):
        rec.log(f"{prefix}/components/{name}", frame,
                rr.Points3D(field.positions, colors=colours(e_um[:, i], -bound, bound, "RdBu_r"),
                            radii=radius),
                rr.AnyValues(**{f"{name}_um": e_um[:, i]}), static=static)
    if legend:
        lo_corner = field.positions.min(axis=0)
        hi_corner = field.positions.max(axis=0)
        offset = 0.15 * max(extent, 0.05)
        levels = np.linspace(0.0, hi, 11)
        where = np.c_[np.full(11, hi_corner[0] + offset), np.full(11, lo_corner[1]),
                      np.linspace(lo_corner[2], lo_corner[2] + max(extent, 0.05) * 0.6, 11)]
        labels = [f"{v:.2f} um" if k % 5 == 0 else "" for k, v in enumerate(levels)]
        rec.log(f"{prefix}/legend", frame,
                rr.Points3D(where, colors=colours(levels, 0.0, hi), radii=radius * 4, labels=labels,
                            show_labels=True), static=static)
        rec.log(f"{prefix}/about", rr.TextDocument(
            f"# Volumetric error field of {machine.name}\n\n"
            f"{len(field.q)} points; colour: |error| from 0 to {hi:.2f} um (viridis; legend beside the "
            f"field); arrows: error vectors magnified **{field.scale:g} times**; "
            f"`components/dx|dy|dz`: signed components, blue -{bound:.2f} .. red +{bound:.2f} um. "
            "Select a point to read dx_um, dy_um, dz_um and norm_um.\n\n"
            "Error = actual minus nominal tool point relative to the workpiece, in the workpiece "
            "frame.", media_type=rr.MediaType.MARKDOWN), static=True)


def log_ranking(rec: rr.RecordingStream, ranking: dict, prefix: str = "sensitivity") -> None:
    """The ranking (from :func:`volerr_pin.fit.ranking.rank`.to_dict()) as a bar chart and a table."""
    rows = ranking["ranking"]
    rec.log(f"{prefix}/ranking", rr.BarChart(np.array([r["rms_um"] for r in rows]),
                                             color=[64, 110, 180]), static=True)
    lines = ["| # | term | axis | RMS um | max um | share of all terms |", "|---|---|---|---|---|---|"]
    lines += [f"| {i} | {r['parameter']} | {r['axis']} | {r['rms_um']:.3f} | {r['max_um']:.3f} | "
              f"{100 * r.get('share_of_all', r['share']):.1f} % |" for i, r in enumerate(rows)]
    rec.log(f"{prefix}/table", rr.TextDocument(
        f"Bars, left to right (index 0 first), RMS tool-point error per term over "
        f"{ranking['points']} points:\n\n" + "\n".join(lines), media_type=rr.MediaType.MARKDOWN),
        static=True)


def log_time_series(rec: rr.RecordingStream, t: np.ndarray, series: dict[str, np.ndarray],
                    prefix: str = "thermal", timeline: str = "time") -> None:
    """Bulk time series: one ``send_columns`` call per series on the ``time`` timeline [s]."""
    t = np.asarray(t, dtype=float)
    for name, values in series.items():
        values = np.asarray(values, dtype=float)
        if values.shape != t.shape:
            raise InputError(f"series '{name}' has shape {values.shape}; time has {t.shape}")
        rec.send_columns(f"{prefix}/{name}", indexes=[rr.TimeColumn(timeline, duration=t)],
                         columns=rr.Scalars.columns(scalars=values))


def record_field(machine: Machine, path: str | Path | None = None, *, counts=None,
                 config: dict[str, float] | None = None, scale: float | None = None,
                 ranking: dict | None = None, sweep_steps: int = 24, spawn: bool = False,
                 connect: str | None = None, package_dirs=None) -> dict:
    """Write a complete recording: machine, error field, ranking, default blueprint.

    Rotary axes not fixed by ``config`` sweep their travel in ``sweep_steps`` steps on the
    ``sweep`` timeline (machine and field together; an endless axis sweeps one turn, -180 to
    180 deg); otherwise everything is static.

    Parameters
    ----------
    machine : Machine
        The machine.
    path : str or Path, optional
        The ``.rrd`` file, written through a temporary file beside it and renamed over it once
        complete (a failed run leaves an existing file as it was); None for a viewer only.
    counts : sequence of int, optional
        Points per linear axis (see :func:`volerr_pin.model.workspace.field_grid`).
    config : dict of str to float, optional
        Positions of the axes that do not span the field [m, rad].
    scale : float, optional
        Arrow magnification (default: a round factor, see :func:`volerr_pin.model.workspace.nice_scale`).
    ranking : dict, optional
        A ranking (:meth:`volerr_pin.fit.ranking.Ranking.to_dict`) to show beside the field.
    sweep_steps : int, default 24
        Steps of the rotary-axis sweep; 0 for none.
    spawn : bool, default False
        Also stream to a new Rerun viewer.
    connect : str, optional
        Also stream to a running viewer at this gRPC URL (``rerun+http://host:port/proxy``).
    package_dirs : path or iterable of path, optional
        Folders of ``package://`` meshes, besides the machine's own (see :func:`log_machine`).

    Returns
    -------
    dict
        ``path``, ``points``, ``scale``, ``max_um``, ``sweep_steps``, ``sweep_axes``, ``bytes``
        (of the file, or None), ``config`` (mm / deg).

    Raises
    ------
    InputError
        If ``sweep_steps`` is not a whole number >= 0, the field would take more memory than
        this machine has free (naming ``counts`` and ``sweep_steps``), ``path`` cannot be
        written, a viewer cannot be reached, or an argument of the field is invalid.
    """
    if isinstance(sweep_steps, bool) or not isinstance(sweep_steps, numbers.Integral) or sweep_steps < 0:
        raise InputError(f"sweep_steps must be a whole number >= 0 (0: no sweep), got {sweep_steps!r}",
                         parameters=("sweep_steps",))
    sweep_steps = int(sweep_steps)
    if path is not None:
        check_outputs({"path": path})
    config = dict(config or {})
    base = default_config(machine, config)
    linear_present = any(k == "linear" for k in machine.axis_kinds)
    sweeping = tuple(a for a, k in zip(machine.axes, machine.axis_kinds)
                     if k == "rotary" and a not in config) if (linear_present and sweep_steps > 0) else ()
    points = _field_points(machine, counts)
    if points is not None:  # sized before the grid is made; field_grid checks the counts themselves
        steps = sweep_steps if sweeping else 1
        require_memory(points * steps * FIELD_POINT_BYTES,
                       f"a field of {points:,} points" + (f" in {steps:,} sweep steps" if sweeping else ""),
                       ("counts", "sweep_steps") if sweeping else ("counts",))
    q = field_grid(machine, counts, config)
    rec = new_recording()
    blueprint = default_blueprint(sweep=bool(sweeping))
    with streaming(rec, path, blueprint, spawn, connect):
        log_machine(rec, machine, base, moving=sweeping, package_dirs=package_dirs)
        if sweeping:
            scale = log_rotary_sweep(rec, machine, q, base, sweeping, scale, sweep_steps)
            field = evaluate_field(machine, q, scale)
        else:
            field = evaluate_field(machine, q, scale)
            log_field(rec, machine, field)
        if ranking is not None:
            log_ranking(rec, ranking)
    size = Path(path).stat().st_size if path is not None else None
    return {"path": str(path) if path is not None else None, "points": int(len(q)),
            "scale": field.scale, "max_um": float(np.linalg.norm(field.error[:, :3], axis=1).max() * UM_PER_M),
            "sweep_steps": sweep_steps if sweeping else 0, "sweep_axes": list(sweeping),
            "bytes": size, "config": to_engineering(machine, base).tolist()}


def _field_points(machine: Machine, counts) -> int | None:
    """How many points :func:`~volerr_pin.model.workspace.field_grid` will make, without making them;
    None when ``counts`` is not something it accepts (it then says why)."""
    linear = sum(k == "linear" for k in machine.axis_kinds)
    if not linear:
        return 1000
    try:
        values = [9] if counts is None else [int(c) for c in counts]
    except (TypeError, ValueError):
        return None
    if len(values) == 1:
        values = values * linear
    if len(values) != linear or min(values) < 1:
        return None
    return math.prod(values)


def sweep_angles(machine: Machine, axes: tuple[str, ...], steps: int) -> np.ndarray:
    """(steps, len(axes)) angles: the axes sweep their travels together, end to end."""
    idx = [machine.axes.index(a) for a in axes]
    travel = machine.travel[idx]
    u = np.linspace(0.0, 1.0, steps)[:, None]
    return travel[:, 0] + u * (travel[:, 1] - travel[:, 0])


def log_rotary_sweep(rec: rr.RecordingStream, machine: Machine, q: np.ndarray, base: np.ndarray,
                     axes: tuple[str, ...], scale: float | None, steps: int,
                     prefix: str = "field") -> float:
    """The field and the machine while ``axes`` sweep their travels, on the ``sweep``
    timeline (step k at ``sweep = k``). One arrow scale for all steps; returns it."""
    idx = [machine.axes.index(a) for a in axes]
    angles = sweep_angles(machine, axes, steps)
    fields = []
    for row in angles:
        qs = q.copy()
        qs[:, idx] = row
        fields.append(evaluate_field(machine, qs, 1.0))
    peak = max(float(np.linalg.norm(f.error[:, :3], axis=1).max()) for f in fields) * UM_PER_M
    if scale is None:
        extent = float(np.ptp(fields[0].positions, axis=0).max()) if len(q) > 1 else 1.0
        scale = nice_scale(peak, extent)
    for step, (row, f) in enumerate(zip(angles, fields)):
        rec.set_time("sweep", sequence=step)
        shown = base.copy()
        shown[idx] = row
        log_field(rec, machine, FieldData(f.q, f.positions, f.error, scale), prefix=prefix,
                  static=False, legend=step == 0, colour_max=peak)
        log_joint_transforms(rec, machine, shown, static=False, axes=axes)
        state = ", ".join(f"{a} = {np.degrees(v):.1f} deg" for a, v in zip(axes, row))
        rec.log(f"{prefix}/sweep_state", rr.TextLog(state))
    rec.reset_time()
    return scale


def record_diagnosis(diagnosis, path: str | Path, scale: float | None = None, package_dirs=None) -> dict:
    """The residual field at each step of a diagnosis (``step`` timeline) and, for each
    accepted effect, the residual against its driver before and after (2D view).

    Parameters
    ----------
    diagnosis : volerr_pin.fit.diagnosis.Diagnosis
        The diagnosis.
    path : str or Path
        The ``.rrd`` file, written through a temporary file renamed over it once complete.
    scale : float, optional
        Arrow magnification (default: a round factor).
    package_dirs : path or iterable of path, optional
        Folders of ``package://`` meshes, besides the machine's own (see :func:`log_machine`).

    Returns
    -------
    dict
        ``path``, ``steps``, ``scale``, ``bytes``.

    Raises
    ------
    InputError
        If ``path`` cannot be written.
    """
    from ..fit.diagnosis import drift_series, evidence

    check_outputs({"path": path})
    machine = diagnosis.machine
    obs = diagnosis.observations
    _, positions = machine.tool_poses(obs.q, nominal=True)
    per_step = []
    for step in diagnosis.steps:
        vec = np.zeros((obs.n_points, 3))
        for k in range(3):
            rows = (obs.w[:, k] > 0.5) & ~obs.angular
            vec[obs.point[rows], k] = step.residual[rows]
        per_step.append(vec)
    peak = max(float(np.linalg.norm(v, axis=1).max()) for v in per_step) * UM_PER_M
    extent = float(np.ptp(positions, axis=0).max()) if len(positions) > 1 else 0.1
    scale = scale or nice_scale(peak, extent)
    radius = max(extent / 300.0, 1e-4)
    rec = new_recording("volerr_pin_diagnose")
    blueprint = rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="/", contents=["machine/**", "residuals/**"], name="residual field"),
            rrb.Vertical(rrb.Spatial2DView(origin="evidence", name="residual vs driver (um)"),
                         rrb.TimeSeriesView(origin="thermal", name="thermal drift: measured and model (um)"),
                         rrb.TextLogView(origin="steps", name="steps")),
            column_shares=[3, 2]),
        rrb.TimePanel(state="expanded"))
    frame = rr.CoordinateFrame(machine.workpiece_frame)
    with streaming(rec, path, blueprint):
        log_machine(rec, machine, default_config(machine), package_dirs=package_dirs)
        for number, (step, vec) in enumerate(zip(diagnosis.steps, per_step)):
            rec.set_time("step", sequence=number)
            norm = np.linalg.norm(vec, axis=1) * UM_PER_M
            rec.log("residuals/points", frame, rr.Points3D(positions, colors=colours(norm, 0.0, peak),
                                                           radii=radius), rr.AnyValues(residual_um=norm))
            rec.log("residuals/arrows", frame, rr.Arrows3D(origins=positions, vectors=vec * scale,
                                                            colors=colours(norm, 0.0, peak), radii=radius / 2))
            text = (f"step {number}: held-out RMS {step.rms_holdout_um:.3f} um; "
                    + (f"added {'; '.join(a.label for a in step.accepted_all)}" if step.accepted
                       else "no candidate is significant"))
            rec.log("steps", rr.TextLog(text))
            if step.accepted is not None:
                ev = evidence(diagnosis, number)
                if ev is not None:
                    span = float(np.ptp(ev.x)) or 1.0
                    x = (ev.x - ev.x.min()) / span * 100.0
                    rec.log("evidence/before", rr.Points2D(np.c_[x, -ev.before_um * 10], radii=0.6,
                                                            colors=[200, 60, 50]))
                    rec.log("evidence/after", rr.Points2D(np.c_[x, -ev.after_um * 10], radii=0.6,
                                                           colors=[40, 110, 190]))
                    rec.log("evidence/label", rr.TextLog(
                        f"{ev.label}: residual d{ev.direction} (red before, blue after, x10 um) vs "
                        f"{ev.x_label} (0-100 % of its range)"))
        rec.reset_time()
        for k, series in enumerate(drift_series(diagnosis)):  # on the `time` timeline [s]
            t = series.t_h * 3600.0
            keep = np.r_[True, np.diff(t) > 0]  # one value per instant
            log_time_series(rec, t[keep], {"measured_um": series.measured_um[keep],
                                           "model_um": series.model_um[keep],
                                           **{f"share_{n}_um": v[keep] for n, v in series.contributions_um.items()},
                                           **{f"T_{n}_degC": v[keep] for n, v in series.temperatures.items()}},
                            prefix=f"thermal/d{series.direction}")
            rec.log(f"thermal/d{series.direction}/about", rr.TextDocument(series.label), static=True)
        rec.log("residuals/about", rr.TextDocument(
            f"Residual (measured minus model) at each step of the diagnosis, arrows x{scale:g}; "
            "the `step` timeline walks through the accepted effects.", media_type=rr.MediaType.MARKDOWN),
            static=True)
    return {"path": str(path), "steps": len(diagnosis.steps), "scale": scale,
            "bytes": Path(path).stat().st_size}


def record_gear(rows, path: str | Path, scale: float | None = None) -> dict:
    """The generated gear flanks, one error source per step of the ``source`` timeline.

    ``rows`` are :class:`volerr_pin.applications.gear.SourceDeviations` (a source alone, or all together):
    each step shows every evaluated flank point in the workpiece frame coloured by its normal
    deviation (red: more material, blue: less; one colour scale over all steps, in
    ``normal_deviation_um``) and arrows along the normals of length deviation x ``scale``.

    Parameters
    ----------
    rows : sequence of volerr_pin.applications.gear.SourceDeviations
        The sources, in the order of the steps.
    path : str or Path
        The ``.rrd`` file, written through a temporary file renamed over it once complete.
    scale : float, optional
        Arrow magnification (default: a round factor).

    Returns
    -------
    dict
        ``path``, ``sources``, ``points``, ``scale``.

    Raises
    ------
    InputError
        If ``rows`` is empty or ``path`` cannot be written.
    """
    if not rows:
        raise InputError("record_gear needs at least one source", parameters=("rows",))
    check_outputs({"path": path})
    first = rows[0].deviations
    points = first.points.reshape(-1, 3)
    normals = first.normals.reshape(-1, 3)
    peak = max(float(np.abs(r.deviations.normal).max()) for r in rows) * UM_PER_M or 1.0
    extent = float(np.ptp(points, axis=0).max())
    scale = scale or nice_scale(peak, extent)
    radius = max(extent / 600.0, 2e-5)
    rec = new_recording("volerr_pin_gear")
    blueprint = rrb.Blueprint(
        rrb.Horizontal(rrb.Spatial3DView(origin="/", contents=["gear/**"], name="flanks"),
                       rrb.TextLogView(origin="sources", name="sources"), column_shares=[3, 1]),
        rrb.TimePanel(state="expanded"))
    with streaming(rec, path, blueprint):
        for number, row in enumerate(rows):
            rec.set_time("source", sequence=number)
            dn = row.deviations.normal.reshape(-1)
            colors = colours(dn * UM_PER_M, -peak, peak, "RdBu_r")
            rec.log("gear/flanks", rr.Points3D(points, colors=colors, radii=radius),
                    rr.AnyValues(normal_deviation_um=dn * UM_PER_M))
            rec.log("gear/deviation", rr.Arrows3D(origins=points, vectors=normals * (dn * scale)[:, None],
                                                  colors=colors, radii=radius / 2))
            right = row.deviations.values["right"]
            rec.log("sources", rr.TextLog(
                f"{row.source} ({row.label}, {row.value}): profile {right['profile'] * UM_PER_M:.3f} um, "
                f"helix {right['helix'] * UM_PER_M:.3f} um, pitch {right['pitch'] * UM_PER_M:.3f} um (right flank); "
                f"arrows x{scale:g}"))
    return {"path": str(path), "sources": len(rows), "points": int(points.shape[0]), "scale": scale}
