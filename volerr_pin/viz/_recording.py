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
is only ever given a copy of the URDF whose meshes passed :func:`volerr_pin.model.checked_meshes`:
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

from ..base import UM_PER_M, InputError, check_outputs, replacing, require_memory
from ..model import (FieldData, Machine, checked_meshes, complete_limits, default_config, evaluate_field, field_grid,
                     nice_scale, package_folders, to_engineering, tool_poses)

#: memory a field point takes while it is evaluated and logged, and per sweep step held [bytes]
#: (measured: about 0.6 kB per point and step for a 5-axis machine; doubled for headroom)
FIELD_POINT_BYTES = 1200


def new_recording(app_id: str = "volerr_pin", recording_id: str | None = None) -> rr.RecordingStream:
    """A fresh recording stream (not global).

    Parameters
    ----------
    app_id : str, default "volerr_pin"
        The application id the viewer groups recordings by.
    recording_id : str, optional
        The recording's id (default: a new one Rerun makes).

    Returns
    -------
    rerun.RecordingStream
        The stream; :func:`streaming` sends what it logs to a file or a viewer.
    """
    return rr.RecordingStream(app_id, recording_id=recording_id)


def default_blueprint(time_series: bool = False, sweep: bool = False, eye: rrb.EyeControls3D | None = None,
                      sweep_timeline: str = "sweep") -> rrb.Blueprint:
    """3D view of machine and field, beside the ranking (and the time series, if any).

    The per-component fields (``field/components``) are left out of the 3D view (three colour
    schemes on the same dots); the blueprint panel adds them back. The recording opens paused,
    with ``eye`` as the 3D camera when given."""
    side = [rrb.Spatial2DView(origin="sensitivity/bars", name="error sources at the tool (named bars)"),
            rrb.TextDocumentView(origin="sensitivity/table", name="ranking")]
    if time_series:
        side.append(rrb.TimeSeriesView(origin="thermal", name="time-dependent errors", **whole_range("time")))
    if sweep:
        side.append(rrb.TextDocumentView(origin="field/sweep_angles", name="sweep: step and angles"))
    shares = [3, 2] + [2] * (len(side) - 2)   # the named bars need the height
    main = rrb.Spatial3DView(origin="/", contents=["+ machine/**", "+ field/**", "- field/components/**",
                                                   "- field/about"],
                             name="machine and error field", eye_controls=eye)
    return rrb.Blueprint(
        rrb.Horizontal(main, rrb.Vertical(*side, row_shares=shares), column_shares=[3, 2]),
        opened_paused(timeline=sweep_timeline if sweep else ("time" if time_series else None),
                      state="expanded" if (time_series or sweep) else "collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )


def log_machine(rec: rr.RecordingStream, machine: Machine, q: np.ndarray,
                prefix: str = "machine", moving: tuple[str, ...] = (), package_dirs=None) -> None:
    """The nominal URDF (static) and the axis-joint transforms at NC positions ``q`` (SI),
    static except for the axes named in ``moving`` (those are logged on the active timeline
    by :func:`log_joint_transforms`).

    Meshes are read only as :func:`volerr_pin.model.checked_meshes` allows, from the machine's
    :attr:`~volerr_pin.model.Machine.package_dirs` and ``package_dirs``; a visual whose mesh
    is refused is left out with a warning naming the URDF, its line and the mesh.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording to log to.
    machine : Machine
        The machine.
    q : ndarray, shape (n_axes,)
        NC positions to show it at [m, rad].
    prefix : str, default "machine"
        The entity path under which the URDF and ``transforms`` are logged.
    moving : tuple of str, default ()
        Axes whose transforms are left to the caller to log on a timeline.
    package_dirs : path or iterable of path, optional
        Folders of ``package://`` meshes, besides the machine's own.
    """
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
    (:func:`volerr_pin.model.checked_meshes`; refused ones dropped with a warning), or no visuals
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


def _workpiece_placement(machine: Machine, q: np.ndarray):
    """Pinocchio's data of the nominal machine (every error joint at zero: no state needed) at NC
    positions ``q`` (SI), and the workpiece frame's placement in the root."""
    import pinocchio as pin

    from ..model import check_q, pinocchio_configuration

    model = machine.model.pinocchio
    data = model.createData()
    configuration = pinocchio_configuration(machine.model, check_q(machine.model, q, extrapolate=True))[0]
    pin.framesForwardKinematics(model, data, configuration)
    return data, data.oMf[model.getFrameId(machine.workpiece_frame)]


def eye_on(machine: Machine, q: np.ndarray, positions: np.ndarray, distance: float = 1.6,
           elevation: float = 30.0) -> rrb.EyeControls3D:
    """A 3D view's camera that frames ``positions`` (workpiece frame) from outside the machine.

    It looks at their box's centre from ``distance`` times the box's diagonal, z up: horizontally
    from the mean of the machine's joint origins towards the points (the side the work zone
    opens to, away from the bulk of the machine), turned 30 degrees for a three-quarter view,
    and ``elevation`` degrees above; a machine whose joints gather on the points is seen from -y.

    Parameters
    ----------
    machine : Machine
        The machine.
    q : ndarray, shape (n_axes,)
        NC positions it is shown at [m, rad] (they place the workpiece frame in the world).
    positions : ndarray, shape (N, 3)
        The points to frame, in the workpiece frame [m].
    distance : float, default 1.6
        The eye's distance from the centre, in diagonals of the points' box (a diagonal counts
        as at least 5 cm).
    elevation : float, default 30
        The eye's height above the horizontal [deg].

    Returns
    -------
    rerun.blueprint.EyeControls3D
        An orbital camera looking at the centre, z up.
    """
    data, placement = _workpiece_placement(machine, q)
    points = np.asarray(positions, float).reshape(-1, 3) @ placement.rotation.T + placement.translation
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = (lo + hi) / 2.0
    diagonal = max(float(np.linalg.norm(hi - lo)), 0.05)
    body = np.mean([m.translation for m in data.oMi[1:]] or [centre], axis=0)
    away = (centre - body)[:2]
    if np.linalg.norm(away) < 0.05 * diagonal:
        away = np.array([0.0, -1.0])
    away = away / np.linalg.norm(away)
    turn = np.radians(30.0)
    away = np.array([away[0] * np.cos(turn) - away[1] * np.sin(turn), away[0] * np.sin(turn) + away[1] * np.cos(turn)])
    direction = np.r_[away * np.cos(np.radians(elevation)), np.sin(np.radians(elevation))]
    return rrb.EyeControls3D(kind="Orbital", position=centre + direction * distance * diagonal,
                             look_target=centre, eye_up=[0.0, 0.0, 1.0])


def log_legend(rec: rr.RecordingStream, entity: str, frame, positions: np.ndarray, lo: float, hi: float,
               cmap: str = "viridis", unit: str = "um", title: str = "|error|", static: bool = True) -> None:
    """A colour key beside ``positions`` (the field's points, in ``frame``, or None for the
    entity's own space): a column of
    coloured dots from ``lo`` to ``hi`` on ``entity``, and its dark labels on ``entity/labels``
    (a label takes its point's colour, and yellow text is unreadable on the viewer's light grey)."""
    lo_corner, hi_corner = positions.min(axis=0), positions.max(axis=0)
    extent = max(float(np.ptp(positions, axis=0).max()) if len(positions) > 1 else 0.1, 0.05)
    radius = max(extent / 300.0, 1e-4)
    levels = np.linspace(lo, hi, 11)
    where = np.c_[np.full(11, hi_corner[0] + 0.15 * extent), np.full(11, lo_corner[1]),
                  np.linspace(lo_corner[2], lo_corner[2] + 0.6 * extent, 11)]
    placed = () if frame is None else (frame,)   # None: in the entity's own space
    rec.log(entity, *placed, rr.Points3D(where, colors=colours(levels, lo, hi, cmap), radii=radius * 4), static=static)
    ends = [0, 5, 10]
    labels = [f"{title} {levels[k]:.2f} {unit}" if k == 10 else f"{levels[k]:.2f} {unit}" for k in ends]
    rec.log(f"{entity}/labels", *placed, rr.Points3D(where[ends] + [0.06 * extent, 0.0, 0.0], radii=radius / 4,
                                                   colors=[40, 40, 40], labels=labels, show_labels=True),
            static=static)


def figure_image(fig) -> rr.EncodedImage:
    """A matplotlib figure as an image for a 2D view (PNG in memory; the figure is closed): for
    plots Rerun has no view of its own for, such as bars with names."""
    import io

    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    try:
        fig.savefig(buffer, format="png")
    finally:
        plt.close(fig)
    return rr.EncodedImage(contents=buffer.getvalue(), media_type="image/png")


def opened_paused(timeline: str | None = None, state: str = "collapsed") -> rrb.TimePanel:
    """The time panel of a recording that opens still: paused (the viewer would play a
    timeline from its start at 1x), on ``timeline`` if given.

    Parameters
    ----------
    timeline : str, optional
        The timeline the panel shows (default: the viewer's choice).
    state : str, default "collapsed"
        The panel's state, as Rerun names it ("collapsed", "expanded", "hidden").

    Returns
    -------
    rerun.blueprint.TimePanel
        The panel, paused.
    """
    return rrb.TimePanel(state=state, timeline=timeline, play_state="paused")


def whole_range(timeline: str) -> dict:
    """A time series view's arguments that show ``timeline`` end to end, wherever the time
    cursor is (by default it shows 30 s either side of the cursor): its data's range and its
    x axis' range. ``rrb.TimeSeriesView(..., **whole_range("time"))``.

    Parameters
    ----------
    timeline : str
        The timeline's name.

    Returns
    -------
    dict
        ``time_ranges`` and ``axis_x``, both unbounded.
    """
    everything = rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
    return {"time_ranges": rrb.VisibleTimeRange(timeline, range=everything),
            "axis_x": rrb.TimeAxis(view_range=everything)}


def log_field(rec: rr.RecordingStream, machine: Machine, field: FieldData, prefix: str = "field",
              static: bool = True, legend: bool = True, colour_max: float | None = None) -> None:
    """Points coloured by |error| (0 .. ``colour_max`` um, default the field's maximum), arrows
    magnified ``field.scale`` times, per-component fields, the numbers attached to every
    point, a colour legend and an explanation.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording to log to.
    machine : Machine
        The machine the field is of (its name and workpiece frame).
    field : FieldData
        The field (:func:`~volerr_pin.model.evaluate_field`): points, errors and the arrows' scale.
    prefix : str, default "field"
        The entity path it is logged under.
    static : bool, default True
        Log it as static data (False: on the active timeline, as a sweep's steps are).
    legend : bool, default True
        Also log the colour legend and the explanation (``legend``, ``about``).
    colour_max : float, optional
        The |error| [um] at the top of the colour scale (default: the field's largest).
    """
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
    if legend and not norm.any():   # said on screen, where the user looks: a uniform field explains nothing
        centre = (field.positions.min(axis=0) + field.positions.max(axis=0)) / 2.0 if len(norm) else np.zeros(3)
        rec.log(f"{prefix}/nothing", frame, rr.Points3D(centre[None, :], radii=radius / 4, colors=[40, 40, 40],
                                                        labels=[f"{machine.name}: every error is zero here "
                                                                "(no error terms with values)"], show_labels=True),
                static=static)
    if legend:
        log_legend(rec, f"{prefix}/legend", frame, field.positions, 0.0, hi,
                   title="|error|" if colour_max is None else "|error| (peak of all steps)", static=static)
        rec.log(f"{prefix}/about", rr.TextDocument(
            f"# Volumetric error field of {machine.name}\n\n"
            f"{len(field.q)} points; colour: |error| from 0 to {hi:.2f} um (viridis; legend beside the "
            f"field); arrows: error vectors magnified **{field.scale:g} times**; "
            f"`components/dx|dy|dz` (left out of the 3D view; the blueprint panel adds them): signed "
            f"components, blue -{bound:.2f} .. red +{bound:.2f} um. "
            "Select a point to read dx_um, dy_um, dz_um and norm_um.\n\n"
            "Error = actual minus nominal tool point relative to the workpiece, in the workpiece "
            "frame.", media_type=rr.MediaType.MARKDOWN), static=True)


def log_ranking(rec: rr.RecordingStream, ranking: dict, prefix: str = "sensitivity") -> None:
    """The ranking (from :func:`volerr_pin.fit.rank`.to_dict()) as bars with names (a
    picture on ``bars``: Rerun's bar charts take no names), a table, and the values as a bar
    chart (``ranking``) for other views."""
    from ._plots import ranking_figure

    rows = ranking["ranking"]
    rec.log(f"{prefix}/ranking", rr.BarChart(np.array([r["rms_um"] for r in rows]),
                                             color=[64, 110, 180]), static=True)
    rec.log(f"{prefix}/bars", figure_image(ranking_figure(ranking, top=min(len(rows), 15), size=(7.0, 6.0))),
            static=True)
    lines = ["| # | term | axis | RMS um | max um | share of all terms |", "|---|---|---|---|---|---|"]
    lines += [f"| {i} | {r['parameter']} | {r['axis']} | {r['rms_um']:.3f} | {r['max_um']:.3f} | "
              f"{100 * r.get('share_of_all', r['share']):.1f} % |" for i, r in enumerate(rows)]
    rec.log(f"{prefix}/table", rr.TextDocument(
        f"RMS and largest tool-point error per term over {ranking['points']} points:\n\n" + "\n".join(lines),
        media_type=rr.MediaType.MARKDOWN),
        static=True)


#: colours of the series of one time series view, in order (matplotlib's tab10: told apart at a glance)
SERIES_COLOURS = [[31, 119, 180], [214, 39, 40], [44, 160, 44], [255, 127, 14], [148, 103, 189], [140, 86, 75],
                  [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207]]


def log_time_series(rec: rr.RecordingStream, t: np.ndarray, series: dict[str, np.ndarray],
                    prefix: str = "thermal", timeline: str = "time") -> None:
    """Bulk time series: one ``send_columns`` call per series on the ``time`` timeline [s], each
    named and in its own colour (:data:`SERIES_COLOURS`, in the order given).

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording to log to.
    t : ndarray, shape (N,)
        Times [s].
    series : dict of str to ndarray, shape (N,)
        The series by name, each logged on ``<prefix>/<name>``.
    prefix : str, default "thermal"
        The entity path they are logged under.
    timeline : str, default "time"
        The timeline they are logged on.

    Raises
    ------
    InputError
        If a series' shape differs from ``t``'s.
    """
    t = np.asarray(t, dtype=float)
    for k, (name, values) in enumerate(series.items()):
        values = np.asarray(values, dtype=float)
        if values.shape != t.shape:
            raise InputError(f"series '{name}' has shape {values.shape}; time has {t.shape}")
        rec.log(f"{prefix}/{name}", rr.SeriesLines(colors=SERIES_COLOURS[k % len(SERIES_COLOURS)], names=name),
                static=True)
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
        Points per linear axis (see :func:`volerr_pin.model.field_grid`).
    config : dict of str to float, optional
        Positions of the axes that do not span the field [m, rad].
    scale : float, optional
        Arrow magnification (default: a round factor, see :func:`volerr_pin.model.nice_scale`).
    ranking : dict, optional
        A ranking (:meth:`volerr_pin.fit._ranking.Ranking.to_dict`) to show beside the field.
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
    eye = eye_on(machine, base, tool_poses(machine.model, q, nominal=True)[1])   # the grid is within the travel
    blueprint = default_blueprint(sweep=bool(sweeping), eye=eye)
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
    """How many points :func:`~volerr_pin.model.field_grid` will make, without making them;
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
    rec.reset_time()
    lines = [f"The `sweep` timeline turns {', '.join(axes)} through {'their' if len(axes) > 1 else 'its'} travel "
             f"in {steps} steps; the colour key's top is the peak over all steps, {peak:.2f} um.", "",
             "| step | " + " | ".join(f"{a} deg" for a in axes) + " | max um |",
             "|--:|" + "--:|" * len(axes) + "--:|"]
    for step, (row, f) in enumerate(zip(angles, fields)):
        top = float(np.linalg.norm(f.error[:, :3], axis=1).max()) * UM_PER_M
        lines.append(f"| {step} | " + " | ".join(f"{np.degrees(v):.1f}" for v in row) + f" | {top:.2f} |")
    rec.log(f"{prefix}/sweep_angles", rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN),
            static=True)
    return scale


def record_diagnosis(diagnosis, path: str | Path, scale: float | None = None, package_dirs=None) -> dict:
    """The residual field at each step of a diagnosis, the diagnosis at a glance, its drift over
    time and its steps.

    It opens, paused, on two 3D views: the residual of the model as given and after the last
    step (static data, named with the held-out RMS; every step's residual is recorded on
    ``residuals/step_<k>``), the picture
    of :func:`volerr_pin.viz.diagnosis_png` (held-out RMS per step against the noise floor,
    each effect's residual against its driver before and after, with axes and labels), the
    drift's measured and model values over the whole ``time`` timeline when a drift was found,
    and the steps as a table.

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
    from ..fit.diagnosis import drift_series
    from ._plots import diagnosis_figure

    check_outputs({"path": path})
    machine = diagnosis.machine
    obs = diagnosis.observations
    _, positions = tool_poses(machine.model, obs.q, nominal=True)   # the measurements' positions, checked as read
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
    radius = max(extent / 150.0, 1e-4)
    base = default_config(machine)
    eye = eye_on(machine, base, positions)
    drifts = drift_series(diagnosis)

    def title(number, step):
        added = "; ".join(a.label for a in step.accepted_all) if step.accepted else ""
        what = "the model as given" if number == 0 else f"after step {number}"
        return f"{number}. residual, {what}: held-out RMS {step.rms_holdout_um:.2f} um" + (
            f" (next: {added})" if added and len(added) < 60 else "")

    shown = sorted({0, len(diagnosis.steps) - 1})   # before and after; every step is in residuals/step_<k>
    views = [rrb.Spatial3DView(origin="/", contents=["machine/**", f"residuals/step_{k}/**", "residuals/legend/**"],
                               name=title(k, diagnosis.steps[k]), eye_controls=eye) for k in shown]
    side = [rrb.Spatial2DView(origin="summary/picture", name="the diagnosis at a glance")]
    if drifts:
        side.append(rrb.TimeSeriesView(origin="thermal", name="drift over time: measured and model (um)",
                                       **whole_range("time")))
    side.append(rrb.TextDocumentView(origin="summary/steps", name="steps"))
    blueprint = rrb.Blueprint(
        rrb.Horizontal(rrb.Vertical(*views),
                       rrb.Vertical(*side, row_shares=[3] + [2] * (len(side) - 1)), column_shares=[3, 2]),
        opened_paused(timeline="time" if drifts else None), rrb.SelectionPanel(state="collapsed"),
        rrb.BlueprintPanel(state="collapsed"))
    frame = rr.CoordinateFrame(machine.workpiece_frame)
    rec = new_recording("volerr_pin_diagnose")
    with streaming(rec, path, blueprint):
        log_machine(rec, machine, base, package_dirs=package_dirs)
        log_legend(rec, "residuals/legend", frame, positions, 0.0, peak, title="|residual|")
        for number, vec in enumerate(per_step):
            norm = np.linalg.norm(vec, axis=1) * UM_PER_M
            rec.log(f"residuals/step_{number}/points", frame,
                    rr.Points3D(positions, colors=colours(norm, 0.0, peak), radii=radius),
                    rr.AnyValues(residual_um=norm), static=True)
            rec.log(f"residuals/step_{number}/arrows", frame,
                    rr.Arrows3D(origins=positions, vectors=vec * scale, colors=colours(norm, 0.0, peak),
                                radii=radius / 2), static=True)
        rec.log("summary/picture", figure_image(diagnosis_figure(diagnosis)), static=True)
        lines = [f"Residual = measured minus model, arrows x{scale:g}, colour 0 .. {peak:.2f} um (one scale for "
                 "every step; the key beside the points). The views show the first and the last step; every "
                 "step's residual is `residuals/step_<k>` (drag it into a view from the streams).", "",
                 "| step | held-out RMS um | added next |", "|--:|--:|---|"]
        for number, step in enumerate(diagnosis.steps):
            added = "; ".join(a.label for a in step.accepted_all) if step.accepted else "nothing significant"
            lines.append(f"| {number} | {step.rms_holdout_um:.3f} | {added} |")
        rec.log("summary/steps", rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN), static=True)
        for series in drifts:  # on the `time` timeline [s]
            t = series.t_h * 3600.0
            keep = np.r_[True, np.diff(t) > 0]  # one value per instant
            log_time_series(rec, t[keep], {"measured_um": series.measured_um[keep],
                                           "model_um": series.model_um[keep],
                                           **{f"share_{n}_um": v[keep] for n, v in series.contributions_um.items()}},
                            prefix=f"thermal/d{series.direction}")
            log_time_series(rec, t[keep], {f"T_{n}_degC": v[keep] for n, v in series.temperatures.items()},
                            prefix=f"temperatures/d{series.direction}")
            rec.log(f"thermal/d{series.direction}/about", rr.TextDocument(series.label), static=True)
    return {"path": str(path), "steps": len(diagnosis.steps), "scale": scale,
            "bytes": Path(path).stat().st_size}


def record_gear(rows, path: str | Path, scale: float | None = None) -> dict:
    """The generated gear flanks, one error source per step of the ``source`` timeline.

    ``rows`` are :class:`volerr_pin.applications.gear.SourceDeviations` (a source alone, or all together):
    each step shows every evaluated flank point in the workpiece frame coloured by its normal
    deviation (red: more material, blue: less; one colour scale over all steps, with its key, in
    ``normal_deviation_um``) and arrows along the normals of length deviation x ``scale``. The
    row of all sources together, when there is one, is step 0, where the recording opens
    (paused); a table names every step's source and its deviations. The points' positions are
    logged once: each step carries only its colours and arrow lengths.

    Parameters
    ----------
    rows : sequence of volerr_pin.applications.gear.SourceDeviations
        The sources, in the order of the steps (the row of all sources goes first).
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
    rows = sorted(rows, key=lambda r: r.source != "all")   # stable: all sources first, then as given
    first = rows[0].deviations
    points = first.points.reshape(-1, 3)
    normals = first.normals.reshape(-1, 3)
    peak = max(float(np.abs(r.deviations.normal).max()) for r in rows) * UM_PER_M or 1.0
    extent = float(np.ptp(points, axis=0).max())
    scale = scale or nice_scale(peak, extent)
    radius = max(extent / 600.0, 2e-5)
    centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
    diagonal = max(float(np.linalg.norm(np.ptp(points, axis=0))), 1e-3)
    above = np.array([0.5, -0.7, 0.9]) / np.linalg.norm([0.5, -0.7, 0.9])   # the gear's axis is z: from above, aside
    eye = rrb.EyeControls3D(kind="Orbital", position=centre + above * 1.4 * diagonal, look_target=centre,
                            eye_up=[0.0, 0.0, 1.0])
    blueprint = rrb.Blueprint(
        rrb.Horizontal(rrb.Spatial3DView(origin="/", contents=["gear/**"], name="flanks: normal deviation at the "
                                         "time cursor's source (red: more material)", eye_controls=eye),
                       rrb.TextDocumentView(origin="sources", name="sources: step, deviations"), column_shares=[3, 2]),
        opened_paused(timeline="source", state="expanded"), rrb.SelectionPanel(state="collapsed"))
    lines = [f"Step of the `source` timeline, the error source (alone), and the right flank's deviations of the worst "
             f"tooth [um]; arrows x{scale:g}, colour -{peak:.2f} .. +{peak:.2f} um (one scale for every step).", "",
             "| step | source | value | profile | helix | pitch |", "|--:|---|---|--:|--:|--:|"]
    for number, row in enumerate(rows):
        right = row.deviations.values["right"]
        lines.append(f"| {number} | {row.source} ({row.label}) | {row.value} | {right['profile'] * UM_PER_M:.3f} | "
                     f"{right['helix'] * UM_PER_M:.3f} | {right['pitch'] * UM_PER_M:.3f} |")
    rec = new_recording("volerr_pin_gear")
    with streaming(rec, path, blueprint):
        rec.log("gear/flanks", rr.Points3D(points, radii=radius), static=True)
        rec.log("gear/deviation", rr.Arrows3D(origins=points, vectors=np.zeros_like(points), radii=radius / 2),
                static=True)
        log_legend(rec, "gear/legend", None, points, -peak, peak, cmap="RdBu_r",
                   title="normal deviation")
        rec.log("sources", rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN), static=True)
        for number, row in enumerate(rows):
            rec.set_time("source", sequence=number)
            dn = row.deviations.normal.reshape(-1)
            colors = colours(dn * UM_PER_M, -peak, peak, "RdBu_r")
            rec.log("gear/flanks", rr.Points3D.from_fields(colors=colors),
                    rr.AnyValues(normal_deviation_um=dn * UM_PER_M, error_source=row.source))
            rec.log("gear/deviation", rr.Arrows3D.from_fields(vectors=normals * (dn * scale)[:, None], colors=colors))
    return {"path": str(path), "sources": len(rows), "points": int(points.shape[0]), "scale": scale}


def record_part(prediction, path: str | Path, factor: float | None = None) -> dict:
    """The predicted part in 3D: the programmed path, the cut (the path moved by its deviation
    normal to it, magnified ``factor`` times, coloured by its size, with a key) on the machine,
    each cone's sections where they are (their form about the least-squares circle magnified
    as much), and the features as a table.

    Parameters
    ----------
    prediction : volerr_pin.applications.part.PartPrediction
        The prediction.
    path : str or Path
        The ``.rrd`` file, written through a temporary file renamed over it once complete.
    factor : float, optional
        Magnification of the drawn deviation (default: a round factor, the largest about 8 % of
        the path's extent).

    Returns
    -------
    dict
        ``path``, ``samples``, ``factor``, ``bytes``.
    """
    from ..applications.part import blocks_text

    check_outputs({"path": path})
    machine = prediction.machine
    deviation = prediction.deviation
    size = np.linalg.norm(deviation.normal, axis=1) * UM_PER_M
    extent = float(np.ptp(deviation.point, axis=0).max()) if len(deviation.point) > 1 else 0.1
    factor = factor or nice_scale(float(size.max()) or 1.0, extent)
    base = default_config(machine)
    eye = eye_on(machine, base, deviation.point, distance=1.3, elevation=55.0)   # a flat part: from above
    frame = rr.CoordinateFrame(machine.workpiece_frame)
    runs = deviation.runs()
    programmed = [deviation.point[rows] for rows in runs]
    cut = [deviation.point[rows] + deviation.normal[rows] * factor for rows in runs]
    colours_of = colours(size[[rows[len(rows) // 2] for rows in runs]], 0.0, float(size.max()) or 1.0)
    lines = [f"# {machine.name}: {Path(prediction.source).name}", "",
             f"The cut: the programmed path (grey) moved by its deviation normal to the path, **x{factor:g}**, "
             f"coloured by its size 0 .. {size.max():.2f} um (key beside the path); largest {deviation.max_um:.3f} um.",
             "", "| feature | blocks | value um | first source |", "|---|---|--:|---|"]
    for feature, ranking in zip(prediction.features, prediction.rankings):
        row = feature.to_dict()
        value = row.get("circularity_um", row.get(f"{row['kind']}_um"))
        first = f"{ranking[0]['component']} {100 * ranking[0]['share']:.0f} %" if ranking else ""
        kind = row["kind"] if row["kind"] != "cone" else f"cone at {row['height_mm']:g} mm"
        lines.append(f"| {kind} | {blocks_text(row['blocks'])} | {value:.3f} | {first} |")
    blueprint = rrb.Blueprint(
        rrb.Horizontal(rrb.Spatial3DView(origin="/", contents=["machine/**", "part/**"],
                                         name=f"the cut, deviation x{factor:g}", eye_controls=eye),
                       rrb.TextDocumentView(origin="features", name="features (um)"), column_shares=[3, 2]),
        opened_paused(), rrb.SelectionPanel(state="collapsed"))
    rec = new_recording("volerr_pin_predict")
    with streaming(rec, path, blueprint):
        log_machine(rec, machine, base)
        rec.log("part/programmed", frame, rr.LineStrips3D(programmed, colors=[150, 150, 150], radii=extent / 2000),
                static=True)
        rec.log("part/cut", frame, rr.LineStrips3D(cut, colors=colours_of, radii=extent / 150), static=True)
        rec.log("part/samples", frame, rr.Points3D(deviation.point + deviation.normal * factor,
                                                   colors=colours(size, 0.0, float(size.max()) or 1.0),
                                                   radii=extent / 120),
                rr.AnyValues(deviation_um=size, line=deviation.line), static=True)
        log_legend(rec, "part/legend", frame, deviation.point, 0.0, float(size.max()) or 1.0,
                   title="normal deviation")
        for k, section in enumerate(prediction.cones):   # each cone's sections where they are, form magnified
            cone = section.cone
            order = np.argsort(section.angle)
            around = np.c_[np.cos(section.angle[order]), np.sin(section.angle[order])] @ cone.basis()
            level = cone.apex + (cone.bottom + section.height) * cone.axis
            ring = level + (section.radius + section.radial_um[order] / UM_PER_M * factor)[:, None] * around
            rec.log(f"part/cone/section_{k}", frame,
                    rr.LineStrips3D([np.vstack([ring, ring[:1]])], colors=SERIES_COLOURS[k % len(SERIES_COLOURS)],
                                    radii=extent / 400, labels=[f"{section.height * 1e3:g} mm"]), static=True)
        rec.log("features", rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN), static=True)
    return {"path": str(path), "samples": int(len(size)), "factor": factor, "bytes": Path(path).stat().st_size}
