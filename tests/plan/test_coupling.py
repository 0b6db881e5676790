"""The shaped coupling keeps its bounds on every sample, not only on those it was solved on."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.plan.coupling import shape_coupling
from dexlfd.plan.dmp_config import DmpConfig
from dexlfd.plan.end_shaping import end_window

# [normalised time] the push may start this early: the planner's, 1.5 DMP time constants
LEAD = 1.5 / np.sqrt(DmpConfig().K_bar)


@pytest.mark.parametrize("n", [2001, 18101])
def test_an_obstacle_just_before_the_goal_is_passed_without_a_swing_at_the_end(n: int) -> None:
    """A long, slow carry (18 s at 1 kHz) whose obstacle ends 1.2 % before the goal, as
    a raised place's block on a real carry: the programme is posed on every ~120th
    sample, and the pieces acting in the last stretch were tied down by none of them
    (the displacement swung 13 mm towards the obstacle there; on the real carry 0.9 m)."""
    tb = np.linspace(0.0, 1.0, n)
    over = (tb > 0.84) & (tb < 0.988)
    required = np.where(over, 0.065 * np.sin(np.pi * np.clip((tb - 0.84) / 0.148, 0, 1)), 0.0)
    band = 0.02
    sc = shape_coupling(DmpConfig(), tb, required, np.zeros(n), end_window(tb), kappa=0.0,
                        band=band, lead=LEAD)  # fmt: skip
    assert sc.band_met
    cushion = 1e-3
    assert sc.x.min() >= -cushion  # never towards the obstacle's side
    assert np.all(sc.x[over] >= required[over] - cushion)  # the lift it needs, everywhere
    assert np.all(sc.x <= required.max() + band + cushion)  # and no higher than the band
    assert abs(sc.x[-1]) < 1e-9  # the goal is kept (the end window)


def test_a_path_that_needs_no_lift_is_left_alone() -> None:
    """Shaped coupling on: a straight path passing 3 cm beside a box (outside the 2 cm
    margin, inside the fade-in distance) is not pushed. The thesis's push used to be
    applied there, its gains fed the fading intrusion (a real carry lifted 0.9 m)."""
    from dexlfd.geometry import Box
    from dexlfd.plan import PlanConfig
    from dexlfd.plan.clearance import avoid_obstacles
    from dexlfd.plan.planner import _avoidance

    n = 501
    tb = np.linspace(0.0, 1.0, n)
    x = np.stack([0.3 + 0.4 * tb, np.zeros(n), np.full(n, 0.1)], axis=1)
    path = (x, np.tile([0.4, 0.0, 0.0], (n, 1)), np.zeros((n, 3)))
    box = Box((0.5, 0.08, 0.1), (0.1, 0.1, 0.2))  # its face 3 cm beside the path
    cfg = PlanConfig(obstacles=(box,))
    (x2, _, _), records, _ = avoid_obstacles(
        cfg.obstacles, _avoidance(cfg), tb, path, lambda v: np.ones(n), end_window(tb)
    )
    assert records[0]["max_intrusion"] > 0.0  # within the fade-in distance
    assert records[0]["required_lift"] == 0.0
    np.testing.assert_array_equal(x2, x)
