from __future__ import annotations

import numpy as np
import pytest

from dexlfd.panda import FLANGE_D, Q_MAX, Q_MIN
from dexlfd.robot import MujocoPandaModel, dh_flange, dh_tcp


@pytest.fixture(scope="module")
def model() -> MujocoPandaModel:
    return MujocoPandaModel()


def test_dh_closed_form_at_zero() -> None:
    # q = 0: the arm stands straight up, offsets a4 - a5 + a7 along x
    T = dh_flange(np.zeros(7))
    np.testing.assert_allclose(T[:3, 3], [0.088, 0.0, 0.333 + 0.316 + 0.384 - FLANGE_D], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-12)


def test_mujoco_model_matches_dh_table(model: MujocoPandaModel, rng: np.random.Generator) -> None:
    for q in rng.uniform(Q_MIN, Q_MAX, (20, 7)):
        p, R = model.flange_pose(q)
        T = dh_flange(q)
        np.testing.assert_allclose(p, T[:3, 3], atol=1e-6)  # Table 3.1 to < 1e-6 m
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-9)
        p, R = model.tcp_pose(q)
        T = dh_tcp(q)
        np.testing.assert_allclose(p, T[:3, 3], atol=1e-6)
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-9)


def test_dh_batch_equals_loop(rng: np.random.Generator) -> None:
    qs = rng.uniform(Q_MIN, Q_MAX, (5, 7))
    batch = dh_tcp(qs)
    for i, q in enumerate(qs):
        np.testing.assert_allclose(batch[i], dh_tcp(q), atol=1e-15)


def test_dh_panda_pose_and_jacobian_match_the_mujoco_model(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    from dexlfd.panda_kinematics import DhPanda

    dh = DhPanda()
    for q in rng.uniform(Q_MIN, Q_MAX, (10, 7)):
        p, R = dh.tcp_pose(q)
        p_mj, R_mj = model.tcp_pose(q)
        np.testing.assert_allclose(p, p_mj, atol=1e-6)
        np.testing.assert_allclose(R, R_mj, atol=1e-9)
        np.testing.assert_allclose(dh.tcp_jacobian(q), model.tcp_jacobian(q), atol=1e-6)


def test_pose_and_jacobian_in_one_pass_are_the_pose_and_the_jacobian(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    """tcp_pose_jacobian (what the IK iterates on) is tcp_pose and tcp_jacobian, to the
    bit, for both models; Table 3.1's Jacobian is its pose's derivative."""
    from dexlfd.panda_ik import rotation_error
    from dexlfd.panda_kinematics import DhPanda

    for kin in (DhPanda(), model):
        for q in rng.uniform(Q_MIN, Q_MAX, (5, 7)):
            p, R, J = kin.tcp_pose_jacobian(q)
            p1, R1 = kin.tcp_pose(q)
            np.testing.assert_array_equal(p, p1)
            np.testing.assert_array_equal(R, R1)
            np.testing.assert_array_equal(J, kin.tcp_jacobian(q))
    dh, eps = DhPanda(), 1e-6
    for q in rng.uniform(Q_MIN, Q_MAX, (3, 7)):
        J = dh.tcp_pose_jacobian(q)[2]
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = eps
            (pp, Rp), (pm, Rm) = dh.tcp_pose(q + dq), dh.tcp_pose(q - dq)
            np.testing.assert_allclose((pp - pm) / (2 * eps), J[:3, i], atol=1e-8)
            np.testing.assert_allclose(rotation_error(Rp, Rm) / (2 * eps), J[3:, i], atol=1e-8)


def test_the_hand_envelope_holds_the_hand_fingers_and_flange_link(
    model: MujocoPandaModel, rng: np.random.Generator
) -> None:
    """Every collision-mesh vertex of the hand, the open fingers and link 7, in the TCP
    frame, lies in :data:`dexlfd.panda.HAND_ENVELOPE`'s box, and the box is no more than
    a centimetre larger than they are."""
    import mujoco

    from dexlfd.panda import HAND_ENVELOPE
    from dexlfd.robot.robot_model import build_arm_spec

    m = build_arm_spec(fixed_fingers=False).compile()
    d = mujoco.MjData(m)
    names = ("panda_link7", "panda_hand", "panda_leftfinger", "panda_rightfinger")
    bodies = {mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n) for n in names}
    tcp = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for q in rng.uniform(Q_MIN, Q_MAX, (3, 7)):
        d.qpos[:7], d.qpos[7:9] = q, 0.04  # the fingers fully open
        mujoco.mj_kinematics(m, d)
        p, R = d.site_xpos[tcp], d.site_xmat[tcp].reshape(3, 3)
        for g in range(m.ngeom):
            if m.geom_bodyid[g] not in bodies:
                continue
            if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
                mid = m.geom_dataid[g]
                v = m.mesh_vert[m.mesh_vertadr[mid] : m.mesh_vertadr[mid] + m.mesh_vertnum[mid]]
            else:  # a primitive (the fingertip pads): its box's corners
                c, h = m.geom_aabb[g][:3], m.geom_aabb[g][3:]
                v = c + h * np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T
            pts = (v @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g] - p) @ R
            lo, hi = np.minimum(lo, pts.min(axis=0)), np.maximum(hi, pts.max(axis=0))
    depth, width, height, tips = HAND_ENVELOPE
    box_lo, box_hi = np.array([-depth, -width, -height]), np.array([depth, width, tips])
    assert (lo >= box_lo - 1e-9).all() and (hi <= box_hi + 1e-9).all(), (lo, hi)
    assert (lo - box_lo <= 0.01).all() and (box_hi - hi <= 0.01).all(), (lo, hi)
