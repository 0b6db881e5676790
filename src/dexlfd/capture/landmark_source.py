"""A landmark recording replayed as a source, and a tracker tap that writes one.

Replay keeps one pipeline: :class:`LandmarkFileSource` is a
:class:`~dexlfd.capture.frame_source.FrameSource` whose frames carry no picture (a
read-only, zero-strided black image of the recorded size, so everything that reads a
frame's size works unchanged) and :class:`ReplayTracker` a
:class:`~dexlfd.capture.tracking.HandTracker` that returns, for each frame, the hands
stored for it. :class:`~dexlfd.capture.hand_capture.HandCapture` and
:func:`~dexlfd.capture.track_source` then run exactly as on a video.

:class:`TrackerTap` wraps a live tracker: it passes every result through unchanged
and logs it (:class:`~dexlfd.capture.landmark_log.LandmarkLog`), and measures
the background's motion on each frame (:mod:`dexlfd.capture.camera_motion`, on a
worker thread while the next frame is tracked) and each hand's carry cue
(:mod:`dexlfd.capture.carry_cue`), both from one set of small grey copies
(:mod:`dexlfd.capture.frame_grey`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd.capture.frame_grey import FrameGrey
from dexlfd.capture.frame_source import Frame, FrameSource
from dexlfd.capture.landmark_log import LandmarkLog
from dexlfd.capture.landmark_recording import (
    LandmarkRecording,
    load_landmark_recording,
    observations_at,
)
from dexlfd.capture.tracking import HandObservation, HandTracker
from dexlfd.errors import InvalidInput, SourceError

if TYPE_CHECKING:
    from dexlfd.capture.camera_motion import CameraMotionEstimator
    from dexlfd.capture.carry_cue import CarryCue
    from dexlfd.capture.hand_capture import CaptureConfig
    from dexlfd.capture.redetection import Redetector

__all__ = [
    "LANDMARK_SUFFIXES",
    "LandmarkFileSource",
    "ReplayTracker",
    "TrackerTap",
    "landmark_facts",
    "landmark_meta",
    "logging_depth",
    "redetection_summary",
    "tapped_tracker",
    "recorded_camera_motion",
    "replay_tracker",
]

logger = logging.getLogger(__name__)

LANDMARK_SUFFIXES = (".npz",)


class LandmarkFileSource(FrameSource):
    """The frames of a landmark recording, without pictures (``has_images`` False).

    ``fps`` is the median frame rate of ``t_s``; ``native_size`` the recorded
    ``frame_size_px``; frame times are the recording's ``t_s``. Use
    :meth:`tracker` as the capture's tracker.
    """

    kind = "landmarks"
    has_images = False

    def __init__(self, path: str | Path, max_frames: int | None = None) -> None:
        super().__init__(max_frames)
        self.path = Path(path)
        self.description = f"landmark recording {self.path}"
        self.recording: LandmarkRecording | None = None

    @property
    def native_size(self) -> tuple[int, int] | None:
        """The video's ``(width, height)`` [px] before any resizing, None before :meth:`open`.

        The recording's ``native_size_px`` when it says (a resized video), else
        ``frame_size_px``: ``--intrinsics`` are read at this size.
        """
        if self.recording is None:
            return None
        return self.recording.native_size_px or self.recording.size

    def open(self) -> None:
        """Load and check the file (:class:`~dexlfd.errors.InvalidFile` naming the array)."""
        rec = load_landmark_recording(self.path)
        self.recording = rec
        self.has_depth = rec.depth_m is not None  # an RGB-D source's depth at the landmarks
        self.intrinsics = rec.intrinsics  # the source's own (e.g. a RealSense's), or None
        dt = np.diff(rec.t_s)
        self.fps = float(1.0 / np.median(dt)) if dt.size else None
        self.n_frames = self._limit(rec.n_frames)
        self._open = True

    def close(self) -> None:
        """Forget the recording."""
        self._open = False

    def frames(self) -> Iterator[Frame]:
        """One picture-less frame per recorded frame."""
        rec = self._rec()
        w, h = rec.size
        blank = np.broadcast_to(np.zeros((1, 1, 3), np.uint8), (h, w, 3))
        n = rec.n_frames if self.n_frames is None else self.n_frames
        for i in range(n):
            yield Frame(i, float(rec.t_s[i]), blank)

    def tracker(self, mirrored: bool = False) -> ReplayTracker:
        """The tracker that replays this recording's hands (labels as ``mirrored`` says)."""
        return ReplayTracker(self._rec(), mirrored)

    def _rec(self) -> LandmarkRecording:
        if self.recording is None:
            raise SourceError(f"{self.description}: use 'with source:' first")
        return self.recording


