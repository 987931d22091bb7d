"""Where Monte Carlo studies run: in this process, on an embedded local Dask cluster, or on
an existing one.

A study is a list of independent tasks (a chunk of samples x a block of points) whose
results are folded **in task order**, whatever order they finish in. Every engine hands
back the results in that order, so a study gives the same numbers on 1 or N workers.

- :class:`InProcess` runs the tasks one after the other here (library calls, tests).
- :class:`DaskEngine` submits them to a ``distributed`` client: a
  :func:`local_cluster` of worker processes on the loopback (the command line's default,
  sized to this machine's cores), or :func:`connect` to a scheduler. At most
  ``window`` tasks are in flight or waiting to be folded, so the memory of a run stays
  bounded however many tasks it has. Objects every task needs are scattered to the workers
  once; those that name their content (``scatter_key``: the machine, the points) stay there
  for the engine's later maps, so a study of several runs (Monte Carlo, Sobol' design,
  re-simulations) sends its machine and points once.

Machines cross process boundaries as :class:`PortableMachine`: the spec, the URDF text,
the coefficients and the state (about 10 kB; a machine is rebuilt on a worker in 20-60 ms,
once per worker and machine). Rebuilt machines give bit-identical errors.

Random numbers: the samples of chunk ``k`` are drawn from
``numpy.random.SeedSequence(seed, spawn_key=(k,))`` (the ``k``-th child of
``SeedSequence(seed).spawn(...)``), so a sample's value depends on the seed and its chunk,
never on which worker draws it.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import pickle
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any, Protocol

import numpy as np

from ..base import InputError, VolerrError, require_memory
from ..model import Machine

__all__ = ["DaskEngine", "Engine", "InProcess", "PortableMachine", "available_cores", "chunk_rng", "connect",
           "local_cluster"]


def chunk_rng(seed: int, chunk: int) -> np.random.Generator:
    """The random generator of one chunk of samples.

    Parameters
    ----------
    seed : int
        The study's seed (>= 0).
    chunk : int
        Index of the chunk (>= 0).

    Returns
    -------
    numpy.random.Generator
        PCG64 seeded with ``SeedSequence(seed, spawn_key=(chunk,))``, the same stream as
        ``SeedSequence(seed).spawn(n)[chunk]`` for any ``n > chunk``.
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(chunk,)))


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity, else the machine's count).

    Returns
    -------
    int
        At least 1.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


# ------------------------------------------------------------------ machines on workers

_BUILT: dict[str, Machine] = {}

#: memory of one worker process with volerr_pin, Pinocchio, numba and Dask loaded (measured:
#: 350-420 MB), for the check before a local cluster is started
WORKER_BYTES = 450e6


class PortableMachine:
    """A machine that can be sent to another process and rebuilt there.

    Holds the spec, the URDF text, the coefficients and the state; pickling leaves the
    machine object itself behind. :meth:`machine` gives the machine: the original in the
    process that made it, a rebuilt one (cached per process) elsewhere.

    Parameters
    ----------
    machine : Machine
        The machine to carry.
    """

    def __init__(self, machine: Machine):
        self._machine = machine
        self._spec = machine.spec
        self._urdf = machine.urdf.to_string()
        self._source = str(machine.urdf.source)
        self._theta = machine.theta
        self._state = machine.state
        self.key = hashlib.sha1(pickle.dumps((self._spec, self._urdf, self._theta, sorted(self._state)))
                                + repr(self._state).encode()).hexdigest()

    @property
    def scatter_key(self) -> str:
        """Names the content: an engine keeps it on its workers under this key (str)."""
        return "machine-" + self.key

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_machine"] = None
        return state

    def machine(self) -> Machine:
        """The machine (built here the first time this process needs it).

        Returns
        -------
        Machine
            The machine, with its coefficients and state.
        """
        if self._machine is None:
            built = _BUILT.get(self.key)
            if built is None:
                from ..model import build_model, parse_urdf

                built = Machine(build_model(self._spec, parse_urdf(self._urdf, self._source))).with_theta(self._theta,
                                                                                                     limits=False)
                if self._state:
                    built = built.with_state(**self._state)
                if len(_BUILT) > 8:
                    _BUILT.clear()
                _BUILT[self.key] = built
            self._machine = built
        return self._machine


# ------------------------------------------------------------------ engines


