"""Frames -> 3-D hand keypoints in the robot base frame, per frame and for a whole source.

:class:`HandCapture` is the per-frame API (``process(frame) -> FrameKeypoints``,
usable by teleoperation); :func:`track_source` runs it over a source and
returns a :class:`KeypointSeries` with the tracker's confidence, handedness and
pixels, ready for :func:`dexlfd.motion.demonstration_from_capture`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.capture.association import (
    HandAssociator,
    TrackActivity,
    choose_track,
    hand_activity,
)
from dexlfd.capture.lifting import (
    DEPTH_MODELS,
    RGB_MODELS,
    Intrinsics,
    LiftConfig,
    LiftInput,
    PnPTracker,
    lift,
    robust_depth,
)
from dexlfd.capture.sources import Frame, FrameSource
from dexlfd.capture.tracking import (
    HandObservation,
    HandTracker,
    TrackerConfig,
    make_tracker,
    select_hand,
)
from dexlfd.errors import InvalidDemonstration, InvalidInput

__all__ = [
    "CaptureConfig",
    "FrameKeypoints",
    "HandCapture",
    "KeypointSeries",
    "track_source",
]

logger = logging.getLogger(__name__)

HANDEDNESS_CODE = {"right": 1, "left": -1}


@dataclass(frozen=True, slots=True)
class CaptureConfig:
    """Tracker, lifting model and what to assume when the source says nothing."""

    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    lift: LiftConfig = field(default_factory=LiftConfig)
    assumed_hfov_deg: float = 60.0  # field of view assumed for RGB-only video [deg]

    def __post_init__(self) -> None:
        if not 0 < self.assumed_hfov_deg < 180:
            raise InvalidInput(f"assumed_hfov_deg must be in (0, 180), got {self.assumed_hfov_deg}")


@dataclass(frozen=True, slots=True)
class FrameKeypoints:
    """Result of one frame: base-frame landmarks (NaN if no hand) and tracker info."""

    t: float
    keypoints: FloatArray  # (21, 3) [m], base frame
    valid: bool
    uv_px: FloatArray  # (21, 2) [px]
    score: float  # handedness confidence, NaN without a hand
    handedness: str  # "right", "left" or "" without a hand
    n_hands: int
    depth_filled: int  # landmarks whose depth was filled from the others
    observation: HandObservation | None = None


@dataclass(frozen=True, slots=True)
class KeypointSeries:
    """Keypoints of a whole source (time axis first) and how they were made."""

    t: FloatArray  # (n,) [s]
    keypoints: FloatArray  # (n, 21, 3) [m], base frame, NaN where unseen
    valid: BoolArray  # (n,)
    uv_px: FloatArray  # (n, 21, 2) [px]
    score: FloatArray  # (n,) handedness confidence
    handedness: np.ndarray  # (n,) int8: 1 right, -1 left, 0 none
    n_hands: np.ndarray  # (n,) int
    depth_filled: np.ndarray  # (n,) int
    meta: dict[str, Any]

    @property
    def detection_rate(self) -> float:
        """Fraction of frames with a hand."""
        return float(self.valid.mean()) if self.valid.size else 0.0

    @property
    def majority_hand(self) -> str:
        """The hand seen most often ("right" if none)."""
        return "left" if (self.handedness == -1).sum() > (self.handedness == 1).sum() else "right"


class HandCapture:
    """Per-frame hand capture: track, choose a hand, lift to metres, map to the base frame.

    Parameters
    ----------
    cfg : CaptureConfig
    intrinsics : Intrinsics, optional
        The colour camera's intrinsics from the source (e.g. RealSense); overrides
        none given in ``cfg.lift``. For RGB-only sources without any, an ideal camera
        with ``cfg.assumed_hfov_deg`` is assumed (approximate, logged).
    tracker, side_tracker : HandTracker, optional
        Injected trackers (default: built from ``cfg.tracker``); ``side_tracker`` is
        the second camera of a pair.
    """

    def __init__(
        self,
        cfg: CaptureConfig | None = None,
        intrinsics: Intrinsics | None = None,
        tracker: HandTracker | None = None,
        side_tracker: HandTracker | None = None,
        *,
        has_depth: bool | None = None,
    ) -> None:
        self.cfg = cfg or CaptureConfig()
        self.lift_cfg = self.cfg.lift
        if self.lift_cfg.intrinsics is None and intrinsics is not None:
            from dataclasses import replace

            self.lift_cfg = replace(self.lift_cfg, intrinsics=intrinsics)
        model = self.lift_cfg.model
        if has_depth is False and model in DEPTH_MODELS:
            raise InvalidInput(
                f"lift model {model!r} needs depth, but the source has none (RGB only); "
                "use LiftConfig.model pnp, assumed_depth or world_fit, or an RGB-D source"
            )
        if model == "pinhole" and self.lift_cfg.intrinsics is None:
            raise InvalidInput(
                "lift model 'pinhole' needs camera intrinsics: the source gives none and none "
                "were configured (LiftConfig.intrinsics)"
            )
        self._assumed_K = False
        self._own = tracker is None
        self.tracker = tracker or make_tracker(self.cfg.tracker)
        self._own_side = side_tracker is None and model == "two_webcams"
        self.side_tracker = side_tracker
        if self._own_side:
            self.side_tracker = make_tracker(self.cfg.tracker)
        self.depth_filled_total = 0
        self.pnp = PnPTracker(self.lift_cfg.pnp) if model == "pnp" else None
        self._track_pnp: dict[int, PnPTracker] = {}  # process_tracks: one per hand

    def _intrinsics_for(self, shape: tuple[int, ...]) -> Intrinsics | None:
        h, w = shape[:2]
        K = self.lift_cfg.intrinsics
        if K is None:
            if self.lift_cfg.model not in RGB_MODELS:
                return None
            K = Intrinsics.from_fov(w, h, self.cfg.assumed_hfov_deg)
            if not self._assumed_K:
                logger.warning(
                    "no camera intrinsics: assuming an ideal camera with %.0f deg horizontal "
                    "field of view (approximate)",
                    self.cfg.assumed_hfov_deg,
                )
                self._assumed_K = True
            from dataclasses import replace

            self.lift_cfg = replace(self.lift_cfg, intrinsics=K)
        if (K.width, K.height) != (w, h):
            if not math.isclose(K.width / K.height, w / h, rel_tol=1e-2):
                logger.warning(
                    "intrinsics are for %dx%d but frames are %dx%d (aspect differs)",
                    K.width,
                    K.height,
                    w,
                    h,
                )
            K = K.scaled(w, h)
            from dataclasses import replace

            self.lift_cfg = replace(self.lift_cfg, intrinsics=K)
        return K

    def process(self, frame: Frame) -> FrameKeypoints:
        """Landmarks of one frame in the base frame (NaN and ``valid=False`` without a hand)."""
        hands = self.tracker.detect(frame.rgb, frame.t)
        obs = select_hand(hands, self.cfg.tracker.hand)
        if obs is None:
            if self.pnp is not None:
                self.pnp.reset()  # the hand may come back anywhere
            return _no_hand(frame.t)
        return self.lift_observation(frame, obs, len(hands), self.pnp)

    def process_tracks(
        self, frame: Frame, associator: HandAssociator
    ) -> list[tuple[int, FrameKeypoints]]:
        """Every hand of one frame, lifted, with its persistent track id (see ``association``).

        The ``"pnp"`` lift keeps one :class:`PnPTracker` per track, so two hands never
        seed or gate each other's pose; a track not seen in this frame starts afresh.
        """
        hands = self.tracker.detect(frame.rgb, frame.t)
        seen = associator.update(hands, frame.t)
        if self.pnp is not None:
            for k in set(self._track_pnp) - {k for k, _ in seen}:
                self._track_pnp[k].reset()  # the hand may come back anywhere
        return [
            (k, self.lift_observation(frame, obs, len(hands), self._pnp_for(k))) for k, obs in seen
        ]

    def _pnp_for(self, track: int) -> PnPTracker | None:
        if self.pnp is None:
            return None
        if track not in self._track_pnp:
            self._track_pnp[track] = PnPTracker(self.lift_cfg.pnp)
        return self._track_pnp[track]

    def lift_observation(
        self, frame: Frame, obs: HandObservation, n_hands: int, pnp: PnPTracker | None = None
    ) -> FrameKeypoints:
        """One detected hand of ``frame`` lifted to the base frame.

        ``pnp`` is that hand's tracker for the ``"pnp"`` lift (None: a single frame).
        """
        nan_kp = np.full((21, 3), np.nan)
        self._intrinsics_for(frame.rgb.shape)
        depth = None
        filled = 0
        if self.lift_cfg.model in DEPTH_MODELS:
            if frame.depth_m is None:
                raise InvalidInput(
                    f"lift model {self.lift_cfg.model!r} needs depth; frame has none"
                )
            depth = robust_depth(
                frame.depth_m, obs.uv_px, self.lift_cfg.depth_patch_px, self.lift_cfg.depth_range_m
            )
            depth, filled = _fill_depth(depth, obs.world_m)
        uv2 = None
        if self.lift_cfg.model == "two_webcams":
            if frame.rgb2 is None or self.side_tracker is None:
                raise InvalidInput(
                    "lift model 'two_webcams' needs a pair of cameras (webcams:TOP,SIDE)"
                )
            side = select_hand(self.side_tracker.detect(frame.rgb2, frame.t), self.cfg.tracker.hand)
            if side is None:
                return FrameKeypoints(
                    frame.t, nan_kp, False, obs.uv_px, obs.score, obs.handedness, n_hands, 0, obs
                )
            uv2 = side.uv_px
        kp = lift(LiftInput(obs.uv_px, depth, uv2, obs.world_m), self.lift_cfg, pnp)
        valid = bool(np.isfinite(kp[[0, 4, 8]]).all())
        self.depth_filled_total += filled
        return FrameKeypoints(
            frame.t, kp, valid, obs.uv_px, obs.score, obs.handedness, n_hands, filled, obs
        )

    def close(self) -> None:
        """Close the trackers this object made."""
        if self._own:
            self.tracker.close()
        if self._own_side and self.side_tracker is not None:
            self.side_tracker.close()

    def __enter__(self) -> HandCapture:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def describe(self) -> dict[str, Any]:
        """Settings for the output file's meta (JSON-able)."""
        from dataclasses import asdict

        K = self.lift_cfg.intrinsics
        lc = self.lift_cfg
        approx = lc.approximate or (K is not None and K.approximate and lc.model != "two_webcams")
        out: dict[str, Any] = {
            "tracker": asdict(self.cfg.tracker),
            "lift_model": lc.model,
            "camera2base": lc.camera2base.tolist(),
            "intrinsics": None if K is None else K.as_dict(),
            "depth": "approximate" if approx else "measured",
        }
        if lc.model == "assumed_depth":
            out["assumed_wrist_depth_m"] = lc.assumed_wrist_depth_m
        if lc.model in RGB_MODELS:
            out["note"] = (
                "APPROXIMATE depth: RGB-only video has no metric depth; MediaPipe world "
                f"landmarks placed by the {lc.model!r} model with "
                + ("assumed" if K is None or K.approximate else "given")
                + " intrinsics"
            )
        if self.pnp is not None:
            out["pnp"] = asdict(lc.pnp)
            counts = dict(self.pnp.counts)
            for tracker in self._track_pnp.values():
                counts = {k: counts[k] + tracker.counts[k] for k in counts}
            out["pnp_frames"] = counts
        if lc.model == "angle":
            out["angle_model"] = asdict(lc.angle)
        if lc.model == "two_webcams":
            out["two_webcams"] = asdict(lc.two_webcams)
        if lc.model in DEPTH_MODELS:
            out["depth_patch_px"] = lc.depth_patch_px
        return out


