"""Serendipity shape functions (seed 002 eqs. 7-14), error maps and compensation tables."""

from __future__ import annotations

import csv
import itertools

import numpy as np
import pytest

from volerr_pin.compensation import compensate_points
from volerr_pin.compensation._errormap import ErrorMap, axis_tables, compensation_table, natural_nodes, shape_functions
from volerr_pin.base import InputError


def _monomials(degree):
    return [e for e in itertools.product(range(degree + 1), repeat=3) if sum(e) <= degree]


def _poly(xi, coeffs, degree):
    return sum(c * np.prod(xi ** np.array(e), axis=1) for c, e in zip(coeffs, _monomials(degree)))


@pytest.mark.parametrize("order, n", [(1, 8), (2, 20), (3, 32)])
def test_partition_of_unity_and_nodal_interpolation(order, n):
    nodes = natural_nodes(order)
    assert nodes.shape == (n, 3)
    assert len(np.unique(nodes, axis=0)) == n
    np.testing.assert_allclose(shape_functions(order, nodes), np.eye(n), atol=1e-14)
    xi = np.random.default_rng(order).uniform(-1, 1, (500, 3))
    np.testing.assert_allclose(shape_functions(order, xi).sum(axis=1), 1.0, atol=1e-13)


@pytest.mark.parametrize("order", [1, 2, 3])
def test_polynomial_reproduction(order):
    rng = np.random.default_rng(10 + order)
    nodes = natural_nodes(order)
    xi = rng.uniform(-1, 1, (400, 3))
    N = shape_functions(order, xi)
    if order == 1:  # the trilinear family: 1, x, y, z, xy, yz, zx, xyz
        basis = [e for e in itertools.product((0, 1), repeat=3)]
        coeffs = rng.normal(size=len(basis))
        f = lambda p: sum(c * np.prod(p ** np.array(e), axis=1) for c, e in zip(coeffs, basis))
    else:  # complete polynomials of the element's order
        coeffs = rng.normal(size=len(_monomials(order)))
        f = lambda p: _poly(p, coeffs, order)
    np.testing.assert_allclose(N @ f(nodes), f(xi), atol=1e-12)
    # one degree more is not reproduced (so the check can fail)
    higher = lambda p: p[:, 0] ** (order + 1)
    assert np.abs(N @ higher(nodes) - higher(xi)).max() > 1e-3


def test_bad_order_is_rejected():
    with pytest.raises(InputError, match="order"):
        natural_nodes(4)


def test_error_map_matches_model_at_nodes_and_converges_with_order(machines):
    m = machines["vmc500"]
    results = []
    for order in (1, 2, 3):
        emap = ErrorMap.build(m, (3, 3, 3), order)
        # nodes: interpolation equals the model exactly
        pts = emap._node_points()[5]
        q = np.tile(emap.fixed, (len(pts), 1))
        q[:, list(emap.axes)] = pts
        np.testing.assert_allclose(emap.interpolate(q), m.volumetric_error(q), atol=1e-15)
        results.append(emap.interpolation_error(800, seed=1))
    rms = [r["rms_um"] for r in results]
    assert rms[0] > rms[1] > rms[2] > 0
    assert results[0]["nodes"] == 64 and results[1]["nodes"] == 64 + 3 * 4 * 4 * 3
    with pytest.raises(InputError, match="outside the error map"):
        emap.locate(np.array([[0.2, 0.1, m.travel[2, 1] + 0.01]]))


def test_error_map_of_a_five_axis_machine_at_a_fixed_head_angle(machines):
    m = machines["cgm4000"]
    emap = ErrorMap.build(m, (2, 2, 2), 2, config={"A": 0.3, "B": -0.2})
    q = np.array([[1.0, 1.0, 0.3, 0.3, -0.2]])
    assert np.linalg.norm(emap.interpolate(q) - m.volumetric_error(q)) < 0.2 * np.linalg.norm(m.volumetric_error(q))
    with pytest.raises(InputError, match="built with"):
        emap.interpolate(np.array([[1.0, 1.0, 0.3, 0.0, -0.2]]))


def test_error_map_needs_three_linear_axes(machines):
    with pytest.raises(InputError, match="three linear axes"):
        ErrorMap.build(machines["lathe_2axis"])