class Engine(Protocol):
    """Runs independent tasks and hands their results back in task order.

    Attributes
    ----------
    workers : int
        Worker processes (1 for :class:`InProcess`).
    where : str
        In words: "this process", "local cluster of 2 worker processes", "scheduler ...".
    """

    workers: int
    where: str

    def map(self, fn: Callable, shared: Sequence[Any], tasks: Sequence[tuple],
            progress: Callable[[int], None] | None = None) -> Iterator[Any]:
        """``fn(*shared, *task)`` for every task, yielded in the order of ``tasks``.

        Parameters
        ----------
        fn : callable
            A module-level function (it is pickled by reference).
        shared : sequence
            Arguments every task takes first (sent to each worker once).
        tasks : sequence of tuple
            The remaining arguments of each task.
        progress : callable(int), optional
            Called with the number of tasks finished so far.

        Yields
        ------
        object
            The result of each task, in task order.
        """
        ...


class InProcess(Engine):
    """The tasks one after the other in this process (numba may still use every core).

    Attributes
    ----------
    workers : int
        1.
    where : str
        "this process".

    Notes
    -----
    The methods of :class:`Engine` (documented there) do here:

    - ``map``: ``fn(*shared, *task)`` for every task, in order (see :class:`Engine`).
    """

    workers = 1
    where = "this process"

    def map(self, fn, shared, tasks, progress=None):
        for done, task in enumerate(tasks, 1):
            yield fn(*shared, *task)
            if progress is not None:
                progress(done)

    def close(self) -> None:
        """Nothing to close (the same interface as :class:`DaskEngine`)."""


#: what one submitted piece of work should take on a worker [s]: Dask's own cost per task is
#: milliseconds (scheduling, moving arguments and results), so consecutive tasks are sent
#: together until a piece holds about this much work, measured on the pieces already done
TASK_SECONDS = 0.5


def _on_worker(fn, *args):
    """Run a task on a Dask worker: the worker's processes are the parallelism, so numba's
    kernels take one thread (no oversubscription); the results do not depend on it."""
    import numba

    if numba.get_num_threads() != 1:
        numba.set_num_threads(1)
    return fn(*args)


def _batch_on_worker(fn, n_shared: int, *args):
    """Consecutive tasks on a worker, in order: ``args`` is the shared values then the list of
    the tasks' own arguments. Returns the seconds they took and their results."""
    import time

    shared, tasks = args[:n_shared], args[n_shared]
    start = time.perf_counter()
    results = [_on_worker(fn, *shared, *task) for task in tasks]
    return time.perf_counter() - start, results


