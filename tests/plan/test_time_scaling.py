"""Every slow-down is listed, and they add up to the plan's growth."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import LearnedModel
from dexlfd.learn import LearnConfig, learn_from_demonstrations
from dexlfd.plan import PlanConfig, plan_from_model
from dexlfd.plan.feasibility import make_feasible

RATE = 200.0
STEP = 1.0 / RATE


@pytest.fixture(scope="module")
def model() -> LearnedModel:
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    return learn_from_demonstrations(demos, LearnConfig(), np.random.default_rng(0)).model


def _nominal_parts(model: LearnedModel, duration: float) -> list[float]:
    """The parts' durations before any slow-down: the model's stretches between events."""
    assert model.event_t is not None
    t0, t1 = float(model.t[0]), float(model.t[-1])
    cuts = [t0, *map(float, model.event_t), t1]
    return [duration * (b - a) / (t1 - t0) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]


def test_the_slow_downs_add_up_to_the_plans_growth(model: LearnedModel) -> None:
    # a short duration: the parts need the Cartesian slow-down and the joints need more
    duration = 5.0
    cart = plan_from_model(model, PlanConfig(rate_hz=RATE, duration=duration, feasible=False))
    plan = plan_from_model(model, PlanConfig(rate_hz=RATE, duration=duration))
    ts = plan.time_scaling
    stages = {s.stage for s in ts.slowdowns}
    assert stages == {"cartesian", "joint"}, ts.slowdowns
    # each Cartesian slow-down: the part lasts its nominal duration times the factor;
    # nominal: the model's stretch for a part the person made, the robot's own timing
    # for the reach from the ready pose (no slow-down: it is as long as it needs)
    timing = cart.meta["part_timing"]
    assert timing["timed_by"]["reach"] == "robot" and timing["timed_by"]["carry"] == "person"
    nominal = [
        timing["duration_unscaled_s"][name] if timing["timed_by"][name] == "robot" else t_nom
        for name, t_nom in zip(("reach", "carry", "retreat"), _nominal_parts(model, duration),
                               strict=True)
    ]  # fmt: skip
    assert cart.meta["parts"][0]["time_scale"] == 1.0
    for part, t_nom in zip(cart.meta["parts"], nominal, strict=True):
        span = part["t_s"][1] - part["t_s"][0]
        assert span == pytest.approx(t_nom * part["time_scale"], abs=3 * STEP)
    cart_added = sum(s.added_s for s in ts.slowdowns if s.stage == "cartesian")
    spans = sum(p["t_s"][1] - p["t_s"][0] for p in cart.meta["parts"])
    assert spans - cart_added == pytest.approx(sum(nominal), abs=6 * STEP)
    # the joint-space ones: the feasible plan's growth over the Cartesian-only one
    joint_added = sum(s.added_s for s in ts.slowdowns if s.stage == "joint")
    assert plan.t[-1] - cart.t[-1] == pytest.approx(joint_added, abs=4 * STEP)
    # the totals
    assert ts.added_s == pytest.approx(cart_added + joint_added)
    assert ts.duration_s == pytest.approx(plan.t[-1])
    assert ts.duration_s - ts.duration_unscaled_s == pytest.approx(ts.added_s)
    # and the plan is feasible: joint peaks within the planning margin
    feas = plan.feasibility
    assert feas.joint_velocity_ratio <= 0.8 * 1.05
    assert feas.joint_acceleration_ratio <= 0.8 * 1.1


def test_make_feasible_reports_each_round(model: LearnedModel) -> None:
    fast = plan_from_model(
        model, PlanConfig(duration=2.0, task="motion", rate_hz=RATE, on_limit="scale",
                          feasible=False),
    )  # fmt: skip
    slow, report = make_feasible(fast)
    assert report.needed
    assert report.added_s == pytest.approx(sum(d.added_s for d in report.stretches))
    rounds = max(1, len(report.stretches))
    assert slow.t[-1] - fast.t[-1] == pytest.approx(report.added_s, abs=rounds * STEP)
    # a motion plan asked to be scaled is made feasible by plan_from_model itself
    lib = plan_from_model(
        model, PlanConfig(duration=2.0, task="motion", rate_hz=RATE, on_limit="scale")
    )
    assert lib.t[-1] == pytest.approx(slow.t[-1], abs=STEP)
    raw = dataclasses.replace(fast, meta={})
    assert "time_scaling" not in raw.meta
