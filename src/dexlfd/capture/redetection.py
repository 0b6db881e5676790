"""Looking again for a hand the tracker lost: a crop around where its motion predicts it.

MediaPipe's video tracker loses a hand in fast motion (blur), behind the object it
carries, or on a background of its own colour, while a person still sees it; a hand
only a few tens of pixels wide is also hard for its palm detector at full frame. For
every hand seen in the previous frames (in ``min_seen_frames`` at least: a one-frame
false detection is not looked for) and missing now (at most ``max_lost_frames`` in a
row, and until ``max_misses`` crops in a row did not find it: a hand that left or is
hidden is not searched for 20 frames), :class:`Redetector` predicts its palm centre
from its last two sightings (constant velocity), cuts a square of ``crop_hands`` hand
sizes around the prediction, scales it up to ``crop_px`` and runs the hand landmarker
on it (IMAGE mode: one picture, no tracking state). A hand found there whose palm
centre maps back to within ``gate_hands`` hand sizes of the prediction, and that is not
a hand the tracker already reports, is the lost hand: its landmarks are mapped back to
the frame (image landmarks shifted and scaled, MediaPipe's relative depth scaled with the crop, the
metric world landmarks unchanged) and it is reported with ``redetected=True``, so the
association (:mod:`dexlfd.capture.association`) joins it to the same track and a
landmark recording keeps it (``redetected`` array) for re-processing.

A hand predicted outside the picture (it left the frame) is not looked for.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.tracking import HandObservation, TrackerConfig

__all__ = ["RedetectConfig", "Redetector", "crop_box", "map_back"]

logger = logging.getLogger(__name__)
_PALM = (0, 5, 9, 13, 17)


@dataclass(frozen=True, slots=True)
class RedetectConfig:
    """Settings of :class:`Redetector` (sizes in hand sizes: the landmarks' box side)."""

    max_lost_frames: int = 20  # look for a lost hand for at most this many frames
    min_seen_frames: int = 2  # ... seen in at least this many frames before (not a flicker)
    max_misses: int = 6  # ... and stop after this many crops in a row without it
    crop_hands: float = 3.0  # crop side [hand sizes]
    min_crop_px: int = 64  # smallest crop side [px at the frame]
    crop_px: int = 320  # the crop is scaled up to this side [px] (never down)
    gate_hands: float = 1.0  # a hand found this near the prediction is the lost one
    duplicate_hands: float = 0.5  # ... unless a reported hand is this near


@dataclass
class _Hand:
    """One hand's last sighting and velocity, for the prediction."""

    centre: FloatArray  # palm centre [px]
    size: float  # landmarks' box side [px]
    t: float
    velocity: FloatArray = field(default_factory=lambda: np.zeros(2))  # [px/s]
    lost: int = 0  # frames missing since
    seen: int = 1  # frames it was seen in (up to its loss)
    misses: int = 0  # crops looked at in a row without finding it

    def predict(self, t: float) -> FloatArray:
        return self.centre + self.velocity * (t - self.t)


def _centre_size(obs: HandObservation) -> tuple[FloatArray, float]:
    uv = np.asarray(obs.uv_px, dtype=np.float64)
    side = float(np.max(uv.max(axis=0) - uv.min(axis=0)))
    return uv[list(_PALM)].mean(axis=0), max(side, 1.0)


def crop_box(
    centre: FloatArray, side: float, size_px: tuple[int, int]
) -> tuple[int, int, int, int] | None:
    """``(x0, y0, x1, y1)`` of a square crop of ``side`` [px] at ``centre``, inside the image.

    Shifted (not shrunk) to stay inside; None when the centre is outside the image.
    """
    w, h = size_px
    cx, cy = float(centre[0]), float(centre[1])
    if not (0 <= cx < w and 0 <= cy < h):
        return None
    s = int(min(round(side), w, h))
    x0 = int(np.clip(round(cx - s / 2), 0, w - s))
    y0 = int(np.clip(round(cy - s / 2), 0, h - s))
    return x0, y0, x0 + s, y0 + s


def map_back(
    obs: HandObservation, box: tuple[int, int, int, int], scale: float, width_px: int
) -> HandObservation:
    """``obs`` found in a crop ``box`` scaled by ``scale``, in the frame's pixels.

    Image landmarks are shifted and scaled; MediaPipe's relative depth (in units of
    the picture's width) is rescaled to the frame's width; world landmarks are metric
    and stay.
    """
    x0, y0, x1, _ = box
    uv = np.asarray(obs.uv_px, dtype=np.float64) / scale + np.array([x0, y0], dtype=np.float64)
    z = np.asarray(obs.z_rel, dtype=np.float64) * (x1 - x0) / float(width_px)
    return replace(obs, uv_px=uv, z_rel=z, redetected=True)


class Redetector:
    """Finds lost hands again in a crop around their predicted place (module docstring).

    ``update(rgb, t, hands)`` once per frame with the tracker's hands; returns them
    plus any hand found again. ``n_redetected`` counts the hands found again.
    """

    def __init__(
        self,
        tracker_cfg: TrackerConfig,
        cfg: RedetectConfig | None = None,
        detector: Any = None,
    ) -> None:
        self.cfg = cfg or RedetectConfig()
        self.max_hands = tracker_cfg.max_num_hands
        self._tracker_cfg = replace(tracker_cfg, static_image_mode=True, max_num_hands=2)
        self._detector = detector  # built on first use (most frames need none)
        self._hands: list[_Hand] = []
        self.n_redetected = 0
        self.n_tries = 0

    def _detect(self, crop: np.ndarray) -> list[HandObservation]:
        if self._detector is None:
            from dexlfd.capture.tracking import make_tracker

            self._detector = make_tracker(self._tracker_cfg)
        found: list[HandObservation] = self._detector.detect(crop, 0.0)
        return found

    def update(
        self, rgb: np.ndarray, t: float, hands: list[HandObservation]
    ) -> list[HandObservation]:
        """The frame's hands: the tracker's, then any lost hand found again."""
        h, w = rgb.shape[:2]
        seen = [_centre_size(o) for o in hands]  # of each hand in ``out``
        matched = self._match(seen)
        out = list(hands)
        missed: set[int] = set()
        for k, prev in enumerate(self._hands):
            if k in matched or not self._worth_looking(prev):
                continue
            if len(out) >= self.max_hands:
                break
            found = self._look_again(rgb, t, prev, (w, h), [c for c, _ in seen])
            if found is not None:
                out.append(found)
                seen.append(_centre_size(found))
                matched[k] = len(out) - 1
            else:
                missed.add(k)
        self._advance(t, seen, matched, missed)
        return out

    def _worth_looking(self, prev: _Hand) -> bool:
        """A hand seen steadily (not a one-frame flicker), lost recently, not given up."""
        cfg = self.cfg
        return (
            prev.lost < cfg.max_lost_frames
            and prev.seen >= cfg.min_seen_frames
            and prev.misses < cfg.max_misses
        )

    def _match(self, seen: list[tuple[FloatArray, float]]) -> dict[int, int]:
        """Previous hand -> this frame's hand, nearest first within 1.5 hand sizes."""
        pairs = sorted(
            (float(np.linalg.norm(c - p.centre)) / p.size, k, j)
            for k, p in enumerate(self._hands)
            for j, (c, _) in enumerate(seen)
        )
        matched: dict[int, int] = {}
        for d, k, j in pairs:
            if d <= 1.5 and k not in matched and j not in matched.values():
                matched[k] = j
        return matched

    def _look_again(
        self,
        rgb: np.ndarray,
        t: float,
        prev: _Hand,
        size_px: tuple[int, int],
        others: list[FloatArray],
    ) -> HandObservation | None:
        cfg = self.cfg
        guess = prev.predict(t)
        side = max(cfg.crop_hands * prev.size, float(cfg.min_crop_px))
        box = crop_box(guess, side, size_px)
        if box is None:
            return None
        import cv2

        x0, y0, x1, y1 = box
        scale = max(1.0, cfg.crop_px / float(x1 - x0))
        crop = np.ascontiguousarray(rgb[y0:y1, x0:x1])
        if scale > 1.0:
            crop = cv2.resize(crop, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC)
        self.n_tries += 1
        best, best_d = None, np.inf
        for obs in self._detect(crop):
            back = map_back(obs, box, scale, size_px[0])
            centre, _ = _centre_size(back)
            d = float(np.linalg.norm(centre - guess)) / prev.size
            dup = any(np.linalg.norm(centre - o) / prev.size < cfg.duplicate_hands for o in others)
            if d <= cfg.gate_hands and not dup and d < best_d:
                best, best_d = back, d
        if best is not None:
            self.n_redetected += 1
        return best

    def _advance(
        self,
        t: float,
        hands: list[tuple[FloatArray, float]],
        matched: dict[int, int],
        missed: set[int],
    ) -> None:
        """Sightings for the next frame: this one's hands (palm centre, size), the lost aged."""
        nxt: list[_Hand] = []
        taken = set(matched.values())
        for k, prev in enumerate(self._hands):
            if k in matched:
                c, s = hands[matched[k]]
                dt = t - prev.t
                vel = (c - prev.centre) / dt if dt > 0 else prev.velocity
                nxt.append(_Hand(c, s, t, vel, 0, prev.seen + 1))
            elif prev.lost + 1 <= self.cfg.max_lost_frames:
                nxt.append(replace(prev, lost=prev.lost + 1, misses=prev.misses + (k in missed)))
        for j, (c, s) in enumerate(hands):
            if j not in taken:
                nxt.append(_Hand(c, s, t))
        self._hands = nxt

    def close(self) -> None:
        """Release the crop detector."""
        if self._detector is not None:
            self._detector.close()
            self._detector = None
