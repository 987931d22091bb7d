"""Workspace sensitivity ranking and identifiability at the tool."""

from __future__ import annotations

import json

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.fit import rank, read_tolerances, tool_identifiability
from volerr_pin.model import sample


def test_ranking_contributions_equal_direct_first_order_errors(machines):
    """max/RMS of each term's contribution equal those of the first-order error it alone causes."""
    m = machines["vmc500"]
    q = sample(m, 256, seed=1)
    r = rank(m, q).to_dict()
    for row in r["ranking"][:6]:
        keep = np.array([n.split(".")[0] == row["term"] for n in m.parameter_names])
        alone = m.volumetric_error(q, np.where(keep, m.theta, 0.0), order=1)
        norm = np.linalg.norm(alone[:, :3], axis=1) * 1e6
        # the contribution uses the sensitivity at the actual errors: equal to first order
        assert row["max_um"] == pytest.approx(norm.max(), rel=1e-3)
        assert row["rms_um"] == pytest.approx(np.sqrt(np.mean(norm**2)), rel=1e-3)


def test_shares_sum_to_one_and_rows_are_sorted(machines):
    for name in ("vmc500", "cgm4000", "ur5"):
        r = rank(machines[name], points=256).to_dict()
        shares = [row["share"] for row in r["ranking"]]
        assert sum(shares) == pytest.approx(1.0, abs=1e-12)
        rms = [row["rms_um"] for row in r["ranking"]]
        assert rms == sorted(rms, reverse=True)
        top = rank(machines[name], points=256).to_dict(top=4)
        assert len(top["ranking"]) == 4 and sum(x["share"] for x in top["ranking"]) == pytest.approx(1.0)


def test_per_unit_sensitivity_of_positioning_is_one(machines):
    r = rank(machines["vmc500"], points=256).to_dict()
    row = next(x for x in r["ranking"] if x["term"] == "EXX")
    assert row["per_unit"] == "um/um"
    assert row["per_unit_max"] == pytest.approx(1.0, abs=1e-4)


def test_contribution_degree_sums_to_one_per_axis_and_kind(machines):
    r = rank(machines["cgm4000"], points=256).to_dict()
    groups = {}
    for row in r["ranking"]:
        kind = (row["axis"], row["term"][1] in "ABC", "0" in row["term"][2:3])
        groups.setdefault(kind, []).append(row["contribution_degree"])
    for values in groups.values():
        assert sum(values) == pytest.approx(1.0)


def test_tolerances_give_variance_shares(tmp_path, machines):
    m = machines["vmc500"]
    path = tmp_path / "tol.toml"
    path.write_text("EXX_um = 10\nEBX_arcsec = 5\ndefault_um = 1\ndefault_arcsec = 1\n")
    tol = read_tolerances(path, m)
    assert tol["EXX"] == pytest.approx(10e-6) and tol["EYY"] == pytest.approx(1e-6)
    q = sample(m, 512)
    r = rank(m, q, tolerances=tol).to_dict()
    exx = next(x for x in r["ranking"] if x["term"] == "EXX")
    eyy = next(x for x in r["ranking"] if x["term"] == "EYY")
    # positioning moves the tool 1:1, so its RMS contribution is the tolerance itself
    assert exx["rms_um"] == pytest.approx(10.0, rel=1e-4)
    assert exx["share"] / eyy["share"] == pytest.approx(100.0, rel=1e-3)
    assert r["basis"] == "tolerances"


def test_tolerances_file_errors(tmp_path, machines):
    m = machines["vmc500"]
    path = tmp_path / "tol.toml"
    path.write_text("EXX_um = 10\n")
    with pytest.raises(vp.SpecError, match=r"no tolerance for EYX, EZX"):
        read_tolerances(path, m)
    path.write_text("EQX_um = 10\ndefault_um = 1\ndefault_arcsec = 1\n")
    with pytest.raises(vp.SpecError, match=r"tol\.toml: EQX_um: 'EQX' is not an error term of vmc500"):
        read_tolerances(path, m)
    path.write_text("EXX_arcsec = 10\ndefault_um = 1\ndefault_arcsec = 1\n")
    with pytest.raises(vp.SpecError, match=r"unit 'arcsec' is an angle unit"):
        read_tolerances(path, m)


