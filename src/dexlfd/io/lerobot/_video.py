"""The episodes' camera video: source frames at the frame times, re-encoded into one MP4.

A demonstration recorded by ``dexlfd record`` from a video file keeps, under
``meta["capture"]``, ``"source" == "video file PATH"``, ``"source_kind" == "video"`` and
``"fps"`` (older files and hand-made ones may hold them at the top of ``meta``); source
frame ``i`` is
at ``i / fps``. Each episode frame takes the nearest source frame (the last one past
the end).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.errors import InvalidFile
from dexlfd.io.lerobot._frames import Episode

__all__ = ["source_video", "video_feature", "write_episode_video"]


def source_video(meta: dict[str, Any]) -> tuple[Path, float] | None:
    """The source video file and its frame rate recorded by ``dexlfd record``, if it exists."""
    capture = meta.get("capture")
    if isinstance(capture, dict) and "source_kind" in capture:
        meta = capture  # where record writes them
    source = str(meta.get("source", ""))
    if meta.get("source_kind") != "video" or not source.startswith("video file "):
        return None
    path = Path(source[len("video file ") :])
    fps = float(meta.get("fps") or 0.0)
    return (path, fps) if path.is_file() and fps > 0 else None


def _copy_frames(
    writer: Any,
    video: Path,
    wanted: np.ndarray,
    size: tuple[int, int] | None = None,
    on_frame: Callable[[], None] | None = None,
) -> np.ndarray:
    """Append the frames ``wanted`` (increasing source frame indices) of ``video``.

    ``size`` ``(width, height)`` [px]: each frame resized to it (area interpolation);
    ``on_frame()`` is called after each appended frame (progress).
    Returns the histogram of the appended RGB values, shape (3, 256).
    """
    import cv2

    histogram = np.zeros((3, 256), dtype=np.int64)
    cap = cv2.VideoCapture(str(video))
    try:
        i, frame, ok = -1, None, True
        for k in wanted:
            while i < k and ok:
                ok, bgr = cap.read()
                if ok:
                    i, frame = i + 1, bgr
            if frame is None:
                raise InvalidFile(f"{video}: no frame could be decoded")
            rgb = cv2.cvtColor(frame, cv2.COLOR_BGR2RGB)
            if size is not None and (rgb.shape[1], rgb.shape[0]) != size:
                rgb = cv2.resize(rgb, size, interpolation=cv2.INTER_AREA)
            writer.write(rgb)
            for c in range(3):
                histogram[c] += np.bincount(rgb[..., c].reshape(-1), minlength=256)
            if on_frame is not None:
                on_frame()
    finally:
        cap.release()
    return histogram


def write_episode_video(
    episodes: Sequence[Episode],
    rate: int,
    path: Path,
    size: tuple[int, int] | None = None,
    callback: Callable[[int, float], None] | None = None,
) -> tuple[list[tuple[float, float]], list[np.ndarray]]:
    """Frames of each episode's source video at its frame times -> one MP4 at ``rate`` [Hz].

    ``size`` ``(width, height)`` [px] resizes every frame (default: the source's size).
    ``callback(i, seconds)`` is called after the i-th frame written (``seconds``: its time
    in the MP4), for a progress bar.

    Returns each episode's span ``(from, to)`` in the MP4 [s] and the histogram of its
    frames' RGB values before encoding, shape (3, 256) (for the statistics,
    :func:`dexlfd.io.lerobot._schema.image_stats`).
    """
    from dexlfd.io.video import VideoWriter

    spans: list[tuple[float, float]] = []
    histograms: list[np.ndarray] = []
    start = 0
    written = [0]

    def on_frame() -> None:
        if callback is not None:
            callback(written[0], written[0] / rate)
        written[0] += 1

    with VideoWriter(path, fps=rate) as writer:
        for ep in episodes:
            src = source_video(ep.meta)
            assert src is not None
            video, fps = src
            wanted = np.rint(ep.times * fps).astype(np.int64)
            histograms.append(_copy_frames(writer, video, wanted, size, on_frame))
            spans.append((start / rate, (start + wanted.size) / rate))
            start += wanted.size
    return spans, histograms


def video_feature(path: Path, rate: int) -> dict[str, Any]:
    """``info.json``'s feature entry of the MP4 at ``path`` (H.264, ``rate`` [Hz])."""
    import cv2

    cap = cv2.VideoCapture(str(path))
    w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    cap.release()
    return {
        "dtype": "video",
        "shape": [h, w, 3],
        "names": ["height", "width", "channels"],
        "info": {
            "video.height": h,
            "video.width": w,
            "video.codec": "h264",
            "video.pix_fmt": "yuv420p",
            "video.is_depth_map": False,
            "video.fps": rate,
            "video.channels": 3,
            "has_audio": False,
        },
    }
