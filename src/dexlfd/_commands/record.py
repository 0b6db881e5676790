"""``dexlfd record``: hand video or camera -> demonstration file (keypoints + EE motion).

Examples
--------
    dexlfd record hand.mp4 -o demo.npz --overlay overlay.mp4 --plot figures/
    dexlfd record realsense -o demo.npz --camera-pose top-down --camera-height-m 1.0
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path
from typing import Any

from dexlfd._commands._capture_args import (
    SOURCE_HELP,
    add_capture_arguments,
    capture_config,
    motion_config,
)
from dexlfd._commands._common import progress
from dexlfd.errors import InvalidInput

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
    return p


def run(args: argparse.Namespace) -> int:
    """Record, derive the motion and write the outputs."""
    from dexlfd.capture import open_source, track_source
    from dexlfd.capture.session import HandCapture
    from dexlfd.io import save_demonstration
    from dexlfd.motion import demonstration_from_capture

    out = Path(args.output)
    if not out.parent.is_dir():
        raise InvalidInput(f"-o/--output: folder {out.parent} does not exist")
    source = open_source(args.source, max_frames=args.max_frames, resize_width=args.resize_width)
    overlay_cm: Any = None
    with source:
        cfg = capture_config(args, source)
        logger.info(
            "record %s: lift=%s, tracker=%s", source.description, cfg.lift.model, cfg.tracker
        )
        on_frame = None
        if args.overlay:
            from dexlfd.viz.capture import OverlayWriter

            overlay_cm = OverlayWriter(args.overlay, source.fps or 30.0)

            def on_frame(frame: Any, res: Any) -> None:
                label = f"{res.handedness} {res.score:.2f}" if res.valid else "no hand"
                overlay_cm.write(frame.rgb, res.uv_px if res.n_hands else None, label)

        t0 = time.perf_counter()
        ok = False
        try:
            with (
                HandCapture(cfg, source.intrinsics, has_depth=source.has_depth) as capture,
                progress(source.n_frames, "record", quiet=args.quiet) as bar,
            ):
                series = track_source(
                    source, capture=capture, callback=lambda i, t: bar.update(1), on_frame=on_frame
                )
            ok = True
        finally:
            if overlay_cm is not None:
                overlay_cm.close(ok=ok)
    elapsed = time.perf_counter() - t0
    hand = series.majority_hand if args.hand == "auto" else args.hand
    motion = motion_config(args, hand, max_gap_s=args.max_gap_s)
    demo = demonstration_from_capture(series, motion)
    save_demonstration(out, demo)
    n = demo.n_samples
    gaps = [g for g in demo.meta["gaps"]]
    logger.info(
        "%d frames, hand detected in %.1f %% (%s hand), %.1f fps processing, %d gap(s)%s; wrote %s",
        n,
        100 * series.detection_rate,
        hand,
        n / elapsed if elapsed > 0 else float("nan"),
        len(gaps),
        "" if not gaps else f" (longest {max(g['duration_s'] for g in gaps):.2f} s)",
        out,
    )
    if demo.meta["capture"].get("depth") == "approximate":
        logger.warning(
            "depth is APPROXIMATE (%s): RGB-only source", demo.meta["capture"]["lift_model"]
        )
    if args.overlay:
        logger.info("wrote overlay %s", args.overlay)
    if args.plot:
        from dexlfd.viz.capture import save_capture_figures

        for path in save_capture_figures(demo, args.plot):
            logger.info("wrote %s", path)
    return 0
