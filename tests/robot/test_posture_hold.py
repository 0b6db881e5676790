"""Where the controllers may hold the arm's own posture: near a grasp or a release, and
only where holding it keeps the links clear."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.geometry import Box
from dexlfd.robot.arm_clearance import arm_clearance
from dexlfd.robot.posture_hold import held_windows, hold_windows

from ..control.test_posture_hold import swinging_posture_plan


def test_hold_windows_span_where_the_hand_stays_near_a_grasp_or_a_release() -> None:
    t = np.arange(0.0, 10.0, 0.1)
    z = np.where(t < 3.0, 0.3 - 0.1 * t, 0.0) + np.where(t > 6.0, 0.1 * (t - 6.0), 0.0)
    p = np.column_stack([np.zeros_like(t), np.zeros_like(t), z])
    closed = (t >= 4.0) & (t < 5.0)  # closes at 4 s, opens at 5 s, the hand down 3-6 s
    wins = hold_windows(t, p, closed, radius=0.055)
    assert len(wins) == 2
    for a, b in wins:  # within 5.5 cm of z = 0: from 2.5 s (z = 0.05) to 6.5 s
        assert a == pytest.approx(2.5) and b == pytest.approx(6.5)
    assert hold_windows(t, p, np.zeros_like(closed)) == ()


def test_a_window_is_held_only_where_holding_keeps_the_links_clear() -> None:
    from dexlfd.robot import MujocoPandaModel

    model = MujocoPandaModel()
    plan, q0 = swinging_posture_plan(model)
    posture = plan.joint_posture
    elbow = Box((0.0, 0.0, 0.7), (0.2, 0.2, 0.2))  # round the shoulder and the elbow at q0
    far = Box((0.6, 0.6, 0.1), (0.05, 0.05, 0.1))
    assert (
        arm_clearance(q0[None], (elbow,))[0].min() < 0.02 < arm_clearance(q0[None], (far,))[0].min()
    )
    every = hold_windows(plan.t, plan.position, plan.grasp)
    assert held_windows(plan, posture, (far,), 0.02, model) == every == ((0.0, 3.0),)
    assert held_windows(plan, posture, (elbow,), 0.02, model) == ()  # the plan's is followed
    assert held_windows(dataclasses.replace(plan, grasp=None), posture, (far,), 0.02, model) == ()
