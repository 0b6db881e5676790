"""Clearance of the Panda's arm links (not only the hand) from the plan's obstacles.

The hand and a held object are checked along the plan by their envelope
(:mod:`dexlfd.plan.envelope`); the links behind the wrist are not, and with the
hand beside an obstacle the forearm can sweep over it (seen in simulation: link 5
rubbing the top edge of the thesis's 0.5 m pillar while the hand came down beside
it). :func:`arm_clearance` follows the plan's inverse kinematics
(:func:`dexlfd.plan.feasibility.joint_profile`) and measures, at each joint sample,
the distance from every arm link's collision geometry (the packaged franka_ros
description's collision meshes, as MuJoCo holds them: their convex hulls, the
shapes the simulation's contacts use) to every obstacle
(``mujoco.mj_geomDistance``; negative: the depth they overlap).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.geometry import Box, Obstacle, half_extents

__all__ = ["ARM_LINKS", "HAND_BODIES", "arm_clearance"]

ARM_LINKS = tuple(f"panda_link{i}" for i in range(2, 8))  # behind the hand, moving
HAND_BODIES = ("panda_hand", "panda_leftfinger", "panda_rightfinger")  # fingers as held
_DIST_MAX = 1.0  # [m] distances beyond this are reported as this


@functools.lru_cache(maxsize=8)
def _scene(
    obstacles: tuple[tuple[str, tuple[float, ...], tuple[float, ...]], ...],
    bodies: tuple[str, ...] = ARM_LINKS,
) -> Any:
    """The arm (fingers fixed) with ``obstacles`` as world geoms; ``bodies``' and their geoms."""
    from dexlfd.robot.robot_model import build_arm_spec, import_mujoco

    mj = import_mujoco()
    spec = build_arm_spec(fixed_fingers=True)
    for kind, center, half in obstacles:
        geom_type = mj.mjtGeom.mjGEOM_BOX if kind == "box" else mj.mjtGeom.mjGEOM_SPHERE
        spec.worldbody.add_geom(type=geom_type, pos=list(center), size=[*half, 0.0][:3],
                                contype=0, conaffinity=0)  # fmt: skip
    m = spec.compile()
    d = mj.MjData(m)
    links = []
    for name in bodies:
        b = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, name)
        links.append([g for g in range(m.ngeom) if m.geom_bodyid[g] == b])
    world = [g for g in range(m.ngeom) if m.geom_bodyid[g] == 0]
    return mj, m, d, links, world[-len(obstacles) :] if obstacles else []


def _key(ob: Obstacle) -> tuple[str, tuple[float, ...], tuple[float, ...]]:
    kind = "box" if isinstance(ob, Box) else "sphere"
    half = tuple(float(v) for v in half_extents(ob))
    return kind, tuple(float(v) for v in ob.center), half if kind == "box" else half[:1]


def arm_clearance(
    qs: FloatArray, obstacles: tuple[Obstacle, ...], bodies: tuple[str, ...] = ARM_LINKS
) -> tuple[FloatArray, list[tuple[str, int]]]:
    """Clearance (n_obstacles, m) [m] of the arm's links at each joint sample ``qs`` (m, 7).

    Also returns, per obstacle, the nearest link's name and the sample where the
    clearance is smallest. Negative: the link's collision geometry overlaps the
    obstacle by that much. ``bodies``: whose geometry (default the links behind the
    hand; :data:`HAND_BODIES` for the hand and its fingers, as the simulation holds
    them when it checks a rollout).
    """
    mj, m, d, links, world = _scene(tuple(_key(ob) for ob in obstacles), tuple(bodies))
    qs = np.atleast_2d(np.asarray(qs, dtype=np.float64))
    per = np.full((len(obstacles), qs.shape[0]), _DIST_MAX)
    which = np.zeros((len(obstacles), qs.shape[0]), dtype=int)
    fromto = np.zeros(6)
    for k, q in enumerate(qs):
        d.qpos[: q.shape[0]] = q
        mj.mj_kinematics(m, d)
        for i, g_ob in enumerate(world):
            for j, geoms in enumerate(links):
                for g in geoms:
                    dist = mj.mj_geomDistance(m, d, g, g_ob, _DIST_MAX, fromto)
                    if dist < per[i, k]:
                        per[i, k], which[i, k] = dist, j
    worst = []
    for i in range(len(obstacles)):
        k = int(np.argmin(per[i]))
        worst.append((bodies[which[i, k]].replace("panda_", "").replace("link", "link "), k))
    return per, worst
