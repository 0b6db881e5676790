"""``dexlfd simulate``: track a plan on the simulated Panda and write the rollout.

Examples
--------
    dexlfd simulate plan.npz --controller ntsm-pd --payload 1.2 -o rollout.npz
    dexlfd simulate plan.npz --controller ntsm-pd-i -o r.npz --video r.mp4 --plot r.png
    dexlfd simulate plan.npz --robot franka://172.16.0.2 --approach -o r.npz
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._commands._common import bounded_int, progress, tick_callback
from dexlfd._commands._franka import ROBOT_FLAGS
from dexlfd._commands._outputs import DIR, check_outputs, partial_path
from dexlfd._commands._sim_args import SIM_FLAGS, add_sim_arguments, sim_setup
from dexlfd.errors import DexlfdError

logger = logging.getLogger(__name__)

# the delay line holds one torque vector per tick: 100 ticks (0.1 s) is far beyond any
# real arm's latency and keeps a run's memory and time bounded
MAX_TORQUE_DELAY = 100
FLAGS = {**SIM_FLAGS, "rerun recording": "--rerun"}  # library parameter -> flag (cli.speak_cli)


FLAGS.update(ROBOT_FLAGS)  # the robot URL and approach=True of the franka branch


HELP = "track a plan with a controller on the simulated Panda"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(name, help=HELP)
    p.add_argument("plan", help="plan .npz file (dexlfd plan contract)")
    add_sim_arguments(
        p,
        payload_help="mass of the object to pick [kg] (0: no object); the controller does "
        "not know it",
    )
    p.add_argument(
        "--torque-delay",
        type=bounded_int(0, MAX_TORQUE_DELAY),
        default=1,
        help=f"torque delay in control ticks of 1 ms, 0..{MAX_TORQUE_DELAY} (default: 1)",
    )
    p.add_argument(
        "-o", "--output", required=True,
        help="rollout .npz to write (a run cut short by a safety stop writes NAME.partial.npz "
        "when NAME.npz exists)",
    )  # fmt: skip
    p.add_argument("--video", help="also render an MP4 (.mp4; set MUJOCO_GL=egl without a display)")
    p.add_argument(
        "--plot", metavar="DIR|FILE.png",
        help="also write a tracking figure: into a folder DIR (DIR/rollout.png, as learn, "
        "plan and record take --plot DIR) or as FILE.png",
    )  # fmt: skip
    p.add_argument(
        "--rerun",
        metavar="FILE.rrd",
        help="also write a rerun recording (.rrd): plan, obstacles, TCP path/pose, gripper, "
        "joints (open with `rerun FILE.rrd`)",
    )
    from dexlfd._commands._franka import add_robot_arguments
    from dexlfd._commands._ros2 import add_ros2_arguments

    add_robot_arguments(p)
    add_ros2_arguments(p, states=True)
    return p


def run(args: argparse.Namespace) -> int:
    """Load, simulate, save."""
    from dexlfd.io import load_plan
    from dexlfd.robot import plan_world

    if args.plot and Path(args.plot).suffix.lower() != ".png":  # --plot DIR
        check_outputs([("--plot", args.plot, DIR)], inputs=[args.plan])
        args.plot = str(Path(args.plot) / "rollout.png")
    check_outputs(
        [("-o/--output", args.output, ".npz"), ("--plot", args.plot, ".png"),
         ("--video", args.video, ".mp4"), ("--rerun", args.rerun, ".rrd")],
        inputs=[args.plan],
    )  # fmt: skip
    out = Path(args.output)
    plan = load_plan(args.plan)
    plant, loop, controller, model = sim_setup(args, obstacles=plan_world(plan))
    logger.info(
        "simulate %s: controller %s, payload %.2f kg, model error %.0f %%, %.2f s",
        args.plan, args.controller, args.payload, 100 * args.model_error, plan.t[-1] - plan.t[0],
    )  # fmt: skip
    ros2 = _ros2_start(args, plan) if args.ros2_publish else None
    try:
        return _simulate(args, plan, out, ros2, plant, loop, controller, model)
    finally:
        if ros2 is not None:
            ros2.close()


def _ros2_start(args: argparse.Namespace, plan: Any) -> Any:
    """The ROS 2 publisher, with the plan published on it."""
    from dexlfd._commands._ros2 import publish_plan
    from dexlfd.io.ros2 import Ros2Publisher

    pub = Ros2Publisher()
    publish_plan(plan, args.ros2_rate_hz, pub)
    return pub


def _simulate(
    args: argparse.Namespace, plan: Any, out: Path, ros2: Any, plant: Any, loop: Any,
    controller: Any, model: Any,
) -> int:  # fmt: skip
    """Track the plan on the arm or the MuJoCo plant; write the rollout and the views."""
    from dexlfd.control import TrackingStopped, track, tracking_summary
    from dexlfd.control.grasp import carry_failure
    from dexlfd.io import save_rollout

    if args.robot != "mujoco":
        from dexlfd._commands._franka import run_on_franka

        rollout = run_on_franka(args, plan, controller, out, ros2)
        _write_rerun(args, plan, rollout)
        if args.plot:
            from dexlfd.viz.control import plot_rollout

            logger.info("wrote %s", plot_rollout(rollout, args.plot))
        return 0
    if ros2 is not None:
        from dexlfd._commands._ros2 import StateTap

        model = StateTap(model, ros2, args.ros2_rate_hz, loop.rate_hz)
    n_ticks = int((plan.t[-1] - plan.t[0]) * loop.rate_hz) // 100 + 1
    with progress(n_ticks, "simulate", quiet=args.quiet) as bar:
        try:
            rollout = track(
                plan, controller, model, plant, loop,
                rng=np.random.default_rng([args.seed, 2]), callback=tick_callback(bar),
            )  # fmt: skip
        except TrackingStopped as exc:
            partial = save_rollout(partial_path(out), exc.rollout)
            logger.error(
                "partial rollout (%d samples) written to %s", exc.rollout.n_samples, partial
            )
            _write_views(args, exc.rollout, plant)  # the figures matter most after a stop
            _write_rerun(args, plan, exc.rollout)
            raise
    save_rollout(out, rollout)
    summary = tracking_summary(rollout)
    logger.info(
        "wrote %s: %d samples, TCP error RMS %.3f mm, max %.3f mm, orientation max %.2f deg",
        out, rollout.n_samples, 1e3 * summary["position_rms_m"], 1e3 * summary["position_max_m"],
        np.degrees(summary["orientation_max_rad"]),
    )  # fmt: skip
    _write_views(args, rollout, plant)
    _write_rerun(args, plan, rollout)
    # a pick-and-place: the placement check decides the exit status (1: failed, said why)
    placement = rollout.placement
    if placement is not None and not placement.ok:
        logger.error("placement failed: %s; the rollout is in %s", placement.failure, out)
        return 1
    failure = carry_failure(rollout) if args.payload > 0 and placement is None else None
    if failure is not None:
        raise DexlfdError(
            f"the {args.payload:g} kg object was not carried: {failure}; the rollout is in "
            f"{out}. Does the plan close the gripper over the object and open it where "
            "the object should go?"
        )
    return 0


def _write_views(args: argparse.Namespace, rollout: Any, plant: Any) -> None:
    """The --plot figure and --video MP4 of a (possibly partial) rollout."""
    if args.plot:
        from dexlfd.viz.control import plot_rollout

        logger.info("wrote %s", plot_rollout(rollout, args.plot))
    if args.video:
        from dexlfd.viz.robot_video import render_rollout_video

        logger.info("rendering %d s of video ...", int(rollout.t[-1] - rollout.t[0]))
        render_rollout_video(rollout, plant, args.video)
        logger.info("wrote %s", args.video)


def _write_rerun(args: argparse.Namespace, plan: Any, rollout: Any) -> None:
    """The --rerun .rrd file: plan, obstacles and the (possibly partial) rollout."""
    if args.rerun:
        from dexlfd.viz.rerun_log import write_rerun

        write_rerun(args.rerun, plan=plan, rollouts=[("robot", rollout)])
