"""Whole-recording RGB hand pose on real MediaPipe landmark recordings (skipped when absent).

The figures the estimator must meet on real third-person footage (the same figures as
``benchmarks/bench_recording_pose.py``), with the camera's field of view assumed (60
deg): frame-to-frame wrist steps, no depth held while the hand moves in depth, no palm
flips, and the wrist's travel between the annotated grasp and release. Today's per-frame
lift (``PnPTracker``) fails the step and orientation bounds on every one of them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dexlfd.capture import Intrinsics
from dexlfd.capture.recording_pose import estimate_recording_pose

from .landmark_files import (
    NAMES,
    bone_depth,
    frozen_fraction,
    load_acting_hand,
    orientation_steps_deg,
    path,
    per_frame_pnp,
    travel_ratios,
    wrist_steps,
)

# p99 wrist step bound [m]: the 2.5 cm, except bagging: its hand is ~1.8 m away
# (at the assumed field of view) and reaches down and pulls back at ~0.9 m/s, 2.5-3.2 cm
# a frame in its fastest frames (image motion of 18 px a frame at 1080p, and a steady
# depth trend in the measurements), real motion a smoother should not remove
P99_BOUND = {"bagging": 0.035}


@pytest.fixture(scope="module", params=NAMES)
def recording(request):  # type: ignore[no-untyped-def]
    name = request.param
    if not path(name).is_file():
        pytest.skip(f"real landmark recording not found at {path(name)}")
    hand = load_acting_hand(name)
    K = Intrinsics.from_fov(*hand.size, 60.0)
    est = estimate_recording_pose(hand.t, hand.uv_px, hand.world_m, hand.valid, K, hand.score)
    return hand, est


def test_wrist_steps_bounded(recording) -> None:  # type: ignore[no-untyped-def]
    hand, est = recording
    # the bounds hold the smoothing to account: in the depth's units before the clip's one
    # full-size factor (RecordingPoseConfig.depth_template_quantile), which scales every
    # step alike (1.0-1.6 here: the hand really moves that much farther)
    steps = wrist_steps(est.keypoints) / est.info["depth_scale"]
    assert np.percentile(steps, 99) <= P99_BOUND.get(hand.name, 0.025)
    assert steps.max() <= 0.06
    before = wrist_steps(per_frame_pnp(hand))
    assert before.max() > 0.06  # today's per-frame lift jumps


def test_depth_follows_the_hand(recording) -> None:  # type: ignore[no-untyped-def]
    hand, est = recording
    assert frozen_fraction(est.keypoints, hand.uv_px) == 0.0
    std = est.depth_std[hand.valid]
    assert np.isfinite(std).all() and (std > 0).all()
    assert np.median(std) < 0.05 * np.median(est.depth_m[hand.valid])


def test_orientation_without_flips(recording) -> None:  # type: ignore[no-untyped-def]
    hand, est = recording
    assert orientation_steps_deg(est.keypoints).max() <= 30.0
    assert orientation_steps_deg(per_frame_pnp(hand)).max() > 30.0  # today's flips
    assert est.orientation_set.sum() >= 10


def test_travel_against_the_annotation(recording) -> None:  # type: ignore[no-untyped-def]
    hand, est = recording
    if not hand.judge_travel:
        pytest.skip(f"{hand.name}: the hand-held camera moves, travel is not judged")
    ratios = travel_ratios(est.keypoints, hand)
    assert all(0.6 <= r <= 1.6 for r in ratios), ratios


def test_depth_moves_over_each_carry_as_the_hand_grows_in_the_image(recording, request) -> None:  # type: ignore[no-untyped-def]
    """The written depth's change from grasp to release is the pixels' own.

    The whole hand's bones read the depth where they are least foreshortened
    (:func:`landmark_files.bone_depth`, their lengths set at the written depth's level):
    over each annotated carry the two depths change alike, within 3 sigma of the
    bones' frame-to-frame noise (7-frame medians at each end) and the written depth's
    own std. bagging's written depth goes 18 % farther from its grasp to its release
    where its bones say it stays put (8.7 sigma): its hand is unseen over most of the
    carry and the written end is the palm's reading of a hand seen edge-on.
    """
    hand, est = recording
    if hand.name == "bagging":
        request.applymarker(pytest.mark.xfail(strict=True, reason="the pixels disagree"))
    K = Intrinsics.from_fov(*hand.size, 60.0)
    z, sd = est.depth_m, est.depth_std
    uv = np.where(hand.valid[:, None, None], hand.uv_px, np.nan)
    zb = bone_depth(uv, z, K.fx)
    lz = np.diff(np.log(zb))
    lz = lz[np.isfinite(lz)]
    noise = 1.4826 * np.median(np.abs(lz - np.median(lz))) / np.sqrt(2)  # one frame's [-]

    def end(i: int) -> tuple[float, float, float]:  # written, bones, log-variance
        w = slice(max(i - 3, 0), i + 4)
        seen = max(int(np.isfinite(zb[w]).sum()), 1)
        zw = float(np.nanmedian(z[w]))
        var = (1.25 * noise) ** 2 / seen + (float(np.nanmedian(sd[w])) / zw) ** 2
        return zw, float(np.nanmedian(zb[w])), var

    for a, b, _ in hand.grasps:
        (wa, ba, va), (wb, bb, vb) = end(a), end(b)
        gap = abs(np.log(wb / wa) - np.log(bb / ba))
        assert gap <= 3.0 * np.sqrt(va + vb), (hand.name, a, b, wb / wa, bb / ba)


@pytest.mark.slow
def test_real_hand_video_through_the_capture_path(hand_video) -> None:  # type: ignore[no-untyped-def]
    """The real hand video, tracked (640x360) and lifted as ``record`` does it.

    A still hand opens, makes fists and pinches (frames 240-330): its depth stays within
    10 cm (MediaPipe's palm shrinks in the image in a fist: 20 cm without the curl
    correction; the pinch still reads ~6 cm deeper); it turns ~100 deg at 540-570,
    which the orientation keeps, without a step above 30 deg.
    """
    from dexlfd.capture import CaptureConfig, HandCapture, LiftConfig, open_source, track_source
    from dexlfd.capture.recording_pose import series_with_recording_pose
    from dexlfd.capture.recording_pose_config import RecordingPoseConfig
    from dexlfd.motion import MotionConfig, demonstration_from_capture, palm_matrix_from_keypoints
    from dexlfd.rotations import rotation_angle

    cfg = CaptureConfig(lift=LiftConfig(model="pnp"))
    with open_source(hand_video, resize_width=640) as src, HandCapture(cfg, src.intrinsics) as cap:
        series = series_with_recording_pose(track_source(src, capture=cap), cap.lift_cfg)
    assert series.meta["recording_pose"]["curl_beta"] < -0.05
    kp = series.keypoints
    z = kp[240:331, 0, 2]
    assert np.nanmax(z) - np.nanmin(z) < 0.1  # 0.2 m without the curl correction
    plain = series_with_recording_pose(
        replace(series, keypoints=np.zeros_like(kp)),
        cap.lift_cfg,
        RecordingPoseConfig(curl_iterations=0),
    )
    z0 = plain.keypoints[240:331, 0, 2]
    assert np.nanmax(z0) - np.nanmin(z0) > 0.15
    turns = orientation_steps_deg(kp)
    assert turns.max() < 30
    R = palm_matrix_from_keypoints(kp)
    turned = [float(np.degrees(rotation_angle(R[i], R[0]))) for i in range(540, 570)]
    assert max(turned) > 80
    demo = demonstration_from_capture(series, MotionConfig(euler_mode="palm"))
    std = demo.extras["depth_std"]
    assert np.isfinite(std[demo.valid]).all() and np.isnan(std[~demo.valid]).all()
    assert "orientation_set" in demo.extras


def test_the_tracker_shortens_curled_fingers_and_rigid_fingers_undoes_it(recording) -> None:  # type: ignore[no-untyped-def]
    # MediaPipe's world landmarks make a finger's bones shorter against the palm as it
    # curls; the rigid bones keep every bone's length over the clip and every joint angle
    from dexlfd.capture.palm_depth import finger_curl
    from dexlfd.capture.palm_fit import rigid_fingers
    from dexlfd.capture.tracking import FINGER_CHAINS as FINGERS
    from dexlfd.capture.tracking import WRIST

    hand, _ = recording
    W = hand.world_m[hand.valid]
    fixed = rigid_fingers(W)
    bones = [(c[j - 1], c[j]) for c in FINGERS[1:] for j in range(1, 4)]

    def finger_length(P: np.ndarray) -> np.ndarray:  # [m]
        return sum(np.linalg.norm(P[:, b] - P[:, a], axis=1) for a, b in bones) / 4

    palm = np.linalg.norm(W[:, [5, 9, 13, 17]] - W[:, [0]], axis=2).mean(axis=1)

    curl = finger_curl(W)
    curled, open_ = curl < np.percentile(curl, 10), curl > np.percentile(curl, 90)
    raw = finger_length(W) / palm
    assert np.median(raw[curled]) < 0.95 * np.median(raw[open_])
    assert np.ptp(finger_length(fixed)) < 1e-9  # one length per bone over the clip

    def cos(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        n = np.linalg.norm(x, axis=1) * np.linalg.norm(y, axis=1)
        return np.sum(x * y, axis=1) / n

    for chain in FINGERS:
        pts = (WRIST, *chain)
        for j in range(1, 4):
            a, b, c = pts[j - 1], pts[j], pts[j + 1]
            before = cos(W[:, b] - W[:, a], W[:, c] - W[:, b])
            after = cos(fixed[:, b] - fixed[:, a], fixed[:, c] - fixed[:, b])
            np.testing.assert_allclose(after, before, atol=1e-9)
