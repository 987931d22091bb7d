"""Two processes in step (volerr_pin.lockstep): shares, results in order, failures raised in
both, processes that leave step or die, nothing left running, nothing printed twice."""

from __future__ import annotations

import os
import signal
import sys
import threading

import numpy as np
import pytest

from volerr_pin import lockstep
from volerr_pin.errors import InputError


def _children() -> list[int]:
    """This process's children (Linux), zombies included."""
    path = f"/proc/{os.getpid()}/task/{os.getpid()}/children"
    if not os.path.exists(path):
        pytest.skip("no /proc children list here")
    with open(path) as f:
        return [int(p) for p in f.read().split()]


def test_map_shares_the_items_and_gives_every_result_in_order():
    before = set(_children())
    with lockstep.together(2) as group:
        assert lockstep.active() is group
        if group.rank == 0:   # the second process runs this block too
            assert len(set(_children()) - before) == 1
        pids = group.map(lambda x: (x * x, os.getpid()), range(9), "squares")
        assert [v for v, _ in pids] == [x * x for x in range(9)]
        (first,), (second,) = {p for _, p in pids[0::2]}, {p for _, p in pids[1::2]}
        assert first != second and (first, second)[group.rank] == os.getpid()   # every second item from its rank
        # items given to a process: all to the second, then all to the first
        assert [p for _, p in group.map(lambda x: (x, os.getpid()), range(4), "second", [1] * 4)] == [second] * 4
        assert [p for _, p in group.map(lambda x: (x, os.getpid()), range(3), "first", [0] * 3)] == [first] * 3
        assert group.map(lambda x: x, [], "none") == []
        assert group.share(("mine", 1), "share") == [("mine", 1), ("mine", 1)]   # both ran the same code
        a = np.arange(200_000.0)   # larger than a socket's buffer, both ways
        halves = group.map(lambda k: a[k::2] * 2, [0, 1], "arrays")
        assert np.array_equal(np.concatenate(halves), np.concatenate([a[0::2], a[1::2]]) * 2)
    assert lockstep.active() is None
    assert set(_children()) == before   # the second process ended and was reaped


def test_inside_an_item_the_group_is_not_active():
    with lockstep.together(2) as group:
        inner = group.map(lambda x: lockstep.active() is None, range(4), "inner")
        assert inner == [True] * 4 and lockstep.active() is group


@pytest.mark.parametrize("bad", [0, 1, 3])   # this process's share (0) or the other's (1, 3)
def test_what_an_item_raised_is_raised_in_both_and_leaves_no_process(bad):
    before = set(_children())

    def fn(x):
        if x == bad:
            raise InputError(f"item {x} is bad")
        return x

    with pytest.raises(InputError, match=f"item {bad} is bad"):
        with lockstep.together(2) as group:
            group.map(fn, range(6), "bad")
    assert set(_children()) == before and lockstep.active() is None


def test_an_exception_that_does_not_travel_arrives_as_its_text():
    class Local(Exception):   # not importable by name: does not pickle
        pass

    def fn(x):
        if x == 1:
            raise Local("no way back")
        return x

    with pytest.raises(RuntimeError, match="Local: no way back"):
        with lockstep.together(2) as group:
            group.map(fn, range(2), "local")


def test_processes_that_reach_different_exchanges_raise():
    with pytest.raises(lockstep.OutOfStep, match="left step"):
        with lockstep.together(2) as group:
            group.share(None, "first" if group.rank == 0 else "second")


def test_when_the_second_process_dies_the_first_goes_on_alone():
    before = set(_children())
    first = os.getpid()

    def fn(x):
        if x == 1 and os.getpid() != first:   # killed, as for memory, in the middle of its share
            os.kill(os.getpid(), signal.SIGKILL)
        return x * 10, os.getpid()

    with lockstep.together(2) as group:
        out = group.map(fn, range(4), "dies")
        assert [v for v, _ in out] == [0, 10, 20, 30] and {p for _, p in out} == {first}
        assert group.alone and lockstep.active() is None
        assert group.map(lambda x: (x, os.getpid()), range(3), "after") == [(0, first), (1, first), (2, first)]
        with pytest.raises(InputError, match="still raised"):
            group.map(lambda x: (_ for _ in ()).throw(InputError("still raised")), range(2), "raises")
    assert set(_children()) == before


def test_a_failure_here_is_raised_when_the_second_process_died_meanwhile():
    first = os.getpid()

    def fn(x):
        if os.getpid() != first:
            os.kill(os.getpid(), signal.SIGKILL)
        raise InputError("here")

    with pytest.raises(InputError, match="here"):
        with lockstep.together(2) as group:
            group.map(fn, range(2), "both fail")


def test_the_second_process_raises_when_the_first_has_ended():
    import socket

    here, there = socket.socketpair()
    there.close()   # the first process is gone
    second = lockstep.Group(1, 2, here)
    with pytest.raises(lockstep.OutOfStep, match="ended early"):
        second.map(abs, range(2), "alone")
    assert not second.alone
    here.close()


def test_the_second_process_prints_nothing(capfd):
    with lockstep.together(2) as group:
        print("printed once")
        os.write(1, b"written once\n")
        group.share(None, "printed")
    out = capfd.readouterr().out
    assert out.count("printed once") == 1 and out.count("written once") == 1


def test_alone_where_a_fork_is_not_safe(monkeypatch):
    with lockstep.together(1) as group:
        assert group is None and lockstep.active() is None
    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()
    try:
        with lockstep.together(2) as group:   # another thread running: a fork would copy its locks
            assert group is None
    finally:
        stop.set()
        thread.join()
    with lockstep.together(2) as group:
        with lockstep.together(2) as inner:   # no group within a group
            assert inner is None and lockstep.active() is group
    monkeypatch.setattr(sys, "platform", "darwin")   # a forked child may not use Accelerate there
    with lockstep.together(2) as group:
        assert group is None
    monkeypatch.undo()
    with pytest.raises(ValueError, match="1 or 2 processes"):
        with lockstep.together(3):
            pass
    with lockstep.together(2) as group:
        with pytest.raises(ValueError, match="a process from 0 to 1"):
            group.map(abs, [1, 2], "ranks", [0, 2])


def test_the_second_process_runs_large_kernels_after_this_one_started_its_thread_pool(machines):
    # numba's thread pool does not survive a fork: the second process runs the kernels on its own thread
    m = machines["vmc500"]
    q = np.random.default_rng(3).uniform(m.travel[:, 0], m.travel[:, 1], (4096, 3))
    here = m.volumetric_error(q)  # above kinematics.PARALLEL_MIN points: the parallel kernel, its pool started
    with lockstep.together(2) as group:
        parts = group.map(lambda k: m.volumetric_error(q[k::2]), [0, 1], "kernels")
    assert np.array_equal(parts[0], here[0::2]) and np.array_equal(parts[1], here[1::2])


def test_the_command_line_progress_bar_starts_no_thread():
    """A thread of the bar's own would keep a diagnosis from forking its second process."""
    import io

    from rich.console import Console

    from volerr_pin.cli.common import FitProgress

    bar = FitProgress(True)
    bar.console, bar.enabled = Console(file=io.StringIO(), force_terminal=True), True
    with bar as progress:
        progress("round 1: candidates", 3)
        progress("round 1: candidates", 4)
        assert threading.active_count() == 1
    assert "round 1: candidates" in bar.console.file.getvalue()
