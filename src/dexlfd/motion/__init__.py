"""Motion stage: hand keypoints -> end-effector pose, Euler angles, gripper and grasp.

Thesis Section 4.2, Eqs. (4.10)-(4.14); see :mod:`dexlfd.motion.definition`.
"""

from __future__ import annotations

from dexlfd.motion.definition import (
    GRIPPER_FROM_HAND,
    MOUNTS,
    PoseSeries,
    euler_from_keypoints,
    euler_from_quat,
    gripper_opening,
    hand_matrix_from_keypoints,
    hand_quat_from_euler,
    mount_quat,
    palm_matrix_from_keypoints,
    pose_from_keypoints,
    quat_from_euler,
)
from dexlfd.motion.demonstration import MotionConfig, demonstration_from_keypoints
from dexlfd.motion.episodes import episode_demonstrations, split_demonstration
from dexlfd.motion.gaps import Gap, fill_short_gaps, find_gaps
from dexlfd.motion.grasp import (
    GRASP_METHODS,
    GraspConfig,
    GraspResult,
    HandClosure,
    aperture_ratio,
    detect_grasp,
    drop_short_runs,
    finger_curl,
    grasp_state,
    hand_closure,
)
from dexlfd.motion.lifts import LiftEvent, lift_events
from dexlfd.motion.online import OnlineMotion, OnlinePose, demonstration_from_capture
from dexlfd.motion.phases import (
    EPISODE_KINDS,
    PHASES,
    Episode,
    HandPhases,
    PhaseConfig,
    hand_phases,
    track_phases,
)
from dexlfd.motion.quality import format_quality, jitter_mm, quality_report
from dexlfd.motion.smoothing import (
    SMOOTHING_METHODS,
    OneEuroFilter,
    SmoothingConfig,
    smooth_keypoints,
)
from dexlfd.motion.task_frame import TaskFrame, apply_frame, estimate_task_frame
from dexlfd.motion.trim import (
    TrimConfig,
    cut_demonstration,
    motion_span,
    trim_demonstration,
)

__all__ = [
    "EPISODE_KINDS",
    "GRASP_METHODS",
    "GRIPPER_FROM_HAND",
    "MOUNTS",
    "PHASES",
    "SMOOTHING_METHODS",
    "Episode",
    "Gap",
    "GraspConfig",
    "GraspResult",
    "HandClosure",
    "HandPhases",
    "LiftEvent",
    "MotionConfig",
    "OneEuroFilter",
    "OnlineMotion",
    "OnlinePose",
    "PhaseConfig",
    "PoseSeries",
    "SmoothingConfig",
    "TaskFrame",
    "TrimConfig",
    "aperture_ratio",
    "apply_frame",
    "cut_demonstration",
    "demonstration_from_capture",
    "demonstration_from_keypoints",
    "detect_grasp",
    "estimate_task_frame",
    "drop_short_runs",
    "episode_demonstrations",
    "euler_from_keypoints",
    "euler_from_quat",
    "fill_short_gaps",
    "find_gaps",
    "finger_curl",
    "format_quality",
    "grasp_state",
    "gripper_opening",
    "hand_closure",
    "hand_matrix_from_keypoints",
    "hand_phases",
    "hand_quat_from_euler",
    "jitter_mm",
    "lift_events",
    "motion_span",
    "mount_quat",
    "palm_matrix_from_keypoints",
    "pose_from_keypoints",
    "quality_report",
    "quat_from_euler",
    "smooth_keypoints",
    "split_demonstration",
    "track_phases",
    "trim_demonstration",
]
