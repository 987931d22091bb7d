"""Point and path compensation (seed 002 schemes, Newton on the exact axis Jacobian)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from volerr_pin.compensation import (PathCompensator, arc_from_center, compensate_points,
                                     evaluate_compensation)
from volerr_pin.base import InputError
from volerr_pin.model import add_terms

from conftest import random_q


def _pos_error(m, q_cmd, q_des):
    _, p = m.tool_poses(q_cmd, extrapolate=True)
    _, p_d = m.tool_poses(q_des, nominal=True)
    return np.linalg.norm(p - p_d, axis=1)


@pytest.mark.parametrize("name", ["vmc500", "vmc700", "gear_roller"])
def test_newton_puts_the_tool_on_target(machines, name):
    m = machines[name]
    q = random_q(m, 40, seed=3)
    travel = m.travel
    q = np.clip(q, travel[:, 0] + 0.05 * (travel[:, 1] - travel[:, 0]),
                travel[:, 1] - 0.05 * (travel[:, 1] - travel[:, 0]))
    res = compensate_points(m, q, tol_um=0.001, orientation=False)
    assert res.converged.all() and res.within_tolerance.all()
    assert res.before.max() > 1e-6  # the machine has errors to correct
    # independent check: simulate the commands with the model
    np.testing.assert_array_less(_pos_error(m, res.q, q), 1e-9)
    np.testing.assert_allclose(res.residual, _pos_error(m, res.q, q), atol=1e-12)
    assert res.reachable.all()


@pytest.mark.parametrize("name", ["lathe_2axis"])
def test_underactuated_machine_stops_at_least_squares_optimum(machines, name):
    """Fewer axes than error directions: the residual is what no axis motion can undo,
    i.e. orthogonal to every column of the axis Jacobian (first-order optimality)."""
    m = machines[name]
    q = random_q(m, 20, seed=4)
    t = m.travel
    q = np.clip(q, t[:, 0] + 0.05 * (t[:, 1] - t[:, 0]), t[:, 1] - 0.05 * (t[:, 1] - t[:, 0]))
    res = compensate_points(m, q, orientation=False, tol_um=1e-6)
    assert res.converged.all() and not res.within_tolerance.all()
    R, p = m.tool_poses(res.q, extrapolate=True)
    _, p_d = m.tool_poses(q, nominal=True)
    r = p - p_d
    J = m.axis_jacobian(res.q, extrapolate=True)[:, :3, :]
    grad = np.einsum("nij,ni->nj", J, r)
    col = np.linalg.norm(J, axis=1)
    assert np.all(np.abs(grad) <= 1e-6 * col * np.linalg.norm(r, axis=1)[:, None] + 1e-18)
    assert np.all(res.residual <= res.before + 1e-15)


def test_recursive_and_newton_agree(machines):
    m = machines["vmc500"]
    q = random_q(m, 30, seed=5) * 0.9 + 0.05 * m.travel[:, 1]
    a = compensate_points(m, q, method="newton", tol_um=1e-4)
    b = compensate_points(m, q, method="recursive", tol_um=1e-4)
    assert a.converged.all() and b.converged.all()
    np.testing.assert_allclose(a.q, b.q, atol=2e-9)
    assert b.iterations.max() > 1  # the recursion really iterates


def test_recursive_residual_follows_eq21(machines):
    """Seed 002 eq. 21: e(1) = E(Xd - E(Xd)) - E(Xd), in machine coordinates."""
    m = machines["vmc500"]
    q_d = random_q(m, 12, seed=11) * 0.8 + 0.1 * m.travel[:, 1]
    res = compensate_points(m, q_d, method="recursive", tol_um=1e-9, max_iter=2)
    J = m.axis_jacobian(q_d, nominal=True)[:, :3, :]
    to_axes = np.linalg.inv(J)

    def E(q):  # position error of the tool at command q [m]
        return m.volumetric_error(q, extrapolate=True)[:, :3]

    e0 = E(q_d)
    np.testing.assert_allclose(res.history[0], e0, atol=1e-13)
    q1 = q_d - np.einsum("nij,nj->ni", to_axes, e0)
    e1_eq21 = E(q1) - e0
    np.testing.assert_allclose(res.history[1], e1_eq21, atol=1e-13)
    # each step shrinks the residual by about the error's slope (here < 1e-3)
    assert np.all(np.linalg.norm(res.history[1], axis=1) < 1e-2 * np.linalg.norm(e0, axis=1))


def test_cgm4000_pose_compensation_corrects_tool_axis(machines):
    m = machines["cgm4000"]
    rng = np.random.default_rng(2)
    q = np.column_stack([rng.uniform(0.5, 3.5, 25), rng.uniform(0.3, 2.2, 25), rng.uniform(0.1, 0.5, 25),
                         np.radians(rng.uniform(-60, 60, 25)), np.radians(rng.uniform(-60, 60, 25))])
    res = compensate_points(m, q, tol_um=0.01, tol_urad=0.01)
    assert res.converged.all()
    R, p = m.tool_poses(res.q, extrapolate=True)
    R_d, p_d = m.tool_poses(q, nominal=True)
    R_0, _ = m.tool_poses(q)
    before_axis = np.linalg.norm(np.cross(R_0[:, :, 2], R_d[:, :, 2]), axis=1)
    after_axis = np.linalg.norm(np.cross(R[:, :, 2], R_d[:, :, 2]), axis=1)
    assert before_axis.max() > 5e-6
    assert after_axis.max() < 1e-8
    assert np.linalg.norm(p - p_d, axis=1).max() < 1e-8
    # position-only compensation leaves the tool axis as it was (no orientation rows)
    pos_only = compensate_points(m, q, orientation=False, tol_um=0.01)
    assert np.linalg.norm(m.tool_poses(pos_only.q, extrapolate=True)[1] - p_d, axis=1).max() < 1e-8


def test_unreachable_pose_is_reported(machines):
    m = machines["vmc500"]
    q = np.array([m.travel[:, 0], m.travel[:, 1], 0.5 * m.travel.sum(axis=1)])
    res = compensate_points(m, q)
    # at a travel end the correction pushes at least one axis outside on this machine
    err = m.volumetric_error(q)[:, :3]
    assert np.any(np.abs(err[:2]) > 1e-7)
    assert not res.reachable[:2].all()
    assert res.reachable[2]
    with pytest.raises(InputError, match="method"):
        compensate_points(m, q, method="magic")


def _path_max(m, commanded, desired):
    return _pos_error(m, commanded, desired).max()


def test_line_splitting_reaches_tolerance_seed002_example(machines):
    m = machines["vmc700"]
    comp = PathCompensator(m, tol_um=1.0)
    a, b = np.array([0.010, 0.010, 0.010]), np.array([0.680, 0.240, 0.190])
    res = comp.line(a, b)
    assert res.max_before > 10e-6
    assert 2 <= len(res.pieces) <= 16   # seed 002: 8 pieces with its own error model
    # independent check with dense sampling of every commanded piece
    k = np.linspace(0, 1, 2001)
    for piece in res.pieces:
        cmd = piece.start + np.outer(k, piece.end - piece.start)
        des = a + np.outer(piece.k0 + k * (piece.k1 - piece.k0), b - a)
        assert _path_max(m, cmd, des) <= 1.0e-6 * 1.001
    # pieces are contiguous and cover the move
    assert res.pieces[0].k0 == 0.0 and res.pieces[-1].k1 == 1.0
    for p, q in zip(res.pieces[:-1], res.pieces[1:]):
        assert p.k1 == q.k0 and np.array_equal(p.end, q.start)


def test_helical_arc_splitting_seed002_example(machines):
    m = machines["vmc700"]
    comp = PathCompensator(m, tol_um=1.0)
    start, end = np.array([0.5, 0.01, 0.05]), np.array([0.1, 0.03, 0.15])
    arc = arc_from_center(start, end, np.array([0.3, 0.02]), (0, 1, 2), clockwise=False)
    assert arc.radius == pytest.approx(math.hypot(0.2, 0.01))
    res = comp.arc(arc)
    assert all(p.kind == "arc" for p in res.pieces)
    assert 2 <= len(res.pieces) <= 12   # seed 002: 4 pieces
    k = np.linspace(0, 1, 2001)
    for piece in res.pieces:
        # the commanded helix through the piece's compensated start and end
        r0 = math.hypot(*(piece.start[:2] - piece.center))
        r1 = math.hypot(*(piece.end[:2] - piece.center))
        assert abs(r0 - r1) < 1e-12
        a0 = math.atan2(piece.start[1] - piece.center[1], piece.start[0] - piece.center[0])
        ang = a0 + k * piece.turns
        cmd = piece.start + np.outer(k, piece.end - piece.start)
        cmd[:, 0] = piece.center[0] + r0 * np.cos(ang)
        cmd[:, 1] = piece.center[1] + r0 * np.sin(ang)
        np.testing.assert_allclose(cmd[-1], piece.end, atol=1e-12)
        des = arc.point(piece.k0 + k * (piece.k1 - piece.k0))
        assert _path_max(m, cmd, des) <= 1.0e-6 * 1.001


def test_arc_radius_mismatch_is_rejected():
    with pytest.raises(InputError, match="radius"):
        arc_from_center(np.array([0.1, 0.0, 0.0]), np.array([0.0, 0.1001, 0.0]), np.zeros(2), (0, 1, 2), False)


@pytest.mark.parametrize("name", ["vmc500", "vmc700", "cgm4000"])
def test_evaluation_reduces_error_on_every_machine(machines, name):
    m = machines[name]
    q = random_q(m, 60, seed=1)
    t = m.travel
    q = np.clip(q, t[:, 0] + 0.02 * (t[:, 1] - t[:, 0]), t[:, 1] - 0.02 * (t[:, 1] - t[:, 0]))
    ev = evaluate_compensation(m, q)
    assert ev["points"] == 60 and ev["reachable"] >= 55
    assert ev["reduction_percent"] > 95
    assert ev["max_after_um"] < 0.05 * ev["max_before_um"]


# ------------------------------------------------------------------ bad or extreme inputs
@pytest.mark.parametrize("kwargs, match, parameter", [
    ({"tol_um": 0.0}, "tol_um must be positive and finite, got 0.0", "tol_um"),
    ({"tol_um": float("nan")}, "tol_um must be positive and finite, got nan", "tol_um"),
    ({"tol_urad": -1.0}, "tol_urad must be positive and finite, got -1.0", "tol_urad"),
    ({"lever": float("inf")}, "lever must be positive and finite, got inf", "lever"),
    ({"max_iter": -1}, "max_iter must be >= 0, got -1", "max_iter"),
    ({"max_iter": 2.5}, "max_iter must be a whole number, got 2.5", "max_iter"),
    ({"method": "magic"}, "method must be 'newton' or 'recursive'", "method"),
])
def test_bad_point_compensation_options_are_refused(machines, kwargs, match, parameter):
    m = machines["vmc500"]
    with pytest.raises(InputError, match=match) as err:
        compensate_points(m, m.mid_travel, **kwargs)
    assert err.value.parameters == (parameter,)


@pytest.mark.parametrize("kwargs, match, parameter", [
    ({"tol_um": 0.0}, "tol_um must be positive and finite, got 0.0", "tol_um"),
    ({"tol_um": float("inf")}, "tol_um must be positive and finite, got inf", "tol_um"),
    ({"tol_urad": float("nan")}, "tol_urad must be positive and finite, got nan", "tol_urad"),
    ({"samples": 0}, "samples must be >= 1, got 0", "samples"),
    ({"max_depth": -1}, "max_depth must be >= 0, got -1", "max_depth"),
    ({"method": "magic"}, "method must be 'newton' or 'recursive'", "method"),
])
def test_bad_path_compensation_options_are_refused(machines, kwargs, match, parameter):
    with pytest.raises(InputError, match=match) as err:
        PathCompensator(machines["vmc500"], **kwargs)
    assert err.value.parameters == (parameter,)


def test_positions_and_covariates_are_checked_once_at_the_door(machines):
    """Point compensation checks what it is given once, naming it as the caller does; the path
    compensator's own methods check the positions they take (outside the travel allowed)."""
    m = machines["vmc500"]
    ok, nan = np.array([0.1, 0.1, 0.1]), np.array([0.1, np.nan, 0.1])
    with pytest.raises(InputError, match=r"q_desired\[0, 1\] \(axis Y\) is nan"):
        compensate_points(m, nan[None, :])
    with pytest.raises(InputError, match=r"q_desired\[0, 1\] = 0.9 m is outside the travel of axis Y"):
        compensate_points(m, np.array([[0.1, 0.9, 0.1]]))
    with pytest.raises(InputError, match=r"covariate 't' has shape \(2,\); expected \(1,\)"):
        compensate_points(m, ok[None, :], t=[1.0, 2.0])
    with pytest.raises(InputError, match="unknown covariate"):
        compensate_points(m, ok[None, :], speed=[1.0])
    comp = PathCompensator(m)
    for call in (lambda: comp.points(nan), lambda: comp.point(nan), lambda: comp.line(ok, nan),
                 lambda: comp.line(nan, ok), lambda: comp.rapid(ok, nan), lambda: comp.line(ok, ok, start_c=nan)):
        with pytest.raises(InputError, match=r"q\[0, 1\] \(axis Y\) is nan"):
            call()
    with pytest.raises(InputError, match=r"q has shape \(2, 4\); expected \(N, 3\)"):
        comp.points(np.zeros((2, 4)))
    assert comp.line(ok, np.array([0.1, 0.45, 0.1])).max_residual < 1e-6   # beyond the travel: compensated


