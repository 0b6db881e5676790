"""The ``--robot franka://HOST`` branch of ``dexlfd simulate``: track a plan on a Franka arm.

Examples
--------
    dexlfd simulate plan.npz --robot franka://172.16.0.2 --approach -o rollout.npz
    dexlfd simulate plan.npz --robot franka://127.0.0.1 --controller pd -o r.npz --plot r.png
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

logger = logging.getLogger(__name__)

# library parameter -> flag of these options, for errors (cli.speak_cli)
ROBOT_FLAGS = {"robot URL": "--robot", "approach=True": "--approach"}

# simulate's options that describe the simulated plant: they do not apply to an arm
_PLANT_ONLY = {
    "payload": 0.0, "model_error": 0.1, "no_friction": False, "no_noise": False,
    "torque_delay": 1,
}  # fmt: skip


def add_robot_arguments(p: argparse.ArgumentParser) -> None:
    """``--robot``, ``--franka-generation`` and ``--approach``."""
    from dexlfd.robot.franka_bindings import GENERATIONS

    p.add_argument(
        "--robot", default="mujoco",
        help="'mujoco' (simulated Panda, default) or 'franka://HOST': a Franka arm or a "
        "Franka-protocol simulator over libfranka",
    )  # fmt: skip
    p.add_argument(
        "--franka-generation", choices=GENERATIONS, default="auto",
        help="franka: fer = a Franka Emika Panda (libfranka 0.9.2 via panda-python: pip "
        "install 'dexlfd[franka-fer]'); fr3 = a Franka Research 3 (pylibfranka 0.21.3: "
        "'dexlfd[franka]'); auto = ask the robot (its protocol version) with whichever is "
        "installed (default)",
    )  # fmt: skip
    p.add_argument(
        "--approach", action="store_true",
        help="franka: first move to the plan's start if the arm is elsewhere (<= 0.1 m/s)",
    )  # fmt: skip


def run_on_franka(
    args: argparse.Namespace, plan: Any, controller: Any, out: Path, ros2: Any = None
) -> Any:
    """Track ``plan`` on the arm at ``args.robot``; writes the rollout (partial on a stop).

    ``ros2``: a :class:`~dexlfd.io.ros2.Ros2Publisher` for the arm's joint states, or None.
    """
    from dexlfd.control import tracking_summary
    from dexlfd.control.franka import track_franka
    from dexlfd.io import save_rollout
    from dexlfd.robot.franka import FrankaArm
    from dexlfd.robot.libfranka import RobotStopped
    from dexlfd.robot.url import parse_robot_url

    host = parse_robot_url(args.robot)  # its error names the "robot URL" (FLAGS)
    for name, default in _PLANT_ONLY.items():
        if getattr(args, name, default) != default:
            logger.warning("--%s describes the simulated plant; ignored on %s", name, args.robot)
    if getattr(args, "video", None):
        logger.warning("--video renders the MuJoCo plant; ignored on %s", args.robot)
    logger.info("track %s on %s with %s", args.plan, args.robot, args.controller)
    with FrankaArm(host, generation=args.franka_generation) as arm:
        if ros2 is not None:
            from dexlfd._commands._ros2 import arm_state_listener

            arm.state_listener = arm_state_listener(ros2, args.ros2_rate_hz)
        try:
            rollout, stats = track_franka(
                arm, plan, controller, approach=args.approach, gripper=True
            )
        except RobotStopped as exc:
            if exc.rollout is not None:
                from dexlfd._commands._outputs import partial_path

                partial = save_rollout(partial_path(out), exc.rollout)
                logger.error(
                    "partial rollout (%d samples) written to %s", exc.rollout.n_samples, partial
                )
            raise
    save_rollout(out, rollout)
    s, err = stats.summary(), tracking_summary(rollout)
    logger.info(
        "wrote %s: %d cycles at %.0f Hz, %d missed, compute median %.0f µs; "
        "TCP error RMS %.3f mm, max %.3f mm, orientation max %.2f deg",
        out, s["n_cycles"], s["rate_hz"], s["missed_cycles"], s["compute_us_median"],
        1e3 * err["position_rms_m"], 1e3 * err["position_max_m"],
        np.degrees(err["orientation_max_rad"]),
    )  # fmt: skip
    return rollout


def run_protocol_study(args: argparse.Namespace) -> int:
    """``dexlfd experiment payload --robot franky-sim``: the study over the Franka protocol."""
    import json
    import sys

    from dexlfd._commands._common import ensure_output_dir, progress, tick_callback
    from dexlfd.experiments.payload_franka import (
        ProtocolPayloadConfig,
        format_protocol_table,
        run_protocol_payload,
    )
    from dexlfd.io import atomic_write
    from dexlfd.viz.franka import plot_protocol_vs_mujoco

    out = ensure_output_dir(args.output)
    kwargs: dict[str, Any] = {
        "duration": args.duration_s, "sim_root": Path(args.sim_root),
        "lockstep_s": args.sim_lockstep_s,
    }  # fmt: skip
    if args.controllers:
        kwargs["controllers"] = args.controllers  # parsed by experiment.controller_list
    cfg = ProtocolPayloadConfig(**kwargs)
    n = len(cfg.controllers) * len(cfg.payloads)
    with progress(n, "payload study (franka)", quiet=args.quiet) as bar:
        result = run_protocol_payload(cfg, callback=tick_callback(bar))
    sys.stdout.write(format_protocol_table(result) + "\n")
    runs = {(c, m, "protocol"): ro for (c, m), ro in result.rollouts.items()}
    if runs:
        title = format_protocol_table(result).splitlines()[1]  # what ran where
        fig = plot_protocol_vs_mujoco(runs, out / "payload_lift_z_franka.png", title=title)
        logger.info("wrote %s", fig)
    else:
        logger.warning("every run stopped early: no figure")
    if args.json:
        text = json.dumps(result.rows, indent=2)
        atomic_write(Path(args.json), lambda fh: fh.write(text.encode()))
        logger.info("wrote %s", args.json)
    return 0
