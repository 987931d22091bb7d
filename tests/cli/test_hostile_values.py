"""Issue 44, the third adversarial pass: every value is checked as a spec's values are, whatever
way it comes in - tolerance files, reports read back, measurement columns, URDF numbers, options
and the Python API - by the spec's rules: one value under one key, units named and known,
magnitudes within sense, sizes before allocation.

The cases run through the oracle of the second pass (``tests/cli/test_hostile.py``: no traceback,
exit 0 or 2 with one line naming the culprit, nothing created or changed on a refusal). They
grow by kind, not by instance: ``key-`` one value under one key, ``unit-`` units named and known,
``sense-`` magnitudes within sense, ``size-`` sizes before allocation, ``series-`` time series.
"""

from __future__ import annotations

import numpy as np
import pytest

import volerr_pin as vp

from test_hostile import (FIELD, OK, Case, _marks, _with_paths, judge, machine_files, replace, run_in_process,
                          slide_urdf)

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
    # --- reports read back: one value under one key, of this machine --------------------------
    Case("key-report-duplicate-key", "uncertainty vmc500 --from id.json --samples 64 --grid 2 2 2",
         {"id.json": '{"parameters": {"EXX.n0": {"value": 506, "uncertainty": 1, "value": 18}}}'}, ("'value'",)),
    Case("key-report-correlation-names-no-coefficient", "uncertainty vmc500 --from id.json --samples 64 --grid 2 2 2",
         {"id.json": '{"parameters": {"EXX.n0": {"value": 1, "uncertainty": 1}}, "correlation": '
                     '{"parameters": ["EXX.n0", "EQQ.c0"], "matrix": [[1, 0.5], [0.5, 1]]}}'}, ("EQQ.c0",)),
    Case("key-plan-after-a-diagnosis-of-another-machine", "plan vmc700 --instrument probe --budget 4 --after d.json",
         {"d.json": '{"machine": "vmc500", "effects": [{"component": "EXX"}], "under_modelled": []}'},
         ("vmc500",)),
    Case("size-plan-after-nested-50000-deep", "plan vmc500 --instrument probe --budget 4 --after d.json",
         {"d.json": "[" * 50_000 + "]" * 50_000}, ("d.json",)),
    Case("size-uncertainty-from-nested-50000-deep", "uncertainty vmc500 --from id.json --samples 64",
         {"id.json": '{"parameters": ' + "[" * 50_000 + "]" * 50_000 + "}"}, ("id.json",)),
    Case("sense-report-value-overflowing", "uncertainty vmc500 --from id.json --samples 64 --grid 2 2 2",
         {"id.json": '{"parameters": {"EXX.n0": {"value": 1e300, "uncertainty": 1}}}'}, ("EXX.n0.value",)),
    Case("sense-report-uncertainty-overflowing", "uncertainty vmc500 --from id.json --samples 64 --grid 2 2 2",
         {"id.json": '{"parameters": {"EXX.n0": {"value": 1, "uncertainty": 1e300}}}'}, ("EXX.n0.uncertainty",)),
    # --- URDF numbers and spec values within sense --------------------------------------------
    Case("sense-urdf-origin-overflowing", f"rank robot/slide.urdf {FIELD.split(' --grid')[0]} --points 16",
         {"robot/slide.urdf": slide_urdf().replace('xyz="0 0 0.1"', 'xyz="0 0 1e300"')}, ("1e+300", "xyz")),
    Case("sense-urdf-joint-limit-overflowing", f"rank robot/slide.urdf {FIELD.split(' --grid')[0]} --points 16",
         {"robot/slide.urdf": slide_urdf().replace('upper="0.5"', 'upper="1e300"')}, ("upper",)),
    Case("sense-spec-pitch-period-of-a-nanometre", "info m", machine_files("vmc500", "m", replace(
        'kind = "table"\ninterpolation = "cubic"\npositions_mm = [0, 50, 100, 150, 200, 250, 300, 350, 400, 450, 500]\n'
        'values_um = [0.0, 1.2, 2.1, 3.4, 4.0, 4.6, 5.9, 6.8, 7.1, 8.3, 9.0]',
        'kind = "periodic_pitch"\nperiod_mm = 1e-6\nsine_um = [1.0]\ncosine_um = [0.0]')), ("period_mm",)),
    # --- options within sense, sized before allocation -----------------------------------------
    Case("sense-export-zone-tool-of-a-million-km", "export vmc500 --controller linuxcnc -o o --zone tool=0:1e12",
         {}, ("--zone",)),
    Case("sense-plan-tool-lengths-of-a-thousand-km", "plan vmc500 --instrument tracker --budget 4 --tool-lengths 1e9",
         {}, ("--tool-lengths",)),
    Case("sense-plan-tool-lengths-nan-blames-tool-lengths",
         "plan vmc500 --instrument tracker --budget 4 --tool-lengths nan", {}, ("--tool-lengths",)),
    Case("sense-uncertainty-instrument-sigma-overflowing",
         "uncertainty vmc500 --instrument-sigma 1e300 --samples 64 --grid 2 2 2", {}, ("--instrument-sigma",)),
    Case("sense-identify-sigma-overflowing", "identify vmc500 m.csv --sigma-um 1e300", {"m.csv": points("T_a")},
         ("--sigma-um",)),
    Case("sense-diagnose-sigma-urad-overflowing", "diagnose vmc500 m.csv --sigma-urad 1e300", {"m.csv": points("T_a")},
         ("--sigma-urad",)),
    Case("sense-export-negative-seed", "export vmc500 --controller linuxcnc -o o --seed -1", {}, ("--seed",)),
    Case("sense-identify-negative-seed", "identify vmc500 m.csv --seed -1", {"m.csv": points("T_a")}, ("--seed",)),
    Case("size-export-a-billion-points", "export vmc500 --controller linuxcnc -o o --points 1000000000", {},
         ("--points",)),
    Case("size-plan-a-billion-candidates", "plan vmc500 --instrument tracker --budget 4 --candidates 1000000000", {},
         ("--candidates",)),
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