def test_the_state_is_checked_where_it_enters(machines):
    """A term reading a lagged temperature needs the time: refused with the machine's message
    by point and path compensation alike."""
    m = add_terms(machines["vmc500"], {"EZZ": {"kind": "thermal_drift", "driver": "temperature", "prefix": "g",
                                               "sensors": ["column"], "coefficients_um_per_K": [3.0],
                                               "reference_degC": 21.0, "lag_s": 1800.0}})
    m = m.with_state(temperatures={"column": 22.0})
    q = np.array([[0.1, 0.1, 0.1]])
    with pytest.raises(InputError, match=r"a temperature lag needs the covariate t \(time, s\)"):
        compensate_points(m, q)
    with pytest.raises(InputError, match=r"a temperature lag needs the covariate t \(time, s\)"):
        PathCompensator(m).points(q)
    held = compensate_points(m.with_state(t=3600.0), q)
    assert held.within_tolerance.all()


def test_newton_reads_each_point_at_its_own_lagged_temperature(machines):
    """The lagged temperatures of the points are read along all of them once: the residual
    reported is that of the commands at the points' own covariates, however few points are
    still iterating."""
    m = add_terms(machines["vmc500"], {"EZZ": {"kind": "thermal_drift", "driver": "temperature", "prefix": "g",
                                               "sensors": ["column"], "coefficients_um_per_K": [3.0],
                                               "reference_degC": 21.0, "lag_s": 1800.0}})
    q = random_q(m, 300, seed=0)
    cov = {"t": np.linspace(0.0, 7200.0, 300), "temperatures": {"column": 20 + 5 * np.sin(np.linspace(0, 9, 300))}}
    res = compensate_points(m, q, **cov)
    _, p = m.tool_poses(res.q, extrapolate=True, **cov)
    _, p_d = m.tool_poses(q, nominal=True)
    np.testing.assert_array_equal(res.residual, np.linalg.norm(p - p_d, axis=1))


