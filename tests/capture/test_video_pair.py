"""Two recorded videos (top, side) as a two-camera source: thesis Eqs. (4.1)-(4.8)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture import (
    CaptureConfig,
    HandCapture,
    HandObservation,
    LiftConfig,
    TwoWebcamModel,
    open_source,
    project_two_webcams,
    track_source,
)
from dexlfd.capture.opencv_sources import VideoPairSource
from dexlfd.cli import main
from dexlfd.errors import InvalidInput, SourceError
from dexlfd.io import load_demonstration

SHARED = Path(
    os.environ.get("DEXLFD_SHARED", Path(__file__).resolve().parents[2] / ".." / "shared")
)


def _video(path: Path, n: int, size: tuple[int, int], fps: float = 10.0) -> Path:
    import cv2

    vw = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), fps, size)
    for i in range(n):
        vw.write(np.full((size[1], size[0], 3), 10 * i % 255, np.uint8))
    vw.release()
    return path


class PixelsPerFrame:
    """Returns known pixel landmarks, one set per call."""

    def __init__(self, uv: np.ndarray) -> None:
        self.uv, self.i = uv, 0

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        uv = self.uv[self.i]
        self.i += 1
        return [HandObservation(uv, np.zeros(21), np.zeros((21, 3)), "right", 0.9)]

    def close(self) -> None:
        pass


def test_two_videos_recover_known_points(tmp_path: Path) -> None:
    n = 8
    top = _video(tmp_path / "top.mp4", n, (320, 240))
    side = _video(tmp_path / "side.mp4", n, (160, 128))
    rng = np.random.default_rng(2)
    centre = np.column_stack([np.linspace(-0.1, 0.1, n), np.full(n, 0.05), np.full(n, 0.4)])
    P = centre[:, None, :] + rng.uniform(-0.04, 0.04, (n, 21, 3))
    # what each camera sees of the known points (at its own image size)
    top_uv = np.stack([project_two_webcams(p, TwoWebcamModel().at_size(320, 240))[0] for p in P])
    side_uv = np.stack([project_two_webcams(p, TwoWebcamModel().at_size(160, 128))[1] for p in P])
    source = open_source(f"videos:{top},{side}")
    assert isinstance(source, VideoPairSource)
    cfg = CaptureConfig(lift=LiftConfig(model="two_webcams"))
    with source:
        assert source.n_frames == n and source.native_size == (320, 240)
        cap = HandCapture(
            cfg, None, PixelsPerFrame(top_uv), PixelsPerFrame(side_uv), has_depth=False
        )
        series = track_source(source, capture=cap)
    assert series.valid.all() and series.meta["source_kind"] == "videos"
    np.testing.assert_allclose(series.keypoints, P, atol=1e-9)
    np.testing.assert_allclose(series.t, np.arange(n) / 10.0, atol=1e-6)


def test_a_pair_of_videos_of_different_lengths_ends_with_the_shorter(
    tmp_path: Path, caplog
) -> None:
    top = _video(tmp_path / "top.mp4", 6, (64, 48))
    side = _video(tmp_path / "side.mp4", 4, (64, 48))
    with open_source(f"videos:{top},{side}") as src:
        frames = list(src)
    assert len(frames) == 4 and all(f.rgb2 is not None for f in frames)
    assert "6 and 4 frames" in caplog.text


@pytest.mark.parametrize(
    ("spec", "error", "words"),
    [
        ("videos:one.mp4", InvalidInput, "expected 'videos:TOP,SIDE'"),
        ("videos:a.mp4,", InvalidInput, "expected 'videos:TOP,SIDE'"),
        ("videos:a.mp4,a.mp4", InvalidInput, "two files"),
    ],
)
def test_bad_pair_specs(spec: str, error: type, words: str) -> None:
    with pytest.raises(error, match=words):
        open_source(spec)


def test_a_missing_video_of_the_pair(tmp_path: Path, capsys) -> None:
    top = _video(tmp_path / "top.mp4", 3, (64, 48))
    with (
        pytest.raises(SourceError, match="no such video file"),
        open_source(f"videos:{top},{tmp_path / 'absent.mp4'}"),
    ):
        pass
    out = tmp_path / "d.npz"
    assert main(["record", f"videos:{top},{tmp_path / 'absent.mp4'}", "-o", str(out)]) == 1
    assert "no such video file" in capsys.readouterr().err and not out.exists()


@pytest.mark.slow
def test_the_real_two_camera_recording_runs_end_to_end(tmp_path: Path, capsys) -> None:
    cams = [SHARED / "data" / f"mimicplay_play_cam{i}.mp4" for i in (1, 2)]
    if not all(c.is_file() for c in cams):
        pytest.skip(f"real two-camera videos not found in {SHARED / 'data'}")
    out = tmp_path / "pair.npz"
    assert main(["record", f"videos:{cams[0]},{cams[1]}", "-o", str(out)]) == 0
    # one file, or one per pick-and-place (pair-1.npz, ...) when the session holds several
    written = [out] if out.exists() else sorted(tmp_path.glob("pair-*.npz"))
    assert written, "record wrote no demonstration"
    demo = load_demonstration(written[0])
    cap = {**demo.meta["capture"], **demo.capture.to_json()}
    assert cap["lift_model"] == "two_webcams" and cap["source_kind"] == "videos"
    # the rig is read at the videos' real size, not the thesis's 640x480
    assert (cap["two_webcams"]["width_px"], cap["two_webcams"]["height_px"]) == (120, 120)
    assert demo.valid.sum() > 20
