"""Where no elbow posture keeps a link out, the hand's path goes round the obstacle widened."""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, Sphere
from dexlfd.io import Plan
from dexlfd.io.plan_facts import ArmPosture
from dexlfd.panda_kinematics import DhPanda
from dexlfd.plan import PlanConfig
from dexlfd.plan.arm_room import WIDEN_EXTRA, keep_links_clear, widened

CUP = Box((0.45, 0.0, 0.2), (0.08, 0.08, 0.4))


def _plan(obstacles: tuple) -> Plan:
    """A still hand at one pose, with ``obstacles`` in its arrays."""
    n = 3
    t = np.linspace(0.0, 1.0, n)
    pos = np.tile([0.3, -0.3, 0.3], (n, 1))
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    zeros = np.zeros((n, 3))
    return Plan(t=t, position=pos, velocity=zeros, acceleration=zeros, quaternion=quat,
                angular_velocity=zeros, gripper=np.full(n, 0.08),
                obstacle_center=np.array([ob.center for ob in obstacles]),
                obstacle_size=np.array([ob.size for ob in obstacles]),
                obstacle_radius=np.zeros(len(obstacles)))  # fmt: skip


def _arm_that_needs(width: float):  # noqa: ANN202
    """An arm step whose link 5 goes (width - the hand's obstacle width) into the cup."""

    def arm(plan, obstacles, margin, qs, model):  # noqa: ANN001, ANN202
        assert obstacles == (CUP,)  # the links are measured against the real obstacle
        planned_round = float(plan.extras["planned_width"])
        clearance = planned_round - width
        fact = ArmPosture(planned=clearance >= 0.0, margin=margin, min_clearance=clearance,
                          default_min_clearance=clearance, link="link 5", obstacle=0,
                          t_s=0.5, joint_velocity_ratio=0.5, rate_hz=20.0)  # fmt: skip
        return dataclasses.replace(plan, arm_posture=fact)

    return arm


def _hand(cfg: PlanConfig) -> Plan:
    plan = _plan(cfg.obstacles)
    return dataclasses.replace(plan, extras={"planned_width": cfg.obstacles[0].size[0]})


def test_widened_grows_every_horizontal_side_and_keeps_the_height() -> None:
    """A box 2 cm wider each side, as tall; a sphere 2 cm larger."""
    wide = widened(CUP, 0.02)
    assert isinstance(wide, Box)
    assert wide.size == pytest.approx((0.12, 0.12, 0.4)) and wide.center == CUP.center
    ball = widened(Sphere((0.4, 0.0, 0.3), 0.05), 0.02)
    assert isinstance(ball, Sphere) and ball.radius == pytest.approx(0.07)


def test_the_hand_goes_round_the_obstacle_widened_until_the_links_clear(caplog) -> None:
    """Links 15 mm into the cup: one re-plan round a cup widened by 15 + 20 mm clears
    them; the plan keeps the real cup in its arrays and says what was widened."""
    cfg = PlanConfig(obstacles=(CUP,))
    with caplog.at_level(logging.WARNING):
        plan = keep_links_clear(_hand, cfg, _arm_that_needs(0.095), DhPanda())
    fact = plan.arm_posture
    assert fact is not None and fact.planned and fact.min_clearance >= 0.0
    assert plan.extras["planned_width"] == pytest.approx(0.08 + 2 * (0.015 + WIDEN_EXTRA))
    np.testing.assert_array_equal(plan.obstacle_size, [CUP.size])  # the real cup
    assert "widened by 35 mm" in caplog.text and "clear it" in caplog.text


def test_links_that_clear_leave_the_hand_as_planned() -> None:
    """Nothing is re-planned where the elbow alone keeps the links out."""
    seen: list[PlanConfig] = []

    def hand(cfg: PlanConfig) -> Plan:
        seen.append(cfg)
        return _hand(cfg)

    plan = keep_links_clear(hand, PlanConfig(obstacles=(CUP,)), _arm_that_needs(0.05), DhPanda())
    assert len(seen) == 1 and plan.extras["planned_width"] == pytest.approx(0.08)


def test_a_widened_obstacle_the_hand_cannot_pass_keeps_the_first_plan(caplog) -> None:
    """A refused re-plan: the first plan (links still in), and a line saying so."""

    def hand(cfg: PlanConfig) -> Plan:
        if cfg.obstacles[0].size[0] > CUP.size[0]:
            raise InvalidInput("the start is inside obstacle 0")
        return _hand(cfg)

    with caplog.at_level(logging.WARNING):
        plan = keep_links_clear(hand, PlanConfig(obstacles=(CUP,)), _arm_that_needs(0.1), DhPanda())
    assert plan.arm_posture is not None and not plan.arm_posture.planned
    assert "cannot go round obstacle 0" in caplog.text


def test_widening_that_does_not_help_is_not_kept(caplog) -> None:
    """An arm whose links go deeper the wider the hand's path: the first plan stays."""

    def arm(plan, obstacles, margin, qs, model):  # noqa: ANN001, ANN202
        clearance = -float(plan.extras["planned_width"])  # wider: deeper
        fact = ArmPosture(planned=False, margin=margin, min_clearance=clearance,
                          default_min_clearance=clearance, link="link 5", obstacle=0,
                          t_s=0.5, joint_velocity_ratio=0.5, rate_hz=20.0)  # fmt: skip
        return dataclasses.replace(plan, arm_posture=fact)

    with caplog.at_level(logging.WARNING):
        plan = keep_links_clear(_hand, PlanConfig(obstacles=(CUP,)), arm, DhPanda())
    assert plan.extras["planned_width"] == pytest.approx(0.08)
    assert "move the obstacle, the pick or the place" in caplog.text