class DaskEngine(Engine):
    """Tasks on a Dask ``distributed`` cluster, results folded in task order.

    Parameters
    ----------
    client : distributed.Client
        The client of the cluster.
    where : str
        The cluster in words.
    window : int, optional
        Tasks in flight or waiting to be folded at any time (default four per worker thread,
        at least 4): what bounds the memory held for results.
    owned : tuple, optional
        Objects to close with the engine (the client and the local cluster it made).

    Attributes
    ----------
    busy_seconds : float
        The time the workers spent in tasks, summed over the pieces of every map so far (what
        the cost model in docs/studies.md calls the parallel work).
    pieces : int
        Pieces of work sent so far.

    Notes
    -----
    The methods of :class:`Engine` (documented there) do here:

    - ``map``: ``fn(*shared, *task)`` for every task on the cluster, yielded in task order (see
      :class:`Engine`).
    """

    def __init__(self, client, where: str, window: int | None = None, owned: tuple = ()):
        self.client = client
        self.where = where
        info = client.scheduler_info(n_workers=-1) if _takes_n_workers(client) else client.scheduler_info()
        workers = info.get("workers", {})
        self.workers = max(1, len(workers))
        threads = sum(int(w.get("nthreads", 1)) for w in workers.values()) or 1
        self.window = int(window) if window else max(4, 4 * threads)
        self._owned = owned
        self.busy_seconds = 0.0
        self.pieces = 0
        self._kept: dict = {}    # scatter_key -> future of what stays on the workers

    #: objects an engine keeps on its workers between maps, at most
    KEEP = 8

    def _scatter(self, value):
        """A future of ``value`` on every worker, and whether it is this map's alone."""
        key = getattr(value, "scatter_key", None)
        if key is not None and key in self._kept:
            return self._kept[key], False
        future = self.client.scatter([value], broadcast=True, hash=False)[0]
        if key is None:
            return future, True
        while len(self._kept) >= self.KEEP:
            self._kept.pop(next(iter(self._kept))).release()
        self._kept[key] = future
        return future, False

    def lost(self, err: BaseException) -> BaseException:
        """What to raise for an error met while using the cluster: an error naming the cluster
        as lost when it is (its futures cancelled, its connection closed: distributed's
        CommClosedError is an OSError with no strerror, which read as "writing the outputs:
        None"), else ``err`` itself (a task's own OSError stays its own).

        Parameters
        ----------
        err : BaseException
            The error.

        Returns
        -------
        BaseException
            A :class:`~volerr_pin.base.VolerrError`, or ``err``.
        """
        from concurrent.futures import CancelledError

        from distributed.comm import CommClosedError

        if not isinstance(err, (CommClosedError, CancelledError)) and self.client.status == "running":
            return err
        why = getattr(err, "reason", None) or (str(err).splitlines() or [type(err).__name__])[0]
        return VolerrError(f"the Dask cluster ({self.where}) was lost during the run ({why}); nothing was written")

    def map(self, fn, shared, tasks, progress=None):
        from concurrent.futures import CancelledError

        from distributed import as_completed

        tasks = list(tasks)
        if not tasks:
            return
        sent = [self._scatter(s) for s in shared]
        scattered = [future for future, _ in sent]
        order: dict = {}
        pending: dict = {}
        waiting: dict[int, list] = {}
        running = as_completed()
        submitted = next_out = finished = 0
        size = 1                 # tasks per piece: one until a piece's time is known
        in_flight = 0            # pieces submitted and not yet folded

        def top_up():
            nonlocal submitted, in_flight
            while submitted < len(tasks) and in_flight < self.window:
                # never fewer pieces left than two per worker: the last ones balance the load
                left = len(tasks) - submitted
                take = max(1, min(size, left // (2 * self.workers) or 1))
                piece = tasks[submitted:submitted + take]
                future = self.client.submit(_batch_on_worker, fn, len(scattered), *scattered, piece, pure=False)
                order[future.key] = (submitted, len(piece))
                pending[future.key] = future
                running.add(future)
                submitted += len(piece)
                in_flight += 1

        try:
            top_up()
            for future in running:
                index, count = order.pop(future.key)
                pending.pop(future.key, None)
                seconds, results = future.result()  # re-raises the task's own exception
                future.release()
                in_flight -= 1
                self.busy_seconds += seconds
                self.pieces += 1
                if count:   # tasks per piece for about TASK_SECONDS, from this piece's measured time
                    size = max(1, min(4096, int(TASK_SECONDS / max(seconds / count, 1e-6))))
                waiting[index] = results
                finished += count
                if progress is not None:
                    progress(finished)
                while next_out in waiting:
                    part = waiting.pop(next_out)
                    yield from part
                    next_out += len(part)
                top_up()
        except (OSError, CancelledError) as err:
            raise self.lost(err) from None
        finally:
            for future in pending.values():
                future.cancel()
            for future, own in sent:
                if own:
                    future.release()

    def close(self) -> None:
        """Close the client and, for a local cluster, the cluster and its workers."""
        for future in self._kept.values():
            with contextlib.suppress(Exception):
                future.release()
        self._kept.clear()
        for thing in self._owned:
            with contextlib.suppress(Exception):
                thing.close()

    def __enter__(self) -> "DaskEngine":
        return self

    def __exit__(self, *exc) -> bool:
        self.close()
        return False


def _takes_n_workers(client) -> bool:
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters


@contextlib.contextmanager
def _interrupts_to_this_process():
    """Start worker processes that ignore SIGINT: a terminal's Ctrl-C reaches every process of
    the foreground group, and each worker printed its own KeyboardInterrupt traceback (128
    lines for two) while this process, which closes the cluster, said it in one. An ignored
    signal stays ignored in a process started from this one, and Python then installs no
    KeyboardInterrupt there (a blocked one does not: the workers unblock it). This process's
    handler is back once they are started; a Ctrl-C in the second or two they take to start is
    not seen."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def local_cluster(workers: int | None = None, *, window: int | None = None) -> DaskEngine:
    """An embedded local cluster of worker processes on the loopback, one thread each.

    Parameters
    ----------
    workers : int, optional
        Worker processes (default: the cores this process may use).
    window : int, optional
        See :class:`DaskEngine`.

    Returns
    -------
    DaskEngine
        Close it (or use it as a context manager) to stop the cluster.

    Raises
    ------
    InputError
        If ``workers`` is below 1.
    """
    n = available_cores() if workers is None else int(workers)
    if n < 1:
        raise InputError(f"workers must be >= 1, got {workers}", parameters=("workers",))
    require_memory(n * WORKER_BYTES, f"a cluster of {n} worker processes", ("workers",))
    from distributed import Client, LocalCluster

    with _interrupts_to_this_process():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL)   # (None is :8787)
    try:
        client = Client(cluster)
    except BaseException:
        cluster.close()
        raise
    return DaskEngine(client, f"local cluster of {n} worker process{'es' if n > 1 else ''}", window,
                      owned=(client, cluster))


def connect(address: str, *, timeout: float = 10.0, window: int | None = None) -> DaskEngine:
    """An engine on an existing Dask cluster, through its scheduler.

    The workers need volerr_pin (the same version) installed; the machine travels with the
    tasks, so they need none of its files.

    Parameters
    ----------
    address : str
        The scheduler's address, e.g. ``tcp://10.0.0.5:8786``.
    timeout : float, default 10
        Seconds to wait for the connection.
    window : int, optional
        See :class:`DaskEngine`.

    Returns
    -------
    DaskEngine
        Closing it closes the client, not the cluster.

    Raises
    ------
    InputError
        Naming ``scheduler``, if no Dask scheduler answers at ``address`` within ``timeout``
        (nothing listens, a server of another kind, or one that never answers), or it has no
        workers.
    """
    from distributed import Client

    _probe(address, timeout)
    try:
        client = Client(address, timeout=f"{timeout}s")
    except (OSError, TimeoutError, ValueError) as err:
        raise InputError(f"scheduler: no Dask scheduler answers at {address!r} ({err})",
                         parameters=("scheduler",)) from None
    engine = DaskEngine(client, f"scheduler {address}", window, owned=(client,))
    if not client.scheduler_info().get("workers"):
        engine.close()
        raise InputError(f"scheduler: the cluster at {address!r} has no workers", parameters=("scheduler",))
    return engine


#: the most bytes a Dask scheduler's greeting may take (it is about 60)
GREETING_BYTES = 1 << 16


def _probe(address: str, timeout: float) -> None:
    """Refuse, within ``timeout``, a TCP address where no Dask scheduler answers.

    A Dask scheduler greets every connection at once with its handshake (a frame of a few
    dozen bytes naming its compression, Python and pickle protocol). distributed's own client
    waits for it without a bound: a port that accepts and never answers hung it, and a server
    of another kind (HTTP) made it ask for 3 EiB."""
    import socket
    import struct
    import time
    from urllib.parse import urlsplit

    where = address if "://" in address else f"tcp://{address}"
    try:
        parts = urlsplit(where)
        host, port = parts.hostname, parts.port
    except ValueError:
        parts, host, port = None, None, None
    if parts is not None and parts.scheme != "tcp":   # (tls://, ucx:// ... are left to distributed)
        return
    if not host or port is None:
        raise InputError(f"scheduler: {address!r} is not a scheduler's address (tcp://HOST:PORT)",
                         parameters=("scheduler",))
    deadline = time.monotonic() + timeout

    def read(sock, n: int) -> bytes:
        data = b""
        while len(data) < n:
            sock.settimeout(max(deadline - time.monotonic(), 1e-3))
            chunk = sock.recv(n - len(data))
            if not chunk:
                raise ConnectionError("it closed the connection")
            data += chunk
        return data

    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            size = struct.unpack("<Q", read(sock, 8))[0]
            greeting = read(sock, size) if 0 < size <= GREETING_BYTES else b""
    except socket.timeout:
        raise InputError(f"scheduler: nothing at {address!r} answered as a Dask scheduler within {timeout:g} s",
                         parameters=("scheduler",)) from None
    except OSError as err:
        raise InputError(f"scheduler: no Dask scheduler answers at {address!r} ({err.strerror or err})",
                         parameters=("scheduler",)) from None
    if b"pickle-protocol" not in greeting:
        raise InputError(f"scheduler: what answers at {address!r} is not a Dask scheduler (its first bytes are no "
                         "Dask handshake)", parameters=("scheduler",))


def plan_chunks(total: int, size: int) -> list[tuple[int, int, int]]:
    """Consecutive chunks of ``total`` items, ``size`` each (the last one shorter).

    Parameters
    ----------
    total : int
        Number of items.
    size : int
        Items per chunk (>= 1).

    Returns
    -------
    list of (int, int, int)
        ``(index, start, stop)`` of every chunk.
    """
    return [(k, start, min(start + size, total)) for k, start in enumerate(range(0, total, size))]


def tasks_of(chunks: Iterable, blocks: Iterable) -> list[tuple]:
    """Every (sample chunk, point block) pair, samples major (the fold order).

    Parameters
    ----------
    chunks : iterable of tuple
        Sample chunks from :func:`plan_chunks`.
    blocks : iterable of tuple
        Point blocks from :func:`plan_chunks`.

    Returns
    -------
    list of tuple
        ``(chunk, block)`` pairs.
    """
    blocks = list(blocks)
    return [(c, b) for c in chunks for b in blocks]
