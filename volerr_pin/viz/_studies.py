"""Pictures of the uncertainty and tolerance studies: a Rerun recording of the uncertainty
field and a PNG of the distribution of the largest error.

- :func:`record_uncertainty`: under ``uncertainty/<field>/`` (``map``, and ``compensation``
  when the study has a residual) the nominal tool points in the workpiece frame, coloured by
  the Monte Carlo standard uncertainty of the position (``points``) and by the linear one
  (``linear``), with both and the 95 % interval of ``|e|`` attached to every point; the
  points where the two methods disagree (``disagree``, red); a colour ``legend`` and an
  ``about`` text. The machine is drawn at its default configuration under ``machine/``.
- :func:`max_error_png`: the histogram of the largest position error over the grid,
  one value per draw, with the target ``T`` and the 95th percentile marked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..base import UM_PER_M, check_outputs
from ..model import default_config, tool_poses

__all__ = ["log_uncertainty_field", "max_error_png", "record_uncertainty"]


def log_uncertainty_field(rec, machine, field, prefix: str = "uncertainty/map") -> dict:
    """Log one field of an uncertainty study (static).

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    machine : Machine
        The machine (its workpiece frame and nominal tool points).
    field : FieldUncertainty
        The field (:class:`volerr_pin.studies._uncertainty.FieldUncertainty`).
    prefix : str, default "uncertainty/map"
        Entity path.

    Returns
    -------
    dict
        ``points``, ``u_max_um`` (top of the colour scale) and ``disagreeing``.
    """
    import rerun as rr

    from ._recording import colours, log_legend

    _, positions = tool_poses(machine.model, field.q, nominal=True)   # the study checked its points
    u_mc = field.u_position * UM_PER_M
    u_lin = field.linear_u_position * UM_PER_M
    hi = float(max(u_mc.max(), u_lin.max())) if len(u_mc) else 1.0
    frame = rr.CoordinateFrame(machine.workpiece_frame)
    extent = float(np.ptp(positions, axis=0).max()) if len(positions) > 1 else 0.1
    radius = max(extent / 150.0, 1e-4)
    values = rr.AnyValues(u_um=u_mc, u_linear_um=u_lin, error_um=field.estimate[:, 3] * UM_PER_M,
                          low_um=field.interval[:, 3, 0] * UM_PER_M, high_um=field.interval[:, 3, 1] * UM_PER_M)
    rec.log(f"{prefix}/points", frame, rr.Points3D(positions, colors=colours(u_mc, 0.0, hi), radii=radius), values,
            static=True)
    rec.log(f"{prefix}/linear", frame, rr.Points3D(positions, colors=colours(u_lin, 0.0, hi), radii=radius),
            rr.AnyValues(u_linear_um=u_lin), static=True)
    bad = np.flatnonzero(field.disagree)
    rec.log(f"{prefix}/disagree", frame, rr.Points3D(positions[bad], colors=[220, 40, 40], radii=radius * 1.6),
            rr.AnyValues(u_um=u_mc[bad], u_linear_um=u_lin[bad]), static=True)
    log_legend(rec, f"{prefix}/legend", frame, positions, 0.0, hi, title="u")
    rec.log(f"{prefix}/about", rr.TextDocument(
        f"# Standard uncertainty of the position error ({prefix.rsplit('/', 1)[-1]})\n\n"
        f"{len(positions)} points; colour: standard uncertainty sqrt(u_x^2 + u_y^2 + u_z^2), 0 to {hi:.3g} um "
        "(viridis; the key beside the points): the points are Monte Carlo's, and `linear` (S Sigma S^T, on the "
        "same points; left out of the views, the blueprint panel adds it) is the check. Red `disagree`: points "
        f"where the two methods differ beyond tolerance ({len(bad)}). Select a point for u_um, u_linear_um, "
        "error_um and the 95 % interval of |e| (low_um, high_um).", media_type=rr.MediaType.MARKDOWN), static=True)
    return {"points": int(len(positions)), "u_max_um": hi, "disagreeing": int(len(bad))}


def record_uncertainty(study, path: str | Path, package_dirs=None) -> dict:
    """A Rerun recording of an uncertainty study's fields.

    Parameters
    ----------
    study : UncertaintyStudy
        The study (:func:`volerr_pin.studies.study_uncertainty`).
    path : str or Path
        The ``.rrd`` file, written through a temporary file renamed over it once complete.
    package_dirs : path or iterable of path, optional
        Folders of ``package://`` meshes (see :func:`volerr_pin.viz.log_machine`).

    Returns
    -------
    dict
        ``path``, ``fields`` (names), ``points``, ``bytes``.
    """
    import rerun.blueprint as rrb

    from ._recording import eye_on, log_machine, new_recording, opened_paused, streaming

    check_outputs({"path": path})
    machine = study.machine
    fields = {"map": study.map}
    if study.compensated is not None:
        fields["compensation"] = study.compensated
    rec = new_recording("volerr_pin_uncertainty")
    base = default_config(machine)
    eye = eye_on(machine, base, tool_poses(machine.model, study.map.q, nominal=True)[1])   # one camera: views compare
    what = {"map": "of the error map (what the machine does)",
            "compensation": f"of the residual after {study.compensation} compensation"}
    views = [rrb.Spatial3DView(origin="/", contents=["+ machine/**", f"+ uncertainty/{name}/**",
                                                     f"- uncertainty/{name}/linear", f"- uncertainty/{name}/about"],
                               name=f"standard uncertainty {what.get(name, name)}: up to "
                                    f"{float(field.u_position.max()) * UM_PER_M:.2f} um", eye_controls=eye)
             for name, field in fields.items()]
    about = rrb.Vertical(*[rrb.TextDocumentView(origin=f"uncertainty/{name}/about", name=f"about: {name}")
                           for name in fields])
    blueprint = rrb.Blueprint(rrb.Horizontal(rrb.Vertical(*views) if len(views) > 1 else views[0], about,
                                             column_shares=[3, 2]),
                              opened_paused(), rrb.SelectionPanel(state="collapsed"))
    with streaming(rec, path, blueprint):
        log_machine(rec, machine, base, package_dirs=package_dirs)
        for name, field in fields.items():
            log_uncertainty_field(rec, machine, field, f"uncertainty/{name}")
    return {"path": str(path), "fields": list(fields), "points": int(len(study.map.q)),
            "bytes": Path(path).stat().st_size}


def max_error_png(max_um: np.ndarray, path: str | Path, target_um: float | None = None, title: str = "") -> dict:
    """Histogram of the largest position error over the grid, one value per draw.

    Parameters
    ----------
    max_um : ndarray, shape (S,)
        The largest position error of every draw [um].
    path : str or Path
        The picture (format from the suffix).
    target_um : float, optional
        The target ``T`` [um], marked with the probability of meeting it.
    title : str, optional
        Title.

    Returns
    -------
    dict
        ``path``, ``samples``, ``p95_um`` and ``probability_within_target`` (None without a
        target).
    """
    import matplotlib.pyplot as plt

    from ._plots import save

    x = np.asarray(max_um, dtype=float)
    p95 = float(np.quantile(x, 0.95))
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.hist(x, bins=min(80, max(10, int(np.sqrt(len(x))))), color="#4a7fb5", edgecolor="white", linewidth=0.3)
    ax.axvline(p95, color="#444444", linestyle="--", label=f"95th percentile {p95:.3g} um")
    probability = None
    if target_um is not None:
        probability = float(np.mean(x <= target_um))
        ax.axvline(target_um, color="#c0392b", linewidth=2,
                   label=f"T = {target_um:.3g} um: P(max <= T) = {probability:.3f}")
    ax.set_xlabel("largest position error over the grid [um]")
    ax.set_ylabel(f"draws (of {len(x):,})")
    ax.set_title(title or "distribution of the largest volumetric error")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return {"path": str(path), "samples": int(len(x)), "p95_um": p95, "probability_within_target": probability}


def uncertainty_png(study, path: str | Path) -> dict:
    """The picture of an uncertainty study: for each field (the map, a compensation's residual)
    the distribution of its largest error over the draws beside the linear 95 % interval (or
    the note that a norm near zero has none), and every point's position uncertainty by Monte
    Carlo against the linear propagation.

    Parameters
    ----------
    study : UncertaintyStudy
        The study (:func:`volerr_pin.studies.study_uncertainty`).
    path : str or Path
        The picture (format from the suffix).

    Returns
    -------
    dict
        ``path`` and ``fields`` (the fields drawn).
    """
    import matplotlib.pyplot as plt

    from ._plots import save

    fields = [("error map", study.map)] + ([(f"residual after {study.compensation} compensation", study.compensated)]
                                           if study.compensated is not None else [])
    fig, axes = plt.subplots(len(fields), 2, figsize=(11, 3.8 * len(fields)), squeeze=False)
    for (name, field), (left, right) in zip(fields, axes):
        s = field.max
        x = field.max_draws * UM_PER_M if field.max_draws is not None else np.array([s.mc_mean * UM_PER_M])
        left.hist(x, bins=min(80, max(10, int(np.sqrt(len(x))))), color="#4a7fb5", edgecolor="white", linewidth=0.3,
                  label=f"Monte Carlo ({len(x):,} draws)")
        left.axvspan(s.mc_low * UM_PER_M, s.mc_high * UM_PER_M, color="#4a7fb5", alpha=0.12, label="Monte Carlo 95 %")
        left.axvline(s.value * UM_PER_M, color="#222222", linewidth=1.5, label=f"at the estimate {s.value * UM_PER_M:.3g} um")
        if s.applicable:
            left.axvline(s.linear_low * UM_PER_M, color="#c0392b", linestyle="--", label="linear 95 % (value -+ 1.96 u)")
            left.axvline(s.linear_high * UM_PER_M, color="#c0392b", linestyle="--")
        else:
            left.text(0.98, 0.95, "no linear interval:\na norm near zero has\nno derivative (GUM 5.1.2)",
                      transform=left.transAxes, ha="right", va="top", fontsize=8, color="#c0392b")
        left.set_xlabel(f"{name}: largest position error over the {len(field.q)} points [um]")
        left.set_ylabel("draws")
        left.legend(loc="upper left", fontsize=7, framealpha=0.9)
        mc, lin = field.u_position * UM_PER_M, field.linear_u_position * UM_PER_M
        top = max(float(mc.max()), float(lin.max()), 1e-12) * 1.05
        right.plot([0, top], [0, top], color="#999999", linewidth=1, label="equal")
        right.scatter(lin, mc, s=9, color=np.where(field.disagree, "#c0392b", "#4a7fb5"),
                      label=f"a point ({int(field.disagree.sum())} disagree, red)")
        right.set_xlim(0, top)
        right.set_ylim(0, top)
        right.set_xlabel("position uncertainty, linear propagation [um]")
        right.set_ylabel("position uncertainty, Monte Carlo [um]")
        right.set_title("every point's sqrt(u_x^2 + u_y^2 + u_z^2), both ways", fontsize=9)
        right.legend(loc="upper left", fontsize=7)
    fig.suptitle(f"{study.machine.name}: uncertainty from {study.covariance.source}", fontsize=10)
    fig.tight_layout()
    save(fig, path)
    return {"path": str(path), "fields": [name for name, _ in fields]}
