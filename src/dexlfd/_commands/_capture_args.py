"""Capture options shared by ``record`` and ``teleop``: SOURCE, lifting, camera pose, motion.

``add_capture_arguments`` registers the flags and ``record_config`` turns them into a
:class:`~dexlfd.experiments.record.RecordConfig` (no math here: the capture and motion
configurations are built from it in :mod:`dexlfd.experiments.record`).
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import positive_int
from dexlfd.errors import InvalidInput

__all__ = ["SOURCE_HELP", "add_capture_arguments", "record_config"]

logger = logging.getLogger(__name__)

SOURCE_HELP = (
    "SOURCE: a video file, webcam:N, webcams:TOP,SIDE, realsense[:SERIAL], "
    "or a RealSense recording (.bag/.db3)."
)


def add_capture_arguments(p: argparse.ArgumentParser, *, camera_pose: str = "identity") -> None:
    """Add SOURCE and the capture/motion flags; ``camera_pose`` is the preset's default."""
    from dexlfd.experiments.record import LIFT_CHOICES

    p.add_argument("source", metavar="SOURCE")
    p.add_argument("--max-frames", type=positive_int, help="stop after this many frames")
    p.add_argument(
        "--resize-width", type=positive_int, help="downscale video frames to this width [px]"
    )
    p.add_argument(
        "--lift",
        choices=LIFT_CHOICES,
        default="auto",
        help="3-D model (auto: pinhole with RGB-D, two_webcams with a pair, else assumed_depth)",
    )
    p.add_argument("--intrinsics", help="fx,fy,cx,cy [px] of the colour camera at full size")
    p.add_argument("--fov-deg", type=float, default=60.0, help="assumed horizontal field of view")
    p.add_argument("--assumed-depth-m", type=float, default=0.5, help="wrist depth for RGB only")
    p.add_argument("--extrinsics", help="camera->base 4x4 transform (.npy or text file)")
    p.add_argument(
        "--camera-pose",
        choices=("identity", "top-down", "front"),
        default=camera_pose,
        help="preset camera->base transform when --extrinsics is not given (default: %(default)s)",
    )
    p.add_argument("--camera-height-m", type=float, default=1.0, help="height for the presets")
    p.add_argument("--hand", choices=("auto", "right", "left"), default="auto")
    p.add_argument("--max-hands", type=int, default=1, help="hands to detect (2: choose one)")
    p.add_argument(
        "--mount", choices=("thesis", "top_grasp"), default="top_grasp",
        help="hand-to-gripper rotation: top_grasp (default; Franka Hand grasping from above: "
        "a flat palm-down hand gives a downward gripper) or thesis (90 deg about y, the "
        "thesis's qb-SoftHand mount)",
    )  # fmt: skip
    p.add_argument(
        "--euler-mode",
        choices=("palm", "heading", "thesis", "triad"),
        default="palm",
        help="hand orientation: palm (default; rigid frame of wrist, index MCP and pinky "
        "MCP: fingers do not turn it), or from wrist/thumb/index: Eq. 4.11 in the hand's "
        "heading frame, as printed (thesis), or the rigid wrist-thumb-index triad",
    )
    p.add_argument("--grasp-threshold-m", type=float, default=0.1)
    p.add_argument("--mirrored", action="store_true", help="frames are mirrored (selfie view)")


def _intrinsics(text: str | None) -> tuple[float, float, float, float] | None:
    if text is None:
        return None
    try:
        fx, fy, cx, cy = (float(v) for v in text.split(","))
    except ValueError:
        raise InvalidInput(f"--intrinsics: expected fx,fy,cx,cy, got {text!r}") from None
    return fx, fy, cx, cy


def _extrinsics(args: argparse.Namespace) -> np.ndarray:
    from dexlfd.capture import top_down_camera2base

    if args.extrinsics:
        path = Path(args.extrinsics)
        try:
            T = np.load(path) if path.suffix == ".npy" else np.loadtxt(path)
        except (OSError, ValueError) as exc:
            raise InvalidInput(f"--extrinsics {path}: cannot read a 4x4 matrix: {exc}") from exc
        return np.asarray(T, dtype=np.float64)
    h = args.camera_height_m
    if args.camera_pose == "identity":
        logger.warning(
            "no --extrinsics/--camera-pose: keypoints stay in the camera frame "
            "(x right, y down, z forward), not the robot base frame"
        )
    if args.camera_pose == "top-down":
        return top_down_camera2base(h)
    if args.camera_pose == "front":
        # camera looking along base +x at height h: cam x -> -y, cam y -> -z, cam z -> +x
        T = np.eye(4)
        T[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
        T[2, 3] = h
        return T
    return np.eye(4)


def record_config(args: argparse.Namespace, **changes: Any) -> Any:
    """The :class:`~dexlfd.experiments.record.RecordConfig` of the flags (``changes`` win)."""
    from dexlfd.experiments.record import RecordConfig

    fields = {
        "max_frames": args.max_frames,
        "resize_width": args.resize_width,
        "lift": args.lift,
        "intrinsics_px": _intrinsics(args.intrinsics),
        "fov_deg": args.fov_deg,
        "assumed_depth_m": args.assumed_depth_m,
        "camera2base": _extrinsics(args),
        "mirrored": args.mirrored,
        "hand": args.hand,
        "max_hands": args.max_hands,
        "grasp_threshold_m": args.grasp_threshold_m,
        "mount": args.mount,
        "euler_mode": args.euler_mode,
    }
    return RecordConfig(**{**fields, **changes})
