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

from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration

if TYPE_CHECKING:
    from dexlfd.capture import CaptureConfig, FrameSource
    from dexlfd.motion import MotionConfig

__all__ = [
    "BOUNDS",
    "LIFT_CHOICES",
    "RecordConfig",
    "RecordJob",
    "RecordOutcome",
    "RecordResult",
    "capture_config",
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
    """Motion defaults of a recording: a top grasp, palm-based Euler angles, One-Euro smoothing."""
    from dexlfd.motion import MotionConfig

    return MotionConfig(smoothing="one_euro", mount="top_grasp", euler_mode="palm")


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
        two_webcams for a pair of webcams, pnp otherwise.
    hand : str
        ``"auto"`` (the most active hand), ``"right"`` or ``"left"``.
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
    """

    capture: CaptureConfig = field(default_factory=_record_capture)
    motion: MotionConfig = field(default_factory=_record_motion)
    lift: str = "auto"
    hand: str = "auto"
    max_frames: int | None = None
    resize_width: int | None = None  # [px]
    intrinsics_px: tuple[float, float, float, float] | None = None  # fx, fy, cx, cy [px]
    intrinsics_size: tuple[int, int] | None = None  # (width, height) [px]
    trim: bool = True
    max_gap_s: float | None = None  # None: default_max_gap_s(fps) of the source

    def __post_init__(self) -> None:
        if self.lift not in LIFT_CHOICES:
            raise InvalidInput(f"lift must be one of {LIFT_CHOICES}, got {self.lift!r}")
        if self.hand not in ("auto", "right", "left"):
            raise InvalidInput(f"hand must be auto, right or left, got {self.hand!r}")
        for name, (lo, hi) in BOUNDS.items():
            value = setting(self, name)
            if value is not None and not lo <= value <= hi:
                raise InvalidInput(f"{name} must be in [{lo}, {hi}], got {value}")


# accepted ranges of the numeric settings, by their path in RecordConfig (checked before
# any work; the CLI names the flags)
BOUNDS: dict[str, tuple[float, float]] = {
    "max_frames": (1, 10_000_000),
    "resize_width": (16, 7680),  # [px]; no upscaling beyond 8K
    "capture.assumed_hfov_deg": (1.0, 179.0),
    "capture.lift.assumed_wrist_depth_m": (0.05, 10.0),
    "capture.tracker.max_num_hands": (1, 4),
    "motion.grasp_threshold": (0.005, 0.2),  # within a hand's thumb-index range [m]
    "max_gap_s": (0.0, 5.0),
}


def setting(cfg: Any, path: str) -> Any:
    """The value at a dotted ``path`` of nested configs (``"capture.tracker.max_num_hands"``)."""
    for name in path.split("."):
        cfg = getattr(cfg, name)
    return cfg


@dataclass(frozen=True, slots=True)
class RecordResult:
    """The demonstration and how the recording went."""

    demo: Demonstration
    n_frames: int
    detection_rate: float
    hand: str
    elapsed_s: float
    lift_model: str
    quality: dict[str, Any] = field(default_factory=dict)  # motion.quality_report


def capture_config(source: FrameSource, cfg: RecordConfig) -> CaptureConfig:
    """``cfg.capture`` for the opened ``source``: lifting model, intrinsics and hand resolved.

    ``lift="auto"`` becomes ``pinhole`` for RGB-D sources, ``two_webcams`` for a
    pair of webcams and ``pnp`` otherwise.
    """
    from dexlfd.capture import Intrinsics

    model = cfg.lift
    if model == "auto":
        model = (
            "pinhole" if source.has_depth else "two_webcams" if source.kind == "webcams" else "pnp"
        )
    K = None
    if cfg.intrinsics_px is not None:
        size = cfg.intrinsics_size or source.native_size
        if size is None:
            raise InvalidInput("intrinsics need a source with a known image size")
        K = Intrinsics(size[0], size[1], *cfg.intrinsics_px)
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
) -> RecordResult:
    """Record ``source_spec`` (a video path, ``webcam:0``, ``realsense``, a bag...).

    ``callback(i, t)`` is called per frame; ``n_frames_hint(n)`` once with the
    source's frame count (None if unknown), for a progress bar; ``on_frame(frame,
    keypoints)`` per frame with the image and its tracking result (e.g.
    ``RerunLog.capture_frame``). The overlay is written atomically (discarded when
    recording fails).
    """
    from dexlfd.capture import HandCapture, open_source, track_source
    from dexlfd.capture.recording_pose import series_with_recording_pose
    from dexlfd.motion import demonstration_from_capture, quality_report, trim_demonstration

    source = open_source(source_spec, max_frames=cfg.max_frames, resize_width=cfg.resize_width)
    overlay_cm: Any = None
    with source:
        capture_cfg = capture_config(source, cfg)
        model = capture_cfg.lift.model
        logger.info("record %s: lift=%s, hand=%s", source.description, model, cfg.hand)
        logger.debug("tracker: %s", capture_cfg.tracker)
        if n_frames_hint is not None:
            n_frames_hint(source.n_frames)
        each_frame = on_frame
        if overlay is not None:
            from dexlfd.viz.capture import OverlayWriter

            overlay_cm = OverlayWriter(overlay, source.fps or 30.0)

            def each_frame(frame: Any, res: Any) -> None:
                label = f"seen: {res.handedness} {res.score:.2f}" if res.valid else "no hand"
                overlay_cm.write(frame.rgb, res.uv_px if res.n_hands else None, label)
                if on_frame is not None:
                    on_frame(frame, res)

        t0 = time.perf_counter()
        ok = False
        try:
            with HandCapture(capture_cfg, source.intrinsics, has_depth=source.has_depth) as cap:
                series = track_source(
                    source, capture=cap, callback=callback, on_frame=each_frame, hand=cfg.hand
                )
                if model == "pnp":  # offline: the whole recording's pose, not frame by frame
                    series = series_with_recording_pose(series, cap.lift_cfg)
            ok = True
        finally:
            if overlay_cm is not None:
                overlay_cm.close(ok=ok)
    elapsed = time.perf_counter() - t0
    hand = series.meta["hand_choice"]["hand"]
    demo = demonstration_from_capture(series, motion_config(cfg, hand, series.meta.get("fps")))
    n_frames = demo.n_samples
    if demo.meta["capture"].get("depth") == "approximate":
        logger.warning(
            "depth is APPROXIMATE (%s): RGB-only source", demo.meta["capture"]["lift_model"]
        )
    if cfg.trim:
        demo = trim_demonstration(demo)
    quality = quality_report(demo)
    demo = replace(demo, meta={**demo.meta, "quality": quality})
    if overlay is not None:  # now known: the hand recorded, its grasp state
        from dexlfd.viz.capture import annotate_overlay

        annotate_overlay(overlay, demo)
    return RecordResult(
        demo=demo,
        n_frames=n_frames,
        detection_rate=float(series.detection_rate),
        hand=hand,
        elapsed_s=elapsed,
        lift_model=model,
        quality=quality,
    )


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


@dataclass(frozen=True, slots=True)
class RecordOutcome:
    """What became of one :class:`RecordJob`: a summary, or the one-line error."""

    source: str
    output: str
    error: str | None = None
    n_frames: int = 0
    elapsed_s: float = 0.0
    quality: dict[str, Any] = field(default_factory=dict)
    written: tuple[str, ...] = ()

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
            )
        written = [str(save_demonstration(job.output, res.demo))]
        if rr_log is not None and job.rerun is not None:
            rr_log.demonstration(res.demo)
            rr_log.close()
            written.append(job.rerun)
        if job.overlay:
            written.append(job.overlay)
        if job.plot_dir:
            from dexlfd.viz.capture import save_capture_figures

            written += [str(p) for p in save_capture_figures(res.demo, job.plot_dir)]
    except DexlfdError as exc:
        return RecordOutcome(job.source, job.output, error=str(exc))
    return RecordOutcome(
        job.source, job.output, None, res.n_frames, res.elapsed_s, res.quality, tuple(written)
    )
