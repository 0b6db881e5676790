"""Typed facts of a demonstration file: what ``dexlfd record`` decides and later stages read.

Each is a frozen :class:`~dexlfd.io._facts.Fact` held in a field of
:class:`~dexlfd.io.demonstration.Demonstration` (saved as the file's ``facts`` member,
checked on load; docs/file-formats.md lists them with their units). Frame numbers
(unit ``frame``) count the frames of the whole recording unless said otherwise;
times [s] are on the recording's time axis.

=================  =========================================================================
``phases``         :class:`Phases`: the task's episodes found in the whole recording
``episode``        :class:`Episode`: the one pick-and-place a demonstration was cut for
``source_frames``  ``[first, stop)`` of the recording that a demonstration holds [frame]
``trim``           :class:`Trim`: the idle frames cut at either end
``recording``      :class:`RecordingSummary`: the whole recording's frames and detection
``quality``        :class:`Quality`: the verdict and its figures
``frame``          the coordinate frame of the positions (``"panda_base"``, ``"camera..."``)
``task_frame``     :class:`AppliedFrame`: the transform that moved it into ``frame``
``capture``        :class:`Capture`: the source, camera, lifting and the hand followed
``motion``         :class:`Motion`: the motion settings the later stages read
=================  =========================================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any, Literal, TypeVar

from dexlfd.io._facts import Fact

__all__ = [
    "AppliedFrame",
    "Capture",
    "CameraIntrinsics",
    "HandChoice",
    "Motion",
    "TrackFigures",
    "split_table",
    "Episode",
    "EpisodeKind",
    "GraspSpan",
    "OtherEpisode",
    "Outside",
    "Phases",
    "Quality",
    "RecordingSummary",
    "TaskEpisode",
    "Trim",
    "Trimmed",
]

F = TypeVar("F", bound=Fact)


def split_table(fact: type[F], table: Mapping[str, Any], where: str) -> tuple[F, dict[str, Any]]:
    """``(fact, rest)``: the entries of a JSON ``table`` that are ``fact``'s, and the others.

    A table of settings and reports (a capture's) holds a few entries later stages
    read beside provenance: those become the typed fact (checked; ``None`` entries
    are absent), the rest stays provenance. ``where`` names the table in errors.
    """
    names = {f.name for f in fields(fact)}
    mine = {k: v for k, v in table.items() if k in names and v is not None}
    return fact.from_json(mine, where), {k: v for k, v in table.items() if k not in names}


EpisodeKind = Literal["pick_and_place", "no_release", "push", "drag"]
_FRAME = {"unit": "frame"}
_S = {"unit": "s"}


@dataclass(frozen=True)
class TaskEpisode(Fact):
    """One grasp (or push) with its reach and retreat (:class:`dexlfd.motion.phases.Episode`).

    Frames of the demonstration it was found in: ``[start, stop)`` with the idle
    frames shared with its neighbours, ``[task_start, task_stop)`` the task itself,
    ``grasp_start`` the first grasping frame, ``release`` the first frame seen open
    after it (None: never released).
    """

    kind: EpisodeKind
    start: int = field(metadata=_FRAME)
    stop: int = field(metadata=_FRAME)
    grasp_start: int = field(metadata=_FRAME)
    release: int | None = field(metadata=_FRAME)
    reason: str
    task_start: int | None = field(default=None, metadata=_FRAME)
    task_stop: int | None = field(default=None, metadata=_FRAME)
    grasp_start_s: float | None = field(default=None, metadata=_S)
    release_s: float | None = field(default=None, metadata=_S)


@dataclass(frozen=True)
class Phases(Fact):
    """The task's structure in the recorded hand's track (:mod:`dexlfd.motion.phases`)."""

    episodes: tuple[TaskEpisode, ...] = ()
    n_pick_and_place: int = 0
    phase_frames: dict[str, int] = field(default_factory=dict, metadata=_FRAME)


@dataclass(frozen=True)
class OtherEpisode(Fact):
    """Another episode of the recording, left out of a cut demonstration."""

    kind: EpisodeKind
    grasp_start: int = field(metadata=_FRAME)
    release: int | None = field(metadata=_FRAME)
    reason: str


@dataclass(frozen=True)
class Outside(Fact):
    """Frames of the recording a cut leaves out where the hand was unseen."""

    unseen_before: int = field(metadata=_FRAME)
    unseen_after: int = field(metadata=_FRAME)
    n_frames: int = field(metadata=_FRAME)


@dataclass(frozen=True, kw_only=True)
class Episode(TaskEpisode):
    """The pick-and-place a demonstration was cut for (:mod:`dexlfd.motion.episodes`).

    Its :class:`TaskEpisode` figures, ``index`` (from 1) ``of`` the recording's
    pick-and-places, the recording's ``others`` episodes, what was left ``outside``
    and the recording's ``[first, stop)`` frames.
    """

    index: int
    of: int
    others: tuple[OtherEpisode, ...] = ()
    outside: Outside | None = None
    recording_frames: tuple[int, int] | None = field(default=None, metadata=_FRAME)


@dataclass(frozen=True)
class GraspSpan(Fact):
    """A pick-and-place read from the grasp flags alone (no phases): its grasp's frames."""

    grasp_start: int = field(metadata=_FRAME)
    release: int = field(metadata=_FRAME)


@dataclass(frozen=True)
class Trim(Fact):
    """What :func:`dexlfd.motion.trim.trim_demonstration` cut (frames of the uncut one)."""

    moved: bool
    start: int = field(metadata=_FRAME)
    stop: int = field(metadata=_FRAME)
    n_original: int = field(metadata=_FRAME)
    onset_s: float | None = field(metadata=_S)
    offset_s: float | None = field(metadata=_S)
    cut_start_s: float = field(metadata=_S)
    cut_end_s: float = field(metadata=_S)
    detection_rate_original: float
    settings: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class RecordingSummary(Fact):
    """The whole recording a demonstration was cut from."""

    n_frames: int = field(metadata=_FRAME)
    detection_rate: float


@dataclass(frozen=True)
class Trimmed(Fact):
    """Seconds the idle trim cut at the start and at the end."""

    start_s: float | None = field(metadata=_S)
    end_s: float | None = field(metadata=_S)


@dataclass(frozen=True)
class Quality(Fact):
    """The verdict of one demonstration (:func:`dexlfd.motion.quality.quality_report`).

    ``usable`` exactly when there is no warning; ``notes`` report, never veto.
    """

    usable: bool
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    n_frames: int = field(default=0, metadata=_FRAME)
    n_frames_recorded: int = field(default=0, metadata=_FRAME)
    detection_rate_recorded: float = 0.0
    source_frames: tuple[int, int] = field(default=(0, 0), metadata=_FRAME)
    recording_frames: int | None = field(default=None, metadata=_FRAME)
    recording_detection_rate: float | None = None
    episode: Episode | None = None
    pick_and_place: TaskEpisode | GraspSpan | None = None
    duration_s: float = field(default=0.0, metadata=_S)
    detection_rate: float = 0.0
    n_gaps: int = 0
    n_interpolated: int = field(default=0, metadata=_FRAME)
    longest_gap_s: float = field(default=0.0, metadata=_S)
    hand: str | None = None
    hand_reason: str = "the configured hand"
    grasp_intervals_s: tuple[tuple[float, float], ...] = field(default=(), metadata=_S)
    grasp_method: str | None = None
    carry_m: float | None = field(default=None, metadata={"unit": "m"})  # grasp to release
    carry_std_m: float | None = field(default=None, metadata={"unit": "m"})  # its 1-sigma
    travel_extent_m: float = field(default=0.0, metadata={"unit": "m"})
    travel_path_m: float = field(default=0.0, metadata={"unit": "m"})
    p99_speed_m_s: float = field(default=0.0, metadata={"unit": "m/s"})
    jitter_mm: float | None = field(default=None, metadata={"unit": "mm"})
    max_orientation_step_deg: float = field(default=0.0, metadata={"unit": "deg"})
    trimmed: Trimmed | None = None


@dataclass(frozen=True)
class AppliedFrame(Fact):
    """The rigid transform (after ``scale``) that moved a demonstration into its frame.

    ``camera_to_base`` maps ``scale * p`` of ``from_frame`` to the new frame (rotation
    unitless, translation [m]); ``method`` says how it was found (free text from
    :func:`dexlfd.motion.task_frame.apply_frame`'s provenance).
    """

    camera_to_base: tuple[
        tuple[float, float, float, float],
        tuple[float, float, float, float],
        tuple[float, float, float, float],
        tuple[float, float, float, float],
    ] = field(metadata={"unit": "m"})
    scale: float
    from_frame: str
    method: str | None = None


_PX = {"unit": "px"}


@dataclass(frozen=True)
class CameraIntrinsics(Fact):
    """The pinhole intrinsics the hand was lifted with (capture.camera_models.Intrinsics)."""

    width: int = field(metadata=_PX)
    height: int = field(metadata=_PX)
    fx: float = field(metadata=_PX)
    fy: float = field(metadata=_PX)
    cx: float = field(metadata=_PX)
    cy: float = field(metadata=_PX)
    approximate: bool = False  # assumed (e.g. from a guessed field of view)


@dataclass(frozen=True)
class TrackFigures(Fact):
    """How much one tracked hand works (:class:`dexlfd.capture.association.TrackActivity`)."""

    track: int
    label: str
    label_agreement: float
    seen: float
    travel: float = field(metadata={"unit": "hand lengths"})
    aperture_change: float
    score: float
    pick_and_places: int = 0
    carries: int = 0
    shown_pick_and_places: int = 0  # of those, the ones the pixels show carrying
    shown_carries: int = 0


@dataclass(frozen=True)
class HandChoice(Fact):
    """Which tracked hand was recorded and why (None ``hand``: no hand was seen)."""

    hand: str | None
    reason: str
    requested: str | None = None
    track: int | None = None
    warning: str | None = None
    tracks: tuple[TrackFigures, ...] = ()
    convention: str | None = None


@dataclass(frozen=True)
class Capture(Fact):
    """How the hand was captured: what the motion, the verdict and the plots read.

    The capture's further settings and reports (tracker, lifting model settings,
    camera motion...) stay provenance in ``meta["capture"]``.
    """

    source_kind: str | None = None  # "video", "webcam", "realsense", "landmarks"...
    fps: float | None = field(default=None, metadata={"unit": "Hz"})
    image_size: tuple[int, int] | None = field(default=None, metadata=_PX)  # (width, height)
    lift_model: str | None = None
    depth: Literal["measured", "approximate"] | None = None
    intrinsics: CameraIntrinsics | None = None
    # the one factor the RGB-only depth was multiplied by to read the palm at its full
    # size (capture.palm_fit.full_size_scale) [-]; None: none applied
    depth_scale: float | None = None
    depth_scale_sd: float | None = None  # its relative 1-sigma [-]
    hand_choice: HandChoice | None = None


@dataclass(frozen=True)
class Motion(Fact):
    """The settings of :class:`dexlfd.motion.demonstration.MotionConfig` later stages read.

    The rest (the phase settings, the definition's text) stays in ``meta["motion"]``.
    """

    hand: str
    mount: str
    euler_mode: str
    smoothing: str
    grasp_method: str
    grasp_threshold: float = field(metadata={"unit": "m"})
    grasp_hysteresis: float = field(metadata={"unit": "m"})
    grasp_min_duration_s: float = field(metadata=_S)
    max_gap_s: float = field(metadata=_S)
