"""A whole source -> a :class:`~dexlfd.capture.keypoints.KeypointSeries`.

:func:`track_source` runs :class:`~dexlfd.capture.hand_capture.HandCapture` over an open
source: per frame the preferred hand, or every hand as a track and, at the end, the
most active one (:mod:`dexlfd.capture.association`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.capture.association import (
    HandAssociator,
    TrackActivity,
    chain_tracks,
    choose_track,
    hand_activity,
)
from dexlfd.capture.frame_source import Frame, FrameSource
from dexlfd.capture.hand_capture import CaptureConfig, HandCapture
from dexlfd.capture.keypoints import FrameKeypoints, KeypointSeries, no_hand, series_from_rows
from dexlfd.capture.prefetch import prefetched
from dexlfd.errors import InvalidDemonstration
from dexlfd.io.demonstration_facts import HandChoice

__all__ = ["TrackJudge", "track_source"]

# what a hand does in its track: (t (n,), uv_px (n, 21, 2) [px], world_m (n, 21, 3) [m],
# seen (n,), carry cue (n,)) -> (pick-and-places, grasps that carry, and of each the ones
# the pixels show carrying); NaN where unseen or unmeasured
TrackJudge = Callable[
    [FloatArray, FloatArray, FloatArray, BoolArray, FloatArray], tuple[int, int, int, int]
]

logger = logging.getLogger(__name__)


def track_source(
    source: FrameSource,
    cfg: CaptureConfig | None = None,
    *,
    capture: HandCapture | None = None,
    callback: Callable[[int, float], None] | None = None,
    on_frame: Callable[[Frame, FrameKeypoints], None] | None = None,
    hand: str | None = None,
    judge: TrackJudge | None = None,
) -> KeypointSeries:
    """Run hand capture over an open source.

    A video file's frames are decoded one or two ahead on a worker thread
    (:func:`~dexlfd.capture.prefetch.prefetched`): the same frames, in order; a
    tracker with ``announce(rgb, t)`` (a
    :class:`~dexlfd.capture.landmark_source.TrackerTap`) is told each next frame
    before this one is processed.

    Parameters
    ----------
    source : FrameSource
        Already opened (``with source:``).
    cfg : CaptureConfig, optional
        Used when ``capture`` is not given.
    capture : HandCapture, optional
        A prepared per-frame capture (closed by the caller).
    callback : callable(i, t), optional
        Called after each frame (progress bars).
    on_frame : callable(frame, result), optional
        Called with each frame and its result (e.g. to draw an overlay); with
        several hands, the result of the first one detected in that frame.
    hand : {"auto", "right", "left"}, optional
        Follow every hand as a track (:class:`~dexlfd.capture.association.HandAssociator`)
        and keep, at the end, the most active one ("auto") or the most active with
        that label; ``hand_choice`` says which and why. None (default):
        per frame, the hand with the tracker's preferred label
        (``cfg.tracker.hand``), as teleoperation does.
    judge : callable, optional
        With ``hand``: reads what each hand does (``(pick_and_places, carries)`` of
        its track, e.g. from :func:`dexlfd.motion.phases.hand_phases`), so the hand
        that grasps, carries and releases is chosen over one that is only seen or
        moves (:func:`~dexlfd.capture.association.choose_track`). None: activity only.

    Returns
    -------
    KeypointSeries

    Raises
    ------
    InvalidDemonstration
        When no hand is found in any frame.
    InvalidInput
        When ``hand`` names a hand that is never seen.
    """
    own = capture is None
    cap = capture or HandCapture(cfg, source.intrinsics, has_depth=source.has_depth)
    run = _FrameRun(HandAssociator() if hand is not None else None)
    # a video file's next frames are decoded (and, by a tracker that can, tracked)
    # while this one is worked on
    frames = iter(source)
    if source.kind == "video":
        frames = _announced(prefetched(frames), getattr(cap.tracker, "announce", None))
    try:
        for i, frame in enumerate(frames):
            res = run.add(i, frame, cap)
            if on_frame is not None:
                on_frame(frame, res)
            if callback is not None:
                callback(frame.index, frame.t)
    finally:
        close = getattr(frames, "close", None)
        if close is not None:
            close()  # the decoding stops before the source is closed
        if own:
            cap.close()
    choice: dict[str, Any] | None = None
    rows = run.rows
    if run.associator is not None:
        rows, choice = _chosen_rows(run.times, run.per_track, run.counts, hand or "auto", judge)
    _check_found(rows, source, cap)
    series = series_from_rows(
        rows,
        {"source": source.description, "source_kind": source.kind, **cap.describe()},
        fps=source.fps,
        image_size=(int(run.shape[1]), int(run.shape[0])) if run.shape else None,
        hand_choice=None if choice is None else HandChoice.from_json(choice, "hand_choice"),
        camera2base=np.array(cap.lift_cfg.camera2base, dtype=np.float64),
    )
    _log_summary(series, choice, cap)
    return series


def _announced(
    frames: Iterator[Frame], announce: Callable[[np.ndarray, float], None] | None
) -> Iterator[Frame]:
    """``frames`` unchanged; before each is yielded, the one after it is announced."""
    try:
        if announce is None:
            yield from frames
            return
        nxt = next(frames, None)
        while nxt is not None:
            frame, nxt = nxt, next(frames, None)
            if nxt is not None:
                announce(nxt.rgb, nxt.t)
            yield frame
    finally:
        close = getattr(frames, "close", None)
        if close is not None:
            close()


@dataclass
class _FrameRun:
    """The per-frame results of a run: one row per frame, or every hand's track."""

    associator: HandAssociator | None  # None: one row per frame, the preferred hand
    rows: list[FrameKeypoints] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    per_track: dict[int, dict[int, FrameKeypoints]] = field(default_factory=dict)
    counts: list[int] = field(default_factory=list)  # hands per frame
    shape: tuple[int, ...] = ()  # of the last frame's image

    def add(self, i: int, frame: Frame, cap: HandCapture) -> FrameKeypoints:
        """Process frame ``i``; returns its result (the first hand's with tracks)."""
        self.shape = frame.rgb.shape
        if self.associator is None:
            res = cap.process(frame)
            self.rows.append(res)
            return res
        found = cap.process_tracks(frame, self.associator)
        for k, r in found:
            self.per_track.setdefault(k, {})[i] = r
        self.counts.append(len(found))
        self.times.append(frame.t)
        return found[0][1] if found else no_hand(frame.t)


