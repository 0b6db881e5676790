"""Capture stage: frame sources, hand tracking and lifting of landmarks to 3-D.

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
from dexlfd.capture.lifting import LIFT_MODELS, LiftConfig, LiftInput, lift, robust_depth
from dexlfd.capture.session import (
    CaptureConfig,
    FrameKeypoints,
    HandCapture,
    KeypointSeries,
    track_source,
)
from dexlfd.capture.sources import (
    Frame,
    FrameSource,
    RealSenseLive,
    RealSenseRecording,
    VideoFileSource,
    WebcamPairSource,
    WebcamSource,
    open_source,
)
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
    "LiftConfig",
    "LiftInput",
    "MediaPipeHands",
    "MediaPipeTasksHands",
    "RealSenseLive",
    "RealSenseRecording",
    "TrackerConfig",
    "TwoWebcamModel",
    "VideoFileSource",
    "WebcamPairSource",
    "WebcamSource",
    "deproject_angle",
    "deproject_pinhole",
    "lift",
    "lift_two_webcams",
    "open_source",
    "project_angle",
    "project_pinhole",
    "project_two_webcams",
    "robust_depth",
    "select_hand",
    "top_down_camera2base",
    "track_source",
]
