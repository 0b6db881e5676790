"""``dexlfd record``: hand videos or a camera -> demonstration files (keypoints + EE motion).

Examples
--------
    dexlfd record hand.mp4 -o demo.npz --overlay overlay.mp4 --plot figures/
    dexlfd record a.mp4 b.mp4 c.mp4 -o demos/ --camera-pose front --camera-height-m 1.2
    dexlfd record realsense -o demo.npz --camera-pose top-down --camera-height-m 1.0
"""

from __future__ import annotations

import argparse
import glob
import logging
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from dexlfd._commands._capture_args import FLAGS as CAPTURE_FLAGS
from dexlfd._commands._capture_args import (
    SOURCE_HELP,
    add_capture_arguments,
    record_config,
    warn_camera_frame,
)
from dexlfd._commands._common import bounded_int, progress
from dexlfd._commands._outputs import DIR, check_outputs
from dexlfd._stderr import native_stderr_silenced
from dexlfd.errors import InvalidInput

logger = logging.getLogger(__name__)

# library parameter -> flag, for errors (cli.speak_cli)
FLAGS = {
    **CAPTURE_FLAGS,
    "max_gap_s": "--max-gap-s",  # record only: teleop has no gap filling
    "overlay video": "--overlay",
    "save_landmarks": "--save-landmarks",
    "rerun recording": "--rerun",
}


HELP = "track a hand in videos or a camera and write demonstrations"


