"""``dexlfd record``: hand video or camera -> demonstration file (keypoints + EE motion).

Examples
--------
    dexlfd record hand.mp4 -o demo.npz --overlay overlay.mp4 --plot figures/
    dexlfd record realsense -o demo.npz --camera-pose top-down --camera-height-m 1.0
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import progress
from dexlfd.errors import InvalidInput

logger = logging.getLogger(__name__)

LIFT_CHOICES = ("auto", "pinhole", "angle", "two_webcams", "assumed_depth", "world_fit")


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


def _intrinsics(text: str | None, size: tuple[int, int] | None) -> Any:
    from dexlfd.capture import Intrinsics

    if text is None:
        return None
    try:
        fx, fy, cx, cy = (float(v) for v in text.split(","))
    except ValueError:
        raise InvalidInput(f"--intrinsics: expected fx,fy,cx,cy, got {text!r}") from None
    if size is None:
        raise InvalidInput("--intrinsics needs a source with a known image size")
    return Intrinsics(size[0], size[1], fx, fy, cx, cy)


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


def _video_size(source: Any) -> tuple[int, int] | None:
    import cv2

    cap = getattr(source, "_cap", None)
    if cap is None:
        return None
    return int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))


def run(args: argparse.Namespace) -> int:
    """Record, derive the motion and write the outputs."""
    from dexlfd.capture import CaptureConfig, LiftConfig, TrackerConfig, open_source, track_source
    from dexlfd.capture.session import HandCapture
    from dexlfd.io import save_demonstration
    from dexlfd.motion import MotionConfig, demonstration_from_capture

    out = Path(args.output)
    if not out.parent.is_dir():
        raise InvalidInput(f"-o/--output: folder {out.parent} does not exist")
    source = open_source(args.source, max_frames=args.max_frames, resize_width=args.resize_width)
    tracker = TrackerConfig(
        max_num_hands=args.max_hands,
        mirrored=args.mirrored,
        hand="right" if args.hand == "auto" else args.hand,
    )
    overlay_cm: Any = None
    with source:
        model = args.lift
        if model == "auto":
            model = (
                "pinhole"
                if source.has_depth
                else "two_webcams"
                if source.kind == "webcams"
                else "assumed_depth"
            )
        K = _intrinsics(args.intrinsics, _video_size(source))
        lift = LiftConfig(
            model=model,
            intrinsics=K,
            assumed_wrist_depth_m=args.assumed_depth_m,
            camera2base=_extrinsics(args),
        )
        cfg = CaptureConfig(tracker=tracker, lift=lift, assumed_hfov_deg=args.fov_deg)
        logger.info("record %s: lift=%s, tracker=%s", source.description, model, tracker)
        on_frame = None
        if args.overlay:
            from dexlfd.viz.capture import OverlayWriter

            overlay_cm = OverlayWriter(args.overlay, source.fps or 30.0)

            def on_frame(frame: Any, res: Any) -> None:
                label = f"{res.handedness} {res.score:.2f}" if res.valid else "no hand"
                overlay_cm.write(frame.rgb, res.uv_px if res.n_hands else None, label)

        t0 = time.perf_counter()
        ok = False
        try:
            with (
                HandCapture(cfg, source.intrinsics, has_depth=source.has_depth) as capture,
                progress(source.n_frames, "record", quiet=args.quiet) as bar,
            ):
                series = track_source(
                    source, capture=capture, callback=lambda i, t: bar.update(1), on_frame=on_frame
                )
            ok = True
        finally:
            if overlay_cm is not None:
                overlay_cm.close(ok=ok)
    elapsed = time.perf_counter() - t0
    hand = series.majority_hand if args.hand == "auto" else args.hand
    motion = MotionConfig(
        hand=hand,
        grasp_threshold=args.grasp_threshold_m,
        max_gap_s=args.max_gap_s,
        mount=args.mount,
        euler_mode=args.euler_mode,
    )
    demo = demonstration_from_capture(series, motion)
    save_demonstration(out, demo)
    n = demo.n_samples
    gaps = [g for g in demo.meta["gaps"]]
    logger.info(
        "%d frames, hand detected in %.1f %% (%s hand), %.1f fps processing, %d gap(s)%s; wrote %s",
        n,
        100 * series.detection_rate,
        hand,
        n / elapsed if elapsed > 0 else float("nan"),
        len(gaps),
        "" if not gaps else f" (longest {max(g['duration_s'] for g in gaps):.2f} s)",
        out,
    )
    if demo.meta["capture"].get("depth") == "approximate":
        logger.warning(
            "depth is APPROXIMATE (%s): RGB-only source", demo.meta["capture"]["lift_model"]
        )
    if args.overlay:
        logger.info("wrote overlay %s", args.overlay)
    if args.plot:
        from dexlfd.viz.capture import save_capture_figures

        for path in save_capture_figures(demo, args.plot):
            logger.info("wrote %s", path)
    return 0
