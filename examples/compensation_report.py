"""Compensation on every bundled machine (seed 002)
================================================

Predicted effect of compensation on every bundled machine (seed 002's evaluation).

For each machine: exact point compensation over a space-filling workspace sample (max and
RMS tool position error before and after, % reduction, how many points would need commands
beyond the travel), and path compensation of random straight moves at 1 um (pieces per
move, largest residual along the paths), plus seed 002's two worked examples on vmc700.

Run: ``python examples/compensation_report.py`` (prints a Markdown table; about half a minute
on 2 cores, with a progress bar on stderr).
"""

from __future__ import annotations

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

import volerr_pin as vp
from volerr_pin.compensation import PathCompensator, arc_from_center, evaluate_compensation
from volerr_pin.model import sample


def machine_row(name: str, points: int = 512, moves: int = 8, seed: int = 0, advance=lambda: None) -> dict:
    m = vp.load_machine(name)
    travel = m.travel
    span = travel[:, 1] - travel[:, 0]
    q = sample(m, points, seed=seed)
    inner = np.where(np.isfinite(span)[None, :], travel[:, 0] + 0.02 * span + 0.96 * (q - travel[:, 0]), q)
    ev = evaluate_compensation(m, inner)
    advance()
    rng = np.random.default_rng(seed)
    comp = PathCompensator(m, tol_um=1.0)
    pieces, worst, before, limited = [], 0.0, 0.0, 0
    for _ in range(moves):
        a, b = inner[rng.integers(len(inner), size=2)]
        r = comp.line(a, b)
        pieces.append(len(r.pieces))
        worst, before = max(worst, r.max_residual), max(before, r.max_before)
        limited += r.limited  # the move passes a pose no command can correct (singular)
        advance()
    return {"machine": name, "axes": "".join(m.axes) if all(len(a) == 1 for a in m.axes) else len(m.axes),
            **ev, "path_before_um": before * 1e6, "path_after_um": worst * 1e6,
            "pieces_per_move": float(np.mean(pieces)), "moves": moves, "limited_moves": limited}


def _axis(row: dict) -> str:
    if "max_axis_before_urad" not in row:
        return "-"
    return (f"{row['max_axis_before_urad']:.1f} -> {row['max_axis_after_urad']:.2f} / "
            f"{row['rms_axis_before_urad']:.1f} -> {row['rms_axis_after_urad']:.2f}")


def seed002_examples() -> dict:
    m = vp.load_machine("vmc700")
    comp = PathCompensator(m, tol_um=1.0)
    line = comp.line(np.array([0.010, 0.010, 0.010]), np.array([0.680, 0.240, 0.190]))
    arc = comp.arc(arc_from_center(np.array([0.5, 0.01, 0.05]), np.array([0.1, 0.03, 0.15]),
                                   np.array([0.3, 0.02]), (0, 1, 2), clockwise=False))
    return {"line": (len(line.pieces), line.max_before * 1e6, line.max_residual * 1e6),
            "arc": (len(arc.pieces), arc.max_before * 1e6, arc.max_residual * 1e6)}


def main(moves: int = 8) -> dict:
    names = vp.bundled_machines()
    # about half a minute in all on 2 cores, most of it cgm4000 and the UR5 (their moves pass
    # singular poses and split into many pieces): a bar on stderr shows where it is
    with Progress(TextColumn("{task.description:<24}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task("compensating", total=len(names) * (1 + moves))
        rows = []
        for name in names:
            bar.update(task, description=f"{name}: points, moves")
            rows.append(machine_row(name, moves=moves, advance=lambda: bar.advance(task)))
    print("| machine | points (reachable) | max before -> after [um] | RMS before -> after [um] | reduction "
          "| tool axis max / RMS before -> after [urad] | paths: max before -> after [um] | pieces per move "
          "| moves limited |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['machine']} | {r['points']} ({r['reachable']}) | {r['max_before_um']:.2f} -> "
              f"{r['max_after_um']:.3f} | {r['rms_before_um']:.2f} -> {r['rms_after_um']:.3f} | "
              f"{r['reduction_percent']:.1f} % | {_axis(r)} | {r['path_before_um']:.2f} -> {r['path_after_um']:.3f} | "
              f"{r['pieces_per_move']:.1f} | {r['limited_moves']} of {r['moves']} |")
    ex = seed002_examples()
    print()
    for key, paper in (("line", 8), ("arc", 4)):
        n, b, a = ex[key]
        print(f"seed 002 {key} example on vmc700 at 1 um: {n} pieces (paper: {paper}), "
              f"max error {b:.2f} um -> {a:.3f} um")
    return {"rows": rows, "seed002": ex}


if __name__ == "__main__":
    main()
