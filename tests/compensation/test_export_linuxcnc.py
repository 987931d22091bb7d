"""LinuxCNC's comp files, checked against LinuxCNC's own parsing and compensation rules,
re-implemented here from its source independently of the writer:

- ``usrmotLoadComp`` (src/emc/motion/usrmotintf.cc): ``fgets`` a line of at most LINELEN - 1
  characters, ``sscanf(buffer, "%lf %lf %lf")``; anything but 3 conversions ends the file
  silently; type 1 sends the three numbers as they are;
- ``EMCMOT_SET_JOINT_COMP`` (src/emc/motion/command.c): an entry beyond EMCMOT_COMP_SIZE (256)
  is refused ("too many compensation entries"), a nominal not above the previous one is
  refused ("compensation values must increase"); slopes run from each entry to the next, the
  sentinels at -/+DBL_MAX hold the end trims;
- ``compute_screw_comp`` (src/emc/motion/control.c): walk to the entry below the commanded
  position, trim + slope x (position - nominal), forward trim while the commanded velocity is
  positive, reverse while negative, the last value kept at standstill; added to the command.
"""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.base import InputError
from volerr_pin.compensation.export import Zone, export_tables
from volerr_pin.compensation.export._linuxcnc import LinuxCNC
from volerr_pin.model import add_terms, replace_terms

LINELEN = 255
EMCMOT_COMP_SIZE = 256
DBL_MAX = sys.float_info.max
_FLOAT = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)", re.IGNORECASE)


def c_sscanf_three_doubles(buffer: str) -> tuple[int, list[float]]:
    """C's ``sscanf(buffer, "%lf %lf %lf", ...)``: the number of conversions and the values.
    Each %lf skips white space and takes the longest strtod prefix; the spaces in the format
    match any white space, or none; what follows the third number is ignored; an input that
    ends before the first conversion gives EOF (-1)."""
    pos, values = 0, []
    for _ in range(3):
        while pos < len(buffer) and buffer[pos] in " \t\n\v\f\r":
            pos += 1
        if pos == len(buffer):
            return (-1 if not values else len(values)), values
        m = _FLOAT.match(buffer, pos)
        if m is None:
            return len(values), values
        values.append(float(m.group(0)))
        pos = m.end()
    return 3, values


def linuxcnc_load_comp(text: str, comp_type: int = 1) -> tuple[list[tuple[float, float, float]], list[str]]:
    """The entries LinuxCNC's motion controller holds after loading ``text``, and its errors."""
    entries, errors = [], []
    lines = text.splitlines(keepends=True)
    chunks = []
    for line in lines:                                       # fgets: at most LINELEN - 1 characters a call
        while len(line) > LINELEN - 1:
            chunks.append(line[:LINELEN - 1])
            line = line[LINELEN - 1:]
        chunks.append(line)
    for buffer in chunks:
        count, (values) = c_sscanf_three_doubles(buffer)
        if count != 3:
            break
        nom, fwd, rev = values
        if comp_type == 0:
            fwd, rev = nom - fwd, nom - rev
        if len(entries) >= EMCMOT_COMP_SIZE:
            errors.append("too many compensation entries")
            continue
        if nom <= (entries[-1][0] if entries else -DBL_MAX):
            errors.append("compensation values must increase")
            continue
        entries.append((nom, fwd, rev))
    return entries, errors


def linuxcnc_screw_comp(entries, positions, velocities) -> np.ndarray:
    """``compute_screw_comp`` along a path: the correction added to each commanded position."""
    nominal = [-DBL_MAX] + [e[0] for e in entries] + [DBL_MAX]
    fwd = [entries[0][1]] + [e[1] for e in entries] + [0.0]
    rev = [entries[0][2]] + [e[2] for e in entries] + [0.0]
    fslope, rslope = [0.0] * len(nominal), [0.0] * len(nominal)
    for k in range(1, len(entries)):
        dx = nominal[k + 1] - nominal[k]
        fslope[k] = (fwd[k + 1] - fwd[k]) / dx
        rslope[k] = (rev[k + 1] - rev[k]) / dx
    entry, corr, out = 0, 0.0, []
    for pos, vel in zip(positions, velocities):
        while pos < nominal[entry]:
            entry -= 1
        while pos >= nominal[entry + 1]:
            entry += 1
        dpos = pos - nominal[entry]
        if vel > 0:
            corr = fwd[entry] + fslope[entry] * dpos
        elif vel < 0:
            corr = rev[entry] + rslope[entry] * dpos
        out.append(corr)
    return np.array(out)


def ini_sections(text: str) -> dict[str, dict[str, str]]:
    sections, current = {}, None
    for line in text.splitlines():
        line = line.strip()
        if not line or line[0] in "#;":
            continue
        if line.startswith("["):
            current = sections.setdefault(line.strip("[]"), {})
        else:
            key, _, value = line.partition("=")
            current[key.strip()] = value.strip()
    return sections


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    m = vp.load_machine("cgm4000")
    folder = tmp_path_factory.mktemp("linuxcnc")
    return m, folder, export_tables(m, "linuxcnc", folder, points=1024)


