"""After the release the hand rises clear of the placed object before it moves sideways.

A person's hand often ends low and off to the side (resting on the table after the
drop); replayed relative to the place, the retreat swept along the table a few
centimetres up. The retreat now keeps above the rise point (the placed object's top
plus the clearance) once it leaves the object's column, and ends no lower.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import LearnedModel
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.task_poses import RISE_CLEARANCE

PICK = (0.52, -0.12, 0.12)
PLACE = (0.40, 0.30, 0.15)
SIZE = (0.04, 0.04, 0.06)  # [m] the object; the TCP holds it at its middle


def _low_lateral_end(model: LearnedModel, dx: float, dy: float, dz: float) -> LearnedModel:
    """The model with the person's hand after the release drifting by (dx, dy, dz) [m]."""
    assert model.event_t is not None
    t = model.t
    t_r, t1 = float(model.event_t[1]), float(t[-1])
    u = np.clip((t - t_r) / (t1 - t_r), 0.0, 1.0)
    s = u**3 * (10 - 15 * u + 6 * u * u)
    mean = model.mean.copy()
    mean[:, :3] += s[:, None] * np.array([dx, dy, dz])
    return dataclasses.replace(model, mean=mean)


@pytest.fixture(scope="module")
def low_end_model() -> LearnedModel:
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    model = learn_from_demonstrations(
        demos, LearnConfig(n_components=8), np.random.default_rng(0)
    ).model
    assert model.event_position is not None
    # the person's hand ends 11 cm lower than where it opened (near the table) and 22 cm
    # to the side
    drop = float(model.mean[-1, 2] - model.event_position[1][2]) + 0.11
    return _low_lateral_end(model, 0.0, -0.22, -drop)


def test_the_retreat_stays_above_the_placed_object_once_it_leaves_its_column(
    low_end_model: LearnedModel,
) -> None:
    cfg = PlanConfig(pick=PICK, place=PLACE, object_size=SIZE, object_bottom=SIZE[2] / 2,
                     object_half_width=SIZE[0] / 2, rate_hz=250.0)  # fmt: skip
    plan = plan_from_model(low_end_model, cfg)
    assert plan.grasp is not None
    released = int(np.flatnonzero(plan.grasp)[-1]) + 1
    after = plan.position[released:]
    top = PLACE[2] - SIZE[2] / 2 + SIZE[2]  # the placed object's top [m]
    bound = top + RISE_CLEARANCE
    # the person's end, replayed relative to the place, lies far below the bound
    demo_end = PLACE[2] + float(low_end_model.mean[-1, 2] - low_end_model.event_position[1][2])
    assert demo_end < bound - 0.05
    lateral = np.linalg.norm(after[:, :2] - np.asarray(PLACE[:2]), axis=1)
    outside = lateral > 0.02  # left the object's vertical column
    assert outside.any() and lateral[-1] > 0.15  # the retreat does go sideways
    assert after[outside, 2].min() >= bound - 1e-4, (
        f"the retreat dips to {after[outside, 2].min():.3f} m beside the placed object "
        f"(its top + clearance {bound:.3f} m)"
    )
    assert after[-1, 2] >= bound - 1e-4  # and ends no lower
    # lifted smoothly: the velocity is the position's, no step at the rise or the end
    v_num = np.gradient(plan.position, plan.t, axis=0)
    assert np.abs(v_num - plan.velocity)[released:].max() < 0.02
    # it first rises straight up: no sideways motion below the bound
    below = after[:, 2] < bound - 1e-4
    assert lateral[below].max() < 2e-3
