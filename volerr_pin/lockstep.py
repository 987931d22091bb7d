"""Two processes that run one computation in step, each doing its share of the parts that split.

A diagnosis is a long serial chain of fits (each round's model is the last round's refitted),
and most of its time is spent in parts that split into independent halves: the design of a fit
over the points, a round's candidates, independent refits. Threads cannot share that work
(the interpreter lock serialises the Python between the numerical kernels), and a worker
forked for each part pays for the pages it copies. So the whole computation is forked once,
at its start, while the process is still small: both processes then run the same code on the
same data, and at each part that splits each computes its share and the two exchange results
(:meth:`Group.map`, :meth:`Group.share`). Everything else is computed in both, identically, so
both hold the same state that decisions and exchanges rest on, and take the same decisions;
what an item computed stays only where it was computed (caches, a score's columns), and no
decision may read it. The second process never returns (it ends when the computation does) and
only the first one's result is used.

The computation must be deterministic apart from the shares (no clocks, no reading of the
machine's load or free memory that a decision depends on), and its shared values must pickle.
Every exchange is numbered and tagged: two processes that reach exchanges of different numbers
or tags raise (two exchanges with the same tag at the same count but different items are not
told apart). Where the second process has ended, the first goes on alone (:meth:`Group.map`).
The check before the fork sees Python threads only: the native threads of BLAS and numba's
pool are the libraries' to handle (OpenBLAS resets its pool in a child; the second process runs
the compiled kinematics on its own thread).
"""

from __future__ import annotations

import os
import pickle
import signal
import socket
import struct
import sys
import threading
import traceback
from contextlib import contextmanager

__all__ = ["Group", "OutOfStep", "active", "balanced", "together"]

_group: Group | None = None


class OutOfStep(RuntimeError):
    """The processes of a group reached different exchanges, or one of them ended early."""


class _Ended(OutOfStep):
    """The other process of a group ended."""


class _Failed:
    """What a share raised, travelling to the other process to be raised there too."""

    def __init__(self, exc: BaseException):
        try:
            pickle.loads(pickle.dumps(exc, protocol=pickle.HIGHEST_PROTOCOL))
            self.exc = exc
        except Exception:  # noqa: BLE001 - an exception that does not travel: its text
            self.exc = RuntimeError("".join(traceback.format_exception(exc)))


class Group:
    """This process's place in a group of processes running one computation in step.

    Attributes
    ----------
    rank : int
        This process's number, 0 for the one that called :func:`together` (whose result counts).
    size : int
        The processes of the group.
    alone : bool
        Whether the second process has ended and the first goes on by itself (:meth:`map`).
    """

    def __init__(self, rank: int, size: int, sock: socket.socket):
        self.rank, self.size, self._sock = rank, size, sock
        self._count = 0
        self.alone = False   # the second process ended: the first goes on by itself

    def share(self, mine, tag: str = ""):
        """Every process's value, in the order of their ranks: each sends its own and receives the
        other's (a barrier: both wait for each other here).

        Parameters
        ----------
        mine : object
            This process's value (it must pickle).
        tag : str, optional
            What is exchanged; both processes must pass the same tag at the same exchange.

        Returns
        -------
        list
            The values, by rank.

        Raises
        ------
        OutOfStep
            If the other process reached another exchange, or ended.
        """
        self._count += 1
        label = (self._count, tag)
        payload = pickle.dumps((label, mine), protocol=pickle.HIGHEST_PROTOCOL)
        if self.rank == 0:   # one sends first and the other receives first: no two full buffers
            self._send(payload)
            theirs = self._receive()
        else:
            theirs = self._receive()
            self._send(payload)
        other_label, value = pickle.loads(theirs)
        if other_label != label:
            raise OutOfStep(f"the processes of the computation left step: exchange {label} here, "
                            f"{other_label} in the other process")
        return [mine, value] if self.rank == 0 else [value, mine]

    def map(self, fn, items, tag: str = "", ranks=None) -> list:
        """``[fn(x) for x in items]``, each process computing every ``size``-th item from its rank
        (or the items ``ranks`` gives it), and both getting every result (in order).

        What ``fn`` raised in either process is raised in both. Inside ``fn`` the group is not
        active (:func:`active` is None): an item is computed whole by the process it falls to.
        When the second process has ended (killed, for example when the machine ran out of
        memory), the first computes its items too and goes on alone: from then on the group is
        no longer active, and every later map of it runs here whole.

        Parameters
        ----------
        fn : callable
            The function of one item (its results must pickle).
        items : iterable
            The items, the same in both processes.
        tag : str, optional
            What is computed (see :meth:`share`).
        ranks : sequence of int, optional
            The process that computes each item (the same in both processes).

        Returns
        -------
        list
            The results, in the order of ``items``.

        Raises
        ------
        OutOfStep
            If the processes reached different exchanges, or (in the second process) the first
            one ended.
        """
        global _group
        items = list(items)
        ranks = [k % self.size for k in range(len(items))] if ranks is None else list(ranks)
        if len(ranks) != len(items) or not set(ranks) <= set(range(self.size)):
            raise ValueError(f"ranks must give each of the {len(items)} items a process from 0 to {self.size - 1}")
        if self.alone:
            return [fn(x) for x in items]
        active_before, _group = _group, None   # an item is computed here alone: the other process is at others
        try:
            mine = [fn(x) for x, rank in zip(items, ranks) if rank == self.rank]
        except Exception as exc:  # noqa: BLE001 - raised in both processes below
            mine = _Failed(exc)
        finally:
            _group = active_before
        try:
            parts = self.share(mine, tag or getattr(fn, "__qualname__", "map"))
        except _Ended:
            if self.rank != 0:
                raise
            self.alone = True   # the second process is gone: its items here, and alone from now
            if _group is self:
                _group = None
            if isinstance(mine, _Failed):
                raise mine.exc from None
            theirs = [fn(x) for x, rank in zip(items, ranks) if rank != self.rank]
            parts = [mine, theirs]
        for part in parts:
            if isinstance(part, _Failed):
                raise part.exc
        parts = [iter(part) for part in parts]
        return [next(parts[rank]) for rank in ranks]

    def _send(self, payload: bytes) -> None:
        try:
            self._sock.sendall(struct.pack("!Q", len(payload)) + payload)
        except OSError as exc:
            raise _Ended("the other process of the computation ended early") from exc

    def _receive(self) -> bytes:
        (n,) = struct.unpack("!Q", self._exactly(8))
        return self._exactly(n)

    def _exactly(self, n: int) -> bytes:
        buf = bytearray(n)
        view, got = memoryview(buf), 0
        while got < n:
            try:
                k = self._sock.recv_into(view[got:], n - got)
            except OSError:   # reset: the other process ended with data unread
                k = 0
            if k == 0:
                raise _Ended("the other process of the computation ended early (it may have been "
                             "killed, for example when the machine ran out of memory)")
            got += k
        return bytes(buf)


