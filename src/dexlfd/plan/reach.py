"""How near its own axis the Panda takes a top-down TCP, and keeping a path outside it.

A top-down TCP near the base needs the elbow folded: joint 4 towards its limit
(-3.07 rad) and joint 6, which keeps the hand pointing down (``q6 = q2 - q4`` with
joints 1, 3, 5 at the heading alone, as from the ready pose), towards its own
(3.75 rad). :func:`top_down_radius` is the band of distances from the base's z
axis that this elbow-up family reaches at a height, from the forward kinematics
over the joint limits: at the table about 0.26 m, at 9 cm 0.29 m. Nearer, the inverse
kinematics of a plan that comes from the ready pose has no solution within the
limits (seen on a real recording: a reach through 0.28 m from the axis at 9 cm
height missed by 6.6 mm); the solutions that exist there fold joints 3 and 5 round
by a half turn, which no smooth motion from the ready pose reaches.

:func:`push_outside_radius` moves a planned path that passes nearer than the band
(plus a margin) outward, over the stretch that does, along minimum-jerk ramps (the
same plateau as the floor's, :func:`dexlfd.plan.floor.floor_lift`); its ends stay.

That move comes after the path was bent round the obstacles, and a plateau that moves
a whole stretch outward can take it back towards one: on a real recording a carry over
a box 0.12 m from the pick overshot past its place (0.3 m from the axis) towards the
base, was moved 64-87 mm outward and came down over the box (the hand 14.6 mm from it
where the margin is 20, or into it). :func:`reach_clear` therefore bends the nominal
path moved by the same amount round the obstacles again, and moves that, until the
move no longer takes the path within the margin of an obstacle, and refuses in one
line naming the obstacle when a few rounds cannot.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Sequence
from typing import TypeVar

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Obstacle
from dexlfd.panda import Q_MAX, Q_MIN
from dexlfd.panda_kinematics import dh_tcp
from dexlfd.plan.floor import floor_lift
from dexlfd.plan.obstacles import distance

__all__ = [
    "RADIUS_MARGIN",
    "check_top_down",
    "push_outside_radius",
    "reach_clear",
    "top_down_radius",
]

logger = logging.getLogger(__name__)

Path3 = tuple[FloatArray, FloatArray, FloatArray]
_Bent = TypeVar("_Bent")

RADIUS_MARGIN = 0.01  # [m] a planned path keeps this much outside the band's inner edge
_Z_STEP = 0.005  # [m] the band's height bins
_N_GRID = 241  # joint 2 and joint 4 samples over their ranges
_ROUNDS = 4  # bendings of a moved path round the obstacles before it is refused


@functools.lru_cache(maxsize=1)
def _band() -> tuple[FloatArray, FloatArray, FloatArray]:
    """Heights (m,), nearest and farthest top-down radius (m,) per height bin [m]."""
    q2, q4 = np.meshgrid(
        np.linspace(Q_MIN[1], Q_MAX[1], _N_GRID), np.linspace(Q_MIN[3], Q_MAX[3], _N_GRID)
    )
    q6 = q2 - q4  # the hand points straight down
    ok = (q6 >= Q_MIN[5]) & (q6 <= Q_MAX[5])
    q = np.zeros((int(ok.sum()), 7))
    q[:, 1], q[:, 3], q[:, 5], q[:, 6] = q2[ok], q4[ok], q6[ok], np.pi / 4
    p = dh_tcp(q)[:, :3, 3]
    front = p[:, 0] > 0.0
    x, z = p[front, 0], p[front, 2]
    edges = np.arange(0.0, float(z.max()) + _Z_STEP, _Z_STEP)
    k = np.digitize(z, edges) - 1
    r_min = np.full(edges.shape, np.inf)
    r_max = np.full(edges.shape, -np.inf)
    np.minimum.at(r_min, k[k >= 0], x[k >= 0])
    np.maximum.at(r_max, k[k >= 0], x[k >= 0])
    return edges, r_min, r_max


def top_down_radius(z: FloatArray | float) -> tuple[FloatArray, FloatArray]:
    """Nearest and farthest distance [m] from the base's z axis of a top-down TCP at ``z``.

    Per the height bin of ``z`` [m] (5 mm), from the forward kinematics of the
    elbow-up family over a grid of joints 2 and 4 (module docstring): the nearest
    sample in a bin is never nearer than the family's true edge, so the band errs on
    the safe side. Outside the heights the family reaches: ``(inf, -inf)``.
    """
    edges, r_min, r_max = _band()
    k = np.floor(np.asarray(z, dtype=np.float64) / _Z_STEP).astype(int)
    inside = (k >= 0) & (k < edges.shape[0])
    kk = np.clip(k, 0, edges.shape[0] - 1)
    return np.where(inside, r_min[kk], np.inf), np.where(inside, r_max[kk], -np.inf)


def push_outside_radius(
    tb: FloatArray, path: tuple[FloatArray, FloatArray, FloatArray], margin: float = RADIUS_MARGIN
) -> tuple[tuple[FloatArray, FloatArray, FloatArray], float]:
    """``path`` (x, x', x'') per normalised time ``tb`` moved outward where it is too near.

    Where the TCP passes nearer the base's axis than :func:`top_down_radius`'s inner
    edge plus ``margin`` [m], the path is moved horizontally outward (along the
    direction from the axis to its nearest offending sample) by the deepest
    shortfall, ramped in and out (:func:`dexlfd.plan.floor.floor_lift`); a few rounds
    for the samples the first push turned less directly outward. The ends stay (an end
    that is itself too near lowers the bound to it). Returns the path and the largest
    push [m].
    """
    x, xd, xdd = (np.array(p, dtype=np.float64, copy=True) for p in path)
    inner = top_down_radius(x[:, 2])[0] + margin
    total = 0.0
    for _ in range(4):
        slack = np.hypot(x[:, 0], x[:, 1]) - inner
        floor = min(0.0, float(slack[0]), float(slack[-1]))
        if not np.isfinite(slack).all() or slack.min() >= floor - 1e-9:
            break
        k = int(np.argmin(slack))
        u = x[k, :2] / max(float(np.hypot(x[k, 0], x[k, 1])), 1e-9)
        push, d_push, dd_push = floor_lift(tb, slack, floor)
        x[:, :2] += push[:, None] * u
        xd[:, :2] += d_push[:, None] * u
        xdd[:, :2] += dd_push[:, None] * u
        total = max(total, float(push.max()))
    return (x, xd, xdd), total


def _nearest(obstacles: Sequence[Obstacle], x: FloatArray, phase: FloatArray) -> tuple[float, int]:
    """The least clearance [m] of ``x`` from ``obstacles`` and which obstacle."""
    per = [float(distance(ob, x, phase).min()) for ob in obstacles]
    i = int(np.argmin(per))
    return per[i], i


def reach_clear(
    tb: FloatArray,
    nominal: Path3,
    bend: Callable[[Path3], tuple[Path3, _Bent]],
    obstacles: Sequence[Obstacle],
    margin: float,
) -> tuple[Path3, _Bent, float]:
    """``bend(nominal)`` moved outside the band, and bent again where that took it near.

    ``bend`` takes a path (x, x', x'' per normalised time ``tb``) round ``obstacles``
    (and whatever else the planner does before the move), returning the path and what
    it learnt on the way. The bent path is moved outward (:func:`push_outside_radius`);
    when the move takes it nearer than ``margin`` [m] to an obstacle than the bending
    left it, the nominal path moved by the same amount is bent again, and moved again,
    up to :data:`_ROUNDS` times (module docstring). Returns the moved path, ``bend``'s
    report of its last round and the largest move [m] from the nominal.

    Raises
    ------
    InvalidInput
        The move still takes the path within ``margin`` of an obstacle after the last
        round; one line naming the obstacle.
    """
    offset = tuple(np.zeros_like(p) for p in nominal)
    for k in range(_ROUNDS):
        shifted: Path3 = (nominal[0] + offset[0], nominal[1] + offset[1], nominal[2] + offset[2])
        path, bent = bend(shifted)
        moved, push = push_outside_radius(tb, path)
        offset = tuple(o + m - p for o, m, p in zip(offset, moved, path, strict=True))
        total = float(np.hypot(offset[0][:, 0], offset[0][:, 1]).max())
        if push == 0.0 or not obstacles:
            return moved, bent, total
        near, i = _nearest(obstacles, moved[0], tb)
        before = _nearest(obstacles, path[0], tb)[0]
        if near >= min(margin, before) - 1e-6:
            return moved, bent, total
        logger.info(
            "moved %.1f mm outward of the top-down reach band, the path passes %.1f mm "
            "from obstacle %d (%.1f mm before the move): bent round it again (round %d)",
            1e3 * push, 1e3 * near, i, 1e3 * before, k + 2,
        )  # fmt: skip
    raise InvalidInput(
        f"moved {1e3 * total:.0f} mm outward (a top-down hand nearer the Panda's axis "
        f"meets its joint limits), the path passes {near:.3f} m from obstacle {i} "
        f"({obstacles[i].spec()}), less than the margin {margin} m: move the pick, the "
        "place or the obstacle"
    )


def check_top_down(name: str, p: FloatArray, approach: float) -> None:
    """Refuse a top-down ``name`` at ``p`` [m] (and ``approach`` [m] above it) the arm can't take.

    One line naming the band of distances from the base's axis the Panda reaches with
    a top-down hand at that height (:func:`top_down_radius`).
    """
    p = np.asarray(p, dtype=np.float64)
    r = float(np.hypot(p[0], p[1]))
    for z in (float(p[2]), float(p[2]) + approach):
        lo, hi = (float(v) for v in top_down_radius(z))
        if lo <= r <= hi:
            continue
        raise InvalidInput(
            f"{name} {np.round(p, 3).tolist()} m is {r:.3f} m from the Panda's axis: a "
            f"top-down hand at z = {z:.3f} m reaches {lo:.3f}..{hi:.3f} m from it (nearer, "
            "the folded elbow meets its joint limits); move it"
        )
