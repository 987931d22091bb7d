"""Changing a machine's terms: what refitting as polynomials accepts."""

from __future__ import annotations

import pytest

import volerr_pin as vp
from volerr_pin.cli import main
from volerr_pin.specio import MAX_DEGREE, legendre_terms


def test_legendre_degree_is_bounded(machines):
    m = machines["vmc500"]
    assert len(legendre_terms(m, ["EXX"], MAX_DEGREE)["EXX"]["coefficients_um"]) == MAX_DEGREE + 1
    for degree in (-1, MAX_DEGREE + 1, 1000):
        with pytest.raises(vp.InputError, match=f"degree must be 0 to {MAX_DEGREE}, got {degree}") as info:
            legendre_terms(m, ["EXX"], degree)
        assert info.value.parameters == ("degree",)


def test_identify_names_the_degree_option(tmp_path, capsys):
    from pathlib import Path

    data = Path(__file__).resolve().parents[1] / "examples" / "data" / "vmc500_x_positioning.csv"
    assert main(["identify", "vmc500", str(data), "--terms", "EXX", "--degree", "1000"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"volerr: error: --degree must be 0 to {MAX_DEGREE}, got 1000 (a polynomial of higher degree over the travel "
        "follows the noise, not the geometry; a table term holds finer detail)")


def test_check_values_refuses_what_a_spec_file_would(machines):
    """A fit can take a coefficient where a spec cannot hold it (a period of 1e8 deg, an angular
    error of 3,000 rad); the check names it as reading a spec would, and passes the rest."""
    import numpy as np

    from volerr_pin.errors import SpecError
    from volerr_pin.specio import add_terms, check_values

    m = add_terms(machines["cgm4000"], {"EBB": {"kind": "periodic_pitch", "prefix": "rotary", "period_deg": 360.0,
                                                "sine_arcsec": [5.0], "cosine_arcsec": [2.0], "origin_deg": 0.0}})
    check_values(m)
    for name, value, what in [("EBB.rotary.period", 1.84e6, "period_deg: 105424234.3 deg is implausible"),
                              ("EBB.rotary.s1", -3060.9, "sine_arcsec.*is implausible")]:
        theta = m.theta.copy()
        theta[m.parameter_names.index(name)] = value
        with pytest.raises(SpecError, match=f"\\(present values\\): errors.EBB.terms\\[\\d\\].{what}"):
            check_values(m._with_theta(theta))   # as a fit makes it
    theta = m.theta.copy()
    theta[m.parameter_names.index("EBB.rotary.period")] = np.radians(1e6)   # far, but a spec holds it
    check_values(m.with_theta(theta))
