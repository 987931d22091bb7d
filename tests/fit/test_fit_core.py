"""The fit stands on the model core: identification, diagnosis and ranking evaluate the model
through its algorithms, the points checked once where the data enter (never through the
checking Machine); a diagnosis edits the model as typed values (no spec document is written or
read back, Pinocchio's model is built once more at most) and each round is a pipeline the
machine goes through once: offered, scored, accepted and refitted."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import volerr_pin as vp
from conftest import record_checking_calls
from volerr_pin.measurements import read_any

DATA = Path(__file__).resolve().parents[2] / "examples" / "data"


@pytest.fixture(scope="module")
def tracker():
    m = vp.load_machine("vmc500")
    return m, read_any(DATA / "vmc500_tracker.csv", m)


def test_no_checking_machine_method_is_called_inside_the_fit(monkeypatch, tracker):
    from volerr_pin.fit.identify import identify
    from volerr_pin.fit import rank, tool_identifiability

    m, data = tracker
    calls = record_checking_calls(monkeypatch, "volerr_pin.fit")
    identify(m, [data], folds=3)
    vp.diagnose(m, [data], max_rounds=3)
    rank(m, points=64)
    rank(m, points=64, by="parameter")
    tool_identifiability(m, points=64)
    assert calls == []


def test_the_recorder_sees_a_checking_call_from_the_fit(monkeypatch, tracker):
    """The check above can fail: a call of a checking method from a module of the fit is recorded."""
    m, _ = tracker
    calls = record_checking_calls(monkeypatch, __name__)
    m.volumetric_error(m.mid_travel)
    assert [c[:2] for c in calls] == [("volumetric_error", __name__)]


def test_a_diagnosis_writes_and_reads_no_spec_and_builds_pinocchio_once_more_at_most(monkeypatch, tracker):
    """The sample tracker data on a model without squareness: every round offers location errors
    whose error joints the spec lacks and edits the model; no TOML is written or parsed, no spec
    document is made or read, and Pinocchio's model is built once (a model with a location
    site on every axis and body)."""
    import tomllib

    import tomli_w

    import volerr_pin.model._model as model_module
    import volerr_pin.model._spec as spec_module
    import volerr_pin.model._specio as specio

    m, data = tracker
    m = vp.load_machine("vmc500")   # its own: the structures its edits share
    m = m.with_spec(m.spec.without(*(c for c in m.components if "0" in c)))   # no location errors
    used = []

    def counted(name, fn):
        return lambda *a, **k: used.append(name) or fn(*a, **k)

    for module, name in [(tomllib, "loads"), (tomli_w, "dumps"), (specio, "spec_document"), (specio, "write_spec"),
                         (spec_module, "parse_components"), (spec_module, "load_spec"), (spec_module, "read_toml")]:
        monkeypatch.setattr(module, name, counted(f"{module.__name__}.{name}", getattr(module, name)))
    built, build = [], model_module.pin.buildModelFromXML
    monkeypatch.setattr(model_module.pin, "buildModelFromXML", lambda *a, **k: built.append(1) or build(*a, **k))
    report = vp.diagnose(m, [data])
    assert report.effects or report.under_modelled   # the case: the model was edited
    assert used == []
    assert len(built) <= 1


def _route(machine, data, rounds):
    """Per round, the files of the library (above the model core) the machine goes through:
    every call of a function that receives a Machine, consecutive calls in one file one stop."""
    from volerr_pin.fit.diagnosis import _loop as loop
    from volerr_pin.model import Machine

    package = Path(vp.__file__).parent
    core = {"model", "base"}
    routes, original = [], loop._Loop.round

    def profile(frame, event, arg):
        if event != "call":
            return
        code = frame.f_code
        path = Path(code.co_filename)
        if package not in path.parents or path.relative_to(package).parts[0] in core:
            return
        args = [frame.f_locals.get(a) for a in code.co_varnames[:code.co_argcount + code.co_kwonlyargcount]]
        if any(isinstance(a, Machine) for a in args):
            stop = path.relative_to(package).as_posix()
            if not routes[-1] or routes[-1][-1] != stop:
                routes[-1].append(stop)

    def traced(self, number, may_accept):
        routes.append([])
        sys.setprofile(profile)
        try:
            return original(self, number, may_accept)
        finally:
            sys.setprofile(None)

    loop._Loop.round = traced
    try:
        vp.diagnose(machine, data, max_rounds=rounds)
    finally:
        loop._Loop.round = original
    return routes


def test_a_round_is_a_pipeline_the_machine_goes_through_once(tracker):
    """Following the machine through each round of the sample diagnosis: from the loop to the
    candidates offered on it, to the change accepted and its refit (identify), and no further:
    at most four files, and no file entered again, but the refit of a smaller batch, which goes
    back from identify to the accept stage."""
    m, data = tracker
    routes = _route(m, [data], 8)
    assert len(routes) >= 5
    for route in routes:
        stages = ["fit/diagnosis/_candidates.py", "fit/diagnosis/_changes.py", "fit/identify/_fit.py"]
        assert route[:1] == stages[:1], route
        assert len({"fit/diagnosis/_loop.py", *route}) <= 4, route
        tail = route[1:]
        # changes -> identify, again for each smaller batch: nothing goes back to the candidates
        assert all(a != b and {a, b} <= set(stages[1:]) for a, b in zip(tail, tail[1:])), route
        assert not tail or tail[0] == stages[1]
    assert sum(len(route) == 3 for route in routes) >= 4   # most rounds: each stage once
