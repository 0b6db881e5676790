"""The arm's links, not only the hand, are measured against the plan's obstacles."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.geometry import Box
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.panda import Q_READY
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.arm_room import ARM_RATE_HZ
from dexlfd.plan.feasibility import joint_profile
from dexlfd.robot import MujocoPandaModel
from dexlfd.robot.arm_clearance import arm_clearance, plan_arm_clearance


def test_clearance_is_the_distance_to_the_links_collision_geometry() -> None:
    """A wall moved 5 cm further off is 5 cm clearer; a box round the elbow overlaps it."""
    wall = [Box((x, 0.0, 0.5), (0.02, 1.0, 1.0)) for x in (-0.5, -0.55)]
    near, far = (float(arm_clearance(Q_READY[None], (w,))[0].min()) for w in wall)
    assert near > 0.0
    assert far - near == pytest.approx(0.05, abs=1e-6)
    # the elbow at the ready pose is about 0.6 m up, 0.1 m forward of the base axis
    elbow = Box((0.08, 0.0, 0.62), (0.06, 0.06, 0.06))
    per, worst = arm_clearance(Q_READY[None], (elbow,))
    assert per.min() < 0.0 and worst[0][0] in ("link 3", "link 4", "link 5")


def test_the_forearm_over_the_thesis_pillar_is_measured_and_said(caplog) -> None:
    """The hand clears the 0.5 m pillar; the forearm (link 5) reaches over its top edge."""
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    model = learn_from_demonstrations(
        demos, LearnConfig(n_components=8), np.random.default_rng(0)
    ).model
    pillar = Box((0.46, -0.05, 0.25), (0.10, 0.10, 0.50))
    kinematics = MujocoPandaModel()
    cfg = PlanConfig(obstacles=(pillar,), rate_hz=500.0)
    plan = plan_from_model(model, cfg, kinematics)
    t, q, _, _ = joint_profile(plan, kinematics, rate_hz=ARM_RATE_HZ)
    with caplog.at_level(logging.WARNING):
        plan = plan_arm_clearance(plan, cfg.obstacles, cfg.margin, (t, q))
    arm = plan.extras["arm_clearance"]
    assert arm.shape == plan.t.shape
    assert arm.min() < 0.0  # the planned joints put link 5 into the pillar's edge
    assert plan.extras["clearance"].min() > 0.0  # while the hand and object clear it
    assert any("link 5" in r.getMessage() and "overlap" in r.getMessage() for r in caplog.records)
