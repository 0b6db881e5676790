"""``dexlfd export``: dexlfd files to ROS 2 bags (MCAP or SQLite), CSV or a LeRobot dataset.

Examples
--------
    dexlfd export rollout.npz -o rollout_bag                   # ROS 2 bag, MCAP storage
    dexlfd export plan.npz -o plan_bag --format db3            # ROS 2 bag, SQLite storage
    dexlfd export plan.npz -o plan.csv                         # CSV
    dexlfd export demos/*.npz --format lerobot -o ds/          # LeRobotDataset v3.0
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

from dexlfd._commands._common import progress, tick_callback
from dexlfd.errors import InvalidInput
from dexlfd.io.kinds import LOADERS, kind_of

logger = logging.getLogger(__name__)

FORMATS = ("mcap", "db3", "rosbag", "csv", "lerobot")


HELP = "export dexlfd files to a ROS 2 bag (MCAP/db3), CSV or a LeRobot dataset"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=HELP,
    )
    p.add_argument(
        "inputs",
        nargs="+",
        metavar="INPUT",
        help="dexlfd .npz file(s) of at least 2 samples: one plan/rollout/demonstration "
        "(bag), any one file (csv), or demonstrations or rollouts (lerobot: one episode "
        "each, all of one kind: a dataset holds demonstrations or rollouts, not both)",
    )
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="output: a new bag folder (a name without a file suffix such as .txt), a .csv "
        "file, or a new dataset folder",
    )
    p.add_argument(
        "--format",
        choices=FORMATS,
        default=None,
        help="mcap: ROS 2 bag with MCAP storage; db3: ROS 2 bag with SQLite storage; "
        "rosbag: same as mcap; csv; lerobot: LeRobotDataset v3.0 folder. Default: csv if "
        "OUTPUT ends in .csv, lerobot for several inputs, else mcap",
    )
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        help="lerobot: frame rate of the dataset [Hz], > 0; every episode is resampled "
        "to uniform 1/fps steps (default: the recordings' own rate, the rounded median of "
        "the inputs; 30 for rollouts, which are simulated at 1 kHz; at most 20,000,000 frames, "
        "the duration of every input x the rate: its frames, size and time are said first); "
        "csv: one row per 1/fps s, the recorded sample nearest each time, at most the "
        "record's own rate (default: every sample)",
    )
    p.add_argument(
        "--task",
        default=None,
        help="lerobot only: task description stored with every episode (default: each "
        "input's own: 'pick and place', or, for a recording its quality report calls NOT "
        "USABLE, what it is instead)",
    )
    p.add_argument(
        "--video-size",
        type=video_size,
        default=None,
        metavar="WxH",
        help="lerobot only: the camera video's frame size [px], e.g. 320x240 (default: the "
        "source video's)",
    )
    return p


def video_size(text: str) -> tuple[int, int]:
    """``WxH`` [px] -> (width, height), each 16..8192."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        msg = f"expected WxH in pixels, e.g. 320x240, got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"width and height must be 16..8192 px, got {text!r}")
    return w, h


def _format(args: argparse.Namespace) -> str:
    if args.format is not None:
        return "mcap" if args.format == "rosbag" else str(args.format)
    if args.output.endswith(".csv"):
        return "csv"
    return "lerobot" if len(args.inputs) > 1 else "mcap"


# frames a second one quiet core makes and writes (~40,000 for a 300,000-sample
# demonstration, benchmarks/bench_lerobot_long.py), and parquet bytes a frame: 317 measured
# for demonstrations (21 keypoints); a rollout frame stores 184 bytes before compression
LEROBOT_FRAMES_PER_S = 35_000.0
LEROBOT_BYTES_PER_FRAME = {"demonstration": 320, "rollout": 185}


def _announce_lerobot(records: list[Any], fps: float | None, names: list[str]) -> int:
    """Say, before any frame is made, the dataset's frames, size and time; refuse past the bound.

    The bound (``MAX_FRAMES``) is the library's own: :func:`export_lerobot` refuses past it.
    """
    from dexlfd._commands._common import rough_duration
    from dexlfd.io import Demonstration
    from dexlfd.io.lerobot import check_frames, frame_count, frame_rate

    rate = frame_rate(records, fps)
    frames = frame_count(records, rate)
    kind = "demonstration" if isinstance(records[0], Demonstration) else "rollout"
    logger.info(
        "lerobot: %d %s(s) at %d Hz = %s frames: ~%.3g MB of parquet, about %s "
        "on one quiet core, without the camera video",
        len(records), kind, rate, f"{frames:,}",
        frames * LEROBOT_BYTES_PER_FRAME[kind] / 1e6,
        rough_duration(frames / LEROBOT_FRAMES_PER_S),
    )  # fmt: skip
    return check_frames(records, rate, names)


