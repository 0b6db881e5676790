"""``dexlfd plan``: adapt a learned model to a new pick, place, start, goal and obstacles.

Examples
--------
    dexlfd plan model.npz --pick 0.5,-0.2,0.12 --place 0.45,0.25,0.12,30 -o plan.npz
    dexlfd plan model.npz --start 0.37,-0.34,0.22 --goal 0.51,0.11,0.31 -o plan.npz
    dexlfd plan model.npz --obstacle box:0.45,0,0.2,0.1,0.1,0.4 -o plan.npz --plot figs/
"""

from __future__ import annotations

import argparse
import logging
import math
from typing import Any

from dexlfd._commands._common import ensure_output_dir, phase_progress
from dexlfd._commands._fields import add_params, alias, metres_hint
from dexlfd._commands._obstacle_args import add_obstacle_argument, obstacles_from_args
from dexlfd._commands._outputs import DIR, check_outputs
from dexlfd.errors import InvalidInput

logger = logging.getLogger(__name__)


def _pose(text: str, flag: str) -> tuple[tuple[float, ...], float | None]:
    """``x,y,z[,yaw_deg]`` -> position [m] and yaw [rad] (None when not given)."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError as exc:
        raise InvalidInput(
            f"{flag} {text!r}: expected x,y,z [m] and optionally yaw_deg, comma-separated"
        ) from exc
    if len(values) not in (3, 4):
        raise InvalidInput(
            f"{flag} {text!r}: expected x,y,z [m] and optionally yaw_deg, comma-separated"
        )
    _refuse_millimetres(values[:3], text, flag)
    if not all(math.isfinite(v) for v in values[:3]):
        raise InvalidInput(f"{flag} {text!r}: x,y,z must be finite numbers [m]")
    if len(values) == 4 and not (math.isfinite(values[3]) and abs(values[3]) <= 360.0):
        raise InvalidInput(f"{flag} {text!r}: yaw_deg must be a finite angle in [-360, 360]")
    yaw = math.radians(values[3]) if len(values) == 4 else None
    return values[:3], yaw


def _refuse_millimetres(xyz: tuple[float, ...], text: str, flag: str) -> None:
    """A position typed in millimetres (``500,-200,120``) is refused with that hint."""
    hint = metres_hint(xyz)
    if hint:
        raise InvalidInput(f"{flag} {text!r}: outside 5 m of the base{hint}")


def _floats(text: str, n: int, flag: str, *, position: bool = True) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError as exc:
        raise InvalidInput(f"{flag} {text!r}: expected {n} comma-separated numbers") from exc
    if len(values) != n:
        raise InvalidInput(f"{flag} {text!r}: expected {n} comma-separated numbers")
    if not all(math.isfinite(v) for v in values):
        raise InvalidInput(f"{flag} {text!r}: expected {n} finite numbers")
    if n == 3 and position:  # a position [m]
        _refuse_millimetres(values, text, flag)
    return values


def _size(text: str) -> tuple[float, ...]:
    """``--object-size-m W,D,H`` [m]; sizes typed in millimetres get that hint."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) == 3 and not all(0.005 <= v <= 0.5 for v in values):
        hint = metres_hint(values, inside=lambda v: 0.005 <= v <= 0.5)
        raise InvalidInput(
            f"--object-size-m {text!r}: each size is in metres, in [0.005, 0.5]{hint}"
        )
    return _floats(text, 3, "--object-size-m", position=False)


def _start(text: str | None) -> tuple[float, ...] | str | None:
    """``--start``: x,y,z [m], ``ready`` or ``demonstrated``."""
    if text is None or text.strip() in ("ready", "demonstrated"):
        return None if text is None else text.strip()
    return _floats(text, 3, "--start")


HELP = "plan a motion from a learned model (DMP: new start/goal, obstacles)"


