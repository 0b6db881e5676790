"""Capture stage: frame sources, hand tracking and lifting of landmarks to 3-D.

Modules: ``frame_source`` (Frame, FrameSource), ``opencv_sources`` and ``realsense``
(the sources), ``sources`` (open_source: SOURCE strings), ``tracking`` and
``tracking_tasks`` (MediaPipe hand trackers), ``landmark_recording`` (the tracker's raw
output as a file) and ``landmark_source`` (replaying one; the tracker tap that writes
one), ``camera_motion`` (is the camera moving?), ``association`` (hands across frames),
``camera_models`` (pixels <-> metres), ``rgb_lifting`` (RGB-only placement, per frame),
``recording_pose`` (RGB-only pose of a whole recording, offline),
``transforms`` (camera -> base), ``lifting`` (the model choice), ``keypoints``,
``session`` (HandCapture, per frame), ``source_tracking`` (track_source, a whole
source); calibration: ``board``, ``board_detection``, ``calibration_files``,
``calibration`` (camera -> base from a board).

``open_source`` -> :class:`HandCapture` / :func:`track_source` -> :class:`KeypointSeries`
(21 landmarks in the robot base frame per frame). The motion stage turns the series
into a :class:`~dexlfd.io.Demonstration` (``dexlfd.motion.demonstration_from_capture``).
"""

from __future__ import annotations

from dexlfd.capture.camera_models import (
    AngleModel,
    Intrinsics,
    TwoWebcamModel,
    deproject_angle,
    deproject_pinhole,
    lift_two_webcams,
    project_angle,
    project_pinhole,
    project_two_webcams,
)
from dexlfd.capture.frame_source import Frame, FrameSource
from dexlfd.capture.hand_capture import CaptureConfig, HandCapture
from dexlfd.capture.keypoints import FrameKeypoints, KeypointSeries
from dexlfd.capture.landmark_recording import (
    LandmarkRecording,
    load_landmark_recording,
    save_landmark_recording,
)
from dexlfd.capture.lifting import LIFT_MODELS, LiftConfig, LiftInput, lift, robust_depth
from dexlfd.capture.opencv_sources import (
    VideoFileSource,
    VideoPairSource,
    WebcamPairSource,
    WebcamSource,
)
from dexlfd.capture.realsense import RealSenseLive, RealSenseRecording
from dexlfd.capture.recording_pose import (
    RecordingPose,
    estimate_recording_pose,
    series_with_recording_pose,
)
from dexlfd.capture.recording_pose_config import RecordingPoseConfig
from dexlfd.capture.source_tracking import track_source
from dexlfd.capture.sources import open_source
from dexlfd.capture.tracking import (
    HAND_CONNECTIONS,
    HandObservation,
    HandTracker,
    MediaPipeHands,
    TrackerConfig,
    select_hand,
)
from dexlfd.capture.tracking_tasks import MediaPipeTasksHands  # registers "mediapipe-tasks"
from dexlfd.capture.transforms import top_down_camera2base

__all__ = [
    "HAND_CONNECTIONS",
    "LIFT_MODELS",
    "AngleModel",
    "CaptureConfig",
    "Frame",
    "FrameKeypoints",
    "FrameSource",
    "HandCapture",
    "HandObservation",
    "HandTracker",
    "Intrinsics",
    "KeypointSeries",
    "LandmarkRecording",
    "LiftConfig",
    "LiftInput",
    "MediaPipeHands",
    "MediaPipeTasksHands",
    "RealSenseLive",
    "RealSenseRecording",
    "RecordingPose",
    "RecordingPoseConfig",
    "TrackerConfig",
    "TwoWebcamModel",
    "VideoFileSource",
    "VideoPairSource",
    "WebcamPairSource",
    "WebcamSource",
    "deproject_angle",
    "deproject_pinhole",
    "estimate_recording_pose",
    "lift",
    "lift_two_webcams",
    "load_landmark_recording",
    "open_source",
    "project_angle",
    "project_pinhole",
    "project_two_webcams",
    "robust_depth",
    "save_landmark_recording",
    "select_hand",
    "series_with_recording_pose",
    "top_down_camera2base",
    "track_source",
]
