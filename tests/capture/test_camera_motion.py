"""A moving camera is found from the background; moving hands or blobs are not camera motion."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture.camera_motion import (
    CameraMotionEstimator,
    camera_motion_report,
)


def _texture(h: int, w: int, seed: int = 0) -> np.ndarray:
    """A smooth random texture (corners everywhere), RGB uint8."""
    import cv2

    rng = np.random.default_rng(seed)
    small = rng.integers(0, 256, (h // 8, w // 8, 3), dtype=np.uint8)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)


def _shifted(big: np.ndarray, x: float, y: float, size: tuple[int, int], zoom: float = 1.0):
    """The ``size`` window of ``big`` centred at its centre + (x, y), zoomed by ``zoom``."""
    import cv2

    w, h = size
    H, W = big.shape[:2]
    cx, cy = W / 2 + x, H / 2 + y
    # output pixel p shows big at c + (p - centre) / zoom
    A = np.array([[1 / zoom, 0, cx - w / 2 / zoom], [0, 1 / zoom, cy - h / 2 / zoom]])
    return cv2.warpAffine(
        big, A, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REFLECT
    )


def test_a_panning_camera_is_measured_and_flagged() -> None:
    big = _texture(720, 960)
    est = CameraMotionEstimator()
    n, step = 30, 3.0  # the view moves 3 px right per frame: the background moves left
    for i in range(n):
        est.update(_shifted(big, step * i, 0.0, (640, 480)), [])
    m = est.motion
    assert m.shape == (n, 4) and np.isnan(m[0]).all()
    np.testing.assert_allclose(m[1:, 0], -step, atol=0.15)
    np.testing.assert_allclose(m[1:, 1], 0.0, atol=0.15)
    np.testing.assert_allclose(m[1:, 2:], 0.0, atol=2e-3)
    rep = camera_motion_report(m, (640, 480))
    assert rep["checked"] and rep["moving"]
    assert rep["shift_extent"] == pytest.approx(step * (n - 1) / 640, rel=0.05)
    assert rep["moving_frames"] and rep["moving_frames"][0][1] >= n - 3


def test_a_zooming_camera_is_flagged() -> None:
    big = _texture(720, 960, seed=1)
    est = CameraMotionEstimator()
    n, rate = 25, 1.004
    for i in range(n):
        est.update(_shifted(big, 0.0, 0.0, (640, 480), zoom=rate**i), [])
    m = est.motion
    np.testing.assert_allclose(m[1:, 2], math.log(rate), atol=1e-3)
    np.testing.assert_allclose(m[1:, :2], 0.0, atol=0.3)  # about the image centre
    rep = camera_motion_report(m, (640, 480))
    assert rep["moving"] and rep["zoom_extent"] == pytest.approx((n - 1) * math.log(rate), rel=0.1)


def test_a_still_background_with_a_moving_blob_is_not_camera_motion() -> None:
    import cv2

    rng = np.random.default_rng(4)
    background = _texture(480, 640, seed=2)
    est = CameraMotionEstimator()
    n = 30
    for i in range(n):
        img = background.copy()
        # a textured blob (a hand with its object) sweeping across a third of the picture
        x0, y0 = 100 + 12 * i, 150
        patch = rng.integers(0, 256, (20, 20, 3), dtype=np.uint8)
        img[y0 : y0 + 160, x0 : x0 + 160] = cv2.resize(patch, (160, 160))
        hand = np.column_stack(
            [rng.uniform(x0 + 40, x0 + 120, 21), rng.uniform(y0 + 40, y0 + 120, 21)]
        )
        img = np.clip(img.astype(np.int16) + rng.integers(-3, 4, img.shape), 0, 255).astype(
            np.uint8
        )
        est.update(img, [hand])
    m = est.motion
    assert np.isfinite(m[1:]).all()
    assert np.abs(m[1:, :2]).max() < 0.3 and np.abs(m[1:, 2:]).max() < 1e-3
    rep = camera_motion_report(m, (640, 480))
    assert rep["checked"] and not rep["moving"] and rep["moving_frames"] == []


def test_a_blank_picture_cannot_be_measured_and_is_not_a_motion() -> None:
    est = CameraMotionEstimator()
    for _ in range(5):
        est.update(np.zeros((120, 160, 3), np.uint8), [])
    assert np.isnan(est.motion).all()
    rep = camera_motion_report(est.motion, (160, 120))
    assert rep["checked"] and rep["moving"] is None and rep["frames_measured"] == 0.0
    assert camera_motion_report(None, (160, 120)) == {"checked": False, "moving": None}


def test_record_stores_the_camera_motion_and_replay_reads_it(tmp_path: Path, capsys) -> None:
    """A still camera on the packaged real video: measured, stored per frame, not moving."""
    from dexlfd.capture.landmark_recording import load_landmark_recording
    from dexlfd.cli import main
    from dexlfd.data import hand_video
    from dexlfd.io import load_demonstration

    lms, a, b = tmp_path / "L.npz", tmp_path / "a.npz", tmp_path / "b.npz"
    argv = ["record", str(hand_video()), "-o", str(a), "--save-landmarks", str(lms)]
    assert main([*argv, "--max-frames", "40", "--max-hands", "1", "--no-trim"]) == 0
    demo = load_demonstration(a)
    cam = demo.meta["capture"]["camera_motion"]
    assert cam["checked"] and cam["moving"] is False and cam["frames_measured"] > 0.9
    assert demo.extras["camera_motion"].shape == (40, 4)
    rec = load_landmark_recording(lms)
    np.testing.assert_array_equal(rec.camera_motion, demo.extras["camera_motion"])
    capsys.readouterr()
    assert main(["record", str(lms), "-o", str(b), "--no-trim"]) == 0
    assert "camera motion cannot be checked" not in capsys.readouterr().err
    assert load_demonstration(b).meta["capture"]["camera_motion"] == cam


def test_an_arm_passing_in_front_of_a_still_camera_is_not_camera_motion() -> None:
    """A big unmasked textured band (an arm, the hand out of view) crosses and leaves."""
    background = _texture(240, 320, seed=6)
    arm = _texture(240, 320, seed=7)
    est = CameraMotionEstimator()
    n = 60
    for i in range(n):
        img = background.copy()
        if 15 <= i < 30:  # the arm covers 60 % of the picture, sliding 6 px a frame
            x = 6 * (i - 15)
            img[:, :190] = np.roll(arm, x, axis=1)[:, :190]
        est.update(img, [])
    rep = camera_motion_report(est.motion, (320, 240))
    assert rep["checked"] and not rep["moving"], rep


def test_record_warns_when_the_camera_pans(tmp_path: Path, capsys) -> None:
    """The packaged real video, cropped by a window sliding 2 px a frame: a panning camera."""
    import cv2

    from dexlfd.cli import main
    from dexlfd.data import hand_video
    from dexlfd.io import load_demonstration

    cap = cv2.VideoCapture(str(hand_video()))
    video = tmp_path / "pan.mp4"
    vw = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"mp4v"), 30.0, (640, 360))
    for i in range(40):
        ok, bgr = cap.read()
        assert ok
        x = 2 * i  # the view slides right: the background moves left
        vw.write(cv2.resize(bgr[0:675, x : x + 1200], (640, 360), interpolation=cv2.INTER_AREA))
    cap.release()
    vw.release()
    out = tmp_path / "d.npz"
    assert main(["record", str(video), "-o", str(out), "--max-hands", "1", "--no-trim"]) == 0
    err = capsys.readouterr().err
    assert "CAMERA MOVES" in err
    cam = load_demonstration(out).meta["capture"]["camera_motion"]
    assert cam["moving"] and cam["shift_extent"] == pytest.approx(39 * 2 / 1200, rel=0.2)
    assert cam["moving_frames"] and cam["moving_frames"][0][0] <= 5
