"""A whole recording captured offline: tracker, every frame tracked, the recording's pose.

The capture stage of ``dexlfd record``: :func:`recording_tracker` picks the tracker
of an opened source (a landmark recording's stored hands, or a live tracker tapped
for the camera's motion, a landmark log and re-detection), and
:func:`capture_recording` tracks every frame, replaces the per-frame lift by the
whole recording's pose where the lifting model allows it
(:func:`~dexlfd.capture.recording_pose.series_with_recording_pose`) and reports the
camera's motion and the hands found again.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from dexlfd.errors import InvalidInput

if TYPE_CHECKING:
    from dexlfd.capture.frame_source import FrameSource
    from dexlfd.capture.hand_capture import CaptureConfig
    from dexlfd.capture.keypoints import KeypointSeries
    from dexlfd.capture.landmark_recording import LandmarkRecording
    from dexlfd.capture.source_tracking import TrackJudge

__all__ = ["CapturedRecording", "RecordingTracker", "capture_recording", "recording_tracker"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class RecordingTracker:
    """The tracker of a recording and, for a live one, its tap (see :func:`recording_tracker`).

    ``tap`` is the :class:`~dexlfd.capture.landmark_source.TrackerTap` wrapping a live
    tracker (None on replay); ``landmark_meta`` the meta of the landmark recording it
    logs and ``landmark_facts`` its typed facts (None on replay).
    """

    tracker: Any
    tap: Any = None
    landmark_meta: dict[str, Any] | None = None
    landmark_facts: dict[str, Any] | None = None


@dataclass(frozen=True, slots=True)
class CapturedRecording:
    """What :func:`capture_recording` found.

    ``series`` carries ``meta["camera_motion"]`` and ``meta["redetection"]``;
    ``camera_motion`` is the (n, 4) background motion per frame (None when unknown);
    ``landmarks`` the tracker's raw output on every frame when it was logged.
    """

    series: KeypointSeries
    camera_motion: Any
    landmarks: LandmarkRecording | None


def recording_tracker(
    source: FrameSource, capture_cfg: CaptureConfig, *, keep_landmarks: bool, redetect: bool
) -> RecordingTracker:
    """The tracker of an opened ``source``: a landmark recording's, or a live one tapped.

    ``keep_landmarks``: log the tracker's raw output on every frame (one camera's video
    only); ``redetect``: look again for hands the tracker lost.

    Raises
    ------
    InvalidInput
        When landmarks are to be kept from a landmark recording or a camera pair.
    """
    from dexlfd.capture.landmark_source import (
        landmark_facts,
        landmark_meta,
        replay_tracker,
        tapped_tracker,
    )

    tracker = replay_tracker(source, capture_cfg)
    if keep_landmarks and (tracker is not None or source.kind in ("webcams", "videos")):
        raise InvalidInput(
            f"save_landmarks: {source.description} is "
            + ("already a landmark recording" if tracker is not None else "a camera pair")
            + "; landmarks are saved from one camera's video",
            param="save_landmarks",
        )
    if tracker is not None:
        return RecordingTracker(tracker)
    # a live tracker, tapped: the raw output, the camera's motion
    tap = tapped_tracker(source, capture_cfg, keep_landmarks, redetect)
    # while open
    return RecordingTracker(tap, tap, landmark_meta(source, capture_cfg), landmark_facts(source))


def capture_recording(
    source: FrameSource,
    capture_cfg: CaptureConfig,
    tracking: RecordingTracker,
    *,
    hand: str,
    callback: Callable[[int, float], None] | None = None,
    on_frame: Callable[[Any, Any], None] | None = None,
    judge: TrackJudge | None = None,
) -> CapturedRecording:
    """Track every frame of the opened ``source`` and estimate the recording's hand pose.

    With the ``pnp`` or ``pinhole`` lifting model the per-frame lift is replaced by the
    whole recording's pose (RGB-D: with the depth image's readings as measurements of
    the same smoother); the ``pnp`` lift frame by frame then only finds each frame's
    first plausible pose (unseeded, ungated: it decides which frames have a pose).
    ``callback``, ``on_frame``, ``hand`` and ``judge`` are
    :func:`~dexlfd.capture.source_tracking.track_source`'s. The tap of a live tracker
    is closed here, also on error.
    """
    from dexlfd.capture.camera_motion import camera_motion_report, log_camera_motion
    from dexlfd.capture.hand_capture import HandCapture
    from dexlfd.capture.landmark_source import (
        logging_depth,
        recorded_camera_motion,
        redetection_summary,
    )
    from dexlfd.capture.recording_pose import series_with_recording_pose
    from dexlfd.capture.source_tracking import track_source

    model = capture_cfg.lift.model
    tap = tracking.tap
    frame_size = source.native_size
    try:
        with HandCapture(
            capture_cfg,
            source.intrinsics,
            tracking.tracker,
            has_depth=source.has_depth,
            seeded_pnp=False,  # its poses are replaced by the whole recording's below
        ) as cap:
            frame_cb = on_frame
            if tap is not None and tap.log is not None and source.has_depth:
                frame_cb = logging_depth(tap.log, cap, on_frame)
            series = track_source(
                source, capture=cap, callback=callback, on_frame=frame_cb, hand=hand, judge=judge
            )
            # offline: the whole recording's pose, not frame by frame
            if model in ("pnp", "pinhole"):
                series = series_with_recording_pose(
                    series, cap.lift_cfg, measured_depth=model == "pinhole"
                )
    finally:
        if tap is not None:
            tap.close()  # HandCapture closes only the trackers it made
    motion = recorded_camera_motion(source, tap, series.t.size)
    image_size = series.image_size or frame_size
    camera = camera_motion_report(motion, image_size)
    log_camera_motion(camera, source.description)
    found = redetection_summary(source, tap)
    if found is not None and found["found"]:
        logger.info("lost hands found again in %d frame(s) by a crop search", found["found"])
    series = replace(series, meta={**series.meta, "camera_motion": camera, "redetection": found})
    landmarks = None
    if tap is not None and tap.log is not None:
        landmarks = tap.log.recording(
            camera_motion=motion, meta=tracking.landmark_meta, **(tracking.landmark_facts or {})
        )
    return CapturedRecording(series, motion, landmarks)
