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
