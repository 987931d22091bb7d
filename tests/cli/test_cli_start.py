"""How the command line starts: ``--help`` and shell completion without loading the model,
"did you mean" for a misspelt command, and completion of commands, options and machines."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

import pytest

from volerr_pin.cli import COMMANDS, build_parser, main

#: what the model loads: none of it is needed to list the commands or one command's options
HEAVY = ("pinocchio", "scipy", "numba", "rerun", "matplotlib", "dask", "SALib", "lxml", "yourdfpy")

_IMPORTS = """
import sys
from volerr_pin.cli import main
try:
    main({argv!r})
except SystemExit:
    pass
print("loaded:" + ",".join(sorted({{m.split(".")[0] for m in sys.modules}} & set({heavy!r}))), file=sys.stderr)
"""


def _loaded(argv: list[str]) -> list[str]:
    code = _IMPORTS.format(argv=argv, heavy=HEAVY)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    line = run.stderr.splitlines()[-1]
    assert line.startswith("loaded:"), run.stderr
    return [m for m in line.removeprefix("loaded:").split(",") if m]


@pytest.mark.parametrize("argv", [["--help"], ["rank", "--help"], ["field", "--help"], ["gear", "--help"],
                                  ["tolerance", "--help"], ["rnak"]])
def test_help_and_a_misspelt_command_load_nothing_of_the_model(argv):
    assert _loaded(argv) == []


def test_a_command_that_runs_loads_the_model():
    """The check above can fail: the same probe sees the model once a command runs."""
    assert {"pinocchio", "scipy"} <= set(_loaded(["info", "vmc500", "--json"]))


def _subparsers(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def test_the_listed_commands_are_the_built_ones_with_the_same_help():
    full, listed = _subparsers(build_parser()), _subparsers(build_parser(commands=()))
    assert list(full.choices) == list(listed.choices) == [c.COMMAND for c in COMMANDS]
    assert [(a.dest, a.help) for a in full._choices_actions] == [(a.dest, a.help) for a in listed._choices_actions]
    # a listed command has no options of its own; a built one has them
    assert [a.dest for a in listed.choices["rank"]._actions] == ["help"]
    assert "points" in [a.dest for a in full.choices["rank"]._actions]


def test_one_command_built_parses_as_all_built():
    argv = ["rank", "vmc500", "--points", "64", "--seed", "3", "--json"]
    assert vars(build_parser(commands={"rank"}).parse_args(argv)) == vars(build_parser().parse_args(argv))


@pytest.mark.parametrize("typo, meant", [("rnak", "rank"), ("diagnos", "diagnose"), ("thermalfit", "thermal-fit"),
                                         ("iso230", "iso230-2"), ("tolerances", "tolerance")])
def test_a_misspelt_command_is_suggested(capsys, typo, meant):
    with pytest.raises(SystemExit) as stop:
        main([typo, "vmc500"])
    assert stop.value.code == 2
    assert capsys.readouterr().err.rstrip().endswith(f"invalid choice: '{typo}' (choose from "
                                                     + ", ".join(f"'{c.COMMAND}'" for c in COMMANDS)
                                                     + f"); did you mean {meant}?")


def test_a_word_like_no_command_gets_no_suggestion(capsys):
    with pytest.raises(SystemExit):
        main(["calibrate", "vmc500"])
    assert "did you mean" not in capsys.readouterr().err


def _complete(line: str, tmp_path) -> list[str]:
    """What the shell gets on TAB at the end of ``line``, by argcomplete's protocol (the
    variables its bash function sets; the candidates written to a file instead of fd 8)."""
    out = tmp_path / "candidates"
    env = dict(os.environ, _ARGCOMPLETE="1", _ARGCOMPLETE_IFS="\n", COMP_LINE=line, COMP_POINT=str(len(line)),
               _ARGCOMPLETE_STDOUT_FILENAME=str(out))
    subprocess.run([sys.executable, "-c", "from volerr_pin.cli import main; main()"], env=env, cwd=tmp_path,
                   capture_output=True, check=True, timeout=120)
    return [c.strip() for c in out.read_text().split("\n") if c.strip()]


@pytest.mark.parametrize("line, expected", [
    ("volerr ra", ["rank"]),
    ("volerr thermal-f", ["thermal-fit"]),
    ("volerr rank vm", ["vmc500", "vmc700"]),
    ("volerr info cg", ["cgm4000"]),
    ("volerr rank vmc500 --to", ["--tool-frame", "--tolerances", "--top"]),
    ("volerr export vmc500 --controller ", ["linuxcnc", "isg", "siemens-840d", "heidenhain", "fanuc"]),
    ("volerr demo --machine ur", ["ur5"]),
])
def test_shell_completion(tmp_path, line, expected):
    assert _complete(line, tmp_path) == expected


def test_completion_of_a_machine_offers_specs_and_urdfs_beside_the_bundled_names(tmp_path):
    (tmp_path / "vmc_mine.toml").write_text("")
    (tmp_path / "vmc_notes.txt").write_text("")
    (tmp_path / "vmc_folder").mkdir()
    got = _complete("volerr info vmc", tmp_path)
    assert got[:2] == ["vmc500", "vmc700"]
    assert "vmc_mine.toml" in got and "vmc_folder/" in got
    assert "vmc_notes.txt" not in got


def test_bash_completes_through_the_registered_function(tmp_path):
    """The README's line, in a real bash: the function argcomplete registers gets the machines."""
    register = os.path.join(os.path.dirname(sys.executable), "register-python-argcomplete")
    volerr = os.path.join(os.path.dirname(sys.executable), "volerr")
    if not (os.path.exists(register) and os.path.exists(volerr)):
        pytest.skip("not installed as scripts beside this Python")
    script = ('eval "$(register-python-argcomplete volerr)"; COMP_LINE="volerr rank vm"; '
              'COMP_POINT=${#COMP_LINE}; COMP_WORDS=(volerr rank vm); COMP_CWORD=2; COMP_TYPE=9; '
              '_python_argcomplete volerr vm rank; printf "%s\\n" "${COMPREPLY[@]}"')
    env = dict(os.environ, PATH=os.path.dirname(sys.executable) + os.pathsep + os.environ.get("PATH", ""))
    run = subprocess.run(["bash", "-c", script], env=env, cwd=tmp_path, capture_output=True, text=True, check=True,
                         timeout=120)
    assert run.stdout.split() == ["vmc500", "vmc700"]
