"""Frame sources: video files, webcams, two webcams, Intel RealSense (live and recorded).

Every source is a context manager that always releases its file or device, and
an iterator of :class:`Frame`. :func:`open_source` parses the CLI's SOURCE
string:

==================  ==========================================================
``path/video.mp4``  any file OpenCV can read (RGB only)
``webcam:0``        a webcam by index
``webcams:0,1``     two webcams (top, side) for the thesis's two-camera method
``realsense``       a live RealSense (``realsense:SERIAL`` picks one), RGB-D
``rec.bag``         a RealSense recording: ``.bag`` (SDK < 2.58) or ``.db3``
``rec.db3``         (SDK 2.58+), played back as fast as it is read
==================  ==========================================================

RealSense needs the optional ``pyrealsense2`` package (and Debian's
``libusb-1.0-0``); it is imported only when a RealSense source is opened.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.capture.lifting import Intrinsics
from dexlfd.errors import DependencyNotInstalled, InvalidInput, SourceError

__all__ = [
    "Frame",
    "FrameSource",
    "RealSenseLive",
    "RealSenseRecording",
    "VideoFileSource",
    "WebcamPairSource",
    "WebcamSource",
    "open_source",
]

logger = logging.getLogger(__name__)

RECORDING_SUFFIXES = (".bag", ".db3")


@dataclass(frozen=True, slots=True)
class Frame:
    """One captured frame.

    ``rgb`` (H, W, 3) uint8 in RGB order; ``depth_m`` (H, W) float32 depth aligned
    to ``rgb`` [m] (0 = no reading) or None; ``rgb2`` the side camera of a pair.
    """

    index: int
    t: float  # [s] since the first frame
    rgb: np.ndarray
    depth_m: np.ndarray | None = None
    rgb2: np.ndarray | None = None


class FrameSource:
    """Base class: context manager + iterator of frames.

    Attributes: ``kind`` (str), ``description`` (str), ``fps`` (float or None),
    ``n_frames`` (int or None when unknown), ``intrinsics`` (:class:`Intrinsics` of
    the colour stream or None), ``has_depth`` (bool).
    """

    kind = "source"
    has_depth = False

    def __init__(self, max_frames: int | None = None) -> None:
        if max_frames is not None and int(max_frames) < 1:
            raise InvalidInput(f"max_frames must be >= 1, got {max_frames}")
        self.max_frames = None if max_frames is None else int(max_frames)
        self.description = self.kind
        self.fps: float | None = None
        self.n_frames: int | None = None
        self.intrinsics: Intrinsics | None = None
        self._open = False

    @property
    def native_size(self) -> tuple[int, int] | None:
        """(width, height) [px] of the frames as decoded, before resizing; None if unknown."""
        return None

    def open(self) -> None:
        """Acquire the device or file."""
        self._open = True

    def close(self) -> None:
        """Release the device or file (idempotent)."""
        self._open = False

    def __enter__(self) -> FrameSource:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def frames(self) -> Iterator[Frame]:
        """Yield frames until the source ends or ``max_frames`` were read."""
        raise NotImplementedError

    def __iter__(self) -> Iterator[Frame]:
        if not self._open:
            raise SourceError(f"{self.description}: use 'with source:' before iterating")
        return self.frames()

    def _limit(self, n: int | None) -> int | None:
        if self.max_frames is None:
            return n
        return self.max_frames if n is None else min(n, self.max_frames)


def _cv2() -> Any:
    import cv2

    # OpenCV's own [ WARN ]/[ERROR] lines (e.g. probing a missing webcam) would bury our one-line
    # errors; the failures they describe are reported by the sources themselves
    cv2.setLogLevel(0)  # silent (levels: 0 silent, 2 error, 3 warning)
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


class VideoFileSource(_OpenCvSource):
    """Any video file OpenCV can decode; frame times from its frame rate.

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

    def open(self) -> None:
        """Open the file; raises :class:`SourceError` if missing, empty or unreadable."""
        if not self.path.is_file():
            raise SourceError(f"{self.path}: no such video file")
        if self.path.stat().st_size == 0:
            raise SourceError(f"{self.path}: the file is empty (0 bytes), expected a video")
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
        self.n_frames = self._limit(count if count > 0 else None)
        self._open = True

    def frames(self) -> Iterator[Frame]:
        """Decode frames in order."""
        cv2 = _cv2()
        fps = self.fps or 30.0
        i = 0
        while self.max_frames is None or i < self.max_frames:
            ok, bgr = self._cap.read()
            if not ok or bgr is None:
                break
            rgb = cv2.cvtColor(_resize(bgr, self.resize_width), cv2.COLOR_BGR2RGB)
            yield Frame(i, i / fps, rgb)
            i += 1
        if i == 0:
            raise SourceError(f"{self.path}: no frame could be decoded (empty or corrupt video)")


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