def _chosen_rows(
    times: list[float],
    per_track: dict[int, dict[int, FrameKeypoints]],
    counts: list[int],
    hand: str,
) -> tuple[list[FrameKeypoints], dict[str, Any]]:
    """The rows of the chosen track (no-hand rows elsewhere) and the choice's report."""
    n = len(times)
    acts: list[TrackActivity] = []
    for k, track_rows in per_track.items():
        ok = [r for r in track_rows.values() if r.valid]
        uv = np.stack([r.uv_px for r in ok]) if ok else np.zeros((0, 21, 2))
        acts.append(hand_activity(k, uv, [r.handedness for r in ok], n))
    if not any(a.seen > 0 for a in acts):
        return [_no_hand(t) for t in times], {"hand": None, "reason": "no hand"}
    best, why = choose_track([a for a in acts if a.seen > 0], hand)
    chosen = per_track[best.track]
    out = [
        replace(chosen[i], n_hands=counts[i])
        if i in chosen
        else replace(_no_hand(times[i]), n_hands=counts[i])
        for i in range(n)
    ]
    from dataclasses import asdict

    return out, {
        "requested": hand,
        "hand": best.label,
        "track": best.track,
        "reason": why,
        "tracks": [asdict(a) for a in acts],
        "convention": "labels name the person's hand on an unmirrored image "
        "(MediaPipe's selfie labels swapped unless TrackerConfig.mirrored)",
    }


