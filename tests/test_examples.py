"""The examples are programs that run in CI."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

import volerr_pin as vp

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_seed001_example(tmp_path, capsys):
    result = load("seed001_z_axis").main(tmp_path)
    assert result["iso"]["E_up"] == pytest.approx(0.2389, abs=1e-4)   # from the published table
    assert result["report"]["rank"] == 6 and result["report"]["n_parameters"] == 7
    assert result["unseen_rms_um"] < result["raw_rms_um"]               # the model helps on a new run
    assert vp.load_machine(result["spec"]).name == "vmc500"
    assert "EZZ.c0 cannot be told from the interferometer zero" in capsys.readouterr().out
