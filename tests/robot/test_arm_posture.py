"""The arm's elbow is chosen so its links keep clear; controllers follow that posture."""

from __future__ import annotations

import functools
import logging
import re

import numpy as np
import pytest

from dexlfd.control import CartesianPd, NtsmPd, RobotState, resample_plan
from dexlfd.control.base import Reference
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box
from dexlfd.io import Plan, load_plan, save_plan
from dexlfd.panda import Q_MAX, Q_MIN, Q_READY
from dexlfd.panda_ik import solve_ik
from dexlfd.robot import MujocoPandaModel
from dexlfd.robot.arm_clearance import arm_clearance
from dexlfd.robot.arm_posture import clear_posture, plan_arm_posture
from dexlfd.rotations import quat_from_matrix

MARGIN = 0.02


@functools.cache
def _path() -> tuple[MujocoPandaModel, np.ndarray, np.ndarray, np.ndarray, np.ndarray, Box]:
    """A 0.36 m sideways and downward TCP move from the ready pose (20 Hz joint samples).

    With a box put by the elbow's path (46 mm clear at the start), the inverse
    kinematics' own posture drives link 4 into it.
    """
    kin = MujocoPandaModel()
    p0, R0 = kin.tcp_pose(Q_READY)
    t = np.linspace(0.0, 4.0, 81)
    s = np.clip(t / 3.0, 0.0, 1.0)
    s = s * s * (3.0 - 2.0 * s)
    P = p0 + s[:, None] * np.array([0.0, 0.35, -0.1])
    R = np.repeat(R0[None], t.shape[0], axis=0)
    qs = np.empty((t.shape[0], 7))
    q = Q_READY
    for k in range(t.shape[0]):
        q = solve_ik(kin, P[k], R[k], q, max_iter=50).q
        qs[k] = q
    box = Box((-0.057, 0.122, 0.752), (0.04, 0.04, 0.04))
    return kin, t, qs, P, R, box


def test_the_elbow_swivels_out_of_an_obstacle_the_default_posture_meets() -> None:
    """Link 4 overlaps the box with the IK's posture; the chosen one keeps the margin."""
    kin, t, qs, P, R, box = _path()
    default, _ = arm_clearance(qs, (box,))
    assert default.min() < 0.0  # the links' collision meshes overlap the box
    choice = clear_posture(t, qs, (P, R), (box,), MARGIN, kin)
    measured, _ = arm_clearance(choice.q, (box,))  # mj_geomDistance on the chosen joints
    assert measured.min() >= MARGIN
    np.testing.assert_allclose(choice.clearance, measured)
    # the same TCP poses, within the joint limits, continuous from the start posture
    for k in range(t.shape[0]):
        p, _ = kin.tcp_pose(choice.q[k])
        assert np.linalg.norm(p - P[k]) < 1e-3
    assert (choice.q >= Q_MIN).all() and (choice.q <= Q_MAX).all()
    np.testing.assert_array_equal(choice.q[0], qs[0])
    assert np.abs(np.diff(choice.q, axis=0)).max() < 0.06  # rad per 50 ms sample
    assert np.abs(choice.swivel).max() > 0.1


def test_a_far_obstacle_changes_nothing() -> None:
    """Where the IK's posture keeps every link well clear, it is the planned posture."""
    kin, t, qs, P, R, _ = _path()
    far = Box((0.6, -0.6, 0.1), (0.05, 0.05, 0.1))
    choice = clear_posture(t, qs, (P, R), (far,), MARGIN, kin)
    np.testing.assert_array_equal(choice.q, qs)
    assert not choice.swivel.any()


def _plan(t: np.ndarray, P: np.ndarray, R: np.ndarray, box: Box) -> Plan:
    n = t.shape[0]
    quat = np.array([quat_from_matrix(r) for r in R])
    zeros = np.zeros((n, 3))
    v = np.gradient(P, t, axis=0)
    return Plan(t=t, position=P, velocity=v, acceleration=zeros, quaternion=quat,
                angular_velocity=zeros, gripper=np.full(n, 0.08),
                obstacle_center=np.array([box.center]), obstacle_size=np.array([box.size]),
                obstacle_radius=np.zeros(1))  # fmt: skip


def test_the_plan_keeps_its_posture_typed_and_the_controllers_follow_it(tmp_path) -> None:
    """``joint_posture`` and ``arm_posture`` survive a save and load; the reference holds them."""
    kin, t, qs, P, R, box = _path()
    plan = plan_arm_posture(_plan(t, P, R, box), (box,), MARGIN, (t, qs), kin)
    assert plan.joint_posture is not None and plan.joint_posture.shape == (t.shape[0], 7)
    fact = plan.arm_posture
    assert fact is not None and fact.planned
    assert fact.min_clearance >= MARGIN > 0.0 > fact.default_min_clearance
    assert fact.link == "link 4" and fact.max_swivel > 0.1
    back = load_plan(save_plan(tmp_path / "plan.npz", plan))
    np.testing.assert_array_equal(back.joint_posture, plan.joint_posture)
    assert back.arm_posture == fact
    ref = resample_plan(back, 0.001)
    assert ref.q_null is not None and ref.dq_null is not None
    np.testing.assert_allclose(ref.q_null[-1], plan.joint_posture[-1])
    with pytest.raises(InvalidInput, match="joint_posture"):
        Plan(**{**{f: getattr(plan, f) for f in ("t", "position", "velocity", "acceleration",
                                                  "quaternion", "angular_velocity", "gripper")},
                "joint_posture": plan.joint_posture + 10.0})  # fmt: skip


