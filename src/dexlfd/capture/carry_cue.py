"""Something moving with the hand: the pixels beside the fingers that follow the palm.

A hand that carries an object moves the object's pixels with it; an empty hand moving
over a still scene leaves the pixels around it where they were. The skeleton alone
cannot tell a relaxed, half-closed hand moving to an object from a hand carrying it;
the picture can. :class:`CarryCue` measures, between consecutive frames and for every
hand seen in both, the motion of image corners in a *ring* around the hand:

* the ring is the hand's landmark box grown by ``ring_hands`` hand sizes per side,
  without the hand itself (its landmarks' convex hull grown by ``hand_margin`` hand
  sizes) and without what lies behind the wrist (the forearm moves with the hand and
  is no object: only points ahead of the wrist along the wrist -> middle-finger axis);
* corners there (Shi-Tomasi) in the previous frame are followed into this one
  (pyramidal Lucas-Kanade);
* a corner *moves with the hand* when its displacement is within ``match`` of the
  palm centre's (relative, plus 1.5 px), and *stays* when it moved less than ``match``
  of it (plus 1 px).

The cue is the fraction of the two that moved with the hand, defined only when the palm
moved at least ``min_palm_px`` and ``min_points`` corners were classified (NaN
otherwise: a still hand says nothing). Near 1: something carried; near 0: an empty hand
over a still scene (or a scene that does not move with it). It is measured on a grey
copy at most ``width_px`` wide. Stored per hand in the landmark recording
(``carry_cue``) and read by :func:`dexlfd.motion.phases.hand_phases`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.frame_grey import FrameGrey
from dexlfd.capture.tracking import HandObservation

__all__ = ["CarryCue", "CarryCueConfig", "ring_corners", "ring_mask"]

_PALM = (0, 5, 9, 13, 17)


@dataclass(frozen=True, slots=True)
class CarryCueConfig:
    """Settings of :class:`CarryCue`."""

    width_px: int = 640  # measured on a grey copy at most this wide [px]
    ring_hands: float = 0.5  # ring: the hand's box grown by this [hand sizes] per side
    hand_margin: float = 0.08  # the hand itself: its hull grown by this [hand sizes]
    match: float = 0.35  # a corner's motion within this of the palm's [relative]
    min_palm_px: float = 2.0  # the palm moved at least this much [px at width_px]
    min_points: int = 6  # classified corners needed for a cue
    max_corners: int = 60


def _palm(uv: FloatArray) -> FloatArray:
    return np.asarray(uv[list(_PALM)], dtype=np.float64).mean(axis=0)


def ring_mask(uv: FloatArray, shape: tuple[int, int], cfg: CarryCueConfig) -> np.ndarray:
    """uint8 mask (255 in the ring) of a hand with image landmarks ``uv`` [px] in ``shape``."""
    import cv2

    h, w = shape
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    size = float(max(hi - lo))
    grow = cfg.ring_hands * size
    x0, y0 = (int(max(0, v)) for v in np.floor(lo - grow))
    x1, y1 = int(min(w, np.ceil(hi[0] + grow))), int(min(h, np.ceil(hi[1] + grow)))
    mask = np.zeros((h, w), np.uint8)
    if x1 <= x0 or y1 <= y0:
        return mask
    mask[y0:y1, x0:x1] = 255
    hull = cv2.convexHull(np.round(uv).astype(np.int32))
    cv2.fillConvexPoly(mask, hull, 0)
    margin = max(1, int(round(cfg.hand_margin * size)))
    cv2.polylines(mask, [hull], True, 0, thickness=2 * margin)
    # behind the wrist: the forearm
    axis = np.asarray(uv[9] - uv[0], dtype=np.float64)
    if float(np.linalg.norm(axis)) > 0:
        # per pixel (x - wrist) . axis, a column's and a row's term added by broadcasting
        along_x = (np.arange(x0, x1) - uv[0][0]) * axis[0]
        along_y = (np.arange(y0, y1) - uv[0][1]) * axis[1]
        behind = along_x[None, :] + along_y[:, None] < 0
        mask[y0:y1, x0:x1][behind] = 0
    return mask


def ring_corners(
    grey: np.ndarray, mask: np.ndarray, cfg: CarryCueConfig, size: float
) -> np.ndarray | None:
    """Shi-Tomasi corners of ``grey`` in the ring ``mask`` (hand size ``size`` [px]), or None.

    ``cv2.goodFeaturesToTrack`` on the ring's bounding box grown by 4 px, not on the
    whole frame: a corner's score reads the pixels within 2 px of it and the local
    maximum test its neighbours' scores, so inside the ring they are the whole frame's
    (and the strongest score the quality level is taken from is the ring's alike);
    the same corners, shifted back to the frame.
    """
    import cv2

    x, y, w, h = cv2.boundingRect(mask)
    if w == 0 or h == 0:
        return None
    pad = 4
    x0, y0 = max(0, x - pad), max(0, y - pad)
    x1, y1 = min(grey.shape[1], x + w + pad), min(grey.shape[0], y + h + pad)
    pts = cv2.goodFeaturesToTrack(
        np.ascontiguousarray(grey[y0:y1, x0:x1]),
        cfg.max_corners,
        0.01,
        max(3.0, size / 10),
        mask=np.ascontiguousarray(mask[y0:y1, x0:x1]),
    )
    if pts is None:
        return None
    return np.asarray(pts + np.array([x0, y0], np.float32), np.float32)


class CarryCue:
    """Per-frame carry cue of every hand (module docstring); ``update`` once per frame."""

    def __init__(self, cfg: CarryCueConfig | None = None) -> None:
        self.cfg = cfg or CarryCueConfig()
        self._prev: np.ndarray | None = None  # grey, at the working scale
        self._prev_hands: list[FloatArray] = []  # uv at the working scale
        self._prev_palms: list[FloatArray] = []  # their palm centres

    def update(
        self, rgb: np.ndarray, hands: list[HandObservation], frame: FrameGrey | None = None
    ) -> list[HandObservation]:
        """``hands`` with ``carry`` set (NaN where not measurable).

        ``frame``: the grey copies of ``rgb`` other cues share (made here if not given).
        """
        grey, scale = self._grey(frame if frame is not None else FrameGrey(rgb))
        now = [np.asarray(o.uv_px, dtype=np.float64) * scale for o in hands]
        palms = [_palm(uv) for uv in now]
        out = []
        for obs, uv, centre in zip(hands, now, palms, strict=True):
            cue = self._cue(grey, uv, centre)
            out.append(replace(obs, carry=cue))
        self._prev, self._prev_hands, self._prev_palms = grey, now, palms
        return out

    def _grey(self, frame: FrameGrey) -> tuple[np.ndarray, float]:
        """The grey frame at most ``cfg.width_px`` wide and its scale.

        ``cv2.resize(rgb, None, fx=scale, fy=scale)``: the same as a resize to the size
        it rounds to, and shared through ``frame``, when that size has the same scale
        in both directions (e.g. 1920x1080 -> 640x360).
        """
        import cv2

        w, h = frame.size
        scale = min(1.0, self.cfg.width_px / float(w))
        if scale == 1.0:
            return frame.linear((w, h)), scale
        # OpenCV's size for fx = fy = scale: rounded half to even
        sw, sh = int(np.rint(w * scale)), int(np.rint(h * scale))
        if sw / w == scale and sh / h == scale:
            return frame.linear((sw, sh)), scale
        small = cv2.resize(np.ascontiguousarray(frame.rgb), None, fx=scale, fy=scale)
        return cv2.cvtColor(small, cv2.COLOR_RGB2GRAY), scale

    def _cue(self, grey: np.ndarray, uv: FloatArray, centre: FloatArray) -> float:
        """The cue of the hand ``uv`` (palm centre ``centre``) against the last frame."""
        import cv2

        if self._prev is None or not self._prev_hands or self._prev.shape != grey.shape:
            return float("nan")
        cfg = self.cfg
        # the last frame's hand whose palm was nearest (the first of equals)
        moves = [centre - p for p in self._prev_palms]
        k = min(range(len(moves)), key=lambda i: float(np.linalg.norm(moves[i])))
        before = self._prev_hands[k]
        size = float(max(before.max(axis=0) - before.min(axis=0)))
        move = moves[k]
        step = float(np.linalg.norm(move))
        if step > size or step < cfg.min_palm_px:  # another hand, or a still one
            return float("nan")
        pts = ring_corners(self._prev, ring_mask(before, grey.shape, cfg), cfg, size)
        if pts is None or len(pts) < cfg.min_points:
            return float("nan")
        nxt, status, _ = cv2.calcOpticalFlowPyrLK(
            self._prev,
            grey,
            pts,
            None,
            winSize=(15, 15),
            maxLevel=2,  # type: ignore[call-overload]
        )
        ok = np.asarray(status).ravel() == 1
        flow = (np.asarray(nxt) - np.asarray(pts)).reshape(-1, 2)[ok]
        with_hand = np.linalg.norm(flow - move, axis=1) < cfg.match * step + 1.5
        stays = np.linalg.norm(flow, axis=1) < cfg.match * step + 1.0
        n = int(with_hand.sum() + stays.sum())
        if n < cfg.min_points:
            return float("nan")
        return float(with_hand.sum()) / n