def _add_task_arguments(p: argparse.ArgumentParser) -> None:
    """The pick-and-place flags: grasp orientation, object, pick, place, hold."""
    from dexlfd.plan.config import PlanConfig

    p.add_argument(
        "--grasp-orientation", choices=["top-down", "demonstrated"], default="top-down",
        help="pick and place orientation: top-down (the TCP's z axis straight down, turned "
        "to the demonstrated or given heading; default) or demonstrated (the person's hand "
        "orientation, tilt included)",
    )  # fmt: skip
    size = p.add_argument(
        "--object-size-m", metavar="W,D,H", dest="object_size",
        help="the object's width (across the fingers), depth and height [m], each in "
        "[0.005, 0.5]: the placed object is an obstacle of this size for the retreat "
        "(default: width = depth = the learned closed gripper opening, height twice "
        "--object-bottom-m)",
    )  # fmt: skip
    alias(p, size, "--object-size")
    p.add_argument(
        "--pick", metavar="X,Y,Z[,YAW_DEG]",
        help="TCP position [m] (base frame) where the gripper closes on the object, and "
        "optionally its heading about z [deg]; within the Panda's reach, the object's bottom "
        "above the table (default: where the demonstrations grasped)",
    )  # fmt: skip
    p.add_argument(
        "--place", metavar="X,Y,Z[,YAW_DEG]",
        help="TCP position [m] where the gripper opens, at least 0.05 m from the pick "
        "(default: where the demonstrations released)",
    )  # fmt: skip
    add_params(p, PlanConfig, ["hold"])
    p.add_argument(
        "--whole-motion", action="store_true",
        help="plan the learned motion as one DMP, ignoring the model's grasp events "
        "(the thesis's Section 5.3.1 plans)",
    )  # fmt: skip


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    from dexlfd.plan.config import PlanConfig

    p: argparse.ArgumentParser = sub.add_parser(name, help=HELP)
    p.add_argument("model", help="learned model .npz (dexlfd learn)")
    p.add_argument(
        "--start", metavar="X,Y,Z|ready|demonstrated",
        help="start position x,y,z [m], or ready (the TCP at the Panda's ready pose) or "
        "demonstrated (where the person's hand started); default: ready for a "
        "pick-and-place (the robot moves from its own pose), the model's for --whole-motion",
    )  # fmt: skip
    p.add_argument(
        "--goal", metavar="X,Y,Z",
        help="goal position x,y,z [m]; default: for a pick-and-place, where the person's "
        "hand ended relative to the place when the arm can end there clear of every "
        "obstacle, else the ready pose; the model's for --whole-motion",
    )  # fmt: skip
    p.add_argument("--goal-quat", help="goal orientation x,y,z,w (unit; default: the model's)")
    _add_task_arguments(p)
    add_params(p, PlanConfig, ["duration"])
    add_obstacle_argument(p)
    add_params(p, PlanConfig, ["margin", "influence"])
    p.add_argument(
        "--no-variance", action="store_true",
        help="no variance term (level 0): the shaped coupling clears by the margin alone, "
        "the thesis coupling is Eq. 5.6",
    )  # fmt: skip
    p.add_argument(
        "--variance-measure", choices=["metres", "relative"], default="metres",
        help="metres: extra clearance = the demonstrations' std along the push [m], up to "
        "1.5 cm (default); relative: against the model's own 90th percentile",
    )  # fmt: skip
    p.add_argument(
        "--coupling", choices=["shaped", "thesis"], default="shaped",
        help="shaped: clear by the margin, at most 2 cm more (default); thesis: Eqs. "
        "5.6/5.7 as printed (u = c k1 k2 nu h; guarantees no clearance)",
    )  # fmt: skip
    add_params(p, PlanConfig, ["rate_hz", "place_surface_z", "object_bottom"])
    _add_dmp_arguments(p)
    from dexlfd._commands._ros2 import add_ros2_arguments

    add_ros2_arguments(p, states=False)
    p.add_argument("-o", "--output", required=True, help="plan .npz to write")
    p.add_argument(
        "--plot", metavar="DIR", help="write figures (PNG, like thesis Figs. 5.4-5.8) to DIR"
    )
    return p


def _add_dmp_arguments(p: argparse.ArgumentParser) -> None:
    """The DMP variant, gains and basis count, and the coupling's k1, k2, c (Eqs. 5.1-5.7)."""
    from dexlfd.plan.config import PlanConfig
    from dexlfd.plan.dmp_config import VARIANTS, DmpConfig

    g = p.add_argument_group("DMP and coupling (thesis Eqs. 5.1-5.7)")
    g.add_argument(
        "--dmp", choices=VARIANTS, default=DmpConfig().variant,
        help="original: Eq. 5.1 (forcing scaled by g - x0); modified: Eq. 5.5 in its "
        "published form (default: %(default)s)",
    )  # fmt: skip
    add_params(g, DmpConfig, ["K", "D", "n_basis"])
    add_params(g, PlanConfig, ["k1", "k2", "c"])


