"""HandCapture and track_source with a scripted tracker (exact geometry, no MediaPipe)."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import numpy as np
import pytest

from dexlfd.capture import (
    CaptureConfig,
    Frame,
    FrameSource,
    HandCapture,
    HandObservation,
    HandTracker,
    Intrinsics,
    LiftConfig,
    TrackerConfig,
    project_pinhole,
    select_hand,
    track_source,
)
from dexlfd.datasets import hand_keypoints_from_pose
from dexlfd.errors import InvalidDemonstration, InvalidInput
from dexlfd.motion import MotionConfig, OnlineMotion, demonstration_from_capture, quat_from_euler

K = Intrinsics(640, 480, 610.0, 612.0, 319.5, 239.5)


class ScriptedTracker:
    """Returns the projection of known camera-frame keypoints, one set per call."""

    def __init__(self, kp_cam: np.ndarray, extra_left: bool = False) -> None:
        self.kp_cam = kp_cam
        self.i = 0
        self.extra_left = extra_left
        self.closed = False

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        kp = self.kp_cam[self.i]
        self.i += 1
        if not np.isfinite(kp).all():
            return []
        uv, _ = project_pinhole(kp, K)
        hands = [HandObservation(uv, np.zeros(21), kp - kp.mean(axis=0), "right", 0.9)]
        if self.extra_left:  # a second hand, shifted, more confident but the other side
            hands.insert(0, HandObservation(uv + 50, np.zeros(21), kp - kp.mean(0), "left", 0.99))
        return hands

    def close(self) -> None:
        self.closed = True


class ListSource(FrameSource):
    kind = "test"
    has_depth = True

    def __init__(self, frames: list[Frame]) -> None:
        super().__init__()
        self._frames = frames
        self.intrinsics = K
        self.description = "scripted frames"
        self.fps = 30.0
        self._open = True  # nothing to acquire

    def frames(self) -> Iterator[Frame]:
        yield from self._frames


def _scene(rng: np.random.Generator, n: int = 12) -> tuple[np.ndarray, list[Frame]]:
    """Camera-frame hand keypoints and RGB-D frames whose depth matches them."""
    t = np.arange(n) / 30.0
    p = np.column_stack([0.05 * np.sin(t), 0.02 * t, 0.6 + 0.05 * t])
    q = quat_from_euler(np.column_stack([0.3 * t, 0.1 + 0 * t, -0.2 + 0 * t]))
    kp = hand_keypoints_from_pose(p, q, np.full(n, 0.06), rng)
    frames = []
    for i in range(n):
        depth = np.full((480, 640), 3.0, np.float32)  # background 3 m away
        uv, z = project_pinhole(kp[i], K)
        for (u, v), d in sorted(zip(uv, z, strict=True), key=lambda x: -x[1]):
            r, c = int(np.floor(v)), int(np.floor(u))
            depth[r - 1 : r + 2, c - 1 : c + 2] = d  # 3x3 patch per landmark
        frames.append(Frame(i, t[i], np.zeros((480, 640, 3), np.uint8), depth_m=depth))
    return kp, frames


def test_scripted_tracker_is_a_hand_tracker(rng: np.random.Generator) -> None:
    assert isinstance(ScriptedTracker(np.zeros((1, 21, 3))), HandTracker)


def test_rgbd_pinhole_recovers_keypoints(rng: np.random.Generator) -> None:
    kp, frames = _scene(rng)
    cfg = CaptureConfig(lift=LiftConfig(model="pinhole", depth_patch_px=3))
    tracker = ScriptedTracker(kp)
    with HandCapture(cfg, K, tracker=tracker) as cap:
        series = track_source(ListSource(frames), capture=cap)
    # landmarks whose 3x3 patch is not covered by a nearer landmark come back exactly
    err = np.linalg.norm(series.keypoints - kp, axis=2)
    # float32 depth image: ~1e-8 m round-off
    assert np.median(err) < 1e-6 and (err[:, [0, 4, 8]] < 1e-3).all()
    assert series.valid.all() and series.meta["depth"] == "measured"
    assert not tracker.closed  # injected trackers belong to the caller


def test_depth_holes_are_filled_with_a_warning(
    rng: np.random.Generator, caplog: pytest.LogCaptureFixture
) -> None:
    kp, frames = _scene(rng, 3)
    uv, _ = project_pinhole(kp[1, 4], K)
    frames[1].depth_m[int(uv[1]) - 6 : int(uv[1]) + 7, int(uv[0]) - 6 : int(uv[0]) + 7] = 0.0
    cfg = CaptureConfig(lift=LiftConfig(model="pinhole", depth_patch_px=3))
    with caplog.at_level(logging.WARNING):
        series = track_source(
            ListSource(frames), capture=HandCapture(cfg, K, tracker=ScriptedTracker(kp))
        )
    assert "depth holes" in caplog.text
    assert series.depth_filled[1] >= 1 and series.valid.all()
    # filled from the other landmarks' depth + MediaPipe's relative z (exact here)
    np.testing.assert_allclose(series.keypoints[1, 4], kp[1, 4], atol=2e-3)


def test_depth_all_zero_or_nan_is_a_clear_error(rng: np.random.Generator) -> None:
    kp, frames = _scene(rng, 3)
    for k, f in enumerate(frames):
        f.depth_m[:] = np.nan if k % 2 else 0.0
    cfg = CaptureConfig(lift=LiftConfig(model="pinhole"))
    with pytest.raises(InvalidDemonstration, match="could not be lifted.*no valid depth"):
        track_source(ListSource(frames), capture=HandCapture(cfg, K, tracker=ScriptedTracker(kp)))


def test_missing_intrinsics_and_missing_depth_are_errors(rng: np.random.Generator) -> None:
    kp, _ = _scene(rng, 1)
    with pytest.raises(InvalidInput, match="needs camera intrinsics"):
        HandCapture(CaptureConfig(), None, tracker=ScriptedTracker(kp))
    with pytest.raises(InvalidInput, match="needs depth, but the source has none"):
        HandCapture(CaptureConfig(), K, tracker=ScriptedTracker(kp), has_depth=False)


def test_two_hands_choose_by_handedness_then_confidence(rng: np.random.Generator) -> None:
    kp, frames = _scene(rng, 4)
    cfg = CaptureConfig(lift=LiftConfig(model="pinhole", depth_patch_px=3))
    series = track_source(
        ListSource(frames), capture=HandCapture(cfg, K, tracker=ScriptedTracker(kp, True))
    )
    assert (series.handedness == 1).all() and (series.n_hands == 2).all()
    a = HandObservation(np.zeros((21, 2)), np.zeros(21), np.zeros((21, 3)), "right", 0.6)
    b = HandObservation(np.zeros((21, 2)), np.zeros(21), np.zeros((21, 3)), "right", 0.8)
    c = HandObservation(np.zeros((21, 2)), np.zeros(21), np.zeros((21, 3)), "left", 0.99)
    assert select_hand([a, b, c], "right") is b
    assert select_hand([a, b, c], "any") is c
    assert select_hand([a, c], "left") is c
    assert select_hand([a], "left") is a  # the preferred hand absent: best other one
    assert select_hand([], "right") is None
    with pytest.raises(InvalidInput, match="hand must be one of"):
        TrackerConfig(hand="both")


def test_the_series_carries_the_facts_later_stages_read_typed(
    rng: np.random.Generator,
) -> None:
    kp, frames = _scene(rng, 8)
    cfg = CaptureConfig(lift=LiftConfig(model="pinhole", depth_patch_px=3))
    cap = HandCapture(cfg, K, tracker=ScriptedTracker(kp))
    series = track_source(ListSource(frames), capture=cap, hand="auto")
    h, w = frames[0].rgb.shape[:2]
    assert series.fps == 30.0 and series.image_size == (w, h)
    assert series.hand_choice is not None and series.hand_choice.hand in ("left", "right")
    assert series.camera2base is not None
    np.testing.assert_array_equal(series.camera2base, np.eye(4))
    assert not {"fps", "image_size", "hand_choice"} & set(series.meta)  # provenance only
    assert series.meta["source"] == "scripted frames"
    demo = demonstration_from_capture(series, MotionConfig(max_gap_s=0.0))
    assert demo.capture is not None and demo.capture.fps == 30.0
    assert demo.capture.image_size == (w, h) and demo.capture.hand_choice == series.hand_choice
    assert demo.frame.startswith("camera")  # identity extrinsics: the camera frame, stated


def test_unseen_frames_and_online_equals_batch(rng: np.random.Generator) -> None:
    kp, frames = _scene(rng, 12)
    kp[5:7] = np.nan  # the tracker loses the hand for two frames
    cfg = CaptureConfig(lift=LiftConfig(model="pinhole", depth_patch_px=3))
    series = track_source(
        ListSource(frames), capture=HandCapture(cfg, K, tracker=ScriptedTracker(kp))
    )
    assert series.valid.tolist() == [i not in (5, 6) for i in range(12)]
    mcfg = MotionConfig(max_gap_s=0.0)
    demo = demonstration_from_capture(series, mcfg)
    assert np.isnan(demo.position[5:7]).all() and demo.meta["detection_rate"] == pytest.approx(
        10 / 12
    )
    assert demo.extras["confidence"].shape == (12,) and demo.extras["uv_px"].shape == (12, 21, 2)
    online = OnlineMotion(HandCapture(cfg, K, tracker=ScriptedTracker(kp)), mcfg)
    poses = [online.process(f) for f in frames]
    for i, pose in enumerate(poses):
        assert pose.valid == demo.valid[i]
        if pose.valid:
            np.testing.assert_allclose(pose.position, demo.position[i], atol=1e-12)
            np.testing.assert_allclose(pose.quaternion, demo.quaternion[i], atol=1e-12)
            assert pose.gripper == pytest.approx(demo.gripper[i], abs=1e-12)
            assert pose.grasp == demo.grasp[i]


class PixelTracker:
    """Returns fixed pixel landmarks per call (for the two-webcam rig)."""

    def __init__(self, uv: np.ndarray) -> None:
        self.uv, self.i = uv, 0

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        uv = self.uv[self.i]
        self.i += 1
        return [HandObservation(uv, np.zeros(21), np.zeros((21, 3)), "right", 0.9)]

    def close(self) -> None:
        pass


def test_two_webcam_rig_recovers_keypoints(rng: np.random.Generator) -> None:
    from dexlfd.capture import TwoWebcamModel, project_two_webcams

    m = TwoWebcamModel()
    n = 5
    p = np.column_stack([np.linspace(0.0, 0.1, n), np.full(n, 0.05), np.full(n, 0.45)])
    kp = hand_keypoints_from_pose(p, quat_from_euler(np.zeros((n, 3))), np.full(n, 0.05), rng)
    top, side = project_two_webcams(kp, m)
    img = np.zeros((480, 640, 3), np.uint8)
    frames = [Frame(i, i / 30, img, rgb2=img) for i in range(n)]
    cfg = CaptureConfig(lift=LiftConfig(model="two_webcams"))
    cap = HandCapture(cfg, None, PixelTracker(top), PixelTracker(side), has_depth=False)
    src = ListSource(frames)
    src.has_depth = False
    series = track_source(src, capture=cap)
    np.testing.assert_allclose(series.keypoints, kp, atol=1e-9)
    assert series.meta["two_webcams"]["H"] == 0.6
    # a single camera cannot feed the two-webcam model
    with pytest.raises(InvalidInput, match="pair of cameras"):
        HandCapture(cfg, None, PixelTracker(top), PixelTracker(side)).process(Frame(0, 0.0, img))


def test_online_one_euro_and_palm_equal_the_batch(rng: np.random.Generator) -> None:
    """Teleoperation's per-frame smoothing is the recording's, restarted after a gap alike."""
    kp, frames = _scene(rng, 12)
    kp[5:7] = np.nan
    cfg = CaptureConfig(lift=LiftConfig(model="pinhole", depth_patch_px=3))
    series = track_source(
        ListSource(frames), capture=HandCapture(cfg, K, tracker=ScriptedTracker(kp))
    )
    mcfg = MotionConfig(
        max_gap_s=0.0, smoothing="one_euro", euler_mode="palm", grasp_method="absolute"
    )
    demo = demonstration_from_capture(series, mcfg)
    raw = demonstration_from_capture(series, MotionConfig(max_gap_s=0.0, euler_mode="palm"))
    assert np.nanmax(np.abs(demo.position - raw.position)) > 1e-6  # it did smooth
    online = OnlineMotion(HandCapture(cfg, K, tracker=ScriptedTracker(kp)), mcfg)
    for i, pose in enumerate(online.process(f) for f in frames):
        assert pose.valid == demo.valid[i]
        if pose.valid:
            np.testing.assert_allclose(pose.position, demo.position[i], atol=1e-12)
            np.testing.assert_allclose(pose.quaternion, demo.quaternion[i], atol=1e-12)
            assert pose.grasp == demo.grasp[i]
