"""Every controller's files: signs and units against closed forms, each controller's way of
applying them re-done here from its manual (independently of the readers and the simulation),
round trips, what the controllers refuse, and what each kind of table reaches."""

from __future__ import annotations

import re

import numpy as np
import pytest

import volerr_pin as vp
from volerr_pin.base import InputError, SpecError
from volerr_pin.compensation.export import CONTROLLERS, export_tables, parse_zone
from volerr_pin.compensation.export._siemens import Siemens840D
from volerr_pin.model import add_terms, replace_terms

SCALE_UM_PER_MM = 0.02                                 # EXX = 20 um/m x X


def scale_error_machine(backlash_um: float = 0.0):
    """vmc500 with one error: X's positioning error 20 um/m x X (plus a backlash of X)."""
    m = vp.load_machine("vmc500")
    m = m.with_spec(m.spec.without(*(c for c in m.components if c != "EXX")))
    m = replace_terms(m, {"EXX": {"kind": "monomial", "over": "position", "position_unit": "mm",
                                  "coefficients_um": [0.0, SCALE_UM_PER_MM]}})
    if backlash_um:
        m = add_terms(m, {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": backlash_um}})
    return m


def assignments(text: str, pattern: str) -> dict[str, float]:
    return {m[1]: float(m[2]) for m in re.finditer(pattern, text)}


@pytest.fixture(scope="module")
def scale_exports():
    m = scale_error_machine()
    return m, {name: export_tables(m, name, kind=fmt.kinds[0] if name == "isg" else None, points=512)
               for name, fmt in CONTROLLERS.items()}


def test_isg_leadscrew_values_are_errors_in_tenths_of_a_micrometre(scale_exports):
    m, results = scale_exports
    text = results["isg"].texts["achskw_X.lis"]
    setpoints = assignments(text, r"kw\.ssfk\.table\[(\d+)\]\.setpoint (-?\d+)")
    pos = assignments(text, r"kw\.ssfk\.table\[(\d+)\]\.pos (-?\d+)")
    neg = assignments(text, r"kw\.ssfk\.table\[(\d+)\]\.neg (-?\d+)")
    assert len(setpoints) == len(pos) == len(neg) == 41
    for i, s in setpoints.items():
        x_mm = s * 1e-4
        assert pos[i] == pytest.approx(SCALE_UM_PER_MM * x_mm * 10, abs=1.0)   # +EXX, 0.1 um
        assert neg[i] == pos[i]
    assert results["isg"].summaries["residual"].max_um < 0.06


def test_siemens_lec_values_are_errors_in_mm_at_the_internal_resolution(scale_exports):
    m, results = scale_exports
    text = results["siemens-840d"].texts["AX_EEC.INI"]
    values = assignments(text, r"\$AA_ENC_COMP\[0,(\d+),AX1\]=(-?[\d.]+)")
    lo = float(re.search(r"\$AA_ENC_COMP_MIN\[0,AX1\]=(-?[\d.]+)", text)[1])
    step = float(re.search(r"\$AA_ENC_COMP_STEP\[0,AX1\]=([\d.]+)", text)[1])
    for i, v in values.items():
        assert v == pytest.approx(SCALE_UM_PER_MM * 1e-3 * (lo + step * int(i)), abs=0.00051)  # +EXX, 0.001 mm
    assert text.startswith("%_N_AX_EEC_INI\nCHANDATA(1)\n") and text.endswith("M17\n")
    assert "NC_CEC.INI" in results["siemens-840d"].texts          # the default kind is cec
    assert results["siemens-840d"].summaries["residual"].max_um < 0.51  # 1 um resolution


def test_heidenhain_values_are_errors_and_backlash_is_the_negative_direction(scale_exports):
    m, results = scale_exports
    rows = [line.split() for line in results["heidenhain"].texts["X.COM"].splitlines()[2:-1]]
    header = results["heidenhain"].texts["X.COM"].splitlines()[1].split()
    assert header[:3] == ["NR", "AXISPOS", "X"] and header[-1] == "BACKLASH"
    for row in rows:
        cell = dict(zip(header, row))
        assert float(cell["X"]) == pytest.approx(SCALE_UM_PER_MM * 1e-3 * float(cell["AXISPOS"]), abs=6e-5)
        assert cell["BACKLASH"] == cell["X"]
    assert results["heidenhain"].summaries["residual"].max_um < 0.06


def test_fanuc_increments_are_corrections_zero_at_the_reference(scale_exports):
    m, results = scale_exports
    text = results["fanuc"].texts["PITCH.TXT"]
    params = {int(n): dict(re.findall(r"A(\d)P(-?\d+)", rest))
              for n, rest in re.findall(r"^N(0\d{4})(A.*)$", text, re.M)}
    data = {int(n) - 10000: int(v) for n, v in re.findall(r"^N(1\d{4})P(-?\d+)$", text, re.M)}
    ref, lo, hi, mag, interval = (int(params[p]["1"]) for p in (3620, 3621, 3622, 3623, 3624))
    assert ref == lo and mag == 1 and interval == 12500                     # X from machine 0, 12.5 mm in um
    total = sum(data[n] for n in range(ref + 1, hi + 1))                    # pulses from the reference to 500 mm
    assert total == pytest.approx(-SCALE_UM_PER_MM * 500, abs=1)            # corrections: -10 um
    assert results["fanuc"].summaries["residual"].max_um < 1.3              # 1 um steps of 12.5 mm


def test_linuxcnc_and_volumetric_files_are_exact_enough(scale_exports):
    m, results = scale_exports
    assert results["linuxcnc"].summaries["residual"].max_um < 1e-3
    isg = export_tables(m, "isg", kind="volumetric", points=512)
    text = isg.texts["volcomp_components.csv"]
    block = text[text.index("X  EXX  EYX  EZX  EAX  EBX  ECX"):].split("#")[0].splitlines()[1:]
    assert len(block) == 41
    for row in (line.split() for line in block):
        assert float(row[1]) == pytest.approx(SCALE_UM_PER_MM * 1e-3 * float(row[0]), abs=2e-7)   # EXX in mm
    assert isg.summaries["residual"].max_um < 1e-3


# ------------------------------------------------------------------ each controller's own rules, re-done

def interp_held(nodes, values, x):
    return np.interp(x, nodes, values)                                  # numpy holds the end values


def test_isg_lists_applied_as_the_kernel_does(tmp_path):
    m = vp.load_machine("vmc700")
    result = export_tables(m, "isg", kind="crosscomp2", points=512)
    p = result.points
    expected = np.zeros_like(p.q)
    for j, axis in enumerate(m.axes):
        text = result.texts[f"achskw_{axis}.lis"]
        sp = assignments(text, r"kw\.ssfk\.table\[(\d+)\]\.setpoint (-?\d+)")
        pos = assignments(text, r"kw\.ssfk\.table\[(\d+)\]\.pos (-?\d+)")
        neg = assignments(text, r"kw\.ssfk\.table\[(\d+)\]\.neg (-?\d+)")
        x = np.array([sp[str(i)] for i in range(len(sp))]) * 1e-7
        up = interp_held(x, -np.array([pos[str(i)] for i in range(len(sp))]) * 1e-7, p.q[:, j])
        down = interp_held(x, -np.array([neg[str(i)] for i in range(len(sp))]) * 1e-7, p.q[:, j])
        expected[:, j] += np.where(p.directions[:, j] > 0, up, down)
        if "kw.crosscomp2.interval" in text:
            get = lambda key: int(re.search(rf"kw\.crosscomp2\.{key} (-?\d+)", text)[1])  # noqa: E731
            n1, n2 = get("last_index_master1") + 1, get("last_index_master2") + 1
            g1 = (get("start_position_master1") + get("interval") * np.arange(n1)) * 1e-7
            g2 = (get("start_position_master2") + get("interval") * np.arange(n2)) * 1e-7
            m1, m2 = get("master1_ax_nr") - 1, get("master2_ax_nr") - 1
            table = np.zeros((n2, n1))
            for jj, ii, v in re.findall(r"kw\.crosscomp2\.table\[(\d+)\]\[(\d+)\]\.correction (-?\d+)", text):
                table[int(jj), int(ii)] = -int(v) * 1e-7
            from scipy.interpolate import RegularGridInterpolator

            f = RegularGridInterpolator((g2, g1), table)
            at = np.column_stack([np.clip(p.q[:, m2], g2[0], g2[-1]), np.clip(p.q[:, m1], g1[0], g1[-1])])
            expected[:, j] += f(at)                                     # bilinear, margins held
    np.testing.assert_allclose(result.compensation.correction(p.q, p.directions, p.tool), expected, atol=1e-15)


def test_siemens_tables_applied_as_the_nck_does():
    """LEC both ways; CEC read at the base axis' set-point, one-way tables only moving that way."""
    m = add_terms(vp.load_machine("vmc500"), {"EYY": {"kind": "backlash", "prefix": "rev", "reversal_um": 4.0}})
    result = export_tables(m, "siemens-840d", kind="cec", points=512)
    p = result.points
    expected = np.zeros_like(p.q)
    lec = result.texts["AX_EEC.INI"]
    for j in range(3):
        ax = f"AX{j + 1}"
        values = assignments(lec, rf"\$AA_ENC_COMP\[0,(\d+),{ax}\]=(-?[\d.]+)")
        lo = float(re.search(rf"\$AA_ENC_COMP_MIN\[0,{ax}\]=(-?[\d.]+)", lec)[1])
        step = float(re.search(rf"\$AA_ENC_COMP_STEP\[0,{ax}\]=([\d.]+)", lec)[1])
        grid = (lo + step * np.arange(len(values))) * 1e-3
        expected[:, j] -= interp_held(grid, np.array([values[str(i)] for i in range(len(values))]) * 1e-3, p.q[:, j])
    cec = result.texts["NC_CEC.INI"]
    tables = sorted({int(t) for t in re.findall(r"\$AN_CEC\[(\d+),0\]", cec)})
    directions = []
    for t in tables:
        get = lambda key: re.search(rf"\$AN_CEC_{key}\[{t}\]=(\S+)", cec)[1]  # noqa: E731
        values = assignments(cec, rf"\$AN_CEC\[{t},(\d+)\]=(-?[\d.]+)")
        base, out = int(get("INPUT_AXIS")[3:-1]) - 1, int(get("OUTPUT_AXIS")[3:-1]) - 1
        grid = (float(get("MIN")) + float(get("STEP")) * np.arange(len(values))) * 1e-3
        only = int(get("DIRECTION"))
        directions.append(only)
        value = -interp_held(grid, np.array([values[str(i)] for i in range(len(values))]) * 1e-3, p.q[:, base])
        active = np.ones(len(p.q), bool) if only == 0 else p.directions[:, base] == only
        expected[:, out] += np.where(active, value, 0.0)
    assert directions.count(1) == directions.count(-1) == 3 and len(tables) <= 8
    np.testing.assert_allclose(result.compensation.correction(p.q, p.directions, p.tool), expected, atol=1e-15)
    assert result.summaries["residual"].rms_um < result.summaries["naive"].rms_um


def test_heidenhain_tables_applied_as_the_tnc_does():
    m = vp.load_machine("vmc500")
    result = export_tables(m, "heidenhain", kind="cross", points=512)
    p = result.points
    expected = np.zeros_like(p.q)
    cma = result.texts["CONFIG.CMA"].splitlines()
    header, active = cma[1].split(), cma[2].split()
    assert active[-1] == "*"
    for axis, name in zip(header[1:-1], active[1:-1]):
        m_idx = m.axes.index(axis)
        lines = result.texts[name].splitlines()
        cols = lines[1].split()
        rows = np.array([[float(c) for c in line.split()] for line in lines[2:-1]])
        grid = rows[:, 1] * 1e-3
        for k, col in enumerate(cols[2:-1], 2):
            s = m.axes.index(col)
            up = -interp_held(grid, rows[:, k] * 1e-3, p.q[:, m_idx])
            if s == m_idx:
                down = -interp_held(grid, rows[:, -1] * 1e-3, p.q[:, m_idx])
                expected[:, s] += np.where(p.directions[:, m_idx] > 0, up, down)
            else:
                expected[:, s] += up
    np.testing.assert_allclose(result.compensation.correction(p.q, p.directions, p.tool), expected, atol=1e-15)


def test_fanuc_pulses_applied_as_the_cnc_outputs_them():
    """The compensation at a position is the sum of the increments of the points passed on the
    way from the reference position (moving down, the points above the position are passed
    backwards), in the table of the direction moved; 3627 is where the negative table starts."""
    m = add_terms(vp.load_machine("cgm4000"), {"EXX": {"kind": "backlash", "prefix": "rev", "reversal_um": 5.0}})
    result = export_tables(m, "fanuc", points=512)
    text = result.texts["PITCH.TXT"]
    params = {int(n): {int(a): int(v) for a, v in re.findall(r"A(\d)P(-?\d+)", rest)}
              for n, rest in re.findall(r"^N(0\d{4})(A.*)$", text, re.M)}
    data = {int(n) - 10000: int(v) for n, v in re.findall(r"^N(1\d{4})P(-?\d+)$", text, re.M)}
    p = result.points
    got = result.compensation.correction(p.q, p.directions, p.tool)
    for j in range(len(m.axes)):
        a = j + 1
        unit = (1e-6 if m.axis_kinds[j] == "linear" else np.radians(1e-3)) * params[3623][a]
        ref, lo, hi, interval, neg, at_ref = (params[k][a] for k in (3620, 3621, 3622, 3624, 3626, 3627))
        step = interval * (1e-6 if m.axis_kinds[j] == "linear" else np.radians(1e-3))

        def pulses(x, first, start):
            total = start
            for n in range(lo, hi + 1):
                position = (n - ref) * step
                number = first + (n - lo)
                if 0 < position <= x + 1e-12 and n > ref:
                    total += data[number]
                elif x + 1e-12 < position <= 0 and n <= ref:
                    total -= data[number]
            return total * unit

        for i in range(0, len(p.q), 37):
            x = p.q[i, j]
            want = pulses(x, lo, 0) if p.directions[i, j] > 0 else pulses(x, neg, at_ref)
            assert got[i, j] == pytest.approx(want, abs=1e-15), (m.axes[j], x)
    assert params[3627][1] != 0                                          # X's reversal reaches the reference


# ------------------------------------------------------------------ round trips and reach

def check_export(result):
    fmt = CONTROLLERS[result.controller.name]
    back = fmt.read(result.texts, result.machine)
    p = result.points
    np.testing.assert_allclose(back.correction(p.q, p.directions, p.tool),
                               result.compensation.correction(p.q, p.directions, p.tool), atol=1e-15)
    s = result.summaries
    assert s["residual"].rms_um <= s["naive"].rms_um and s["residual"].max_um <= s["naive"].max_um
    assert s["residual"].rms_um < s["uncompensated"].rms_um
    assert s["exact"].max_um < 1e-4
    if result.kind == "volumetric":
        assert s["node"].max_um - s["node_exact"].max_um < 0.1
        assert s["residual"].max_um < 0.1


KINDS = [(name, kind) for name, fmt in CONTROLLERS.items() for kind in fmt.kinds]


@pytest.mark.parametrize("controller,kind", KINDS)
def test_vmc500_every_kind_round_trips_and_beats_the_naive_tables(controller, kind, tmp_path):
    m = vp.load_machine("vmc500")
    result = export_tables(m, controller, tmp_path, kind=kind, points=512)
    on_disk = {path.name: path.read_text() for path in tmp_path.iterdir()}
    assert on_disk == result.texts and sorted(result.files) == sorted(str(tmp_path / n) for n in on_disk)
    check_export(result)


@pytest.mark.slow
@pytest.mark.parametrize("machine", ["vmc500", "vmc700", "cgm4000"])
@pytest.mark.parametrize("controller,kind", KINDS)
def test_every_controller_round_trips_on_the_three_machines(machine, controller, kind, tmp_path):
    result = export_tables(vp.load_machine(machine), controller, tmp_path, kind=kind, points=2048)
    check_export(result)


@pytest.mark.parametrize("machine", ["vmc700", "cgm4000"])
def test_volumetric_reaches_exact_compensation_at_the_nodes(machine):
    result = export_tables(vp.load_machine(machine), "isg", points=1024)
    assert result.kind == "volumetric"
    check_export(result)


def test_volumetric_with_a_range_of_tools_in_a_zone(machines):
    m = machines["cgm4000"]
    zone = parse_zone(m, ["X=1000:2000", "Y=500:1500", "A=-45:45", "B=-90:90", "tool=0:150"])
    result = export_tables(m, "isg", zone=zone, points=1024, nodes=31)
    assert result.points.tool.max() > 0.1
    assert result.summaries["residual"].max_um < 0.1 < result.summaries["uncompensated"].max_um


def test_a_zone_fit_does_better_in_its_zone_than_a_workspace_fit(machines):
    m = machines["vmc500"]
    zone = parse_zone(m, ["X=0:200", "Y=0:150", "Z=250:400"])
    local = export_tables(m, "heidenhain", zone=zone, points=1024)
    everywhere = export_tables(m, "heidenhain", points=1024)
    inside = local.points
    from volerr_pin.compensation.export._simulate import residuals, summary

    assert summary(residuals(m, local.compensation, inside)).rms_um < summary(
        residuals(m, everywhere.compensation, inside)).rms_um


# ------------------------------------------------------------------ refusals

def test_machines_a_controller_cannot_serve_are_refused(machines):
    with pytest.raises(SpecError, match="J1 is not an NC axis"):
        export_tables(machines["ur5"], "siemens-840d")
    with pytest.raises(SpecError, match="precisely three linear axes X, Y, Z"):
        export_tables(machines["lathe_2axis"], "isg", kind="volumetric")
    assert export_tables(machines["lathe_2axis"], "isg", points=256).kind == "crosscomp2"   # the most that fits
    with pytest.raises(InputError, match="kind: fanuc has no tables of kind 'cec'"):
        export_tables(machines["vmc500"], "fanuc", kind="cec")
    with pytest.raises(InputError, match="unknown controller 'okuma'"):
        export_tables(machines["vmc500"], "okuma")


@pytest.mark.parametrize("controller,nodes,match", [
    ("linuxcnc", 300, "LinuxCNC holds 2 to 256"), ("heidenhain", 257, "a .COM table holds 2 to 256"),
    ("fanuc", 200, "the CNC holds 128 per axis"), ("isg", 1501, "kw.ssfk"),
])
def test_too_many_points_are_refused(machines, controller, nodes, match):
    kind = "ssfk" if controller == "isg" else None
    with pytest.raises(InputError, match=match) as err:
        export_tables(machines["vmc500"], controller, kind=kind, nodes=nodes)
    assert err.value.parameters == ("nodes",)


def test_values_beyond_a_format_are_refused():
    m = vp.load_machine("vmc500")
    m = replace_terms(m.with_spec(m.spec.without(*(c for c in m.components if c != "EXX"))),
                      {"EXX": {"kind": "monomial", "over": "position", "position_unit": "mm",
                               "coefficients_um": [0.0, 10.0]}})
    with pytest.raises(InputError, match="beyond the lists' 32767"):          # 5 mm of error in 0.1 um units
        export_tables(m, "isg", kind="ssfk", points=256)
    m = replace_terms(m, {"EXX": {"kind": "monomial", "over": "position", "position_unit": "mm",
                                  "coefficients_um": [0.0, 50.0]}})
    with pytest.raises(InputError, match="beyond 127 x 100"):              # 25 mm in one section of 500 mm
        export_tables(m, "fanuc", nodes=2, points=256)


@pytest.fixture(scope="module")
def small_exports():
    m = vp.load_machine("vmc500")
    return {name: export_tables(m, name, kind="ssfk" if name == "isg" else None, points=256) for name in CONTROLLERS}


@pytest.mark.parametrize("controller,name,line,new,match", [
    ("isg", "achskw_Y.lis", "kw.ssfk.table[3].setpoint", "kw.ssfk.table[3].setpoint -9", "does not ascend"),
    ("isg", "achskw_Y.lis", "kw.ssfk.table[3].pos", "kw.ssfk.table[3].pos 99999", "beyond"),
    ("isg", "achskw_Y.lis", "kw.ssfk.kw_nr_max", "kw.ssfk.kw_nr_max 1600", "outside 2..1499"),
    ("siemens-840d", "AX_EEC.INI", "$AA_ENC_COMP_STEP[0,AX1]=", "$AA_ENC_COMP_STEP[0,AX1]=9", "is not MAX"),
    ("siemens-840d", "AX_EEC.INI", "$AA_ENC_COMP[0,2,AX1]=", "$AA_ENC_COMP[0,2,AX1]=abc", "is not a number"),
    ("heidenhain", "Y.COM", "     3 ", "     7 +0.0000", "NR '7' out of sequence"),
    ("heidenhain", "Y.COM", "     3 ", "AXISPOS=+900.0000", "AXISPOS does not increase"),
    ("fanuc", "PITCH.TXT", "N10003P", "N10003P999", "beyond"),
    ("fanuc", "PITCH.TXT", "N03624", "N03624A1P-5A2P1A3P1", "do not describe a table"),
    ("linuxcnc", "joint1_Y.comp", "20.000000", "# a comment", "not three numbers"),
])
def test_tampered_files_are_refused_when_read(machines, small_exports, controller, name, line, new, match):
    """A line of a written file replaced: what the controller would refuse, the reader refuses."""
    result = small_exports[controller]
    lines = result.texts[name].splitlines()
    k = next(i for i, text in enumerate(lines) if text.startswith(line))
    if new.startswith("AXISPOS="):                                 # the cell of a fixed-width column
        new = lines[k][:6] + f"{new[8:]:>14}" + lines[k][20:]
    tampered = "\n".join(lines[:k] + [new] + lines[k + 1:]) + "\n"
    with pytest.raises(InputError, match=match):
        CONTROLLERS[controller].read({**result.texts, name: tampered}, machines["vmc500"])


def test_siemens_resolution_is_a_setting():
    m = scale_error_machine()
    fine = export_tables(m, Siemens840D(increments_per_mm=10000), kind="lec", points=512)
    assert "=0.0100" in fine.texts["AX_EEC.INI"]                          # 10 um at 500 mm, 4 decimals
    assert fine.summaries["residual"].max_um < 0.06
