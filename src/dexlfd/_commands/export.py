"""``dexlfd export``: a plan or rollout file to a ROS 2 bag or CSV."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

from dexlfd.errors import InvalidInput
from dexlfd.io.kinds import LOADERS, kind_of

logger = logging.getLogger(__name__)


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name, help="export a plan/rollout to a ROS 2 bag, or any dexlfd file to CSV"
    )
    p.add_argument("input", help="a dexlfd .npz file (plan, rollout, model, demonstration)")
    p.add_argument(
        "-o", "--output", required=True,
        help="output: a new bag folder (rosbag) or a .csv file (csv)",
    )  # fmt: skip
    p.add_argument(
        "--format",
        choices=("rosbag", "csv"),
        default=None,
        help="default: csv if OUTPUT ends in .csv, else rosbag",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Load the file by its kind and export it."""
    from dexlfd._commands._outputs import NEW_DIR, check_outputs
    from dexlfd.io.csv import export_csv
    from dexlfd.io.rosbag import export_plan_rosbag, export_rollout_rosbag

    src = Path(args.input)
    fmt = args.format or ("csv" if args.output.lower().endswith(".csv") else "rosbag")
    check_outputs([("-o/--output", args.output, ".csv" if fmt == "csv" else NEW_DIR)], inputs=[src])
    kind = kind_of(src)
    record = LOADERS[kind](src)
    if fmt == "csv":
        out = export_csv(record, args.output)
    elif kind == "plan":
        out = export_plan_rosbag(record, args.output)  # type: ignore[arg-type]
    elif kind == "rollout":
        out = export_rollout_rosbag(record, args.output)  # type: ignore[arg-type]
    else:
        raise InvalidInput(f"--format rosbag: a {kind} file has no ROS 2 export; use --format csv")
    logger.info("wrote %s (%s, %d samples)", out, fmt, record.n_samples)
    return 0