def test_gear_roller_translation_along_a_rotation_axis_moves_the_tool_only_along_it(machines):
    """Seed 004, Table 3: the translations of A and B along their own axes (z) cause no
    profile, helix or pitch deviation; at the tool they act only along z."""
    m = machines["gear_roller"]
    q = sample(m, 512)
    C = m.component_sensitivity(q, np.zeros_like(m.theta))
    for name in ("EZA", "EZB"):
        k = m.components.index(name)
        np.testing.assert_allclose(C[:, :2, k], 0.0, atol=1e-15)
        np.testing.assert_allclose(np.abs(C[:, 2, k]), 1.0, atol=1e-15)
    for direction in ("x", "y"):
        r = rank(m, q, direction=direction).to_dict()
        shares = {x["term"]: x["share"] for x in r["ranking"]}
        # with the machine's other errors present only a second-order remainder (~1e-10)
        assert shares["EZA"] < 1e-8 and shares["EZB"] < 1e-8


def test_gear_roller_wheel_rotation_dominates_the_tangential_error(machines):
    """Seed 004, Table 5: eps_z(A) dominates A's angular errors. At the pitch point (A = B = 0)
    the tangential (x) error of A's angular errors comes from ECA alone (first order: the
    sensitivities are taken at zero error)."""
    m = machines["gear_roller"].with_theta(np.zeros(len(machines["gear_roller"].theta)))
    rng = np.random.default_rng(0)
    q = np.c_[rng.uniform(-0.01, 0.05, 200), rng.uniform(0, 0.15, 200), np.zeros(200), np.zeros(200)]
    r = rank(m, q, direction="x").to_dict()
    degree = {x["term"]: x["contribution_degree"] for x in r["ranking"]}
    assert degree["ECA"] == 1.0
    assert degree["EAA"] == 0.0 and degree["EBA"] == 0.0
    # and the workpiece spindle's own rotation dominates B's angular group less: its tilt
    # about y acts through the height of the tool point above B's reference point
    assert 0.0 < degree["ECB"] < 1.0 and degree["EAB"] == 0.0


def test_identifiability_on_a_machine_built_for_it(tmp_path):
    """Roll of a tool-carrying axis with the tool on it: zero; the same offset through two
    chains: collinear; a yaw whose lever arm is its own position: a combination."""
    (tmp_path / "m.urdf").write_text("""<robot name="m">
      <link name="bed"/><link name="table"/><link name="head"/><link name="tool"/><link name="work"/>
      <joint name="x" type="prismatic"><parent link="bed"/><child link="table"/>
        <axis xyz="-1 0 0"/><limit lower="0" upper="0.4"/></joint>
      <joint name="w" type="fixed"><parent link="table"/><child link="work"/></joint>
      <joint name="z" type="prismatic"><parent link="bed"/><child link="head"/>
        <axis xyz="0 0 1"/><limit lower="0" upper="0.3"/></joint>
      <joint name="t" type="fixed"><parent link="head"/><child link="tool"/></joint>
    </robot>""")
    (tmp_path / "errors.toml").write_text("""
[machine]
name = "built"
urdf = "m.urdf"
tool_frame = "tool"
workpiece_frame = "work"
[axes.X]
joint = "x"
[axes.Z]
joint = "z"
[errors.ECZ]
kind = "constant"
value_arcsec = 2
[errors.EYX]
kind = "legendre"
coefficients_um = [1.0, 2.0, 3.0]
[errors.EYZ]
kind = "constant"
value_um = 1
[errors.ECX]
kind = "legendre"
coefficients_arcsec = [0.0, 1.0]
[errors.EXX]
kind = "legendre"
coefficients_um = [0.0, 1.0]
""")
    m = vp.load_machine(tmp_path)
    groups = {g.kind: [] for g in ()}
    for g in tool_identifiability(m, points=128):
        groups.setdefault(g.kind, []).append(set(g.parameters))
    assert {"ECZ.c0"} in groups["zero"]
    assert {"EYX.c0", "EYZ.c0"} in groups["collinear"]
    assert any({"ECX.c1"} <= s and s <= {"ECX.c1", "EYX.c0", "EYX.c1", "EYX.c2"}
               for s in groups["combination"])
    assert not any("EXX.c1" in s for v in groups.values() for s in v)


