"""ISO 230-2:2014 evaluation against hand-worked vectors, and on real runs when available."""

from __future__ import annotations

import json
import math
import os
import re
import statistics
from pathlib import Path

import numpy as np
import pytest

from volerr_pin.cli import main
from volerr_pin.applications.iso230 import evaluate, evaluate_runs
from volerr_pin.measurements import read_runs

R2 = math.sqrt(2.0)


def run(data):
    """data: {(target, direction): [deviations]} -> flat arrays."""
    t, d, x = [], [], []
    for (target, direction), values in data.items():
        for v in values:
            t.append(target)
            d.append(direction)
            x.append(v)
    return evaluate(t, d, x)


def test_vector_1_repeatability_set_by_4s():
    r = run({(0, 1): [1, 3], (0, -1): [0, 0], (10, 1): [2, 2], (10, -1): [-1, 1]})
    # hand-worked: means up 2, 2; down 0, 0; s up sqrt2, 0; down 0, sqrt2; B_i = 2, 2
    assert r["B"] == pytest.approx(2.0) and r["B_mean"] == pytest.approx(2.0)
    assert r["R_up"] == pytest.approx(4 * R2) and r["R_down"] == pytest.approx(4 * R2)
    assert r["R"] == pytest.approx(4 * R2)              # 4s = 5.657 > 2s+2s+|B| = 4.828
    assert r["E_up"] == pytest.approx(0.0) and r["E_down"] == pytest.approx(0.0)
    assert r["E"] == pytest.approx(2.0)
    assert r["M"] == pytest.approx(0.0)
    assert r["A_up"] == pytest.approx(4 * R2) and r["A_down"] == pytest.approx(4 * R2)
    assert r["A"] == pytest.approx(2 + 2 * R2 + 2 * R2)  # 7.657


def test_vector_2_repeatability_set_by_reversal():
    r = run({(0, 1): [1, 2, 3], (0, -1): [-1, 0, 1], (5, 1): [0, 0, 0], (5, -1): [0, 0, 0]})
    # target 0: s up = s down = 1, B = 2: 2 + 2 + 2 = 6 > 4s = 4
    assert r["positions"][0]["R"] == pytest.approx(6.0)
    assert r["R"] == pytest.approx(6.0) and r["R_up"] == pytest.approx(4.0) and r["R_down"] == pytest.approx(4.0)
    assert r["B"] == pytest.approx(2.0) and r["B_mean"] == pytest.approx(1.0)
    assert r["E_up"] == pytest.approx(2.0) and r["E_down"] == pytest.approx(0.0) and r["E"] == pytest.approx(2.0)
    assert r["M"] == pytest.approx(1.0)
    assert r["A_up"] == pytest.approx(4.0) and r["A_down"] == pytest.approx(4.0) and r["A"] == pytest.approx(6.0)


def test_vector_3_extremes_of_the_two_directions_at_different_targets():
    """E is max of all one-way means minus min of all one-way means: here 5 (up, target 10)
    minus -4 (down, target 0) = 9, not max(E_up, E_down) = 6."""
    means = {(0, 1): 0, (0, -1): -4, (10, 1): 5, (10, -1): 0, (20, 1): 1, (20, -1): 2}
    r = run({k: [m - 1, m + 1] for k, m in means.items()})   # s = sqrt2 everywhere
    assert r["E_up"] == pytest.approx(5.0) and r["E_down"] == pytest.approx(6.0)
    assert r["E"] == pytest.approx(9.0)
    assert r["M"] == pytest.approx(4.5)                  # bidirectional means -2, 2.5, 1.5
    assert r["B"] == pytest.approx(5.0) and r["B_mean"] == pytest.approx(8 / 3)
    assert r["R"] == pytest.approx(4 * R2 + 5)           # 2s + 2s + |B| at target 10
    assert r["A_up"] == pytest.approx(5 + 4 * R2) and r["A_down"] == pytest.approx(6 + 4 * R2)
    assert r["A"] == pytest.approx(9 + 4 * R2)


