"""Measurement readers: strict validation naming file, line and column."""

from __future__ import annotations

import numpy as np
import pytest

from volerr_pin.measurements import MeasurementError, read_any, read_points, read_runs

POINTS = """# tracker data, vmc500
x,y,z,dx,dy,dz,rx,t,T_spindle,Fx,Fy,Fz,dir_x,operator
100,50,20,1.5,-0.5,0.25,,0,20.5,0,0,0,1,ann
200.5,100,30,2.0,0.0,-1.0,3.0,60,21.0,10,0,-5,-1,ann
"""


def write(tmp_path, text, name="d.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_points_are_read_in_si_with_covariates(tmp_path, machines):
    data = read_points(write(tmp_path, POINTS), machines["vmc500"])
    np.testing.assert_allclose(data.q, [[0.1, 0.05, 0.02], [0.2005, 0.1, 0.03]])
    np.testing.assert_allclose(data.values[:, :3], [[1.5e-6, -0.5e-6, 0.25e-6], [2e-6, 0, -1e-6]])
    assert np.isnan(data.values[0, 3]) and data.values[1, 3] == pytest.approx(3e-6)
    assert np.all(np.isnan(data.values[:, 4:]))
    np.testing.assert_array_equal(data.covariates["t"], [0, 60])
    np.testing.assert_array_equal(data.covariates["temperatures"]["spindle"], [20.5, 21.0])
    np.testing.assert_array_equal(data.covariates["forces"][1], [10, 0, -5])
    np.testing.assert_array_equal(data.covariates["directions"][:, 0], [1, -1])
    assert data.unused == ("operator",)  # reported, not dropped silently
    np.testing.assert_array_equal(data.lines, [3, 4])


def test_columns_may_carry_their_units(tmp_path, machines):
    data = read_points(write(tmp_path, "x_mm,y_mm,z_mm,dz_um\n1,2,3,0.5\n"), machines["vmc500"])
    assert data.values[0, 2] == pytest.approx(0.5e-6)
    with pytest.raises(MeasurementError, match=r"d\.csv:1:4: column 'dz_mm': unit 'mm' is not the file unit 'um'"):
        read_points(write(tmp_path, "x_mm,y_mm,z_mm,dz_mm\n1,2,3,0.5\n"), machines["vmc500"])


@pytest.mark.parametrize("text,match", [
    ("x,y,z,dx\n1,2,3,abc\n", r"d\.csv:2:4: column 'dx': 'abc' is not a number"),
    ("x,y,z,dx\n1,2,3,nan\n", r"d\.csv:2:4: column 'dx': 'nan' is not a finite number"),
    ("x,y,z,dx\n1,2,3\n", r"d\.csv:2:4: 3 values but the header has 4 columns"),
    ("# c\nx,y,z,dx\n1,2,3,0\n600,2,3,0\n", r"d\.csv:4:1: x = 600 mm is outside the travel of X \[0, 500\] mm"),
    ("x,y,dx\n1,2,3\n", r"d\.csv:1: missing position column 'z' for axis Z \(mm\)"),
    ("x,y,z,T_a\n1,2,3,20\n", r"d\.csv:1: no deviation column"),
    ("x,y,z,dx,dir_y\n1,2,3,0,0\n", r"d\.csv:2:5: column 'dir_y': direction must be \+1 or -1, got 0"),
    ("x,y,z,dx,dy\n1,2,3,,\n", r"d\.csv:2: row has no measured deviation"),
    ("x,y,z,dx,Fx\n1,2,3,0,5\n", r"force columns need all of Fx, Fy, Fz \(missing Fy, Fz\)"),
    ("x,y,x,dx\n1,2,3,0\n", r"d\.csv:1:3: duplicate column 'x'"),
    ("# only a comment\n", r"d\.csv: no header row"),
    ("x,y,z,dx\n", r"d\.csv:1: no data rows"),
])
def test_malformed_point_files(tmp_path, machines, text, match):
    with pytest.raises(MeasurementError, match=match):
        read_points(write(tmp_path, text), machines["vmc500"])


def test_positioning_run_and_metadata(tmp_path):
    path = write(tmp_path, "# axis: X\n# at: Y=100, Z=50\ntarget_mm,cycle,direction,deviation_um\n"
                           "0,1,1,0.5\n100,1,-1,1.5\n")
    runs = read_runs(path)
    assert runs.axis == "X" and runs.component is None and runs.at == {"Y": 100.0, "Z": 50.0}
    np.testing.assert_allclose(runs.target, [0.0, 0.1])
    np.testing.assert_allclose(runs.value, [0.5e-6, 1.5e-6])
    np.testing.assert_array_equal(runs.direction, [1, -1])


def test_component_run(tmp_path):
    runs = read_runs(write(tmp_path, "target_mm,run,direction,EBX_arcsec\n0,1,1,2\n100,1,1,3\n"))
    assert runs.component == "EBX" and runs.axis == "X" and runs.unit == "arcsec"
    assert runs.value[1] == pytest.approx(3 * np.pi / 180 / 3600)


@pytest.mark.parametrize("text,match", [
    ("cycle,direction,deviation_um\n1,1,0\n", r"needs exactly one of the columns target_mm"),
    ("target_mm,cycle,direction,deviation_um,EYX_um\n0,1,1,0,0\n", r"exactly one value column"),
    ("target_mm,cycle,direction,deviation_arcsec\n0,1,1,0\n", r"gives its deviation in um, not arcsec"),
    ("target_mm,cycle,direction,EBX_um\n0,1,1,0\n", r"EBX is an angle; unit 'um' does not fit"),
    ("target_mm,cycle,direction,deviation_um\n0,1,2,0\n", r"d\.csv:2:3: column 'direction': must be \+1 or -1"),
    ("target_mm,cycle,direction,deviation_um\n0,1.5,1,0\n", r"d\.csv:2:2: column 'cycle': cycle numbers are integers"),
    ("target_mm,direction,deviation_um\n0,1,0\n", r"missing column 'cycle'"),
    ("# axis: Y\ntarget_mm,cycle,direction,EYX_um\n0,1,1,0\n", r"belongs to axis X, but the run is along Y"),
])
def test_malformed_runs(tmp_path, text, match):
    with pytest.raises(MeasurementError, match=match):
        read_runs(write(tmp_path, text))


def test_read_any_tells_kinds_apart(tmp_path, machines):
    assert read_any(write(tmp_path, POINTS, "p.csv"), machines["vmc500"]).q.shape == (2, 3)
    runs = read_any(write(tmp_path, "target_deg,cycle,direction,deviation_arcsec\n0,1,1,1\n", "r.csv"))
    assert runs.target_unit == "deg"
    with pytest.raises(MeasurementError, match="cannot read"):
        read_any(tmp_path / "missing.csv", machines["vmc500"])
