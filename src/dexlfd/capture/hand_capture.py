"""Per-frame hand capture: frames -> 3-D hand keypoints in the robot base frame.

:class:`HandCapture` (``process(frame) -> FrameKeypoints``, used by teleoperation and
by :func:`~dexlfd.capture.track_source` for a whole source) tracks the hand, chooses
one, lifts it to metres (:mod:`dexlfd.capture.lifting`) and maps it to the base frame.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._params import param
from dexlfd._types import FloatArray
from dexlfd.capture.association import HandAssociator
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.frame_source import Frame
from dexlfd.capture.keypoints import FrameKeypoints, no_hand
from dexlfd.capture.lifting import (
    DEPTH_MODELS,
    RGB_MODELS,
    LiftConfig,
    LiftInput,
    lift,
    robust_depth,
)
from dexlfd.capture.rgb_lifting import PnPTracker
from dexlfd.capture.tracking import (
    HandObservation,
    HandTracker,
    TrackerConfig,
    make_tracker,
    select_hand,
)
from dexlfd.errors import InvalidInput

__all__ = ["CaptureConfig", "HandCapture"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class CaptureConfig:
    """Tracker, lifting model and what to assume when the source says nothing."""

    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    lift: LiftConfig = field(default_factory=LiftConfig)
    assumed_hfov_deg: float = param(
        60.0,
        "without --intrinsics: ASSUMED horizontal field of view, ideal camera (60: a "
        "typical webcam); metric depth scales with it",
        unit="deg",
        lo=1.0,
        hi=179.0,
        flag="--fov-deg",
    )  # field of view assumed for RGB-only video [deg]

    def __post_init__(self) -> None:
        if not 0 < self.assumed_hfov_deg < 180:
            raise InvalidInput(f"assumed_hfov_deg must be in (0, 180), got {self.assumed_hfov_deg}")


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
    seeded_pnp : bool
        The ``"pnp"`` lift seeded and gated by the past (True, live); False: each
        frame's first plausible pose alone (a recording whose per-frame poses are
        replaced by the whole recording's, see :class:`PnPTracker`).
    """

    def __init__(
        self,
        cfg: CaptureConfig | None = None,
        intrinsics: Intrinsics | None = None,
        tracker: HandTracker | None = None,
        side_tracker: HandTracker | None = None,
        *,
        has_depth: bool | None = None,
        seeded_pnp: bool = True,
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
                "use the lift model pnp, assumed_depth or world_fit, or an RGB-D source",
                param="lift",
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
        self._seeded_pnp = seeded_pnp
        self.pnp = PnPTracker(self.lift_cfg.pnp, seeded=seeded_pnp) if model == "pnp" else None
        self._track_pnp: dict[int, PnPTracker] = {}  # process_tracks: one per hand
        self._frame_size: tuple[int, int] | None = None  # (width, height) of the last frame

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
            return no_hand(frame.t)
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
            self._track_pnp[track] = PnPTracker(self.lift_cfg.pnp, seeded=self._seeded_pnp)
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
            depth = self.landmark_depth(frame, obs)
            if depth is None:
                raise InvalidInput(
                    f"lift model {self.lift_cfg.model!r} needs depth; frame has none"
                )
            depth, filled = _fill_depth(depth, obs.world_m)
        uv2 = None
        if self.lift_cfg.model == "two_webcams":
            if frame.rgb2 is None or self.side_tracker is None:
                raise InvalidInput(
                    "lift model 'two_webcams' needs a pair of cameras (webcams:TOP,SIDE or "
                    "videos:TOP,SIDE)"
                )
            side = select_hand(self.side_tracker.detect(frame.rgb2, frame.t), self.cfg.tracker.hand)
            if side is None:
                return FrameKeypoints(
                    frame.t, nan_kp, False, obs.uv_px, obs.score, obs.handedness, n_hands, 0, obs
                )
            # Eqs. (4.1)-(4.8) read both images at one size: the side image's pixels
            # as fractions of its own size, at the top image's
            h2, w2 = frame.rgb2.shape[:2]
            uv2 = side.uv_px * np.array([frame.rgb.shape[1] / w2, frame.rgb.shape[0] / h2])
        size = (int(frame.rgb.shape[1]), int(frame.rgb.shape[0]))
        self._frame_size = size
        kp = lift(LiftInput(obs.uv_px, depth, uv2, obs.world_m, size), self.lift_cfg, pnp)
        valid = bool(np.isfinite(kp[[0, 4, 8]]).all())
        self.depth_filled_total += filled
        return FrameKeypoints(
            frame.t, kp, valid, obs.uv_px, obs.score, obs.handedness, n_hands, filled, obs
        )

    def landmark_depth(self, frame: Frame, obs: HandObservation) -> FloatArray | None:
        """(21,) depth [m] at the landmarks of ``obs`` (NaN at holes), None without depth.

        The depth ``obs`` carries (a replayed recording), else the robust patch median of
        the frame's depth image (``LiftConfig.depth_patch_px``, ``depth_range_m``).
        """
        if obs.depth_m is not None:
            return np.array(obs.depth_m, dtype=np.float64)
        if frame.depth_m is None:
            return None
        return robust_depth(
            frame.depth_m, obs.uv_px, self.lift_cfg.depth_patch_px, self.lift_cfg.depth_range_m
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
            out["pnp_frames"]["shape_held"] = self.pnp.shape_held + sum(
                tracker.shape_held for tracker in self._track_pnp.values()
            )
        size = self._frame_size
        if lc.model == "angle":  # as used: at the frames' size
            out["angle_model"] = asdict(lc.angle if size is None else lc.angle.at_size(*size))
        if lc.model == "two_webcams":
            rig = lc.two_webcams if size is None else lc.two_webcams.at_size(*size)
            out["two_webcams"] = asdict(rig)
        if lc.model in DEPTH_MODELS:
            out["depth_patch_px"] = lc.depth_patch_px
        return out


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