def test_with_theta_refuses_what_a_spec_would_refuse(machines):
    """Issue 44: Machine.with_theta(1e300) was taken (inf and NaN downstream). The API goes
    through the spec's limits: an error within 1 m or 1 rad, a period from 1 um to 1 km."""
    m = machines["vmc500"]
    theta = m.theta
    theta[0] = 1e300
    with pytest.raises(vp.InputError, match=r"theta\[0\] \(EXX\.n0\) = 1e\+306 um is implausible"):
        m.with_theta(theta)
    theta[0] = 0.999  # 999 mm: absurd for a machine, but within what a spec may state
    assert m.with_theta(theta).theta[0] == 0.999
    from volerr_pin.model import add_terms

    p = add_terms(m, {"EXX": {"kind": "periodic_pitch", "prefix": "h", "period_mm": 5.0, "sine_um": [1.0],
                              "cosine_um": [0.0]}})
    k = p.parameter_names.index("EXX.h.period")
    theta = p.theta
    theta[k] = 1e-9
    with pytest.raises(vp.InputError, match=r"EXX\.h\.period\) = 1e-06 mm is implausible"):
        p.with_theta(theta)
    np.testing.assert_array_equal(p.theta_bounds[k], [1e-6, 1e3])


@pytest.mark.parametrize("method", ["volumetric_error", "sensitivity"])
def test_a_billion_points_broadcast_from_one_are_sized_before_they_are_copied(machines, method):
    """Issue 44: np.broadcast_to(q, (10**9, 3)) takes one row of memory, and the evaluation
    raised MemoryError (or was killed) copying it. It is sized first and refused naming q."""
    m = machines["vmc500"]
    q = np.broadcast_to(m.travel.mean(axis=1), (10**9, 3))
    with pytest.raises(vp.InputError, match=r"evaluating 1,000,000,000 positions q needs about .* of memory"):
        getattr(m, method)(q)


