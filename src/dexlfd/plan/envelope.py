"""What must clear an obstacle: the hand and the held object around the TCP, not the TCP.

The planner moves the TCP (between the fingertips); the Franka Hand and the object
it holds take room around it. :func:`envelope` gives that room as axis-aligned boxes
(base frame, relative to the TCP): the hand's box (fingers, body and the flange link,
:data:`dexlfd.panda.HAND_ENVELOPE`) cut into :data:`CELLS` cells and, while carried,
the object's own box (its size, its bottom ``object_bottom`` below the TCP), each
for one TCP orientation or swept over several. The TCP keeps clear of an obstacle
grown by a box (:func:`inflate`: the Minkowski sum, for an axis-aligned box exact,
for a sphere its bounding cube's) exactly when the box keeps clear of the obstacle;
grown by every cell (:func:`grow`, one :class:`~dexlfd.plan.obstacles.BoxUnion` per
obstacle), exactly when every cell does. So the clearance the planner keeps and
reports (:func:`envelope_clearance`) is that of the hand and the object, a lower
bound on the true one.

Why cells: the hand is 0.21 m across the fingers and 0.09 m deep; turned to a
heading of 15-18 deg (the real recordings' picks), the axis-aligned box round it
reaches 0.071-0.074 m along its depth instead of 0.045, and a box 0.12-0.19 m from
the pick was refused for the approach point's lack of room. Each cell, turned, takes
little more than itself.

Over a range of headings of a top-down hand (the TCP's z axis straight down, turned
about the base z axis), :func:`yaw_envelope` is exact: each cell's corners sweep arcs
whose extremes are known. Other orientations are sampled (:func:`swept_envelope`,
padded by :data:`SWEEP_PAD`).
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.geometry import Box, Obstacle, half_extents
from dexlfd.panda import HAND_ENVELOPE
from dexlfd.plan.obstacles import BoxUnion
from dexlfd.rotations import matrix_from_quat

__all__ = [
    "CELLS",
    "envelope",
    "envelope_clearance",
    "grow",
    "inflate",
    "object_envelope",
    "swept_envelope",
    "yaw_envelope",
]

SWEEP_SAMPLES = 9  # orientations sampled between a part's end orientations
SWEEP_PAD = 0.005  # [m] the planned orientation strays a little from the sweep
# the hand's box is cut into this many cells along the TCP's x (depth) and y (across
# the fingers): 15 x 26 mm; turned by 45 deg a cell's axis-aligned box is 0.7 cm
# wider each side than the cell, the whole hand's 6 cm
CELLS = (3, 8)


Corners = tuple[FloatArray, FloatArray]  # low and high corner (3,) [m] around the TCP


def _hand_cells() -> list[Corners]:
    """The hand's box cut into :data:`CELLS` cells, TCP frame (z towards the fingertips)."""
    d, w, h, tips = HAND_ENVELOPE
    xs, ys = np.linspace(-d, d, CELLS[0] + 1), np.linspace(-w, w, CELLS[1] + 1)
    return [
        (np.array([xs[i], ys[j], -h]), np.array([xs[i + 1], ys[j + 1], tips]))
        for i in range(CELLS[0])
        for j in range(CELLS[1])
    ]


def _object_box(object_size: FloatArray, object_bottom: float) -> Corners:
    """The held object's box in the TCP frame: its bottom ``object_bottom`` below the TCP."""
    width, depth, height = (float(v) for v in object_size)
    return (
        np.array([-depth / 2, -width / 2, object_bottom - height]),
        np.array([depth / 2, width / 2, object_bottom]),
    )


