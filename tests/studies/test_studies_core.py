"""The studies, the simulated campaigns, the measurements' observations, the gear flanks and the
pictures evaluate the model through its algorithms (``volumetric_error(model, q, theta, cov)``
...), not through the checking methods of :class:`~volerr_pin.model.Machine`, which are for
users: the value checks run once where user input enters, never per block or per draw.

Two counts: the checking methods are wrapped and every call made from these packages is
recorded while small studies, plans and simulations run (the Monte Carlo workers' tasks run in
this process, so their calls are seen); and the source of these packages names none of the
methods as an attribute (a call, or a bound method passed on as a callable).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import volerr_pin as vp
from volerr_pin.model import grid

from conftest import CHECKING_METHODS as CHECKING, record_checking_calls

ROOT = Path(__file__).resolve().parents[2]

#: the modules whose calls are counted: the layers above the model that evaluate it in loops
WATCHED = ("volerr_pin.studies", "volerr_pin.measurements", "volerr_pin.applications.gear", "volerr_pin.viz")
#: their source files, the other applications that read measurements into the model, and the
#: commands that run them
SOURCES = [*sorted((ROOT / "volerr_pin" / "studies").rglob("*.py")),
           *sorted((ROOT / "volerr_pin" / "measurements").rglob("*.py")),
           *sorted((ROOT / "volerr_pin" / "applications" / "gear").rglob("*.py")),
           *sorted((ROOT / "volerr_pin" / "viz").rglob("*.py")),
           *(ROOT / "volerr_pin" / "applications" / f"{name}.py"
             for name in ("thermal", "thermalfit", "dh", "axisfit", "iso230")),
           *(ROOT / "volerr_pin" / "cli" / f"_{name}.py"
             for name in ("uncertainty", "tolerance", "plan", "ballbar", "iso230", "thermal_fit", "gear", "dh",
                          "field", "demo"))]


@pytest.fixture
def calls(monkeypatch):
    """Calls of the checking methods whose immediate caller is a module of :data:`WATCHED`:
    (method, module, function, line) in call order."""
    return record_checking_calls(monkeypatch, *WATCHED)


@pytest.fixture(scope="module")
def vmc500():
    return vp.load_machine("vmc500")


def test_the_count_sees_a_call_from_a_watched_module(calls, vmc500):
    """The count can fail: a call made from a module of the studies is recorded, one made
    elsewhere is not."""
    vmc500.volumetric_error(vmc500.mid_travel)
    exec("machine.volumetric_error(machine.mid_travel)", {"__name__": "volerr_pin.studies.anywhere", "machine": vmc500})
    assert [c[:2] for c in calls] == [("volumetric_error", "volerr_pin.studies.anywhere")]


def test_an_uncertainty_study_calls_the_algorithms(calls, vmc500):
    from volerr_pin.studies import InProcess, covariance_from_campaign, study_uncertainty

    machine = vmc500.with_state(t=600.0, temperatures={"spindle": 24.0}, directions=[1, -1, 1])
    covariance = covariance_from_campaign(machine, 1e-6, points=30)
    study = study_uncertainty(covariance, grid(machine, 3), samples=8, interval_samples=4, compensation="point",
                              engine=InProcess())
    assert study.compensated is not None
    assert not calls, sorted(set(calls))


def test_a_tolerance_study_calls_the_algorithms(calls, vmc500):
    from volerr_pin.studies import InProcess, read_tolerance_file, study_tolerances

    tolerances = read_tolerance_file(ROOT / "examples" / "data" / "vmc500_tolerances.toml", vmc500)
    study = study_tolerances(vmc500, tolerances, grid(vmc500, 3), samples=16, seed=1, sobol_samples=4,
                             target=10e-6, engine=InProcess())
    assert study.reallocation is not None and study.sobol is not None
    assert not calls, sorted(set(calls))


@pytest.mark.parametrize("name, budget, criterion", [("tracker", 8, "I"), ("ballbar", 2, "D")])
def test_a_plan_and_its_simulated_campaigns_call_the_algorithms(calls, vmc500, name, budget, criterion):
    from volerr_pin.studies.plan import instrument, make_setup, plan

    inst = instrument(name)
    setup = make_setup(vmc500, inst, station=[2.0, -1.0, 0.3]) if name == "tracker" else None
    result = plan(vmc500, inst, budget, setup, candidates=32, zone_points=16, compare=True, repeats=1,
                  criterion=criterion)
    assert len(result.units) == budget
    assert not calls, sorted(set(calls))


def test_a_plan_after_a_diagnosis_calls_the_algorithms(calls, vmc500):
    from volerr_pin.studies.plan import instrument, make_setup
    from volerr_pin.studies.plan import after_diagnosis

    report = {"machine": "vmc500", "effects": [{"name": "straightness", "component": "EAZ",
                                                "same_at_tool_as": ["EYX", "EYZ"]}], "under_modelled": []}
    inst = instrument("tracker")
    after = after_diagnosis(vmc500, inst, make_setup(vmc500, inst), report, 6, candidates=64)
    assert after.simulation
    assert not calls, sorted(set(calls))


def test_simulated_measurements_and_their_observations_call_the_algorithms(calls, vmc500):
    from volerr_pin.measurements import ObservationOptions
    from volerr_pin.measurements._simulate import ballbar_run, campaign, heldout_set, tracker_campaign

    truth, points = heldout_set(vmc500, n=20, seed=2)
    runs = [points, campaign(truth, n=10), ballbar_run(truth, radius_mm=50.0, n=36),
            tracker_campaign(truth, n=6, offsets_mm=((0, 0, 0), (0, 0, -100)))]
    for run in runs:
        run.observations(vmc500, ObservationOptions(1.0, 1.0))
    assert not calls, sorted(set(calls))


def test_gear_flanks_call_the_algorithms(calls):
    from volerr_pin.applications.gear import flank_deviations

    machine = vp.load_machine("gear_roller")
    flank_deviations(machine, profile_points=5, face_points=3, tooth_numbers=[0, 1])
    assert not calls, sorted(set(calls))


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_checking_method_is_named_in_the_source(path):
    """No ``x.volumetric_error(...)`` nor ``fn=x.tool_poses``: the algorithms are free functions
    (``volumetric_error(model, ...)``), so an attribute of one of these names is a Machine's."""
    named = [f"{path.name}:{node.lineno}: .{node.attr}" for node in ast.walk(ast.parse(path.read_text()))
             if isinstance(node, ast.Attribute) and node.attr in CHECKING]
    assert not named, "checking Machine methods named: " + "; ".join(named)
