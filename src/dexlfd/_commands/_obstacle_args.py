"""The ``--obstacle`` option: one way for every command to read obstacles from its flags.

``box:cx,cy,cz,sx,sy,sz[@dir]`` or ``sphere:cx,cy,cz,r[@dir]`` (metres, base frame);
``dir`` is the side to pass it on, one of :data:`dexlfd.geometry.DIRECTIONS`
(default ``+z``). The shapes are :class:`dexlfd.geometry.Box` / ``Sphere``.
"""

from __future__ import annotations

import argparse
import math

from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, Obstacle, Sphere

__all__ = ["add_obstacle_argument", "obstacles_from_args", "parse_obstacle"]

_FLAG = "--obstacle"
_SIZES = {"box": (6, "cx,cy,cz,sx,sy,sz"), "sphere": (4, "cx,cy,cz,r")}
# an obstacle on the table the Panda works at: centre and size within a few metres
MAX_OBSTACLE_M = 5.0


def add_obstacle_argument(parser: argparse.ArgumentParser) -> None:
    """Register the repeatable ``--obstacle`` option (``args.obstacle``: list of str)."""
    parser.add_argument(
        _FLAG,
        action="append",
        default=[],
        help="box:cx,cy,cz,sx,sy,sz or sphere:cx,cy,cz,r [m], optional @+z/@+x/.../@auto "
        "(avoidance side); repeatable",
    )


def parse_obstacle(spec: str) -> Obstacle:
    """Parse one ``--obstacle`` value; :class:`InvalidInput` naming the flag if bad."""
    kind, sep, rest = spec.strip().partition(":")
    if not sep:
        raise InvalidInput(f"{_FLAG} {spec!r}: expected box:cx,cy,cz,sx,sy,sz or sphere:cx,cy,cz,r")
    if kind not in _SIZES:
        raise InvalidInput(f"{_FLAG} {spec!r}: unknown kind {kind!r}, expected 'box' or 'sphere'")
    rest, _, direction = rest.partition("@")
    try:
        nums = [float(v) for v in rest.split(",")]
    except ValueError as exc:
        raise InvalidInput(f"{_FLAG} {spec!r}: values must be numbers in metres") from exc
    count, names = _SIZES[kind]
    if len(nums) != count:
        raise InvalidInput(f"{_FLAG} {spec!r}: a {kind} needs {count} numbers {names}")
    if not all(math.isfinite(v) for v in nums):
        raise InvalidInput(f"{_FLAG} {spec!r}: values must be finite numbers in metres")
    if max(abs(v) for v in nums) > MAX_OBSTACLE_M:
        scaled = ",".join(f"{v / 1000:g}" for v in nums)
        raise InvalidInput(
            f"{_FLAG} {spec!r}: values are in metres, within {MAX_OBSTACLE_M:g} m of the base "
            f"({kind}:{scaled} if you meant millimetres)"
        )
    center = (nums[0], nums[1], nums[2])
    try:
        if kind == "box":
            return Box(center, (nums[3], nums[4], nums[5]), direction.strip() or "+z")
        return Sphere(center, nums[3], direction.strip() or "+z")
    except InvalidInput as exc:  # the shape's own check (size, radius, direction)
        raise InvalidInput(f"{_FLAG} {spec!r}: {exc}") from exc


def obstacles_from_args(specs: list[str]) -> tuple[Obstacle, ...]:
    """Every ``--obstacle`` value parsed, in order."""
    return tuple(parse_obstacle(s) for s in specs)
