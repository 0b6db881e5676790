"""The hand's and the held object's room around the TCP, and the obstacles grown by it."""

from __future__ import annotations

import numpy as np

from dexlfd.geometry import Box, Sphere, signed_distance
from dexlfd.panda import HAND_ENVELOPE
from dexlfd.plan.envelope import (
    Corners,
    envelope,
    envelope_clearance,
    grow,
    inflate,
    yaw_envelope,
)
from dexlfd.plan.obstacles import BoxUnion, distance
from dexlfd.plan.task_poses import top_down

D, W, H, TIPS = HAND_ENVELOPE


def _bounds(boxes: list[Corners]) -> tuple[np.ndarray, np.ndarray]:
    return np.min([lo for lo, _ in boxes], axis=0), np.max([hi for _, hi in boxes], axis=0)


def test_a_top_down_hand_takes_its_box_above_the_tcp_turned_with_the_heading() -> None:
    lo, hi = _bounds(envelope(top_down(0.0)))
    np.testing.assert_allclose(lo, [-D, -W, -TIPS], atol=1e-12)
    np.testing.assert_allclose(hi, [D, W, H], atol=1e-12)
    lo, hi = _bounds(envelope(top_down(np.pi / 2)))  # across the fingers is now along x
    np.testing.assert_allclose(hi, [W, D, H], atol=1e-12)
    # a held object 0.06 m tall, its bottom 0.03 m below the TCP, 0.2 m deep
    boxes = envelope(top_down(0.0), np.array([0.05, 0.2, 0.06]), 0.03)
    lo, hi = _bounds(boxes)
    np.testing.assert_allclose(lo, [-0.1, -W, -0.03], atol=1e-12)  # below the tips
    np.testing.assert_allclose(hi, [0.1, W, H], atol=1e-12)
    # the object's own box, not the hand's width at the object's depth
    np.testing.assert_allclose(boxes[-1][0], [-0.1, -0.025, -0.03], atol=1e-12)


def test_a_turned_hand_takes_little_more_than_itself_not_its_bounding_box() -> None:
    """Turned 20 deg, the hand's axis-aligned box reaches 0.078 m along x, the hand itself
    (0.09 m deep) 0.058 m where a small block 0.1 m along -x from the TCP faces it: the
    clearance from the block is over 3 cm (the bounding box left under 2.5 cm), and
    never more than the exact hand's."""
    q = top_down(np.radians(20.0))
    slab = Box((0.5 - 0.1 - 0.05, 0.0, 0.0), (0.1, 0.04, 0.04))  # face 0.1 m along -x
    p = np.array([[0.5, 0.0, 0.0]])
    got = envelope_clearance((slab,), p, q[None], np.array([False]), np.full(3, 0.01), 0.0)
    assert got[0, 0] > 0.03
    # the exact hand: its face's distance from the block's nearest edge (x -0.1, y 0.02)
    c, s = np.cos(np.radians(20.0)), np.sin(np.radians(20.0))
    true_gap = 0.1 * c - D - 0.02 * s  # 0.042 m
    assert got[0, 0] <= true_gap + 1e-9  # a lower bound
    lo, hi = _bounds(envelope(q))
    assert 0.1 + lo[0] < 0.025  # its bounding box: 2 cm


def test_the_heading_sweep_is_exact(rng: np.random.Generator) -> None:
    """Over a range of headings, each box is that of the densely sampled orientations."""
    size = np.array([0.04, 0.05, 0.06])
    for _ in range(5):
        a = rng.uniform(-np.pi, np.pi)
        b = a + rng.uniform(0.0, 2.0)
        exact = yaw_envelope(a, b, size, 0.03)
        dense = envelope(top_down(np.linspace(a, b, 20001)), size, 0.03)
        for (lo, hi), (lo_d, hi_d) in zip(exact, dense, strict=True):
            assert np.all(lo <= lo_d + 1e-12) and np.all(hi >= hi_d - 1e-12)
            np.testing.assert_allclose(lo, lo_d, atol=1e-6)
            np.testing.assert_allclose(hi, hi_d, atol=1e-6)


def test_a_union_stands_only_over_its_parts_stretches() -> None:
    """A part standing over the first half of a motion is no obstacle in its second."""
    ob = Box((0.5, 0.0, 0.1), (0.1, 0.1, 0.2))
    far, near = [(np.full(3, -0.01), np.full(3, 0.01))], [(np.full(3, -0.2), np.full(3, 0.2))]
    (u,) = grow((ob,), [*far, *near], [(0.0, 1.0), (0.0, 0.5)])
    assert isinstance(u, BoxUnion) and len(u.parts) == 2
    p = np.array([[0.5, 0.0, 0.4]] * 3)  # 0.2 m above the box's top
    d = distance(u, p, np.array([0.2, 0.5, 0.8]))
    np.testing.assert_allclose(d, [0.0, 0.0, 0.19], atol=1e-12)
    np.testing.assert_allclose(distance(u, p), 0.0, atol=1e-12)  # no phase: every part
    np.testing.assert_allclose(u.size, [0.5, 0.5, 0.6], atol=1e-12)  # others: the bounds


def test_the_clearance_is_the_tcps_from_the_grown_obstacle(rng: np.random.Generator) -> None:
    """For one orientation: the box-to-box distance equals the TCP's signed distance from
    the obstacle grown by the box (the Minkowski sum), inside and out."""
    obstacles = (Box((0.46, -0.05, 0.25), (0.1, 0.1, 0.5)), Sphere((0.3, 0.2, 0.3), 0.05))
    size = np.array([0.05, 0.05, 0.06])
    for held in (False, True):
        for _ in range(20):
            q = top_down(rng.uniform(-np.pi, np.pi))
            p = rng.uniform([0.2, -0.3, 0.0], [0.7, 0.3, 0.7], (1, 3))
            got = envelope_clearance(obstacles, p, q[None], np.array([held]), size, 0.03)
            boxes = envelope(q, size if held else None, 0.03)
            for i, ob in enumerate(obstacles):
                ref = min(signed_distance(inflate(ob, lo, hi), p)[0] for lo, hi in boxes)
                assert abs(got[i, 0] - ref) < 1e-12


def test_the_hand_beside_a_pillar_touches_it_where_the_tcp_does_not() -> None:
    pillar = Box((0.46, -0.05, 0.25), (0.1, 0.1, 0.5))
    p = np.array([[0.46, -0.15, 0.3]])  # the TCP 5 cm beside the pillar's face
    assert signed_distance(pillar, p)[0] > 0.04
    no_object = np.array([0.01, 0.01, 0.01])
    c = envelope_clearance((pillar,), p, top_down(0.0)[None], np.array([False]), no_object, 0.03)
    assert c[0, 0] < 0  # the fingers (0.105 m each side) reach into it
