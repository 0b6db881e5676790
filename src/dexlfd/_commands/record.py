"""``dexlfd record``: hand videos or a camera -> demonstration files (keypoints + EE motion).

Examples
--------
    dexlfd record hand.mp4 -o demo.npz --overlay overlay.mp4 --plot figures/
    dexlfd record a.mp4 b.mp4 c.mp4 -o demos/ --camera-pose front --camera-height-m 1.2
    dexlfd record realsense -o demo.npz --camera-pose top-down --camera-height-m 1.0
"""

from __future__ import annotations

import argparse
import logging
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from dexlfd._commands._capture_args import FLAGS as CAPTURE_FLAGS
from dexlfd._commands._capture_args import SOURCE_HELP, add_capture_arguments, record_config
from dexlfd._commands._common import bounded_int, ensure_output_dir, progress
from dexlfd._commands._outputs import DIR, check_outputs
from dexlfd.errors import InvalidInput

logger = logging.getLogger(__name__)

# library parameter -> flag, for errors (cli.speak_cli)
FLAGS = {**CAPTURE_FLAGS, "overlay video": "--overlay", "rerun recording": "--rerun"}


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help="track a hand in videos or a camera and write demonstrations",
        description=SOURCE_HELP + " Several SOURCEs: -o is a folder, one DIR/<name>.npz each; "
        "a video that fails is reported and the others are still recorded (exit 1 at the end).",
    )
    add_capture_arguments(p, many=True)
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="demonstration file (.npz), or a folder (several SOURCEs, or a name ending in /)",
    )
    p.add_argument(
        "--overlay",
        help="video with the tracked skeleton (.mp4; a folder with several SOURCEs)",
    )
    p.add_argument(
        "--plot", metavar="DIR", help="3-D hand view and time series here (per SOURCE: DIR/<name>/)"
    )
    p.add_argument(
        "--max-gap-s",
        type=float,
        default=0.1,
        help="interpolate gaps without a hand up to this long [s] (default: %(default)s); "
        "accepted 0..5",
    )
    p.add_argument(
        "--engine", choices=("local", "ray"), default="local",
        help="several SOURCEs: local = this machine's processes (default), ray = a local Ray "
        "cluster with --workers CPUs or the cluster at --ray-address",
    )  # fmt: skip
    p.add_argument(
        "--workers", type=bounded_int(1, 64), default=1,
        help="several SOURCEs: videos tracked at once, 1..64 (default: %(default)s)",
    )  # fmt: skip
    p.add_argument(
        "--ray-address",
        default=None,
        help="a running Ray cluster (host:6379, ray://host:10001 or auto) for --engine ray",
    )
    p.add_argument(
        "--rerun",
        metavar="FILE.rrd",
        help="also write a rerun recording (.rrd; one SOURCE only): camera images, 2-D/3-D "
        "hand, EE pose, gripper (open with `rerun FILE.rrd`)",
    )
    return p


def _jobs(args: argparse.Namespace, cfg: Any) -> list[Any]:
    """One :class:`~dexlfd.apps.record.RecordJob` per SOURCE, outputs checked first."""
    from dexlfd.apps.record import RecordJob

    sources: list[str] = list(args.source)
    as_dir = len(sources) > 1 or args.output.endswith(("/", os.sep)) or Path(args.output).is_dir()
    single = not as_dir
    if single:
        npz, _, _, _ = check_outputs(
            [("-o/--output", args.output, ".npz"), ("--overlay", args.overlay, ".mp4"),
             ("--plot", args.plot, DIR), ("--rerun", args.rerun, ".rrd")],
            inputs=sources,
        )  # fmt: skip
        outputs = [(str(npz), args.overlay, args.plot)]
    else:
        if args.rerun:
            raise InvalidInput("--rerun takes one SOURCE; record the videos apart to log each")
        folder = ensure_output_dir(args.output, "-o/--output")
        ov = ensure_output_dir(args.overlay, "--overlay") if args.overlay else None
        plot = ensure_output_dir(args.plot, "--plot") if args.plot else None
        stems = [Path(s).stem or s.replace(":", "_") for s in sources]
        dup = sorted({s for s in stems if stems.count(s) > 1})
        if dup:
            raise InvalidInput(
                f"-o/--output {folder}: several SOURCEs would write the same file "
                f"({', '.join(d + '.npz' for d in dup)}); rename the videos or record them apart"
            )
        outputs = [
            (
                str(folder / f"{stem}.npz"),
                str(ov / f"{stem}_overlay.mp4") if ov else None,
                str(plot / stem) if plot else None,
            )
            for stem in stems
        ]
    inputs = {Path(s).resolve() for s in sources if Path(s).exists()}
    for out, overlay, _ in outputs:
        for path, flag in ((out, "-o/--output"), (overlay, "--overlay")):
            if path is not None and Path(path).resolve() in inputs:
                raise InvalidInput(f"{flag} {path} is an input SOURCE: refusing to overwrite it")
    return [
        RecordJob(src, out, cfg, overlay, plot, show_progress=single, rerun=args.rerun)
        for src, (out, overlay, plot) in zip(sources, outputs, strict=True)
    ]


