"""Intel RealSense frame sources: a live camera and a recording (``.bag``/``.db3``), RGB-D.

Needs the optional ``pyrealsense2`` package (and Debian's ``libusb-1.0-0``); it is
imported only when a RealSense source is opened.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.frame_source import Frame, FrameSource
from dexlfd.errors import SourceError

__all__ = ["RECORDING_SUFFIXES", "RealSenseLive", "RealSenseRecording"]

RECORDING_SUFFIXES = (".bag", ".db3")


def _rs() -> Any:
    from dexlfd._extras import import_extra

    return import_extra(
        "pyrealsense2", "Intel RealSense (and Debian's libusb-1.0-0: apt-get install libusb-1.0-0)"
    )


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