def test_rank_cli_json_follows_the_contract(capsys):
    assert main(["rank", "vmc500", "--json", "--points", "256"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["machine"] == "vmc500" and data["points"] == 256
    for row in data["ranking"]:
        assert {"parameter", "term", "axis", "max_um", "rms_um", "share"} <= set(row)
    assert sum(r["share"] for r in data["ranking"]) == pytest.approx(1.0)
    assert any(g["kind"] == "zero" and g["parameters"] == ["ECZ.c0"] for g in data["identifiability"])


def test_rank_cli_csv_and_table(capsys):
    assert main(["rank", "vmc700", "--csv", "--points", "128", "--top", "3"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].startswith("parameter,term,axis,max_um,rms_um,share_of_all,share") and len(lines) == 4
    # share_of_all is of the whole, whatever --top shows; share is renormalised over the rows listed
    rows = [dict(zip(lines[0].split(","), line.split(","))) for line in lines[1:]]
    assert sum(float(r["share"]) for r in rows) == pytest.approx(1.0)
    assert sum(float(r["share_of_all"]) for r in rows) < 0.999
    assert main(["rank", "cgm4000", "--points", "128", "--top", "5", "--direction", "z"]) == 0
    out = capsys.readouterr().out
    assert "direction z" in out and "identifiability" in out


def test_rank_cli_bad_tolerances_exit_2(tmp_path, capsys):
    path = tmp_path / "t.toml"
    path.write_text("EXX = 3\n")
    assert main(["rank", "vmc500", "--tolerances", str(path)]) == 2
    assert "give the unit in the key" in capsys.readouterr().err


# ------------------------------------------------------------------ bad or extreme inputs
@pytest.mark.parametrize("call, match, parameter", [
    (lambda m: rank(m, points=0), "points must be >= 1, got 0", "points"),
    (lambda m: rank(m, points=10, seed=-2), "seed must be >= 0, got -2", "seed"),
    (lambda m: rank(m, points=10**9), r"a ranking over 1,000,000,000 workspace samples needs about .* of memory",
     "points"),
    (lambda m: rank(m, np.zeros((0, 3))), "q holds no points", "q"),
    (lambda m: rank(m, points=8, direction="w"), "direction must be one of x, y, z, all", "direction"),
    (lambda m: rank(m, points=8, tolerances={"EXX": 1e-6}), "tolerances: no value for", "tolerances"),
    (lambda m: rank(m, points=8, tolerances={c: float("nan") for c in m.components}),
     "tolerances: EXX = nan is not a non-negative finite number", "tolerances"),
    (lambda m: tool_identifiability(m, points=0), "points must be >= 1, got 0", "points"),
    (lambda m: tool_identifiability(m, points=10**9), "an identifiability analysis over 1,000,000,000 workspace "
                                                      "samples needs", "points"),
    (lambda m: tool_identifiability(m, points=8, rtol=0), "rtol must be positive and finite", "rtol"),
])
def test_bad_studies_are_refused_naming_the_parameter(machines, monkeypatch, call, match, parameter):
    import volerr_pin.base._safeio as safeio

    monkeypatch.setattr(safeio, "available_memory", lambda: 2_000_000_000)
    with pytest.raises(vp.InputError, match=match) as err:
        call(machines["vmc500"])
    assert err.value.parameters == (parameter,)


def test_the_identifiability_analysis_refuses_what_it_cannot_analyse():
    from volerr_pin.fit import analyse

    A = np.random.default_rng(0).normal(size=(20, 3))
    assert analyse(A, ["a", "b", "c"]).rank == 3
    bad = A.copy()
    bad[4, 1] = np.nan
    for args, kwargs, match, parameter in (
            ((bad, ["a", "b", "c"]), {}, r"A\[4, 1\] is nan: the sensitivities must be finite", "A"),
            ((A[0], ["a"]), {}, r"A has shape \(3,\); expected \(rows, columns\)", "A"),
            ((A, ["a", "b"]), {}, "names: 2 names for 3 columns", "names"),
            ((A, ["a", "b", "c"]), {"protected": 4}, "protected must be a whole number from 0 to 3", "protected"),
            ((A, ["a", "b", "c"]), {"rtol": 1.5}, "rtol must be between 0 and 1", "rtol"),
            ((A, ["a", "b", "c"]), {"rows": 0}, "rows must be a whole number >= 1, got 0", "rows"),
            ((A, ["a", "b", "c"]), {"typical": [1.0, 0.0, 1.0]}, "typical must be one positive finite size",
             "typical")):
        with pytest.raises(vp.InputError, match=match) as err:
            analyse(*args, **kwargs)
        assert err.value.parameters == (parameter,)


@pytest.mark.parametrize("n,d,protected", [(6, 1e-3, 0), (8, 1e-3, 1), (5, 1e-4, 0), (8, 1e-3, 2)])
def test_columns_each_independent_but_singular_together_are_thinned(n, d, protected):
    """Each column keeps far more than sqrt(rtol) of itself against those before it (d over
    its norm), yet chained together they are singular to rounding: on the real robot's wrist
    (axes meeting within a millimetre) the fit kept 27 such columns, said 21 coefficients were
    determined where 20 were, and warned that its design was rank-deficient. The kept set is now
    thinned with its own singular vectors: what goes is reported as a combination whose
    weighted sum has no effect, and what stays is well conditioned."""
    from volerr_pin.fit import analyse
    from volerr_pin.fit.identify._solver import ill_conditioned

    R = np.triu(-np.ones((n, n)), 1) + d * np.eye(n)
    Q, _ = np.linalg.qr(np.random.default_rng(n).normal(size=(3 * n, n)))
    A = Q @ R * np.linspace(1.0, 5.0, n)         # columns of different sizes
    U = A / np.linalg.norm(A, axis=0)
    sv = np.linalg.svd(U, compute_uv=False)
    assert sv[-1] < 10 * np.finfo(float).eps * sv[0]                       # the case: singular to rounding
    names = [f"p{k}" for k in range(n)]
    analysis = analyse(A, names, protected=protected)
    assert analysis.rank == n - 1 and analysis.condition < 1e3
    assert not ill_conditioned(analysis.singular_values, 3 * n)
    (group,) = analysis.groups
    assert group.kind == "combination" and group.factors[0] == 1.0
    columns = [names.index(p) for p in group.parameters]
    # the last column of those that carry the combination goes (here columns 0 and 1; the
    # protected ones come first, so one goes only when the combination holds nothing else)
    assert columns[0] == 1 and columns[0] not in analysis.kept
    assert set(columns[1:]) <= set(analysis.kept)
    size = np.linalg.norm(A[:, columns[0]])
    # the relation as listed (factors below 1e-4 of the largest left out) ...
    assert np.linalg.norm(A[:, columns] @ np.array(group.factors)) < 1e-3 * size
    # ... of a column that lies in the span of those kept
    kept = A[:, list(analysis.kept)]
    fit = kept @ np.linalg.lstsq(kept, A[:, columns[0]], rcond=None)[0]
    assert np.linalg.norm(A[:, columns[0]] - fit) < 1e-12 * size


def test_a_negative_top_is_refused_not_taken_as_all_but_the_last(machines):
    r = rank(machines["vmc500"], points=16)
    assert len(r.to_dict(top=2)["ranking"]) == 2 and len(r.to_dict(top=0)["ranking"]) == len(r.rows)
    with pytest.raises(vp.InputError, match="top must be >= 0, got -1"):
        r.to_dict(top=-1)