def _check_found(rows: list[FrameKeypoints], source: FrameSource, cap: HandCapture) -> None:
    """Raise :class:`InvalidDemonstration` without frames or without a lifted hand."""
    n = len(rows)
    if n == 0:
        raise InvalidDemonstration(f"{source.description}: no frames")
    if any(r.valid for r in rows):
        return
    seen = sum(r.n_hands > 0 for r in rows)
    if seen:
        raise InvalidDemonstration(
            f"{source.description}: a hand was detected in {seen} of {n} frames but could "
            f"not be lifted to 3-D by the {cap.lift_cfg.model!r} model (no valid depth at "
            "the wrist/thumb/index: depth image empty or all holes?)"
        )
    raise InvalidDemonstration(f"{source.description}: no hand detected in any of the {n} frames")


def _log_summary(series: KeypointSeries, choice: dict[str, Any] | None, cap: HandCapture) -> None:
    """Log the hand followed and any depth holes filled."""
    if choice is not None:
        logger.info("hand followed: %s", choice["reason"])
    elif (series.n_hands > 1).any():
        logger.warning(
            "more than one hand in %d frame(s): followed the %s hand with the highest confidence",
            int((series.n_hands > 1).sum()),
            cap.cfg.tracker.hand,
        )
    if series.depth_filled.any():
        logger.warning(
            "depth holes at %d landmark(s) in %d frame(s): filled from the hand's other "
            "landmarks and MediaPipe's relative depth",
            int(series.depth_filled.sum()),
            int((series.depth_filled > 0).sum()),
        )
    # no warn_if_mostly_held here: a recording's pnp depth is replaced by the
    # whole-recording estimate (capture.recording_pose), which holds no depth