def test_no_posture_clears_a_box_round_the_wrist_so_the_start_posture_stays(caplog) -> None:
    """A box the wrist cannot leave in any elbow posture: said, and no planned posture."""
    kin, t, qs, P, R, _ = _path()
    wrist = Box(tuple(P[40] + np.array([0.0, 0.0, 0.15])), (0.05, 0.05, 0.05))
    with caplog.at_level(logging.WARNING):
        plan = plan_arm_posture(_plan(t, P, R, wrist), (wrist,), MARGIN, (t, qs), kin)
    assert plan.joint_posture is None
    fact = plan.arm_posture
    assert fact is not None and not fact.planned and fact.min_clearance < 0.0
    assert plan.extras["arm_clearance"].min() < 0.0
    said = [r.getMessage() for r in caplog.records]
    assert any(re.search(r"the arm's link \d passes [\d.]+ mm into obstacle 0", m) for m in said)


@pytest.mark.parametrize("law", [CartesianPd(), NtsmPd()])
def test_a_planned_posture_replaces_the_start_posture_in_the_null_space(law) -> None:
    """The reference's posture acts as the rest posture would; without it, nothing changes."""
    kin = MujocoPandaModel()
    q = Q_READY + 0.05
    dq = np.full(7, 0.1)
    terms = kin.terms(q, dq)
    rs = RobotState(0.0, q, dq)
    base = dict(p=terms.p, v=np.zeros(3), a=np.zeros(3), R=terms.R, w=np.zeros(3))
    other = Q_READY - 0.2
    state_rest = law.init(RobotState(0.0, other, dq), terms)  # rest posture `other`
    state_start = law.init(rs, terms)  # rest posture `q`
    tau_rest, _ = law.step(state_rest, rs, Reference(**base), terms)
    tau_planned, _ = law.step(
        state_start, rs, Reference(**base, q_null=other, dq_null=np.zeros(7)), terms
    )
    tau_plain, _ = law.step(state_start, rs, Reference(**base), terms)
    np.testing.assert_allclose(tau_planned, tau_rest, atol=1e-12)
    assert np.abs(tau_planned - tau_plain).max() > 1e-3


@pytest.mark.integration
def test_a_0_3_m_pillar_beside_the_pick_is_cleared_by_the_elbow() -> None:
    """Six synthetic pick-and-places round a 0.3 m pillar: the IK's posture puts link 5
    into it at the pick; the planned posture keeps every link the margin away."""
    from dexlfd.datasets import pick_place_demonstrations
    from dexlfd.learn import LearnConfig, learn_from_demonstrations
    from dexlfd.plan import PlanConfig, plan_from_model
    from dexlfd.plan.arm_room import ARM_RATE_HZ
    from dexlfd.plan.feasibility import joint_profile

    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    model = learn_from_demonstrations(
        demos, LearnConfig(n_components=8), np.random.default_rng(0)
    ).model
    pillar = Box((0.46, -0.05, 0.15), (0.10, 0.10, 0.30))
    kin = MujocoPandaModel()
    cfg = PlanConfig(obstacles=(pillar,))
    plan = plan_from_model(model, cfg, kin)
    t, q, _, _ = joint_profile(plan, kin, rate_hz=ARM_RATE_HZ)
    assert arm_clearance(q, (pillar,))[0].min() < 0.0
    plan = plan_arm_posture(plan, cfg.obstacles, cfg.margin, (t, q), kin)
    assert plan.arm_posture is not None and plan.arm_posture.planned
    assert plan.joint_posture is not None
    at_samples = plan.joint_posture[np.searchsorted(plan.t, t).clip(0, plan.n_samples - 1)]
    assert arm_clearance(at_samples, (pillar,))[0].min() >= 0.9 * cfg.margin
    assert np.abs(np.diff(plan.joint_posture, axis=0)).max() < 0.02  # per plan sample


@pytest.mark.integration
def test_a_posture_that_gains_nothing_or_is_too_fast_is_not_used(caplog) -> None:
    """A 0.4 m box by the carry, 0.08 m margin: whatever the elbow does, link 5 passes
    within millimetres. A 2 rad swivel that keeps it no further, and moves joint 5
    beyond its limit, is not the plan's posture; what is kept is said."""
    from dexlfd.datasets import pick_place_demonstrations
    from dexlfd.learn import LearnConfig, learn_from_demonstrations
    from dexlfd.plan import PlanConfig, plan_from_model
    from dexlfd.plan.arm_room import ARM_RATE_HZ
    from dexlfd.plan.feasibility import joint_profile

    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    model = learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0)).model
    box = Box((0.45, 0.0, 0.2), (0.08, 0.08, 0.4))
    kin = MujocoPandaModel()
    cfg = PlanConfig(obstacles=(box,), margin=0.08, task="motion", on_limit="scale", feasible=True)
    plan = plan_from_model(model, cfg, kin)
    t, q, _, _ = joint_profile(plan, kin, rate_hz=ARM_RATE_HZ)
    with caplog.at_level(logging.INFO, logger="dexlfd.robot.arm_posture"):
        plan = plan_arm_posture(plan, cfg.obstacles, cfg.margin, (t, q), kin)
    fact = plan.arm_posture
    assert fact is not None
    if fact.planned:
        assert plan.joint_posture is not None
        assert fact.joint_velocity_ratio < 1.0  # within the joints' limits
        assert fact.min_clearance > min(fact.default_min_clearance, cfg.margin)
    else:
        assert plan.joint_posture is None
        assert "start posture" in caplog.text
