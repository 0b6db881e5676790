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
"""

from __future__ import annotations

import functools

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_MAX, Q_MIN
from dexlfd.panda_kinematics import dh_tcp
from dexlfd.plan.floor import floor_lift

__all__ = ["RADIUS_MARGIN", "check_top_down", "push_outside_radius", "top_down_radius"]

RADIUS_MARGIN = 0.01  # [m] a planned path keeps this much outside the band's inner edge
_Z_STEP = 0.005  # [m] the band's height bins
_N_GRID = 241  # joint 2 and joint 4 samples over their ranges


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
