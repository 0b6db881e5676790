"""RealSense playback on recordings made here with the SDK's software device (no camera)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture import (
    CaptureConfig,
    LiftConfig,
    RealSenseRecording,
    deproject_pinhole,
    open_source,
    track_source,
)
from dexlfd.cli import main
from dexlfd.io import load_demonstration

rs = pytest.importorskip(
    "pyrealsense2",
    reason="pyrealsense2 not installed (optional: pip install pyrealsense2==2.59.1.11053 "
    "and apt-get install libusb-1.0-0)",
)

FX = 320.0  # focal length of the recorded streams [px]


def _intrinsics(w: int, h: int) -> object:
    i = rs.intrinsics()
    i.width, i.height, i.fx, i.fy = w, h, FX, FX
    i.ppx, i.ppy = (w - 1) / 2, (h - 1) / 2
    i.model = rs.distortion.none
    i.coeffs = [0.0] * 5
    return i


def record_rgbd(path: Path, colors: list[np.ndarray], depths_mm: list[np.ndarray]) -> Path:
    """Write a RealSense recording (colour rgb8 + depth z16, 1 mm units) from arrays."""
    h, w = depths_mm[0].shape
    dev = rs.software_device()
    depth_s, color_s = dev.add_sensor("Depth"), dev.add_sensor("Color")
    streams = []
    for sensor, kind, fmt, bpp, uid in [
        (depth_s, rs.stream.depth, rs.format.z16, 2, 0),
        (color_s, rs.stream.color, rs.format.rgb8, 3, 1),
    ]:
        vs = rs.video_stream()
        vs.type, vs.index, vs.uid, vs.width, vs.height = kind, 0, uid, w, h
        vs.fps, vs.bpp, vs.fmt, vs.intrinsics = 30, bpp, fmt, _intrinsics(w, h)
        streams.append(sensor.add_video_stream(vs))
    dp, cp = streams
    depth_s.add_read_only_option(rs.option.depth_units, 0.001)
    dev.create_matcher(rs.matchers.default)
    ext = rs.extrinsics()
    ext.rotation, ext.translation = [1, 0, 0, 0, 1, 0, 0, 0, 1], [0, 0, 0]
    dp.register_extrinsics_to(cp, ext)
    recorder = rs.recorder(str(path), dev)
    depth_s.open(dp)
    color_s.open(cp)
    depth_s.start(lambda f: None)
    color_s.start(lambda f: None)
    for i, (c, d) in enumerate(zip(colors, depths_mm, strict=True)):
        for sensor, prof, pixels, bpp in [(depth_s, dp, d, 2), (color_s, cp, c, 3)]:
            f = rs.software_video_frame()
            f.pixels, f.stride, f.bpp = np.ascontiguousarray(pixels), w * bpp, bpp
            f.timestamp, f.frame_number = i * 1000 / 30, i
            f.domain = rs.timestamp_domain.hardware_clock
            f.profile = prof.as_video_stream_profile()
            if bpp == 2:
                f.depth_units = 0.001
            sensor.on_video_frame(f)
        time.sleep(0.02)  # the recorder writes from its own thread: let it keep up
    time.sleep(0.2)  # ... and drain its queue before the sensors stop (a busy host lags)
    for s in (depth_s, color_s):
        s.stop()
        s.close()
    del recorder  # flushes and closes the file
    return path


def test_playback_pairs_colour_depth_and_intrinsics(tmp_path: Path) -> None:
    n, h, w = 6, 48, 64
    colors = [np.full((h, w, 3), 30 * i, np.uint8) for i in range(n)]
    depths = [np.full((h, w), 500 + 10 * i, np.uint16) for i in range(n)]
    path = record_rgbd(tmp_path / "rec.db3", colors, depths)
    with RealSenseRecording(path) as src:
        assert src.intrinsics is not None and src.intrinsics.fx == FX
        assert src.has_depth and src.fps == pytest.approx(30.0)
        frames = list(src)
    # playback starts with the first matched pair: the SDK drops up to two frames at the start
    assert len(frames) >= n - 2
    assert round((float(np.median(frames[-1].depth_m)) - 0.5) / 0.01) == n - 1  # none at the end
    for f in frames:
        i = round((float(np.median(f.depth_m)) - 0.5) / 0.01)
        assert f.rgb[0, 0, 0] == 30 * i  # colour and depth of the same instant
        assert f.depth_m.dtype == np.float32 and f.rgb.shape == (h, w, 3)
    t = np.array([f.t for f in frames])
    assert (np.diff(t) > 0).all()


def test_rgbd_recording_of_a_real_hand(hand_video: Path, tmp_path: Path) -> None:
    with open_source(hand_video, max_frames=8, resize_width=320) as src:
        colors = [f.rgb for f in src]
    h, w = colors[0].shape[:2]
    depth = np.full((h, w), 600, np.uint16)  # the hand on a plane 0.6 m away...
    depth[::7, :] = 0  # ...with rows of holes, as RealSense depth has
    path = record_rgbd(tmp_path / "hand.db3", colors, [depth] * len(colors))
    with RealSenseRecording(path) as src:
        series = track_source(src, CaptureConfig(lift=LiftConfig(model="pinhole")))
    assert series.valid.mean() >= 0.8 and series.meta["depth"] == "measured"
    kp = series.keypoints[series.valid]
    np.testing.assert_allclose(kp[..., 2], 0.6, atol=1e-6)  # depth plane, holes skipped
    K = series.meta["intrinsics"]
    assert K["fx"] == FX
    from dexlfd.capture import Intrinsics

    expected = deproject_pinhole(
        series.uv_px[series.valid], np.full(kp.shape[:2], 0.6), Intrinsics(**K)
    )
    np.testing.assert_allclose(kp, expected, atol=1e-6)
    # the CLI picks the pinhole model for RGB-D automatically
    out = tmp_path / "demo.npz"
    assert main(["record", str(path), "-o", str(out), "-q"]) == 0
    demo = load_demonstration(out)
    assert demo.capture.lift_model == "pinhole" and demo.valid.any()
    # the whole-recording pose takes the depth image's readings as its measurements: the
    # wrist stays on the 0.6 m plane (camera frame), with a small depth uncertainty
    v = demo.valid
    np.testing.assert_allclose(demo.position[v, 2], 0.6, atol=0.01)
    assert np.nanmax(demo.extras["depth_std"][v]) < 0.01