def test_empty_positions_and_degenerate_arcs_are_refused(machines):
    m = machines["vmc500"]
    with pytest.raises(InputError, match="q holds no points: there is nothing to compensate"):
        evaluate_compensation(m, np.zeros((0, 3)))
    s, e = np.array([0.1, 0.1, 0.1]), np.array([0.1, 0.1, 0.1])
    with pytest.raises(InputError, match="the arc starts at its centre: a radius of zero"):
        arc_from_center(s, e, np.array([0.1, 0.1]), (0, 1, 2), True)
    with pytest.raises(InputError, match="center of the arc is not finite"):
        arc_from_center(s, e, np.array([np.nan, 0.1]), (0, 1, 2), True)
    with pytest.raises(InputError, match="full_turns must be >= 0, got -1"):
        arc_from_center(s, e, np.array([0.2, 0.1]), (0, 1, 2), True, full_turns=-1)
    with pytest.raises(InputError, match="an arc of 1,000,000,001 turns needs about") as err:
        arc_from_center(s, e, np.array([0.2, 0.1]), (0, 1, 2), True, full_turns=10**9)
    assert err.value.parameters == ("full_turns",)


def test_path_sizes_are_bounded(machines, monkeypatch):
    """A depth beyond double precision would only reach Python's recursion limit; samples are
    sized against the free memory."""
    import volerr_pin.base._safeio as safeio

    monkeypatch.setattr(safeio, "available_memory", lambda: 1_000_000_000)
    m = machines["vmc500"]
    with pytest.raises(InputError, match=r"max_depth must be at most 60 .* got 1000"):
        PathCompensator(m, max_depth=1000)
    with pytest.raises(InputError, match="10,000,000,000 samples along a move needs about") as err:
        PathCompensator(m, samples=10**10)
    assert err.value.parameters == ("samples",)


def test_more_points_than_the_memory_can_compensate_at_once_are_refused(machines, monkeypatch):
    import volerr_pin.base._safeio as safeio

    monkeypatch.setattr(safeio, "available_memory", lambda: 1_000_000)
    m = machines["vmc500"]
    with pytest.raises(InputError, match=r"compensating 1,000 positions needs about 2.5 MB") as err:
        compensate_points(m, np.tile(m.mid_travel, (1000, 1)))
    assert err.value.parameters == ("q_desired",)
