"""What each part of a pick-and-place keeps the hand and the held object clear of.

The user's obstacles are grown by the room the hand (and, carried, the object) takes
around the TCP over the part's orientations (:mod:`dexlfd.plan.envelope`); the retreat
also keeps clear of the object it has just placed, and the carry of the block a raised
place stands on.
"""

from __future__ import annotations

from dexlfd._types import FloatArray
from dexlfd.geometry import Box
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.envelope import envelope, grow, object_envelope, swept_envelope
from dexlfd.plan.task_poses import Pose, support


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

    The ``placed`` object (the retreat's) is grown by the open hand at ``q_a`` (the
    place orientation) only: the hand rises straight off it with that orientation, to
    :data:`~dexlfd.plan.task_poses.RISE_CLEARANCE` above it, before turning.
    """
    out = grow(obstacles, swept_envelope(q_a, q_b, size, cfg.object_bottom))
    return out if placed is None else (*out, *grow((placed,), envelope(q_a)))
