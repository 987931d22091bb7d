"""A study on a cluster the user started: ``dask scheduler`` and two ``dask worker`` processes
on the loopback, as docs/cluster.md tells a user to start them, give the numbers the same study
gives embedded in the command's own process."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from volerr_pin.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "data" / "vmc500_tolerances.toml"
#: report fields that name where the study ran, not what it found
WHERE = {"workers", "engine"}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def external_cluster(tmp_path):
    """A scheduler and two single-threaded workers started as a user starts them; stopped after."""
    from distributed import Client

    dask = Path(sys.executable).parent / "dask"
    if not dask.exists():
        pytest.skip("the dask command is not installed beside this Python")
    address = f"tcp://127.0.0.1:{_free_port()}"
    log = open(tmp_path / "cluster.log", "w")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    procs = [subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", address.rsplit(":", 1)[1],
                               "--no-dashboard"], stdout=log, stderr=log, env=env, start_new_session=True)]
    try:
        procs += [subprocess.Popen([str(dask), "worker", address, "--nthreads", "1", "--nworkers", "1",
                                    "--no-dashboard", "--local-directory", str(tmp_path / f"w{k}")],
                                   stdout=log, stderr=log, env=env, start_new_session=True) for k in range(2)]
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
        yield address
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        log.close()


def _report(argv, capsys) -> dict:
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


@pytest.mark.slow
def test_a_study_on_a_cluster_the_user_started_gives_the_embedded_numbers(external_cluster, capsys):
    study = ["tolerance", "vmc500", "--tolerances", str(EXAMPLE), "--samples", "2000", "--grid", "3",
             "--target-um", "12", "--sobol-samples", "16", "--json"]
    there = _report(study + ["--scheduler", external_cluster], capsys)
    here = _report(study + ["--workers", "0"], capsys)
    assert there["engine"] == f"scheduler {external_cluster}" and there["workers"] == 2
    assert {k: v for k, v in there.items() if k not in WHERE} == {k: v for k, v in here.items() if k not in WHERE}
    field = ["uncertainty", "vmc500", "--instrument-sigma", "1", "--campaign-points", "40", "--samples", "300",
             "--grid", "3", "--json"]
    there = _report(field + ["--scheduler", external_cluster], capsys)
    here = _report(field + ["--workers", "0"], capsys)
    assert {k: v for k, v in there.items() if k not in WHERE} == {k: v for k, v in here.items() if k not in WHERE}


def _slow_square(offset, x):
    import time

    time.sleep(0.02)
    return offset + x * x


def test_a_cluster_gets_pieces_of_work_worth_sending_and_folds_them_in_order(cluster):
    """Dask's cost per task is milliseconds: consecutive tasks travel together once a piece's
    time is measured (to about TASK_SECONDS each), the last pieces stay small enough to balance
    the workers, and the results come back in task order, as in one process."""
    from distributed import Client

    from volerr_pin.studies import DaskEngine, InProcess

    tasks = [(k,) for k in range(200)]
    with Client(cluster) as client:
        engine = DaskEngine(client, "test cluster")
        pieces = []
        submit = client.submit

        def counting(fn, *args, **kwargs):
            pieces.append(len(args[-1]))
            return submit(fn, *args, **kwargs)

        client.submit = counting
        done = []
        got = list(engine.map(_slow_square, (1000,), tasks, progress=done.append))
    assert got == list(InProcess().map(_slow_square, (1000,), tasks)) == [1000 + k * k for k in range(200)]
    assert sum(pieces) == 200 and len(pieces) < 60 and max(pieces) > 10   # 20 ms tasks: about 25 a piece
    assert pieces[-1] <= 200 // 4 and done[-1] == 200 and done == sorted(done)


def test_a_study_sends_its_machine_and_points_to_the_workers_once(cluster, machines, tmp_path):
    """A tolerance study with its Sobol' design and re-allocation maps several runs; what names
    its content (the machine, the points) is scattered once and kept, the runs' own sources are
    scattered with their run and released after it; the numbers are those of one process."""
    from distributed import Client

    from volerr_pin.model import grid
    from volerr_pin.studies import DaskEngine
    from volerr_pin.studies import study_tolerances
    from volerr_pin.studies import read_tolerance_file

    m = machines["vmc500"]
    path = tmp_path / "tol.toml"
    path.write_text("EXX_um = 5\nEC0Y_arcsec = 3\ndefault_um = 1\ndefault_arcsec = 1\n")
    tol = read_tolerance_file(path, m)
    kwargs = dict(samples=600, seed=3, target=6e-6, sobol_samples=8)
    with Client(cluster) as client:
        engine = DaskEngine(client, "test cluster")
        sent = []
        scatter = client.scatter

        def counting(data, **kwargs):
            sent.append(type(data[0]).__name__)
            return scatter(data, **kwargs)

        client.scatter = counting
        on_cluster = study_tolerances(m, tol, grid(m, 3), engine=engine, **kwargs)
        kept = len(engine._kept)
        engine.close()
    here = study_tolerances(m, tol, grid(m, 3), **kwargs)
    runs = 2 + on_cluster.reallocation.rounds            # Monte Carlo, Sobol', re-simulations
    assert sent.count("PortableMachine") == 1 and sent.count("Points") == 1 and kept == 2
    assert sent.count("ShapedSource") == 1 + on_cluster.reallocation.rounds and sent.count("DesignSource") == 1
    assert len(sent) == 2 + runs
    np.testing.assert_array_equal(on_cluster.run.max, here.run.max)
    assert on_cluster.to_dict()["drivers"] == here.to_dict()["drivers"]
    assert on_cluster.reallocation.to_dict() == here.reallocation.to_dict()
