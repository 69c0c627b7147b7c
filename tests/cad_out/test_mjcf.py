"""The MuJoCo export: loads, fixed base, limits, contacts against is_valid, statics, coupling."""

import mujoco
import numpy as np
import pytest

import handarm
from handarm.cad_out.carve_files import write_carve_outputs
from handarm.cad_out.mjcf import mjcf_string
from handarm.carve import carve
from handarm.carve.properties import link_properties
from handarm.collision import LINK_PAIRS
from handarm.firmware_bridge.sizing import GRAVITY, carved_link_masses, gravity_terms
from handarm.kinematics import colliding_pairs
from handarm.transmission import coupling_matrix, motor_torque_from_joint

DESIGNS = {
    "paper": handarm.ArmDesign(),
    "other_lengths": handarm.ArmDesign(link_lengths=(0.04, 0.07, 0.06, 0.05, 0.045, 0.055, 0.04)),
}


@pytest.fixture(scope="module", params=sorted(DESIGNS))
def carved(request):
    result = carve(DESIGNS[request.param], 2.0)
    props = [link_properties(link, result.design.density) for link in result.links]
    model = mujoco.MjModel.from_xml_string(mjcf_string(result, props, visual_meshes=False))
    return result, model


def _contact(model, data, q, margin):
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    # MuJoCo's box contacts may add points of a contact patch beyond the margin; a contact
    # is a point closer than the margin (the clearance), as is_valid counts one
    return any(c.dist < margin for c in data.contact[: data.ncon])


def test_written_beside_the_urdf_and_loads_with_meshes(tmp_path):
    result = carve(handarm.ArmDesign(), 2.0)
    write_carve_outputs(result, tmp_path)
    path = tmp_path / "paper_arm.mjcf.xml"
    assert (tmp_path / "paper_arm.urdf").is_file()
    model = mujoco.MjModel.from_xml_path(str(path))
    assert (model.geom_type == mujoco.mjtGeom.mjGEOM_MESH).sum() == 7


def test_base_fixed_and_limits(carved):
    result, model = carved
    d = result.design
    assert model.nq == model.nv == 6
    assert model.body("l0").jntnum[0] == 0 and model.body("l0").parentid[0] == 0
    for k in range(6):
        j = model.joint(f"joint{k + 1}")
        lo, hi = d.joint_limits[k]
        alo, ahi = result.joints[k].achieved
        np.testing.assert_allclose(j.range, [max(lo, alo), min(hi, ahi)])
        assert model.jnt_limited[k]


def test_frames_match_forward_kinematics(carved, rng):
    result, model = carved
    data = mujoco.MjData(model)
    frames_of = handarm.kinematics.joint_frames
    for q in rng.uniform(result.design.lower, result.design.upper, (5, 6)):
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        frames = frames_of(result.design, q)
        for k in range(6):
            body = data.body(f"l{k + 1}")
            np.testing.assert_allclose(body.xpos, frames[k, :3, 3], atol=1e-12)
            np.testing.assert_allclose(body.xmat.reshape(3, 3), frames[k, :3, :3], atol=1e-12)


def test_no_contact_at_zero(carved):
    result, model = carved
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0


def test_contacts_agree_with_is_valid(carved):
    """Agreement >= 99 %; MuJoCo never finds a contact is_valid misses.

    Where they differ, is_valid reports a pair of a base-plane and a tip-plane piece that
    MuJoCo finds apart: the printed-link model's test across the two planes is conservative
    (it contains the true intersection, see handarm.collision).
    """
    result, model = carved
    d = result.design
    data = mujoco.MjData(model)
    rng = np.random.default_rng(1)
    # the requested limits: the model's ranges (where the cables keep clear) are too narrow
    # for any two links to meet, and the test needs both kinds
    q = rng.uniform(d.lower, d.upper, (1500, 6))
    valid = handarm.is_valid(d, q)
    contact = np.array([_contact(model, data, x, d.clearance) for x in q])
    assert 0.1 < valid.mean() < 0.95  # the sample holds both kinds
    assert not np.any(contact & valid)
    assert np.mean(contact == ~valid) >= 0.99
    for x in q[~contact & ~valid]:
        pairs = [LINK_PAIRS[i] for i in np.flatnonzero(colliding_pairs(d, x))]
        assert any(a <= 3 <= b for a, b in pairs)


@pytest.mark.parametrize("gravity", [(0, 0, -1), (0, -1, 0), (1, 1, -1)])
def test_gravity_torques_match_the_statics(carved, rng, gravity):
    result, model = carved
    d = result.design
    g = GRAVITY * np.asarray(gravity, float) / np.linalg.norm(gravity)
    model.opt.gravity[:] = g
    data = mujoco.MjData(model)
    q = rng.uniform(d.lower * 0.8, d.upper * 0.8, (10, 6))
    a, _ = gravity_terms(d, q, carved_link_masses(result))
    for x, ax in zip(q, a, strict=True):
        data.qpos[:] = x
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        hold = -(ax @ g)  # the torque that holds the arm against gravity
        scale = np.abs(hold).max()
        assert np.abs(data.qfrc_bias - hold).max() <= 0.01 * scale


def test_static_hold_through_the_tendons(carved):
    """The position servos hold a pose: their forces are the statics' motor torques."""
    result, model = carved
    d = result.design
    g = np.array([0.0, -GRAVITY, 0.0])  # arm held sideways: every joint carries load
    model.opt.gravity[:] = g
    data = mujoco.MjData(model)
    k = coupling_matrix(d)
    q0 = np.radians([20.0, 30.0, -20.0, 40.0, 30.0, 20.0])
    data.qpos[:] = q0
    data.ctrl[:] = k @ q0
    for _ in range(8000):
        mujoco.mj_step(model, data)
    assert np.abs(data.qvel).max() < 1e-6
    a, _ = gravity_terms(d, data.qpos[None], carved_link_masses(result))
    hold = -(a[0] @ g)
    motors = motor_torque_from_joint(d, hold)
    assert np.abs(data.actuator_force - motors).max() <= 0.01 * np.abs(motors).max()
    np.testing.assert_allclose(data.ten_length, k @ data.qpos, atol=1e-12)
    # the actuators' moment arms are the rows of K: joint torques K^T tau
    moment = np.zeros((6, 6))
    mujoco.mju_sparse2dense(
        moment, data.actuator_moment, data.moment_rownnz, data.moment_rowadr, data.moment_colind
    )
    np.testing.assert_allclose(moment, k, atol=1e-12)
