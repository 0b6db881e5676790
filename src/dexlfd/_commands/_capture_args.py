"""Capture options shared by ``record`` and ``teleop``: SOURCE, lifting, camera pose, motion.

``add_capture_arguments`` registers the flags and ``record_config`` turns them into a
:class:`~dexlfd.apps.record.RecordConfig` (no math here: the capture and motion
configurations are built from it in :mod:`dexlfd.apps.record`).
"""

from __future__ import annotations

import argparse
import logging
import re
from typing import Any

import numpy as np

from dexlfd._commands._fields import add_params
from dexlfd.errors import InvalidInput

__all__ = [
    "SOURCE_HELP",
    "add_capture_arguments",
    "record_config",
    "warn_camera_frame",
]

logger = logging.getLogger(__name__)

SOURCE_HELP = (
    "SOURCE: a video file, webcam:N, webcams:TOP,SIDE, videos:TOP.mp4,SIDE.mp4 (two videos "
    "filmed together by the top and side cameras), realsense[:SERIAL], "
    "a RealSense recording (.bag/.db3), or a landmark recording (.npz, as written by "
    "--save-landmarks: re-processed without the video)."
)


CAMERA_HEIGHT_M = (0.05, 10.0)  # accepted --camera-height-m [m]

# the help of each choice flag: (choices, help); the default comes from add_capture_arguments
_CHOICE_HELP: dict[str, tuple[tuple[str, ...], str]] = {
    "--camera-pose": (
        ("auto", "identity", "top-down", "front"),
        "preset camera->base transform when --extrinsics is not given (default: auto: "
        "identity, the camera's own frame, for record and teach, which estimates the task "
        "frame; front, a camera facing the person, for teleop)",
    ),
    "--hand": (
        ("auto", "right", "left"),
        "hand to record (default: auto, the hand that works: palm travel and aperture "
        "change). right/left name the person's hand on an unmirrored camera image "
        "(MediaPipe's selfie labels are swapped unless --mirrored); an error if never seen",
    ),
    "--mount": (
        ("thesis", "top_grasp"),
        "hand-to-gripper rotation: top_grasp (default; Franka Hand grasping from above: "
        "a flat palm-down hand gives a downward gripper) or thesis (90 deg about y, the "
        "thesis's qb-SoftHand mount)",
    ),
    "--euler-mode": (
        ("palm", "heading", "thesis", "triad"),
        "hand orientation: palm (default; rigid frame of wrist, index MCP and pinky "
        "MCP: fingers do not turn it), or from wrist/thumb/index: Eq. 4.11 in the hand's "
        "heading frame, as printed (thesis), or the rigid wrist-thumb-index triad",
    ),
    "--grasp": (
        ("closure", "adaptive", "ratio", "absolute"),
        "grasp detection (closure, record's default: the hand closes (aperture and finger "
        "curl) at a stop, carries and opens: one demonstration per pick-and-place; "
        "adaptive: open and closed levels of the thumb-index distance over hand size, read "
        "from each recording, with hysteresis; ratio: fixed levels of that ratio; "
        "absolute: the thesis's thumb-index distance below --grasp-threshold-m)",
    ),
    "--smoothing": (
        ("one_euro", "mean", "none"),
        "keypoint smoothing (default: one_euro: speed-adaptive low-pass, little lag; "
        "mean: the thesis's 5-frame mean filter)",
    ),
}


def _add_choice(p: argparse.ArgumentParser, flag: str, default: str) -> None:
    choices, help_ = _CHOICE_HELP[flag]
    p.add_argument(flag, choices=choices, default=default, help=help_)


def add_capture_arguments(
    p: argparse.ArgumentParser,
    *,
    camera_pose: str = "identity",
    many: bool = False,
    grasp: str = "adaptive",
) -> None:
    """Add SOURCE (several if ``many``) and the capture/motion flags.

    ``camera_pose`` is the preset ``--camera-pose auto`` (the default) stands for in this
    command, ``grasp`` the default of ``--grasp``; every other default is the recording's
    (:class:`~dexlfd.apps.record.RecordConfig`).
    """
    _add_source_arguments(p, many)
    # "-1000,1000,640,360" is a value (a list of numbers), not an unknown flag: without
    # this argparse answers "expected one argument" and never shows our message
    p._negative_number_matcher = re.compile(r"^-\.?\d[\d.,eE+-]*$")
    _add_camera_arguments(p)
    p.set_defaults(_auto_camera_pose=camera_pose)
    _add_hand_arguments(p, grasp)


def _add_source_arguments(p: argparse.ArgumentParser, many: bool) -> None:
    """SOURCE and how much of it: ``--max-frames``, ``--resize-width-px``."""
    p.add_argument("source", metavar="SOURCE", nargs="+" if many else None)
    from dexlfd.apps.record import RecordConfig

    add_params(
        p, RecordConfig, ["max_frames", "resize_width"], dests={"resize_width": "resize_width"}
    )