def _record_each(
    jobs: Sequence[Any],
    fn: Callable[[Any], Any],
    on_done: Callable[[Any], None],
    args: Any,
    on_progress: Callable[[], None] = lambda: None,
) -> list[Any]:
    """Run ``fn`` (a module-level, picklable per-video function) over ``jobs``, in order.

    The one place that loops over the videos, on :func:`~dexlfd.engine.map_items`
    (``--engine``, ``--workers``, ``--ray-address``): the same files whatever the engine.
    ``on_progress()`` is called as each video finishes, ``on_done(outcome)`` per video in
    input order once all have; a video whose worker failed outright becomes a failed
    outcome with the error.
    """
    from dexlfd.apps.record import RecordOutcome
    from dexlfd.engine import map_items

    if len(jobs) == 1 and args.engine == "local":
        results = [fn(jobs[0])]  # one video: in this process, with its frame progress bar
    else:
        outcomes = map_items(
            fn, jobs, labels=[j.source for j in jobs], engine=args.engine,
            workers=args.workers, address=args.ray_address, desc="record", quiet=True,
            callback=lambda i, seconds: on_progress(),
        )  # fmt: skip
        results = [
            o.value if o.error is None else RecordOutcome(j.source, j.output, error=o.error)
            for j, o in zip(jobs, outcomes, strict=True)
        ]
    for res in results:
        on_done(res)
    return results


def _report(outcome: Any) -> None:
    from dexlfd.motion import format_quality

    name = outcome.source
    if not outcome.ok:
        logger.error("%s: FAILED: %s", name, outcome.error)
        return
    q = outcome.quality
    fps = outcome.n_frames / outcome.elapsed_s if outcome.elapsed_s > 0 else float("nan")
    logger.info(
        "%d frames, hand detected in %.1f %% (%s hand), %.1f fps processing, %d gap(s); wrote %s",
        outcome.n_frames,
        100 * q["detection_rate"],
        q["hand"],
        fps,
        q["n_gaps"],
        ", ".join(outcome.written),
    )
    logger.info("%s", format_quality(name, q))


def run(args: argparse.Namespace) -> int:
    """Record every SOURCE, derive the motion and write the outputs."""
    from dexlfd.apps.record import record_job

    cfg = record_config(args, max_gap_s=args.max_gap_s)  # bad flag values: before any work
    jobs = _jobs(args, cfg)
    with progress(
        len(jobs) if len(jobs) > 1 else None, "record", quiet=args.quiet or len(jobs) == 1
    ) as bar:
        outcomes = _record_each(jobs, record_job, _report, args, lambda: bar.update(1))
    failed = [o for o in outcomes if not o.ok]
    if len(jobs) > 1:
        usable = sum(o.ok and o.quality.get("usable", False) for o in outcomes)
        logger.info(
            "recorded %d of %d video(s) (%d usable as demonstrations)%s",
            len(jobs) - len(failed),
            len(jobs),
            usable,
            "; failed: " + ", ".join(o.source for o in failed) if failed else "",
        )
    if failed:
        if len(jobs) == 1:
            raise InvalidInput(failed[0].error)
        return 1
    return 0