def test_compensation_table(machines, tmp_path):
    m = machines["vmc700"]
    summary = compensation_table(m, tmp_path / "table.csv", nodes=(5, 4, 3))
    lines = (tmp_path / "table.csv").read_text().splitlines()
    assert any("trilinear" in line for line in lines if line.startswith("#"))
    rows = list(csv.reader(line for line in lines if not line.startswith("#")))
    assert rows[0] == ["X_mm", "Y_mm", "Z_mm", "dX_um", "dY_um", "dZ_um"]
    assert len(rows) - 1 == 5 * 4 * 3 == summary["rows"]
    # a node's correction is the exact point compensation there
    node = np.array([float(v) for v in rows[7][:3]]) * 1e-3
    exact = compensate_points(m, node[None, :], orientation=False).q[0] - node
    np.testing.assert_allclose([float(v) for v in rows[7][3:]], exact * 1e6, atol=1e-4)
    # the table works: the residual with trilinear table compensation is far below the error
    before = np.linalg.norm(m.volumetric_error(np.array([[0.35, 0.125, 0.1]]))[0, :3]) * 1e6
    assert summary["residual_with_table_max_um"] < 0.5 * summary["max_correction_um"]
    assert summary["max_correction_um"] > before


def test_axis_tables_carry_iso_names_and_model_values(machines, tmp_path):
    m = machines["vmc500"]
    files = axis_tables(m, tmp_path, points=5)
    assert [f.rsplit("_", 1)[1] for f in files] == ["X.csv", "Y.csv", "Z.csv"]
    rows = list(csv.reader(line for line in open(files[0]) if not line.startswith("#")))
    assert rows[0][:4] == ["X_mm", "EXX_um", "EYX_um", "EZX_um"]
    assert "EAX_urad" in rows[0]
    x = float(rows[3][0]) * 1e-3
    q = m.travel.mean(axis=1)
    q[0] = x
    vals = m.component_values(q[None, :])[0]
    col = rows[0].index("EYX_um")
    assert float(rows[3][col]) == pytest.approx(vals[m.components.index("EYX")] * 1e6, abs=1e-4)


# ------------------------------------------------------------------ bad or extreme inputs
def test_a_table_written_in_chunks_is_the_table_written_at_once(machines, tmp_path, monkeypatch):
    """The table is computed and written chunk by chunk; with chunks of 7 nodes every byte and
    every summary number is what one chunk gives."""
    import volerr_pin.compensation._errormap as errormap

    m = machines["vmc500"]
    whole = compensation_table(m, tmp_path / "whole.csv", nodes=(4, 3, 5))
    monkeypatch.setattr(errormap, "TABLE_CHUNK", 7)
    chunked = compensation_table(m, tmp_path / "chunked.csv", nodes=(4, 3, 5))
    assert (tmp_path / "whole.csv").read_bytes() == (tmp_path / "chunked.csv").read_bytes()
    assert {k: v for k, v in whole.items() if k != "file"} == {k: v for k, v in chunked.items() if k != "file"}


def test_a_table_the_disk_cannot_hold_is_refused_before_any_work(machines, tmp_path):
    """--nodes 2000 asked for 8e9 nodes and was killed at 23.5 GB: the table is streamed, and one
    larger than the free disk is refused up front, naming nodes; the file is not touched."""
    target = tmp_path / "table.csv"
    target.write_text("old\n")
    with pytest.raises(InputError, match=r"nodes: a table of 2000 x 2000 x 2000 = 8,000,000,000 nodes takes about "
                                         r".* GB, more than the .* GB free on the disk of") as err:
        compensation_table(machines["vmc500"], target, nodes=(2000, 2000, 2000))
    assert err.value.parameters == ("nodes",)
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


def test_a_failed_table_leaves_the_old_file_and_no_temporary(machines, tmp_path, monkeypatch):
    import volerr_pin.compensation._points as compensate

    target = tmp_path / "table.csv"
    target.write_text("old\n")
    calls = []

    checked = compensate.compensate_checked

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) > 1:  # the disk probe passes, the table itself fails
            raise RuntimeError("interrupted")
        return checked(*args, **kwargs)

    monkeypatch.setattr(compensate, "compensate_checked", failing)
    with pytest.raises(RuntimeError, match="interrupted"):
        compensation_table(machines["vmc500"], target, nodes=(3, 3, 3))
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