def _add_camera_arguments(p: argparse.ArgumentParser) -> None:
    """The lifting model, the camera's intrinsics and its pose in the robot base frame."""
    from dexlfd.apps.record import LIFT_CHOICES

    p.add_argument(
        "--lift",
        choices=LIFT_CHOICES,
        default="auto",
        help="3-D model (auto: pinhole with RGB-D, two_webcams with a pair of webcams or "
        "videos, else pnp: "
        "the hand's metric pose fitted to its pixels, depth from its apparent size; "
        "assumed_depth/world_fit: older RGB-only approximations)",
    )
    p.add_argument(
        "--intrinsics",
        metavar="FX,FY,CX,CY|FILE",
        help="colour camera intrinsics: fx,fy,cx,cy [px] at full video size, or a file with "
        "the 3x3 K (.npy, .json, OpenCV/ROS .yaml/.xml; see docs/capture.md)",
    )
    from dexlfd.capture import CaptureConfig, LiftConfig

    add_params(p, CaptureConfig, ["assumed_hfov_deg"])
    add_params(p, LiftConfig, ["assumed_wrist_depth_m"])
    p.add_argument(
        "--extrinsics",
        help="camera->base 4x4 rigid transform: .npy (as written by dexlfd calibrate) or text",
    )
    _add_choice(p, "--camera-pose", "auto")
    p.add_argument(
        "--camera-height-m",
        type=float,
        default=1.0,
        help="camera height above the base for the presets [m] (default: %(default)s); "
        f"accepted {CAMERA_HEIGHT_M[0]:g}..{CAMERA_HEIGHT_M[1]:g}",
    )


def _add_hand_arguments(p: argparse.ArgumentParser, grasp: str) -> None:
    """Which hand (``--mirrored``: selfie labels), and how it becomes the end-effector motion."""
    from dexlfd.apps.record import RecordConfig
    from dexlfd.capture import TrackerConfig
    from dexlfd.motion import MotionConfig

    _add_choice(p, "--hand", "auto")
    recording = RecordConfig()  # its defaults: two hands tracked, so the working one is chosen
    add_params(p, TrackerConfig, ["max_num_hands"],
               defaults={"max_num_hands": recording.capture.tracker.max_num_hands})  # fmt: skip
    _add_choice(p, "--mount", "top_grasp")
    _add_choice(p, "--euler-mode", "palm")
    _add_choice(p, "--grasp", grasp)
    add_params(p, MotionConfig, ["grasp_threshold"])
    _add_choice(p, "--smoothing", "one_euro")
    p.add_argument(
        "--no-trim",
        action="store_true",
        help="keep the idle start and end (default: cut them at motion onset/offset)",
    )
    p.add_argument("--mirrored", action="store_true", help="frames are mirrored (selfie view)")


def _intrinsics(
    text: str | None,
) -> tuple[tuple[float, float, float, float] | None, tuple[int, int] | None]:
    if text is None:
        return None, None
    from dexlfd.capture.calibration_files import load_intrinsics

    return load_intrinsics(text, "--intrinsics")


def _extrinsics(args: argparse.Namespace) -> np.ndarray:
    from dexlfd.capture import top_down_camera2base

    if args.extrinsics:
        from dexlfd.capture.calibration_files import load_extrinsics

        return load_extrinsics(args.extrinsics, "--extrinsics")
    h, pose = args.camera_height_m, camera_pose(args)
    if pose != "identity" and not CAMERA_HEIGHT_M[0] <= h <= CAMERA_HEIGHT_M[1]:
        raise InvalidInput(
            f"--camera-height-m: expected {CAMERA_HEIGHT_M[0]:g}..{CAMERA_HEIGHT_M[1]:g} m "
            f"above the robot base, got {h:g}"
        )
    if pose == "top-down":
        return top_down_camera2base(h)
    if pose == "front":
        # camera looking along base +x at height h: cam x -> -y, cam y -> -z, cam z -> +x
        T = np.eye(4)
        T[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
        T[2, 3] = h
        return T
    return np.eye(4)


def camera_pose(args: argparse.Namespace) -> str:
    """The ``--camera-pose`` preset, ``auto`` resolved for the command."""
    pose = str(args.camera_pose)
    return str(getattr(args, "_auto_camera_pose", "identity")) if pose == "auto" else pose


def warn_camera_frame(args: argparse.Namespace) -> None:
    """Warn when no camera->base transform is given (once the inputs are checked)."""
    if not args.extrinsics and camera_pose(args) == "identity":
        logger.warning(
            "no --extrinsics/--camera-pose: keypoints stay in the camera frame "
            "(x right, y down, z forward), not the robot base frame"
        )


def record_config(
    args: argparse.Namespace, *, warn: bool = True, max_gap_s: float | None = None
) -> Any:
    """The :class:`~dexlfd.apps.record.RecordConfig` of the flags, composed of the stage configs.

    ``max_gap_s`` (``record``'s ``--max-gap-s``; None: from the source's frame rate).
    ``warn=False``: the caller calls :func:`warn_camera_frame` itself, after it has
    checked the inputs (a missing file is reported before notes about the flags).
    """
    from dataclasses import replace

    from dexlfd.apps.record import RecordConfig

    intrinsics_px, intrinsics_size = _intrinsics(args.intrinsics)
    camera2base = _extrinsics(args)
    default = RecordConfig()
    capture = replace(
        default.capture,
        tracker=replace(default.capture.tracker, max_num_hands=args.max_hands,
                        mirrored=args.mirrored),
        lift=replace(default.capture.lift, assumed_wrist_depth_m=args.assumed_depth_m,
                     camera2base=camera2base),
        assumed_hfov_deg=args.fov_deg,
    )  # fmt: skip
    motion = replace(
        default.motion,
        grasp_threshold=args.grasp_threshold_m, grasp_method=args.grasp,
        smoothing=args.smoothing, mount=args.mount, euler_mode=args.euler_mode,
    )  # fmt: skip
    cfg = RecordConfig(
        capture=capture, motion=motion, lift=args.lift, hand=args.hand,
        max_frames=args.max_frames, resize_width=args.resize_width,
        intrinsics_px=intrinsics_px, intrinsics_size=intrinsics_size, trim=not args.no_trim,
        max_gap_s=max_gap_s,
    )  # fmt: skip
    if warn:
        warn_camera_frame(args)
    return cfg
