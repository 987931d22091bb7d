"""The TF5280 model: built from the machine's own nominal kinematics, its first-order
sensitivities against its exact chain, and the correction the kernel computes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from volerr_pin.base import SpecError
from volerr_pin.compensation.export import Zone
from volerr_pin.compensation.export._isg_volumetric import kinematic_chain, model_of, read_volumetric, volumetric_files
from volerr_pin.compensation.export._isg_model import rotation


@pytest.mark.parametrize("name,chain", [("vmc500", "YXZ"), ("vmc700", "XYZ"), ("cgm4000", "XYZAB")])
def test_the_chain_runs_from_the_workpiece_to_the_tool(machines, name, chain):
    m = machines[name]
    workpiece, tool = kinematic_chain(m)
    assert "".join(m.axes[j] for j in workpiece + tool) == chain
    model = model_of(m, Zone.workspace(m), 5)
    assert "".join(model.names) == chain


def test_the_model_reproduces_the_nominal_tool_point_and_rotation_centres(machines):
    m = machines["cgm4000"]
    model = model_of(m, Zone.workspace(m), 5)
    np.testing.assert_allclose(model.centres[3], [0, 0, 0.4], atol=1e-12)      # A pivot 0.4 m above the tool point
    np.testing.assert_allclose(model.centres[4], [0, 0, 0.25], atol=1e-12)     # B pivot 0.25 m above it
    np.testing.assert_allclose(model.n0, [0, 0, 1], atol=1e-12)
    p = Zone.workspace(m).sample(200, seed=9)
    tool = np.linspace(0.0, 0.2, 200)
    R, x = m.tool_poses(p.q, nominal=True)
    want = x - tool[:, None] * R[:, :, 2]
    np.testing.assert_allclose(model.tool_points(p.q, tool, with_errors=False), want, atol=1e-12)


def test_first_order_sensitivities_match_the_exact_chain(machines):
    m = machines["cgm4000"]
    model = model_of(m, Zone.workspace(m), 3)
    model = replace(model, positions=np.zeros_like(model.positions))          # at the nominal chain
    p = Zone.workspace(m).sample(16, seed=4)
    tool = np.full(16, 0.1)
    S = model.sensitivities(p.q, tool)
    h = 1e-7
    for k in range(len(model.chain)):
        for c in range(6):
            positions = model.positions.copy()
            positions[k, c] = h
            plus = replace(model, positions=positions).deviation(p.q, tool)
            positions[k, c] = -h
            minus = replace(model, positions=positions).deviation(p.q, tool)
            np.testing.assert_allclose(S[k][:, :, c], (plus - minus) / (2 * h), atol=1e-7)


def test_the_kernel_corrects_its_own_deviation_with_the_linear_axes(machines):
    m = machines["cgm4000"]
    model = model_of(m, Zone.workspace(m), 5).naive(m)
    p = Zone.workspace(m).sample(64, seed=2)
    c = model.correction(p.q, p.directions, p.tool)
    np.testing.assert_allclose(c[:, :3], -model.deviation(p.q, p.tool), atol=1e-18)
    assert not c[:, 3:].any()
    B = model.basis(p.q, p.directions, p.tool)
    constant = model.with_values(np.zeros(model.values.size)).correction(p.q, p.directions, p.tool)  # position errors
    np.testing.assert_allclose((B @ model.values).reshape(c.shape) + constant - c, 0.0, atol=5e-9)   # second order


def test_rotation_is_rodrigues():
    v = np.array([[0.0, 0.0, np.pi / 2], [1e-14, 0, 0], [0.3, -0.2, 0.1]])
    R = rotation(v)
    np.testing.assert_allclose(R[0] @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(R[1], np.eye(3), atol=1e-13)
    np.testing.assert_allclose(R[2] @ R[2].T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(R[2] @ v[2], v[2], atol=1e-15)


def test_the_files_state_the_model_and_read_back(machines):
    m = machines["cgm4000"]
    model = model_of(m, Zone.workspace(m), 5).naive(m)
    texts = volumetric_files(model, m)
    assert "chain XYZAB" in texts["volcomp_0.lis"] and "workpiece_axes 0" in texts["volcomp_0.lis"]
    assert texts["volcomp_geometry.csv"].splitlines()[1].split()[:12] == [
        "P0X", "P0Y", "P0Z", "N0X", "N0Y", "N0Z", "PXA", "PYA", "PZA", "PXB", "PYB", "PZB"]
    back = read_volumetric(texts, m)
    assert back.chain == model.chain
    for a, b in zip(back.tables, model.tables):
        np.testing.assert_allclose(a, b, atol=1e-10)                   # mm to 1e-7, rad to 1e-12
    np.testing.assert_allclose(back.positions, model.positions, atol=1e-12)


def test_machines_the_model_cannot_describe_are_refused(machines):
    with pytest.raises(SpecError, match="gear_roller: TF5280 Volumetric Compensation needs precisely three linear"):
        model_of(machines["gear_roller"], Zone.workspace(machines["gear_roller"]), 5)


def test_plane_tables_reserve_the_same_points_whatever_their_grid():
    """kw.crosscomp2.max_points is reserved at the kernel's start-up and refused changed on
    reloading (TF5200: error 110640): it was written as the table's size, so a re-export with
    another grid could not be loaded without a restart. It is the manual's default in every
    export, and every grid fits in it."""
    import re

    import volerr_pin as vp
    from volerr_pin.compensation.export._isg import PLANE_MAX_POINTS
    from volerr_pin.compensation.export import export_tables

    m = vp.load_machine("vmc500")
    reserved = set()
    for nodes in (9, 17, 33):
        texts = export_tables(m, "isg", kind="crosscomp2", nodes=nodes, points=512).texts
        for text in texts.values():
            reserved |= set(re.findall(r"^kw\.crosscomp2\.max_points (\d+)$", text, re.M))
            n1 = re.search(r"^kw\.crosscomp2\.last_index_master1 (\d+)$", text, re.M)
            n2 = re.search(r"^kw\.crosscomp2\.last_index_master2 (\d+)$", text, re.M)
            if n1:
                assert (int(n1.group(1)) + 1) * (int(n2.group(1)) + 1) <= PLANE_MAX_POINTS
    assert reserved == {"10201"} == {str(PLANE_MAX_POINTS)}
