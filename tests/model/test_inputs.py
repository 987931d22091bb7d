"""Bad arguments to the public functions raise the project's InputError naming the culprit."""

from __future__ import annotations

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.applications.thermal import GM11, GM1N, feed_axis_six_point, spindle_five_point
from volerr_pin.base import parse_axis_values


def test_wrong_shape(machines):
    m = machines["vmc500"]
    with pytest.raises(vp.InputError, match=r"q has shape \(4, 2\); expected \(N, 3\) with columns X, Y, Z"):
        m.volumetric_error(np.zeros((4, 2)))


def test_nan_is_named(machines):
    m = machines["vmc500"]
    q = np.full((3, 3), 0.1)
    q[2, 1] = np.nan
    with pytest.raises(vp.InputError, match=r"q\[2, 1\] \(axis Y\) is nan"):
        m.volumetric_error(q)


def test_outside_travel_is_an_error_unless_asked(machines):
    m = machines["vmc500"]
    q = np.array([[0.1, 0.1, 0.1], [0.52, 0.1, 0.1]])
    with pytest.raises(vp.InputError, match=r"q\[1, 0\] = 0\.52 m is outside the travel of axis X \[0, 0\.5\] m"):
        m.volumetric_error(q)
    out = m.volumetric_error(q, extrapolate=True)
    assert out.shape == (2, 6) and np.all(np.isfinite(out))


def test_single_point_gives_single_row(machines):
    m = machines["vmc500"]
    assert m.volumetric_error([0.1, 0.2, 0.3]).shape == (6,)


def test_theta_shape_and_nan(machines):
    m = machines["vmc500"]
    with pytest.raises(vp.InputError, match=r"theta has shape \(3,\); expected \(67,\)"):
        m.volumetric_error([[0.1, 0.1, 0.1]], np.zeros(3))
    theta = m.theta
    theta[5] = np.inf
    with pytest.raises(vp.InputError, match=r"theta\[5\] \(EXX\.n5\) is inf"):
        m.volumetric_error([[0.1, 0.1, 0.1]], theta)


def test_covariates_are_checked(machines):
    m = machines["vmc500"]
    q = np.full((2, 3), 0.1)
    with pytest.raises(vp.InputError, match="unknown covariate"):
        m.volumetric_error(q, temperature={"spindle": [20.0, 21.0]})
    with pytest.raises(vp.InputError, match=r"covariate 't' has shape \(3,\); expected \(2,\)"):
        m.volumetric_error(q, t=[0.0, 1.0, 2.0])
    with pytest.raises(vp.InputError, match="only \\+1 and -1"):
        m.volumetric_error(q, directions=[[1, 0, 1], [1, 1, 1]])
    ok = m.volumetric_error(q, t=[0.0, 1.0], temperatures={"spindle": [20.0, 21.0]},
                            forces=np.zeros((2, 3)), directions=[[1, -1, 1], [1, 1, -1]])
    np.testing.assert_array_equal(ok, m.volumetric_error(q))


def test_order_is_checked(machines):
    with pytest.raises(vp.InputError, match="order must be None"):
        machines["vmc500"].volumetric_error([[0.1, 0.1, 0.1]], order=2)


def test_machine_is_immutable(machines):
    m = machines["vmc500"]
    theta = m.theta
    theta[:] = 0
    assert np.any(m.theta != 0)
    with pytest.raises(ValueError):
        m._theta[0] = 1.0
    other = m.with_theta(np.zeros_like(theta))
    assert np.all(other.theta == 0) and np.any(m.theta != 0)
    assert np.abs(other.volumetric_error([[0.1, 0.2, 0.3]])).max() == 0.0


@pytest.mark.parametrize("call, match", [
    (lambda: spindle_five_point(0, 0, 0, 0, 0, np.inf, 0.05, 0.04), r"finite l1 > 0, l2 > 0 and l >= 0"),
    (lambda: spindle_five_point([0, np.nan], 0, 0, 0, 0, 0.1, 0.05, 0.04), r"s1 holds a value that is not a finite"),
    (lambda: feed_axis_six_point(0, 0, np.inf, 0, 0, 0), r"s8 holds a value that is not a finite number"),
    (lambda: GM11.fit([1.0, 2.0, np.nan, 4.0, 5.0]), r"x0 holds a value that is not a finite number"),
    (lambda: GM1N.fit(np.arange(1.0, 9.0), np.arange(8.0), lam=1.5), r"lam must be in \[0, 1\], got 1\.5"),
])
def test_thermal_methods_refuse_non_finite_input(call, match):
    with pytest.raises(vp.InputError, match=match) as err:
        call()
    assert err.value.parameters


@pytest.mark.parametrize("text, match", [
    ("X=1, X=2", r"here: axis X is given twice"),
    ("X=nan", r"here: 'X=nan' is not AXIS=VALUE: 'nan' is not a finite number"),
    ("X=1e999", r"'1e999' is not a finite number"),
    ("X=1_0", r"'1_0' is not a number"),
    ("X", r"here: 'X' is not AXIS=VALUE"),
])
def test_axis_value_lists_are_strict(text, match):
    with pytest.raises(vp.InputError, match=match):
        parse_axis_values(text, "here", ("X", "Y"))
    assert parse_axis_values(" X=1.5,Y=-2e1 ", "here") == {"X": 1.5, "Y": -20.0}
