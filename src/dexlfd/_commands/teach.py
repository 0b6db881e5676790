"""``dexlfd teach``: videos of a person's pick-and-place in, the simulated Panda doing it out.

Examples
--------
    dexlfd teach take1.mp4 take2.mp4 -o taught/      # report: taught/report.html
    dexlfd teach hand.mp4 -o out/ --pick 0.5,-0.2,0.03 --place 0.45,0.2,0.03,90
    dexlfd teach breakfast_landmarks.npz -o out/ --extrinsics camera2base.npy --fresh
    dexlfd teach hand.mp4 -o out/ --obstacle box:0.45,-0.05,0.15,0.06,0.06,0.3
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from typing import Any

from dexlfd._commands._capture_args import add_capture_arguments, record_config
from dexlfd.errors import DexlfdError, InvalidInput

logger = logging.getLogger(__name__)

OBJECT_EDGE_M = (0.01, 0.3)  # accepted --object-size-m edges [m]

HELP = "from videos of a person's pick-and-place to the simulated Panda doing it"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    from dexlfd._commands._fields import alias
    from dexlfd._commands._obstacle_args import add_obstacle_argument
    from dexlfd._commands._sim_args import add_sim_arguments

    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=HELP,
        description="Record every SOURCE (a video, a landmark recording .npz as record "
        "--save-landmarks writes it, or a demonstration .npz; one demonstration per "
        "pick-and-place), find each camera's task frame from the demonstrations (or take "
        "--extrinsics/--camera-pose), learn them together, plan the pick-and-place from "
        "the robot's ready pose to --pick and --place, simulate it and write "
        "DIR/report.html and DIR/teach.json. Exit 0 only when the object was placed. "
        "A rerun resumes finished stages.",
    )
    add_capture_arguments(p, many=True, grasp="closure")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="output folder (created; files another program wrote there are "
                   "never replaced)")  # fmt: skip
    p.add_argument(
        "--pick", metavar="X,Y,Z[,YAW_DEG]",
        help="where the object is now: the TCP position [m] (base frame) where the gripper "
        "closes, optionally its heading about z [deg] (default: 0.5,-0.15 at the object's "
        "half height over the table, or the demonstrated pick with --extrinsics)",
    )  # fmt: skip
    p.add_argument(
        "--place", metavar="X,Y,Z[,YAW_DEG]",
        help="where the object must go: the TCP position [m] where the gripper opens "
        "(default: the demonstrated displacement from pick to place applied at --pick)",
    )  # fmt: skip
    size = p.add_argument(
        "--object-size-m", metavar="S|X,Y,Z", dest="object_size",
        help="the object's size [m]: one edge (a cube) or x,y,z, each "
        f"{OBJECT_EDGE_M[0]:g}..{OBJECT_EDGE_M[1]:g} (default: from the grasp aperture)",
    )  # fmt: skip
    alias(p, size, "--object-size")
    add_obstacle_argument(p)
    add_sim_arguments(p, payload_help="mass of the object [kg]; the controller does not know it")
    p.set_defaults(payload=0.3)
    p.add_argument(
        "--fresh", action="store_true", help="rerun every stage (default: resume finished ones)"
    )
    return p


def _pose(text: str | None, flag: str) -> tuple[float, ...] | None:
    """``x,y,z[,yaw_deg]`` -> a tuple of 3 or 4 floats (the yaw in degrees)."""
    if text is None:
        return None
    from dexlfd._commands.plan import _pose as parse

    xyz, yaw = parse(text, flag)
    return (*xyz, math.degrees(yaw)) if yaw is not None else tuple(xyz)


def _object_size(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    lo, hi = OBJECT_EDGE_M
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) == 1:
        values *= 3
    if len(values) != 3 or not all(lo <= v <= hi for v in values):
        raise InvalidInput(
            f"--object-size-m {text!r}: expected one edge or x,y,z [m], each {lo:g}..{hi:g}"
        )
    return values[0], values[1], values[2]


def run(args: argparse.Namespace) -> int:
    """Check the inputs and outputs, run every stage, say how it ended."""
    from pathlib import Path

    import numpy as np

    from dexlfd._commands._obstacle_args import obstacles_from_args
    from dexlfd._commands._outputs import DIR, check_outputs
    from dexlfd.apps.teach import TeachConfig, foreign_outputs, run_teach
    from dexlfd.apps.teach_sources import check_sources
    from dexlfd.panda import check_workspace

    cfg_record = record_config(args, warn=False)
    check_sources(list(args.source))
    pick, place = _pose(args.pick, "--pick"), _pose(args.place, "--place")
    size = _object_size(args.object_size)
    obstacles = obstacles_from_args(args.obstacle)
    for flag, pose in (("--pick", pick), ("--place", place)):
        if pose is not None:  # out of reach: said before any work
            check_workspace(np.asarray(pose[:3]), flag)
    (out,) = check_outputs([("-o/--output", args.output, DIR)], inputs=args.source)
    assert out is not None
    foreign = foreign_outputs(out)
    if foreign:
        raise InvalidInput(
            f"-o/--output {out}: {', '.join(p.name for p in foreign)} already there and not "
            "written by dexlfd teach: remove them or choose another folder"
        )
    cfg = TeachConfig(
        sources=tuple(args.source), record=cfg_record, pick=pick, place=place,
        object_size=size, controller=args.controller, payload_kg=args.payload, seed=args.seed,
        model_error=args.model_error, friction=not args.no_friction, noise=not args.no_noise,
        obstacles=obstacles,
    )  # fmt: skip
    result = run_teach(cfg, Path(out), fresh=args.fresh)
    sys.stdout.write(f"report: {result.report}\nteach.json: {result.teach_json}\n")
    if not result.ok:
        raise DexlfdError(f"the object was not placed: {result.reason} (files in {out})")
    return 0