# --- left behind: folders, temporary files, signals --------------------------------------------

def test_export_tables_into_a_device_is_refused_before_any_work(machines):
    """Issue 44: export_tables(m, "linuxcnc", "/dev/null") raised FileExistsError after the
    whole fit. The folder is checked first, as the command line checks it."""
    from volerr_pin.compensation.export import export_tables

    with pytest.raises(vp.InputError, match=r"folder: /dev/null is not a folder"):
        export_tables(machines["vmc500"], "linuxcnc", "/dev/null", points=8)


def test_a_full_disk_leaves_no_folder_and_names_the_file(machines, tmp_path, monkeypatch, capsys):
    """Issue 44: a disk-full export left the empty folder it made and said
    'volerr: error: : No space left on device', naming no file."""
    import builtins
    import errno

    from volerr_pin.cli import main
    from volerr_pin.compensation.export import _run as export_run

    class Full:
        def __init__(self, *args, **kwargs):
            self.file = builtins.open(*args, **kwargs)

        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.file.close()

    monkeypatch.setattr(export_run, "open", Full, raising=False)
    out = tmp_path / "new" / "tables"
    assert main(["export", "vmc500", "--controller", "linuxcnc", "-o", str(out), "--points", "64"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"volerr: error: {out}/compensation.ini: ") and "No space left" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == []   # neither folder stays, nor a temporary file


def _default_signals() -> None:
    """In the child before it runs: the signals at their defaults. A test run started in the
    background of a shell inherits SIGINT ignored, and Python then leaves Ctrl-C ignored."""
    import signal

    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_DFL)


