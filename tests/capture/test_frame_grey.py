"""The shared small grey copies give the pixel cues exactly what their own resizes gave,
and the tap's background motion, measured on a worker thread, is the one measured in line."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from dexlfd.capture.camera_motion import CameraMotionEstimator
from dexlfd.capture.carry_cue import CarryCue
from dexlfd.capture.frame_grey import FrameGrey, linear_shrink
from dexlfd.capture.landmark_source import TrackerTap
from dexlfd.capture.tracking import HandObservation

SIZES = [  # (frame w, h) -> (shrunk w, h): odd factors, an even one, not whole ones
    ((1920, 1080), (640, 360)),
    ((1500, 900), (300, 180)),
    ((1280, 720), (640, 360)),
    ((641, 361), (320, 180)),
    ((1000, 563), (640, 360)),
]


@pytest.mark.parametrize(("size", "small"), SIZES)
@pytest.mark.parametrize("channels", [1, 3])
def test_linear_shrink_is_opencvs_linear_resize(size, small, channels) -> None:
    rng = np.random.default_rng(0)
    w, h = size
    img = rng.integers(0, 256, (h, w, channels)[: 3 if channels == 3 else 2], dtype=np.uint8)
    want = cv2.resize(img, small, interpolation=cv2.INTER_LINEAR)
    got = linear_shrink(img, small)
    assert got.shape == want.shape
    np.testing.assert_array_equal(got, want)


def test_each_grey_size_is_made_once_per_frame() -> None:
    rgb = np.random.default_rng(1).integers(0, 256, (1080, 1920, 3), dtype=np.uint8)
    frame = FrameGrey(rgb)
    grey = frame.linear((640, 360))
    assert frame.linear((640, 360)) is grey
    want = cv2.cvtColor(cv2.resize(rgb, (640, 360), interpolation=cv2.INTER_LINEAR),
                        cv2.COLOR_RGB2GRAY)  # fmt: skip
    np.testing.assert_array_equal(grey, want)
    np.testing.assert_array_equal(frame.linear((1920, 1080)), cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))


@pytest.mark.parametrize("size", [s for s, _ in SIZES] + [(640, 480), (300, 200)])
def test_the_cues_read_the_grey_copies_they_made_themselves(size) -> None:
    """Carry cue: ``resize(fx=fy=scale)`` then grey; camera motion: linear, grey, area."""
    w, h = size
    rgb = np.random.default_rng(2).integers(0, 256, (h, w, 3), dtype=np.uint8)
    frame = FrameGrey(rgb)
    cue = CarryCue()
    s = min(1.0, cue.cfg.width_px / float(w))
    small = rgb if s == 1.0 else cv2.resize(rgb, None, fx=s, fy=s)
    got, scale = cue._grey(frame)
    assert scale == s
    np.testing.assert_array_equal(got, cv2.cvtColor(small, cv2.COLOR_RGB2GRAY))

    est = CameraMotionEstimator()
    s = est.cfg.width_px / w if w > est.cfg.width_px else 1.0
    aw, ah = max(1, round(w * s)), max(1, round(h * s))
    img = cv2.resize(rgb, (2 * aw, 2 * ah), interpolation=cv2.INTER_LINEAR) if w > 2 * aw else rgb
    want = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    if s != 1.0:
        want = cv2.resize(want, (aw, ah), interpolation=cv2.INTER_AREA)
    got, scale = est.analysis_grey(frame)
    assert scale == s
    np.testing.assert_array_equal(got, want)


class _Still:
    """A tracker that reports one hand at a fixed place in every frame."""

    def __init__(self) -> None:
        uv = np.array([[300.0 + 5 * (j % 5), 200.0 + 6 * (j // 5)] for j in range(21)])
        self.hand = HandObservation(uv, np.zeros(21), np.zeros((21, 3)), "right", 1.0)
        self.closed = False

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        return [self.hand]

    def close(self) -> None:
        self.closed = True


def _panning(n: int) -> list[np.ndarray]:
    rng = np.random.default_rng(3)
    big = cv2.resize(rng.integers(0, 256, (90, 120, 3), dtype=np.uint8), (960, 720),
                     interpolation=cv2.INTER_CUBIC)  # fmt: skip
    return [np.ascontiguousarray(big[100:580, 40 + 3 * i : 680 + 3 * i]) for i in range(n)]


def test_the_taps_background_motion_is_the_one_measured_in_line() -> None:
    frames = _panning(20)
    inner = _Still()
    tap = TrackerTap(inner, motion=CameraMotionEstimator(), cue=CarryCue())
    for i, rgb in enumerate(frames):
        tap.detect(rgb, i / 30.0)
    tap.close()
    alone = CameraMotionEstimator()
    for rgb in frames:
        alone.update(rgb, [inner.hand.uv_px])
    assert inner.closed
    np.testing.assert_array_equal(tap.motion.motion, alone.motion)
    assert np.nanmedian(alone.motion[1:, 0]) == pytest.approx(-3.0, abs=0.3)  # it measured


def test_an_error_of_the_background_motion_is_raised_not_lost() -> None:
    class Broken(CameraMotionEstimator):
        def update_grey(self, *args: object) -> None:
            raise RuntimeError("measurement failed")

    tap = TrackerTap(_Still(), motion=Broken())
    tap.detect(_panning(1)[0], 0.0)
    with pytest.raises(RuntimeError, match="measurement failed"):
        tap.close()
    assert tap.inner.closed  # type: ignore[attr-defined]
