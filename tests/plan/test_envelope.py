"""The hand's and the held object's room around the TCP, and the obstacles grown by it."""

from __future__ import annotations

import numpy as np

from dexlfd.geometry import Box, Sphere, signed_distance
from dexlfd.panda import HAND_ENVELOPE
from dexlfd.plan.envelope import envelope, envelope_clearance, inflate
from dexlfd.plan.task_poses import top_down

D, W, H, TIPS = HAND_ENVELOPE


def test_a_top_down_hand_takes_its_box_above_the_tcp_turned_with_the_heading() -> None:
    ((lo, hi),) = envelope(top_down(0.0))
    np.testing.assert_allclose(lo, [-D, -W, -TIPS], atol=1e-12)
    np.testing.assert_allclose(hi, [D, W, H], atol=1e-12)
    ((lo, hi),) = envelope(top_down(np.pi / 2))  # across the fingers is now along x
    np.testing.assert_allclose(hi, [W, D, H], atol=1e-12)
    # a held object 0.06 m tall, its bottom 0.03 m below the TCP, 0.2 m deep
    ((lo, hi),) = envelope(top_down(0.0), np.array([0.05, 0.2, 0.06]), 0.03)
    np.testing.assert_allclose(lo, [-0.1, -W, -0.03], atol=1e-12)  # below the tips
    np.testing.assert_allclose(hi, [0.1, W, H], atol=1e-12)


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
            ((lo, hi),) = envelope(q, size if held else None, 0.03)
            for i, ob in enumerate(obstacles):
                ref = signed_distance(inflate(ob, lo, hi), p)[0]
                assert got[i, 0] == np.float64(ref) or abs(got[i, 0] - ref) < 1e-12


def test_the_hand_beside_a_pillar_touches_it_where_the_tcp_does_not() -> None:
    pillar = Box((0.46, -0.05, 0.25), (0.1, 0.1, 0.5))
    p = np.array([[0.46, -0.15, 0.3]])  # the TCP 5 cm beside the pillar's face
    assert signed_distance(pillar, p)[0] > 0.04
    no_object = np.array([0.01, 0.01, 0.01])
    c = envelope_clearance((pillar,), p, top_down(0.0)[None], np.array([False]), no_object, 0.03)
    assert c[0, 0] < 0  # the fingers (0.105 m each side) reach into it