@pytest.mark.parametrize("call, match, parameter", [
    (lambda m, d: compensation_table(m, d / "t.csv", nodes=(1, 3, 3)), r"nodes must be 3 whole numbers >= 2, got \(1, 3, 3\)", "nodes"),
    (lambda m, d: compensation_table(m, d / "t.csv", nodes=(2.5, 3, 3)), "nodes must be 3 whole numbers >= 2", "nodes"),
    (lambda m, d: compensation_table(m, d / "t.csv", nodes=(3, 3)), "nodes must be 3 whole numbers >= 2", "nodes"),
    (lambda m, d: ErrorMap.build(m, (2.5, 2, 2)), r"elements must be 3 whole numbers >= 1, got \(2.5, 2, 2\)", "elements"),
    (lambda m, d: ErrorMap.build(m, (0, 2, 2)), "elements must be 3 whole numbers >= 1", "elements"),
    (lambda m, d: ErrorMap.build(m, (1000, 1000, 1000), 1), r"an error map of 1000 x 1000 x 1000 hexahedra "
                                                            r"\(8,000,000,000 element nodes\) needs about .* of memory",
     "elements"),
    (lambda m, d: ErrorMap.build(m, (1, 1, 1), 1).interpolation_error(0), "points must be >= 1, got 0", "points"),
    (lambda m, d: ErrorMap.build(m, (1, 1, 1), 1).interpolation_error(10**10), "an interpolation test at "
                                                                          "10,000,000,000 random positions needs", "points"),
    (lambda m, d: ErrorMap.build(m, (1, 1, 1), 1).interpolation_error(10, seed=-1), "seed must be >= 0, got -1", "seed"),
    (lambda m, d: axis_tables(m, d, points=1), "points must be >= 2, got 1", "points"),
    (lambda m, d: axis_tables(m, d, points=10**11), "axis tables at 100,000,000,000 positions needs", "points"),
    (lambda m, d: ErrorMap.build(m, config={"X": 0.1}), "config: X is one of the axes an error map spans", "config"),
    (lambda m, d: ErrorMap.build(m, config={"Q": 0.1}), "config: vmc500 has no axis 'Q'", "config"),
])
def test_bad_sizes_and_counts_are_refused_naming_them(machines, tmp_path, call, match, parameter):
    with pytest.raises(InputError, match=match) as err:
        call(machines["vmc500"], tmp_path)
    assert err.value.parameters == (parameter,)


def test_fixed_axes_outside_their_travel_and_nan_positions_are_refused(machines):
    m = machines["cgm4000"]
    with pytest.raises(InputError, match=r"config: A = 3 rad is outside its travel"):
        ErrorMap.build(m, (1, 1, 1), 1, config={"A": 3.0})
    with pytest.raises(InputError, match="config: A = nan rad is outside its travel"):
        ErrorMap.build(m, (1, 1, 1), 1, config={"A": float("nan")})
    emap = ErrorMap.build(machines["vmc500"], (1, 1, 1), 1)
    with pytest.raises(InputError, match=r"x\[0, 1\] is nan: positions must be finite"):
        emap.locate(np.array([[0.1, np.nan, 0.1]]))


def test_axis_tables_are_written_whole(machines, tmp_path):
    """Each per-axis table goes through a temporary file: a folder that is a file is refused
    in one line, and nothing but the tables is left behind."""
    m = machines["vmc500"]
    (tmp_path / "taken").write_text("")
    with pytest.raises(InputError, match="directory: .*taken is not a folder"):
        axis_tables(m, tmp_path / "taken" / "sub", points=3)
    files = axis_tables(m, tmp_path / "tables", points=3)
    assert sorted(p.name for p in (tmp_path / "tables").iterdir()) == sorted(f.rsplit("/", 1)[1] for f in files)


def test_interpolation_in_chunks_is_the_interpolation_at_once(machines, monkeypatch):
    import volerr_pin.compensation._errormap as errormap

    m = machines["vmc500"]
    emap = ErrorMap.build(m, (2, 2, 2), 3)
    q = np.tile(m.mid_travel, (50, 1))
    q[:, :3] = m.travel[:, 0] + np.random.default_rng(2).random((50, 3)) * (m.travel[:, 1] - m.travel[:, 0])
    whole = emap.interpolate(q)
    monkeypatch.setattr(errormap, "INTERPOLATION_CHUNK", 7)
    np.testing.assert_array_equal(emap.interpolate(q), whole)
    with pytest.raises(InputError, match=r"xi has shape \(4, 2\); expected \(M, 3\)"):
        shape_functions(2, np.zeros((4, 2)))
    with pytest.raises(InputError, match="order must be 1 .* got 4") as err:
        natural_nodes(4)
    assert err.value.parameters == ("order",)


def test_a_table_in_a_missing_folder_is_refused_in_one_line(machines, tmp_path):
    with pytest.raises(InputError, match="path: .* folder .* does not exist") as err:
        compensation_table(machines["vmc500"], tmp_path / "nowhere" / "t.csv", nodes=(2, 2, 2))
    assert err.value.parameters == ("path",)
