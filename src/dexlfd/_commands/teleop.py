"""``dexlfd teleop``: a hand in a video or camera drives the simulated Panda, frame by frame.

Examples
--------
    dexlfd teleop hand.mp4 -o rollout.npz --video side_by_side.mp4 --max-frames 300
    dexlfd teleop webcam:0 --controller ntsm-pd --payload-kg 0.45 -o rollout.npz
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._capture_args import SOURCE_HELP, add_capture_arguments, record_config
from dexlfd._commands._common import bounded_int, progress
from dexlfd._commands._fields import add_params, alias
from dexlfd._commands._outputs import check_outputs, partial_path
from dexlfd._commands._sim_args import add_sim_arguments, sim_setup
from dexlfd.errors import SimulationDiverged

logger = logging.getLogger(__name__)

# MuJoCo's default offscreen framebuffer (visual/global offwidth x offheight) [px]: a
# larger render fails inside MuJoCo
MAX_RENDER_PX = (640, 480)

HELP = "teleoperate the simulated Panda with a hand in a video or camera"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    from dexlfd.apps.teleop import panda_teleop_config

    d = panda_teleop_config()
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=HELP,
        description=SOURCE_HELP
        + " Pose and gripper follow the hand (relative to first sight), filtered, clamped "
        "to the workspace and rate-limited; the robot holds while the hand is lost.",
    )
    add_capture_arguments(p, camera_pose="front")
    p.add_argument(
        "-o", "--output",
        help="rollout .npz to write (kept on a safety stop/Ctrl-C; as NAME.partial.npz "
        "when NAME.npz exists)",
    )  # fmt: skip
    p.add_argument("--video", help="side-by-side MP4 (.mp4): hand with skeleton | rendered robot")
    w, h = MAX_RENDER_PX
    width = p.add_argument(
        "--render-width-px", type=bounded_int(16, w), default=480, dest="render_width",
        help=f"robot render width [px], 16..{w} (MuJoCo's offscreen buffer; default: %(default)s)",
    )  # fmt: skip
    alias(p, width, "--render-width")
    height = p.add_argument(
        "--render-height-px", type=bounded_int(16, h), default=360, dest="render_height",
        help=f"robot render height [px], 16..{h} (default: %(default)s)",
    )  # fmt: skip
    alias(p, height, "--render-height")
    p.add_argument(
        "--rerun",
        metavar="FILE.rrd",
        help="also write a rerun recording (.rrd): camera, 2-D/3-D hand, target pose, TCP path, "
        "gripper (open with `rerun FILE.rrd`)",
    )
    add_sim_arguments(  # its --hand is the demonstrating hand: the Franka Hand here
        p,
        payload_help="object mass [kg] waiting between the open fingers at the start pose",
        end_effector=False,
    )
    from dexlfd.plan.teleop import TeleopConfig

    add_params(
        p, TeleopConfig, SHAPING_FIELDS, defaults={f: getattr(d, f) for f in SHAPING_FIELDS},
        dests={f: f for f in SHAPING_FIELDS},
    )  # fmt: skip
    return p


# TeleopConfig fields set by their flags (--reach-radius-m -> reach_radius)
SHAPING_FIELDS = (
    "reach_radius", "scale", "smoothing_s", "max_speed", "max_angular_speed", "max_gripper_speed",
)  # fmt: skip


def _outputs(args: argparse.Namespace) -> tuple[Path | None, Path | None]:
    """The checked rollout and video paths (None when not asked for)."""
    out, video, _ = check_outputs(
        [("-o/--output", args.output, ".npz"), ("--video", args.video, ".mp4"),
         ("--rerun", args.rerun, ".rrd")],
        inputs=[args.source],
    )  # fmt: skip
    if out is None and video is None and args.rerun is None:
        logger.warning("neither -o nor --video given: the run is only summarised")
    if video is not None:
        from dexlfd._gl import choose_gl_backend

        choose_gl_backend()  # offscreen EGL/OSMesa without a display; must precede mujoco
    return out, video


def _log_summary(s: dict[str, Any]) -> None:
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


def _end(result: Any, out: Path | None) -> int:
    """Exit status 0, or the interruption / safety stop the run ended with."""
    if result.interrupted:
        raise KeyboardInterrupt
    if result.stopped is not None:
        raise SimulationDiverged(
            f"safety stop: {result.stopped}; partial rollout "
            + (f"written to {out}" if out else "not written (no -o)")
        )
    return 0


def run(args: argparse.Namespace) -> int:
    """Open the source, teleoperate, write the rollout and video, log the summary."""
    out, video = _outputs(args)
    from dexlfd.viz.rerun_log import open_rerun

    rr_log = open_rerun(args.rerun)  # the file appears only when the run ends
    from dexlfd.apps.record import capture_config, motion_config
    from dexlfd.apps.teleop import TeleopRunConfig, panda_teleop_config, run_teleop, teleop_summary
    from dexlfd.capture import HandCapture, open_source
    from dexlfd.capture.landmark_source import replay_tracker
    from dexlfd.io import save_rollout
    from dexlfd.motion.online import OnlineMotion

    shaping = panda_teleop_config(**{name: getattr(args, name) for name in SHAPING_FIELDS})
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
        result: Any = None
        try:
            with (
                HandCapture(
                    capture_cfg,
                    source.intrinsics,
                    replay_tracker(source, capture_cfg),
                    has_depth=source.has_depth,
                ) as cap,  # a landmark recording: its stored hands
                progress(source.n_frames, "teleop", quiet=args.quiet) as bar,
            ):
                motion = OnlineMotion(cap, motion_config(rec, hand))

                def on_frame(step: Any, sim: Any) -> None:
                    if writer is not None:
                        writer(step, sim)
                    if rr_log is not None:
                        rr_log.teleop_frame(step)
                    bar.update(1)

                result = run_teleop(
                    source, motion, controller, model, cfg,
                    rng=np.random.default_rng([args.seed, 2]), on_frame=on_frame,
                    meta={"source": source.description, "capture": cap.describe()},
                )  # fmt: skip
            if out is not None:  # the rollout first: a video that fails must not cost it
                done = result.stopped is None and not result.interrupted
                out = save_rollout(out if done else partial_path(out), result.rollout)
                logger.info("wrote %s (%d samples)", out, result.rollout.n_samples)
        finally:
            if writer is not None:
                writer.close(ok=result is not None)
    if rr_log is not None:  # also after a safety stop or Ctrl-C, like -o
        rr_log.rollout(result.rollout)
        rr_log.close()
    _log_summary(teleop_summary(result))  # as the rollout's meta records it
    return _end(result, out)
