"""Measurement readers: strict validation naming file, line and column."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

from volerr_pin.base import _safeio as safeio
from volerr_pin.measurements import MeasurementError, Table, read_any, read_runs
from volerr_pin.measurements._points import read_points

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


# ---------------------------------------------------------------- instrument layouts of runs

def _long_equivalent(tmp_path, rows, unit="um"):
    """The same run written in the long layout, read back: the reference for the others."""
    path = tmp_path / "long.csv"
    path.write_text(f"target_mm,cycle,direction,deviation_{unit}\n"
                    + "".join(f"{t},{c},{d},{v!r}\n" for t, c, d, v in rows))
    return read_runs(path)


def _same_run(a, b):
    order_a = np.lexsort((a.cycle, a.direction, a.target))
    order_b = np.lexsort((b.cycle, b.direction, b.target))
    for name in ("target", "cycle", "direction"):
        np.testing.assert_array_equal(getattr(a, name)[order_a], getattr(b, name)[order_b])
    np.testing.assert_allclose(a.value[order_a], b.value[order_b], rtol=0, atol=1e-15)


def test_wide_layout_of_measured_positions(tmp_path):
    """One row per target and direction, one column per cycle of measured positions (mm)."""
    path = tmp_path / "wide.csv"
    path.write_text("# axis: X\ndirection,i,target_mm,ref_c1,ref_c2,ref_c3\n"
                    "fwd,1,0.0,0.0012,0.0010,0.0011\nfwd,2,100.0,100.0031,100.0030,\n"
                    "bwd,1,0.0,-0.0008,-0.0009,-0.0010\nbwd,2,100.0,100.0021,100.0020,100.0022\n")
    wide = read_runs(path)
    assert wide.axis == "X" and wide.unused == ("i",) and len(wide.target) == 11   # an empty cell: not measured
    rows = [(0.0, c, 1, (x - 0.0) * 1e3) for c, x in zip((1, 2, 3), (0.0012, 0.0010, 0.0011))]
    rows += [(100.0, c, 1, (x - 100.0) * 1e3) for c, x in zip((1, 2), (100.0031, 100.0030))]
    rows += [(0.0, c, -1, (x - 0.0) * 1e3) for c, x in zip((1, 2, 3), (-0.0008, -0.0009, -0.0010))]
    rows += [(100.0, c, -1, (x - 100.0) * 1e3) for c, x in zip((1, 2, 3), (100.0021, 100.0020, 100.0022))]
    _same_run(wide, _long_equivalent(tmp_path, rows))
    assert wide.value[0] == pytest.approx(1.2e-6)          # 1.2 um, in SI
    assert list(wide.lines[:3]) == [3, 3, 3]               # every value keeps its line


def test_wide_layout_of_deviations_and_direction_words(tmp_path):
    path = tmp_path / "wide.csv"
    path.write_text("target_mm,direction,dev_c1_um,dev_c2_um\n10,up,1.5,1.7\n10,down,-0.5,-0.25\n")
    run = read_runs(path)
    _same_run(run, _long_equivalent(tmp_path, [(10, 1, 1, 1.5), (10, 2, 1, 1.7), (10, 1, -1, -0.5),
                                               (10, 2, -1, -0.25)]))


@pytest.mark.parametrize("text, match", [
    ("target_mm,direction,ref_c1\n10,sideways,10.001\n", r"wide.csv:2:2: .*'sideways' is not a direction"),
    ("target_mm,direction,ref_c1,ref_c2\n10,fwd,10.001,abc\n", r"wide.csv:2:4: .*'abc' is not a number"),
    ("target_mm,direction,ref_c1,dev_c2_um\n10,fwd,10.001,3\n", r"wide.csv:1: cycle columns must all"),
])
def test_malformed_wide_runs(tmp_path, text, match):
    (tmp_path / "wide.csv").write_text(text)
    with pytest.raises(MeasurementError, match=match):
        read_runs(tmp_path / "wide.csv")


DAT = """# a run as the logger writes it
UNIT=mm
CYCLES=2
POSITIONS=2
TGT_DATA[1]=-4
TGT_DATA[2]=4
REF_DATA_FWD[1,1]=-4.0012
REF_DATA_FWD[2,1]=4.0020
REF_DATA_FWD[1,2]=-4.0010
REF_DATA_FWD[2,2]=4.0022
REF_DATA_BWD[1,1]=-3.9990
REF_DATA_BWD[2,1]=4.0005
REF_DATA_BWD[1,2]=-3.9992
REF_DATA_BWD[2,2]=4.0004
"""


def test_key_value_layout(tmp_path):
    path = tmp_path / "run.dat"
    path.write_text(DAT)
    run = read_runs(path, axis="X")
    rows = [(-4.0, 1, 1, (-4.0012 + 4) * 1e3), (4.0, 1, 1, (4.0020 - 4) * 1e3), (-4.0, 2, 1, (-4.0010 + 4) * 1e3),
            (4.0, 2, 1, (4.0022 - 4) * 1e3), (-4.0, 1, -1, (-3.9990 + 4) * 1e3), (4.0, 1, -1, (4.0005 - 4) * 1e3),
            (-4.0, 2, -1, (-3.9992 + 4) * 1e3), (4.0, 2, -1, (4.0004 - 4) * 1e3)]
    _same_run(run, _long_equivalent(tmp_path, rows))
    assert run.axis == "X" and run.lines[0] == 7


@pytest.mark.parametrize("edit, match", [
    (lambda t: t.replace("CYCLES=2", "CYCLES=3"), r"run.dat:3: CYCLES=3 but the data hold 2"),
    (lambda t: t.replace("UNIT=mm\n", ""), r"run.dat: no UNIT= line"),
    (lambda t: t.replace("TGT_DATA[2]=4\n", ""), r"run.dat:\d+: REF_DATA_FWD\[2,1\]: no TGT_DATA\[2\]"),
    (lambda t: t + "REF_DATA_BWD[2,2]=4.1\n", r"run.dat:\d+: REF_DATA_BWD\[2,2\] given twice \(first on line 14\)"),
    (lambda t: t.replace("REF_DATA_BWD[1,1]=-3.9990", "REF_DATA_BWD[1,1]=x"), r"run.dat:11: .*'x' is not a number"),
    (lambda t: t + "just words\n", r"run.dat:15: expected KEY=VALUE"),
])
def test_malformed_key_value_runs(tmp_path, edit, match):
    (tmp_path / "run.dat").write_text(edit(DAT))
    with pytest.raises(MeasurementError, match=match):
        read_runs(tmp_path / "run.dat")


# ---------------------------------------------------------------- bad files (issue 22)

@pytest.mark.parametrize("text, match", [
    ("x,y,z,dx,dx_um\n1,2,3,4,5\n", r"d\.csv:1:5: columns 'dx' \(column 4\) and 'dx_um' are both dx; keep one"),
    ("x,y,z,x_mm,dx\n1,2,3,4,5\n", r"d\.csv:1:4: columns 'x' \(column 1\) and 'x_mm' are both x"),
    ("x,y,z,dx,T_a,T_a_degC\n1,2,3,4,20,21\n", r"d\.csv:1:6: columns 'T_a' \(column 5\) and 'T_a_degC' are both T_a"),
    ("x,y,z,dx,t,t_s\n1,2,3,4,0,0\n", r"d\.csv:1:6: columns 't' \(column 5\) and 't_s' are both t"),
    ("x,y,z,dx,dx\n1,2,3,4,5\n", r"d\.csv:1:5: duplicate column 'dx'"),
])
def test_a_column_given_twice_under_any_spelling_is_refused(tmp_path, machines, text, match):
    with pytest.raises(MeasurementError, match=match):
        read_points(write(tmp_path, text), machines["vmc500"])


@pytest.mark.parametrize("cell, message", [
    ("1_000", "'1_000' is not a number"), ("0x10", "'0x10' is not a number"),
    ("\u0663", "'.' is not a number"),                     # an Arabic-Indic three: float() would take it
    ("Infinity", "'Infinity' is not a finite number"), ("-inf", "'-inf' is not a finite number"),
    ("NaN", "'NaN' is not a finite number"), ("1e999", "'1e999' is not a finite number"),
])
def test_only_plain_decimal_numbers_are_read(tmp_path, machines, cell, message):
    with pytest.raises(MeasurementError, match=rf"d\.csv:2:4: column 'dx': {message}"):
        read_points(write(tmp_path, f"x,y,z,dx\n1,2,3,{cell}\n"), machines["vmc500"])


def test_number_syntax_that_is_read(tmp_path, machines):
    data = read_points(write(tmp_path, "x,y,z,dx\n 1 ,+2.,.5e1,-1E-1\n"), machines["vmc500"])
    np.testing.assert_allclose(data.q[0], [1e-3, 2e-3, 5e-3])
    assert data.values[0, 0] == pytest.approx(-0.1e-6)


@pytest.mark.parametrize("column, value, match", [
    ("dx", "1e300", r"column 'dx': 1e\+300 um is implausible: a deviation lies within \+-1e\+06 um"),
    ("dx", "-1000001", r"column 'dx': -1000001 um is implausible"),
    ("rx", "2e6", r"column 'rx': 2000000 urad is implausible: an angular deviation lies within \+-1e\+06 urad"),
    ("t", "1e11", r"column 't': 1e\+11 s is implausible: a time lies within \+-1e\+10 s"),
    ("T_spindle", "-300", r"column 'T_spindle': -300 degC is implausible: a temperature lies within -273\.15 \.\. 1000"),
    ("T_spindle", "1e300", r"column 'T_spindle': 1e\+300 degC is implausible"),
])
def test_implausible_values_name_file_line_and_column(tmp_path, machines, column, value, match):
    text = f"x,y,z,dx,{column}\n1,2,3,0.5,0\n1,2,3,0.5,{value}\n" if column != "dx" else \
        f"x,y,z,dx\n1,2,3,0.5\n1,2,3,{value}\n"
    col = 4 if column == "dx" else 5
    with pytest.raises(MeasurementError, match=rf"d\.csv:3:{col}: {match}"):
        read_points(write(tmp_path, text), machines["vmc500"])


def test_forces_beyond_ten_meganewton_are_refused(tmp_path, machines):
    with pytest.raises(MeasurementError, match=r"d\.csv:2:6: column 'Fy': -20000000 N is implausible"):
        read_points(write(tmp_path, "x,y,z,dx,Fx,Fy,Fz\n1,2,3,0,0,-2e7,0\n"), machines["vmc500"])


def test_values_just_inside_the_limits_are_read(tmp_path, machines):
    data = read_points(write(tmp_path, "x,y,z,dx,rx,t,T_a,Fx,Fy,Fz\n"
                                       "1,2,3,-999999,999999,1.7e9,-273.15,9.9e6,0,0\n"), machines["vmc500"])
    assert data.values[0, 0] == pytest.approx(-0.999999) and data.covariates["t"][0] == 1.7e9
    assert data.covariates["temperatures"]["a"][0] == -273.15


@pytest.mark.parametrize("content, match", [
    (b"x,y,z,dx\n1,2,3,1 # \xe9\n", r"d\.csv:2:11: not UTF-8 text \(byte 0xe9 at offset 19\); save the "
                                     r"measurement file as UTF-8"),
    (b"x,y,z,dx\n1,2,3,1\x00\n", r"d\.csv:2:8: a NUL byte; this is not a text file"),
    (b"", r"d\.csv: no header row"),
    (b"\xef\xbb\xbf# only comments\n\n", r"d\.csv: no header row"),
    (b"x,y,z,dx\r\n", r"d\.csv:1: no data rows after the header"),
])
def test_encodings_and_empty_files(tmp_path, machines, content, match):
    (tmp_path / "d.csv").write_bytes(content)
    with pytest.raises(MeasurementError, match=match):
        read_points(tmp_path / "d.csv", machines["vmc500"])


@pytest.mark.parametrize("content", [b"\xef\xbb\xbfx,y,z,dx\n1,2,3,1\n", b"x,y,z,dx\r\n1,2,3,1\r\n",
                                     b"x,y,z,dx\r1,2,3,1\r"])
def test_byte_order_mark_and_line_ends_are_read(tmp_path, machines, content):
    (tmp_path / "d.csv").write_bytes(content)
    data = read_points(tmp_path / "d.csv", machines["vmc500"])
    assert data.values[0, 0] == pytest.approx(1e-6) and list(data.lines) == [2]


def test_folders_pipes_and_files_larger_than_memory_are_refused(tmp_path, machines, monkeypatch):
    with pytest.raises(MeasurementError, match=r": is a folder, not a measurement file"):
        read_any(tmp_path, machines["vmc500"])
    os.mkfifo(tmp_path / "pipe.csv")         # reading it would wait for a writer forever
    with pytest.raises(MeasurementError, match=r"pipe\.csv: not a regular file"):
        read_any(tmp_path / "pipe.csv", machines["vmc500"])
    path = write(tmp_path, POINTS)
    monkeypatch.setattr(safeio, "available_memory", lambda: 2_000)
    with pytest.raises(MeasurementError, match=r"d\.csv: reading this measurement file of \d+ bytes needs about "
                                               r".* more than this machine can spare"):
        read_any(path, machines["vmc500"])


@pytest.mark.parametrize("text, match", [
    ("# axis: X\n# axis: Y\ntarget_mm,cycle,direction,deviation_um\n0,1,1,0\n",
     r"d\.csv:2: '# axis:' is given twice \(first on line 1\)"),
    ("target_mm,cycle,direction,deviation_um\n# at: Y=100\n0,1,1,0\n",
     r"d\.csv:2: '# at:' comes after the header row \(line 1\); metadata lines go before it"),
    ("# at: Y=1, Y=2\ntarget_mm,cycle,direction,deviation_um\n0,1,1,0\n", r"axis Y is given twice"),
    ("# at: Y=nan\ntarget_mm,cycle,direction,deviation_um\n0,1,1,0\n", r"'Y=nan' is not AXIS=VALUE: 'nan' is not a finite"),
])
def test_metadata_lines_count_once_and_before_the_header(tmp_path, text, match):
    with pytest.raises(MeasurementError, match=match):
        read_runs(write(tmp_path, text))


RUN = "target_mm,cycle,direction,deviation_um\n" + "".join(
    f"{t},{c},{d},{0.1 * c + 0.01 * t}\n" for t in (0, 100) for c in range(1, 6) for d in (1, -1))


@pytest.mark.parametrize("text, match", [
    (RUN + "0,5,1,3.0\n", r"d\.csv:22: target 0 mm, cycle 5, direction \+1 is given twice \(first on line 10\); "
                          "one approach per target, cycle and direction"),
    (RUN + "1e-12,5,-1,3.0\n", r"d\.csv:22: target 0 mm, cycle 5, direction -1 is given twice \(first on line 11\)"),
    ("target_mm,cycle,run,direction,deviation_um\n0,1,1,1,0\n",
     r"d\.csv:1:3: columns 'cycle' and 'run' are both the cycle; keep one"),
    ("target_mm,cycle,direction,deviation_um\n0,-1,1,0\n", r"d\.csv:2:2: column 'cycle': cycle numbers are integers "
                                                          r"from 0 to 1,000,000, got -1"),
    ("target_mm,cycle,direction,deviation_um\n0,1e300,1,0\n", r"d\.csv:2:2: .*got 1e300"),
    ("target_mm,cycle,direction,deviation_um\n0,1,1,1e300\n",
     r"d\.csv:2:4: column 'deviation_um': 1e\+300 um is implausible: a deviation lies within \+-1e\+06 um"),
    ("target_mm,cycle,direction,deviation_um\n2e6,1,1,1\n", r"d\.csv:2:1: column 'target_mm': 2000000 mm is implausible"),
    ("target_deg,cycle,direction,deviation_arcsec\n0,1,1,3e5\n",
     r"d\.csv:2:4: column 'deviation_arcsec': 300000 arcsec is implausible: an angular deviation lies within "
     r"\+-206265 arcsec"),
    ("target_mm,cycle,direction,EYX_mm\n0,1,1,1500\n", r"d\.csv:2:4: column 'EYX_mm': 1500 mm is implausible"),
])
def test_repeated_approaches_and_implausible_runs_are_refused(tmp_path, text, match):
    with pytest.raises(MeasurementError, match=match):
        read_runs(write(tmp_path, text))


@pytest.mark.parametrize("text, match", [
    ("target_mm,direction,ref_c1\n10,fwd,10.001\n10,fwd,10.002\n",
     r"wide\.csv:3: target 10 mm, cycle 1, direction \+1 is given twice \(first on line 2\)"),
    ("target_mm,direction,ref_c1,cycle1\n10,fwd,10.001,10.002\n", r"wide\.csv:1:4: columns 'ref_c1' and 'cycle1' "
                                                                  "are both cycle 1"),
    ("target_mm,direction,ref_c1\n10,fwd,1e300\n", r"wide\.csv:2:3: column 'ref_c1': 1e\+300 mm is implausible"),
    ("target_mm,direction,ref_c1\n10,fwd,1200\n", r"wide\.csv:2:3: column 'ref_c1': the deviation 1190000 um "
                                                  r"\(measured minus target\) is implausible"),
    ("target_deg,direction,ref_c1\n0,fwd,359.999\n", r"wide\.csv:2:3: .*the deviation 1295996\.4 arcsec"),
    ("target_mm,direction,dev_c1_um\n10,fwd,5e6\n", r"wide\.csv:2:3: column 'dev_c1_um': 5000000 um is implausible"),
    ("target_mm,direction,dir,ref_c1\n10,fwd,bwd,10.001\n",
     r"wide\.csv:1:3: columns 'direction' and 'dir' are both the direction"),
])
def test_wide_runs_refuse_repeats_and_implausible_values(tmp_path, text, match):
    (tmp_path / "wide.csv").write_text(text)
    with pytest.raises(MeasurementError, match=match):
        read_runs(tmp_path / "wide.csv")


@pytest.mark.parametrize("edit, match", [
    (lambda t: t.replace("UNIT=mm\n", "UNIT=mm\nUNIT=deg\n"), r"run\.dat:3: UNIT given twice \(first on line 2\)"),
    (lambda t: t.replace("CYCLES=2", "CYCLES=2.5"), r"run\.dat:3: CYCLES=2\.5 but the data hold 2"),
    (lambda t: t.replace("TGT_DATA[2]=4", "TGT_DATA[2]=-4").replace("POSITIONS=2\n", ""),
     r"run\.dat:\d+: target -4 mm, cycle 1, direction \+1 is given twice \(first on line \d+\)"),
    (lambda t: t.replace("TGT_DATA[2]=4", "TGT_DATA[2,1]=4"), r"run\.dat:6: TGT_DATA needs one index \[target\]"),
    (lambda t: t.replace("REF_DATA_FWD[1,1]=-4.0012", "REF_DATA_FWD[1,1]=1e300"),
     r"run\.dat:7: REF_DATA_FWD\[1,1\] = 1e\+300 mm is implausible: a position lies within \+-1e\+06 mm"),
    (lambda t: t.replace("REF_DATA_FWD[1,1]=-4.0012", "REF_DATA_FWD[1,1]=2000"),
     r"run\.dat:7: REF_DATA_FWD\[1,1\]: the deviation 2004000 um is implausible"),
    (lambda t: t.replace("REF_DATA_FWD[1,1]=-4.0012", "REF_DATA_FWD[1,1]=inf"), r"run\.dat:7: .*'inf' is not a finite"),
    (lambda t: "# axis: X\n# axis: Y\n" + t, r"run\.dat:2: '# axis:' is given twice"),
])
def test_key_value_runs_refuse_repeats_and_implausible_values(tmp_path, edit, match):
    (tmp_path / "run.dat").write_text(edit(DAT))
    with pytest.raises(MeasurementError, match=match):
        read_runs(tmp_path / "run.dat")


def test_the_axis_given_and_the_files_own_must_agree(tmp_path):
    path = write(tmp_path, "# axis: X\n# at: Y=200, Z=200\n" + RUN)
    assert read_runs(path, axis="X").axis == "X"
    with pytest.raises(MeasurementError, match=r"^axis Y is not the run's own: .*d\.csv says '# axis: X'$") as err:
        read_runs(path, axis="Y")
    assert err.value.parameters == ("axis",)
    with pytest.raises(MeasurementError, match=r"d\.csv: header '# at: X=100, Y=200' gives X=100, but X is the axis "
                                               "that moves in this run"):
        read_runs(write(tmp_path, "# axis: X\n# at: X=100, Y=200\n" + RUN))


@pytest.mark.parametrize("row, match", [
    ('1,2,3,"1\n', r"d\.csv:2: not a comma-separated row \(unexpected end of data\)"),
    ("1,2,3," + "1" * 200_000 + "\n", r"d\.csv:2: not a comma-separated row \(field larger than field limit"),
])
def test_rows_the_csv_module_cannot_read_are_one_error(tmp_path, machines, row, match):
    with pytest.raises(MeasurementError, match=match):
        read_points(write(tmp_path, "x,y,z,dx\n" + row), machines["vmc500"])


def test_a_header_of_many_columns_is_checked_in_linear_time(tmp_path, machines):
    """A million-column header took hours (duplicates were counted pairwise); 100,000 now take
    well under a second, and the repeated last name is still found."""
    names = ",".join(f"c{i}" for i in range(100_000))
    with pytest.raises(MeasurementError, match=r"d\.csv:1:100005: duplicate column 'c0'"):
        read_points(write(tmp_path, f"x,y,z,dx,{names},c0\n"), machines["vmc500"])


def test_identify_on_a_deviation_of_1e300_writes_nothing_and_names_the_cell(tmp_path, capsys):
    """Issue 22: one deviation of 1e300 um gave a spec with a coefficient of 1e296."""
    from volerr_pin.cli import main

    rows = "".join(f"{x},{y},{z},0.5,0.2,-0.1\n" for x, y, z in ((100, 100, 100), (400, 300, 50), (250, 50, 350),
                                                                   (50, 350, 200)))
    path = write(tmp_path, "x,y,z,dx,dy,dz\n" + rows + "300,200,100,1e300,0,0\n")
    out = tmp_path / "fitted.toml"
    assert main(["identify", "vmc500", str(path), "--folds", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(r"d\.csv:6:4: column 'dx': 1e\+300 um is implausible", err)
    assert not out.exists()


def test_the_documented_plausibility_limits_are_the_ones_applied():
    """docs/measurements.md states each limit; a change of one without the other fails here."""
    from pathlib import Path

    from volerr_pin.base import DEG, PLAUSIBLE

    doc = (Path(__file__).resolve().parents[2] / "docs" / "measurements.md").read_text()
    section = doc[doc.index("### Plausibility limits"):doc.index("## Point measurements")]
    stated = {"error_length": ("1 m (1e6 um)", 1.0), "error_angle": ("1 rad (206,265 arcsec)", 1.0),
              "position_length": ("1 km (1e6 mm)", 1e3), "position_angle": ("1e7 deg", 1e7 * DEG),
              "time": ("1e10 s", 1e10), "force": ("10 MN (1e7 N)", 1e7), "reading": ("| 1e15 |", 1e15)}
    for kind, (text, limit) in stated.items():
        assert text in section, text
        assert PLAUSIBLE[kind] == (-limit, limit), kind
    assert "below -273.15 degC or above 1000 degC" in section and PLAUSIBLE["temperature"] == (-273.15, 1000.0)


@pytest.mark.parametrize("cell", ["1", " -2.5 ", "+.5e-3", "1.", "1E+05", "007", "", " ", "nan", "-Infinity", "1e999",
                                  "1_0", "0x10", "\u0663", "1e", ".", "+", "1 2", "\t3\t"])
@pytest.mark.parametrize("allow_empty", [False, True])
def test_a_column_reads_each_cell_as_the_cell_reader_does(cell, allow_empty):
    """Table.column's fast path (float() on a whole column) and Table.number agree on every
    spelling: the same value, or the same error."""
    table = Table("t.csv", ["a"], 1, [["4"], [cell], ["5"]], [2, 3, 4])
    try:
        expected = table.number(1, 0, allow_empty)
    except MeasurementError as err:
        with pytest.raises(MeasurementError, match=re.escape(str(err))):
            table.column(0, allow_empty)
    else:
        got = table.column(0, allow_empty)[1]
        assert got == expected or (np.isnan(got) and np.isnan(expected))