def _no_hand(t: float) -> FrameKeypoints:
    return FrameKeypoints(
        t, np.full((21, 3), np.nan), False, np.full((21, 2), np.nan), math.nan, "", 0, 0
    )


def _fill_depth(depth: FloatArray, world_m: FloatArray) -> tuple[FloatArray, int]:
    """Fill NaN landmark depths from the others plus MediaPipe's relative z (camera-aligned)."""
    bad = ~np.isfinite(depth)
    n_bad = int(bad.sum())
    if n_bad == 0 or n_bad == depth.size or not np.isfinite(world_m).all():
        return depth, 0
    offset = np.median(depth[~bad] - world_m[~bad, 2])
    out = depth.copy()
    out[bad] = world_m[bad, 2] + offset
    return out, n_bad


def track_source(
    source: FrameSource,
    cfg: CaptureConfig | None = None,
    *,
    capture: HandCapture | None = None,
    callback: Callable[[int, float], None] | None = None,
    on_frame: Callable[[Frame, FrameKeypoints], None] | None = None,
    hand: str | None = None,
) -> KeypointSeries:
    """Run hand capture over an open source.

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
        that label; ``meta["hand_choice"]`` says which and why. None (default):
        per frame, the hand with the tracker's preferred label
        (``cfg.tracker.hand``), as teleoperation does.

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
    rows: list[FrameKeypoints] = []
    times: list[float] = []
    per_track: dict[int, dict[int, FrameKeypoints]] = {}
    counts: list[int] = []
    associator = HandAssociator() if hand is not None else None
    shape: tuple[int, ...] = ()
    try:
        for i, frame in enumerate(source):
            if associator is None:
                res = cap.process(frame)
                rows.append(res)
            else:
                found = cap.process_tracks(frame, associator)
                for k, r in found:
                    per_track.setdefault(k, {})[i] = r
                counts.append(len(found))
                times.append(frame.t)
                res = found[0][1] if found else _no_hand(frame.t)
            shape = frame.rgb.shape
            if on_frame is not None:
                on_frame(frame, res)
            if callback is not None:
                callback(frame.index, frame.t)
    finally:
        if own:
            cap.close()
    choice: dict[str, Any] | None = None
    if associator is not None:
        rows, choice = _chosen_rows(times, per_track, counts, hand or "auto")
    n = len(rows)
    if n == 0:
        raise InvalidDemonstration(f"{source.description}: no frames")
    valid = np.array([r.valid for r in rows])
    if not valid.any():
        seen = sum(r.n_hands > 0 for r in rows)
        if seen:
            raise InvalidDemonstration(
                f"{source.description}: a hand was detected in {seen} of {n} frames but could "
                f"not be lifted to 3-D by the {cap.lift_cfg.model!r} model (no valid depth at "
                "the wrist/thumb/index: depth image empty or all holes?)"
            )
        raise InvalidDemonstration(
            f"{source.description}: no hand detected in any of the {n} frames"
        )
    series = KeypointSeries(
        t=np.array([r.t for r in rows]),
        keypoints=np.stack([r.keypoints for r in rows]),
        valid=valid,
        uv_px=np.stack([r.uv_px for r in rows]),
        score=np.array([r.score for r in rows]),
        handedness=np.array([HANDEDNESS_CODE.get(r.handedness, 0) for r in rows], np.int8),
        n_hands=np.array([r.n_hands for r in rows]),
        depth_filled=np.array([r.depth_filled for r in rows]),
        meta={
            "source": source.description,
            "source_kind": source.kind,
            "fps": source.fps,
            "image_size": [int(shape[1]), int(shape[0])] if shape else None,
            **cap.describe(),
            **({"hand_choice": choice} if choice is not None else {}),
        },
    )
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
    return series