def test_unidirectional_run():
    r = run({(0, 1): [0.0, 0.2], (100, 1): [1.0, 1.4]})
    assert not r["bidirectional"] and r["B"] is None and r["R"] is None and r["A"] is None
    assert r["E_up"] == pytest.approx(1.1) and r["M"] == pytest.approx(1.1)
    s0, s1 = statistics.stdev([0.0, 0.2]), statistics.stdev([1.0, 1.4])
    assert r["R_up"] == pytest.approx(4 * s1)
    assert r["A_up"] == pytest.approx(1.2 + 2 * s1 - (0.1 - 2 * s0))


def test_a_repeated_approach_is_refused_not_counted(tmp_path):
    """Issue 22: a row repeating target, cycle and direction was counted as a sixth approach
    of five, changing the mean and s; the reader names both lines instead."""
    rows = [f"{t},{c},{d},{0.2 * c + d}" for t in (0, 100) for c in range(1, 6) for d in (1, -1)]
    path = tmp_path / "runs.csv"
    path.write_text("\n".join(["target_mm,cycle,direction,deviation_um"] + rows + ["100,3,-1,7.5"]) + "\n")
    line_of_first = 2 + next(i for i, row in enumerate(rows) if row.startswith("100,3,-1,"))
    with pytest.raises(ValueError, match=rf"runs\.csv:22: target 100 mm, cycle 3, direction -1 is given twice "
                                         rf"\(first on line {line_of_first}\)"):
        read_runs(path)
    path.write_text("\n".join(["target_mm,cycle,direction,deviation_um"] + rows) + "\n")
    assert evaluate_runs(read_runs(path))["positions"][1]["n_down"] == 5


@pytest.mark.parametrize("args, match", [
    (([0, 0], [1, 1], [1.0, np.nan]), r"deviations\[1\] is nan; values must be finite"),
    (([0, np.inf], [1, 1], [1.0, 2.0]), r"targets\[1\] is inf"),
    (([], [], []), r"targets: no approach given"),
    (([0, 0], [1, 1], [1.0]), r"must be 1-D of one length"),
])
def test_evaluate_refuses_non_finite_and_mismatched_input(args, match):
    with pytest.raises(ValueError, match=match):
        evaluate(*args)


def test_one_approach_is_refused():
    with pytest.raises(ValueError, match="target 5: 1 approach"):
        run({(0, 1): [0, 1], (5, 1): [2]})


def test_cli_json_fields(tmp_path, capsys):
    path = tmp_path / "runs.csv"
    rows = ["target_mm,cycle,direction,deviation_um"]
    rng = np.random.default_rng(0)
    for c in range(1, 6):
        for t in (0, 100, 200, 300):
            for d in (1, -1):
                rows.append(f"{t},{c},{d},{0.01 * t + 0.5 * d + rng.normal(0, 0.2):.4f}")
    path.write_text("\n".join(rows) + "\n")
    png = tmp_path / "iso.png"
    assert main(["iso230-2", str(path), "--json", "--png", str(png)]) == 0
    r = json.loads(capsys.readouterr().out)
    for key in ("unit", "A", "A_up", "A_down", "B", "B_mean", "E", "E_up", "E_down", "M", "R", "R_up",
                "R_down", "positions"):
        assert key in r
    assert r["unit"] == "um" and len(r["positions"]) == 4 and png.stat().st_size > 20_000
    assert r["B_mean"] == pytest.approx(1.0, abs=0.3)


