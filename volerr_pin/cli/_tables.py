"""Tables and lines that several commands print (machine info, error summary, ranking,
identifiability groups, recordings)."""

from __future__ import annotations

import sys

from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table


def print_info(console: Console, info: dict) -> None:
    console.print(f"[bold]{escape(info['machine'])}[/bold]"
                  + (f": {escape(info['description'])}" if info["description"] else
                     " (a bare URDF: no error terms until a spec gives them)" if not info.get("components") else ""))
    if info["source"]:
        console.print(f"source: {escape(info['source'])}")
    provenance = info.get("provenance")
    if provenance:
        flat = "; ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in provenance.items()
                         if not isinstance(v, (dict, list)))
        console.print(escape(f"provenance: {flat}" + ("; --json gives the rest" if any(
            isinstance(v, (dict, list)) for v in provenance.values()) else "")))
    console.print(f"tool frame '{info['tool_frame']}', workpiece frame '{info['workpiece_frame']}'")
    chains = info["chains"]
    console.print(f"tool chain: bed - {' - '.join(chains['tool']) or '(no axis)'} - tool;  "
                  f"workpiece chain: bed - {' - '.join(chains['workpiece']) or '(no axis)'} - workpiece")
    table = Table(box=box.SIMPLE, title="axes")
    for col in ("axis", "joint", "kind", "travel", "chain", "errors frame"):
        table.add_column(col)
    for a in info["axes"]:
        table.add_row(a["name"], a["joint"], a["kind"],
                      f"{a['travel'][0]:g} .. {a['travel'][1]:g} {a['unit']}", a["chain"],
                      a["errors_frame"])
    console.print(table)
    terms = Table(box=box.SIMPLE, title=f"error terms ({len(info['components'])} components, "
                                        f"{info['n_parameters']} coefficients)")
    for col in ("component", "of", "kind", "range over travel", "coefficients"):
        terms.add_column(col)
    for c in info["components"]:
        terms.add_row(c["name"], c["owner"], "+".join(c["kinds"]),
                      f"{c['min']:+.2f} .. {c['max']:+.2f} {c['unit']}", str(len(c["parameters"])))
    console.print(terms)
    if info["ranges_of"] != "all terms":
        console.print(escape(f"ranges over travel: of the {info['ranges_of']}"))
    by_kind = ", ".join(f"{k}: {len(v)}" for k, v in info["terms_by_kind"].items())
    console.print(f"terms by kind: {by_kind}")


def print_summary(console: Console, summary: dict, axes) -> None:
    worst = ", ".join(f"{a}={v:.1f}" for a, v in zip(axes, summary["worst_q"]))
    console.print(
        f"volumetric error over {summary['points']} workspace points (full grid): "
        f"max {summary['max_position_um']:.2f} um, RMS {summary['rms_position_um']:.2f} um "
        f"(max |dx| {summary['max_abs_um']['x']:.2f}, |dy| {summary['max_abs_um']['y']:.2f}, "
        f"|dz| {summary['max_abs_um']['z']:.2f} um); worst at {worst}; "
        f"max orientation error {summary['max_orientation_arcsec']:.2f} arcsec")


def print_ranking(console: Console, ranking: dict, title: str) -> None:
    table = Table(box=box.SIMPLE, title=title)
    for col, justify in (("#", "right"), ("term", "left"), ("axis", "left"), ("max um", "right"),
                         ("RMS um", "right"), ("share", "right"), ("per unit (RMS)", "right"),
                         ("contribution degree", "right"), ("orientation share", "right")):
        table.add_column(col, justify=justify)
    for i, r in enumerate(ranking["ranking"], 1):
        degree = "" if r["contribution_degree"] is None else f"{100 * r['contribution_degree']:.1f} %"
        table.add_row(str(i), r["parameter"], r["axis"], f"{r['max_um']:.2f}", f"{r['rms_um']:.2f}",
                      f"{100 * r.get('share_of_all', r['share']):.1f} %", f"{r['per_unit_rms']:.3f} {r['per_unit']}", degree,
                      f"{100 * r['orientation_share']:.1f} %")
    console.print(table)


def print_groups(console: Console, groups: list[dict], header: bool = True, units: dict | None = None) -> None:
    """Groups of coefficients the data cannot separate; with ``units`` (name -> (SI per
    unit, unit)) the factors are shown for the coefficients in their spec units."""
    if not groups:
        if header:
            console.print("identifiability at the tool: every coefficient has its own effect")
        return
    if header:
        console.print("identifiability at the tool (no tool-point measurement separates these; "
                      + ("factors for the coefficients in their spec units, um and arcsec):" if units
                         else "factors for the coefficients in SI units, m and rad):"))
    for g in groups:
        factors = list(g["factors"])
        si = ""
        if units and all(p in units for p in g["parameters"]):
            # a column per display unit is its column per SI unit times u (SI per display unit):
            # a combination (sum w_k A_k = 0) takes w_k u_0 / u_k; a collinear group
            # (A_k = f_k A_0) takes f_k u_k / u_0
            u0 = units[g["parameters"][0]][0]
            factors = [f * (units[p][0] / u0 if g["kind"] == "collinear" else u0 / units[p][0])
                       for p, f in zip(g["parameters"], factors)]
        elif units:
            si = " (factors in SI units: instrument terms have no spec unit)"
        pairs = list(zip(g["parameters"], factors))
        parts = escape(", ".join(f"{f:+.3g} {p}" for p, f in pairs[:8]))
        more = f", ... ({len(pairs) - 8} more; --json lists all)" if len(pairs) > 8 else ""
        console.print(f"  {g['kind']:<11} {parts}{more}{si}")


def print_recording(summary: dict, stream=None) -> None:
    stream = stream or sys.stdout
    sweep = (f"; rotary sweep of {', '.join(summary['sweep_axes'])} in {summary['sweep_steps']} steps "
             "on the 'sweep' timeline" if summary["sweep_steps"] else "")
    size = f", {summary['bytes'] / 1e6:.2f} MB" if summary.get("bytes") else ""
    print(f"wrote {summary['path']}: {summary['points']} points, arrows x{summary['scale']:g}, "
          f"max {summary['max_um']:.2f} um{sweep}{size}", file=stream)
    print(f"open it with: rerun {summary['path']}", file=stream)