def add_parser(sub: Any, name: str) -> argparse.ArgumentParser:
    """Register the subcommand."""
    p: argparse.ArgumentParser = sub.add_parser(
        name,
        help=HELP,
        description=SOURCE_HELP + " Several SOURCEs: -o is a folder, one DIR/<name>.npz each; "
        "a video that fails is reported and the others are still recorded (exit 1 at the end). "
        "Every pick-and-place is a demonstration of its own, judged on its own frames (its "
        "reach, grasp, carry, release and retreat; other episodes and unseen frames around it "
        "are reported, not held against it): one pick-and-place is written to FILE.npz (or "
        "DIR/<name>.npz), several to FILE-1.npz, FILE-2.npz, ... (DIR/<name>-1.npz, ...) in "
        "time order, times in the video's seconds; a recording without one is written whole "
        "with a verdict saying why. Numbered files already there are never replaced (the run "
        "is refused before any work), nor files already in an output folder. A refused run "
        "leaves no new folder behind.",
    )
    add_capture_arguments(p, many=True, grasp="closure")
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="demonstration file (.npz; several pick-and-places: FILE-1.npz, FILE-2.npz, "
        "...), or a folder (several SOURCEs, or a name ending in /: DIR/<name>.npz, or "
        "DIR/<name>-1.npz, ... per pick-and-place)",
    )
    p.add_argument(
        "--overlay",
        help="video with the tracked skeleton: a FILE.mp4 (one SOURCE, whatever -o is), or "
        "a folder, DIR/<name>_overlay.mp4 per SOURCE",
    )
    p.add_argument(
        "--save-landmarks",
        metavar="FILE.npz",
        help="also write every frame's raw tracker output (all hands, MediaPipe's order and "
        "labels) as a landmark recording, to re-process later with other settings by "
        "`dexlfd record FILE.npz`: a FILE.npz (one SOURCE, whatever -o is), or a folder, "
        "DIR/<name>_landmarks.npz per SOURCE",
    )
    p.add_argument(
        "--plot", metavar="DIR", help="3-D hand view and time series here (per SOURCE: DIR/<name>/)"
    )
    p.add_argument(
        "--max-gap-s",
        type=float,
        default=None,
        help="interpolate gaps without a hand up to this long [s], measured between the seen "
        "frames around the gap; accepted 0..5 (default: max(0.1 s, 2.5 frame periods): up to "
        "0.1 s, and a single missing frame at any frame rate, e.g. 0.31 s at 8 fps)",
    )
    p.add_argument(
        "--no-redetect",
        action="store_true",
        help="do not look again for a hand the tracker lost (by default a crop around where "
        "its motion predicts it is searched, scaled up, for up to 20 frames)",
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
    """One :class:`~dexlfd.apps.record.RecordJob` per SOURCE, outputs checked first.

    Every output is checked before a folder is made, so a refused command leaves
    nothing behind.
    """
    from dexlfd.apps.record import RecordJob

    sources: list[str] = list(args.source)
    as_dir = len(sources) > 1 or args.output.endswith(("/", os.sep)) or Path(args.output).is_dir()
    single = len(sources) == 1
    if single and not as_dir:
        npz, _, _, _, lm_path = check_outputs(
            [("-o/--output", args.output, ".npz"), ("--overlay", args.overlay, ".mp4"),
             ("--plot", args.plot, DIR), ("--rerun", args.rerun, ".rrd"),
             ("--save-landmarks", args.save_landmarks, ".npz")],
            inputs=sources,
        )  # fmt: skip
        if lm_path is not None and npz is not None and lm_path.resolve() == npz.resolve():
            raise InvalidInput(f"--save-landmarks {lm_path} is the -o/--output file")
        assert npz is not None
        _refuse_numbered(npz.parent, npz.stem, "-o/--output")
        outputs = [(str(npz), args.overlay, args.plot, None if lm_path is None else str(lm_path))]
    else:
        outputs = _folder_outputs(args, sources)
    inputs = {Path(s).resolve() for s in sources if Path(s).exists()}
    for out, overlay, _, lms in outputs:
        flags = ((out, "-o/--output"), (overlay, "--overlay"), (lms, "--save-landmarks"))
        for path, flag in flags:
            if path is not None and Path(path).resolve() in inputs:
                raise InvalidInput(f"{flag} {path} is an input SOURCE: refusing to overwrite it")
    return [
        RecordJob(
            src, out, cfg, overlay, plot, show_progress=single, rerun=args.rerun,
            save_landmarks=lms, split=True,
        )
        for src, (out, overlay, plot, lms) in zip(sources, outputs, strict=True)
    ]  # fmt: skip


def _file_or_folder(flag: str, path: str | None, suffix: str, single: bool) -> str | None:
    """``DIR`` for an output folder, ``suffix`` for a file (one SOURCE and a file's name)."""
    if path is None:
        return None
    if Path(path).suffix.lower() == suffix and not Path(path).is_dir():
        if not single:
            raise InvalidInput(f"{flag} {path}: several SOURCEs write one file each: give a folder")
        return suffix
    return DIR


def _folder_outputs(args: argparse.Namespace, sources: list[str]) -> list[tuple[Any, ...]]:
    """The outputs of each SOURCE with ``-o`` a folder; checked first, then folders made.

    ``--overlay`` and ``--save-landmarks`` are a folder (one ``<name>_overlay.mp4`` /
    ``<name>_landmarks.npz`` per SOURCE) or, with one SOURCE, a file's name.
    """
    single = len(sources) == 1
    if args.rerun and not single:
        raise InvalidInput("--rerun takes one SOURCE; record the videos apart to log each")
    ov_kind = _file_or_folder("--overlay", args.overlay, ".mp4", single)
    lm_kind = _file_or_folder("--save-landmarks", args.save_landmarks, ".npz", single)
    stems = [_stem(s) for s in sources]
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise InvalidInput(
            f"-o/--output {args.output}: several SOURCEs would write the same file "
            f"({', '.join(d + '.npz' for d in dup)}); rename the videos or record them apart"
        )
    ov_dir, lm_dir = (
        Path(path) if kind == DIR and path is not None else None
        for path, kind in ((args.overlay, ov_kind), (args.save_landmarks, lm_kind))
    )
    _refuse_existing(Path(args.output), stems, ov_dir, lm_dir)  # before a folder is made
    folder, ov, plot, lm, _ = check_outputs(
        [("-o/--output", args.output, DIR), ("--overlay", args.overlay, ov_kind),
         ("--plot", args.plot, DIR), ("--save-landmarks", args.save_landmarks, lm_kind),
         ("--rerun", args.rerun, ".rrd")],
        inputs=sources,
    )  # fmt: skip
    assert folder is not None
    return [
        (
            str(folder / f"{stem}.npz"),
            None if ov is None else str(ov / f"{stem}_overlay.mp4" if ov_dir else ov),
            None if plot is None else str(plot / stem),
            None if lm is None else str(lm / f"{stem}_landmarks.npz" if lm_dir else lm),
        )
        for stem in stems
    ]


def _refuse_numbered(folder: Path, stem: str, flag: str) -> None:
    """:class:`InvalidInput` when ``<stem>-<k>.npz`` (one per pick-and-place) is already there."""
    numbered = folder.glob(f"{glob.escape(stem)}-*.npz")
    taken = [p for p in sorted(numbered) if p.stem[len(stem) + 1 :].isdigit()]
    if taken:
        raise InvalidInput(
            f"{flag} {folder / (stem + '.npz')}: {', '.join(map(str, taken))} already exists; "
            "this run may write it (one file per pick-and-place): remove it or choose "
            "another name"
        )


def _refuse_existing(
    folder: Path, stems: list[str], overlay_dir: Path | None, landmarks_dir: Path | None
) -> None:
    """:class:`InvalidInput` when a file this run may write is already in an output folder.

    A recording writes ``<stem>.npz``, or ``<stem>-1.npz``, ``<stem>-2.npz``, ... (one
    per pick-and-place, known only once tracked), ``<stem>_overlay.mp4`` and
    ``<stem>_landmarks.npz``: any of them already there is another run's file, and is
    never replaced.
    """
    for stem in stems:
        numbered = folder.glob(f"{glob.escape(stem)}-*.npz")
        taken = [p for p in sorted(numbered) if p.stem[len(stem) + 1 :].isdigit()]
        if (folder / f"{stem}.npz").exists():
            taken.insert(0, folder / f"{stem}.npz")
        for extra_dir, name in ((overlay_dir, "overlay.mp4"), (landmarks_dir, "landmarks.npz")):
            if extra_dir is not None and (extra_dir / f"{stem}_{name}").exists():
                taken.append(extra_dir / f"{stem}_{name}")
        if taken:
            raise InvalidInput(
                f"-o/--output {folder}: {', '.join(str(p) for p in taken)} already exists; "
                "this run would write it (one file per pick-and-place): remove it or choose "
                "another folder"
            )


def _stem(source: str) -> str:
    """The output name of a SOURCE: the file's stem (a pair of videos: the top one's)."""
    if source.lower().startswith("videos:"):
        source = source.split(":", 1)[1].split(",")[0]
    return Path(source).stem or source.replace(":", "_")


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


def _report(outcome: Any, single: bool = False) -> None:
    """Log one video's result; a failure is one line in the flags' words.

    ``single``: a failure is not logged here; :func:`run` raises it as the command's
    one ``error:`` line.
    """
    from dexlfd.cli import speak_cli
    from dexlfd.motion import format_quality

    name = outcome.source
    if not outcome.ok:
        if not single:
            text = speak_cli(str(outcome.error), FLAGS).removeprefix(f"{name}: ")
            logger.error("%s: FAILED: %s", name, text)
        return
    qualities = outcome.qualities or ((outcome.quality,) if outcome.quality else ())
    if not qualities:
        return
    q = qualities[0] if outcome.quality is None else outcome.quality
    fps = outcome.n_frames / outcome.elapsed_s if outcome.elapsed_s > 0 else float("nan")
    rate = q.recording_detection_rate  # over all the frames recorded
    several = f"; {len(qualities)} pick-and-places" if len(qualities) > 1 else ""
    logger.info(
        "%d frames, hand detected in %.1f %% (%s hand), %.1f fps processing, %d gap(s) "
        "left, %d frame(s) interpolated%s; wrote %s",
        outcome.n_frames,
        100 * (q.detection_rate_recorded if rate is None else rate),
        q.hand,
        fps,
        sum(x.n_gaps for x in qualities),
        sum(x.n_interpolated for x in qualities),
        several,
        ", ".join(outcome.written),
    )
    for each in qualities:
        logger.info("%s", format_quality(name, each))


def _check_video_exists(source: str) -> None:
    """:class:`InvalidInput` when ``source`` names a video or landmark file that does not exist."""
    low = source.lower()
    if low.startswith(("webcam:", "webcams:", "videos:", "realsense")) or Path(source).exists():
        return
    if Path(source).suffix.lower() == ".npz":
        raise InvalidInput(f"{source}: no such landmark recording")
    if Path(source).suffix:
        raise InvalidInput(f"{source}: no such video file")


def run(args: argparse.Namespace) -> int:
    """Record every SOURCE, derive the motion and write the outputs."""
    verbose = bool(getattr(args, "verbose", 0))
    saved = os.environ.get("OPENCV_FFMPEG_LOGLEVEL")
    if not verbose:  # ffmpeg quiet at the source (read by OpenCV as it opens a file;
        os.environ["OPENCV_FFMPEG_LOGLEVEL"] = "-8"  # inherited by workers); -v: its notes
    try:
        with native_stderr_silenced(not verbose and len(args.source) == 1):
            return _run(args)
    finally:
        if saved is None:
            os.environ.pop("OPENCV_FFMPEG_LOGLEVEL", None)
        else:
            os.environ["OPENCV_FFMPEG_LOGLEVEL"] = saved


def _run(args: argparse.Namespace) -> int:
    # bad flag values before any work, then a missing file, then notes about the flags
    from dataclasses import replace

    cfg = record_config(args, warn=False, max_gap_s=args.max_gap_s)
    cfg = replace(cfg, redetect=not getattr(args, "no_redetect", False))
    if len(args.source) == 1:
        _check_video_exists(args.source[0])
    warn_camera_frame(args)
    new_dirs = [
        Path(p)
        for p in (args.output, args.overlay, args.plot, args.save_landmarks)
        if p is not None and not Path(p).exists()
    ]
    try:
        code = _record_all(args, cfg)
    except BaseException:
        _remove_empty(new_dirs)
        raise
    if code:
        _remove_empty(new_dirs)
    return code


def _remove_empty(folders: list[Path]) -> None:
    """Remove the folders this run made that are still empty (a refused or failed run)."""
    import contextlib

    for folder in folders:
        with contextlib.suppress(OSError):
            folder.rmdir()  # only when empty


def _record_all(args: argparse.Namespace, cfg: Any) -> int:
    from dexlfd.apps.record import record_job

    jobs = _jobs(args, cfg)
    with progress(
        len(jobs) if len(jobs) > 1 else None, "record", quiet=args.quiet or len(jobs) == 1
    ) as bar:
        report = (lambda o: _report(o, single=True)) if len(jobs) == 1 else _report
        outcomes = _record_each(jobs, record_job, report, args, lambda: bar.update(1))
    failed = [o for o in outcomes if not o.ok]
    if len(jobs) > 1:
        usable = sum(
            o.ok and q.usable
            for o in outcomes
            for q in (o.qualities or ((o.quality,) if o.quality else ()))
        )
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