def run(args: argparse.Namespace) -> int:
    """Load the file(s) by kind and export them."""
    from dexlfd._commands._outputs import NEW_DIR, check_outputs

    fmt = _format(args)
    check_outputs(
        [("-o/--output", args.output, ".csv" if fmt == "csv" else NEW_DIR)], inputs=args.inputs
    )
    if args.fps is not None and not (0.0 < args.fps <= 10_000.0):
        raise InvalidInput(f"--fps must be in (0, 10000] Hz, got {args.fps}")
    for flag, value, takes in (("--fps", args.fps, ("lerobot", "csv")),
                               ("--task", args.task, ("lerobot",)),
                               ("--video-size", args.video_size, ("lerobot",))):  # fmt: skip
        if value is not None and fmt not in takes:
            raise InvalidInput(
                f"{flag} applies to --format {' and '.join(takes)} only; {fmt} writes every "
                "sample as it is"
            )
    records = []
    for name in args.inputs:
        src = Path(name)
        kind = kind_of(src)
        record = LOADERS[kind](src)
        if record.n_samples < 2:
            raise InvalidInput(
                f"{src}: a {kind} of {record.n_samples} sample has no motion to export "
                "(at least 2 samples)"
            )
        records.append((src, kind, record))
    if fmt == "lerobot":
        from dexlfd.io.lerobot import export_lerobot
        from dexlfd.io.lerobot._schema import pyarrow_modules

        pyarrow_modules()  # a missing extra is said before the size estimate
        for src, kind, _ in records:
            if kind not in ("demonstration", "rollout"):
                raise InvalidInput(
                    f"--format lerobot: {src} is a {kind} file; expected demonstrations or rollouts"
                )
        first_src, first_kind, _ = records[0]
        for src, kind, _ in records[1:]:
            if kind != first_kind:
                raise InvalidInput(
                    f"--format lerobot: {first_src} is a {first_kind}, {src} a {kind}; a "
                    "dataset holds one kind (their observation.state differs): export each "
                    "kind to its own dataset"
                )
        recs = [rec for _, _, rec in records]
        frames = _announce_lerobot(recs, args.fps, [str(src) for src, _, _ in records])
        with (
            progress(frames, "lerobot: frames", quiet=args.quiet) as rows,
            progress(None, "lerobot: camera video frames", quiet=args.quiet) as bar,
        ):
            out = export_lerobot(
                recs,  # type: ignore[arg-type]
                args.output,
                fps=args.fps,
                task=args.task,
                names=[str(src) for src, _, _ in records],
                video_size=args.video_size,
                callback=tick_callback(bar),
                on_frames=rows.update,
            )
        logger.info("wrote %s (LeRobotDataset v3.0, %d episodes)", out, len(records))
        return 0
    if len(records) != 1:
        raise InvalidInput(
            f"--format {fmt} takes one input file, got {len(records)}; "
            "use --format lerobot for several"
        )
    src, kind, record = records[0]
    if fmt == "csv":
        _export_csv(record, args.output, args.fps)
        return 0
    from dexlfd.io import rosbag

    writers = {
        "plan": rosbag.export_plan_rosbag,
        "rollout": rosbag.export_rollout_rosbag,
        "demonstration": rosbag.export_demonstration_rosbag,
    }
    if kind not in writers:
        raise InvalidInput(f"--format {fmt}: a {kind} file has no ROS 2 export; use --format csv")
    out = writers[kind](record, args.output, storage=fmt)  # type: ignore[operator]
    logger.info("wrote %s (%s, %d samples)", out, fmt, record.n_samples)
    return 0


def _export_csv(record: Any, output: str, fps: float | None) -> None:
    """Write ``record`` as CSV (every sample, or one row per ``1 / fps`` s) and say what."""
    import numpy as np

    from dexlfd.io.csv import export_csv, rows_at_rate

    out = export_csv(record, output, fps=fps)
    if fps is None:
        logger.info("wrote %s (csv, %d samples)", out, record.n_samples)
    else:
        rows = rows_at_rate(np.asarray(record.t), fps).shape[0]
        logger.info(
            "wrote %s (csv, %d rows at %g Hz from %d samples)", out, rows, fps, record.n_samples
        )
