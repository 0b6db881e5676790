"""Shapes in the robot's base frame: the obstacles and supports every stage shares.

A leaf module. The planner bends a path around a :class:`Box` or :class:`Sphere`,
the simulator puts the same object in its scene, and a plan file carries it as the
dict of :meth:`Box.to_dict` (read back with :func:`obstacle_from_dict`). Each shape
carries the side the planner passes it on (``direction``, default ``+z``: over the top).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput

__all__ = [
    "DIRECTIONS",
    "Box",
    "Obstacle",
    "Sphere",
    "half_extents",
    "obstacle_from_dict",
    "signed_distance",
]

DIRECTIONS = ("+z", "-z", "+x", "-x", "+y", "-y", "auto")
_AXES = {"x": 0, "y": 1, "z": 2}


def _vec3(value: Any, name: str) -> tuple[float, float, float]:
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidInput(f"{name} must be 3 numbers, got {value!r}") from exc
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise InvalidInput(f"{name} must be 3 finite numbers [m], got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _check_direction(direction: str) -> str:
    if direction not in DIRECTIONS:
        raise InvalidInput(f"obstacle direction must be one of {DIRECTIONS}, got {direction!r}")
    return direction


def _spec(kind: str, values: tuple[float, ...], direction: str) -> str:
    """``kind:v1,v2,...[@direction]`` as ``--obstacle`` takes it (the default ``+z`` left out)."""
    text = f"{kind}:" + ",".join(f"{v:.4g}" for v in values)
    return text if direction == "+z" else f"{text}@{direction}"


@dataclass(frozen=True, slots=True)
class Box:
    """Axis-aligned box: ``center`` [m] and edge lengths ``size`` [m], base frame."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]
    direction: str = "+z"

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vec3(self.center, "box center"))
        size = _vec3(self.size, "box size")
        if min(size) <= 0:
            raise InvalidInput(f"box size (edge lengths) must be > 0 [m], got {size}")
        object.__setattr__(self, "size", size)
        _check_direction(self.direction)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (for ``Plan.meta``)."""
        return {
            "type": "box",
            "center": list(self.center),
            "size": list(self.size),
            "direction": self.direction,
        }

    def spec(self) -> str:
        """The ``--obstacle`` spelling of this box (``box:cx,cy,cz,sx,sy,sz[@dir]``, metres)."""
        return _spec("box", (*self.center, *self.size), self.direction)


@dataclass(frozen=True, slots=True)
class Sphere:
    """Sphere: ``center`` [m] and ``radius`` [m], base frame."""

    center: tuple[float, float, float]
    radius: float
    direction: str = "+z"

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vec3(self.center, "sphere center"))
        r = float(self.radius)
        if not np.isfinite(r) or r <= 0:
            raise InvalidInput(f"sphere radius must be > 0 [m], got {self.radius!r}")
        object.__setattr__(self, "radius", r)
        _check_direction(self.direction)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (for ``Plan.meta``)."""
        return {
            "type": "sphere",
            "center": list(self.center),
            "radius": self.radius,
            "direction": self.direction,
        }

    def spec(self) -> str:
        """The ``--obstacle`` spelling of this sphere (``sphere:cx,cy,cz,r[@dir]``, metres)."""
        return _spec("sphere", (*self.center, self.radius), self.direction)


Obstacle = Box | Sphere


def obstacle_from_dict(d: dict[str, Any]) -> Obstacle:
    """Inverse of ``to_dict``."""
    if d.get("type") == "box":
        return Box(tuple(d["center"]), tuple(d["size"]), d.get("direction", "+z"))
    if d.get("type") == "sphere":
        return Sphere(tuple(d["center"]), float(d["radius"]), d.get("direction", "+z"))
    raise InvalidInput(f"unknown obstacle type {d.get('type')!r}")


def signed_distance(obstacle: Obstacle, p: FloatArray) -> FloatArray:
    """Euclidean signed distance [m] from points ``p`` (n, 3) to the obstacle (< 0 inside)."""
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    c = np.asarray(obstacle.center)
    if isinstance(obstacle, Sphere):
        return np.linalg.norm(p - c, axis=1) - obstacle.radius
    q = np.abs(p - c) - 0.5 * np.asarray(obstacle.size)
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return outside + inside


def half_extents(obstacle: Obstacle) -> tuple[float, float, float]:
    """Half sizes [m] of the axis-aligned box that holds the obstacle (a sphere's bounding cube)."""
    if isinstance(obstacle, Sphere):
        return (obstacle.radius, obstacle.radius, obstacle.radius)
    return (0.5 * obstacle.size[0], 0.5 * obstacle.size[1], 0.5 * obstacle.size[2])
