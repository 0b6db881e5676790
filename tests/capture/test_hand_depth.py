"""Depth read from the whole hand (fingers as well as the palm) and the carry's uncertainty."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.capture import Intrinsics
from dexlfd.capture.palm_fit import combined_depth, hand_scale, rigid_fingers
from dexlfd.capture.tracking import FINGER_CHAINS as FINGERS
from dexlfd.motion.carry_travel import carry_travel
from dexlfd.motion.frame_evidence import HAND_LENGTH_REL_SD

K = Intrinsics(640, 480, 500.0, 500.0, 319.5, 239.5)


def hand_points(bend_deg: float, shrink: float = 0.0) -> np.ndarray:
    """21 landmarks [m] about the hand's centre: palm in the x-y plane, fingers bent.

    ``shrink``: the finger bones shortened by this fraction (a tracker's curled hand).
    """
    kp = np.zeros((21, 3))
    a = np.radians(bend_deg)
    for f, x in enumerate((0.03, 0.01, -0.01, -0.03)):
        base = 5 + 4 * f
        p = np.array([x, -0.09, 0.0])
        kp[base] = p
        ang = 0.0
        for j, length in enumerate((0.04, 0.025, 0.02)):
            ang += a
            p = p + (1.0 - shrink) * length * np.array([0.0, -np.cos(ang), -np.sin(ang)])
            kp[base + j + 1] = p
    kp[1:5] = [(0.03, -0.02, 0.0), (0.05, -0.04, -0.01), (0.06, -0.06, -0.02), (0.07, -0.08, -0.03)]
    return kp - kp.mean(axis=0)


def turned(kp: np.ndarray, deg: float) -> np.ndarray:
    """``kp`` turned about the image's vertical axis (90 deg: the palm edge-on)."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return kp @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]).T


def project(points: np.ndarray) -> np.ndarray:
    return np.stack(
        [
            K.fx * points[:, 0] / points[:, 2] + K.cx + 0.5,
            K.fy * points[:, 1] / points[:, 2] + K.cy + 0.5,
        ],
        axis=1,
    )


@pytest.mark.parametrize("turn_deg", [0.0, 60.0, 85.0])
def test_the_whole_hand_reads_its_depth_even_with_the_palm_edge_on(turn_deg: float) -> None:
    rng = np.random.default_rng(1)
    world = turned(hand_points(30.0), turn_deg)  # MediaPipe's world landmarks: camera axes
    depth = 0.6
    uv = project(world + [0.0, 0.0, depth])[None] + rng.normal(0, 0.3, (1, 21, 2))
    s = hand_scale(uv, world[None], np.eye(3)[None], K)
    assert 1.0 / s[0] == pytest.approx(depth, rel=0.03)


def test_the_readings_are_combined_in_log_depth() -> None:
    palm = np.array([0.5, 0.8, np.nan, 0.6])
    hand = np.array([0.6, 0.8, 0.7, np.nan])
    both = combined_depth(palm, hand, 0.75)
    assert both[0] == pytest.approx(0.6**0.75 * 0.5**0.25)
    assert both[1] == pytest.approx(0.8)
    assert both[2] == 0.7 and both[3] == 0.6  # a frame with one reading keeps it
    np.testing.assert_allclose(combined_depth(palm[:2], hand[:2], 0.0), palm[:2])


def test_the_carry_has_the_hand_size_spread_and_the_ends_depth_error() -> None:
    n = 50
    pos = np.zeros((n, 3))
    pos[:, 2] = 0.6
    pos[:, 0] = np.linspace(-0.15, 0.15, n)  # across the line of sight
    grasp = np.zeros(n, bool)
    grasp[10:40] = True
    valid = np.ones(n, bool)
    dist, std = carry_travel(pos, grasp, valid)
    assert dist == pytest.approx(0.3 * 29 / 49, rel=1e-9)
    assert std == pytest.approx(HAND_LENGTH_REL_SD * dist, rel=1e-9)
    # a depth error moves an end along its line of sight: only its part along the carry
    # counts (here the sight's x part at the ends, |x| / distance from the camera)
    across = carry_travel(pos, grasp, valid, np.full(n, 0.05))[1]
    end = pos[10]
    part = 0.05 * abs(end[0]) / np.linalg.norm(end)
    assert across == pytest.approx(np.hypot(std, part * np.sqrt(2)), rel=1e-6)
    along = pos.copy()
    along[:, 0] = 0.0
    along[:, 2] = np.linspace(0.5, 0.8, n)
    d2, s2 = carry_travel(along, grasp, valid, np.full(n, 0.05))
    assert s2 == pytest.approx(np.hypot(HAND_LENGTH_REL_SD * d2, 0.05 * np.sqrt(2)), rel=1e-6)
    assert np.isnan(carry_travel(pos, np.zeros(n, bool), valid)[0])
    # the depth's full-size factor's own uncertainty joins the hand size's
    scaled = carry_travel(pos, grasp, valid, scale_sd=0.1)[1]
    assert scaled == pytest.approx(np.hypot(HAND_LENGTH_REL_SD, 0.1) * dist, rel=1e-9)


def test_curled_bones_shortened_by_the_tracker_are_set_to_their_straight_length() -> None:
    # a clip of a hand at a known depth opening and closing; its world landmarks shorten
    # each finger bone with its bend (as MediaPipe's do: ~25 % at a fist), the image
    # shows the real, rigid bones
    rng = np.random.default_rng(3)
    bends = np.tile(np.r_[np.linspace(0.0, 60.0, 15), np.linspace(60.0, 0.0, 15)], 2)
    depth = 0.55
    truth = np.stack([turned(hand_points(b), 20.0) for b in bends])
    shrunk = np.stack([turned(hand_points(b, shrink=0.25 * b / 60.0), 20.0) for b in bends])
    uv = np.stack([project(p + [0.0, 0.0, depth]) for p in truth])
    uv = uv + rng.normal(0.0, 0.3, uv.shape)
    eye = np.broadcast_to(np.eye(3), (bends.size, 3, 3))
    fixed = rigid_fingers(shrunk)
    # the bones' lengths come back to the open hand's, their directions are kept
    np.testing.assert_allclose(bone_lengths(fixed), bone_lengths(truth), atol=1e-3)
    curled = bends > 45
    z_raw = 1.0 / hand_scale(uv, shrunk, eye, K)
    z_fixed = 1.0 / hand_scale(uv, fixed, eye, K)
    assert np.median(z_raw[curled]) < 0.98 * depth  # shortened bones read the hand near
    np.testing.assert_allclose(z_fixed, depth, rtol=0.02)
    assert np.median(z_fixed[curled]) == pytest.approx(depth, rel=0.015)


def test_rigid_fingers_keeps_unseen_frames_and_a_one_frame_clip() -> None:
    pts = np.stack([hand_points(10.0), np.full((21, 3), np.nan)])
    out = rigid_fingers(pts)
    assert np.isnan(out[1]).all()
    np.testing.assert_allclose(out[0], pts[0], atol=1e-12)
    assert rigid_fingers(np.zeros((0, 21, 3))).shape == (0, 21, 3)


def bone_lengths(kp: np.ndarray) -> np.ndarray:
    """The 15 finger bones' lengths (the four fingers' and the thumb's last three) [m]."""
    idx = [(c[j - 1], c[j]) for c in FINGERS for j in range(1, 4)]
    return np.stack([np.linalg.norm(kp[:, b] - kp[:, a], axis=1) for a, b in idx], axis=1)
