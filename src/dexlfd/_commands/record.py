"""``dexlfd record``: hand video or camera -> demonstration file (keypoints + EE motion).

Examples
--------
    dexlfd record hand.mp4 -o demo.npz --overlay overlay.mp4 --plot figures/
    dexlfd record realsense -o demo.npz --camera-pose top-down --camera-height-m 1.0
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import progress
from dexlfd.errors import InvalidInput

logger = logging.getLogger(__name__)


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help="track a hand in a video or camera and write a demonstration",
        description="SOURCE: a video file, webcam:N, webcams:TOP,SIDE, realsense[:SERIAL], "
        "or a RealSense recording (.bag/.db3).",
    )
    p.add_argument("source", metavar="SOURCE")
    p.add_argument("-o", "--output", required=True, help="demonstration file (.npz)")
    p.add_argument("--overlay", help="write the video with the tracked skeleton here (.mp4)")
    p.add_argument("--plot", metavar="DIR", help="write a 3-D hand view and time series here")
    p.add_argument("--max-frames", type=int, help="stop after this many frames")
    p.add_argument("--resize-width", type=int, help="downscale video frames to this width [px]")
    from dexlfd.experiments.record import LIFT_CHOICES

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
        default="identity",
        help="preset camera->base transform when --extrinsics is not given",
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
        choices=("heading", "thesis", "triad"),
        default="heading",
        help="orientation from wrist/thumb/index: Eq. 4.11 in the hand's heading frame, "
        "as printed, or the rigid triad (no Euler singularity)",
    )
    p.add_argument("--grasp-threshold-m", type=float, default=0.1)
    p.add_argument("--max-gap-s", type=float, default=0.1, help="fill gaps up to this long")
    p.add_argument("--mirrored", action="store_true", help="frames are mirrored (selfie view)")
    return p


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


def run(args: argparse.Namespace) -> int:
    """Record, derive the motion and write the outputs."""
    from dexlfd.experiments.record import RecordConfig, output_path, record_demonstration
    from dexlfd.io import save_demonstration

    out = output_path(args.output)
    cfg = RecordConfig(
        max_frames=args.max_frames,
        resize_width=args.resize_width,
        lift=args.lift,
        intrinsics_px=_intrinsics(args.intrinsics),
        fov_deg=args.fov_deg,
        assumed_depth_m=args.assumed_depth_m,
        camera2base=_extrinsics(args),
        mirrored=args.mirrored,
        hand=args.hand,
        max_hands=args.max_hands,
        grasp_threshold_m=args.grasp_threshold_m,
        max_gap_s=args.max_gap_s,
        mount=args.mount,
        euler_mode=args.euler_mode,
    )
    with progress(None, "record", quiet=args.quiet) as bar:

        def hint(n: int | None) -> None:
            bar.reset(total=n)

        res = record_demonstration(
            args.source, cfg, overlay=args.overlay,
            callback=lambda i, t: bar.update(1), n_frames_hint=hint,
        )  # fmt: skip
    demo = res.demo
    save_demonstration(out, demo)
    gaps = list(demo.meta["gaps"])
    logger.info(
        "%d frames, hand detected in %.1f %% (%s hand), %.1f fps processing, %d gap(s)%s; wrote %s",
        res.n_frames,
        100 * res.detection_rate,
        res.hand,
        res.n_frames / res.elapsed_s if res.elapsed_s > 0 else float("nan"),
        len(gaps),
        "" if not gaps else f" (longest {max(g['duration_s'] for g in gaps):.2f} s)",
        out,
    )
    if args.overlay:
        logger.info("wrote overlay %s", args.overlay)
    if args.plot:
        from dexlfd.viz.capture import save_capture_figures

        for path in save_capture_figures(demo, args.plot):
            logger.info("wrote %s", path)
    return 0
