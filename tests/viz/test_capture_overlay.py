"""Overlay labels readable at any size, the recorded hand and its grasp marked, the
3-D view holding the whole wrist path."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dexlfd.io.demonstration_facts import Capture, HandChoice
from dexlfd.motion import MotionConfig, demonstration_from_keypoints
from dexlfd.viz import capture as vc

from ..motion.test_smoothing_trim_quality import _pick_place


@pytest.mark.parametrize("shape", [(120, 120, 3), (360, 640, 3), (720, 1280, 3)])
def test_label_height_scales_with_the_frame(shape: tuple[int, int, int]) -> None:
    img = np.zeros(shape, np.uint8)
    vc.put_label(img, ("seen: right 0.99", "R 0.99"), 0)
    rows = np.flatnonzero(img.any(axis=(1, 2)))
    band = rows.max() + 1  # the dark band is black: text pixels mark its height
    assert 0.03 < band / shape[0] < 0.12  # about 1/24 of the height, never half the frame
    assert not img[:, -1].any() or shape[1] > 200  # fits the width of a 120-px frame


def _demo():
    t, kp = _pick_place(np.random.default_rng(0))
    uv = 100 + 200 * kp[..., :2]  # pixels of a 320x240 frame
    demo = demonstration_from_keypoints(t, kp, cfg=MotionConfig(smoothing="none"))
    choice = HandChoice(hand="right", reason="made here", track=3)
    cap = Capture(image_size=(320, 240), hand_choice=choice)
    return replace(demo, extras={**demo.extras, "uv_px": uv}, capture=cap)


def test_annotate_marks_the_recorded_hand_and_its_grasp(tmp_path: Path) -> None:
    import cv2

    demo = _demo()
    path = tmp_path / "ov.mp4"
    with vc.OverlayWriter(path, 30.0) as ov:
        for _ in range(demo.n_samples):
            ov.write(np.full((240, 320, 3), 128, np.uint8), None)
    vc.annotate_overlay(path, demo)
    cap = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        frames.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB).astype(int))
    assert len(frames) == demo.n_samples and not list(tmp_path.glob(".ov.mp4*"))
    closed, opened = np.flatnonzero(demo.grasp)[5], np.flatnonzero(~demo.grasp)[5]
    yellow = [(np.abs(f - (255, 220, 0)).sum(axis=2) < 90).sum() for f in frames]
    assert min(yellow) > 50  # skeleton and label in yellow on every frame
    band = slice(8, 40)  # the second label line: differs between CLOSED and open
    assert np.abs(frames[closed][band] - frames[opened][band]).mean() > 1.0
    assert np.abs(frames[opened][band] - frames[opened + 1][band]).mean() < 1.0


def test_hand_3d_axes_hold_the_whole_wrist_path(tmp_path: Path, monkeypatch) -> None:
    demo = _demo()
    shift = np.linspace(0, 1.5, demo.n_samples)[:, None] * (1.0, 0.5, 0.2)  # 1.6 m path
    demo = replace(demo, position=demo.position + shift)
    figs = []
    monkeypatch.setattr(vc, "_save", lambda fig, path: figs.append(fig) or path)
    vc.plot_hand_3d(demo, tmp_path / "h.png", 0)
    ax = figs[0].axes[0]
    p = demo.position[demo.valid]
    for k, lim in enumerate((ax.get_xlim(), ax.get_ylim(), ax.get_zlim())):
        assert lim[0] <= p[:, k].min() and p[:, k].max() <= lim[1]


def test_overlay_is_h264_a_browser_plays(tmp_path: Path) -> None:
    """Tracking overlay and its annotation both go through the one H.264 writer."""
    pytest.importorskip("imageio_ffmpeg", reason="the video extra (H.264) is not installed")
    from dexlfd.io.video import browser_playable, video_codec

    demo = _demo()
    path = tmp_path / "ov.mp4"
    with vc.OverlayWriter(path, 30.0) as ov:
        for _ in range(demo.n_samples):
            ov.write(np.full((120, 161, 3), 90, np.uint8), None)  # odd width: padded
    assert browser_playable(path), video_codec(path)
    vc.annotate_overlay(path, demo)
    assert browser_playable(path), video_codec(path)
    assert [p.name for p in tmp_path.iterdir()] == ["ov.mp4"]
