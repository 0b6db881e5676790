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
from dexlfd.motion.gaps import Gap, fill_short_gaps, find_gaps
from dexlfd.motion.grasp import (
    GRASP_METHODS,
    GraspConfig,
    GraspResult,
    aperture_ratio,
    detect_grasp,
    drop_short_runs,
    grasp_state,
)
from dexlfd.motion.online import OnlineMotion, OnlinePose, demonstration_from_capture
from dexlfd.motion.quality import format_quality, grasp_intervals, jitter_mm, quality_report
from dexlfd.motion.smoothing import (
    SMOOTHING_METHODS,
    OneEuroFilter,
    SmoothingConfig,
    smooth_keypoints,
)
from dexlfd.motion.trim import TrimConfig, motion_span, trim_demonstration

__all__ = [
    "SMOOTHING_METHODS",
    "OneEuroFilter",
    "SmoothingConfig",
    "TrimConfig",
    "format_quality",
    "grasp_intervals",
    "jitter_mm",
    "motion_span",
    "quality_report",
    "smooth_keypoints",
    "trim_demonstration",
    "GRASP_METHODS",
    "GraspConfig",
    "GraspResult",
    "aperture_ratio",
    "detect_grasp",
    "drop_short_runs",
    "GRIPPER_FROM_HAND",
    "Gap",
    "MOUNTS",
    "MotionConfig",
    "OnlineMotion",
    "OnlinePose",
    "PoseSeries",
    "demonstration_from_capture",
    "demonstration_from_keypoints",
    "euler_from_keypoints",
    "euler_from_quat",
    "fill_short_gaps",
    "find_gaps",
    "grasp_state",
    "gripper_opening",
    "hand_matrix_from_keypoints",
    "hand_quat_from_euler",
    "mount_quat",
    "palm_matrix_from_keypoints",
    "pose_from_keypoints",
    "quat_from_euler",
]
