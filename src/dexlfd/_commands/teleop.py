"""``dexlfd teleop``: a hand in a video or camera drives the simulated Panda, frame by frame.

Examples
--------
    dexlfd teleop hand.mp4 -o rollout.npz --video side_by_side.mp4 --max-frames 300
    dexlfd teleop webcam:0 --controller ntsm-pd --payload 0.45 -o rollout.npz
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._capture_args import FLAGS as CAPTURE_FLAGS
from dexlfd._commands._capture_args import SOURCE_HELP, add_capture_arguments, record_config
from dexlfd._commands._common import bounded_float, bounded_int, progress
from dexlfd._commands._outputs import check_outputs, partial_path
from dexlfd._commands._sim_args import SIM_FLAGS, add_sim_arguments, sim_setup
from dexlfd.errors import SimulationDiverged
from dexlfd.panda import CARTESIAN_LIMITS, GRIPPER_SPEED_MAX, REACH

V_MAX = CARTESIAN_LIMITS["translational_velocity"][0]  # [m/s]
W_MAX = CARTESIAN_LIMITS["rotational_velocity"][0]  # [rad/s]
# a low-pass longer than this makes a robot that never catches up with the hand
MAX_SMOOTHING_S = 2.0  # [s]

logger = logging.getLogger(__name__)

# MuJoCo's default offscreen framebuffer (visual/global offwidth x offheight) [px]: a
# larger render fails inside MuJoCo
MAX_RENDER_PX = (640, 480)
# library parameter -> flag, for errors (cli.speak_cli)
FLAGS = {
    **CAPTURE_FLAGS,
    **SIM_FLAGS,
    "reach_radius": "--reach-radius",
    "scale": "--scale",
    "smoothing_s": "--smoothing-s",
    "max_speed": "--max-speed",
    "max_angular_speed": "--max-angular-speed",
    "max_gripper_speed": "--max-gripper-speed",
    "render size": "--render-width/--render-height",
    "rerun recording": "--rerun",
    # capture options (shared with record)
    "assumed_hfov_deg": "--fov-deg",
    "hfov_deg": "--fov-deg",
    "camera2base": "--extrinsics",
    "max_frames": "--max-frames",
    "max_num_hands": "--max-hands",
}


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
    add_capture_arguments(p, camera_pose="front", max_hands=1)
    p.add_argument(
        "-o", "--output",
        help="rollout .npz to write (kept on a safety stop/Ctrl-C; as NAME.partial.npz "
        "when NAME.npz exists)",
    )  # fmt: skip
    p.add_argument("--video", help="side-by-side MP4 (.mp4): hand with skeleton | rendered robot")
    w, h = MAX_RENDER_PX
    p.add_argument(
        "--render-width", type=bounded_int(16, w), default=480,
        help=f"robot render width [px], 16..{w} (MuJoCo's offscreen buffer; default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--render-height", type=bounded_int(16, h), default=360,
        help=f"robot render height [px], 16..{h} (default: %(default)s)",
    )  # fmt: skip
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
    p.add_argument(
        "--scale", type=bounded_float(0.0, 10.0, lo_open=True), default=d.scale,
        help="robot/hand displacement ratio, (0, 10] (default: %(default)s)",
    )  # fmt: skip
    p.add_argument("--smoothing-s", type=bounded_float(0.0, MAX_SMOOTHING_S),
                   default=d.smoothing_s,
                   help=f"low-pass time constant [s], [0, {MAX_SMOOTHING_S:g}] "
                   "(default: %(default)s)")  # fmt: skip
    p.add_argument("--max-speed", type=bounded_float(0.0, V_MAX, lo_open=True),
                   default=d.max_speed,
                   help=f"TCP speed limit [m/s], (0, {V_MAX:g}] (the Panda's; "
                   "default: %(default)s)")  # fmt: skip
    p.add_argument("--max-angular-speed", type=bounded_float(0.0, W_MAX, lo_open=True),
                   default=d.max_angular_speed,
                   help=f"TCP angular speed limit [rad/s], (0, {W_MAX:g}] (the Panda's; "
                   "default: %(default)s)")  # fmt: skip
    p.add_argument("--max-gripper-speed",
                   type=bounded_float(0.0, GRIPPER_SPEED_MAX, lo_open=True),
                   default=d.max_gripper_speed,
                   help=f"gripper speed limit [m/s], (0, {GRIPPER_SPEED_MAX:g}] (the Franka "
                   "Hand's; default: %(default)s)")  # fmt: skip
    p.add_argument("--reach-radius", type=bounded_float(0.0, REACH, lo_open=True),
                   default=d.reach_radius,
                   help=f"keep the TCP within this distance [m] of the shoulder, (0, {REACH}] "
                   "(the Panda's reach; default: %(default)s)")  # fmt: skip
    return p


# TeleopConfig fields set by the flag of the same name (--reach-radius -> reach_radius)
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
