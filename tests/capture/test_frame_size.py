"""The angle and two-webcam models use each frame's real size, not 640x480."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.capture import (
    AngleModel,
    CaptureConfig,
    Frame,
    HandCapture,
    HandObservation,
    LiftConfig,
    LiftInput,
    TwoWebcamModel,
    lift,
    lift_two_webcams,
    project_two_webcams,
)


class FixedTracker:
    """Returns the same pixel landmarks on every call."""

    def __init__(self, uv: np.ndarray) -> None:
        self.uv = uv

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        return [HandObservation(self.uv, np.zeros(21), np.zeros((21, 3)), "right", 0.9)]

    def close(self) -> None:
        pass


@pytest.mark.parametrize("size", [(1280, 720), (320, 240), (1920, 1080)])
def test_the_centre_pixel_lifts_onto_the_optical_axis_at_any_size(size: tuple[int, int]) -> None:
    w, h = size
    uv = np.tile([w / 2, h / 2], (21, 1))  # the image centre (corner convention)
    depth = np.full((h, w), 1.0, np.float32)
    cap = HandCapture(
        CaptureConfig(lift=LiftConfig(model="angle")), None, FixedTracker(uv), has_depth=True
    )
    kp = cap.process(Frame(0, 0.0, np.zeros((h, w, 3), np.uint8), depth_m=depth))
    np.testing.assert_allclose(kp.keypoints, np.tile([0.0, 0.0, 1.0], (21, 1)), atol=1e-12)
    assert (
        cap.describe()["angle_model"]["width_px"],
        cap.describe()["angle_model"]["height_px"],
    ) == (
        w,
        h,
    )
    # the image's right edge is half the field of view off the axis, at any size
    edge = lift(LiftInput(np.array([[w, h / 2]]), np.ones(1), size_px=size), LiftConfig("angle"))
    assert edge[0, 0] == pytest.approx(np.tan(np.radians(AngleModel().fov_x_deg / 2)))


def test_the_angle_model_at_two_sizes_gives_the_same_point() -> None:
    rng = np.random.default_rng(3)
    frac = rng.uniform(0.1, 0.9, (21, 2))  # the same place in the picture
    d = rng.uniform(0.4, 1.5, 21)
    small = lift(LiftInput(frac * [640, 480], d, size_px=(640, 480)), LiftConfig("angle"))
    large = lift(LiftInput(frac * [1920, 1080], d, size_px=(1920, 1080)), LiftConfig("angle"))
    np.testing.assert_allclose(large, small, atol=1e-12)


@pytest.mark.parametrize("size", [(640, 480), (120, 120), (1280, 720)])
def test_two_webcam_rig_at_any_size(size: tuple[int, int]) -> None:
    rng = np.random.default_rng(5)
    P = np.column_stack(
        [rng.uniform(-0.1, 0.1, 21), rng.uniform(-0.05, 0.1, 21), rng.uniform(0.3, 0.5, 21)]
    )
    m = TwoWebcamModel().at_size(*size)
    top, side = project_two_webcams(P, m)
    np.testing.assert_allclose(lift_two_webcams(top, side, m), P, atol=1e-9)
    # the same points seen at the thesis's 640x480 sit at the same fractions of the image
    top0, side0 = project_two_webcams(P, TwoWebcamModel())
    scale = np.array([size[0] / 640, size[1] / 480])
    np.testing.assert_allclose(top, top0 * scale, atol=1e-9)
    np.testing.assert_allclose(side, side0 * scale, atol=1e-9)
    got = lift(LiftInput(top, uv2_px=side, size_px=size), LiftConfig("two_webcams"))
    np.testing.assert_allclose(got, P, atol=1e-9)


def test_two_webcam_capture_with_a_side_image_of_another_size() -> None:
    """Top 1280x720 and side 640x360: the side pixels are read as fractions of its image."""
    rng = np.random.default_rng(8)
    P = np.column_stack(
        [rng.uniform(-0.1, 0.1, 21), rng.uniform(-0.05, 0.1, 21), rng.uniform(0.3, 0.5, 21)]
    )
    top, side = project_two_webcams(P, TwoWebcamModel().at_size(1280, 720))
    cfg = CaptureConfig(lift=LiftConfig(model="two_webcams"))
    cap = HandCapture(cfg, None, FixedTracker(top), FixedTracker(side / 2), has_depth=False)
    frame = Frame(
        0, 0.0, np.zeros((720, 1280, 3), np.uint8), rgb2=np.zeros((360, 640, 3), np.uint8)
    )
    res = cap.process(frame)
    assert res.valid
    np.testing.assert_allclose(res.keypoints, P, atol=1e-9)
    assert cap.describe()["two_webcams"]["x_origin_px"] == pytest.approx(520.0 * 2)
