"""The carry cue on synthetic frames with a known answer: a textured object beside the
fingers moving with the hand reads ~1, an empty hand over a still textured table ~0, a
still hand NaN; the forearm behind the wrist is never counted."""

from __future__ import annotations

import numpy as np

from dexlfd.capture.carry_cue import CarryCue, CarryCueConfig, ring_corners, ring_mask
from dexlfd.capture.tracking import HandObservation

W, H = 320, 240


def hand_landmarks(x: float) -> np.ndarray:
    """A hand pointing right (wrist at the left), palm centre near (x, 120), ~40 px long."""
    uv = np.zeros((21, 2))
    uv[0] = (x - 20, 120)
    for f, dy in enumerate((-12, -4, 4, 12)):
        base = 5 + 4 * f
        uv[base] = (x, 120 + dy)
        for j in range(1, 4):
            uv[base + j] = (x + 6 * j, 120 + dy)
    uv[1:5] = [(x - 12, 132), (x - 6, 136), (x, 138), (x + 6, 138)]
    return uv


def frame(x: float, obj: bool, arm_texture: np.ndarray, table: np.ndarray) -> np.ndarray:
    import cv2

    img = table.copy()
    uv = hand_landmarks(x)
    # the forearm (textured, moving with the hand) behind the wrist
    x_arm = int(x - 20)
    img[110:130, max(0, x_arm - 60) : x_arm] = arm_texture[:20, -min(60, x_arm) :]
    cv2.fillConvexPoly(img, cv2.convexHull(np.round(uv).astype(np.int32)), (200, 160, 140))
    if obj:  # a textured box held in the fingers (hiding their tips), ~2 hands tall
        x0 = int(x + 10)
        img[84:156, x0 : x0 + 40] = np.kron(arm_texture[:18, :10], np.ones((4, 4, 1), np.uint8))
    return img


def cues(obj: bool, step: float) -> np.ndarray:
    rng = np.random.default_rng(0)
    table = rng.integers(0, 255, (H, W, 3), dtype=np.uint8)
    table = np.ascontiguousarray(np.kron(table[::4, ::4], np.ones((4, 4, 1), np.uint8)))
    arm = rng.integers(0, 255, (24, 60, 3), dtype=np.uint8)
    cc = CarryCue()
    out = []
    for k in range(8):
        x = 100 + step * k
        obs = HandObservation(hand_landmarks(x), np.zeros(21), np.zeros((21, 3)), "right", 1.0)
        (res,) = cc.update(frame(x, obj, arm, table), [obs])
        out.append(res.carry)
    return np.array(out)


def test_an_object_moving_with_the_hand_reads_carried_an_empty_hand_does_not() -> None:
    carried = cues(obj=True, step=5.0)
    empty = cues(obj=False, step=5.0)
    still = cues(obj=True, step=0.0)
    assert np.isnan(carried[0]) and np.isnan(empty[0])  # no previous frame
    assert np.nanmedian(carried[1:]) > 0.4, carried  # well above PhaseConfig.carry_above
    assert np.nanmedian(empty[1:]) < 0.15, empty  # the moving forearm is not counted
    assert np.isnan(still).all()  # a still hand says nothing


def test_the_ring_leaves_out_the_hand_and_what_lies_behind_the_wrist() -> None:
    uv = hand_landmarks(150.0)
    mask = ring_mask(uv, (H, W), CarryCueConfig())
    assert mask[120, 150] == 0  # the palm
    assert mask[120, 100] == 0  # behind the wrist (the forearm)
    assert mask[120, 180] == 255  # ahead of the fingertips


def test_the_ring_corners_are_the_whole_frame_corners_in_the_ring() -> None:
    """Corners found on the ring's box alone are those the whole frame gives in the ring.

    Textured frames of three sizes, hands in the middle and cut by each border.
    """
    import cv2

    rng = np.random.default_rng(3)
    cfg = CarryCueConfig()
    for h, w in ((240, 320), (360, 640), (97, 131)):
        grey = rng.integers(0, 255, (h, w), dtype=np.uint8)
        grey = cv2.GaussianBlur(cv2.resize(grey[::3, ::3], (w, h)), (3, 3), 0)
        for x, y in (
            (w / 2, h / 2),
            (12.0, h / 2),
            (w - 5.0, h / 2),
            (w / 2, 3.0),
            (w / 2, h - 2.0),
        ):
            uv = hand_landmarks(0.0) - hand_landmarks(0.0)[9] + (x, y)
            uv = uv * (0.5 + rng.random())
            uv += (x, y) - uv[9]
            mask = ring_mask(uv, (h, w), cfg)
            size = float(max(uv.max(axis=0) - uv.min(axis=0)))
            whole = cv2.goodFeaturesToTrack(
                grey, cfg.max_corners, 0.01, max(3.0, size / 10), mask=mask
            )
            got = ring_corners(grey, mask, cfg, size)
            if whole is None:
                assert got is None
            else:
                assert got is not None and len(whole) >= cfg.min_points
                np.testing.assert_array_equal(got, whole)
