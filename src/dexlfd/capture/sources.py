"""Choosing a frame source by name: :func:`open_source` parses a SOURCE string.

Every source is a context manager that always releases its file or device, and
an iterator of :class:`~dexlfd.capture.frame_source.Frame`
(:mod:`dexlfd.capture.frame_source`); the sources themselves are in
:mod:`dexlfd.capture.opencv_sources` and :mod:`dexlfd.capture.realsense`:

==================  ==========================================================
``path/video.mp4``  any file OpenCV can read (RGB only)
``webcam:0``        a webcam by index
``webcams:0,1``     two webcams (top, side) for the thesis's two-camera method
``videos:T,S``      two video files filmed together by the top and side cameras
                    (``videos:top.mp4,side.mp4``; file names without commas)
``realsense``       a live RealSense (``realsense:SERIAL`` picks one), RGB-D
``rec.bag``         a RealSense recording: ``.bag`` (SDK < 2.58) or ``.db3``
``rec.db3``         (SDK 2.58+), played back as fast as it is read
``hands.npz``       a landmark recording (:mod:`dexlfd.capture.landmark_recording`):
                    the tracker's stored output replayed, no images
==================  ==========================================================

RealSense needs the optional ``pyrealsense2`` package (and Debian's
``libusb-1.0-0``); it is imported only when a RealSense source is opened.
"""

from __future__ import annotations

from pathlib import Path

from dexlfd.capture.frame_source import FrameSource
from dexlfd.capture.landmark_source import LANDMARK_SUFFIXES, LandmarkFileSource
from dexlfd.capture.opencv_sources import (
    VideoFileSource,
    VideoPairSource,
    WebcamPairSource,
    WebcamSource,
)
from dexlfd.capture.realsense import RECORDING_SUFFIXES, RealSenseLive, RealSenseRecording
from dexlfd.errors import InvalidInput

__all__ = [
    "open_source",
]


MAX_WEBCAM_INDEX = 255  # Linux numbers video devices /dev/video0..255


def _webcam_index(text: str, spec: str, form: str) -> int:
    """A camera index 0..MAX_WEBCAM_INDEX from ``text`` (part of SOURCE ``spec``).

    OpenCV reads -1 as "any camera" and crashes on some systems when none is found, so
    negative indices are refused here with the rest.
    """
    try:
        index = int(text)
    except ValueError:
        index = -1
    if not 0 <= index <= MAX_WEBCAM_INDEX:
        raise InvalidInput(
            f"SOURCE {spec!r}: expected '{form}' with camera indices 0..{MAX_WEBCAM_INDEX}, "
            f"e.g. {form.split(':')[0]}:{'0,1' if ',' in form else '0'}"
        )
    return index


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
        if len(parts) != 2:
            raise InvalidInput(f"SOURCE {s!r}: expected 'webcams:TOP,SIDE' with two indices")
        top, side = (_webcam_index(p, s, "webcams:TOP,SIDE") for p in parts)
        return WebcamPairSource(top, side, max_frames=max_frames)
    if low.startswith("videos:"):
        parts = s.split(":", 1)[1].split(",")
        if len(parts) != 2 or not all(p.strip() for p in parts):
            raise InvalidInput(
                f"SOURCE {s!r}: expected 'videos:TOP,SIDE' with two video files "
                "(top camera first; file names without commas)"
            )
        top_file, side_file = (p.strip() for p in parts)
        return VideoPairSource(
            top_file, side_file, max_frames=max_frames, resize_width=resize_width
        )
    if low.startswith("webcam:"):
        index = _webcam_index(s.split(":", 1)[1], s, "webcam:INDEX")
        return WebcamSource(index, max_frames=max_frames)
    if low == "realsense" or low.startswith("realsense:"):
        serial = s.split(":", 1)[1] if ":" in s else None
        return RealSenseLive(serial or None, max_frames=max_frames)
    path = Path(s)
    if path.suffix.lower() in LANDMARK_SUFFIXES:
        if resize_width is not None:
            raise InvalidInput(
                f"resize_width: {s} is a landmark recording, which has no images to resize",
                param="resize_width",
            )
        return LandmarkFileSource(path, max_frames=max_frames)
    if path.suffix.lower() in RECORDING_SUFFIXES:
        return RealSenseRecording(path, max_frames=max_frames)
    if path.exists() or path.suffix:
        return VideoFileSource(path, max_frames=max_frames, resize_width=resize_width)
    raise InvalidInput(
        f"SOURCE {s!r} is not supported: give a video file, webcam:N, webcams:TOP,SIDE, "
        "videos:TOP,SIDE, "
        "realsense[:SERIAL], a RealSense .bag/.db3 recording, or a landmark recording (.npz)"
    )