# ---------------------------------------------------------------- RealSense


def _rs() -> Any:
    try:
        import pyrealsense2 as rs
    except ImportError as exc:
        raise DependencyNotInstalled(
            "pyrealsense2==2.59.1.11053",
            "Intel RealSense (and Debian's libusb-1.0-0: apt-get install libusb-1.0-0)",
        ) from exc
    return rs


def _intrinsics_from_rs(intr: Any) -> Intrinsics:
    return Intrinsics(
        int(intr.width),
        int(intr.height),
        float(intr.fx),
        float(intr.fy),
        float(intr.ppx),
        float(intr.ppy),
    )


class _RealSenseBase(FrameSource):
    """Shared RealSense pipeline: aligned colour + depth, intrinsics, depth scale."""

    has_depth = True

    def __init__(self, max_frames: int | None = None) -> None:
        super().__init__(max_frames)
        self._pipe: Any = None
        self._align: Any = None
        self._depth_scale = 0.001
        self._started = False

    def _configure(self, rs: Any, config: Any) -> None:
        raise NotImplementedError

    def open(self) -> None:
        """Start the pipeline (subclasses say what to read)."""
        rs = _rs()
        pipe = rs.pipeline()
        config = rs.config()
        self._configure(rs, config)
        try:
            profile = pipe.start(config)
        except RuntimeError as exc:
            raise SourceError(f"{self.description}: cannot start RealSense: {exc}") from exc
        self._pipe = pipe
        self._started = True
        try:
            self._after_start(rs, profile)
            dev = profile.get_device()
            sensor = dev.first_depth_sensor()
            self._depth_scale = float(sensor.get_depth_scale())
            color = profile.get_stream(rs.stream.color).as_video_stream_profile()
            self.intrinsics = _intrinsics_from_rs(color.get_intrinsics())
            self.fps = float(color.fps())
        except RuntimeError as exc:
            self.close()
            raise SourceError(
                f"{self.description}: needs a colour and a depth stream: {exc}"
            ) from exc
        self._align = rs.align(rs.stream.color)
        self._open = True

    def _after_start(self, rs: Any, profile: Any) -> None:
        pass

    def close(self) -> None:
        """Stop the pipeline."""
        if self._pipe is not None and self._started:
            with contextlib.suppress(RuntimeError):  # the SDK may have stopped at end of file
                self._pipe.stop()
        self._pipe = None
        self._started = False
        self._open = False

    def _wait(self) -> Any:
        return self._pipe.wait_for_frames()

    def frames(self) -> Iterator[Frame]:
        """Aligned RGB-D frames; times from the device timestamps."""
        i = 0
        t0: float | None = None
        last_t = -np.inf
        while self.max_frames is None or i < self.max_frames:
            fs = self._wait()
            if fs is None:
                break
            fs = self._align.process(fs)
            color, depth = fs.get_color_frame(), fs.get_depth_frame()
            if not color or not depth:
                continue
            ts = float(fs.get_timestamp()) / 1000.0
            t0 = ts if t0 is None else t0
            t = ts - t0
            if t <= last_t:  # duplicate or reordered timestamp
                continue
            last_t = t
            rgb = np.asanyarray(color.get_data()).copy()
            fmt = str(color.get_profile().format())
            if fmt.endswith("bgr8"):
                rgb = rgb[..., ::-1].copy()
            depth_m = np.asanyarray(depth.get_data()).astype(np.float32) * self._depth_scale
            yield Frame(i, t, rgb, depth_m=depth_m)
            i += 1
        if i == 0:
            raise SourceError(f"{self.description}: no colour+depth frame could be read")


