"""Measuring every other frame: the same background path as measuring every frame."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.capture.camera_motion import (
    CameraMotionConfig,
    CameraMotionEstimator,
    camera_motion_report,
)
from dexlfd.errors import InvalidInput

from .test_camera_motion import _shifted, _texture


def _both(frames: list[np.ndarray], hands: list[list[np.ndarray]], **cfg: int) -> list:
    """Rows and optical-flow measurements, measuring every frame and holding frames."""
    out = []
    for every in (1, 2):
        est = CameraMotionEstimator(CameraMotionConfig(measure_every=every, **cfg))
        calls = []
        measure = est._measure

        def counted(*args: object, _m=measure, _c=calls) -> object:
            _c.append(1)
            return _m(*args)

        est._measure = counted  # type: ignore[method-assign]
        for img, hs in zip(frames, hands, strict=True):
            est.update(img, hs)
        out += [est.motion, len(calls)]
    return out


def test_a_drifting_camera_is_measured_every_other_frame_on_the_same_path() -> None:
    """0.1 analysis px a frame: held frames get half of each pair's change."""
    big = _texture(720, 960, seed=3)
    n = 22  # the last frame is held: measured when the rows are read
    frames = [_shifted(big, 0.2 * i, -0.1 * i, (640, 480)) for i in range(n)]
    every, n_every, other, n_other = _both(frames, [[]] * n, key_every=1000)
    assert every.shape == other.shape == (n, 4)
    assert np.isnan(other[0]).all() and np.isfinite(other[1:]).all()
    assert n_every == n - 1 and n_other <= n // 2 + 2
    # frames 1-2 read still (each corner moved < static_px), frames 3-4 jump from it
    # (measured one by one); from frame 5 on, pairs
    np.testing.assert_array_equal(other[:5], every[:5])
    pairs = (every[5:-1:2] + every[6:-1:2]) / 2
    np.testing.assert_allclose(other[5:-1:2], pairs, rtol=0, atol=1e-9)
    np.testing.assert_allclose(other[6:-1:2], pairs, rtol=0, atol=1e-9)
    # frames 2, 4, ... and the last are measured from the keyframe: the same path there
    path_every, path_other = np.cumsum(every[1:], axis=0), np.cumsum(other[1:], axis=0)
    np.testing.assert_allclose(path_other[1::2], path_every[1::2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(path_other[-1], path_every[-1], rtol=0, atol=1e-9)


def test_a_panning_and_zooming_camera_is_measured_on_every_frame() -> None:
    """More than ``pair_px`` over two frames: every frame measured, the same rows."""
    big = _texture(720, 960, seed=4)
    n = 21
    frames = [_shifted(big, 2.5 * i, -1.0 * i, (640, 480), zoom=1.003**i) for i in range(n)]
    every, n_every, other, n_other = _both(frames, [[]] * n)
    np.testing.assert_array_equal(other, every)
    # each second frame's measurement kept; one more where the keyframe was renewed
    assert n_other <= n_every + 1


@pytest.mark.parametrize("n", [30, 31])
def test_a_pan_reads_the_same_with_keyframes_renewed(n: int) -> None:
    big = _texture(720, 960, seed=5)
    frames = [_shifted(big, 3.0 * i, 0.0, (640, 480)) for i in range(n)]
    every, _, other, _ = _both(frames, [[]] * n)
    rep_every = camera_motion_report(every, (640, 480))
    rep_other = camera_motion_report(other, (640, 480))
    assert rep_every["moving"] and rep_other["moving"]
    assert rep_other["shift_extent"] == pytest.approx(rep_every["shift_extent"], abs=0.3 / 640)
    assert rep_other["moving_frames"] == rep_every["moving_frames"]
    assert rep_other["frames_measured"] == rep_every["frames_measured"]


def test_a_still_camera_with_a_moving_hand_reads_still_either_way() -> None:
    """A textured blob (a hand, its box given) sweeps over a still, noisy background."""
    import cv2

    rng = np.random.default_rng(8)
    background = _texture(480, 640, seed=9)
    frames, hands = [], []
    for i in range(40):
        img = background.copy()
        x0, y0 = 80 + 10 * i, 140
        patch = rng.integers(0, 256, (20, 20, 3), dtype=np.uint8)
        img[y0 : y0 + 160, x0 : x0 + 160] = cv2.resize(patch, (160, 160))
        noise = rng.integers(-3, 4, img.shape)
        frames.append(np.clip(img.astype(np.int16) + noise, 0, 255).astype(np.uint8))
        hands.append([np.array([[x0 + 40.0, y0 + 40.0], [x0 + 120.0, y0 + 120.0]])])
    every, n_every, other, n_other = _both(frames, hands)
    assert n_other < 0.6 * n_every
    for m in (every, other):
        rep = camera_motion_report(m, (640, 480))
        assert rep["checked"] and rep["moving"] is False and rep["moving_frames"] == []
        assert rep["shift_extent"] < 0.002 and rep["rotation_extent_deg"] < 0.1
    np.testing.assert_allclose(np.cumsum(other[1:], axis=0), np.cumsum(every[1:], axis=0), atol=0.3)


def test_a_change_of_frame_size_measures_the_held_frame_first() -> None:
    big = _texture(720, 960, seed=2)
    est = CameraMotionEstimator()
    for i in range(4):  # frames 0..3: frame 3 is held
        est.update(_shifted(big, 2.0 * i, 0.0, (640, 480)), [])
    est.update(_shifted(big, 0.0, 0.0, (320, 240)), [])  # another size: a new keyframe
    m = est.motion
    assert m.shape == (5, 4)
    np.testing.assert_allclose(m[1:4, 0], -2.0, atol=0.2)
    assert np.isnan(m[0]).all() and np.isnan(m[4]).all()


def test_only_every_frame_or_every_other_frame() -> None:
    with pytest.raises(InvalidInput, match="measure_every"):
        CameraMotionConfig(measure_every=3)