def test_linuxcnc_reads_every_entry_we_write_and_nothing_else(export):
    m, folder, result = export
    sections = ini_sections((folder / "compensation.ini").read_text())
    for j, axis in enumerate(m.axes):
        section = sections[f"JOINT_{j}"]
        assert section["COMP_FILE_TYPE"] == "1"
        text = (folder / section["COMP_FILE"]).read_text()
        entries, errors = linuxcnc_load_comp(text)
        assert not errors
        assert len(entries) == len(text.splitlines()) == 41               # nothing cut, nothing refused
        table = result.compensation.tables[j]
        unit = 1e-3 if m.axis_kinds[j] == "linear" else np.pi / 180
        np.testing.assert_allclose(np.array(entries)[:, 0] * unit, table.nodes[0], atol=1e-15)
        np.testing.assert_allclose(np.array(entries)[:, 1] * unit, table.values[0], atol=1e-18)
        np.testing.assert_allclose(np.array(entries)[:, 2] * unit, table.values[1], atol=1e-18)


def test_linuxcnc_applies_the_files_as_the_simulation_does(export):
    """Along the evaluation path (directions from the motion, held at standstill) LinuxCNC's
    screw compensation of each joint equals the correction the residual was simulated with."""
    m, folder, result = export
    sections = ini_sections((folder / "compensation.ini").read_text())
    p = result.points
    ours = result.compensation.correction(p.q, p.directions, p.tool)
    for j in range(len(m.axes)):
        entries, _ = linuxcnc_load_comp((folder / sections[f"JOINT_{j}"]["COMP_FILE"]).read_text())
        unit = 1e-3 if m.axis_kinds[j] == "linear" else np.pi / 180
        theirs = linuxcnc_screw_comp(entries, p.q[:, j] / unit, p.directions[:, j]) * unit
        np.testing.assert_allclose(theirs, ours[:, j], atol=1e-15)
    # and outside the table the end trims hold
    entries, _ = linuxcnc_load_comp((folder / sections["JOINT_0"]["COMP_FILE"]).read_text())
    far = linuxcnc_screw_comp(entries, [-1e6, 1e6, 1e6], [1, 1, 0])
    assert far[0] == entries[0][1] and far[1] == far[2] == entries[-1][1]


def test_the_independent_parser_sees_what_linuxcnc_would_cut():
    entries, _ = linuxcnc_load_comp("# header\n0 0 0\n1 1 1\n")
    assert entries == []                                              # stops at the comment: nothing loaded
    entries, _ = linuxcnc_load_comp("0 0 0\n1 1 1\n\n2 2 2\n")
    assert len(entries) == 2                                          # an empty line ends the table
    entries, _ = linuxcnc_load_comp("0 0.5 -0.5 trailing words\n1-1 2\n")
    assert entries == [(0.0, 0.5, -0.5), (1.0, -1.0, 2.0)]           # sscanf takes "1-1" as 1 and -1
    entries, errors = linuxcnc_load_comp("0 0 0\n2 0 0\n1 0 0\n")
    assert len(entries) == 2 and errors == ["compensation values must increase"]
    entries, errors = linuxcnc_load_comp("".join(f"{i} 0 0\n" for i in range(300)))
    assert len(entries) == 256 and errors.count("too many compensation entries") == 44


def test_our_reader_refuses_what_linuxcnc_would_cut_or_refuse(export):
    m, folder, result = export
    fmt = LinuxCNC()
    texts = {p.name: p.read_text() for p in folder.iterdir()}
    name = "joint0_X.comp"
    for bad, match in (("# header\n" + texts[name], "joint0_X.comp:1: not three numbers"),
                       (texts[name].replace("\n", "\n\n", 1), "joint0_X.comp:2: not three numbers"),
                       ("5 0 0\n4 0 0\n", "does not increase"),
                       ("".join(f"{i} 0 0\n" for i in range(257)), "257 entries")):
        with pytest.raises(InputError, match=match):
            fmt.read({**texts, name: bad}, m)
    with pytest.raises(InputError, match="COMP_FILE_TYPE must be 1"):
        ini = texts["compensation.ini"].replace("COMP_FILE_TYPE = 1", "COMP_FILE_TYPE = 0", 1)
        fmt.read({**texts, "compensation.ini": ini}, m)
    with pytest.raises(InputError, match="nodes: LinuxCNC holds 2 to 256"):
        export_tables(m, "linuxcnc", nodes=257)


def test_trims_are_corrections_and_reversal_goes_into_the_columns():
    """X of vmc500 with only a scale error of 20 um/m and a 3 um backlash: the forward trim is
    -20 um/m x X - 1.5 um, the reverse trim -20 um/m x X + 1.5 um (backlash: +b/2 moving +)."""
    m = vp.load_machine("vmc500")
    m = m.with_spec(m.spec.without(*(c for c in m.components if c != "EXX")))
    m = replace_terms(m, {"EXX": {"kind": "monomial", "over": "position", "position_unit": "mm",
                                  "coefficients_um": [0.0, 0.02]}})
    m = add_terms(m, {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 3.0}})
    result = export_tables(m, "linuxcnc", zone=Zone.workspace(m), points=512)
    lines = result.texts["joint0_X.comp"].splitlines()
    for line in lines:
        x, fwd, rev = map(float, line.split())
        assert fwd == pytest.approx(-0.02e-3 * x - 1.5e-3, abs=2e-6)
        assert rev == pytest.approx(-0.02e-3 * x + 1.5e-3, abs=2e-6)
    assert result.summaries["residual"].max_um < 0.01
    assert result.summaries["uncompensated"].max_um > 10
