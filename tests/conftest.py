"""Shared helpers for the tests."""

from __future__ import annotations

import os
import stat

import numpy as np
import pytest

import volerr_pin as vp

ALL_MACHINES = ["vmc500", "vmc700", "lathe_2axis", "cgm4000", "gear_roller", "ur5"]


@pytest.fixture(scope="session", autouse=True)
def nothing_written_where_pytest_runs():
    """Tests write only into temporary folders: a run from a clone (the README's command) must
    leave its folder as it found it, and never replace a user's file there (the Quick start's
    volerr_demo.rrd was overwritten by a demo test once)."""
    here = os.getcwd()

    def listing():   # every entry's name; a file's time too (folders change as caches fill them)
        return {(e.name, e.stat().st_mtime_ns if e.is_file() else 0) for e in os.scandir(here)
                if not e.name.startswith(".")}

    before = listing()
    yield
    changed = sorted(name for name, _ in listing() ^ before)
    assert not changed, f"tests wrote into the folder pytest runs in ({here}): {', '.join(sorted(set(changed)))}"


def needs_device(path: str):
    """Skip a case built on the system's character device ``path`` (``/dev/zero``, ``/dev/full``)
    where it is not one: some sandboxes make these plain files, and the case would test nothing."""
    is_device = os.path.exists(path) and stat.S_ISCHR(os.stat(path).st_mode)
    return pytest.mark.skipif(not is_device, reason=f"{path} is not a character device here")


@pytest.fixture(scope="session")
def cluster():
    """A Dask cluster of two worker processes on the loopback, one thread each, shared by the
    session's study tests."""
    import logging

    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0",
                      silence_logs=logging.ERROR) as c:
        yield c


@pytest.fixture(scope="session")
def machines():
    return {name: vp.load_machine(name) for name in ALL_MACHINES}


def random_q(machine, n, seed=0):
    """Uniform random NC positions over the travel (SI)."""
    rng = np.random.default_rng(seed)
    travel = machine.travel
    return travel[:, 0] + rng.random((n, len(machine.axes))) * (travel[:, 1] - travel[:, 0])


def single(machine, component, value):
    """theta with one component error equal to the constant ``value`` (SI), all else zero."""
    theta = np.zeros(len(machine.parameter_names))
    for term in machine.model.term_info():
        if term["component"] != component:
            continue
        for name in term["parameters"]:
            local = name.rsplit(".", 1)[1]
            idx = machine.parameter_names.index(name)
            if term["kind"] == "table" or local == "c0":
                theta[idx] = value
    assert np.any(theta), f"{component} has no term on {machine.name}"
    return theta


def rot(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


#: the Machine's methods that check what they are given (a user's front end), which the layers
#: that evaluate the model in loops do not call: they call the model's algorithms
CHECKING_METHODS = ("volumetric_error", "sensitivity", "tool_poses", "component_sensitivity",
                    "error_joint_sensitivity", "axis_jacobian", "joint_jacobian", "joint_values", "component_values",
                    "pinocchio_configuration", "search_grid")


def record_checking_calls(monkeypatch, *packages: str) -> list:
    """Record every call of a checking Machine method (:data:`CHECKING_METHODS`, wrapped on the
    class) made directly by a module of ``packages`` (``"volerr_pin.fit"`` ...): (method,
    calling module, calling function, line), in call order."""
    import sys

    from volerr_pin.model import Machine

    calls = []
    for name in CHECKING_METHODS:
        original = getattr(Machine, name)

        def recorded(self, *args, _original=original, _name=name, **kwargs):
            caller = sys._getframe(1)
            module = caller.f_globals.get("__name__", "")
            if module.startswith(packages):
                calls.append((_name, module, caller.f_code.co_name, caller.f_lineno))
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(Machine, name, recorded)
    return calls
