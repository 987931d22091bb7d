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

    from volerr_pin.studies.engine import DaskEngine, InProcess

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
