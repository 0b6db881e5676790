"""``dexlfd plan``: adapt a learned model to a new start, goal, duration and obstacles.

Examples
--------
    dexlfd plan model.npz --start 0.37,-0.34,0.22 --goal 0.51,0.11,0.31 -o plan.npz
    dexlfd plan model.npz --obstacle box:0.45,0,0.2,0.1,0.1,0.4 -o plan.npz --plot figs/
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

from dexlfd._commands._common import ensure_output_dir, output_file
from dexlfd.errors import InvalidInput

logger = logging.getLogger(__name__)


def _floats(text: str, n: int, flag: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError as exc:
        raise InvalidInput(f"{flag} {text!r}: expected {n} comma-separated numbers") from exc
    if len(values) != n:
        raise InvalidInput(f"{flag} {text!r}: expected {n} comma-separated numbers")
    return values


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name, help="plan a motion from a learned model (DMP: new start/goal, obstacles)"
    )
    p.add_argument("model", help="learned model .npz (dexlfd learn)")
    p.add_argument("--start", help="start position x,y,z [m] (default: the model's)")
    p.add_argument("--goal", help="goal position x,y,z [m] (default: the model's)")
    p.add_argument("--goal-quat", help="goal orientation x,y,z,w (unit; default: the model's)")
    p.add_argument("--duration-s", type=float, help="movement duration [s] (default: model's)")
    p.add_argument(
        "--obstacle",
        action="append",
        default=[],
        help="box:cx,cy,cz,sx,sy,sz or sphere:cx,cy,cz,r [m], optional @+z/@+x/.../@auto "
        "(avoidance side); repeatable",
    )
    p.add_argument("--margin-m", type=float, default=0.02, help="clearance [m] (default 0.02)")
    p.add_argument(
        "--no-variance", action="store_true", help="plain Gams coupling (Eq. 5.6), no variance"
    )
    p.add_argument(
        "--rate-hz", type=float, default=1000.0, help="output rate [Hz] (default: %(default)s)"
    )
    p.add_argument(
        "--place-surface-m",
        type=float,
        metavar="Z",
        help="height of the surface under the place point [m], >= 0 (the table is 0): "
        "lower the held object onto it before the gripper opens (default: release where "
        "the demonstrations did)",
    )
    p.add_argument(
        "--object-bottom-m",
        type=float,
        default=0.03,
        help="distance from the TCP down to the held object's bottom [m], >= 0 "
        "(default: %(default)s, the simulated box's half height)",
    )
    p.add_argument("-o", "--output", required=True, help="plan .npz to write")
    p.add_argument("--plot", metavar="DIR", help="write figures (like thesis Figs. 5.4-5.8)")
    return p


def run(args: argparse.Namespace) -> int:
    """Load the model, plan, write the plan (and figures)."""
    from dexlfd.io import load_model, save_plan
    from dexlfd.plan import PlanConfig, check_model_covariance, parse_obstacle, plan_from_model

    output_file(args.output, "-o/--output")
    if args.plot:
        ensure_output_dir(args.plot, "--plot")  # fail now, not after planning
    for flag, value in (("--place-surface-m", args.place_surface_m),
                        ("--object-bottom-m", args.object_bottom_m)):  # fmt: skip
        if value is not None and not (value >= 0.0 and value < 2.0):
            raise InvalidInput(f"{flag} {value!r}: expected a height in [0, 2) m")
    model = load_model(args.model)
    try:
        check_model_covariance(model)
    except InvalidInput as exc:
        raise InvalidInput(f"{args.model}: {exc}") from exc
    cfg = PlanConfig(
        start=None if args.start is None else _floats(args.start, 3, "--start"),
        goal=None if args.goal is None else _floats(args.goal, 3, "--goal"),
        goal_quat=None if args.goal_quat is None else _floats(args.goal_quat, 4, "--goal-quat"),
        duration=args.duration_s,
        rate_hz=args.rate_hz,
        obstacles=tuple(parse_obstacle(s) for s in args.obstacle),
        margin=args.margin_m,
        variance_aware=not args.no_variance,
        place_surface_z=args.place_surface_m,
        object_bottom=args.object_bottom_m,
    )
    logger.info("planning with %s", cfg)
    plan = plan_from_model(model, cfg)
    path = save_plan(args.output, plan)
    logger.info("wrote %s (%d samples, %.2f s)", path, plan.n_samples, plan.t[-1])
    if args.plot:
        from dexlfd.viz.planning import plot_plan

        out = ensure_output_dir(args.plot, "--plot")
        for fig_path in plot_plan(model, plan, out):
            logger.info("wrote %s", fig_path)
    return 0
