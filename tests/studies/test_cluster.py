"""A study on a cluster the user started: ``dask scheduler`` and two ``dask worker`` processes
on the loopback, as docs/cluster.md tells a user to start them, give the numbers the same study
gives embedded in the command's own process."""

from __future__ import annotations

import json
import os
import re
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


DASK = Path(sys.executable).parent / "dask"
ENV = dict(os.environ, PYTHONPATH=str(ROOT))


def _scheduler(tmp_path) -> tuple[str, object, list]:
    """``dask scheduler`` on a free loopback port, as a user starts it: its address, the log
    file the cluster's processes write to, and the list of those processes (the scheduler)."""
    if not DASK.exists():
        pytest.skip("the dask command is not installed beside this Python")
    address = f"tcp://127.0.0.1:{_free_port()}"
    log = open(tmp_path / "cluster.log", "w")
    return address, log, [subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port",
                                            address.rsplit(":", 1)[1], "--no-dashboard"], stdout=log, stderr=log,
                                           env=ENV, start_new_session=True)]


@pytest.fixture
def external_cluster(tmp_path):
    """A scheduler and two single-threaded workers started as a user starts them; stopped after."""
    from distributed import Client

    address, log, procs = _scheduler(tmp_path)
    try:
        procs += [subprocess.Popen([str(DASK), "worker", address, "--nthreads", "1", "--nworkers", "1",
                                    "--no-dashboard", "--local-directory", str(tmp_path / f"w{k}")],
                                   stdout=log, stderr=log, env=ENV, start_new_session=True) for k in range(2)]
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


@pytest.fixture
def silent_port():
    """A port that accepts connections and never says a word."""
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held = []
    stop = threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except OSError:
                pass

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    stop.set()
    thread.join()
    for conn in held:
        conn.close()
    server.close()


@pytest.fixture
def http_port():
    """An HTTP server (it waits for a request, then answers in HTTP)."""
    import http.server
    import threading

    server = http.server.HTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def test_an_address_that_is_no_dask_scheduler_is_refused_within_the_timeout(silent_port, http_port):
    """A port that accepts and never answers hung distributed's client for ever; an HTTP server
    made it ask for 3 EiB (MemoryError). Each is refused, naming the scheduler option, within
    the stated timeout."""
    import time

    from volerr_pin.base import InputError
    from volerr_pin.studies import connect

    for address in (silent_port, http_port):
        start = time.monotonic()
        with pytest.raises(InputError, match=r"^scheduler: nothing at .* answered as a Dask scheduler within 1 s") \
                as err:
            connect(address, timeout=1.0)
        assert time.monotonic() - start < 5.0 and err.value.parameters == ("scheduler",)
    with pytest.raises(InputError, match=r"no Dask scheduler answers at 'tcp://127.0.0.1:\d+' \(Connection refused\)"):
        connect(f"tcp://127.0.0.1:{_free_port()}", timeout=1.0)
    with pytest.raises(InputError, match=r"'tcp://\[::1' is not a scheduler's address"):
        connect("tcp://[::1", timeout=1.0)


def _descendants(pid: int) -> int:
    import psutil

    try:
        return len(psutil.Process(pid).children(recursive=True))
    except psutil.NoSuchProcess:
        return 0


def _tolerance_study(extra: list[str]) -> subprocess.Popen:
    """volerr tolerance long enough to be stopped, in a session of its own with SIGINT as a
    terminal leaves it (a shell's background job would ignore it)."""
    argv = [sys.executable, "-m", "volerr_pin.cli", "tolerance", "vmc500", "--tolerances", str(EXAMPLE),
            "--samples", "400000", *extra]
    return subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT)),
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _wait_for(condition, seconds: float) -> None:
    import time

    end = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.2)


@pytest.mark.slow
def test_ctrl_c_of_a_study_on_a_local_cluster_is_one_line_and_leaves_no_process():
    """A terminal's Ctrl-C reaches the whole foreground group: each worker process printed its
    own KeyboardInterrupt (128 lines in the third hostile pass)."""
    import time

    import psutil

    proc = _tolerance_study(["--workers", "2"])
    try:
        _wait_for(lambda: _descendants(proc.pid) >= 2, 120)
        time.sleep(3.0)   # the workers started and the study running
        children = psutil.Process(proc.pid).children(recursive=True)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert err.strip() == "volerr: error: interrupted; the outputs are left as they were"
    _wait_for(lambda: not any(c.is_running() and c.status() != psutil.STATUS_ZOMBIE for c in children), 30)


@pytest.mark.slow
def test_a_scheduler_lost_during_a_study_is_named_as_lost(tmp_path):
    """It was reported as "writing the outputs: None" (distributed's CommClosedError is an
    OSError with no strerror), after pages of distributed's reconnection logs."""
    import time

    address, log, (scheduler,) = _scheduler(tmp_path)
    worker = subprocess.Popen([str(DASK), "worker", address, "--nthreads", "1", "--no-dashboard", "--local-directory",
                               str(tmp_path / "w")], stdout=log, stderr=log, env=ENV, start_new_session=True)
    proc = None
    try:
        from distributed import Client

        with Client(address, timeout=60) as client:
            client.wait_for_workers(1, timeout=120)
        proc = _tolerance_study(["--scheduler", address, "--json"])
        time.sleep(8.0)   # connected and running (the study takes minutes on one worker)
        assert proc.poll() is None
        os.killpg(scheduler.pid, signal.SIGKILL)
        out, err = proc.communicate(timeout=120)
    finally:
        for p in (proc, worker, scheduler):
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        log.close()
    assert proc.returncode == 2 and out == ""
    assert re.fullmatch(rf"volerr: error: the Dask cluster \(scheduler {re.escape(address)}\) was lost during the "
                        r"run \([^\n]+\); nothing was written", err.strip()), err