def active() -> Group | None:
    """The group this process runs in, or None.

    Returns
    -------
    Group or None
    """
    return _group


@contextmanager
def together(size: int):
    """Run the block in ``size`` processes in step (``size`` 1 or 2; 1, or where forking is not
    safe or fails - not Linux (a forked child may not use macOS's Accelerate BLAS; Windows has no
    ``fork``), other threads running, a group already, no process or socket left - the block
    runs here alone and the group is None).

    The second process is forked on entry; it runs the block too, with the same state, and ends
    at its end (``os._exit``: nothing of this process's - buffers, exit handlers - runs twice),
    whatever the block did. It writes nothing: its standard output and error go nowhere and its
    warnings are ignored. This process kills it when it leaves the block (the second process may
    not have finished the block's last steps: its result is not needed), and reaps it.

    Parameters
    ----------
    size : int
        Processes.

    Yields
    ------
    Group or None
        This process's place in the group (rank 0), or None when the block runs alone.
    """
    global _group
    # Linux only: elsewhere a forked child may not use the system's BLAS (macOS's Accelerate)
    forkable = sys.platform.startswith("linux") and threading.active_count() == 1 and _group is None
    if size < 2 or not forkable:
        yield None
        return
    if size != 2:
        raise ValueError(f"a group runs in 1 or 2 processes, not {size}")
    try:
        mine, theirs = socket.socketpair()
    except OSError:   # no sockets left: alone
        yield None
        return
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        pid = os.fork()
    except OSError:   # no process left (a limit, the memory): alone
        mine.close()
        theirs.close()
        yield None
        return
    if pid == 0:  # pragma: no cover - the second process, which never returns
        mine.close()
        status = 1
        try:
            _quiet()
            _group = Group(1, 2, theirs)
            yield _group
            status = 0
        finally:
            os._exit(status)
    theirs.close()
    _group = Group(0, 2, mine)
    try:
        yield _group
    finally:
        _group = None
        mine.close()
        try:
            os.kill(pid, signal.SIGKILL)   # ended already when the block ran to its end
        except ProcessLookupError:  # pragma: no cover - reaped by someone else
            pass
        try:
            os.waitpid(pid, 0)
        except ChildProcessError:  # pragma: no cover - reaped by someone else
            pass


def _quiet() -> None:
    """In the second process: nothing printed, no warnings, the compiled kernels on this thread
    (the parent's thread pool does not survive a fork)."""
    import warnings

    from . import kinematics

    devnull = open(os.devnull, "w")  # noqa: SIM115 - for the rest of the process
    os.dup2(devnull.fileno(), 1)
    os.dup2(devnull.fileno(), 2)
    sys.stdout = sys.stderr = devnull
    warnings.simplefilter("ignore")
    kinematics.run_on_this_thread()


def balanced(seconds: list, size: int) -> list[int]:
    """The process of each of the items whose times (None: not known, the mean of those known)
    are ``seconds``: the longest first, each to the process with the least so far (on a tie the
    lower rank), so that processes in step wait little for each other."""
    known = [t for t in seconds if t is not None]
    guess = sum(known) / len(known) if known else 1.0
    times = [guess if t is None else t for t in seconds]
    load, ranks = [0.0] * size, [0] * len(times)
    for k in sorted(range(len(times)), key=lambda k: (-times[k], k)):
        rank = min(range(size), key=lambda p: (load[p], p))
        ranks[k] = rank
        load[rank] += times[k]
    return ranks
