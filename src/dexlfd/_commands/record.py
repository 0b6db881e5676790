"""``dexlfd record``: hand video or camera -> demonstration file (keypoints + EE motion).

Examples
--------
    dexlfd record hand.mp4 -o demo.npz --overlay overlay.mp4 --plot figures/
    dexlfd record realsense -o demo.npz --camera-pose top-down --camera-height-m 1.0
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

from dexlfd._commands._capture_args import SOURCE_HELP, add_capture_arguments, record_config
from dexlfd._commands._common import progress
from dexlfd._commands._outputs import DIR, check_outputs

logger = logging.getLogger(__name__)


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help="track a hand in a video or camera and write a demonstration",
        description=SOURCE_HELP,
    )
    add_capture_arguments(p)
    p.add_argument("-o", "--output", required=True, help="demonstration file (.npz)")
    p.add_argument("--overlay", help="write the video with the tracked skeleton here (.mp4)")
    p.add_argument("--plot", metavar="DIR", help="write a 3-D hand view and time series here")
    p.add_argument("--max-gap-s", type=float, default=0.1, help="fill gaps up to this long")
    p.add_argument(
        "--rerun",
        metavar="FILE.rrd",
        help="also write a rerun recording: camera "
        "images, 2-D/3-D hand, EE pose, gripper (open with `rerun FILE.rrd`)",
    )
    return p


def run(args: argparse.Namespace) -> int:
    """Record, derive the motion and write the outputs."""
    from dexlfd.experiments.record import record_demonstration
    from dexlfd.io import save_demonstration

    check_outputs(
        [("-o/--output", args.output, ".npz"), ("--overlay", args.overlay, ".mp4"),
         ("--plot", args.plot, DIR)],
        inputs=[args.source],
    )  # fmt: skip
    out = args.output
    cfg = record_config(args, max_gap_s=args.max_gap_s)
    from dexlfd.viz.rerun_log import open_rerun

    rr_log = open_rerun(args.rerun)  # the file appears only when the recording succeeds
    with progress(None, "record", quiet=args.quiet) as bar:

        def hint(n: int | None) -> None:
            bar.reset(total=n)

        res = record_demonstration(
            args.source, cfg, overlay=args.overlay,
            callback=lambda i, t: bar.update(1), n_frames_hint=hint,
            on_frame=None if rr_log is None else rr_log.capture_frame,
        )  # fmt: skip
    demo = res.demo
    save_demonstration(out, demo)
    if rr_log is not None:
        rr_log.demonstration(demo)
        rr_log.close()
    gaps = list(demo.meta["gaps"])
    logger.info(
        "%d frames, hand detected in %.1f %% (%s hand), %.1f fps processing, %d gap(s)%s; wrote %s",
        res.n_frames,
        100 * res.detection_rate,
        res.hand,
        res.n_frames / res.elapsed_s if res.elapsed_s > 0 else float("nan"),
        len(gaps),
        "" if not gaps else f" (longest {max(g['duration_s'] for g in gaps):.2f} s)",
        out,
    )
    if args.overlay:
        logger.info("wrote overlay %s", args.overlay)
    if args.plot:
        from dexlfd.viz.capture import save_capture_figures

        for path in save_capture_figures(demo, args.plot):
            logger.info("wrote %s", path)
    return 0
