"""VideoFileSource on real files: the file's own timestamps, truncated files."""

from __future__ import annotations

import logging
import subprocess
from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture import VideoFileSource
from dexlfd.data import hand_video as _packaged_video

VIDEO = _packaged_video()


@pytest.fixture
def real_video() -> Path:
    return VIDEO


def _ffmpeg(*args: str) -> None:
    ffmpeg = pytest.importorskip("imageio_ffmpeg").get_ffmpeg_exe()
    subprocess.run([ffmpeg, "-v", "error", "-y", *args], check=True, capture_output=True)


def test_timestamps_of_the_constant_rate_real_video(real_video: Path) -> None:
    with VideoFileSource(real_video, resize_width=160) as src:
        t = np.array([f.t for f in src])
    assert t.size == 621
    assert (np.diff(t) > 0).all()
    np.testing.assert_allclose(t, np.arange(621) / 30.0, atol=1e-3)


def test_variable_frame_rate_times_come_from_the_file(real_video: Path, tmp_path: Path) -> None:
    """40 frames: the first 20 at 30 fps, the next 20 at 10 fps (a phone slowing down)."""
    vfr = tmp_path / "vfr.mp4"
    pts = "if(lt(N,20),N/30,20/30+(N-20)/10)/TB"
    _ffmpeg("-i", str(real_video), "-frames:v", "40", "-vf", f"setpts='{pts}',scale=160:-2",
            "-fps_mode", "vfr", "-an", "-c:v", "libx264", "-preset", "ultrafast",
            str(vfr))  # fmt: skip
    with VideoFileSource(vfr) as src:
        t = np.array([f.t for f in src])
    expected = np.where(np.arange(40) < 20, np.arange(40) / 30, 20 / 30 + (np.arange(40) - 20) / 10)
    assert t.size == 40
    np.testing.assert_allclose(t, expected, atol=2e-3)  # i / fps would be off by 1.3 s


def test_a_truncated_video_warns_with_both_counts(
    real_video: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    fast = tmp_path / "faststart.mp4"
    _ffmpeg("-i", str(real_video), "-c", "copy", "-movflags", "+faststart", str(fast))
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(fast.read_bytes()[:300_000])  # head -c 300000
    with caplog.at_level(logging.WARNING), VideoFileSource(cut, resize_width=160) as src:
        n = sum(1 for _ in src)
    assert 0 < n < 621
    msgs = [r.getMessage() for r in caplog.records if "announces" in r.getMessage()]
    assert len(msgs) == 1
    assert str(cut) in msgs[0] and f"after {n} frames" in msgs[0] and "announces 621" in msgs[0]
    # the whole file and a --max-frames cut of it: no warning
    caplog.clear()
    with caplog.at_level(logging.WARNING), VideoFileSource(fast, max_frames=50) as src:
        assert sum(1 for _ in src) == 50
    assert not [r for r in caplog.records if "announces" in r.getMessage()]
