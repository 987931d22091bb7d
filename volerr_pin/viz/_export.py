"""Pictures of a controller export: the error before and after the controller applies its
tables (:class:`volerr_pin.compensation.export.ExportResult`).

- :func:`export_png`: the distribution of the tool-point error over the zone (uncompensated,
  naive tables, the written tables as the controller applies them, exact compensation) and
  maps of the error before and after over the first two axes.
- :func:`record_export`: a Rerun recording of the evaluation points in the workpiece frame,
  one 3D view per case on the machine, with the error vectors magnified by a stated factor and
  coloured on one scale with its key, and the summary as text.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ..compensation.export import ExportResult
from ..base import UM_PER_M, check_outputs
from ..model import default_config, nice_scale, to_engineering
from ._plots import plt, save
from ._recording import colours, eye_on, log_legend, log_machine, new_recording, opened_paused, streaming

__all__ = ["export_png", "record_export"]

STAGES = (("uncompensated", "before"), ("naive tables", "naive_after"), ("written tables", "after"),
          ("exact compensation", "exact_after"))
COLOURS = {"uncompensated": "#999999", "naive tables": "#e08a1e", "written tables": "#1f6fb2",
           "exact compensation": "#2c9c4a"}


def _norms(result: ExportResult) -> dict[str, np.ndarray]:
    return {label: np.linalg.norm(getattr(result, field), axis=1) * UM_PER_M for label, field in STAGES}


def export_png(result: ExportResult, path: str | Path) -> dict:
    """One page: the error distribution per case and maps before / after.

    Parameters
    ----------
    result : ExportResult
        The export.
    path : str or Path
        The picture (format from the suffix), written through a temporary file.

    Returns
    -------
    dict
        ``path``.
    """
    norms = _norms(result)
    machine = result.machine
    q = to_engineering(machine, result.points.q)
    fig, axes = plt.subplots(1, 3, figsize=(14.0, 4.4), dpi=120, constrained_layout=True)
    ax = axes[0]
    floor = 1e-3                                   # um: below it, "exact"
    for label, values in norms.items():
        ordered = np.sort(np.maximum(values, floor))
        ax.plot(ordered, np.linspace(0, 1, len(ordered)), color=COLOURS[label],
                label=f"{label}: max {values.max():.3g}, RMS {np.sqrt(np.mean(values ** 2)):.3g} um")
    ax.set_xscale("log")
    ax.set_xlabel("tool-point position error [um] (below 0.001 drawn at 0.001)")
    ax.set_ylabel("share of points")
    ax.grid(alpha=0.3, which="both")
    # below the axes: the curves fill the upper part of the plot, where a legend inside would cover them
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=1, frameon=False)
    ax.set_title(f"{len(q)} points over the zone", fontsize=10)
    units = ["mm" if k == "linear" else "deg" for k in machine.axis_kinds]
    top = max(float(norms["uncompensated"].max()), 1e-9)            # one colour scale for both maps
    for panel, (label, title) in zip(axes[1:], (("uncompensated", "before"), ("written tables", "after"))):
        values = norms[label]
        image = panel.scatter(q[:, 0], q[:, 1] if q.shape[1] > 1 else np.zeros(len(q)), c=values, s=6,
                              cmap="viridis", vmin=0.0, vmax=top)
        panel.set_xlabel(f"{machine.axes[0]} [{units[0]}]")
        if q.shape[1] > 1:
            panel.set_ylabel(f"{machine.axes[1]} [{units[1]}]")
        flat = (f", all {machine.axes[2]} seen from above" if q.shape[1] > 2 else "")
        panel.set_title(f"{title}: |error| (max {values.max():.3g} um){flat}", fontsize=10)
        fig.colorbar(image, ax=panel, label="um")
    fig.suptitle(f"{machine.name}: {result.controller.title}, {result.kind} tables", fontsize=11)
    save(fig, path)
    return {"path": str(path)}


def record_export(result: ExportResult, path: str | Path, scale: float | None = None) -> dict:
    """The error vectors at the evaluation points before and after, one 3D view per stage.

    The recording opens on four views side by side (uncompensated, naive tables, the written
    tables as the controller applies them, exact compensation), each named with its largest and
    RMS error, on the machine and with one colour key: every stage is static data, so no time
    cursor decides what shows.

    Parameters
    ----------
    result : ExportResult
        The export.
    path : str or Path
        The ``.rrd`` file, written through a temporary file renamed over it once complete.
    scale : float, optional
        Arrow magnification (default: a round factor for the uncompensated error).

    Returns
    -------
    dict
        ``path``, ``points``, ``scale``, ``stages``.
    """
    check_outputs({"path": path})
    machine = result.machine
    from ..compensation.export import tool_tips

    where = tool_tips(machine, result.points.q, result.points, nominal=True)
    norms = _norms(result)
    peak = float(norms["uncompensated"].max()) or 1.0
    extent = float(np.ptp(where, axis=0).max()) or 1.0
    scale = scale or nice_scale(peak, extent)
    radius = max(extent / 400.0, 2e-4)
    base = default_config(machine)
    eye = eye_on(machine, base, where)
    s = result.summaries
    keys = dict(zip((label for label, _ in STAGES), ("uncompensated", "naive", "residual", "exact")))
    entity = {label: f"export/{k}_{label.replace(' ', '_')}" for k, (label, _) in enumerate(STAGES, start=1)}
    views = [rrb.Spatial3DView(origin="/", contents=["machine/**", f"{entity[label]}/**", "export/legend/**"],
                               name=f"{k}. {label}: max {s[keys[label]].max_um:.2f} um, RMS {s[keys[label]].rms_um:.2f} um",
                               eye_controls=eye)
             for k, (label, _) in enumerate(STAGES, start=1)]
    blueprint = rrb.Blueprint(
        rrb.Horizontal(rrb.Grid(*views, grid_columns=2), rrb.TextDocumentView(origin="summary", name="summary"),
                       column_shares=[4, 1]),
        opened_paused(), rrb.SelectionPanel(state="collapsed"), rrb.BlueprintPanel(state="collapsed"))
    lines = [f"# {machine.name}: {result.controller.title}", "", f"kind: {result.kind}; arrows x{scale:g}; colour: "
             f"|error| 0 .. {peak:.2f} um (viridis, one scale for every stage; the key beside the points)", "",
             "| stage | max um | RMS um |", "|---|--:|--:|"]
    for label, _ in STAGES:
        lines.append(f"| {label} | {s[keys[label]].max_um:.3f} | {s[keys[label]].rms_um:.3f} |")
    lines += ["", f"{len(where):,} evaluation points, in the workpiece frame; the machine at mid travel."]
    frame = rr.CoordinateFrame(machine.workpiece_frame)
    rec = new_recording("volerr_pin_export")
    with streaming(rec, path, blueprint):
        log_machine(rec, machine, base)
        rec.log("summary", rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN), static=True)
        log_legend(rec, "export/legend", frame, where, 0.0, peak)
        for label, field in STAGES:
            vectors = getattr(result, field)
            colors = colours(norms[label], 0.0, peak)
            rec.log(f"{entity[label]}/points", frame, rr.Points3D(where, colors=colors, radii=radius),
                    rr.AnyValues(error_um=norms[label]), static=True)
            rec.log(f"{entity[label]}/error", frame, rr.Arrows3D(origins=where, vectors=vectors * scale,
                                                                 colors=colors, radii=radius / 3), static=True)
    return {"path": str(path), "points": int(len(where)), "scale": scale, "stages": [label for label, _ in STAGES]}
