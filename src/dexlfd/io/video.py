"""H.264 MP4 writer for rendered and overlaid videos, playable in any browser.

OpenCV's pip wheels cannot encode H.264 (only MPEG-4 Part 2, which browsers do
not play), so frames are piped to the ffmpeg binary shipped by the
``imageio-ffmpeg`` package (libx264, yuv420p, ``+faststart``; the ``video``
extra). Without it the video is written with OpenCV's MPEG-4 Part 2 encoder
(``mp4v``; plays in desktop players, not in browsers) after a one-line warning
naming the extra. The file is
written under a temporary name and renamed when closed cleanly; on error or
interruption the partial file is removed.

The encoder's CPU can be traded for size and colour detail (``preset``,
``subsample_here``): measured on 257 rendered 480x360 frames, ffmpeg costs 2.3 ms a
frame as by default, of which ~0.75 ms is its RGB to YUV 4:2:0 conversion and most
of the rest x264's ``veryfast``; with the conversion done here by OpenCV (0.15-0.3 ms)
and ``ultrafast`` 0.6-0.7 ms, the file ~3.5x larger at the same ``crf`` (ultrafast
spends more bits: a higher PSNR, 45.2 against 43.2 dB).

ffmpeg runs in its own session (process group), so the user's Ctrl-C reaches only
dexlfd: the caller decides what to keep (e.g. ``teleop`` saves its rollout, then
finishes or drops the video) instead of ffmpeg dying mid-file with exit 255.
"""

from __future__ import annotations

import logging
import os
import subprocess
from pathlib import Path
from typing import IO, Any

import numpy as np

from dexlfd.errors import DependencyNotInstalled, InvalidFile, InvalidInput
from dexlfd.io._atomic import discard, put_in_place, temp_file

__all__ = ["VideoWriter", "browser_playable", "still_frame_png", "video_codec"]

logger = logging.getLogger(__name__)

_warned_fallback = False  # the mp4v fallback is announced once per process
X264_PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow",
                "slower", "veryslow", "placebo")  # fmt: skip