@pytest.mark.parametrize("signum, status", [(2, 130), (15, 143), (1, 129)])
def test_a_signal_during_compensate_leaves_no_temporary_file(tmp_path, signum, status):
    """Issue 44: SIGTERM or SIGHUP during compensate of a long program left a hidden 4.6 MB
    .part file, and Ctrl-C printed a traceback. Each ends with one line, the signal's exit
    status, and nothing written."""
    import os
    import random
    import subprocess
    import sys
    import time

    rng = random.Random(1)
    moves = [f"G1 X{rng.uniform(50, 450):.3f} Y{rng.uniform(50, 350):.3f} Z{rng.uniform(50, 350):.3f} F2000"
             for _ in range(60_000)]
    program = tmp_path / "long.nc"
    program.write_text("\n".join(["G21 G90 G17", "G0 X100 Y100 Z100", *moves, "M30"]) + "\n")
    proc = subprocess.Popen([sys.executable, "-m", "volerr_pin.cli", "compensate", "vmc500", "long.nc", "-o", "out.nc"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_default_signals)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None and not any(".part" in p.name for p in tmp_path.iterdir()):
        time.sleep(0.05)
    assert proc.poll() is None, "compensate ended before it wrote anything"
    os.kill(proc.pid, signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == status, err[-500:]
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err[-500:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.nc"]


def test_import_works_where_no_compiled_kernel_cache_can_be_written(machines):
    """Issue 44: with a read-only installation and an unwritable HOME (a normal user on a
    shared machine), numba finds nowhere to cache the kernels and `import volerr_pin` failed.
    Numba is made to find no cache folder at all; the kernels are compiled in memory and give
    the same numbers."""
    import subprocess
    import sys

    code = ("import numba.core.caching as c; c.CacheImpl._locator_classes = []\n"
            "import volerr_pin as vp\n"
            "m = vp.load_machine('vmc500'); print(float(m.volumetric_error(m.mid_travel)[0]))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-500:]
    m = machines["vmc500"]
    assert float(done.stdout) == pytest.approx(m.volumetric_error(m.mid_travel)[0], abs=1e-15)


def test_a_refused_position_names_the_argument_it_came_from(machines):
    """Issue 44: 'q[0, 0] (axis X) is nan' said nothing of where the value came from when the
    caller had passed q_desired."""
    from volerr_pin.compensation import compensate_points

    m = machines["vmc500"]
    q = np.tile(m.mid_travel, (3, 1))
    q[1, 2] = np.nan
    with pytest.raises(vp.InputError, match=r"^q_desired\[1, 2\] \(axis Z\) is nan"):
        compensate_points(m, q)
    with pytest.raises(vp.InputError, match=r"^q\[1, 2\] \(axis Z\) is nan"):
        m.volumetric_error(q)


def test_the_memory_a_large_table_takes_is_what_its_reading_was_sized_for(machines):
    """Issue 44: a 7,000-node cubic table was sized at 1.96 GB and peaked at 4.8 GB. The peak of
    reading one (traced) stays within the size it is checked against."""
    import tracemalloc

    from volerr_pin.model import add_terms
    from volerr_pin.model._terms import TABLE_BYTES_PER_NODE_PAIR

    n = 1200
    term = {"kind": "table", "prefix": "t", "interpolation": "cubic", "positions_mm": list(np.linspace(0, 500, n)),
            "values_um": list(np.sin(np.linspace(0, 20, n)))}
    tracemalloc.start()
    try:
        add_terms(machines["vmc500"], {"EXX": term})
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert 0.5 * TABLE_BYTES_PER_NODE_PAIR * n**2 < peak <= TABLE_BYTES_PER_NODE_PAIR * n**2


@pytest.mark.slow
def test_ctrl_c_during_a_study_on_dask_workers_is_one_line(tmp_path):
    """Issue 44: Ctrl-C during `tolerance --workers 2` printed a KeyboardInterrupt traceback of
    126 lines. It is one line, exit status 130, and no worker outlives the run."""
    import os
    import signal
    import subprocess
    import sys
    import time

    (tmp_path / "t.toml").write_text(TOLERANCES)
    proc = subprocess.Popen([sys.executable, "-m", "volerr_pin.cli", "tolerance", "vmc500", "--tolerances", "t.toml",
                             "--samples", "200000", "--workers", "2", "--json"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_default_signals)
    time.sleep(12)   # the cluster is up and the draws are running
    assert proc.poll() is None, "the study ended before it could be interrupted"
    os.kill(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err[-500:]
    assert err.strip().splitlines() == ["volerr: error: interrupted; the outputs are left as they were"], err[-800:]
    assert out == ""
    time.sleep(2)
    with pytest.raises(ProcessLookupError):   # nothing of its process group is left
        os.killpg(proc.pid, 0)


def test_a_signal_whose_exception_a_callback_swallows_still_stops_the_run(tmp_path, capsys, monkeypatch):
    """A signal handler can run inside a weakref callback (an import's module-lock callback, as
    CI once caught), where Python prints and ignores the exception it raises: the run went on
    and wrote its outputs with status 0. The stop is raised again before anything is renamed
    into place: status 143, one line, nothing written, no traceback."""
    import signal
    import weakref

    import volerr_pin.cli as cli
    import volerr_pin.cli._urdf as urdf_cli

    out = tmp_path / "m.urdf"
    real = urdf_cli.run

    def run_with_a_swallowed_stop(args):
        class Thing:
            pass

        thing = Thing()
        ref = weakref.ref(thing, lambda _: cli._stop(signal.SIGTERM, None))   # noqa: F841 - kept alive
        del thing   # the callback runs here, and its exception is ignored
        return real(args)

    monkeypatch.setattr(urdf_cli, "run", run_with_a_swallowed_stop)
    assert cli.main(["urdf", "vmc500", "-o", str(out)]) == 143
    err = capsys.readouterr().err
    assert err == "volerr: error: stopped by SIGTERM; the outputs are left as they were\n", err
    assert list(tmp_path.iterdir()) == []
    monkeypatch.setattr(urdf_cli, "run", real)
    assert cli.main(["urdf", "vmc500", "-o", str(out)]) == 0 and out.exists()   # the next run is not stopped
