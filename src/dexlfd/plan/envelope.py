"""What must clear an obstacle: the hand and the held object around the TCP, not the TCP.

The planner moves the TCP (between the fingertips); the Franka Hand and the object
it holds take room around it. :func:`envelope` is an axis-aligned box (base frame,
relative to the TCP) that holds the hand (fingers, body and the flange link,
:data:`dexlfd.panda.HAND_ENVELOPE`) and, while carried, the object (its size, its
bottom ``object_bottom`` below the TCP), for one TCP orientation or swept over
several. The TCP keeps clear of an obstacle grown by that box
(:func:`inflate`: the Minkowski sum, for an axis-aligned box exact, for a sphere
its bounding cube's) exactly when the box keeps clear of the obstacle, so the
clearance the planner keeps and reports (:func:`envelope_clearance`) is that of
the hand and the object, a lower bound on the true one (the box is conservative:
the hand's outline is not a box).
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.geometry import Box, Obstacle, half_extents
from dexlfd.panda import HAND_ENVELOPE
from dexlfd.rotations import matrix_from_quat

__all__ = [
    "envelope",
    "envelope_clearance",
    "grow",
    "inflate",
    "object_envelope",
    "swept_envelope",
]

SWEEP_SAMPLES = 9  # orientations sampled between a part's end orientations
SWEEP_PAD = 0.005  # [m] the planned orientation strays a little from the sweep


Corners = tuple[FloatArray, FloatArray]  # low and high corner (3,) [m] around the TCP


def _tcp_boxes(object_size: FloatArray | None, object_bottom: float) -> list[Corners]:
    """The hand's box (with the object's) in the TCP frame (z towards the fingertips).

    A list: the room a part of the arm takes (one box today; the wrist and forearm
    above the hand are not modelled, see :data:`dexlfd.panda.HAND_ENVELOPE`).
    """
    d, w, h, tips = HAND_ENVELOPE
    lo, hi = np.array([-d, -w, -h]), np.array([d, w, tips])
    if object_size is not None:
        width, depth, height = (float(v) for v in object_size)
        o_lo = np.array([-depth / 2, -width / 2, object_bottom - height])
        o_hi = np.array([depth / 2, width / 2, object_bottom])
        lo, hi = np.minimum(lo, o_lo), np.maximum(hi, o_hi)
    return [(lo, hi)]


def envelope(
    quats: FloatArray, object_size: FloatArray | None = None, object_bottom: float = 0.0
) -> list[Corners]:
    """The boxes [m] the hand (and object) take around the TCP, base frame.

    Parameters
    ----------
    quats : ndarray, shape (4,) or (n, 4)
        TCP orientations (x, y, z, w); each box holds its part at every one.
    object_size : ndarray, shape (3,), optional
        Width (across the fingers), depth, height [m] of a held object.
    object_bottom : float
        Its bottom's distance below the TCP [m] (along the TCP's z axis).

    Returns
    -------
    list of (lo, hi)
        Low and high corners (3,) relative to the TCP position [m]: the hand's (with
        the object).
    """
    R = matrix_from_quat(np.atleast_2d(np.asarray(quats, dtype=np.float64)))
    out = []
    for lo_t, hi_t in _tcp_boxes(object_size, object_bottom):
        c, h = R @ ((lo_t + hi_t) / 2), np.abs(R) @ ((hi_t - lo_t) / 2)
        out.append(((c - h).min(axis=0), (c + h).max(axis=0)))
    return out


def swept_envelope(
    q_a: FloatArray, q_b: FloatArray, object_size: FloatArray | None, object_bottom: float
) -> list[Corners]:
    """:func:`envelope` over the orientations from ``q_a`` to ``q_b`` (slerp), padded."""
    from scipy.spatial.transform import Rotation, Slerp

    ends = Rotation.from_quat(np.stack([q_a, q_b]))
    quats = Slerp([0.0, 1.0], ends)(np.linspace(0.0, 1.0, SWEEP_SAMPLES)).as_quat()
    return [
        (lo - SWEEP_PAD, hi + SWEEP_PAD) for lo, hi in envelope(quats, object_size, object_bottom)
    ]


def object_envelope(
    q_a: FloatArray, q_b: FloatArray, object_size: FloatArray, object_bottom: float
) -> list[Corners]:
    """The held object's own box round the TCP over ``q_a`` to ``q_b``, padded (no hand).

    What must keep off the block a raised place stands on: the object comes down onto
    it, the hand above it (the hand's box, as wide as the hand, would grow the block
    over the pick a hand's width away).
    """
    from scipy.spatial.transform import Rotation, Slerp

    width, depth, height = (float(v) for v in object_size)
    lo_t = np.array([-depth / 2, -width / 2, object_bottom - height])
    hi_t = np.array([depth / 2, width / 2, object_bottom])
    ends = Rotation.from_quat(np.stack([q_a, q_b]))
    R = Slerp([0.0, 1.0], ends)(np.linspace(0.0, 1.0, SWEEP_SAMPLES)).as_matrix()
    c, h = R @ ((lo_t + hi_t) / 2), np.abs(R) @ ((hi_t - lo_t) / 2)
    return [((c - h).min(axis=0) - SWEEP_PAD, (c + h).max(axis=0) + SWEEP_PAD)]


def inflate(ob: Obstacle, lo: FloatArray, hi: FloatArray) -> Box:
    """The obstacle grown by the box ``[lo, hi]`` around the TCP: where the TCP may not go.

    ``p + [lo, hi]`` meets the obstacle's box ``[b_lo, b_hi]`` exactly when ``p`` is in
    ``[b_lo - hi, b_hi - lo]``; a sphere counts as its bounding cube. The side it is
    passed on is kept.
    """
    c, h = np.asarray(ob.center, dtype=np.float64), np.asarray(half_extents(ob))
    lo_b, hi_b = c - h - hi, c + h - lo
    return Box(tuple((lo_b + hi_b) / 2), tuple(hi_b - lo_b), direction=ob.direction)


def grow(obstacles: tuple[Obstacle, ...], boxes: list[Corners]) -> tuple[Box, ...]:
    """Every obstacle grown by every box of :func:`envelope` (obstacle-major order)."""
    return tuple(inflate(ob, lo, hi) for ob in obstacles for lo, hi in boxes)


def envelope_clearance(
    obstacles: tuple[Obstacle, ...],
    p: FloatArray,
    quats: FloatArray,
    held: np.ndarray,
    object_size: FloatArray,
    object_bottom: float,
) -> FloatArray:
    """Clearance (n_obstacles, n) [m] of the hand (and held object) from each obstacle.

    Per sample: the smallest signed distance between a box of :func:`envelope` at the
    sample's orientation (with the object where ``held``) placed at ``p`` and the
    obstacle's box (a sphere's bounding cube): negative is an overlap.
    """
    R = matrix_from_quat(np.asarray(quats, dtype=np.float64))
    held = np.asarray(held, dtype=bool)[:, None]
    out = np.full((len(obstacles), p.shape[0]), np.inf)
    free, carried = _tcp_boxes(None, object_bottom), _tcp_boxes(object_size, object_bottom)
    for (lo0, hi0), (lo1, hi1) in zip(free, carried, strict=True):
        c = p + np.where(held, R @ ((lo1 + hi1) / 2), R @ ((lo0 + hi0) / 2))
        h = np.where(held, np.abs(R) @ ((hi1 - lo1) / 2), np.abs(R) @ ((hi0 - lo0) / 2))
        for i, ob in enumerate(obstacles):
            gap = np.abs(c - np.asarray(ob.center)) - h - np.asarray(half_extents(ob))
            outside = np.linalg.norm(np.maximum(gap, 0.0), axis=1)
            out[i] = np.minimum(out[i], np.where((gap > 0).any(axis=1), outside, gap.max(axis=1)))
    return out
