"""The hand's path widened round an obstacle until the arm's links clear it too.

The arm posture step (:class:`dexlfd.plan.pipeline.ArmPosturePlanner`) swivels the
elbow to keep the links off the obstacles; where no swivel keeps a link out
(``Plan.arm_posture.planned`` false, the link inside the obstacle), the hand's path
itself has to change. :func:`keep_links_clear` re-plans the hand round the obstacle
that link meets, widened horizontally by the link's depth plus :data:`WIDEN_EXTRA`,
and measures the links again against the real obstacle, up to :data:`WIDEN_TRIES`
times, keeping the first plan whose links clear (or the least intrusive tried).

Why wider and not taller: with a top-down hand the forearm (links 5 and 6) hangs
above and behind the wrist, 0.2 m over the TCP, trailing the hand horizontally. The
hand passing just over an obstacle's top edge and coming down on its far side drags
the forearm across that edge; lifting the hand's path lifts the forearm less than it
lengthens the stretch where it trails over the top. Measured on the demo's executed
plan over the 0.4 m cup (six synthetic demonstrations, 8 cm margin): link 5 met the
cup by 17.8 mm with every elbow posture; the cup raised by 4, 8 and 12 cm for the
hand still left it 14.3, 9.2 and 2.7 mm inside, while widened by 4 cm each side the
links kept 24 mm (25 mm with the planned posture). The plan keeps the real obstacle
(its arrays, what the simulation builds); the hand's clearance it reports is then
from the widened one, a lower bound of the real clearance.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, Obstacle, Sphere
from dexlfd.io import Plan
from dexlfd.io._world import obstacle_arrays
from dexlfd.panda_ik import KinematicModel
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.feasibility import joint_profile

__all__ = ["ARM_RATE_HZ", "WIDEN_EXTRA", "WIDEN_TRIES", "keep_links_clear", "widened"]

logger = logging.getLogger(__name__)

ARM_RATE_HZ = 20.0  # [Hz] the joint samples the arm's posture is planned on
WIDEN_TRIES = 3  # re-plans of the hand's path at most
WIDEN_EXTRA = 0.02  # [m] widened by this beyond the link's depth each time


def widened(ob: Obstacle, by: float) -> Obstacle:
    """``ob`` ``by`` [m] wider on every horizontal side (a sphere: its radius), as tall."""
    if isinstance(ob, Sphere):
        return dataclasses.replace(ob, radius=ob.radius + by)
    assert isinstance(ob, Box)
    w, d, h = ob.size
    return dataclasses.replace(ob, size=(w + 2 * by, d + 2 * by, h))


def _depth(plan: Plan) -> float | None:
    """How deep [m] a link goes into an obstacle with every posture; None: it clears."""
    fact = plan.arm_posture
    if fact is None or fact.planned or fact.min_clearance >= 0.0:
        return None
    return -fact.min_clearance


ArmStep = Callable[
    [Plan, tuple[Obstacle, ...], float, tuple[FloatArray, FloatArray], KinematicModel], Plan
]


def _with_posture(plan: Plan, cfg: PlanConfig, arm: ArmStep, model: KinematicModel) -> Plan:
    """``arm`` on ``plan``'s inverse kinematics at :data:`ARM_RATE_HZ`, the real obstacles.

    A plan with a pose the inverse kinematics cannot reach (a one-motion plan kept as
    planned, not made feasible) is returned as it is.
    """
    try:
        t, q, _, _ = joint_profile(plan, model, rate_hz=ARM_RATE_HZ)
    except InvalidInput:
        return plan
    return arm(plan, cfg.obstacles, cfg.margin, (t, q), model)


def keep_links_clear(
    plan_hand: Callable[[PlanConfig], Plan], cfg: PlanConfig,
    arm: ArmStep,
    model: KinematicModel,
) -> Plan:  # fmt: skip
    """The hand's plan for ``cfg`` with the arm's posture, the hand's path widened if need be.

    ``plan_hand(config)`` plans the hand (and makes it feasible); ``arm`` picks the
    elbow posture against ``cfg.obstacles`` (the real ones) with ``model``. Where the
    links still go into obstacle ``i`` whatever the elbow does, the hand is re-planned
    round obstacle ``i`` widened by the depth plus :data:`WIDEN_EXTRA` (the widenings
    add up), at most :data:`WIDEN_TRIES` times; a widened obstacle the hand's plan
    cannot pass (refused) ends the tries. Said in one line which was kept.
    """
    plan = _with_posture(plan_hand(cfg), cfg, arm, model)
    grown = list(cfg.obstacles)
    added = [0.0] * len(grown)
    for _ in range(WIDEN_TRIES):
        depth = _depth(plan)
        if depth is None:
            break
        assert plan.arm_posture is not None
        i = plan.arm_posture.obstacle
        added[i] += depth + WIDEN_EXTRA
        grown[i] = widened(cfg.obstacles[i], added[i])
        try:
            hand = plan_hand(dataclasses.replace(cfg, obstacles=tuple(grown)))
        except InvalidInput as exc:
            logger.warning(
                "the hand's path cannot go round obstacle %d widened by %.0f mm (%s): "
                "the arm's links keep going %.1f mm into it; move the obstacle, the pick "
                "or the place", i, 1e3 * added[i], exc,
                1e3 * depth,
            )  # fmt: skip
            return plan
        hand = dataclasses.replace(hand, **obstacle_arrays(cfg.obstacles))
        tried = _with_posture(hand, cfg, arm, model)
        after = _depth(tried)
        if after is not None and after >= depth:  # no better: widening does not help here
            break
        plan = tried
        assert plan.arm_posture is not None
        logger.warning(
            "the hand's path goes round obstacle %d widened by %.0f mm on each side, so "
            "the arm's links %s (%s %.1f mm from it)", i, 1e3 * added[i],
            "clear it" if after is None else "go less deep into it", plan.arm_posture.link,
            1e3 * plan.arm_posture.min_clearance,
        )  # fmt: skip
    depth = _depth(plan)
    if depth is not None:
        logger.warning(
            "the arm's links go %.1f mm into obstacle %d whatever the elbow does, the "
            "hand's path widened round it or not: move the obstacle, the pick or the place",
            1e3 * depth, plan.arm_posture.obstacle if plan.arm_posture else 0,
        )  # fmt: skip
    return plan
