from __future__ import annotations

import base64
from pathlib import Path

import numpy as np

from dexlfd.viz.demonstrations import plot_demonstrations
from dexlfd.viz.report import Report, Section, write_report


def test_report_embeds_figures_and_escapes(tmp_path: Path, demos) -> None:
    png = plot_demonstrations(demos, tmp_path / "d.png")
    sec = Section(
        "Demos <1>",
        paragraphs=["a & b"],
        figures=[(png, "paths"), (tmp_path / "missing.png", "gone")],
        tables=[(["controller", "E [mm]"], [["pd", 1.23456], ["ntsm-pd", 0.5]], "errors")],
        settings={"k": 6},
    )
    out = write_report(Report("dexlfd", "intro", [sec]), tmp_path / "r.html")
    text = out.read_text()
    assert "Demos &lt;1&gt;" in text and "a &amp; b" in text
    assert base64.b64encode(png.read_bytes()).decode()[:200] in text
    assert "figure missing" in text and "1.235" in text and "&quot;k&quot;: 6" in text


def _mp4v(path: Path, n: int = 6) -> Path:
    """A short MPEG-4 Part 2 file (what the writer falls back to without H.264)."""
    import cv2

    w = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), 10.0, (64, 48))
    for i in range(n):
        w.write(np.full((48, 64, 3), 40 * i, np.uint8))
    w.release()
    return path


def test_a_video_browsers_cannot_play_is_a_still_frame_with_a_note(tmp_path: Path) -> None:
    import pytest

    from dexlfd.io.video import browser_playable, still_frame_png

    old = _mp4v(tmp_path / "old.mp4")
    assert not browser_playable(old)
    png = still_frame_png(old)
    assert png is not None and png[:8] == b"\x89PNG\r\n\x1a\n"
    sec = Section("Videos", videos=[(old, "robot")])
    text = write_report(Report("dexlfd", "", [sec]), tmp_path / "r.html").read_text()
    assert "<video" not in text and "data:image/png;base64," in text
    assert "not H.264" in text and 'href="old.mp4"' in text
    pytest.importorskip("imageio_ffmpeg", reason="the video extra (H.264) is not installed")
    from dexlfd.io.video import VideoWriter

    with VideoWriter(tmp_path / "new.mp4", 10.0) as vw:
        for i in range(6):
            vw.write(np.full((48, 64, 3), 40 * i, np.uint8))
    sec = Section("Videos", videos=[(tmp_path / "new.mp4", "robot")])
    text = write_report(Report("dexlfd", "", [sec]), tmp_path / "r2.html").read_text()
    assert '<video controls muted loop preload="auto" src="data:video/mp4;base64,' in text
