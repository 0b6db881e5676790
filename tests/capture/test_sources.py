from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture import (
    CaptureConfig,
    LiftConfig,
    RealSenseLive,
    RealSenseRecording,
    VideoFileSource,
    WebcamPairSource,
    WebcamSource,
    open_source,
    track_source,
)
from dexlfd.errors import DependencyNotInstalled, InvalidDemonstration, InvalidInput, SourceError


def write_video(path: Path, frames: list[np.ndarray], fps: float = 30.0) -> Path:
    import cv2

    h, w = frames[0].shape[:2]
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), fps, (w, h))
    for f in frames:
        vw.write(f)
    vw.release()
    return path


@pytest.fixture
def noise_video(tmp_path: Path) -> Path:
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (120, 160, 3), dtype=np.uint8) for _ in range(8)]
    return write_video(tmp_path / "noise.mp4", frames)


def test_video_file_source_frames_times_and_release(noise_video: Path) -> None:
    src = VideoFileSource(noise_video, max_frames=5, resize_width=80)
    with src:
        assert src.fps == pytest.approx(30.0) and src.n_frames == 5
        frames = list(src)
    assert [f.index for f in frames] == list(range(5))
    np.testing.assert_allclose([f.t for f in frames], np.arange(5) / 30.0)
    assert frames[0].rgb.shape == (60, 80, 3) and frames[0].rgb.dtype == np.uint8
    assert src._cap is None  # released
    with pytest.raises(SourceError, match="with source"):
        list(src)


def test_source_released_on_error(noise_video: Path) -> None:
    src = VideoFileSource(noise_video)
    with pytest.raises(RuntimeError), src:
        raise RuntimeError("boom")
    assert src._cap is None


def test_bad_video_files(tmp_path: Path) -> None:
    with (
        pytest.raises(SourceError, match="no such video file"),
        VideoFileSource(tmp_path / "x.mp4"),
    ):
        pass
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    with pytest.raises(SourceError, match="empty"), VideoFileSource(empty):
        pass
    corrupt = tmp_path / "corrupt.mp4"
    corrupt.write_bytes(np.random.default_rng(1).bytes(5000))
    with pytest.raises(SourceError, match="corrupt|cannot decode"), VideoFileSource(corrupt) as src:
        list(src)


def test_noise_video_has_no_hand(noise_video: Path) -> None:
    cfg = CaptureConfig(lift=LiftConfig(model="assumed_depth"))
    src = open_source(noise_video)
    with pytest.raises(InvalidDemonstration, match="no hand detected in any of the 8 frames"), src:
        track_source(src, cfg)


def test_open_source_parsing(tmp_path: Path) -> None:
    assert isinstance(open_source("webcam:2"), WebcamSource)
    pair = open_source("webcams:0,1")
    assert isinstance(pair, WebcamPairSource) and pair.indices == (0, 1)
    assert isinstance(open_source("realsense"), RealSenseLive)
    assert open_source("realsense:123").serial == "123"
    assert isinstance(open_source(tmp_path / "a.bag"), RealSenseRecording)
    assert isinstance(open_source(tmp_path / "a.db3"), RealSenseRecording)
    assert isinstance(open_source(tmp_path / "a.mp4"), VideoFileSource)
    for bad, msg in [
        ("rtsp-stream", "not supported"),
        ("webcam:front", "webcam:INDEX"),
        ("webcams:0", "two indices"),
        ("webcams:1,1", "must differ"),
    ]:
        with pytest.raises(InvalidInput, match=msg):
            open_source(bad)


def test_webcams_not_connected() -> None:
    with pytest.raises(SourceError, match="camera not connected"), WebcamSource(97):
        pass
    pair = WebcamPairSource(97, 98)
    with pytest.raises(SourceError, match="camera not connected"), pair:
        pass
    assert pair._caps == []


def test_realsense_not_connected() -> None:
    try:
        import pyrealsense2 as rs
    except ImportError:
        with pytest.raises(DependencyNotInstalled, match="pyrealsense2"), RealSenseLive():
            pass
        return
    if len(rs.context().query_devices()):
        pytest.skip("a RealSense camera is connected")
    with pytest.raises(SourceError, match="camera not connected"), RealSenseLive():
        pass


def test_missing_recording(tmp_path: Path) -> None:
    pytest.importorskip("pyrealsense2", reason="pyrealsense2 not installed (optional)")
    with (
        pytest.raises(SourceError, match="no such recording"),
        RealSenseRecording(tmp_path / "a.bag"),
    ):
        pass
    bad = tmp_path / "bad.bag"
    bad.write_bytes(b"not a bag file at all" * 10)
    with pytest.raises(SourceError, match="bad.bag"), RealSenseRecording(bad):
        pass


@pytest.mark.parametrize(
    "spec", ["webcam:-1", "webcam:256", "webcam:x", "webcams:0,-1", "webcams:2"]
)
def test_a_camera_index_outside_0_to_255_is_refused_before_opening(spec: str) -> None:
    from dexlfd.capture.sources import open_source

    with pytest.raises(InvalidInput, match=r"SOURCE '.*': expected 'webcams?:"):
        open_source(spec)


@pytest.mark.parametrize(("ext", "name", "video_name"), [(".png", "PNG", "img.mp4"),
                                                        (".jpg", "JPEG", "img.avi"),
                                                        (".bmp", "BMP", "img.mov"),
                                                        (".png", "PNG", "img.png")])  # fmt: skip
def test_a_still_image_is_not_a_video_whatever_its_name(
    tmp_path: Path, ext: str, name: str, video_name: str
) -> None:
    import cv2

    from dexlfd.capture import VideoFileSource

    image = tmp_path / f"frame{ext}"
    assert cv2.imwrite(str(image), np.zeros((48, 64, 3), np.uint8))
    disguised = tmp_path / video_name
    disguised.write_bytes(image.read_bytes())
    message = rf"{video_name}: a {name} image, not a video"
    with pytest.raises(SourceError, match=message), VideoFileSource(disguised):
        pass


def test_teleop_refuses_a_png_named_mp4_in_one_line(tmp_path: Path, capsys) -> None:
    import cv2

    from dexlfd.cli import main

    image = tmp_path / "frame.png"
    assert cv2.imwrite(str(image), np.zeros((48, 64, 3), np.uint8))
    video = tmp_path / "clip.mp4"
    video.write_bytes(image.read_bytes())
    out = tmp_path / "t.npz"
    assert main(["teleop", str(video), "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("dexlfd teleop: error: ")]
    assert len(lines) == 1 and "Traceback" not in err
    assert f"{video}: a PNG image, not a video" in lines[0]
    assert not out.exists()


def test_a_raw_mjpeg_stream_is_a_video_not_a_jpeg_image(tmp_path: Path) -> None:
    """A camera's raw MJPEG (JPEGs back to back) starts like one JPEG but has many frames."""
    import cv2

    from dexlfd.capture.opencv_sources import VideoFileSource

    frames = [np.full((48, 64, 3), 40 * i, np.uint8) for i in range(5)]
    clip = tmp_path / "clip.mjpeg"
    clip.write_bytes(b"".join(cv2.imencode(".jpg", f)[1].tobytes() for f in frames))
    source = VideoFileSource(clip)
    source.open()
    try:
        assert sum(1 for _ in source) == 5
    finally:
        source.close()
