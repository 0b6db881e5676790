"""A box beside the pick: the hand's room is what it takes at the headings it has then.

The hand is 0.21 m across the fingers and 0.09 m deep. Turned to a pick's heading of
110 deg, its axis-aligned box reached 0.078 m along y, and the obstacle was grown by it
swept over every heading from the ready pose's (0 deg): a box whose face was 0.1 m from
the pick along the hand's depth stood over the approach point, and the plan was
refused. The hand's cells, at the headings the hand takes near the pick, leave it 4 cm.
"""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box
from dexlfd.io import LearnedModel
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.part_obstacles import HEADING_TOLERANCE, heading_windows
from dexlfd.plan.task_poses import top_down
from dexlfd.trajectory import minimum_jerk

PICK = (0.52, -0.12, 0.05)
PLACE = (0.40, 0.30, 0.05)
SIZE = (0.04, 0.04, 0.06)


def _cfg(box: Box) -> PlanConfig:
    return PlanConfig(pick=PICK, place=PLACE, pick_yaw=np.radians(110.0), object_size=SIZE,
                      object_bottom=SIZE[2] / 2, object_half_width=SIZE[0] / 2,
                      obstacles=(box,), rate_hz=250.0)  # fmt: skip


def test_a_box_a_hands_depth_beside_the_pick_is_planned_round(event_model: LearnedModel) -> None:
    # the hand's depth along y (heading 110 deg): the box's face 0.1 m from the pick
    # along -y, 0.13 m tall (the approach point is lower), off the carry's way
    box = Box((PICK[0], PICK[1] - 0.13, 0.065), (0.06, 0.06, 0.13))
    plan = plan_from_model(event_model, _cfg(box))
    clearance = plan.meta["clearance"]
    assert clearance["min_m"] >= 0.02 - 1e-3  # the hand and the object keep the margin
    assert clearance["min_m"] < 0.08  # and the box is near enough to matter
    assert np.linalg.norm(plan.position[np.flatnonzero(plan.grasp)[0]] - PICK) < 0.005


def test_the_same_box_across_the_fingers_is_refused(event_model: LearnedModel) -> None:
    """Turned 90 deg about the pick, the box meets the fingers (0.105 m out): refused."""
    box = Box((PICK[0] - 0.13, PICK[1], 0.065), (0.06, 0.06, 0.13))
    with pytest.raises(InvalidInput, match="overlap obstacle 0"):
        plan_from_model(event_model, _cfg(box))


def test_each_stretch_holds_the_headings_the_part_takes_then() -> None:
    """A top-down part turns along a minimum-jerk profile: at every moment its heading is
    inside its stretch's range, by the tolerance (neighbouring stretches share ends)."""
    yaw_a, yaw_b = np.radians(-10.0), np.radians(75.0)
    windows = heading_windows(top_down(yaw_a), top_down(yaw_b))
    assert len(windows) > 1
    s = np.linspace(0.0, 1.0, 2001)
    yaw = yaw_a + (yaw_b - yaw_a) * minimum_jerk(s)[0]
    for (s0, s1), lo, hi in windows:
        at = (s >= s0) & (s <= s1)
        assert at.any()
        assert yaw[at].min() >= lo + HEADING_TOLERANCE - 1e-9
        assert yaw[at].max() <= hi - HEADING_TOLERANCE + 1e-9
        assert hi - lo <= np.radians(3.0) + 2 * HEADING_TOLERANCE + 1e-9
    covered = np.zeros(s.shape, dtype=bool)
    for (s0, s1), _lo, _hi in windows:
        covered |= (s >= s0) & (s <= s1)
    assert covered.all()
