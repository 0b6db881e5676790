"""``dexlfd export``: a plan or rollout file to a ROS 2 bag or CSV."""

from __future__ import annotations

import argparse
import json
import logging
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import load_demonstration, load_model, load_plan, load_rollout

logger = logging.getLogger(__name__)

_LOADERS = {
    "demonstration": load_demonstration,
    "model": load_model,
    "plan": load_plan,
    "rollout": load_rollout,
}


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


def _kind_of(path: Path) -> str:
    if not path.is_file():
        raise InvalidFile(f"{path}: no such file")
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as data:
            kind = json.loads(str(data["meta"])).get("kind")
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
        raise InvalidFile(f"{path}: not a dexlfd file ({type(exc).__name__})") from exc
    if kind not in _LOADERS:
        raise InvalidFile(f"{path}: unknown kind {kind!r}; expected one of {sorted(_LOADERS)}")
    return str(kind)


def run(args: argparse.Namespace) -> int:
    """Load the file by its kind and export it."""
    from dexlfd._commands._outputs import NEW_DIR, check_outputs
    from dexlfd.io.csv import export_csv
    from dexlfd.io.rosbag import export_plan_rosbag, export_rollout_rosbag

    src = Path(args.input)
    fmt = args.format or ("csv" if args.output.lower().endswith(".csv") else "rosbag")
    check_outputs([("-o/--output", args.output, ".csv" if fmt == "csv" else NEW_DIR)], inputs=[src])
    kind = _kind_of(src)
    record = _LOADERS[kind](src)
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