def run(args: argparse.Namespace) -> int:
    """Load the model, plan, write the plan (and figures)."""
    from dexlfd.io import load_model
    from dexlfd.plan import check_model_covariance

    check_outputs(
        [("-o/--output", args.output, ".npz"), ("--plot", args.plot, DIR)], inputs=[args.model]
    )
    if args.whole_motion and args.object_size is not None:
        raise InvalidInput(
            "--object-size-m sizes the object a pick-and-place carries; --whole-motion plans "
            "one motion without one: drop one of the two flags"
        )
    if args.ros2_publish:  # before planning: a missing extra is said before any work
        from dexlfd.io.ros2 import import_cyclonedds

        import_cyclonedds()
    # the flags' own form first (a position in millimetres), then the model
    pick, pick_yaw = (None, None) if args.pick is None else _pose(args.pick, "--pick")
    place, place_yaw = (None, None) if args.place is None else _pose(args.place, "--place")
    start = _start(args.start)
    goal = None if args.goal is None else _floats(args.goal, 3, "--goal")
    goal_quat = None if args.goal_quat is None else _floats(args.goal_quat, 4, "--goal-quat")
    size = None if args.object_size is None else _size(args.object_size)
    model = load_model(args.model)
    try:
        check_model_covariance(model)
    except InvalidInput as exc:
        raise InvalidInput(f"{args.model}: {exc}") from exc
    task = "motion" if args.whole_motion else "auto"
    if place is not None and args.place_surface_m is not None and task == "auto":
        z_set = args.place_surface_m + args.object_bottom_m  # the TCP setting it down
        if model.has_events and abs(place[2] - z_set) > 1e-3:
            raise InvalidInput(
                f"--place z {place[2]:g} m and --place-surface-m {args.place_surface_m:g} m "
                f"disagree: setting the object down on that surface puts the TCP at z = "
                f"{z_set:g} m (surface + --object-bottom-m {args.object_bottom_m:g}); "
                "give one of the two"
            )
    cfg = _config(args, {
        "pick": pick, "pick_yaw": pick_yaw, "place": place, "place_yaw": place_yaw,
        "start": start, "goal": goal, "goal_quat": goal_quat, "size": size,
    })  # fmt: skip
    logger.debug("planning with %s", cfg)
    _plan(args, model, cfg)
    return 0


def _config(args: argparse.Namespace, poses: dict[str, Any]) -> Any:
    """The :class:`~dexlfd.plan.PlanConfig` of the flags and the parsed positions."""
    from dexlfd.plan import PlanConfig
    from dexlfd.plan.dmp_config import DmpConfig

    return PlanConfig(
        pick=poses["pick"],
        pick_yaw=poses["pick_yaw"],
        place=poses["place"],
        place_yaw=poses["place_yaw"],
        hold=args.hold_s,
        task="motion" if args.whole_motion else "auto",
        on_limit="scale",
        feasible=True,
        start=poses["start"],
        grasp_orientation=args.grasp_orientation,
        object_size=poses["size"],
        goal=poses["goal"],
        goal_quat=poses["goal_quat"],
        duration=args.duration_s,
        rate_hz=args.rate_hz,
        obstacles=obstacles_from_args(args.obstacle),
        margin=args.margin_m,
        influence=args.influence_m,
        variance_aware=not args.no_variance,
        variance_measure=args.variance_measure,
        enforce_clearance=args.coupling == "shaped",
        place_surface_z=args.place_surface_m,
        object_bottom=args.object_bottom_m,
        dmp=DmpConfig(variant=args.dmp, K=args.dmp_k, D=args.dmp_d, n_basis=args.dmp_basis),
        k1=args.k1, k2=args.k2, c=args.coupling_c,
    )  # fmt: skip


def _plan(args: argparse.Namespace, model: Any, cfg: Any) -> None:
    """Plan, check the arm's links, write the plan (and figures) under one progress bar."""
    from dexlfd.io import save_plan
    from dexlfd.plan import plan_from_model
    from dexlfd.plan.pipeline import PHASE_ARM_POSTURE, PHASE_PLAN, PHASE_TIME_SCALING

    phases = [PHASE_PLAN, PHASE_TIME_SCALING] + ([PHASE_ARM_POSTURE] if cfg.obstacles else [])
    phases += ["write"] + (["figures"] if args.plot else [])
    with phase_progress(phases, "plan", quiet=args.quiet) as step:
        from dexlfd.robot import MujocoPandaModel  # the robot's kinematics: faster IK
        from dexlfd.robot.arm_posture import plan_arm_posture

        # with obstacles, the arm's links too: its elbow chosen to keep them clear
        plan = plan_from_model(model, cfg, MujocoPandaModel(), on_phase=step, arm=plan_arm_posture)
        step("write")
        path = save_plan(args.output, plan)
        logger.info("wrote %s (%d samples, %.2f s)", path, plan.n_samples, plan.t[-1])
        if args.ros2_publish:
            from dexlfd._commands._ros2 import publish_plan

            publish_plan(plan, args.ros2_rate_hz)
        if args.plot:
            from dexlfd.viz.planning import plot_plan

            step("figures")
            out = ensure_output_dir(args.plot, "--plot")
            for fig_path in plot_plan(model, plan, out):
                logger.info("wrote %s", fig_path)
