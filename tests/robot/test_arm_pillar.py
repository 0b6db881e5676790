"""The arm's posture is part of planning: the thesis's 0.5 m pillar is planned and cleared."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.geometry import Box
from dexlfd.io import LearnedModel
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.arm_room import ARM_RATE_HZ
from dexlfd.plan.feasibility import joint_profile
from dexlfd.robot import MujocoPandaModel
from dexlfd.robot.arm_clearance import HAND_BODIES, arm_clearance
from dexlfd.robot.arm_posture import plan_arm_posture

PILLAR = Box((0.46, -0.05, 0.25), (0.10, 0.10, 0.50))  # box:0.46,-0.05,0.25,0.10,0.10,0.50


@functools.cache
def _six_demo_model() -> LearnedModel:
    """What ``dexlfd synth -n 6`` then ``dexlfd learn`` give (seed 0)."""
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    return learn_from_demonstrations(
        demos, LearnConfig(n_components=8), np.random.default_rng(0)
    ).model


@pytest.mark.integration
def test_the_0_5_m_pillar_is_planned_and_every_link_clears_it_in_simulation(tmp_path) -> None:
    """Six pick-and-places round the thesis's pillar: with the inverse kinematics' own
    posture link 5 meets the pillar's top edge at the pick; the planned posture keeps
    every link out of it along the plan, and the simulated arm too."""
    from dexlfd.cli import main
    from dexlfd.io import load_rollout, save_plan

    kin = MujocoPandaModel()
    cfg = PlanConfig(obstacles=(PILLAR,))
    plan = plan_from_model(_six_demo_model(), cfg, kin, arm=plan_arm_posture)
    t, q_ik, _, _ = joint_profile(plan, kin, rate_hz=ARM_RATE_HZ)
    assert arm_clearance(q_ik, (PILLAR,))[0].min() < 0.0  # the IK's posture touches
    fact = plan.arm_posture
    assert fact is not None and fact.planned and plan.joint_posture is not None
    assert fact.default_min_clearance < 0.0 <= fact.min_clearance
    assert fact.joint_velocity_ratio <= 0.9
    # every link, measured again (MuJoCo's distance) on the posture at every 10th sample
    per, _ = arm_clearance(plan.joint_posture[::10], (PILLAR,))
    assert per.min() >= 0.0
    assert plan.extras["clearance"].min() > 0.0  # the hand and the held object too
    # the posture puts the TCP where the plan does
    for k in range(0, plan.n_samples, 250):
        p, _ = kin.tcp_pose(plan.joint_posture[k])
        assert np.linalg.norm(p - plan.position[k]) < 2e-3
    path = save_plan(tmp_path / "plan.npz", plan)
    out = tmp_path / "rollout.npz"
    assert main(["simulate", str(path), "--payload-kg", "1.2", "-q", "-o", str(out)]) == 0
    rollout = load_rollout(out)
    per, _ = arm_clearance(rollout.q[::10], (PILLAR,))
    assert per.min() > 0.0
    hand, _ = arm_clearance(rollout.q[::10], (PILLAR,), HAND_BODIES)  # hand and fingers
    assert hand.min() > 0.0
    assert rollout.placement is not None and rollout.placement.ok


def test_without_obstacles_the_arm_step_changes_nothing() -> None:
    """No obstacle: the arm posture planner is not called; the plan is the same."""
    calls = []

    def arm(plan, obstacles, margin, model):  # noqa: ANN001, ANN202
        calls.append(obstacles)
        return plan

    cfg = PlanConfig(rate_hz=200.0)
    with_arm = plan_from_model(_six_demo_model(), cfg, arm=arm)
    plain = plan_from_model(_six_demo_model(), cfg)
    assert not calls
    assert with_arm.joint_posture is None and with_arm.arm_posture is None
    for name in ("t", "position", "velocity", "acceleration", "quaternion", "gripper"):
        np.testing.assert_array_equal(getattr(with_arm, name), getattr(plain, name))


@pytest.mark.integration
def test_the_demo_plans_the_arm_of_its_executed_plan_and_widens_the_hands_path() -> None:
    """The demo's executed plan over the 0.4 m cup goes through the arm posture step, as
    ``dexlfd plan``'s does. Link 5 met the cup's top edge (17.8 mm deep) whatever the
    elbow did; the hand's path goes round the cup widened, and the links clear it."""
    from dexlfd.apps.demo import DemoConfig
    from dexlfd.apps.demo_plan import cup, task_plan

    cfg = DemoConfig()
    real = cup(cfg, cfg.executed_height)
    plan = task_plan(_six_demo_model(), cfg)
    fact = plan.arm_posture
    assert fact is not None  # the arm posture step ran
    assert (plan.joint_posture is not None) == fact.planned
    assert plan.obstacles == (real,)  # the real cup is what the simulation builds
    assert fact.min_clearance >= 0.0
    assert plan.extras["arm_clearance"].shape == plan.t.shape
    q = plan.joint_posture
    if q is None:  # the inverse kinematics' own posture is what the controllers keep
        _, q, _, _ = joint_profile(plan, MujocoPandaModel(), rate_hz=ARM_RATE_HZ)
    assert arm_clearance(q, (real,))[0].min() >= 0.0
    assert plan.position[:, 2].max() > real.size[2] + cfg.plan_margin  # still over it
