"""``dexlfd teleop``: a hand in a video or camera drives the simulated Panda, frame by frame.

Examples
--------
    dexlfd teleop hand.mp4 -o rollout.npz --video side_by_side.mp4 --max-frames 300
    dexlfd teleop webcam:0 --controller ntsm-pd --payload 0.45 -o rollout.npz
"""

from __future__ import annotations

import argparse
import logging
import os
from typing import Any

import numpy as np

from dexlfd._commands._capture_args import SOURCE_HELP, add_capture_arguments, record_config
from dexlfd._commands._common import output_file, progress
from dexlfd._commands._sim_args import add_sim_arguments, sim_setup
from dexlfd.errors import SimulationDiverged

logger = logging.getLogger(__name__)


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    from dexlfd.experiments.teleop import panda_teleop_config

    d = panda_teleop_config()
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help="teleoperate the simulated Panda with a hand in a video or camera",
        description=SOURCE_HELP
        + " Pose and gripper follow the hand (relative to first sight), filtered, clamped "
        "to the workspace and rate-limited; the robot holds while the hand is lost.",
    )
    add_capture_arguments(p, camera_pose="front", max_hands=1)
    p.add_argument("-o", "--output", help="rollout .npz to write (kept on a safety stop/Ctrl-C)")
    p.add_argument("--video", help="side-by-side MP4: hand with skeleton | rendered robot")
    p.add_argument("--render-width", type=int, default=480, help="robot render width [px]")
    p.add_argument("--render-height", type=int, default=360, help="robot render height [px]")
    add_sim_arguments(
        p, payload_help="object mass [kg] waiting between the open fingers at the start pose"
    )
    p.add_argument("--scale", type=float, default=d.scale, help="robot/hand displacement ratio")
    p.add_argument("--smoothing-s", type=float, default=d.smoothing_s,
                   help="low-pass time constant [s] (default: %(default)s)")  # fmt: skip
    p.add_argument("--max-speed", type=float, default=d.max_speed,
                   help="TCP speed limit [m/s] (default: %(default)s)")  # fmt: skip
    p.add_argument("--max-angular-speed", type=float, default=d.max_angular_speed,
                   help="TCP angular speed limit [rad/s] (default: %(default)s)")  # fmt: skip
    p.add_argument("--max-gripper-speed", type=float, default=d.max_gripper_speed,
                   help="gripper speed limit [m/s] (default: %(default)s)")  # fmt: skip
    p.add_argument("--reach-radius", type=float, default=d.reach_radius,
                   help="keep the TCP within this distance [m] of the shoulder "
                   "(default: %(default)s)")  # fmt: skip
    return p


def run(args: argparse.Namespace) -> int:
    """Open the source, teleoperate, write the rollout and video, log the summary."""
    out = None if args.output is None else output_file(args.output, "-o/--output")
    video = None if args.video is None else output_file(args.video, "--video", ".mp4")
    if out is None and video is None:
        logger.warning("neither -o nor --video given: the run is only summarised")
    if video is not None and "DISPLAY" not in os.environ:
        os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen; must precede importing mujoco
    from dexlfd.capture import HandCapture, open_source
    from dexlfd.experiments.record import capture_config, motion_config
    from dexlfd.experiments.teleop import TeleopRunConfig, panda_teleop_config, run_teleop
    from dexlfd.io import save_rollout
    from dexlfd.motion.online import OnlineMotion

    shaping = panda_teleop_config(
        reach_radius=args.reach_radius,
        scale=args.scale,
        smoothing_s=args.smoothing_s,
        max_speed=args.max_speed,
        max_angular_speed=args.max_angular_speed,
        max_gripper_speed=args.max_gripper_speed,
    )
    plant, loop, controller, model = sim_setup(args)
    rec = record_config(args)
    source = open_source(args.source, max_frames=rec.max_frames, resize_width=rec.resize_width)
    with source:
        fps = source.fps or 30.0
        cfg = TeleopRunConfig(shaping=shaping, plant=plant, loop=loop, frame_interval_s=1.0 / fps)
        capture_cfg = capture_config(source, rec)
        hand = "right" if args.hand == "auto" else args.hand
        logger.info(
            "teleop %s at %.1f fps: controller %s, payload %.2f kg, lift %s",
            source.description, fps, args.controller, args.payload, capture_cfg.lift.model,
        )  # fmt: skip
        writer: Any = None
        if video is not None:
            from dexlfd.viz.teleop import SideBySideVideo

            writer = SideBySideVideo(video, fps, args.render_width, args.render_height)
        ok = False
        try:
            with (
                HandCapture(capture_cfg, source.intrinsics, has_depth=source.has_depth) as cap,
                progress(source.n_frames, "teleop", quiet=args.quiet) as bar,
            ):
                motion = OnlineMotion(cap, motion_config(rec, hand))

                def on_frame(step: Any, sim: Any) -> None:
                    if writer is not None:
                        writer(step, sim)
                    bar.update(1)

                result = run_teleop(
                    source, motion, controller, model, cfg,
                    rng=np.random.default_rng([args.seed, 2]), on_frame=on_frame,
                    meta={"source": source.description, "capture": cap.describe()},
                )  # fmt: skip
            ok = True
        finally:
            if writer is not None:
                writer.close(ok=ok)
    if out is not None:
        save_rollout(out, result.rollout)
        logger.info("wrote %s (%d samples)", out, result.rollout.n_samples)
    s = result.rollout.meta["teleop_summary"]
    logger.info(
        "teleop summary: %d frames, hand detected in %.1f %%, latency frame->command median "
        "%.1f ms, p99 %.1f ms; TCP tracking RMS %.2f mm (max %.2f mm); %.2f s simulated "
        "in %.2f s (%.2fx real time)",
        s["frames"], 100 * s["detection_rate"], s["latency_median_ms"], s["latency_p99_ms"],
        1e3 * s["tracking_rms_m"], 1e3 * s["tracking_max_m"], s["simulated_s"], s["wall_s"],
        s["speed_vs_real_time"],
    )  # fmt: skip
    if s["detection_rate"] == 0.0:
        logger.warning("the hand was never detected: the robot held its start pose")
    if result.interrupted:
        raise KeyboardInterrupt
    if result.stopped is not None:
        raise SimulationDiverged(
            f"safety stop: {result.stopped}; partial rollout "
            + (f"written to {out}" if out else "not written (no -o)")
        )
    return 0