class RealSenseLive(_RealSenseBase):
    """A connected RealSense camera (colour and depth at the same resolution)."""

    kind = "realsense"

    def __init__(
        self,
        serial: str | None = None,
        width: int = 640,
        height: int = 480,
        fps: int = 30,
        max_frames: int | None = None,
    ) -> None:
        super().__init__(max_frames)
        self.serial = serial
        self.mode = (int(width), int(height), int(fps))
        self.description = f"RealSense {serial or '(first found)'}"

    def _configure(self, rs: Any, config: Any) -> None:
        devices = rs.context().query_devices()
        serials = [d.get_info(rs.camera_info.serial_number) for d in devices]
        if not serials:
            raise SourceError("RealSense: camera not connected (no device found on USB)")
        if self.serial is not None and self.serial not in serials:
            raise SourceError(f"RealSense {self.serial}: camera not connected (found {serials})")
        if self.serial:
            config.enable_device(self.serial)
        w, h, fps = self.mode
        config.enable_stream(rs.stream.color, w, h, rs.format.rgb8, fps)
        config.enable_stream(rs.stream.depth, w, h, rs.format.z16, fps)
        self.n_frames = self.max_frames


class RealSenseRecording(_RealSenseBase):
    """A RealSense recording (``.bag`` or ``.db3``), read frame by frame, not in real time."""

    kind = "recording"

    def __init__(self, path: str | Path, max_frames: int | None = None) -> None:
        super().__init__(max_frames)
        self.path = Path(path)
        self.description = f"RealSense recording {self.path}"

    def _configure(self, rs: Any, config: Any) -> None:
        if not self.path.is_file():
            raise SourceError(f"{self.path}: no such recording")
        if self.path.stat().st_size == 0:
            raise SourceError(f"{self.path}: the recording is empty (0 bytes)")
        try:
            config.enable_device_from_file(str(self.path), repeat_playback=False)
        except RuntimeError as exc:
            raise SourceError(f"{self.path}: not a readable RealSense recording: {exc}") from exc
        self.n_frames = self.max_frames

    def _after_start(self, rs: Any, profile: Any) -> None:
        playback = profile.get_device().as_playback()
        playback.set_real_time(False)  # read every frame, as fast as we process them

    def _wait(self) -> Any:
        ok, fs = self._pipe.try_wait_for_frames(1000)
        return fs if ok else None


# ---------------------------------------------------------------- parsing


def open_source(
    spec: str | Path,
    *,
    max_frames: int | None = None,
    resize_width: int | None = None,
) -> FrameSource:
    """Build (not yet open) the source named by ``spec`` (see the module docstring)."""
    s = str(spec)
    low = s.lower()
    if low.startswith("webcams:"):
        parts = s.split(":", 1)[1].split(",")
        try:
            top, side = (int(p) for p in parts)
        except ValueError:
            raise InvalidInput(
                f"SOURCE {s!r}: expected 'webcams:TOP,SIDE' with two indices"
            ) from None
        return WebcamPairSource(top, side, max_frames=max_frames)
    if low.startswith("webcam:"):
        try:
            index = int(s.split(":", 1)[1])
        except ValueError:
            raise InvalidInput(f"SOURCE {s!r}: expected 'webcam:INDEX', e.g. webcam:0") from None
        return WebcamSource(index, max_frames=max_frames)
    if low == "realsense" or low.startswith("realsense:"):
        serial = s.split(":", 1)[1] if ":" in s else None
        return RealSenseLive(serial or None, max_frames=max_frames)
    path = Path(s)
    if path.suffix.lower() in RECORDING_SUFFIXES:
        return RealSenseRecording(path, max_frames=max_frames)
    if path.exists() or path.suffix:
        return VideoFileSource(path, max_frames=max_frames, resize_width=resize_width)
    raise InvalidInput(
        f"SOURCE {s!r} is not supported: give a video file, webcam:N, webcams:TOP,SIDE, "
        "realsense[:SERIAL], or a RealSense .bag/.db3 recording"
    )
