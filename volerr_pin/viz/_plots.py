"""Static pictures for reports (matplotlib, no viewer needed): error-field slices and rankings."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..model import Machine  # noqa: E402
from ..model import default_config, evaluate_field  # noqa: E402
from ..model import sample, to_engineering  # noqa: E402
from ..base import InputError  # noqa: E402
from ..base import replacing  # noqa: E402
from ..base import UM_PER_M  # noqa: E402

AXES = "xyz"


def picture_format(path: str | Path, parameter: str = "path") -> str:
    """The picture format a file name asks for: its suffix (``.png``, ``.svg``, ``.pdf`` ...), PNG
    when it has none.

    Parameters
    ----------
    path : str or Path
        The picture file.
    parameter : str, optional
        The parameter that gave it, for the message.

    Returns
    -------
    str
        The format, e.g. ``"png"``.

    Raises
    ------
    InputError
        If matplotlib cannot write the suffix's format.
    """
    suffix = Path(path).suffix[1:].lower()
    if not suffix:
        return "png"
    formats = plt.figure().canvas.get_supported_filetypes()
    plt.close("all")
    if suffix not in formats:
        raise InputError(f"{parameter}: {path}: '.{suffix}' is not a picture format this product writes "
                         f"({', '.join('.' + f for f in sorted(formats))})", parameters=(parameter,))
    return suffix


def save(fig, path: str | Path) -> None:
    """Write ``fig`` to ``path`` through a temporary file beside it (the format from the suffix,
    :func:`picture_format`), and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; closed afterwards, written or not.
    path : str or Path
        The picture file; its suffix sets the format.

    Raises
    ------
    InputError
        If matplotlib cannot write the suffix's format.
    """
    try:
        fmt = picture_format(path)
        with replacing(path) as tmp:
            fig.savefig(tmp, format=fmt)
    finally:
        plt.close(fig)


def field_slice_png(machine: Machine, path: str | Path, config: dict[str, float] | None = None,
                    resolution: int = 25, plane: tuple[str, str] | None = None) -> dict:
    """Error field on a plane: two linear axes (``plane``, default the first two) on a
    ``resolution`` grid, the other axes at ``config`` (default mid travel); background |error|,
    arrows the in-plane error. Machines with fewer than two linear axes show a scatter of
    sampled tool points instead.

    Parameters
    ----------
    machine : Machine
        The machine, in the state to show.
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).
    config : dict of str to float, optional
        Axis name -> position [m, rad] of the axes off the plane (:func:`~volerr_pin.model.default_config`).
    resolution : int, default 25
        Grid points along each of the two axes.
    plane : tuple of (str, str), optional
        The names of the two linear axes spanning the slice (default: the first two linear axes).

    Returns
    -------
    dict
        ``path``, ``points`` (configurations evaluated) and ``max_um`` (the largest |error| of
        the tool point [um]).
    """
    base = default_config(machine, config)
    linear = [j for j, k in enumerate(machine.axis_kinds) if k == "linear"]
    if plane is not None:
        linear = [machine.axes.index(a) for a in plane] + [j for j in linear if machine.axes[j] not in plane]
    if len(linear) >= 2:
        a_ax, b_ax = linear[:2]
        u = np.linspace(*machine.travel[a_ax], resolution)
        v = np.linspace(*machine.travel[b_ax], resolution)
        U, V = np.meshgrid(u, v, indexing="ij")
        q = np.tile(base, (U.size, 1))
        q[:, a_ax], q[:, b_ax] = U.ravel(), V.ravel()
    else:
        q = sample(machine, 400, seed=0)
    field = evaluate_field(machine, q)
    pos, err = field.positions, field.error[:, :3] * UM_PER_M
    spread = np.ptp(pos, axis=0)
    i, j = sorted(np.argsort(-spread)[:2])
    norm = np.linalg.norm(err, axis=1)
    fig, ax = plt.subplots(figsize=(8.0, 6.4), dpi=120, constrained_layout=True)
    fig.get_layout_engine().set(rect=(0.0, 0.05, 1.0, 0.95))  # room for the arrow key below
    x, y = pos[:, i] * 1e3, pos[:, j] * 1e3
    if len(linear) >= 2:
        shape = (resolution, resolution)
        mesh = ax.contourf(x.reshape(shape), y.reshape(shape), norm.reshape(shape), levels=20,
                           cmap="viridis")
    else:
        mesh = ax.scatter(x, y, c=norm, cmap="viridis", s=18)
    fig.colorbar(mesh, ax=ax, label="|error| (3D) [um]")
    step = max(1, resolution // 12) if len(linear) >= 2 else 1
    if len(linear) >= 2:
        sel = (np.arange(resolution)[:, None] % step == 0) & (np.arange(resolution)[None, :] % step == 0)
        sel = sel.ravel()
    else:
        sel = slice(None, None, 4)
    key = _nice(np.percentile(norm, 90))
    quiver = ax.quiver(x[sel], y[sel], err[sel, i], err[sel, j], color="white", edgecolor="black",
                       linewidth=0.4, angles="xy", scale_units="inches", scale=key / 0.5, width=0.004)
    ax.quiverkey(quiver, 0.08, 0.025, key, f"{key:g} um in-plane error", labelpos="E",
                 coordinates="figure", fontproperties={"size": 9})
    ax.set_xlabel(f"{AXES[i]} [mm] (workpiece frame)")
    ax.set_ylabel(f"{AXES[j]} [mm] (workpiece frame)")
    ratio = np.ptp(y) / max(np.ptp(x), 1e-12)
    if 0.4 < ratio < 2.5:  # true proportions unless the slice is very elongated
        ax.set_aspect("equal", adjustable="box")
    if len(linear) >= 2:
        units = ["mm" if k == "linear" else "deg" for k in machine.axis_kinds]
        shown = to_engineering(machine, base)
        fixed = [f"{machine.axes[k]} = {shown[k]:g} {units[k]}"
                 for k in range(len(machine.axes)) if k not in linear[:2]]
        title = f"{machine.name}: volumetric error, {AXES[i]}{AXES[j]} slice\n"
        title += ("at " + ", ".join(fixed)) if fixed else "whole travel"
    else:
        title = (f"{machine.name}: volumetric error at {len(q)} sampled configurations\n"
                 f"tool points projected on {AXES[i]}{AXES[j]}")
    ax.set_title(title + f"\nmax {norm.max():.2f} um, RMS {np.sqrt(np.mean(norm**2)):.2f} um; "
                 "arrows: in-plane error", fontsize=10, loc="left")
    save(fig, path)
    return {"path": str(path), "points": int(len(q)), "max_um": float(norm.max())}


def ranking_png(ranking: dict, path: str | Path, top: int = 15) -> dict:
    """Horizontal bars of the RMS tool-point error per term, the maximum as a tick, shares.

    Parameters
    ----------
    ranking : dict
        A ranking's report (the ``to_dict`` of :func:`~volerr_pin.fit.rank`'s result): its
        ``ranking`` rows (``parameter``, ``rms_um``, ``max_um``, ``share``), ``machine`` and
        ``points``.
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).
    top : int, default 15
        How many rows to draw, from the first.

    Returns
    -------
    dict
        ``path`` and ``rows`` (the rows drawn).
    """
    fig = ranking_figure(ranking, top)
    save(fig, path)
    return {"path": str(path), "rows": min(top, len(ranking["ranking"]))}


def ranking_figure(ranking: dict, top: int = 15, size: tuple[float, float] | None = None):
    """The figure of :func:`ranking_png` (the recordings show it too: its bars carry names)."""
    rows = ranking["ranking"][:top]
    names = [r["parameter"] for r in rows][::-1]
    rms = np.array([r["rms_um"] for r in rows])[::-1]
    peak = np.array([r["max_um"] for r in rows])[::-1]
    share = np.array([r.get("share_of_all", r["share"]) for r in rows])[::-1]
    fig, ax = plt.subplots(figsize=size or (8.0, 0.38 * len(rows) + 1.6), dpi=120, constrained_layout=True)
    yy = np.arange(len(rows))
    ax.barh(yy, rms, color="#4a6fb4", label="RMS over the workspace")
    ax.scatter(peak, yy, marker="|", s=180, color="#c0392b", label="maximum", zorder=3)
    for k in range(len(rows)):
        ax.text(max(rms[k], peak[k]) * 1.02 + 1e-9, yy[k], f"{100 * share[k]:.1f} %", va="center",
                fontsize=8)
    ax.set_yticks(yy, names)
    ax.set_xlabel("tool-point error caused by the term [um]")
    top = max(peak.max(), rms.max()) if len(rows) else 0.0
    ax.set_xlim(0, top * 1.2 if top > 0 else 1.0)   # every term zero (a bare URDF): an axis of 1 um
    basis = ranking.get("basis", "current values")
    ax.set_title(f"{ranking['machine']}: error sources at the tool ({basis}, "
                 f"{ranking['points']} points, direction {ranking.get('direction', 'all')})\n"
                 "labels: share of the mean squared tool error", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(axis="x", alpha=0.3)
    return fig


def _nice(value: float) -> float:
    if value <= 0:
        return 1.0
    exponent = np.floor(np.log10(value))
    for step in (5, 2, 1):
        if step * 10**exponent <= value:
            return float(step * 10**exponent)
    return float(10**exponent)


def iso230_png(result: dict, path: str | Path, title: str = "") -> dict:
    """The standard's picture: mean deviation per direction with the +-2s band, per target.

    Parameters
    ----------
    result : dict
        ISO 230-2 figures of a positioning run (:func:`~volerr_pin.applications.iso230.evaluate_runs`).
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).
    title : str, optional
        The plot's title (default: one made from the figures).

    Returns
    -------
    dict
        ``path``: the file written.
    """
    pos = result["positions"]
    t = np.array([p["target"] for p in pos])
    unit, tunit = result["unit"], result.get("target_unit", "")
    fig, ax = plt.subplots(figsize=(8.0, 5.0), dpi=120, constrained_layout=True)
    for label, colour, marker in (("up", "#1f6fb2", "^"), ("down", "#c0392b", "v")):
        if f"mean_{label}" not in pos[0]:
            continue
        m = np.array([p[f"mean_{label}"] for p in pos])
        s = np.array([p[f"s_{label}"] for p in pos])
        name = "positive direction" if label == "up" else "negative direction"
        ax.plot(t, m, marker=marker, color=colour, label=f"mean, {name}")
        ax.fill_between(t, m - 2 * s, m + 2 * s, color=colour, alpha=0.18, label=f"+-2s, {name}")
        ax.plot(t, m + 2 * s, color=colour, lw=0.6, ls="--")
        ax.plot(t, m - 2 * s, color=colour, lw=0.6, ls="--")
    if result["bidirectional"]:
        ax.plot(t, [p["mean"] for p in pos], color="black", lw=1.0, ls=":", label="bidirectional mean")
    ax.axhline(0.0, color="grey", lw=0.5)
    ax.set_xlabel(f"target position [{tunit}]")
    ax.set_ylabel(f"positioning deviation [{unit}]")
    keys = ["A", "A_up", "A_down", "B", "B_mean", "E", "E_up", "E_down", "M", "R", "R_up", "R_down"]
    text = "\n".join(f"{k:<7}{result[k]:9.3f}" for k in keys if result.get(k) is not None)
    ax.text(1.02, 1.0, f"ISO 230-2 [{unit}]\n{text}", transform=ax.transAxes, va="top", family="monospace",
            fontsize=8)
    ax.set_title(title or f"ISO 230-2 positioning run ({result['n_targets']} targets)", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    ax.grid(alpha=0.3)
    save(fig, path)
    return {"path": str(path)}


def ballbar_png(run, result: dict, path: str | Path, title: str = "") -> dict:
    """The ISO 230-4 picture: both traces about the least-squares centre on a polar plot whose
    radial scale is the deviation (um), with the figures beside it.

    Parameters
    ----------
    run : BallbarRun
        The circular test (:func:`~volerr_pin.measurements.read_ballbar`).
    result : dict
        Its ISO 230-4 figures (:func:`~volerr_pin.measurements.evaluate_circular`).
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).
    title : str, optional
        The plot's title (default: one made from the figures).

    Returns
    -------
    dict
        ``path``: the file written.
    """
    from ..measurements import radial_about

    r = run.deviation * 1e6
    about = radial_about(run.angle, r, np.array([0.0, *result["centre_offset_um"]])) - result["radius_error_um"]
    fig = plt.figure(figsize=(8.5, 5.5), dpi=120, constrained_layout=True)
    ax = fig.add_subplot(projection="polar")
    span = max(float(np.abs(about).max()), 1e-3)
    ax.set_ylim(-1.6 * span, 1.1 * span)  # zero deviation sits on a circle, inside is negative
    for d, label, colour in ((1.0, "counter-clockwise (+)", "#1f6fb2"), (-1.0, "clockwise (-)", "#c0392b")):
        mask = run.direction == d
        if mask.any():
            order = np.argsort(run.angle[mask])
            a, v = run.angle[mask][order], about[mask][order]
            ax.plot(np.append(a, a[0]), np.append(v, v[0]), color=colour, lw=1.0, label=label)
    ax.plot(np.linspace(0, 2 * np.pi, 361), np.zeros(361), color="grey", lw=0.6, ls=":")
    ax.set_rlabel_position(112.5)   # between the 90 and 135 deg spokes, where traces cross least
    ax.tick_params(axis="y", labelsize=7, colors="#555555")
    for label in ax.get_yticklabels():
        label.set_bbox({"facecolor": "white", "edgecolor": "none", "alpha": 0.7, "pad": 0.5})
    ax.set_xlabel(f"{run.plane[0]} ->, {run.plane[1]} ^ ; radial: deviation from the least-squares circle [um]",
                  fontsize=8)
    keys = [("G", "G (both)"), ("G_ccw", "G ccw"), ("G_cw", "G cw"), ("H", "H"), ("F_max", "F max"),
            ("F_min", "F min"), ("radius_error_um", "radius error")]
    text = "\n".join(f"{label:<13}{result[k]:8.3f}" for k, label in keys if result.get(k) is not None)
    text += f"\ncentre offset {result['centre_offset_um'][0]:+.2f}, {result['centre_offset_um'][1]:+.2f}"
    fig.text(0.74, 0.92, f"ISO 230-4 [um]\n{text}", va="top", family="monospace", fontsize=8)
    ax.set_title(title or f"circular test, radius {result['radius_mm']:g} mm", fontsize=10)
    ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(1.0, 0.0))
    save(fig, path)
    return {"path": str(path)}


def thermal_fit_png(result: dict, data, path: str | Path) -> dict:
    """Measured and modelled target over the rows, the held-out part shaded.

    Parameters
    ----------
    result : dict
        A thermal fit's report (:func:`~volerr_pin.applications.thermalfit.thermal_fit`).
    data : SeriesData or None
        The data it was fitted on: the measured target, and the time axis when the data have a
        time column (else the rows); None (held-out test files): the model only, over the rows.
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).

    Returns
    -------
    dict
        ``path``: the file written.
    """
    from ..applications.thermalfit import TIME_COLUMNS

    fitted = np.asarray(result["fitted"])
    held = np.asarray(result.get("predicted_holdout") or [])
    fig, ax = plt.subplots(figsize=(9.0, 4.5), dpi=120, constrained_layout=True)
    time = next((c for c in TIME_COLUMNS if data is not None and c in data.columns), None)
    if time is not None:   # the file's own clock, in hours
        at = np.asarray(data.columns[time], dtype=float) / 3600.0
        xlabel = f"time [h] (column {time})"
    else:
        at = np.arange(len(data.batch) if data is not None else len(fitted) + len(held), dtype=float)
        xlabel = "row (time order: the file has no time column t)"
    if data is not None:
        y = data.columns[result["target"]]
        ax.plot(at[:len(y)], y, color="black", lw=0.8, label="measured")
    start = result["n_fit"] and (len(data.batch) - len(held) - len(fitted) if data is not None else 0)
    x_fit = at[start:start + len(fitted)]
    ax.plot(x_fit, fitted, color="#1f6fb2", lw=0.9, label=f"model (R^2 {result['r2']:.4f})")
    if len(held):
        x_held = at[start + len(fitted):start + len(fitted) + len(held)]
        ax.plot(x_held, held, color="#c0392b", lw=0.9, label=f"held out (RMSE {result['rmse_holdout']:.3g})")
        ax.axvspan(x_held[0], x_held[-1], color="#c0392b", alpha=0.08)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(result["target"])
    lag = f", lag {result['lag']}" if result.get("lag") is not None else ""
    ax.set_title(f"thermal-fit: {result['method']}{lag}, {len(result['sensors'])} sensors", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save(fig, path)
    return {"path": str(path)}


def diagnosis_png(diagnosis, path: str | Path) -> dict:
    """One page: held-out RMS per step against the noise floor, and for each accepted effect
    the residual against its driver before and after.

    Parameters
    ----------
    diagnosis : Diagnosis
        The diagnosis (:func:`~volerr_pin.fit.diagnosis.diagnose`); up to four effects and two
        thermal drifts get panels of their own.
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).

    Returns
    -------
    dict
        ``path``: the file written.
    """
    save(diagnosis_figure(diagnosis), path)
    return {"path": str(path)}


def diagnosis_figure(diagnosis):
    """The figure of :func:`diagnosis_png` (the diagnosis' recording shows it too)."""
    from ..fit.diagnosis import Role, drift_series, evidence

    n_eff = min(len(diagnosis.effects), 4)
    drifts = drift_series(diagnosis)[:2]
    rows = 1 + (n_eff + 1) // 2 + len(drifts)
    fig = plt.figure(figsize=(11.0, 3.2 + 2.9 * (rows - 1)), dpi=110, constrained_layout=True)
    grid = fig.add_gridspec(rows, 2)
    ax = fig.add_subplot(grid[0, 0])
    rms = [s.rms_holdout_um for s in diagnosis.steps]
    def short(step):
        a = step.accepted_all
        if a[0].kind == Role.UNDER_MODELLED:
            return "+degree\n" + " ".join(r.component for r in a[:3]) + (" ..." if len(a) > 3 else "")
        e = a[0]
        return e.name + (f"\n{e.axis}" if e.axis else "") + (f" {e.direction}" if e.direction else "")

    labels = ["base"] + [short(s) for s in diagnosis.steps if s.accepted_all]
    # a round whose effect the diagnosis dropped later (replaced, or no longer significant after
    # a refit): its bar is hatched and says so
    gone = {getattr(e, "step", None) for e in diagnosis.dropped} - {e.step for e in diagnosis.effects}
    dropped = [i > 0 and diagnosis.steps[i - 1].number in gone for i in range(len(rms))]   # bar i: round i - 1
    bars = ax.bar(range(len(rms)), rms, color=["#b8c6e0" if d else "#4a6fb4" for d in dropped])
    for bar, d in zip(bars, dropped):
        if d:
            bar.set_hatch("//")
    labels = [label + ("\n(dropped later)" if d else "") for label, d in zip(labels, dropped)]
    ax.axhline(diagnosis.noise_floor_um, color="#c0392b", ls="--", label=f"noise floor {'<= ' if diagnosis.noise_floor_upper_bound else ''}{diagnosis.noise_floor_um:.2f} um")
    ax.set_xticks(range(len(rms)), labels[:len(rms)], fontsize=7, rotation=30, ha="right", rotation_mode="anchor")
    ax.set_ylabel("held-out RMS [um]")
    ax.set_title("held-out RMS after each step", fontsize=10)
    ax.legend(fontsize=8)
    text = fig.add_subplot(grid[0, 1])
    text.axis("off")
    lines = [f"{diagnosis.machine.name}: {len(diagnosis.effects)} effect(s) found",
             f"held-out RMS {diagnosis.rms_before_um:.3f} -> {diagnosis.rms_after_um:.3f} um",
             f"noise floor {'at most ' if diagnosis.noise_floor_upper_bound else ''}"
             f"{diagnosis.noise_floor_um:.3f} um ({diagnosis.noise_floor_source})",
             {True: "reaches the noise floor", False: "does NOT reach the noise floor",
              None: "noise not stated: whether it reaches the floor is unknown"}[diagnosis.reaches_noise_floor]]
    for e in diagnosis.effects:
        params = ", ".join(f"{n.split('.')[-1]} = {p['value']:.4g}"
                           + (f" +- {p['uncertainty']:.2g}" if p["uncertainty"] is not None else "") + f" {p['unit']}"
                           for n, p in e.parameters.items())
        lines.append(f"- {e.label}: {e.rms_before_um:.3f} -> {e.rms_after_um:.3f} um; {params}")
    for e in diagnosis.possible:
        lines.append(f"- {e.note.partition(': ')[0]}: {e.label}")
    if diagnosis.under_modelled:
        lines.append(diagnosis.off_spec()["label"] + " (raised; not physical effects): " + ", ".join(
            u.component for u in diagnosis.under_modelled))
    import textwrap

    wrapped = [w for line in lines for w in textwrap.wrap(line, 64, subsequent_indent="    ")]
    text.text(0.0, 1.0, "\n".join(wrapped), va="top", fontsize=8, family="monospace")
    for k in range(n_eff):
        ev = evidence(diagnosis, diagnosis.effects[k].step)
        if ev is None:
            continue
        a = fig.add_subplot(grid[1 + k // 2, k % 2])
        x = ev.x
        if len(np.unique(x)) <= 2:  # a +-1 driver: spread the points so they can be seen
            x = x + np.random.default_rng(0).uniform(-0.15, 0.15, len(x))
        a.scatter(x, ev.before_um, s=6, color="#c0392b", alpha=0.6, label="before")
        a.scatter(x, ev.after_um, s=6, color="#1f6fb2", alpha=0.6, label="after")
        a.set_xlabel(ev.x_label, fontsize=8)
        a.set_ylabel(f"residual d{ev.direction} [um]", fontsize=8)
        a.set_title(f"step {k + 1}: {ev.label}", fontsize=8)
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    for k, series in enumerate(drifts):
        _drift_panels(fig, grid[1 + (n_eff + 1) // 2 + k, 0], grid[1 + (n_eff + 1) // 2 + k, 1], series)
    return fig


def _drift_panels(fig, left, right, series) -> None:
    """A thermal drift over time: measured against the model (left; the check over time's
    fitted part shaded), and each driver's share with the sensors' temperatures (right)."""
    a = fig.add_subplot(left)
    a.scatter(series.t_h, series.measured_um, s=5, color="#888888", alpha=0.6, label="measured drift")
    a.plot(series.t_h, series.model_um, color="#c0392b", lw=1.2, label="model")
    if series.fit_until_h is not None:
        a.axvspan(series.t_h.min(), series.fit_until_h, color="#1f6fb2", alpha=0.08,
                  label="fitted part of the check over time")
    a.set_xlabel("time [h]", fontsize=8)
    a.set_ylabel(f"drift d{series.direction} [um]", fontsize=8)
    a.set_title(series.label, fontsize=8, wrap=True)
    a.legend(fontsize=7)
    a.grid(alpha=0.3)
    b = fig.add_subplot(right)
    if len(series.contributions_um) <= 1 and not series.temperatures:
        # one driver: its share is the model itself (left); show what the model leaves instead
        b.scatter(series.t_h, np.asarray(series.measured_um) - np.asarray(series.model_um), s=5, color="#888888",
                  alpha=0.6)
        b.axhline(0.0, color="#c0392b", lw=0.8)
        b.set_xlabel("time [h]", fontsize=8)
        b.set_ylabel("measured - model [um]", fontsize=8)
        b.set_title(f"what the model leaves over time (one driver: {', '.join(series.contributions_um) or '-'})",
                    fontsize=8)
        b.grid(alpha=0.3)
        return
    for name, values in series.contributions_um.items():
        b.plot(series.t_h, values, lw=1.0, label=f"share of {name} [um]")
    b.set_xlabel("time [h]", fontsize=8)
    b.set_ylabel("share of the model's drift [um]", fontsize=8)
    b.set_title("which drivers matter", fontsize=8)
    b.grid(alpha=0.3)
    if series.temperatures:
        c = b.twinx()
        for name, values in series.temperatures.items():
            c.plot(series.t_h, values, lw=0.6, ls=":", label=f"T_{name} [degC]")
        c.set_ylabel("temperature [degC]", fontsize=8)
        c.legend(fontsize=6, loc="lower right")
    b.legend(fontsize=6, loc="upper left")


def compensation_png(report, path: str | Path, title: str = "") -> dict:
    """Largest error along each move of an NC program before and after compensation, with
    the tolerance, and the pieces each move was split into.

    Parameters
    ----------
    report : Report
        The report of a compensated program (:class:`~volerr_pin.compensation.gcode.Program`
        made with ``detail=True``, so that it holds the per-move results).
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).
    title : str, optional
        The plot's title (default: one made from the figures).

    Returns
    -------
    dict
        ``path``: the file written.
    """
    detail = np.array(report.detail, dtype=float).reshape(-1, 4)
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(9.0, 5.5), dpi=120, sharex=True, constrained_layout=True,
                                  gridspec_kw={"height_ratios": [3, 1]})
    line = detail[:, 0]
    ax.plot(line, detail[:, 2], color="#999999", lw=0.8, marker=".", ms=3, label="uncompensated")
    ax.plot(line, detail[:, 3], color="#1f6fb2", lw=0.8, marker=".", ms=3, label="compensated (model)")
    ax.axhline(report.tolerance_um, color="#c0392b", ls="--", lw=1.0, label=f"tolerance {report.tolerance_um:g} um")
    ax.set_ylabel("largest error along the move [um]")
    ax.set_yscale("log")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(title or f"{report.moves} moves: {report.max_before_um:.2f} um -> {report.max_residual_um:.3f} um "
                 f"({report.blocks_in} blocks in, {report.blocks_out} out)", fontsize=10)
    ax2.step(line, detail[:, 1], where="mid", color="#333333", lw=0.8)
    ax2.set_ylabel("pieces")
    ax2.set_xlabel("line of the program")
    ax2.grid(alpha=0.3)
    save(fig, path)
    return {"path": str(path)}


def gear_png(deviations, path: str | Path, title: str = "") -> dict:
    """The generated flanks' normal deviations: maps over profile x face width of the worst
    tooth of each flank, and every tooth's flank position on the pitch circle.

    ``deviations`` is a :class:`volerr_pin.applications.gear.FlankDeviations`.

    Parameters
    ----------
    deviations : FlankDeviations
        The generated flanks' normal deviations.
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).
    title : str, optional
        A title over the three panels (default: none).

    Returns
    -------
    dict
        ``path`` and ``worst_teeth`` (the tooth mapped for each flank).
    """
    from ..applications.gear import FLANKS, pitch_positions

    normal = deviations.normal * UM_PER_M                     # (2, teeth, profile, face) um
    diameter = 2 * deviations.radius * 1e3
    face = deviations.face * 1e3
    fig, axes = plt.subplots(1, 3, figsize=(13.0, 4.2), dpi=120, constrained_layout=True)
    worst_teeth = []
    # a flank's mean deviation is its position (the pitch panel shows it); the maps show the
    # form about it, so that profile and helix deviations are not drowned by the offset
    worst = [int(np.argmax(np.abs(normal[index]).max(axis=(1, 2)))) for index in range(len(FLANKS))]
    forms = [normal[index, k] - normal[index, k].mean() for index, k in enumerate(worst)]
    limit = max(float(np.abs(f).max()) for f in forms) or 1.0
    for index, flank in enumerate(FLANKS):
        k = worst[index]
        worst_teeth.append(int(deviations.teeth[k]))
        image = axes[index].pcolormesh(face, diameter, forms[index], cmap="RdBu_r", vmin=-limit, vmax=limit,
                                       shading="gouraud")
        axes[index].set_xlabel("face position from mid face [mm]")
        axes[index].set_ylabel("diameter [mm]")
        axes[index].set_title(f"{flank} flank, tooth {deviations.teeth[k]} (worst), mean {normal[index, k].mean():+.2f} um",
                              fontsize=10)
    fig.colorbar(image, ax=axes[:2], label="form: deviation less the mean [um] (+: material)")
    positions = pitch_positions(normal, deviations.gear)           # um, teeth in ascending order
    for index, flank in enumerate(FLANKS):
        axes[2].plot(deviations.teeth, positions[index], marker="o", ms=3, label=f"{flank} flank")
    axes[2].set_xlabel("tooth")
    axes[2].set_ylabel("flank position along the pitch circle [um]")
    axes[2].set_title("pitch: flank positions at mid face", fontsize=10)
    axes[2].grid(alpha=0.3)
    axes[2].legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=11)
    save(fig, path)
    return {"path": str(path), "worst_teeth": worst_teeth}


def part_png(prediction, path: str | Path, factor: float | None = None) -> dict:
    """The predicted part: left, the programmed contours seen along the contour plane's normal,
    each sample moved by its normal deviation magnified ``factor`` times and coloured by its
    size; right, each full circle's deviation about its least-squares circle as a CMM prints
    it (polar, the nominal circle as reference, deviations magnified).

    Parameters
    ----------
    prediction : PartPrediction
        The predicted part (:func:`~volerr_pin.applications.part.predict`).
    path : str or Path
        The picture file; its suffix sets the format (:func:`picture_format`, PNG without one).
    factor : float, optional
        The magnification of the deviations on the contours (default: a round one,
        :func:`~volerr_pin.model.nice_scale`).

    Returns
    -------
    dict
        ``path`` and ``factor`` (the magnification used).
    """
    from ..model import nice_scale

    deviation = prediction.deviation
    size = np.linalg.norm(deviation.normal, axis=1) * 1e6
    i, j = next((f.plane for f in prediction.features if hasattr(f, "plane")), (0, 1))
    points = deviation.point[:, [i, j]] * 1e3
    extent = float(np.ptp(points, axis=0).max()) or 1.0
    factor = factor or nice_scale(float(size.max()) or 1.0, extent * 1e-3)
    moved = points + deviation.normal[:, [i, j]] * 1e3 * factor
    rounds = prediction.circles[:1] or prediction.cones   # the first circle, or every cone's sections
    fig = plt.figure(figsize=(12.0 if rounds else 7.5, 6.0), dpi=110, constrained_layout=True)
    from matplotlib.collections import LineCollection

    ax = fig.add_subplot(1, 2 if rounds else 1, 1)
    ax.add_collection(LineCollection([points[rows] for rows in deviation.runs()], colors="#bbbbbb", linewidths=0.8))
    within = np.flatnonzero(deviation.move[1:] == deviation.move[:-1])   # neighbours on one move
    pieces = np.stack([moved[within], moved[within + 1]], axis=1)
    shown = LineCollection(pieces, array=(size[within] + size[within + 1]) / 2, cmap="viridis", linewidths=2.0)
    ax.add_collection(shown)
    ax.autoscale()
    fig.colorbar(shown, ax=ax, label="deviation normal to the path [um]")
    ax.set_aspect("equal")
    ax.set_xlabel(f"{'xyz'[i]} [mm]")
    ax.set_ylabel(f"{'xyz'[j]} [mm]")
    ax.set_title(f"{prediction.machine.name}: {Path(prediction.source).name}, deviation x{factor:g} "
                 f"(grey: programmed; largest {deviation.max_um:.2f} um)", fontsize=9)
    if rounds:
        polar = fig.add_subplot(1, 2, 2, projection="polar")
        outer = max(f.radius for f in rounds) * 1e3   # mm
        # a cone's sections on base circles of their own, the lowest (widest) outside, as a CMM's
        # chart draws several profiles, with less room for each; a circle on its own radius
        spread = np.linspace(0.95, 0.45, len(rounds)) if len(rounds) > 1 else np.ones(1)
        room = 0.1 if len(rounds) > 1 else 0.15
        magnify = nice_scale(max(float(np.abs(f.radial_um).max()) for f in rounds) or 1e-3, room * outer * 1e-3 / 0.08)
        titles = []
        for k, feature in enumerate(rounds):
            order = np.argsort(feature.angle)
            reference = feature.radius * 1e3 if len(rounds) == 1 else outer * spread[k]
            cone = getattr(feature, "cone", None)
            label = "measured about the least-squares circle" if cone is None else f"at {feature.height * 1e3:g} mm"
            polar.plot(feature.angle[order], reference + feature.radial_um[order] * 1e-3 * magnify,
                       color=f"C{k}" if cone is not None else "#c0392b", lw=1.0,
                       label=label)
            polar.plot(np.linspace(0, 2 * np.pi, 361), np.full(361, reference), color="#888888", lw=0.6,
                       label="least-squares circle" if k == 0 else None)
            if cone is None:
                titles.append(f"circle of line {feature.lines[0]}: roundness {feature.circularity_um:.2f} um, "
                              f"diameter error {feature.diameter_error_um:+.2f} um, centre {feature.centre_error_um:.2f} um")
            else:
                titles.append(f"at {feature.height * 1e3:g} mm: roundness {feature.circularity_um:.2f}, diameter "
                              f"{feature.diameter_error_um:+.2f}, centre {feature.centre_error_um:.2f} um")
        if prediction.cones and not prediction.circles:
            cone = rounds[0].cone
            titles.insert(0, f"cone of lines {cone.lines[0]}..{cone.lines[-1]} ({'boss' if cone.boss else 'bore'}), "
                             "seen along its axis" + ("\neach section on a base circle of its own"
                                                      if len(rounds) > 1 else ""))
        polar.set_ylim(0, outer * 1.3)
        polar.set_yticklabels([])
        polar.set_title("\n".join(titles) + f"\n(deviation x{magnify:g})", fontsize=9, pad=18)
        polar.legend(loc="lower center", bbox_to_anchor=(0.5, -0.16), fontsize=7, ncol=min(4, len(rounds) + 1))
    save(fig, path)
    return {"path": str(path), "factor": factor}
