"""Frame sources read through OpenCV: video files, a webcam, two webcams, two videos."""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.capture.frame_source import Frame, FrameSource
from dexlfd.errors import InvalidInput, SourceError

__all__ = ["VideoFileSource", "VideoPairSource", "WebcamPairSource", "WebcamSource"]

logger = logging.getLogger(__name__)


def _cv2() -> Any:
    import cv2

    # OpenCV's own [ WARN ]/[ERROR] lines (e.g. probing a missing webcam) would bury our one-line
    # errors; the failures they describe are reported by the sources themselves
    # silent (levels: 0 silent, 2 error, 3 warning); OpenCV 5 keeps it only in cv2.utils.logging
    set_level = getattr(cv2, "setLogLevel", None) or cv2.utils.logging.setLogLevel
    set_level(0)
    return cv2


def _resize(img: np.ndarray, width: int | None) -> np.ndarray:
    if width is None or img.shape[1] == width:
        return img
    cv2 = _cv2()
    h = int(round(img.shape[0] * width / img.shape[1]))
    return cv2.resize(img, (int(width), h), interpolation=cv2.INTER_AREA)


class _OpenCvSource(FrameSource):
    """A source read through one ``cv2.VideoCapture`` (``self._cap``)."""

    _cap: Any = None

    @property
    def native_size(self) -> tuple[int, int] | None:
        """(width, height) [px] the capture decodes, before resizing; None when closed."""
        if self._cap is None:
            return None
        cv2 = _cv2()
        return int(self._cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(
            self._cap.get(cv2.CAP_PROP_FRAME_HEIGHT)
        )

    def close(self) -> None:
        """Release the file or camera."""
        if self._cap is not None:
            self._cap.release()
            self._cap = None
        self._open = False


# leading bytes of still-image formats OpenCV would also open as a video
_IMAGE_SIGNATURES = (
    (b"\x89PNG\r\n\x1a\n", "PNG"),
    (b"\xff\xd8\xff", "JPEG"),
    (b"BM", "BMP"),
    (b"II*\x00", "TIFF"),
    (b"MM\x00*", "TIFF"),
)


def _still_image_format(path: Path) -> str | None:
    """The still-image format ``path`` holds by its leading bytes (``"PNG"``...), or None."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return None  # OpenCV's own open says what is wrong
    if head[:4] == b"RIFF" and head[8:12] == b"WEBP":
        return "WebP"
    return next((name for magic, name in _IMAGE_SIGNATURES if head.startswith(magic)), None)


def _frames_up_to(path: Path, limit: int) -> int:
    """How many frames OpenCV decodes from ``path``, counting no further than ``limit``."""
    cap = _cv2().VideoCapture(str(path))
    try:
        n = 0
        while n < limit and cap.isOpened() and cap.grab():
            n += 1
        return n
    finally:
        cap.release()


class VideoFileSource(_OpenCvSource):
    """Any video file OpenCV can decode; frame times from the file's own timestamps.

    A frame's time is its presentation timestamp (``CAP_PROP_POS_MSEC``) relative
    to the first frame's, so variable-frame-rate (phone) videos keep their real
    timing; where the file gives no usable timestamp (not finite, or not after
    the previous frame's) the times continue at ``1/fps`` with a warning.
    A file that ends before the frame count its container announces (a truncated
    copy, a damaged file) is read up to there with a warning naming both counts.
    ``resize_width`` downscales frames (keeping the aspect ratio) before
    tracking: 640 px wide halves tracking time on 1280x720 video with ~1 px error.
    """

    kind = "video"

    def __init__(
        self,
        path: str | Path,
        max_frames: int | None = None,
        resize_width: int | None = None,
        fps: float | None = None,
    ) -> None:
        super().__init__(max_frames)
        self.path = Path(path)
        self.resize_width = resize_width
        self._fps_override = fps
        self.description = f"video file {self.path}"
        self._cap: Any = None
        self.announced_frames: int | None = None  # the container's frame count

    def open(self) -> None:
        """Open the file; raises :class:`SourceError` if missing, empty or unreadable."""
        if not self.path.is_file():
            raise SourceError(f"{self.path}: no such video file")
        if self.path.stat().st_size == 0:
            raise SourceError(f"{self.path}: the file is empty (0 bytes), expected a video")
        image = _still_image_format(self.path)
        if image is not None and _frames_up_to(self.path, 2) < 2:
            # OpenCV reads a still image as a one-frame "video": a run on it says nothing.
            # (A stream of them, such as a camera's raw MJPEG, starts the same way and is
            # a video: it has a second frame.)
            raise SourceError(
                f"{self.path}: a {image} image, not a video (whatever its name says); "
                "expected a video file (MP4, AVI, MOV, ...)"
            )
        cv2 = _cv2()
        cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            cap.release()
            raise SourceError(f"{self.path}: OpenCV cannot decode this file as a video")
        self._cap = cap
        fps = self._fps_override or cap.get(cv2.CAP_PROP_FPS)
        if not fps or not np.isfinite(fps) or fps <= 0 or fps > 1000:
            logger.warning("%s: no usable frame rate in the file; assuming 30 fps", self.path)
            fps = 30.0
        self.fps = float(fps)
        count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        self.announced_frames = count if count > 0 else None
        self.n_frames = self._limit(count if count > 0 else None)
        self._open = True

    def frames(self) -> Iterator[Frame]:
        """Decode frames in order."""
        cv2 = _cv2()
        fps = self.fps or 30.0
        i = 0
        clock = _FileClock(fps, str(self.path))
        while self.max_frames is None or i < self.max_frames:
            ok, bgr = self._cap.read()
            if not ok or bgr is None:
                break
            t = clock.time(self._cap.get(cv2.CAP_PROP_POS_MSEC))
            rgb = cv2.cvtColor(_resize(bgr, self.resize_width), cv2.COLOR_BGR2RGB)
            yield Frame(i, t, rgb)
            i += 1
        if i == 0:
            raise SourceError(f"{self.path}: no frame could be decoded (empty or corrupt video)")
        self._check_complete(i)

    def _check_complete(self, decoded: int) -> None:
        """Warn when fewer frames were decoded than the container announces (and asked for)."""
        announced = self.announced_frames
        if announced is None:
            return
        wanted = announced if self.max_frames is None else min(announced, self.max_frames)
        if decoded < wanted - max(2, 0.01 * wanted):
            logger.warning(
                "%s: the video ended after %d frames, but its container announces %d "
                "(a truncated or damaged file?); using the %d decoded frames",
                self.path,
                decoded,
                announced,
                decoded,
            )


class _FileClock:
    """Frame times [s] from a file's timestamps, continued at ``1/fps`` where they fail."""

    def __init__(self, fps: float, name: str) -> None:
        self.dt = 1.0 / fps
        self.name = name
        self.t0_ms: float | None = None
        self.last = -np.inf
        self.warned = False

    def time(self, pos_ms: float) -> float:
        """Time of the frame just read, whose timestamp is ``pos_ms`` [ms]."""
        if self.t0_ms is None and np.isfinite(pos_ms) and pos_ms >= 0:
            self.t0_ms = pos_ms
        t = np.nan if self.t0_ms is None else (pos_ms - self.t0_ms) / 1000.0
        if not (np.isfinite(t) and t > self.last):
            t = 0.0 if self.last == -np.inf else self.last + self.dt
            if not self.warned and self.last != -np.inf:
                logger.warning(
                    "%s: frame timestamps missing or not increasing; times continue at 1/fps",
                    self.name,
                )
                self.warned = True
        self.last = float(t)
        return float(t)


class WebcamSource(_OpenCvSource):
    """A webcam by OpenCV index; frame times from the monotonic clock."""

    kind = "webcam"

    def __init__(
        self,
        index: int = 0,
        max_frames: int | None = None,
        width: int | None = None,
        height: int | None = None,
    ) -> None:
        super().__init__(max_frames)
        self.index = int(index)
        self.size = (width, height)
        self.description = f"webcam {self.index}"
        self._cap: Any = None

    def open(self) -> None:
        """Open the camera; raises :class:`SourceError` "camera not connected" otherwise."""
        self._cap = _open_webcam(self.index, self.size)
        self.fps = float(self._cap.get(_cv2().CAP_PROP_FPS)) or None
        self.n_frames = self.max_frames
        self._open = True

    def frames(self) -> Iterator[Frame]:
        """Grab frames until ``max_frames`` or the camera stops."""
        cv2 = _cv2()
        t0 = time.monotonic()
        i = 0
        while self.max_frames is None or i < self.max_frames:
            ok, bgr = self._cap.read()
            if not ok:
                if i == 0:
                    raise SourceError(f"webcam {self.index}: camera opened but sends no frames")
                logger.warning("webcam %d stopped after %d frames", self.index, i)
                break
            yield Frame(i, time.monotonic() - t0, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
            i += 1


def _open_webcam(index: int, size: tuple[int | None, int | None]) -> Any:
    cv2 = _cv2()
    cap = cv2.VideoCapture(index)
    if not cap.isOpened():
        cap.release()
        raise SourceError(
            f"webcam {index}: camera not connected (OpenCV cannot open index {index})"
        )
    w, h = size
    if w:
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, w)
    if h:
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, h)
    return cap


class WebcamPairSource(FrameSource):
    """Two webcams (top, side) read in lock-step for the thesis's two-camera method."""

    kind = "webcams"

    def __init__(self, top: int = 0, side: int = 1, max_frames: int | None = None) -> None:
        super().__init__(max_frames)
        if top == side:
            raise InvalidInput(f"webcams: top and side must differ, got {top},{side}")
        self.indices = (int(top), int(side))
        self.description = f"webcams top={top} side={side}"
        self._caps: list[Any] = []

    def open(self) -> None:
        """Open both cameras (neither stays open if one fails)."""
        try:
            for i in self.indices:
                self._caps.append(_open_webcam(i, (None, None)))
        except SourceError:
            self.close()
            raise
        self.fps = float(self._caps[0].get(_cv2().CAP_PROP_FPS)) or None
        self.n_frames = self.max_frames
        self._open = True

    def close(self) -> None:
        """Release both cameras."""
        for cap in self._caps:
            cap.release()
        self._caps = []
        self._open = False

    def frames(self) -> Iterator[Frame]:
        """Grab both cameras, then retrieve (keeps the pair close in time)."""
        cv2 = _cv2()
        t0 = time.monotonic()
        i = 0
        while self.max_frames is None or i < self.max_frames:
            grabbed = [cap.grab() for cap in self._caps]
            t = time.monotonic() - t0
            if not all(grabbed):
                if i == 0:
                    raise SourceError(f"{self.description}: cameras opened but send no frames")
                break
            imgs = [cap.retrieve()[1] for cap in self._caps]
            if any(im is None for im in imgs):
                break
            top, side = (cv2.cvtColor(im, cv2.COLOR_BGR2RGB) for im in imgs)
            yield Frame(i, t, top, rgb2=side)
            i += 1


class VideoPairSource(FrameSource):
    """Two video files filmed at the same time by a top and a side camera (thesis Eqs. 4.1-4.8).

    Read in lock-step, frame ``i`` of one with frame ``i`` of the other (the
    recordings must start together); frame times are the top video's. The pair
    ends with the shorter video; differing frame counts or rates are warned
    about. Each video may have its own size (the lift reads the side image's
    pixels as fractions of it).
    """

    kind = "videos"

    def __init__(
        self,
        top: str | Path,
        side: str | Path,
        max_frames: int | None = None,
        resize_width: int | None = None,
    ) -> None:
        super().__init__(max_frames)
        if Path(top) == Path(side):
            raise InvalidInput(f"videos: top and side must be two files, got {top} twice")
        self.top = VideoFileSource(top, max_frames, resize_width)
        self.side = VideoFileSource(side, max_frames, resize_width)
        self.description = f"videos top={top} side={side}"

    @property
    def native_size(self) -> tuple[int, int] | None:
        """The top video's (width, height) [px] before resizing."""
        return self.top.native_size

    def open(self) -> None:
        """Open both files (neither stays open if one fails)."""
        try:
            self.top.open()
            self.side.open()
        except SourceError:
            self.close()
            raise
        self.fps = self.top.fps
        top_n, side_n = self.top.n_frames, self.side.n_frames
        if top_n is not None and side_n is not None and top_n != side_n:
            logger.warning(
                "%s: the videos have %d and %d frames; using the first %d of each",
                self.description,
                top_n,
                side_n,
                min(top_n, side_n),
            )
        if self.side.fps and self.fps and abs(self.side.fps - self.fps) > 0.01 * self.fps:
            logger.warning(
                "%s: frame rates differ (%.2f and %.2f fps): frames are paired by index, "
                "so the side camera drifts in time",
                self.description,
                self.fps,
                self.side.fps,
            )
        counts = [n for n in (top_n, side_n) if n is not None]
        self.n_frames = min(counts) if counts else None
        self._open = True

    def close(self) -> None:
        """Release both files."""
        self.top.close()
        self.side.close()
        self._open = False

    def frames(self) -> Iterator[Frame]:
        """Frame ``i`` of both videos, until either ends."""
        for top, side in zip(self.top.frames(), self.side.frames(), strict=False):
            yield Frame(top.index, top.t, top.rgb, rgb2=side.rgb)