def _tcp_boxes(object_size: FloatArray | None, object_bottom: float) -> list[Corners]:
    """The hand's cells (and the object's box) in the TCP frame.

    The wrist and forearm above the hand are not modelled (see
    :data:`dexlfd.panda.HAND_ENVELOPE`).
    """
    cells = _hand_cells()
    return cells if object_size is None else [*cells, _object_box(object_size, object_bottom)]


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
        Low and high corners (3,) relative to the TCP position [m]: one per hand cell
        (and the object's last); together they hold the hand (and the object).
    """
    R = matrix_from_quat(np.atleast_2d(np.asarray(quats, dtype=np.float64)))
    out = []
    for lo_t, hi_t in _tcp_boxes(object_size, object_bottom):
        c, h = R @ ((lo_t + hi_t) / 2), np.abs(R) @ ((hi_t - lo_t) / 2)
        out.append(((c - h).min(axis=0), (c + h).max(axis=0)))
    return out


def _arc_extremes(xy: FloatArray, lo: float, hi: float) -> tuple[FloatArray, FloatArray]:
    """Lowest and highest x, y [m] of the points ``xy`` (k, 2) turned by ``lo..hi`` [rad].

    A point at angle ``phi`` sweeps the arc ``phi + lo .. phi + hi``; its x (y) is
    extreme at the arc's ends or where the arc crosses a multiple of 90 deg.
    """
    r, phi = np.hypot(xy[:, 0], xy[:, 1]), np.arctan2(xy[:, 1], xy[:, 0])
    a, b = phi + lo, phi + hi
    quarter = np.floor(a / (np.pi / 2))[:, None] + np.arange(6)
    angles = np.concatenate(
        [a[:, None], b[:, None], np.clip(quarter * np.pi / 2, a[:, None], b[:, None])], axis=1
    )
    x, y = r[:, None] * np.cos(angles), r[:, None] * np.sin(angles)
    return np.array([x.min(), y.min()]), np.array([x.max(), y.max()])


def yaw_envelope(
    yaw_lo: float, yaw_hi: float, object_size: FloatArray | None = None,
    object_bottom: float = 0.0,
) -> list[Corners]:  # fmt: skip
    """:func:`envelope` over every top-down orientation with a heading in ``yaw_lo..yaw_hi``.

    Exact (no sampling): a top-down TCP frame is :data:`~dexlfd.plan.task_poses.TOP_DOWN`
    turned about the base z axis by the heading, so each box's corners keep their
    height and sweep arcs (:func:`_arc_extremes`). ``yaw_hi - yaw_lo`` in [0, 2 pi] [rad].
    """
    out = []
    for lo_t, hi_t in _tcp_boxes(object_size, object_bottom):
        corners = np.array([[x, -y] for x in (lo_t[0], hi_t[0]) for y in (lo_t[1], hi_t[1])])
        lo_xy, hi_xy = _arc_extremes(corners, float(yaw_lo), float(yaw_hi))
        out.append((np.append(lo_xy, -hi_t[2]), np.append(hi_xy, -lo_t[2])))
    return out


def swept_envelope(
    q_a: FloatArray, q_b: FloatArray, object_size: FloatArray | None, object_bottom: float
) -> list[Corners]:
    """:func:`envelope` over the orientations from ``q_a`` to ``q_b`` (slerp), padded.

    Sampled (:data:`SWEEP_SAMPLES`): for any orientations. A top-down hand whose
    heading turns is swept exactly by :func:`yaw_envelope`.
    """
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

    lo_t, hi_t = _object_box(object_size, object_bottom)
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


Phase = tuple[float, float]  # a stretch (s0, s1) of a motion's normalised time [0, 1]


def grow(
    obstacles: tuple[Obstacle, ...], boxes: list[Corners], phases: list[Phase] | None = None
) -> tuple[Box, ...]:
    """Each obstacle grown by every box of :func:`envelope`: one obstacle each.

    One box: the grown box; more: a :class:`~dexlfd.plan.obstacles.BoxUnion` of the
    obstacle grown by each. ``phases`` (one per box): the stretch of the motion over
    which the hand takes that box's room (the box of that stretch's orientations).
    """
    out: list[Box] = []
    for ob in obstacles:
        parts = tuple(inflate(ob, lo, hi) for lo, hi in boxes)
        if len(parts) == 1 and phases is None:
            out.append(parts[0])
        else:
            out.append(BoxUnion.of(parts, None if phases is None else tuple(phases)))
    return tuple(out)


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
    sample's orientation (the hand's cells, and the object's where ``held``) placed at
    ``p`` and the obstacle's box (a sphere's bounding cube): negative is an overlap.
    """
    R = matrix_from_quat(np.asarray(quats, dtype=np.float64))
    held = np.asarray(held, dtype=bool)
    out = np.full((len(obstacles), p.shape[0]), np.inf)
    boxes: list[tuple[Corners, np.ndarray | None]] = [(box, None) for box in _hand_cells()]
    boxes.append((_object_box(object_size, object_bottom), held))
    for (lo, hi), where in boxes:
        c = p + R @ ((lo + hi) / 2)
        h = np.abs(R) @ ((hi - lo) / 2)
        for i, ob in enumerate(obstacles):
            gap = np.abs(c - np.asarray(ob.center)) - h - np.asarray(half_extents(ob))
            outside = np.linalg.norm(np.maximum(gap, 0.0), axis=1)
            d = np.where((gap > 0).any(axis=1), outside, gap.max(axis=1))
            out[i] = np.minimum(out[i], d if where is None else np.where(where, d, np.inf))
    return out
