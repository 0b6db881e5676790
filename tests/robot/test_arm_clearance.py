"""The arm's links, not only the hand, are measured against the plan's obstacles."""

from __future__ import annotations

import pytest

from dexlfd.geometry import Box
from dexlfd.panda import Q_READY
from dexlfd.robot.arm_clearance import arm_clearance


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
