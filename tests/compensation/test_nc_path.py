"""Issue 25: an independent check of compensated programs.

The compensated program is read back with a minimal parser of this file's own (not the
product's reader), every output segment is interpolated densely as a controller does (lines
linear in the program coordinates, G2/G3 as circles in the plane with the third axis linear),
the *actual* tool (tool tip and tool axis, through :meth:`Machine.tool_poses` with the errors)
is evaluated along it and compared with the *programmed* path: the nominal tool of the input
program at the corresponding parameter. None of the product's splitting, arc or rewriting
code is used here.

The parameter of the input move that an output vertex corresponds to is found by projecting
the actual tool tip at the vertex onto the programmed path of its move (dense samples, then a
parabola through the nearest three); inside a segment the parameter runs linearly between its
vertices (the controller and the program interpolate both linearly in their parameter). The
moves are tagged with sequence numbers ``N``: the block that keeps its ``N`` is the first
piece of its move, the lines after it without one are the rest.

Programs: vmc500 (3 axes) with long random lines and arcs / helices; cgm4000 (X Y Z A B) with
random 5-axis moves in axis programming and in tool-tip programming (G43.4 in the program).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from volerr_pin.compensation.gcode import compensate_program

TOL_UM = 1.0
TOL_URAD = 10.0
#: samples per output segment
SAMPLES = 48
#: samples per programmed move for the projections
PROJECTION = 400
WORD = re.compile(r"([A-Z])([-+]?[0-9]*\.?[0-9]+)")


# ----------------------------------------------------------------------------- a minimal reader
def read_moves(text: str, axes: str) -> list[dict]:
    """The moves of a program of absolute G0-G3 blocks in mm / deg, XY plane, I/J centres.

    Returns one dict per motion block: ``n`` (its N word or None), ``motion``, ``end``
    (program coordinates, mm / deg, every axis), ``centre`` (I/J offsets added to the start,
    arcs only), ``tip`` (tool-tip programming on: G43.4 seen, G49 not since) and ``switched``
    (the mode changed since the last move: ``start`` is still in the former mode's coordinates).
    """
    pos = {a: None for a in axes}
    motion, tip, last_tip = None, False, False
    out = []
    for line in text.splitlines():
        code = re.sub(r"\([^)]*\)", "", line).upper()
        words = WORD.findall(code)
        gs = [float(v) for letter, v in words if letter == "G"]
        for g in gs:
            if g in (0, 1, 2, 3):
                motion = int(g)
            elif g == 43.4:
                tip = True
            elif g == 49:
                tip = False
            assert g in (0, 1, 2, 3, 17, 21, 43.4, 49, 90, 94), f"unexpected G{g:g} in {line!r}"
        coords = {letter: float(v) for letter, v in words if letter in axes}
        if not coords:
            continue
        start = np.array([pos[a] if pos[a] is not None else np.nan for a in axes])
        for a, v in coords.items():
            pos[a] = v
        end = np.array([pos[a] if pos[a] is not None else np.nan for a in axes])
        n = next((int(float(v)) for letter, v in words if letter == "N"), None)
        move = {"n": n, "motion": motion, "start": start, "end": end, "tip": tip, "centre": None,
                "switched": tip != last_tip}
        last_tip = tip
        if motion in (2, 3):
            offsets = {letter: float(v) for letter, v in words if letter in "IJ"}
            move["centre"] = start[:2] + np.array([offsets.get("I", 0.0), offsets.get("J", 0.0)])
        out.append(move)
    return out


def points_along(move: dict, u: np.ndarray) -> np.ndarray:
    """Program coordinates along a move at fractions ``u`` (a controller's interpolation)."""
    s, e = move["start"], move["end"]
    out = s + np.outer(u, e - s)
    if move["motion"] in (2, 3):
        c = move["centre"]
        a0 = math.atan2(s[1] - c[1], s[0] - c[0])
        a1 = math.atan2(e[1] - c[1], e[0] - c[0])
        sweep = a1 - a0
        if move["motion"] == 2:  # clockwise: negative sweep
            sweep = sweep - 2 * math.pi if sweep >= -1e-12 else sweep
        else:
            sweep = sweep + 2 * math.pi if sweep <= 1e-12 else sweep
        r0, r1 = math.hypot(*(s[:2] - c)), math.hypot(*(e[:2] - c))
        r = r0 + u * (r1 - r0)
        out[:, 0] = c[0] + r * np.cos(a0 + u * sweep)
        out[:, 1] = c[1] + r * np.sin(a0 + u * sweep)
    return out


# ----------------------------------------------------------------------------- the machine side
class Tool:
    """Axis positions of program coordinates, and the tool along them (SI inside)."""

    def __init__(self, machine):
        self.m = machine
        self.rotary = np.array([k == "rotary" for k in machine.axis_kinds])
        self.scale = np.where(self.rotary, math.pi / 180, 1e-3)
        self.linear = np.flatnonzero(~self.rotary)

    def axes_of(self, words: np.ndarray, tip: bool) -> np.ndarray:
        """Axis positions [m, rad] of program coordinates (mm, deg): the words themselves, or
        in tool-tip programming the linear axes that put the nominal tool tip at X Y Z (for
        fixed rotary axes the tip is affine in the linear axes: solved from four poses)."""
        q = words * self.scale
        if not tip:
            return q
        out = q.copy()
        base = q.copy()
        base[:, self.linear] = 0.0
        p0 = self.m.tool_poses(base, nominal=True, extrapolate=True)[1]
        cols = []
        for j in self.linear:
            step = base.copy()
            step[:, j] = 1.0
            cols.append(self.m.tool_poses(step, nominal=True, extrapolate=True)[1] - p0)
        M = np.stack(cols, axis=2)  # (N, 3, 3): d tip / d linear axes
        out[:, self.linear] = np.linalg.solve(M, (q[:, self.linear] - p0)[..., None])[..., 0]
        return out

    def switch(self, words: np.ndarray, tip: bool) -> np.ndarray:
        """Program coordinates (mm, deg) in the mode ``tip`` of the axis position that
        ``words`` meant in the other mode (a controller keeps the axes still on a switch)."""
        q = self.axes_of(words[None, :], not tip)
        if not tip:
            return q[0] / self.scale
        out = q[0] / self.scale
        out[self.linear] = self.poses(q, nominal=True)[0][0] / 1e-3
        return out

    def poses(self, q: np.ndarray, nominal: bool) -> tuple[np.ndarray, np.ndarray]:
        R, p = self.m.tool_poses(q, nominal=nominal, extrapolate=True)
        return p, R[:, :, 2]


def check_program(machine, program: str, *, programming: str = "axes") -> dict:
    """Compensate ``program`` and compare the simulated tool path of the output with the
    programmed one; returns the largest deviations found and how many samples were taken."""
    out, report = compensate_program(machine, program, tol_um=TOL_UM, tol_urad=TOL_URAD, programming=programming)
    axes = "".join(machine.axes)
    tool = Tool(machine)
    given = {m["n"]: m for m in read_moves(program, axes) if m["n"] is not None}
    written = read_moves(out, axes)
    assert written and all(written[0]["n"] == n for n in [min(given)]), "the first move lost its N"
    groups: dict[int, list[dict]] = {}
    current = None
    for mv in written:
        if mv["n"] is not None:
            current = mv["n"]
            groups[current] = []
        groups[current].append(mv)
    assert set(groups) == set(given), "moves lost or added"
    worst_pos = worst_axis = 0.0
    samples = 0
    for n, pieces in groups.items():
        move = given[n]
        if np.isnan(move["start"]).any() or move["motion"] == 0:
            continue  # the first move from an unknown start, and rapids: compensated at their end only
        tip = move["tip"] or programming == "tool-tip"
        for mv in (move, pieces[0]):
            if mv["switched"]:
                mv["start"] = tool.switch(mv["start"], tip)
        k = np.linspace(0.0, 1.0, PROJECTION)
        prog_p, prog_a = tool.poses(tool.axes_of(points_along(move, k), tip), nominal=True)

        def parameter(q_vertex, move=move, prog_p=prog_p, k=k):
            p, _ = tool.poses(q_vertex[None, :], nominal=False)
            for level in range(2):  # the nearest sample, then 41 samples around it
                d = np.linalg.norm(prog_p - p, axis=1)
                i = int(np.clip(np.argmin(d), 1, len(k) - 2))
                y0, y1, y2 = d[i - 1] ** 2, d[i] ** 2, d[i + 1] ** 2
                den = y0 - 2 * y1 + y2
                shift = 0.5 * (y0 - y2) / den if den > 0 else 0.0
                best = float(np.clip(k[i] + np.clip(shift, -1, 1) * (k[i + 1] - k[i]), 0.0, 1.0))
                if level == 0:
                    step = k[1] - k[0]
                    k = np.linspace(max(best - step, 0.0), min(best + step, 1.0), 41)
                    prog_p = tool.poses(tool.axes_of(points_along(move, k), tip), nominal=True)[0]
            return best

        for piece in pieces:
            assert piece["tip"] == tip, "the programming mode changed inside a move"
            u = np.linspace(0.0, 1.0, SAMPLES)
            q_cmd = tool.axes_of(points_along(piece, u), tip)
            k0, k1 = parameter(q_cmd[0]), parameter(q_cmd[-1])
            assert k1 >= k0 - 1e-6, f"move N{n}: pieces run backwards"
            act_p, act_a = tool.poses(q_cmd, nominal=False)
            kk = k0 + u * (k1 - k0)
            des_p, des_a = tool.poses(tool.axes_of(points_along(move, kk), tip), nominal=True)
            worst_pos = max(worst_pos, float(np.linalg.norm(act_p - des_p, axis=1).max()) * 1e6)
            if tool.rotary.any():
                angle = np.linalg.norm(np.cross(act_a, des_a), axis=1)
                worst_axis = max(worst_axis, float(angle.max()) * 1e6)
            samples += len(u)
        # the pieces cover the whole move
        assert parameter(tool.axes_of(pieces[0]["start"][None, :], tip)[0]) < 1e-3
        assert parameter(tool.axes_of(pieces[-1]["end"][None, :], tip)[0]) > 1 - 1e-3
    return {"position_um": worst_pos, "axis_urad": worst_axis, "samples": samples, "report": report,
            "pieces": sum(len(g) for g in groups.values()), "moves": len(groups)}


# ----------------------------------------------------------------------------- the programs
def lines_program(rng, travel_mm: np.ndarray, n: int, rotary_deg=None, step=None) -> str:
    """``n`` G1 moves tagged N1.., from a G0 start: random points of the box ``travel_mm``
    (or a random walk of ``step``), with rotary words in ``rotary_deg`` if given."""
    low, high = travel_mm[:, 0], travel_mm[:, 1]
    p = (low + high) / 2
    names = "XYZAB"[:len(low)]
    lines = ["G21 G90 G17 G94", "N1 G0 " + " ".join(f"{a}{v:.4f}" for a, v in zip(names, p)), "G1 F2000"]
    for i in range(n):
        p = low + rng.random(len(low)) * (high - low) if step is None else np.clip(
            p + rng.normal(0, 1, len(low)) * step, low, high)
        lines.append(f"N{i + 2} " + " ".join(f"{a}{v:.4f}" for a, v in zip(names, p)))
    return "\n".join(lines) + "\nM30\n"


def arcs_program(rng, n: int) -> str:
    """``n`` G2/G3 arcs and helices on vmc500 of 5 to 80 mm radius, up to 300 degrees."""
    lines = ["G21 G90 G17 G94", "N1 G0 X250.0000 Y200.0000 Z200.0000", "G1 F2000"]
    p = np.array([250.0, 200.0, 200.0])
    for i in range(n):
        r = rng.uniform(5, 80)
        while True:
            phase = rng.uniform(0, 2 * math.pi)
            c = p[:2] + r * np.array([math.cos(phase), math.sin(phase)])
            if np.all(c - r > 5) and c[0] + r < 495 and c[1] + r < 395:
                break
        ccw = rng.random() < 0.5
        a = math.atan2(p[1] - c[1], p[0] - c[0]) + (1 if ccw else -1) * rng.uniform(0.3, 5.2)
        end = np.array([c[0] + r * math.cos(a), c[1] + r * math.sin(a), np.clip(p[2] + rng.normal(0, 5), 10, 390)])
        end = np.round(end, 4)
        lines.append(f"N{i + 2} {'G3' if ccw else 'G2'} X{end[0]:.4f} Y{end[1]:.4f} Z{end[2]:.4f} "
                     f"I{c[0] - p[0]:.4f} J{c[1] - p[1]:.4f}")
        p = end
    return "\n".join(lines) + "\nM30\n"


def _within(result: dict, rotary: bool) -> None:
    # the written numbers round by up to 0.05 um per axis (0.5e-5 deg for rotary axes): the
    # product compensates to the tolerance less that, so the program as written meets it
    assert result["position_um"] <= TOL_UM, result
    if rotary:
        assert result["axis_urad"] <= TOL_URAD, result
    # the check was not empty: moves were split, and densely sampled
    assert result["pieces"] > result["moves"] and result["samples"] > 1000


def test_3_axis_long_lines_within_tolerance_along_every_piece(machines):
    program = lines_program(np.random.default_rng(11), np.array([[5, 495], [5, 395], [5, 395.0]]), 40)
    result = check_program(machines["vmc500"], program)
    _within(result, rotary=False)
    assert result["report"].max_before_um > 10 * TOL_UM  # there was something to compensate


def test_3_axis_arcs_and_helices_within_tolerance(machines):
    result = check_program(machines["vmc500"], arcs_program(np.random.default_rng(12), 40))
    _within(result, rotary=False)
    assert result["report"].arcs_kept + result["report"].arcs_as_lines == 40


@pytest.mark.parametrize("programming", ["axes", "tool-tip"])
def test_5_axis_moves_within_tolerance_in_position_and_tool_axis(machines, programming):
    box = np.array([[1500, 2500], [800, 1700], [200, 400], [-25, 25], [-40, 40.0]])
    program = lines_program(np.random.default_rng(13), box, 20)
    if programming == "tool-tip":  # switched on by the program itself, after the rapid
        program = program.replace("G1 F2000", "G43.4 H1\nG1 F2000")
    result = check_program(machines["cgm4000"], program, programming="axes")
    _within(result, rotary=True)
    # the rapid to the start is read in axis programming; G43.4 switches the moves after it
    assert result["report"].programming == (["axes"] if programming == "axes" else ["axes", "tool-tip"])


def test_the_check_finds_an_uncompensated_program(machines):
    """The checker itself: the input program, unchanged, misses the tolerance by far."""
    machine = machines["vmc500"]
    program = lines_program(np.random.default_rng(11), np.array([[5, 495], [5, 395], [5, 395.0]]), 10)
    tool = Tool(machine)
    worst = 0.0
    for move in [m for m in read_moves(program, "XYZ") if m["motion"] == 1]:
        q = tool.axes_of(points_along(move, np.linspace(0, 1, SAMPLES)), False)
        worst = max(worst, float(np.linalg.norm(tool.poses(q, False)[0] - tool.poses(q, True)[0], axis=1).max()))
    assert worst * 1e6 > 10 * TOL_UM
