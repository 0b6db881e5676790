"""One demonstration per pick-and-place, each judged on its own frames.

A recording may hold several pick-and-places, and other things a hand does between
them (a grasp never released, a push, a hover), and frames where the hand is not seen
at all (raised out of view, blurred). Each pick-and-place of its ``phases``
(:mod:`dexlfd.motion.phases`) is cut out on its own by :func:`split_demonstration`:

* within its episode's bounds (the midpoints to its neighbouring episodes, whatever
  their kind: another episode's frames are never part of it);
* from its task's first frame (the reach) to the task's end (the retreat, the hand
  still again), with ``margin_s`` either side;
* never over a loss of the hand longer than ``max_loss_s`` before the grasp or after
  the release: the piece starts after the last such loss before the grasp and ends
  before the first one after the release. A loss during the grasp stays in (the
  carry was not seen: its verdict says so).

Each piece keeps the recording's time axis, ``source_frames`` and
its ``episode`` (``index`` from 1, ``of``, the episode's frames, and ``others``:
the recording's other episodes, and the frames cut away where the hand was unseen), so
the quality report judges it on its own frames and only reports the rest
(:func:`dexlfd.motion.quality.quality_report`). :func:`episode_demonstrations` adds the
idle trim and the verdict of each.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import (
    Episode,
    OtherEpisode,
    Outside,
    RecordingSummary,
    TaskEpisode,
)
from dexlfd.motion.trim import TrimConfig, cut_demonstration, trim_demonstration

if TYPE_CHECKING:
    from dexlfd.capture.keypoints import KeypointSeries
    from dexlfd.motion.demonstration import MotionConfig

__all__ = [
    "MAX_LOSS_S",
    "episode_demonstrations",
    "episode_span",
    "recording_demonstrations",
    "split_demonstration",
]

logger = logging.getLogger(__name__)

MAX_LOSS_S = 0.5  # a loss this long before the grasp / after the release ends the piece [s]


def _losses(valid: np.ndarray) -> list[tuple[int, int]]:
    """``[(a, b), ...]``: runs of unseen frames, ``b`` exclusive."""
    m = np.concatenate([[0], (~np.asarray(valid, dtype=bool)).astype(np.int8), [0]])
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def episode_span(
    t: np.ndarray,
    valid: np.ndarray,
    episode: TaskEpisode,
    *,
    margin_s: float | None = None,
    max_loss_s: float = MAX_LOSS_S,
) -> tuple[int, int]:
    """``[a, b)``: the frames of one episode's demonstration (see the module docstring).

    ``episode`` is an entry of ``phases.episodes`` (frames of ``t``).
    """
    n = t.size
    margin = TrimConfig().margin_s if margin_s is None else margin_s
    g0 = int(episode.grasp_start)
    g1 = n - 1 if episode.release is None else int(episode.release)
    lo, hi = int(episode.start), int(episode.stop)
    task0 = episode.task_start
    task1 = episode.task_stop
    if task0 is not None:
        lo = max(lo, int(np.searchsorted(t, t[int(task0)] - margin, side="left")))
    if task1 is not None:
        last = min(int(task1), n) - 1
        hi = min(hi, int(np.searchsorted(t, t[last] + margin, side="right")))
    for a, b in _losses(valid):
        duration = t[min(b, n - 1)] - t[max(a - 1, 0)]
        if duration <= max_loss_s:
            continue
        if b <= g0:
            lo = max(lo, b)
        elif a > g1:
            hi = min(hi, a)
    lo = min(lo, g0)
    hi = max(hi, g1 + 1)
    return lo, hi


def _outside(valid: np.ndarray, a: int, b: int) -> Outside:
    """What the cut leaves out: frames unseen before ``a`` and from ``b`` on."""
    v = np.asarray(valid, dtype=bool)
    return Outside(
        unseen_before=int(np.sum(~v[:a])),
        unseen_after=int(np.sum(~v[b:])),
        n_frames=int(v.size),
    )


def split_demonstration(demo: Demonstration) -> list[Demonstration]:
    """One demonstration per pick-and-place of its ``phases``, or ``[demo]``.

    Each piece holds its episode's own frames only (:func:`episode_span`), even when
    the recording has one pick-and-place among other episodes or unseen frames; it
    keeps the recording's times and carries its ``episode``. Without phases or
    without a pick-and-place the demonstration is returned whole.
    """
    episodes = demo.phases.episodes if demo.phases is not None else ()
    pps = [e for e in episodes if e.kind == "pick_and_place"]
    if not pps:
        return [demo]
    first, _ = demo.source_frames or (0, demo.n_samples)
    out = []
    for k, e in enumerate(pps, start=1):
        lo, hi = episode_span(demo.t, demo.valid, e)
        piece = cut_demonstration(demo, lo, hi)
        others = tuple(
            OtherEpisode(o.kind, o.grasp_start, o.release, o.reason) for o in episodes if o is not e
        )
        episode = Episode(
            **{f: getattr(e, f) for f in TaskEpisode.__dataclass_fields__},
            index=k,
            of=len(pps),
            others=others,
            outside=_outside(demo.valid, lo, hi),
            recording_frames=(int(first), int(first + demo.n_samples)),
        )
        out.append(replace(piece, episode=episode))
    return out


def episode_demonstrations(
    demo: Demonstration, *, trim: bool = True, trim_cfg: TrimConfig | None = None
) -> list[Demonstration]:
    """One demonstration per pick-and-place of a recorded ``demo``, trimmed, with verdicts.

    :func:`split_demonstration` (the whole recording without a pick-and-place), then
    :func:`~dexlfd.motion.trim.trim_demonstration` (with ``trim``) and its ``quality``
    (:func:`~dexlfd.motion.quality.quality_report`) for each.
    """
    from dexlfd.motion.quality import quality_report

    out = []
    for piece in split_demonstration(demo):
        if trim:
            piece = trim_demonstration(piece, trim_cfg)
        out.append(replace(piece, quality=quality_report(piece)))
    return out


def recording_demonstrations(
    series: KeypointSeries,
    cfg: MotionConfig,
    *,
    camera_motion: np.ndarray | None = None,
    trim: bool = True,
) -> tuple[Demonstration, list[Demonstration]]:
    """A tracked recording's motion, and its demonstrations (one per pick-and-place).

    The motion stage of ``dexlfd record``: :func:`~dexlfd.motion.demonstration_from_capture`
    of the whole ``series`` (with ``extras["camera_motion"]``, the background's (n, 4)
    motion, when given, and its ``recording``), then :func:`episode_demonstrations`.
    Returns the whole recording's demonstration and the list.
    """
    from dexlfd.motion.online import demonstration_from_capture

    demo = demonstration_from_capture(series, cfg)
    if camera_motion is not None:  # per frame, sliced with the rest by the trim
        demo = replace(demo, extras={**demo.extras, "camera_motion": camera_motion})
    if demo.meta["capture"].get("depth") == "approximate":
        logger.warning(
            "depth is APPROXIMATE (%s): RGB-only source", demo.meta["capture"]["lift_model"]
        )
    recording = RecordingSummary(demo.n_samples, float(series.detection_rate))
    demo = replace(demo, recording=recording)
    return demo, episode_demonstrations(demo, trim=trim)
