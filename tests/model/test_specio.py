"""Changing a machine's terms: what refitting as polynomials accepts."""

from __future__ import annotations

import pytest

import volerr_pin as vp
from volerr_pin.model import MAX_DEGREE, build_model, legendre_terms
from volerr_pin.cli import main


def test_legendre_degree_is_bounded(machines):
    m = machines["vmc500"]
    assert len(legendre_terms(m, ["EXX"], MAX_DEGREE)["EXX"].coefficients) == MAX_DEGREE + 1
    for degree in (-1, MAX_DEGREE + 1, 1000):
        with pytest.raises(vp.InputError, match=f"degree must be 0 to {MAX_DEGREE}, got {degree}") as info:
            legendre_terms(m, ["EXX"], degree)
        assert info.value.parameters == ("degree",)


def test_identify_names_the_degree_option(tmp_path, capsys):
    from pathlib import Path

    data = Path(__file__).resolve().parents[2] / "examples" / "data" / "vmc500_x_positioning.csv"
    assert main(["identify", "vmc500", str(data), "--terms", "EXX", "--degree", "1000"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"volerr: error: --degree must be 0 to {MAX_DEGREE}, got 1000 (a polynomial of higher degree over the travel "
        "follows the noise, not the geometry; a table term holds finer detail)")


def test_check_values_refuses_what_a_spec_file_would(machines):
    """A fit can take a coefficient where a spec cannot hold it (a period of 1e8 deg, an angular
    error of 3,000 rad); the check names it as reading a spec would, and passes the rest."""
    import numpy as np

    from volerr_pin.base import SpecError
    from volerr_pin.model import add_terms, check_values

    m = add_terms(machines["cgm4000"], {"EBB": {"kind": "periodic_pitch", "prefix": "rotary", "period_deg": 360.0,
                                                "sine_arcsec": [5.0], "cosine_arcsec": [2.0], "origin_deg": 0.0}})
    check_values(m)
    for name, value, what in [("EBB.rotary.period", 1.84e6, "105424234.3 deg is implausible"),
                              ("EBB.rotary.s1", -3060.9, ".* arcsec is implausible")]:
        theta = m.theta.copy()
        theta[m.parameter_names.index(name)] = value
        with pytest.raises(SpecError, match=f"\\(present values\\): theta\\[\\d+\\] \\({name}\\) = {what}"):
            check_values(m.with_theta(theta, limits=False))   # as a fit makes it
    theta = m.theta.copy()
    theta[m.parameter_names.index("EBB.rotary.period")] = np.radians(1e6)   # far, but a spec holds it
    check_values(m.with_theta(theta))


def _counting_builds(monkeypatch) -> list:
    """Record every build of a Pinocchio model from an injected URDF."""
    import volerr_pin.model._model as assembly

    built, build = [], assembly.pin.buildModelFromXML

    def counted(*args, **kwargs):
        built.append(1)
        return build(*args, **kwargs)

    monkeypatch.setattr(assembly.pin, "buildModelFromXML", counted)
    return built


@pytest.mark.parametrize("name", ["vmc500", "cgm4000"])
def test_an_edited_machine_is_the_machine_its_spec_builds(monkeypatch, name):
    """Edits share the model they were made from: a raised degree builds nothing; the first
    location error (new error joints) builds once, with room for every later one; an edit back
    to the first error joints uses the first model. Each edit is
    the machine its spec builds afresh, to the last bit: errors, sensitivities, error joints and
    coefficients (the unused error joints stay at zero)."""
    import numpy as np

    from conftest import random_q
    from volerr_pin.model import add_terms

    m = vp.load_machine(name)  # its own: the structures it gathers are shared with its edits
    built = _counting_builds(monkeypatch)
    owner = m.axes[0]
    raised = add_terms(m, legendre_terms(m, [m.components[0]], 4, start=3))
    square = add_terms(raised, {f"EC0{owner}": {"kind": "constant", "prefix": "sq", "value_arcsec": 20.0}})
    both = add_terms(square, {f"EX0{owner}": {"kind": "constant", "prefix": "sq", "value_um": 3.0}})
    back = both.with_spec(both.spec.without(f"EC0{owner}", f"EX0{owner}"))
    assert len(built) == 1
    assert raised.model.pinocchio is m.model.pinocchio
    assert both.model.pinocchio is square.model.pinocchio
    assert back.model.pinocchio is m.model.pinocchio  # the first structure that holds its error joints
    built.clear()
    q = random_q(m, 50, seed=3)
    rng = np.random.default_rng(3)
    for edited in (raised, square, both, back):
        fresh = vp.Machine(build_model(edited.spec, edited.urdf, edited.package_dirs))
        assert (fresh.error_joints, fresh.parameter_names) == (edited.error_joints, edited.parameter_names)
        theta = edited.theta + 1e-6 * rng.normal(size=len(edited.theta))
        cov = {"t": np.linspace(0, 3600, len(q))}
        np.testing.assert_array_equal(edited.volumetric_error(q, theta, **cov), fresh.volumetric_error(q, theta, **cov))
        np.testing.assert_array_equal(edited.sensitivity(q, theta, **cov), fresh.sensitivity(q, theta, **cov))
        np.testing.assert_array_equal(edited.error_joint_sensitivity(q, theta, **cov),
                                      fresh.error_joint_sensitivity(q, theta, **cov))
    assert len(built) == 4  # the fresh ones
