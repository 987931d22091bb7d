"""Compensation evaluates the model through its algorithms (issue 59): while points, paths, NC
programs, error maps and controller tables are compensated, no module of
``volerr_pin.compensation`` calls a checking method of :class:`~volerr_pin.model.Machine`
(each of which checks its inputs again, O(N), on every call of a loop). The user's positions
are checked once where they enter; the work inside calls ``volerr_pin.model``'s algorithms.

Every checking method is wrapped on the class; a call is recorded when the frame that makes it
is a module under ``volerr_pin.compensation`` (a user's own call, or one from another layer, is
not this test's business)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.compensation import (ErrorMap, PathCompensator, arc_from_center, axis_tables, compensate_points,
                                     compensation_table, evaluate_compensation)
from volerr_pin.compensation.export import export_tables, parse_zone
from volerr_pin.model import add_terms

from conftest import random_q, record_checking_calls

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "examples" / "data"

PACKAGE = "volerr_pin.compensation"


@pytest.fixture
def recorded(monkeypatch):
    """The calls of checking Machine methods made from compensation's modules: (method, module,
    function, line)."""
    return record_checking_calls(monkeypatch, PACKAGE)


def _unexpected(calls):
    return sorted({f"{module}.{function} (line {line}) calls Machine.{name}" for name, module, function, line in calls})


def test_the_wrapper_records_a_call_from_compensation(recorded):
    """The test can fail: a call made from a compensation module is seen."""
    m = vp.load_machine("vmc500")
    namespace = {"__name__": f"{PACKAGE}.probe", "m": m}
    exec("m.volumetric_error(m.mid_travel)", namespace)
    m.tool_poses(m.mid_travel[None, :])          # from here: not compensation's
    assert [(module, name) for name, module, _, _ in recorded] == [(f"{PACKAGE}.probe", "volumetric_error")]


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_point_compensation_calls_the_algorithms(recorded, machines, name):
    m = machines[name]
    q = random_q(m, 40, seed=3)
    compensate_points(m, q)
    evaluate_compensation(m, q, tol_um=0.001)
    if name == "vmc500":   # seed 002's recursion (on machines of three linear axes)
        compensate_points(m, q, method="recursive")
    assert not _unexpected(recorded)


def test_point_compensation_in_a_state_calls_the_algorithms(recorded, machines):
    m = add_terms(machines["vmc500"], {
        "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h", "amplitudes_um": [6.0],
                "time_constants_min": [50.0]},
        "EYY": {"kind": "backlash", "prefix": "h", "reversal_um": 4.0}}).with_state(t=600.0, directions=[1, -1, 1])
    q = random_q(m, 30, seed=4)
    for method in ("newton", "recursive"):
        compensate_points(m, q, method=method, t=np.linspace(0.0, 3600.0, 30))
    comp = PathCompensator(m, tol_um=0.5)
    comp.line(q[0], q[1])
    comp.points(q[:5])
    assert not _unexpected(recorded)


def test_path_compensation_calls_the_algorithms(recorded, machines):
    m = machines["vmc700"]
    comp = PathCompensator(m, tol_um=1.0)
    comp.line(np.array([0.010, 0.010, 0.010]), np.array([0.680, 0.240, 0.190]))
    start, end = np.array([0.5, 0.01, 0.05]), np.array([0.1, 0.03, 0.15])
    comp.arc(arc_from_center(start, end, np.array([0.3, 0.02]), (0, 1, 2), clockwise=False))
    comp.rapid(start, end)
    assert not _unexpected(recorded)


@pytest.mark.parametrize("argv", [
    ["vmc700", "part.nc"],
    ["vmc500", "vmc500_testpiece.nc", "--tol-um", "0.5"],
    ["cgm4000", "cgm4000_cone.nc"],
    ["cgm4000", "cgm4000_cone.nc", "--programming", "tool-tip"],
    ["cgm4000", "cgm4000_cone.nc", "--method", "recursive"],
], ids=["part", "testpiece", "cone", "cone-tool-tip", "cone-recursive"])
def test_nc_compensation_calls_the_algorithms(recorded, tmp_path, argv):
    machine, program, *options = argv
    assert main(["compensate", machine, str(DATA / program), "-o", str(tmp_path / "out.nc"),
                 "--report", str(tmp_path / "report.json"), *options]) == 0
    assert not _unexpected(recorded)


def test_the_nc_reader_calls_the_algorithms_too(recorded, tmp_path):
    """A five-axis program: the reader's rounding levers (the nominal axis Jacobian) included."""
    assert main(["compensate", "cgm4000", str(DATA / "cgm4000_cone.nc"), "-o", str(tmp_path / "out.nc")]) == 0
    assert not _unexpected(recorded)


def test_error_maps_and_compensation_tables_call_the_algorithms(recorded, machines, tmp_path):
    m = machines["vmc500"].with_state(t=60.0)
    emap = ErrorMap.build(m, (2, 2, 2), 2)
    emap.interpolation_error(200)
    emap.interpolate(m.mid_travel[None, :])
    compensation_table(m, tmp_path / "table.csv", (3, 3, 3))
    axis_tables(m, tmp_path / "axes", points=5)
    assert main(["errormap", "vmc500", "--elements", "2", "--order", "1", "--points", "100", "--table",
                 str(tmp_path / "t.csv"), "--nodes", "3", "--axis-tables", str(tmp_path / "at"), "--json"]) == 0
    assert not _unexpected(recorded)


@pytest.mark.parametrize("machine, controller", [("vmc500", "linuxcnc"), ("cgm4000", "isg")])
def test_exports_call_the_algorithms(recorded, tmp_path, machine, controller):
    assert main(["export", machine, "--controller", controller, "-o", str(tmp_path / "out"), "--points", "256",
                 "--json"]) == 0
    assert not _unexpected(recorded)


def test_exports_of_a_machine_in_a_state_call_the_algorithms(recorded, machines):
    m = add_terms(machines["vmc500"], {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 5.0},
                                       "EZZ": {"kind": "thermal_drift", "driver": "time", "prefix": "h",
                                               "amplitudes_um": [6.0], "time_constants_min": [50.0]}})
    m = m.with_state(t=1800.0)
    for controller in ("heidenhain", "siemens-840d", "fanuc", "isg"):
        export_tables(m, controller, points=128, zone=parse_zone(m, ["X=100:300", "tool=0:50"]))
    assert not _unexpected(recorded)
