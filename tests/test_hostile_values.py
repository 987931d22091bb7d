"""Issue 44, the third adversarial pass: every value is checked as a spec's values are, whatever
way it comes in - tolerance files, reports read back, measurement columns, URDF numbers, options
and the Python API - by the spec's rules: one value under one key, units named and known,
magnitudes within sense, sizes before allocation.

The cases run through the oracle of the second pass (``tests/test_hostile.py``: no traceback,
exit 0 or 2 with one line naming the culprit, nothing created or changed on a refusal). They
grow by kind, not by instance: ``key-`` one value under one key, ``unit-`` units named and known,
``sense-`` magnitudes within sense, ``size-`` sizes before allocation, ``series-`` time series.
"""

from __future__ import annotations

import pytest

from test_hostile import OK, Case, _marks, _with_paths, example, judge, run_in_process

TOLERANCES = "default_um = 1\ndefault_arcsec = 1\n"


def points(temperature_column: str, values=(21.0, 22.0, 23.0, 24.0)) -> str:
    """A point measurement of vmc500 with one temperature column."""
    rows = [f"{100 + 50 * i},{80 + 40 * i},{50 + 30 * i},0.1,0.2,-0.1,{v}" for i, v in enumerate(values)]
    return "\n".join([f"x,y,z,dx,dy,dz,{temperature_column}", *rows]) + "\n"


CASES = [
    # --- one value under one key -------------------------------------------------------------
    Case("key-tolerance-component-under-two-units", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": "EXX_um = 5\nEXX_mm = 0.5\n" + TOLERANCES}, ("t.toml", "EXX_um", "EXX_mm")),
    Case("key-rank-tolerance-component-under-two-units", "rank vmc500 --points 16 --tolerances t.toml",
         {"t.toml": "EXX_um = 5\nEXX_mm = 0.5\n" + TOLERANCES}, ("t.toml", "EXX_um", "EXX_mm")),
    Case("key-tolerance-default-under-two-units", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": "default_um = 1\ndefault_mm = 0.001\ndefault_arcsec = 1\n"},
         ("t.toml", "default_um", "default_mm")),
    Case("key-tolerance-angle-default-under-two-units", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": "default_um = 1\ndefault_arcsec = 1\ndefault_deg = 10\n"},
         ("t.toml", "default_arcsec", "default_deg")),
    Case("key-tolerance-entry-table-and-number", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": 'EXX_um = { value = 2, distribution = "normal" }\nEXX_mm = 0.001\n' + TOLERANCES},
         ("t.toml", "EXX_um", "EXX_mm")),
    # --- units named and known ----------------------------------------------------------------
    Case("unit-temperature-in-fahrenheit-spelled-F", "identify vmc500 m.csv --terms T_spindle",
         {"m.csv": points("T_spindle_F", (70.0, 71.0, 72.0, 73.0))}, ("'T_spindle_F'",)),
    Case("unit-temperature-in-kelvin-spelled-out", "identify vmc500 m.csv",
         {"m.csv": points("T_spindle_kelvin", (295.0, 296.0, 297.0, 298.0))}, ("'T_spindle_kelvin'",)),
    Case("unit-temperature-in-lower-case-degc", "identify vmc500 m.csv",
         {"m.csv": points("T_spindle_degc")}, ("'T_spindle_degc'",)),
    Case("unit-temperature-in-a-length", "identify vmc500 m.csv",
         {"m.csv": points("T_spindle_mm")}, ("'T_spindle_mm'",)),
    Case("unit-temperature-below-absolute-zero-in-kelvin", "identify vmc500 m.csv",
         {"m.csv": points("T_spindle_K", (295.0, -1.0, 297.0, 298.0))}, ("m.csv:3:7",)),
    Case("unit-temperature-sensor-in-kelvin-taken", "identify vmc500 m.csv",
         {"m.csv": points("T_spindle_K", (295.0, 296.0, 297.0, 298.0))}, expect=OK),
    # --- magnitudes within sense ---------------------------------------------------------------
    Case("sense-tolerance-overflowing", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": "EXX_um = 1e300\n" + TOLERANCES}, ("t.toml", "EXX_um")),
    Case("sense-tolerance-a-kilometre", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": "EXX_m = 1000\n" + TOLERANCES}, ("t.toml", "EXX_m")),
    Case("sense-tolerance-three-radians", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": "EAX_rad = 3\n" + TOLERANCES}, ("t.toml", "EAX_rad")),
    Case("sense-tolerance-900-m-in-mm", "tolerance vmc500 --tolerances t.toml --samples 64",
         {"t.toml": "EXX_mm = 900000\n" + TOLERANCES}, ("t.toml", "EXX_mm")),
    Case("sense-rank-tolerance-overflowing", "rank vmc500 --points 16 --tolerances t.toml",
         {"t.toml": "EXX_um = 1e300\n" + TOLERANCES}, ("t.toml", "EXX_um")),
]


@pytest.mark.parametrize("case", [c.param(*_marks(c)) for c in CASES])
def test_hostile_values_cli(case, tmp_path, capfd, monkeypatch):
    folder = tmp_path / "case"
    folder.mkdir()
    case = _with_paths(case, folder)
    judge(case, folder, *run_in_process(case, folder, capfd, monkeypatch))


def test_every_case_has_a_kind():
    kinds = ("key-", "unit-", "sense-", "size-", "series-")
    assert all(c.id.startswith(kinds) for c in CASES)
    assert len({c.id for c in CASES}) == len(CASES)
