"""Recording a demonstration: source → hand keypoints → end-effector motion.

The orchestration behind ``dexlfd record`` (and the demo's real-video stage):
open a source, track and lift the hand frame by frame (capture stage), derive
the end-effector motion (motion stage), optionally write an overlay video.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from dexlfd._params import check_params, param
from dexlfd.errors import InvalidDemonstration, InvalidInput
from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import Quality

if TYPE_CHECKING:
    from dexlfd.capture import CaptureConfig, FrameSource
    from dexlfd.motion import MotionConfig

__all__ = [
    "LIFT_CHOICES",
    "RecordConfig",
    "RecordJob",
    "RecordOutcome",
    "RecordResult",
    "capture_config",
    "episode_paths",
    "motion_config",
    "record_demonstration",
    "record_job",
    "setting",
]

logger = logging.getLogger(__name__)

LIFT_CHOICES = ("auto", "pinhole", "angle", "two_webcams", "pnp", "assumed_depth", "world_fit")


def _record_capture() -> CaptureConfig:
    """Capture defaults of a recording: two hands tracked, so the most active one is followed."""
    from dexlfd.capture import CaptureConfig, TrackerConfig

    return CaptureConfig(tracker=TrackerConfig(max_num_hands=2))


def _record_motion() -> MotionConfig:
    """Motion defaults of a recording: top grasp, palm Euler angles, One-Euro, closure grasps.

    Grasps are read from the task's structure (``grasp_method="closure"``).
    """
    from dexlfd.motion import MotionConfig

    return MotionConfig(
        smoothing="one_euro", mount="top_grasp", euler_mode="palm", grasp_method="closure"
    )


@dataclass(frozen=True, slots=True)
class RecordConfig:
    """How to record: the capture and motion stages' settings, and what depends on the source.

    Attributes
    ----------
    capture : CaptureConfig
        Tracker, lifting (assumed depth, camera pose ``lift.camera2base``) and the
        assumed field of view. Per source, ``lift.model`` is set from ``lift``,
        ``lift.intrinsics`` from ``intrinsics_px`` and ``tracker.hand`` from ``hand``.
    motion : MotionConfig
        Grasp detection, smoothing, gap filling, mount; ``hand`` is set to the hand
        that was followed.
    lift : str
        A lifting model (``LIFT_CHOICES``); ``"auto"``: pinhole for RGB-D sources,
        two_webcams for a pair of webcams or videos, pnp otherwise.
    hand : str
        ``"auto"`` (the hand that does the task: a pick-and-place first, then a grasp
        that carries, then the most active; :func:`~dexlfd.capture.association.choose_track`),
        ``"right"`` or ``"left"``.
    max_frames : int, optional
        Stop after this many frames.
    resize_width : int, optional
        Scale frames to this width [px].
    intrinsics_px : (fx, fy, cx, cy), optional
        Camera intrinsics [px] at ``intrinsics_size`` (default: the source's native size).
    intrinsics_size : (width, height), optional
        The image size [px] the intrinsics belong to.
    trim : bool
        Cut the idle start and end (``motion.trim``).
    max_gap_s : float, optional
        Longest tracking gap [s] filled by interpolation, 0..5. None: from the source's
        frame rate (:func:`default_max_gap_s`). Either way it replaces
        ``motion.max_gap_s`` (:func:`motion_config`): a recording's gap limit depends on
        its source, so ``motion.max_gap_s`` is not read here.
    redetect : bool
        Where the tracker loses a hand, look again in a crop around where its motion
        predicts it (:mod:`dexlfd.capture.redetection`; one camera's video or live
        camera; a landmark recording replays what was found).
    """

    capture: CaptureConfig = field(default_factory=_record_capture)
    motion: MotionConfig = field(default_factory=_record_motion)
    lift: str = "auto"
    hand: str = "auto"
    max_frames: int | None = param(
        None, "stop after this many frames (default: all)", lo=1, hi=10_000_000, integer=True
    )
    resize_width: int | None = param(
        None,
        "scale video frames to this width [px] (default: unchanged)",
        lo=16,
        hi=7680,
        integer=True,
        flag="--resize-width-px",
        aliases=("--resize-width",),
    )  # [px]; no upscaling beyond 8K
    intrinsics_px: tuple[float, float, float, float] | None = None  # fx, fy, cx, cy [px]
    intrinsics_size: tuple[int, int] | None = None  # (width, height) [px]
    trim: bool = True
    max_gap_s: float | None = param(
        None,
        "interpolate gaps without a hand up to this long, measured between the seen "
        "frames around the gap (default: max(0.1 s, 2.5 frame periods): up to 0.1 s, and a "
        "single missing frame at any frame rate, e.g. 0.31 s at 8 fps)",
        unit="s",
        lo=0.0,
        hi=5.0,
    )  # None: default_max_gap_s(fps) of the source
    redetect: bool = True  # look again for a lost hand in a crop (one camera's video)

    def __post_init__(self) -> None:
        if self.lift not in LIFT_CHOICES:
            raise InvalidInput(f"lift must be one of {LIFT_CHOICES}, got {self.lift!r}")
        if self.hand not in ("auto", "right", "left"):
            raise InvalidInput(f"hand must be auto, right or left, got {self.hand!r}")
        # every bounded setting, nested ones too, within its field's range (the flags')
        for part in (self, self.capture, self.capture.lift, self.capture.tracker, self.motion):
            check_params(part)


def setting(cfg: Any, path: str) -> Any:
    """The value at a dotted ``path`` of nested configs (``"capture.tracker.max_num_hands"``)."""
    for name in path.split("."):
        cfg = getattr(cfg, name)
    return cfg


@dataclass(frozen=True, slots=True)
class RecordResult:
    """The demonstrations and how the recording went.

    ``demos`` holds one demonstration per pick-and-place found (in time order, each
    with the recording's time axis), or the whole recording when there is at most
    one; ``demo`` and ``quality`` are the first's. ``qualities`` are their reports.
    """

    demo: Demonstration
    n_frames: int
    detection_rate: float
    hand: str
    elapsed_s: float
    lift_model: str
    quality: Quality | None = None  # motion.quality_report
    demos: tuple[Demonstration, ...] = ()
    qualities: tuple[Quality, ...] = ()
    landmarks: Any = None  # LandmarkRecording of the tracker's output, when asked for


def capture_config(source: FrameSource, cfg: RecordConfig) -> CaptureConfig:
    """``cfg.capture`` for the opened ``source``: lifting model, intrinsics and hand resolved.

    ``lift="auto"`` becomes ``pinhole`` for RGB-D sources, ``two_webcams`` for a
    pair of webcams or videos and ``pnp`` otherwise.
    """
    from dexlfd.capture import Intrinsics

    model = cfg.lift
    if model == "auto":
        model = (
            "pinhole"
            if source.has_depth
            else "two_webcams"
            if source.kind in ("webcams", "videos")
            else "pnp"
        )
    K = None
    if cfg.intrinsics_px is not None:
        size = cfg.intrinsics_size or source.native_size
        if size is None:
            raise InvalidInput("intrinsics need a source with a known image size")
        K = Intrinsics(size[0], size[1], *cfg.intrinsics_px)
        K.check_centred("--intrinsics")
    hand = "right" if cfg.hand == "auto" else cfg.hand
    return replace(
        cfg.capture,
        tracker=replace(cfg.capture.tracker, hand=hand),
        lift=replace(cfg.capture.lift, model=model, intrinsics=K),
    )


def default_max_gap_s(fps: float | None) -> float:
    """Default ``max_gap_s`` [s] at ``fps``: max(0.1 s, 2.5 frame periods).

    A single missing frame is always filled (its gap, between the seen frames around
    it, lasts 2 periods); two are not at low frame rates.
    """
    return max(0.1, 2.5 / fps) if fps and fps > 0 else 0.1


def motion_config(cfg: RecordConfig, hand: str, fps: float | None = None) -> MotionConfig:
    """``cfg.motion`` for the ``hand`` followed.

    ``max_gap_s`` is ``cfg.max_gap_s`` if given, else :func:`default_max_gap_s` of the
    source's ``fps``.
    """
    gap = default_max_gap_s(fps) if cfg.max_gap_s is None else cfg.max_gap_s
    return replace(cfg.motion, hand=hand, max_gap_s=gap)


def record_demonstration(
    source_spec: str,
    cfg: RecordConfig,
    *,
    overlay: str | os.PathLike[str] | None = None,
    callback: Callable[[int, float], None] | None = None,
    n_frames_hint: Callable[[int | None], None] | None = None,
    on_frame: Callable[[Any, Any], None] | None = None,
    keep_landmarks: bool = False,
) -> RecordResult:
    """Record ``source_spec`` (a video, ``webcam:0``, ``realsense``, a bag, landmarks...).

    ``callback(i, t)`` is called per frame; ``n_frames_hint(n)`` once with the
    source's frame count (None if unknown), for a progress bar; ``on_frame(frame,
    keypoints)`` per frame with the image and its tracking result (e.g.
    ``RerunLog.capture_frame``). The overlay is written atomically (discarded when
    recording fails). ``keep_landmarks``: ``result.landmarks`` is the tracker's raw
    output on every frame (a
    :class:`~dexlfd.capture.landmark_recording.LandmarkRecording`; one-camera
    sources that are not themselves a landmark recording).
    """
    from dexlfd.capture import open_source
    from dexlfd.capture.recording_capture import capture_recording, recording_tracker
    from dexlfd.capture.scene_change import scene_evidence
    from dexlfd.motion.episodes import recording_demonstrations
    from dexlfd.motion.phases import track_actions

    source = open_source(source_spec, max_frames=cfg.max_frames, resize_width=cfg.resize_width)
    with source:
        capture_cfg = capture_config(source, cfg)
        model = capture_cfg.lift.model
        logger.info("record %s: lift=%s, hand=%s", source.description, model, cfg.hand)
        logger.debug("tracker: %s", capture_cfg.tracker)
        if n_frames_hint is not None:
            n_frames_hint(source.n_frames)
        tracking = recording_tracker(
            source, capture_cfg, keep_landmarks=keep_landmarks, redetect=cfg.redetect
        )
        each_frame, overlay_cm = _frame_callback(source, overlay, on_frame)
        t0 = time.perf_counter()
        ok = False
        try:
            captured = capture_recording(
                source, capture_cfg, tracking, hand=cfg.hand, callback=callback,
                on_frame=each_frame, judge=track_actions,
            )  # fmt: skip
            ok = True
        finally:
            if overlay_cm is not None:
                overlay_cm.close(ok=ok)
    elapsed = time.perf_counter() - t0
    series = captured.series
    choice = series.hand_choice  # with hand=..., capture_recording always chooses one
    if choice is None or choice.hand is None:
        raise InvalidDemonstration(f"{source.description}: no hand was chosen to record")
    hand = choice.hand
    mcfg = motion_config(cfg, hand, series.fps)
    demo, demos = recording_demonstrations(
        series, mcfg, camera_motion=captured.camera_motion, trim=cfg.trim
    )
    # the scene before and after each pick-and-place (a video's frames, or stored)
    demos, landmarks = scene_evidence(source, series, demos, captured.landmarks)
    if overlay is not None:  # now known: the hand recorded, its grasp state
        from dexlfd.viz.capture import annotate_overlay

        annotate_overlay(overlay, demo)
    return RecordResult(
        demo=demos[0],
        n_frames=demo.n_samples,
        detection_rate=float(series.detection_rate),
        hand=hand,
        elapsed_s=elapsed,
        lift_model=model,
        quality=demos[0].quality,
        demos=tuple(demos),
        qualities=tuple(d.quality for d in demos if d.quality is not None),
        landmarks=landmarks,
    )


def _frame_callback(
    source: FrameSource,
    overlay: str | os.PathLike[str] | None,
    on_frame: Callable[[Any, Any], None] | None,
) -> tuple[Callable[[Any, Any], None] | None, Any]:
    """The per-frame callback (the overlay video's writer, then ``on_frame``) and the writer.

    Raises
    ------
    InvalidInput
        When an overlay is asked of a source without images.
    """
    if not source.has_images:
        if overlay is not None:
            raise InvalidInput(
                f"overlay video: {source.description} has no images to draw on; "
                "record the video itself for an overlay",
                param="overlay",
            )
        if on_frame is not None:
            logger.info("%s has no images: no camera view is logged", source.description)
            on_frame = None
    if overlay is None:
        return on_frame, None
    from dexlfd.viz.capture import OverlayWriter

    writer = OverlayWriter(overlay, source.fps or 30.0)

    def each_frame(frame: Any, res: Any) -> None:
        label = f"seen: {res.handedness} {res.score:.2f}" if res.valid else "no hand"
        writer.write(frame.rgb, res.uv_px if res.n_hands else None, label)
        if on_frame is not None:
            on_frame(frame, res)

    return each_frame, writer


@dataclass(frozen=True, slots=True)
class RecordJob:
    """One video to record and where to write it (picklable: a batch can run in processes)."""

    source: str
    output: str
    cfg: RecordConfig
    overlay: str | None = None
    plot_dir: str | None = None
    show_progress: bool = False  # a per-frame progress bar (single video on a terminal)
    rerun: str | None = None  # a rerun recording (.rrd) of the frames, hand and motion
    split: bool = False  # one file per pick-and-place (episode_paths), else the first only
    # (the CLI always splits: `-o FILE.npz` with several writes FILE-1.npz, FILE-2.npz, ...)
    save_landmarks: str | None = None  # a landmark recording of the tracker's output


@dataclass(frozen=True, slots=True)
class RecordOutcome:
    """What became of one :class:`RecordJob`: a summary, or the one-line error."""

    source: str
    output: str
    error: str | None = None
    n_frames: int = 0
    elapsed_s: float = 0.0
    quality: Quality | None = None
    written: tuple[str, ...] = ()
    qualities: tuple[Quality, ...] = ()  # one per demonstration written
    outputs: tuple[str, ...] = ()  # the demonstration files written, in time order
    error_param: str | None = None  # the setting at fault (the error's param), if any

    @property
    def ok(self) -> bool:
        """True when the demonstration was written."""
        return self.error is None


def record_job(job: RecordJob) -> RecordOutcome:
    """Record ``job.source`` and write its demonstration (and overlay/plots).

    Never raises for bad input or a bad video: a :class:`~dexlfd.errors.DexlfdError`
    becomes ``outcome.error`` (a batch goes on with the next video).
    """
    from dexlfd.errors import DexlfdError
    from dexlfd.io import save_demonstration

    try:
        import sys

        from tqdm import tqdm

        with tqdm(
            desc=os.path.basename(job.source),
            disable=not (job.show_progress and sys.stderr.isatty()),
            leave=False,
        ) as bar:

            def hint(n: int | None) -> None:
                bar.reset(total=n)

            from dexlfd.viz.rerun_log import open_rerun

            rr_log = open_rerun(job.rerun)  # the file appears only when the recording succeeds
            res = record_demonstration(
                job.source,
                job.cfg,
                overlay=job.overlay,
                callback=lambda i, t: bar.update(1),
                n_frames_hint=hint,
                on_frame=None if rr_log is None else rr_log.capture_frame,
                keep_landmarks=job.save_landmarks is not None,
            )
        demos = res.demos or (res.demo,)
        if job.split:
            paths = episode_paths(job.output, len(demos))
        else:
            paths = [job.output]
            if len(demos) > 1:
                logger.warning(
                    "%s: %d pick-and-places found; wrote the first to %s (split=True "
                    "writes one file per pick-and-place)",
                    job.source, len(demos), job.output,
                )  # fmt: skip
                demos = demos[:1]
        written = [str(save_demonstration(p, d)) for p, d in zip(paths, demos, strict=True)]
        outputs = tuple(written)
        if job.save_landmarks is not None and res.landmarks is not None:
            from dexlfd.capture.landmark_recording import save_landmark_recording

            written.append(str(save_landmark_recording(job.save_landmarks, res.landmarks)))
        if rr_log is not None and job.rerun is not None:
            rr_log.demonstration(res.demo)
            rr_log.close()
            written.append(job.rerun)
        if job.overlay:
            written.append(job.overlay)
        if job.plot_dir:
            from pathlib import Path

            from dexlfd.viz.capture import save_capture_figures

            for k, d in enumerate(demos, start=1):  # several: one sub-folder each, 1, 2, ...
                folder = Path(job.plot_dir) if len(demos) == 1 else Path(job.plot_dir) / str(k)
                written += [str(p) for p in save_capture_figures(d, folder)]
    except DexlfdError as exc:
        return RecordOutcome(
            job.source, job.output, error=str(exc), error_param=getattr(exc, "param", None)
        )
    return RecordOutcome(
        job.source, job.output, None, res.n_frames, res.elapsed_s, res.quality, tuple(written),
        tuple(d.quality for d in demos if d.quality is not None), outputs,
    )  # fmt: skip


def episode_paths(output: str | os.PathLike[str], n: int) -> list[str]:
    """The files of ``n`` demonstrations of one recording: ``NAME.npz``, or ``NAME-1.npz``...

    One demonstration keeps ``output``; several are numbered in time order from 1 next
    to it (``out/a.npz`` -> ``out/a-1.npz``, ``out/a-2.npz``).
    """
    from pathlib import Path

    path = Path(output)
    if n <= 1:
        return [str(path)]
    return [str(path.with_name(f"{path.stem}-{k}{path.suffix}")) for k in range(1, n + 1)]