class ReplayTracker:
    """A :class:`~dexlfd.capture.tracking.HandTracker` returning a recording's hands.

    ``detect(rgb, t)`` ignores the picture and returns the hands stored for the
    frame at time ``t`` (exactly one of the recording's ``t_s``), in the recorded
    order, with labels naming the person's hand (see
    :func:`~dexlfd.capture.landmark_recording.observations_at`).
    """

    def __init__(self, recording: LandmarkRecording, mirrored: bool = False) -> None:
        self.recording = recording
        self.mirrored = mirrored

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        """The recorded hands of the frame at ``t`` [s]."""
        t_s = self.recording.t_s
        i = int(np.searchsorted(t_s, t))
        if i >= t_s.size or not np.isclose(t_s[i], t, rtol=0.0, atol=1e-9):
            raise InvalidInput(f"no recorded frame at t = {t:g} s in the landmark recording")
        return observations_at(self.recording, i, self.mirrored)

    def close(self) -> None:
        """Nothing to release."""


class TrackerTap:
    """A :class:`~dexlfd.capture.tracking.HandTracker` that logs what another one finds.

    Parameters
    ----------
    inner : HandTracker
        The tracker that does the work (closed by :meth:`close`).
    log : LandmarkLog, optional
        Gets every frame's hands (tracker order and labels) for ``--save-landmarks``.
    motion : CameraMotionEstimator, optional
        Measures the background's motion on each frame, with the hands masked out.
    redetector : Redetector, optional
        Looks again for hands the tracker lost (:mod:`dexlfd.capture.redetection`);
        what it finds is reported and logged with the tracker's hands.
    cue : CarryCue, optional
        Sets each hand's ``carry`` (:mod:`dexlfd.capture.carry_cue`).
    """

    def __init__(
        self,
        inner: HandTracker,
        log: LandmarkLog | None = None,
        motion: CameraMotionEstimator | None = None,
        redetector: Redetector | None = None,
        cue: CarryCue | None = None,
    ) -> None:
        self.inner = inner
        self.log = log
        self.motion = motion
        self.redetector = redetector
        self.cue = cue
        self._pool: ThreadPoolExecutor | None = None  # the background-motion worker
        self._pending: Future[None] | None = None  # its measurement of the last frame
        self._next: tuple[np.ndarray, float] | None = None  # the frame announced
        self._ahead: tuple[np.ndarray, float, Future[list[HandObservation]]] | None = None
        self._ahead_pool: ThreadPoolExecutor | None = None  # the inner tracker's worker

    def announce(self, rgb: np.ndarray, t: float) -> None:
        """The frame :meth:`detect` will be called with after the coming one.

        ``inner.detect`` runs on it on a worker thread as soon as the coming frame's
        is done, while the caller works on that frame: the same calls, in the same
        order, one at a time (not while the inner tracker is :attr:`starting_up`:
        its mute of the native stderr would mute the caller's messages too).
        """
        self._next = (rgb, t)

    def _inner_detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        """``inner.detect(rgb, t)``, done ahead when announced; then the next one started."""
        ahead, self._ahead = self._ahead, None
        if ahead is not None and ahead[0] is rgb and ahead[1] == t:
            hands = ahead[2].result()
        else:
            if ahead is not None:
                ahead[2].result()  # announced but not asked for: done before this one
            hands = self.inner.detect(rgb, t)
        nxt, self._next = self._next, None
        if nxt is not None and not getattr(self.inner, "starting_up", False):
            if self._ahead_pool is None:
                self._ahead_pool = ThreadPoolExecutor(1, thread_name_prefix="dexlfd-tracker")
            self._ahead = (nxt[0], nxt[1], self._ahead_pool.submit(self.inner.detect, *nxt))
        return hands

    def detect(self, rgb: np.ndarray, t: float) -> list[HandObservation]:
        """``inner.detect`` (and the hands found again), logged.

        The background's motion of this frame is measured on a worker thread while
        the next frame is decoded and tracked (in frame order, one frame at a time);
        :meth:`close` waits for it. With :meth:`announce`, the next frame is tracked
        while this one is worked on.
        """
        hands = self._inner_detect(rgb, t)
        if self.redetector is not None:
            hands = self.redetector.update(rgb, t, hands)
        grey = FrameGrey(rgb)  # the small grey copies both pixel cues read, made once
        if self.cue is not None:
            hands = self.cue.update(rgb, hands, grey)
        h, w = rgb.shape[:2]
        if self.log is not None:
            self.log.add(t, hands, (w, h))
        if self.motion is not None:
            small, scale = self.motion.analysis_grey(grey)
            self._wait_motion()
            if self._pool is None:
                self._pool = ThreadPoolExecutor(1, thread_name_prefix="dexlfd-camera-motion")
            uvs = [obs.uv_px for obs in hands]
            self._pending = self._pool.submit(
                self.motion.update_grey, small, scale, (int(w), int(h)), uvs
            )
        return hands

    def _wait_motion(self) -> None:
        """Wait for the last frame's background motion (its error raised here)."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def close(self) -> None:
        """Finish the background motion; close the wrapped tracker (and the re-detector's)."""
        try:
            self._wait_motion()
        finally:
            if self._pool is not None:
                self._pool.shutdown()
                self._pool = None
            if self._ahead_pool is not None:  # a frame tracked ahead and never asked for
                self._ahead_pool.shutdown()
                self._ahead_pool = self._ahead = None
            self.inner.close()
            if self.redetector is not None:
                self.redetector.close()


def logging_depth(log: Any, cap: Any, on_frame: Callable[[Any, Any], None] | None) -> Any:
    """An ``on_frame`` that also logs the depth at the landmarks of every hand of the frame.

    Sampled as ``cap`` (a :class:`~dexlfd.capture.hand_capture.HandCapture`) samples it, so a
    replay lifts them alike.
    """

    def each(frame: Any, res: Any) -> None:
        if log.hands:
            depths = [cap.landmark_depth(frame, obs) for obs in log.hands[-1]]
            if all(d is not None for d in depths):
                log.add_depth(depths)
        if on_frame is not None:
            on_frame(frame, res)

    return each


def recorded_camera_motion(source: FrameSource, tap: Any, n: int) -> Any:
    """(n, 4) background motion per frame: measured while tracking, or the recording's."""
    if tap is not None and tap.motion is not None:
        rows = tap.motion.motion
    elif isinstance(source, LandmarkFileSource) and source.recording is not None:
        rows = source.recording.camera_motion
    else:
        return None
    return None if rows is None or rows.shape[0] < n else rows[:n]


def landmark_meta(source: FrameSource, capture_cfg: CaptureConfig) -> dict[str, Any]:
    """``meta`` of a landmark recording: where it came from and how it was tracked."""
    from dataclasses import asdict

    return {
        "source": source.description,
        "source_kind": source.kind,
        "fps": source.fps,
        "tracker": asdict(capture_cfg.tracker),
        "label_convention": "label_selfie: MediaPipe legacy Hands' own labels (selfie view)",
    }


def landmark_facts(source: FrameSource) -> dict[str, Any]:
    """The typed facts of a landmark recording of the opened ``source``.

    ``native_size_px``: ``--intrinsics`` given at this size apply to a resized
    recording too; ``intrinsics``: the source's own camera (e.g. a RealSense's), used
    on replay.
    """
    native = source.native_size
    return {
        "native_size_px": None if native is None else (int(native[0]), int(native[1])),
        "intrinsics": source.intrinsics,
    }


def replay_tracker(source: FrameSource, capture_cfg: CaptureConfig) -> Any:
    """The tracker of a landmark recording (its stored hands), None for a live source."""
    if isinstance(source, LandmarkFileSource):
        return source.tracker(capture_cfg.tracker.mirrored)
    return None


def redetection_summary(source: FrameSource, tap: Any) -> dict[str, int] | None:
    """``{"tries", "found"}``: crops looked at for lost hands and hands found again.

    Measured while tracking, or read from a landmark recording's ``redetected`` array
    (``tries`` is then unknown, -1); None when nothing was looked for.
    """
    again = getattr(tap, "redetector", None)
    if again is not None:
        return {"tries": int(again.n_tries), "found": int(again.n_redetected)}
    if isinstance(source, LandmarkFileSource) and source.recording is not None:
        flags = source.recording.redetected
        return None if flags is None else {"tries": -1, "found": int(np.sum(flags))}
    return None


def tapped_tracker(
    source: FrameSource, capture_cfg: CaptureConfig, keep_landmarks: bool, redetect: bool
) -> TrackerTap:
    """The live tracker of ``source``, tapped: background motion, landmark log, re-detection.

    ``keep_landmarks``: log every frame's hands; ``redetect``: look again for lost hands
    (one camera's pictures only: a pair's two views would mix their hands); the carry
    cue of every hand is measured on one camera's pictures.
    """
    from dexlfd.capture.camera_motion import CameraMotionEstimator
    from dexlfd.capture.tracking import make_tracker

    log = LandmarkLog(mirrored=capture_cfg.tracker.mirrored) if keep_landmarks else None
    again = cue = None
    if source.has_images and source.kind not in ("webcams", "videos"):
        from dexlfd.capture.carry_cue import CarryCue
        from dexlfd.capture.redetection import Redetector

        again = Redetector(capture_cfg.tracker) if redetect else None
        cue = CarryCue()
    tracker = make_tracker(capture_cfg.tracker)
    return TrackerTap(tracker, log, CameraMotionEstimator(), again, cue)