class VideoWriter:
    """Context manager writing RGB ``uint8`` frames ``(h, w, 3)`` to an H.264 MP4.

    Parameters
    ----------
    path : path-like
        Output ``.mp4``.
    fps : float
        Frame rate [Hz].
    crf : int
        x264 quality (lower is better, 18-28 sensible).
    preset : str
        x264's speed preset (``"ultrafast"`` ... ``"veryslow"``): faster ones cost less
        CPU and make larger files.
    subsample_here : bool
        Convert each frame to YUV 4:2:0 in this process (OpenCV: each 2x2 block's
        colour is its top-left pixel's) instead of in ffmpeg (the block's mean):
        cheaper; thin coloured lines may step. Frames of odd width or height are
        converted by ffmpeg.
    """

    def __init__(self, path: str | os.PathLike[str], fps: float, crf: int = 23, *,
                 preset: str = "veryfast", subsample_here: bool = False) -> None:  # fmt: skip
        if not fps > 0:
            raise InvalidInput(f"fps must be > 0, got {fps}")
        self.path = Path(path)
        if not self.path.parent.is_dir():
            raise InvalidFile(f"cannot write {self.path}: folder {self.path.parent} does not exist")
        self.fps = float(fps)
        self.crf = int(crf)
        if preset not in X264_PRESETS:
            raise InvalidInput(f"preset must be one of {', '.join(X264_PRESETS)}, got {preset!r}")
        self.preset, self._subsample_here = preset, bool(subsample_here)
        self._yuv = False  # the frames go to ffmpeg as YUV 4:2:0 (converted here)
        self._tmp = temp_file(self.path, ".mp4")
        self._proc: subprocess.Popen[bytes] | None = None
        self._cv: Any = None  # OpenCV's writer when imageio-ffmpeg is missing
        self._cv_size = (0, 0)
        self._shape: tuple[int, ...] | None = None
        self.n_frames = 0

    def __enter__(self) -> VideoWriter:
        return self

    def _start(self, h: int, w: int) -> None:
        try:
            from dexlfd._extras import import_extra

            imageio_ffmpeg = import_extra("imageio_ffmpeg", "H.264 (browser-playable) MP4")
        except DependencyNotInstalled as exc:
            self._start_opencv(h, w, str(exc))
            return
        exe = imageio_ffmpeg.get_ffmpeg_exe()
        self._yuv = self._subsample_here and h % 2 == 0 and w % 2 == 0
        cmd = [
            exe, "-y", "-loglevel", "error", "-f", "rawvideo",
            "-pix_fmt", "yuv420p" if self._yuv else "rgb24",
            "-s", f"{w}x{h}", "-r", f"{self.fps}", "-i", "-",
            "-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", str(self.crf),
            "-preset", self.preset, "-movflags", "+faststart",
            # x264 with yuv420p needs even sizes
            *([] if self._yuv else ["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"]), str(self._tmp),
        ]  # fmt: skip
        # own session: a terminal's SIGINT goes to the foreground process group only
        self._proc = subprocess.Popen(
            cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
        )

    def _start_opencv(self, h: int, w: int, why: str) -> None:
        global _warned_fallback
        import cv2

        if not _warned_fallback:
            logger.warning("%s; writing MPEG-4 Part 2 instead (not playable in browsers)", why)
            _warned_fallback = True
        # even sizes, as the H.264 path pads them
        self._cv_size = (w + w % 2, h + h % 2)
        self._cv = cv2.VideoWriter(
            str(self._tmp), cv2.VideoWriter.fourcc(*"mp4v"), self.fps, self._cv_size
        )
        if not self._cv.isOpened():
            self._cv = None
            raise InvalidFile(f"cannot write {self.path}: OpenCV cannot open an MPEG-4 writer")

    def _write_opencv(self, frame: np.ndarray) -> None:
        import cv2

        w, h = self._cv_size
        bgr = cv2.cvtColor(np.ascontiguousarray(frame, dtype=np.uint8), cv2.COLOR_RGB2BGR)
        if bgr.shape[:2] != (h, w):
            bgr = cv2.copyMakeBorder(
                bgr, 0, h - bgr.shape[0], 0, w - bgr.shape[1], cv2.BORDER_CONSTANT
            )
        self._cv.write(bgr)
        self.n_frames += 1

    def write(self, frame: np.ndarray) -> None:
        """Append one RGB frame; all frames must have the same size."""
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[2] != 3:
            raise InvalidInput(f"frame must have shape (h, w, 3), got {frame.shape}")
        if self._shape is None:
            self._shape = frame.shape
            self._start(frame.shape[0], frame.shape[1])
        elif frame.shape != self._shape:
            raise InvalidInput(f"frame size changed from {self._shape} to {frame.shape}")
        if self._cv is not None:
            self._write_opencv(frame)
            return
        if self._proc is None or self._proc.stdin is None:
            raise InvalidFile(f"cannot write {self.path}: the writer is closed")
        stdin: IO[bytes] = self._proc.stdin
        data: np.ndarray = np.ascontiguousarray(frame, dtype=np.uint8)
        if self._yuv:
            import cv2

            data = cv2.cvtColor(data, cv2.COLOR_RGB2YUV_I420)
        try:
            stdin.write(data.tobytes())
        except BrokenPipeError as exc:
            raise InvalidFile(
                f"cannot write {self.path}: ffmpeg stopped: {self._stderr()}"
            ) from exc
        self.n_frames += 1

    def _stderr(self) -> str:
        if self._proc is None or self._proc.stderr is None:
            return ""
        return self._proc.stderr.read().decode(errors="replace").strip()

    def close(self, ok: bool = True) -> Path | None:
        """Finish the file (rename into place when ``ok``), or discard it.

        Whatever ends the closing (ffmpeg failing, Ctrl-C while it encodes the last
        frames), the temporary file is gone afterwards.
        """
        proc = self._proc
        try:
            return self._close(ok)
        except BaseException:
            try:
                if proc is not None and proc.poll() is None:
                    proc.kill()  # else it would go on writing (and re-open the file to finish)
                    proc.wait()
            finally:
                if proc is not None and proc.stderr is not None:
                    proc.stderr.close()
                discard(self._tmp)
            raise

    def _close(self, ok: bool) -> Path | None:
        proc, self._proc = self._proc, None
        cv_writer, self._cv = self._cv, None
        if cv_writer is not None:
            cv_writer.release()
        if proc is not None:
            if proc.stdin is not None:
                proc.stdin.close()
            code = proc.wait()
            err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
            if proc.stderr is not None:
                proc.stderr.close()
            if ok and code != 0:
                raise InvalidFile(f"cannot write {self.path}: ffmpeg exit {code}: {err.strip()}")
        if ok and self.n_frames > 0:
            put_in_place(self._tmp, self.path)
            logger.info("wrote %s (%d frames, %.1f s)", self.path, self.n_frames,
                        self.n_frames / self.fps)  # fmt: skip
            return self.path
        discard(self._tmp)
        return None

    def __exit__(self, exc_type: type[BaseException] | None, *rest: object) -> None:
        self.close(ok=exc_type is None)  # an exception discards the partial file


def video_codec(path: str | os.PathLike[str]) -> str:
    """The FourCC of the first video stream of ``path`` (``"avc1"``/``"h264"`` for H.264).

    Read with OpenCV's demuxer; ``""`` when the file cannot be opened.
    """
    import cv2

    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            return ""
        code = int(cap.get(cv2.CAP_PROP_FOURCC))
    finally:
        cap.release()
    return "".join(chr((code >> (8 * i)) & 0xFF) for i in range(4)).strip("\0 ").lower()


def browser_playable(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is H.264, the MP4 codec every browser plays (mp4v is not)."""
    return video_codec(path) in {"avc1", "h264", "x264", "avc3"}


def still_frame_png(path: str | os.PathLike[str], at: float = 0.5) -> bytes | None:
    """The frame at fraction ``at`` of the video ``path`` as PNG bytes (None if unreadable).

    The report shows it where a browser cannot play the video (no H.264 encoder).
    """
    import cv2

    cap = cv2.VideoCapture(str(path))
    try:
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        if n > 1:
            cap.set(cv2.CAP_PROP_POS_FRAMES, int(min(max(at, 0.0), 1.0) * (n - 1)))
        ok, bgr = cap.read()
    finally:
        cap.release()
    if not ok:
        return None
    ok, png = cv2.imencode(".png", bgr)
    return png.tobytes() if ok else None
