"""The real hand video in ../shared/data (621 frames, 1280x720, one right hand, pinches).

It is tracked once per session at 640x360 (FACTS: same accuracy, half the time).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.capture import CaptureConfig, LiftConfig, TrackerConfig, open_source, track_source
from dexlfd.io import Demonstration
from dexlfd.motion import MotionConfig, demonstration_from_capture

_CACHE: dict[Path, Demonstration] = {}
_SERIES: dict[Path, object] = {}


def _processed(path: Path) -> Demonstration:
    if path not in _CACHE:
        cfg = CaptureConfig(lift=LiftConfig(model="assumed_depth"))
        with open_source(path, resize_width=640) as src:
            series = track_source(src, cfg)
        _SERIES[path] = series
        # record's motion settings (One Euro smoothing, palm orientation, adaptive grasp)
        mcfg = MotionConfig(hand=series.majority_hand, smoothing="one_euro", euler_mode="palm")
        _CACHE[path] = demonstration_from_capture(series, mcfg)
    return _CACHE[path]


def test_detects_the_hand_in_almost_every_frame(hand_video: Path) -> None:
    demo = _processed(hand_video)
    assert demo.n_samples == 621
    assert demo.extras["detected"].mean() >= 0.95
    # a right hand (the legacy API's mirrored "Left" label corrected)
    assert (demo.extras["handedness"][demo.valid] == 1).mean() > 0.95
    assert demo.meta["capture"]["depth"] == "approximate"
    np.testing.assert_allclose(np.diff(demo.t), 1 / 30, atol=1e-9)


def test_landmark_trajectories_are_continuous(hand_video: Path) -> None:
    demo = _processed(hand_video)
    uv = demo.extras["uv_px"]
    palm = np.linalg.norm(uv[:, 9] - uv[:, 0], axis=1)  # wrist to middle-finger MCP [px]
    step = np.linalg.norm(np.diff(uv, axis=0), axis=2) / palm[1:, None]
    # Bounds in palm lengths per frame (30 fps). The wrist is carried by the arm: 0.25 palm
    # lengths/frame is ~0.7 m/s for a 9 cm palm, above this video's motion (max ~0.17).
    # A fingertip can sweep about one finger length (~ one palm length) in a fast curl; a
    # tracking failure (landmark swap, jump to another object) moves points by several palm
    # lengths, and a spread of several frames would show up in the 99th percentile.
    assert step[:, 0].max() < 0.25
    assert step.max() < 1.2
    assert np.percentile(step, 99) < 0.35
    # metric keypoints (assumed wrist depth 0.5 m): the wrist moves < 5 cm per frame
    assert np.nanmax(np.linalg.norm(np.diff(demo.position, axis=0), axis=1)) < 0.05


def test_pinch_is_visible_in_the_gripper_channel(hand_video: Path) -> None:
    g = _processed(hand_video).gripper
    assert np.nanmin(g) < 0.03 and np.nanmax(g) > 0.1  # closed pinch and open hand
    # count pinch episodes: below 3.5 cm, separated by re-opening above 7 cm
    episodes, closed = 0, False
    for x in g[np.isfinite(g)]:
        if not closed and x < 0.035:
            episodes, closed = episodes + 1, True
        elif closed and x > 0.07:
            closed = False
    assert episodes >= 2


def test_two_hands_in_view_follow_the_preferred_one(hand_video: Path) -> None:
    with open_source(hand_video, max_frames=1, resize_width=640) as src:
        frame = next(iter(src))
    both = np.concatenate([frame.rgb, frame.rgb[:, ::-1]], axis=1)  # right hand | its mirror
    w = frame.rgb.shape[1]
    from dexlfd.capture import select_hand
    from dexlfd.capture.tracking import make_tracker

    with make_tracker(TrackerConfig(static_image_mode=True, max_num_hands=2)) as tracker:
        hands = tracker.detect(both, 0.0)
    assert sorted(h.handedness for h in hands) == ["left", "right"]
    right, left = select_hand(hands, "right"), select_hand(hands, "left")
    assert right is not None and left is not None
    assert right.uv_px[0, 0] < w < left.uv_px[0, 0]  # original hand on the left half
    # the mirror image's landmarks are the original's mirrored (same network, flipped input)
    np.testing.assert_allclose(left.uv_px[:, 0], 2 * w - right.uv_px[:, 0], atol=6.0)


# The person's annotation in ../shared/data/README.md (15-frame resolution), as frame ranges.
ANNOTATED_OPEN = [(0, 10), (45, 50), (135, 150), (180, 200), (285, 315), (390, 410), (480, 510),
                  (585, 600)]  # fmt: skip
ANNOTATED_CLOSED = [(15, 30), (360, 375), (465, 465), (255, 270), (615, 620)]  # pinches, fists
# Two annotated ranges disagree with the frames themselves (checked by eye on crops of every
# 5th frame, with MediaPipe's landmarks drawn): in 15-30 the thumb is folded across the palm
# onto the base of the little finger (no thumb-index contact; the thumb-index distance equals
# the open hand's), and in 308-315 the index tip already touches the thumb tip (the clear
# thumb-index pinch of this video is 310-330). They are left out of the accuracy below.
ANNOTATION_DISPUTED = set(range(15, 31)) | set(range(308, 316))


def _annotated(ranges: list[tuple[int, int]]) -> np.ndarray:
    return np.array(sorted({i for a, b in ranges for i in range(a, b + 1)}))


def test_grasp_matches_the_annotation_of_the_real_video(hand_video: Path) -> None:
    demo = _processed(hand_video)
    assert demo.meta["grasp"]["method"] == "adaptive"
    grasp = demo.grasp
    opened = np.setdiff1d(_annotated(ANNOTATED_OPEN), list(ANNOTATION_DISPUTED))
    closed = np.setdiff1d(_annotated(ANNOTATED_CLOSED), list(ANNOTATION_DISPUTED))
    right = np.r_[~grasp[opened], grasp[closed]]
    assert right.mean() >= 0.95, (opened[grasp[opened]], closed[~grasp[closed]])
    # the fists and the thumb-index pinch (by eye: 315-330) are closed in every frame
    assert grasp[np.r_[255:271, 615:621, 315:331]].all()
    # the wide-open hand at the start, middle and end is open in every frame
    assert not grasp[np.r_[0:11, 135:151, 285:301, 585:601]].any()
    # the thesis's absolute 0.10 m calls the open hand a grasp
    from dexlfd.motion import GraspConfig, detect_grasp

    thesis = detect_grasp(demo.t, demo.gripper, demo.extras["aperture_ratio"],
                          GraspConfig(method="absolute"))  # fmt: skip
    assert thesis.grasp[opened].mean() > 0.5


def test_the_closure_never_closes_the_open_hand_and_finds_no_pick_and_place(
    hand_video: Path,
) -> None:
    """Record's grasp (closure + phases): the open hand is never closed, the fists are, and
    a hand making fists and pinches in place (nothing carried) has no grasp at all."""
    from dexlfd.motion import track_phases

    _processed(hand_video)
    series = _SERIES[hand_video]
    phases, res = track_phases(series.t, series.keypoints, series.valid, uv_px=series.uv_px)
    opened = np.setdiff1d(_annotated(ANNOTATED_OPEN), list(ANNOTATION_DISPUTED))
    assert not res.grasp[opened].any()
    assert res.grasp[np.r_[255:271, 615:621, 318:331]].all()  # fists, the clear pinch
    assert phases.episodes == [] and not phases.grasp.any()
    mcfg = MotionConfig(hand=series.majority_hand, grasp_method="closure")
    demo = demonstration_from_capture(series, mcfg)
    assert not demo.grasp.any() and demo.phases.n_pick_and_place == 0


def _steps_deg(q: np.ndarray) -> np.ndarray:
    return np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(q[1:] * q[:-1], axis=1)), 0, 1)))


def test_palm_orientation_has_no_flips_on_the_real_video(hand_video: Path) -> None:
    """The hand barely turns except when it swings sideways (~510-570, ~100 deg over
    ~20 frames): the palm frame's largest frame-to-frame step stays below 30 deg while
    the thumb/index-based Eq. (4.11) angles jump by ~180 deg when the fingers move."""
    from dexlfd.motion import pose_from_keypoints
    from dexlfd.rotations import matrix_from_quat

    demo = _processed(hand_video)
    kp = demo.keypoints
    palm = pose_from_keypoints(kp, "right", "identity", "palm")
    steps = _steps_deg(palm.quaternion)
    assert steps.max() < 30 and np.percentile(steps, 99) < 20
    heading = pose_from_keypoints(kp, "right", "identity", "heading")
    assert _steps_deg(heading.quaternion).max() > 90  # the flips this mode fixes
    # quaternions sign-continuous (no q -> -q jump) and the motion stays small while the
    # hand faces the camera (first 500 frames: within 60 deg of the first frame)
    q = palm.quaternion
    assert (np.sum(q[1:] * q[:-1], axis=1) > 0).all()
    R = matrix_from_quat(q)
    ang = np.degrees(np.arccos(np.clip((np.einsum("nij,ij->n", R, R[0]) - 1) / 2, -1, 1)))
    assert ang[:500].max() < 60 and ang[540:570].max() > 80  # ... and it does turn there
