"""The world a plan expects, as typed arrays: obstacles and supports (plan and rollout).

Obstacles are the :mod:`dexlfd.geometry` shapes the planner bent its path around;
supports are the boxes the object rests on (the pick pedestal, the place surface).
Both travel in the plan and rollout files as arrays, never as ``meta`` strings:

- ``obstacle_center`` (B, 3) [m], ``obstacle_size`` (B, 3) [m] (a box's full
  extents; a sphere's bounding cube), ``obstacle_radius`` (B,) [m] (a sphere's
  radius, 0 for a box);
- ``support_center`` (S, 3) [m], ``support_size`` (S, 3) [m] (boxes standing on
  the table).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.geometry import Box, Obstacle, Sphere
from dexlfd.io._npz import ArraySpec

__all__ = ["WORLD_SPECS", "obstacle_arrays", "obstacles_from_arrays", "support_arrays"]

WORLD_SPECS: dict[str, ArraySpec] = {
    "obstacle_center": ArraySpec(("B", 3), unit="m", required=False),
    "obstacle_size": ArraySpec(("B", 3), unit="m", required=False),
    "obstacle_radius": ArraySpec(("B",), unit="m", required=False),
    "support_center": ArraySpec(("S", 3), unit="m", required=False),
    "support_size": ArraySpec(("S", 3), unit="m", required=False),
}


def obstacle_arrays(obstacles: Sequence[Obstacle]) -> dict[str, Any]:
    """``obstacle_center``, ``obstacle_size``, ``obstacle_radius`` of ``obstacles``."""
    center = np.array([ob.center for ob in obstacles], dtype=np.float64).reshape(-1, 3)
    size = np.array(
        [(2 * ob.radius,) * 3 if isinstance(ob, Sphere) else ob.size for ob in obstacles],
        dtype=np.float64,
    ).reshape(-1, 3)
    radius = np.array(
        [ob.radius if isinstance(ob, Sphere) else 0.0 for ob in obstacles], dtype=np.float64
    )
    return {"obstacle_center": center, "obstacle_size": size, "obstacle_radius": radius}


def support_arrays(supports: Sequence[Box]) -> dict[str, Any]:
    """``support_center``, ``support_size`` of the support boxes."""
    return {
        "support_center": np.array([b.center for b in supports], np.float64).reshape(-1, 3),
        "support_size": np.array([b.size for b in supports], np.float64).reshape(-1, 3),
    }


def obstacles_from_arrays(
    center: FloatArray | None, size: FloatArray | None, radius: FloatArray | None = None
) -> tuple[Obstacle, ...]:
    """The shapes back from their arrays (a positive radius is a sphere); () for None."""
    if center is None or size is None:
        return ()
    r = np.zeros(len(center)) if radius is None else np.asarray(radius)
    out: list[Obstacle] = []
    for c, s, ri in zip(center, size, r, strict=True):
        c3 = (float(c[0]), float(c[1]), float(c[2]))
        if ri > 0:
            out.append(Sphere(c3, float(ri)))
        else:
            out.append(Box(c3, (float(s[0]), float(s[1]), float(s[2]))))
    return tuple(out)