def test_cli_rotary_units(tmp_path, capsys):
    path = tmp_path / "c.csv"
    path.write_text("target_deg,cycle,direction,deviation_arcsec\n0,1,1,1\n0,2,1,2\n90,1,1,3\n90,2,1,5\n")
    assert main(["iso230-2", str(path), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["unit"] == "arcsec" and r["E_up"] == pytest.approx(2.5)


def _independent(targets, directions, values):
    """A second, loop-based evaluation written from the standard's text, for real data."""
    out = {}
    levels = sorted(set(targets))
    stats = {}
    for t in levels:
        for d in (1, -1):
            xs = [v for tt, dd, v in zip(targets, directions, values) if tt == t and dd == d]
            stats[t, d] = (statistics.fmean(xs), statistics.stdev(xs))
    means = [stats[k][0] for k in stats]
    out["E"] = max(means) - min(means)
    out["B"] = max(abs(stats[t, 1][0] - stats[t, -1][0]) for t in levels)
    out["R"] = max(max(2 * stats[t, 1][1] + 2 * stats[t, -1][1] + abs(stats[t, 1][0] - stats[t, -1][0]),
                       4 * stats[t, 1][1], 4 * stats[t, -1][1]) for t in levels)
    out["M"] = max((stats[t, 1][0] + stats[t, -1][0]) / 2 for t in levels) - \
        min((stats[t, 1][0] + stats[t, -1][0]) / 2 for t in levels)
    out["A"] = max(stats[k][0] + 2 * stats[k][1] for k in stats) - min(stats[k][0] - 2 * stats[k][1] for k in stats)
    return out


REAL = Path(os.environ.get("VOLERR_REAL_DATA", Path(__file__).resolve().parents[3] / "shared" / "real-data"))


@pytest.mark.skipif(not (REAL / "iso230_2_runs").is_dir(), reason="real data not beside the repository")
def test_real_runs_agree_with_an_independent_evaluation():
    """Two real bidirectional runs (5 targets x 5 cycles), one with strong drift."""
    # psi: direction,i,target_mm,ref_c1..5 (measured position per cycle)
    lines = [l for l in (REAL / "iso230_2_runs" / "psi_fat_sat.csv").read_text().splitlines()
             if l and not l.startswith("#")][1:]
    t, d, x = [], [], []
    for line in lines:
        cells = line.split(",")
        for ref in cells[3:]:
            t.append(float(cells[2]))
            d.append(1 if cells[0] == "fwd" else -1)
            x.append((float(ref) - float(cells[2])) * 1000.0)  # um
    # ess: key=value lines
    text = (REAL / "iso230_2_runs" / "ess_muts_x.dat").read_text()
    targets = {int(i): float(v) for i, v in re.findall(r"TGT_DATA\[(\d+)\]=(\S+)", text)}
    t2, d2, x2 = [], [], []
    for key, sign in (("FWD", 1), ("BWD", -1)):
        for i, j, v in re.findall(rf"REF_DATA_{key}\[(\d+),(\d+)\]=(\S+)", text):
            t2.append(targets[int(i)])
            d2.append(sign)
            x2.append((float(v) - targets[int(i)]) * 1000.0)
    for tt, dd, xx in ((t, d, x), (t2, d2, x2)):
        ours = evaluate(tt, dd, xx)
        ref = _independent(tt, dd, xx)
        for key in ("E", "B", "R", "M", "A"):
            assert ours[key] == pytest.approx(ref[key], rel=1e-12), key
    # the product reads both files as supplied (wide cycles table; KEY=VALUE .dat), giving
    # the same evaluation as the conversion written out above
    for name, (tt, dd, xx) in (("psi_fat_sat.csv", (t, d, x)), ("ess_muts_x.dat", (t2, d2, x2))):
        native = evaluate_runs(read_runs(REAL / "iso230_2_runs" / name))
        ref = evaluate(tt, dd, xx)
        assert native["unit"] == "um" and native["target_unit"] == "mm"
        for key in ("E", "B", "R", "M", "A", "E_up", "R_down", "B_mean"):
            assert native[key] == pytest.approx(ref[key], rel=1e-12, abs=1e-12), (name, key)
        assert ours["E"] >= max(ours["E_up"], ours["E_down"])
        assert ours["R"] >= max(ours["R_up"], ours["R_down"])
