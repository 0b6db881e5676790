"""What each part of a pick-and-place keeps the hand and the held object clear of.

The user's obstacles are grown by the room the hand (and, carried, the object) takes
around the TCP over the part's orientations (:mod:`dexlfd.plan.envelope`); the retreat
also keeps clear of the object it has just placed, and the carry of the block a raised
place stands on.

A top-down part holds the gripper straight down and turns its heading from the
part's start to its end along a minimum-jerk profile (:func:`dexlfd.plan.task._upright`),
so the orientation at each moment of the part is known before it is planned. The
obstacles are grown stretch by stretch (:func:`heading_windows`): over each stretch of
the part's normalised time by the hand's room at the headings it takes then, widened
by :data:`HEADING_TOLERANCE`; the planner holds the result as one
:class:`~dexlfd.plan.obstacles.BoxUnion` per obstacle whose parts stand over their
stretch only. Grown once by every heading from the part's start to its end, a box
beside the pick stood in the way of the approach point for headings the hand had long
left (the reach turns from the ready pose's heading). Other parts (the demonstrated
orientation) are grown by their whole sweep.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.geometry import Box
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.envelope import (
    Phase,
    envelope,
    grow,
    object_envelope,
    swept_envelope,
    yaw_envelope,
)
from dexlfd.plan.task_poses import Pose, heading_turn, support
from dexlfd.trajectory import minimum_jerk

# [rad] the hand's heading may stray this far from the planned one: the room it takes
# is swept that much further each way (the simulated hand's heading strayed at most
# 0.8 deg from teach's plans on breakfast, 1.2 on plush_toy, 1.6 on bagging, each with
# a box beside its path; its tilt, up to 3-12 deg at moments, is the margin's to cover)
HEADING_TOLERANCE = float(np.radians(2.0))
WINDOW_TURN = float(np.radians(3.0))  # [rad] the heading turns at most this much in a stretch
_PEAK_RATE = 1.875  # the minimum-jerk profile's steepest slope (15/8 at mid-part)


def supports_of(pick: Pose, place: Pose, cfg: PlanConfig) -> tuple[list[Box], tuple[Box, ...]]:
    """The blocks a raised pick and place stand on: all of them, and the place's alone."""
    place_support = tuple(
        s for s in (support("place", place.position, cfg, cfg.object_half_width),) if s
    )
    pick_support = support("pick", pick.position, cfg, cfg.object_half_width)
    return [s for s in (pick_support, *place_support) if s is not None], place_support


def part_obstacles(
    i: int,
    quats: tuple[FloatArray, FloatArray],
    size: FloatArray | None,
    placed: Box,
    place_support: tuple[Box, ...],
    cfg: PlanConfig,
) -> tuple[Box, ...]:
    """The obstacles part ``i`` keeps the hand (and a carried object of ``size``) clear of.

    The carry also keeps the held object off the side of the block under a raised place: it
    comes down onto it from above (cut across, the object struck it and turned in the
    fingers), so that block is grown by the object's own box, not the hand's.
    """
    a_q, b_q = quats
    obstacles = grown(cfg.obstacles, a_q, b_q, size, cfg, placed if i == 2 else None)
    if i == 1 and size is not None:
        room = object_envelope(a_q, b_q, size, cfg.object_bottom)
        obstacles = (*obstacles, *grow(place_support, room))
    return obstacles


def grown(
    obstacles: tuple,
    q_a: FloatArray,
    q_b: FloatArray,
    size: FloatArray | None,
    cfg: PlanConfig,
    placed: Box | None = None,
) -> tuple:
    """``obstacles`` grown by the hand's (and a held object's) room from ``q_a`` to ``q_b``.

    Top-down (``cfg.grasp_orientation``): stretch by stretch of the part
    (:func:`heading_windows`); otherwise by the whole sweep. The ``placed`` object (the
    retreat's) is grown by the open hand at ``q_a`` (the place orientation) only: the
    hand rises straight off it with that orientation, to
    :data:`~dexlfd.plan.task_poses.RISE_CLEARANCE` above it, before turning.
    """
    if cfg.grasp_orientation == "top-down":
        boxes, phases = [], []
        for phase, lo, hi in heading_windows(q_a, q_b):
            room = yaw_envelope(lo, hi, size, cfg.object_bottom)
            boxes += room
            phases += [phase] * len(room)
        out = grow(obstacles, boxes, phases)
    else:
        out = grow(obstacles, swept_envelope(q_a, q_b, size, cfg.object_bottom))
    return out if placed is None else (*out, *grow((placed,), envelope(q_a)))


def heading_windows(q_a: FloatArray, q_b: FloatArray) -> list[tuple[Phase, float, float]]:
    """Stretches of a top-down part and the headings [rad] the hand takes over each.

    The part's heading turns from ``q_a``'s to ``q_b``'s (the short way) along the
    minimum-jerk profile of its normalised time; cut into equal stretches over which it
    turns by at most :data:`WINDOW_TURN`, each with its lowest and highest heading
    widened by :data:`HEADING_TOLERANCE`. Neighbouring stretches share their ends.
    """
    yaw_a, dyaw = heading_turn(q_a, q_b)
    n = max(1, int(np.ceil(_PEAK_RATE * abs(dyaw) / WINDOW_TURN)))
    s = np.linspace(0.0, 1.0, n + 1)
    yaw = yaw_a + dyaw * minimum_jerk(s)[0]
    return [
        ((float(s[j]), float(s[j + 1])),
         float(min(yaw[j], yaw[j + 1])) - HEADING_TOLERANCE,
         float(max(yaw[j], yaw[j + 1])) + HEADING_TOLERANCE)
        for j in range(n)
    ]  # fmt: skip