def warn_if_mostly_held(pnp_frames: dict[str, int] | None) -> None:
    """One warning when the ``pnp`` lift held the depth in more than half its frames."""
    if not pnp_frames:
        return
    lifted = pnp_frames.get("fitted", 0) + pnp_frames.get("gated", 0)
    held = pnp_frames.get("shape_held", 0)
    if lifted and held > 0.5 * lifted:
        logger.warning(
            "the pnp lift held the depth in %d of %d frames (the hand kept changing shape): "
            "depth motion during those frames is not in the recording",
            held,
            lifted,
        )


def _chosen_rows(
    times: list[float],
    per_track: dict[int, dict[int, FrameKeypoints]],
    counts: list[int],
    hand: str,
    judge: TrackJudge | None = None,
) -> tuple[list[FrameKeypoints], dict[str, Any]]:
    """The rows of the chosen track (no-hand rows elsewhere) and the choice's report.

    The tracks are first re-joined across long losses
    (:func:`~dexlfd.capture.association.chain_tracks`); ``judge`` says what each does.
    """
    n = len(times)
    t = np.asarray(times, dtype=np.float64)
    tracks = chain_tracks(t, per_track)
    acts: list[TrackActivity] = []
    for k, track_rows in tracks.items():
        ok = [track_rows[i] for i in sorted(track_rows) if track_rows[i].valid]
        uv = np.stack([r.uv_px for r in ok]) if ok else np.zeros((0, 21, 2))
        act = hand_activity(k, uv, [r.handedness for r in ok], n)
        if judge is not None and ok:
            pnp, carries, shown_pnp, shown = judge(t, *_track_arrays(track_rows, n))
            act = replace(act, pick_and_places=pnp, carries=carries,
                          shown_pick_and_places=shown_pnp, shown_carries=shown)  # fmt: skip
        acts.append(act)
    if not any(a.seen > 0 for a in acts):
        return [no_hand(ti) for ti in times], {"hand": None, "reason": "no hand"}
    best, why, warning = choose_track([a for a in acts if a.seen > 0], hand)
    if warning:
        logger.warning("%s", warning)
    chosen = tracks[best.track]
    out = [
        replace(chosen[i], n_hands=counts[i])
        if i in chosen
        else replace(no_hand(times[i]), n_hands=counts[i])
        for i in range(n)
    ]
    return out, {
        "requested": hand,
        "hand": best.label,
        "track": best.track,
        "reason": why,
        "warning": warning,
        "tracks": [asdict(a) for a in acts],
        "convention": "labels name the person's hand on an unmirrored image "
        "(MediaPipe's selfie labels swapped unless TrackerConfig.mirrored)",
    }


def _track_arrays(
    rows: dict[int, FrameKeypoints], n: int
) -> tuple[FloatArray, FloatArray, BoolArray, FloatArray]:
    """``(uv_px, world_m, seen, carry)`` of one track over all ``n`` frames.

    NaN where unseen; ``carry``: the carry cue, NaN where unmeasured.

    ``world_m``: MediaPipe's world landmarks where the detection is kept, else the
    lifted keypoints (a rigid placement of them for the RGB lifts).
    """
    uv = np.full((n, 21, 2), np.nan)
    world = np.full((n, 21, 3), np.nan)
    seen = np.zeros(n, bool)
    carry = np.full(n, np.nan)
    for i, r in rows.items():
        if not r.valid:
            continue
        uv[i] = r.uv_px
        world[i] = r.observation.world_m if r.observation is not None else r.keypoints
        seen[i] = True
        carry[i] = np.nan if r.observation is None else r.observation.carry
    return uv, world, seen, carry
