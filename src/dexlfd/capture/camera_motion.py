"""Is the camera moving? The background's motion from frame to frame, measured cheaply.

A demonstration's positions are in the camera's frame; when a hand-held camera pans
or zooms, the hand's path is mixed with the camera's and is not the hand's motion.
:class:`CameraMotionEstimator` measures, per frame, the similarity transform
(shift, zoom, rotation) that carries the previous frame's background onto this
one: corners (Shi-Tomasi) of a downscaled grey keyframe are followed by pyramidal
Lucas-Kanade optical flow, the hands' boxes (enlarged, so a held object goes
with them) are masked out in both frames, and the transform is fitted with RANSAC,
so a moving arm or object that is not masked is an outlier as long as most of the
picture is background; when a third of the corners did not move at all, the camera
did not (something large moved in front of it). At 320 px wide this costs ~3 ms a
frame at 1920x1080.

:func:`camera_motion_report` turns the per-frame rows into the figures a verdict
reads: how far the background travelled (extent of its accumulated shift, as a
fraction of the frame width), zoomed and turned over the recording, and the frame
ranges where it moved; ``moving`` is True when any extent passes its limit in
:class:`CameraMotionConfig`.

Rows are ``(dx_px, dy_px, log_scale, rotation_rad)``: the shift of the image centre
[px of the full frame], the natural log of the zoom factor (> 0: zooming in) and the
rotation, from the previous frame to this one; NaN where it could not be measured
(the first frame, too few background corners, a frame of another size).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.frame_grey import FrameGrey
from dexlfd.errors import InvalidInput

__all__ = [
    "CameraMotionConfig",
    "CameraMotionEstimator",
    "camera_motion_report",
    "log_camera_motion",
]

logger = logging.getLogger(__name__)

N_COLUMNS = 4  # dx_px, dy_px, log_scale, rotation_rad
Row = tuple[float, float, float, float]
NAN_ROW: Row = (math.nan, math.nan, math.nan, math.nan)


def _cv2() -> Any:
    import cv2

    return cv2


@dataclass(frozen=True, slots=True)
class CameraMotionConfig:
    """Settings of the background-motion estimate and of the "moving camera" verdict."""

    width_px: int = 320  # analysis width of the grey frame [px]
    max_corners: int = 200  # corners followed per frame
    min_points: int = 15  # fewer background inliers: the frame is not measured
    hand_margin: float = 0.5  # each hand's box grows by this fraction of its size per side
    ransac_px: float = 1.0  # RANSAC inlier distance [analysis px]
    # a still camera with something big moving in front of it (an arm the hand boxes
    # miss): this share of the corners did not move, so the camera did not
    static_px: float = 0.3  # a corner that moved less than this did not move [analysis px]
    static_fraction: float = 0.3
    key_every: int = 15  # frames before the keyframe is renewed (once measured cleanly)
    key_lost: int = 45  # frames without matching the keyframe before it is renewed
    clean_fraction: float = 0.7  # corners agreeing with the fit for a clean measurement
    # 2: a frame is held and measured with the next one, each getting half of the
    # change over the two, when that change is below pair_px [analysis px] and
    # pair_rad [ln zoom, rad] (1: every frame measured; see CameraMotionEstimator)
    measure_every: int = 2
    pair_px: float = 0.3
    pair_rad: float = 0.0003
    near_clean: float = 0.5  # the keyframe is due and this share agrees: both measured
    # the verdict: extents over the whole recording
    max_shift: float = 0.04  # accumulated background shift, fraction of the frame width
    max_zoom: float = 0.04  # accumulated |ln zoom|
    max_rotation_deg: float = 3.0  # accumulated rotation [deg]
    moving_speed: float = 0.0015  # per-frame shift (fraction of the width) counted as motion
    min_measured: float = 0.5  # fewer frames measured: "moving" is unknown (None)
    settle_frames: int = 15  # running-median window of the background's path [frames]

    def __post_init__(self) -> None:
        if self.width_px < 32:
            raise InvalidInput(f"width_px must be >= 32, got {self.width_px}")
        if self.min_points < 3 or self.max_corners < self.min_points:
            raise InvalidInput("need 3 <= min_points <= max_corners")
        if self.measure_every not in (1, 2):
            raise InvalidInput(f"measure_every must be 1 or 2, got {self.measure_every}")


@dataclass
class CameraMotionEstimator:
    """Per-frame background motion of a stream; feed it with :meth:`update`.

    Each frame is measured against a *keyframe* (an earlier frame), and its row is
    the change of that measurement since the previous frame, so within one
    keyframe's span the rows add up to the direct measurement from the keyframe: an
    error while an arm passes in front of a still camera is taken back as soon as
    the view clears, instead of adding up. Where the keyframe cannot be matched the
    frame is measured against the previous one (and those rows add up); the
    keyframe is renewed every ``cfg.key_every`` frames once a frame is measured
    cleanly (most corners agree), or after ``cfg.key_lost`` frames without a match.

    With ``cfg.measure_every = 2`` a frame is held (while the keyframe is matched)
    and measured with the next one: a measurement from the keyframe does not depend
    on the frames between, so where the background moved less than ``cfg.pair_px``
    / ``cfg.pair_rad`` over the two, each gets half of the change, and the
    background's path at the second is the one measuring every frame gives.
    Otherwise the held frame is measured too (the second's measurement kept), and
    so is it when the keyframe is due and the second nearly clean (the held one
    could have become the keyframe): the same rows as measuring every
    frame. Less optical-flow work where the camera stands still; a frame still held
    is measured when :attr:`motion` is read.
    """

    cfg: CameraMotionConfig = field(default_factory=CameraMotionConfig)
    rows: list[Row] = field(default_factory=list)
    _key: Any = None  # keyframe: grey image (analysis size) and its corners
    _key_pts: Any = None
    _key_age: int = 0
    _key_lost: int = 0  # frames since the keyframe was last matched
    _total: Row = (0.0, 0.0, 0.0, 0.0)  # keyframe -> previous frame
    _prev: Any = None  # previous grey frame and its mask (the fallback)
    _prev_mask: Any = None
    _full_size: tuple[int, int] | None = None
    _held: Any = None  # a frame waiting to be measured with the next: grey, mask, scale

    def update(self, rgb: np.ndarray, hands_uv_px: list[FloatArray]) -> None:
        """Measure frame ``rgb`` (H, W, 3) against the keyframe; hands' pixels masked."""
        grey, scale = self.analysis_grey(FrameGrey(rgb))
        self.update_grey(grey, scale, (int(rgb.shape[1]), int(rgb.shape[0])), hands_uv_px)

    def analysis_grey(self, frame: FrameGrey) -> tuple[np.ndarray, float]:
        """``frame``'s grey copy at most ``cfg.width_px`` wide, and its scale (<= 1).

        A cheap linear step to twice that width first (1080p: ~3x faster than one
        area step), the grey copy of it shared through ``frame``.
        """
        w, h = frame.size
        scale = self.cfg.width_px / w if w > self.cfg.width_px else 1.0
        aw, ah = max(1, round(w * scale)), max(1, round(h * scale))
        grey = frame.linear((2 * aw, 2 * ah) if w > 2 * aw else (w, h))
        if scale != 1.0:
            grey = _cv2().resize(grey, (aw, ah), interpolation=_cv2().INTER_AREA)
        return grey, scale

    def update_grey(
        self,
        grey: np.ndarray,
        scale: float,
        full_size: tuple[int, int],
        hands_uv_px: list[FloatArray],
    ) -> None:
        """:meth:`update` on the frame's :meth:`analysis_grey` (``full_size``: (W, H) [px])."""
        ah, aw = grey.shape[:2]
        mask = self._mask((ah, aw), hands_uv_px, scale)
        if self._key is None or self._full_size != full_size:
            self._flush()
            self.rows.append(NAN_ROW)
            self._new_key(grey, mask, full_size)
        elif self._held is None and self._may_hold():
            self._held = (grey, mask, scale)
            self.rows.append(NAN_ROW)  # set when the next frame is measured
            return
        elif self._held is None:
            self.rows.append(self._row(grey, mask, scale, (aw, ah)))
        else:
            self._pair(grey, mask, scale, (aw, ah))
        self._prev, self._prev_mask = grey, mask

    def _may_hold(self) -> bool:
        """Whether the coming frame may wait for the next one (class docstring)."""
        return self.cfg.measure_every == 2 and self._key_lost == 0

    def _pair(
        self, grey: np.ndarray, mask: np.ndarray, scale: float, size: tuple[int, int]
    ) -> None:
        """The held frame and this one: half the change each, if small (class docstring).

        Otherwise measured one by one, as without holding (this frame's measurement
        from the keyframe kept): when this frame does not match the keyframe, when the
        background moved more than ``cfg.pair_px`` / ``cfg.pair_rad``, or when the
        keyframe is due and this frame nearly clean (the held one could have been the
        new keyframe).
        """
        key = self._key
        direct, agree = self._measure(key, self._key_pts, grey, mask, scale, size)
        change = _minus(direct, self._total)
        due = self._key_age + 1 >= self.cfg.key_every
        if (
            all(math.isfinite(v) for v in direct)
            and not (due and agree >= self.cfg.near_clean)
            and max(abs(change[0]), abs(change[1])) * scale <= self.cfg.pair_px
            and max(abs(change[2]), abs(change[3])) <= self.cfg.pair_rad
        ):
            self._held = None
            self.rows[-1] = _half(change)
            self.rows.append(_half(change))
            self._matched(direct, agree, 2, grey, mask)
            return
        self._flush()
        known = (direct, agree) if self._key is key else None
        self.rows.append(self._row(grey, mask, scale, size, known))

    def _matched(
        self, direct: Row, agree: float, frames: int, grey: np.ndarray, mask: np.ndarray
    ) -> None:
        """``frames`` more frames matched the keyframe, the last at ``direct``.

        The keyframe is renewed at ``grey`` once old enough and measured cleanly.
        """
        self._total, self._key_lost = direct, 0
        self._key_age += frames
        if agree >= self.cfg.clean_fraction and self._key_age >= self.cfg.key_every:
            self._new_key(grey, mask, self._full_size)

    def _flush(self) -> None:
        """Measure the frame held for the next one, on its own."""
        held, self._held = self._held, None
        if held is not None:
            grey, mask, scale = held
            self.rows[-1] = self._row(grey, mask, scale, (grey.shape[1], grey.shape[0]))
            self._prev, self._prev_mask = grey, mask

    def _row(
        self,
        grey: np.ndarray,
        mask: np.ndarray,
        scale: float,
        size: tuple[int, int],
        known: tuple[Row, float] | None = None,
    ) -> Row:
        """The row of the frame ``grey``; updates the keyframe state.

        ``known``: its measurement from the keyframe, if already made.
        """
        if known is None:
            known = self._measure(self._key, self._key_pts, grey, mask, scale, size)
        direct, agree = known
        if all(math.isfinite(v) for v in direct):
            row: Row = _minus(direct, self._total)
            self._matched(direct, agree, 1, grey, mask)
            return row
        pts = self._corners(self._prev, self._prev_mask)
        row, _ = self._measure(self._prev, pts, grey, mask, scale, size)
        if all(math.isfinite(v) for v in row):
            self._total = _plus(self._total, row)
        self._key_lost += 1
        if self._key_lost >= self.cfg.key_lost:
            self._new_key(grey, mask, self._full_size)
        return row

    def _corners(self, grey: np.ndarray, mask: np.ndarray) -> Any:
        return _cv2().goodFeaturesToTrack(
            grey, self.cfg.max_corners, 0.01, 6, mask=mask, blockSize=5
        )

    def _new_key(self, grey: np.ndarray, mask: np.ndarray, size: tuple[int, int] | None) -> None:
        self._key, self._key_pts = grey, self._corners(grey, mask)
        self._key_age = self._key_lost = 0
        self._total = (0.0, 0.0, 0.0, 0.0)
        self._full_size = size

    def _mask(self, shape: tuple[int, int], hands: list[FloatArray], scale: float) -> np.ndarray:
        """255 on the background, 0 on each hand's enlarged box and a thin border."""
        ah, aw = shape
        mask = np.zeros(shape, np.uint8)
        b = max(2, aw // 64)
        mask[b:-b, b:-b] = 255
        for uv in hands:
            p = np.asarray(uv, dtype=np.float64) * scale
            p = p[np.isfinite(p).all(axis=1)]
            if not p.size:
                continue
            lo, hi = p.min(axis=0), p.max(axis=0)
            pad = self.cfg.hand_margin * (hi - lo) + 2.0
            x0, y0 = np.floor(lo - pad).astype(int)
            x1, y1 = np.ceil(hi + pad).astype(int)
            mask[max(0, y0) : max(0, y1), max(0, x0) : max(0, x1)] = 0
        return mask

    def _measure(
        self,
        ref: np.ndarray,
        p0: Any,
        grey: np.ndarray,
        mask: np.ndarray,
        scale: float,
        size: tuple[int, int],
    ) -> tuple[Row, float]:
        """``ref`` -> ``grey`` as a row (NaN if not measured), and the share agreeing with it.

        The share: of the corners that did not move, or the fit's inliers (a clean
        measurement: at least ``cfg.clean_fraction``).
        """
        cv2 = _cv2()
        if p0 is None or len(p0) < self.cfg.min_points:
            return NAN_ROW, 0.0
        p1, status, _err = cv2.calcOpticalFlowPyrLK(
            ref, grey, p0, None, winSize=(15, 15), maxLevel=3
        )
        ok = status.ravel() == 1
        q1 = p1.reshape(-1, 2)
        cols = np.clip(np.round(q1[:, 0]).astype(int), 0, size[0] - 1)
        rows = np.clip(np.round(q1[:, 1]).astype(int), 0, size[1] - 1)
        ok &= mask[rows, cols] > 0  # landed on a hand now: not background
        if ok.sum() < self.cfg.min_points:
            return NAN_ROW, 0.0
        a, b = p0.reshape(-1, 2)[ok], q1[ok]
        still = np.linalg.norm(b - a, axis=1) < self.cfg.static_px
        if still.mean() >= self.cfg.static_fraction:
            return (0.0, 0.0, 0.0, 0.0), float(still.mean())
        A, inliers = cv2.estimateAffinePartial2D(
            a, b, method=cv2.RANSAC, ransacReprojThreshold=self.cfg.ransac_px
        )
        if A is None or inliers is None or int(inliers.sum()) < self.cfg.min_points:
            return NAN_ROW, 0.0
        s = float(math.hypot(A[0, 0], A[1, 0]))
        rot = float(math.atan2(A[1, 0], A[0, 0]))
        centre = np.array([size[0] / 2.0, size[1] / 2.0])
        moved = A[:, :2] @ centre + A[:, 2] - centre
        row = (
            float(moved[0] / scale),
            float(moved[1] / scale),
            math.log(s) if s > 0 else math.nan,
            rot,
        )
        return row, float(inliers.mean())

    @property
    def motion(self) -> FloatArray:
        """(n, 4) rows so far (module docstring); a frame still held is measured first."""
        self._flush()
        if not self.rows:
            return np.zeros((0, N_COLUMNS))
        return np.array(self.rows, dtype=np.float64)


def _minus(a: Row, b: Row) -> Row:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3])


def _plus(a: Row, b: Row) -> Row:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3])


def _half(a: Row) -> Row:
    return (a[0] / 2.0, a[1] / 2.0, a[2] / 2.0, a[3] / 2.0)


def camera_motion_report(
    motion: FloatArray | None,
    frame_size_px: tuple[int, int] | None,
    cfg: CameraMotionConfig | None = None,
) -> dict[str, Any]:
    """What a verdict reads about the camera: did it move, how much, when (JSON-able).

    Parameters
    ----------
    motion : ndarray, shape (n, 4), or None
        Per-frame rows (:class:`CameraMotionEstimator`); None: not measured.
    frame_size_px : (width, height)
        The frames' size the shifts are in [px].

    Returns
    -------
    dict
        ``checked`` (False without ``motion``: nothing else is then known), ``moving``
        (True, False, or None when fewer than ``cfg.min_measured`` of the frames could be
        measured and no motion was found),
        ``shift_extent`` (the accumulated background shift's extent, fraction of the
        frame width), ``zoom_extent`` (of the accumulated ln zoom), ``rotation_extent_deg``,
        ``frames_measured`` (fraction of frames with a measurement) and
        ``moving_frames`` ([first, last] frame ranges where the background moved more
        than ``cfg.moving_speed`` of the width per frame, 3 frames or longer).
    """
    cfg = cfg or CameraMotionConfig()
    if motion is None or frame_size_px is None or np.shape(motion)[0] == 0:
        return {"checked": False, "moving": None}
    m = np.asarray(motion, dtype=np.float64)
    width = float(frame_size_px[0])
    measured = np.asarray(np.isfinite(m).all(axis=1), dtype=bool)
    step = np.where(measured[:, None], m, 0.0)
    # the background's path, without excursions shorter than half the window (an arm
    # passing in front of a still camera and taken back when the view clears)
    acc = _running_median(np.cumsum(step, axis=0), cfg.settle_frames)

    def extent(col: FloatArray) -> float:
        return float(col.max() - col.min()) if col.size else 0.0

    shift = max(extent(acc[:, 0]), extent(acc[:, 1])) / width
    zoom = extent(acc[:, 2])
    rot = math.degrees(extent(acc[:, 3]))
    speed = np.zeros(acc.shape[0])
    speed[1:] = np.hypot(*np.diff(acc[:, :2], axis=0).T) / width
    fast = _smoothed(speed, 5) > cfg.moving_speed
    moving: bool | None = bool(
        shift > cfg.max_shift or zoom > cfg.max_zoom or rot > cfg.max_rotation_deg
    )
    if not moving and measured.mean() < cfg.min_measured:
        moving = None  # too little seen to say it stood still (a plain wall, no corners)
    return {
        "checked": True,
        "moving": moving,
        "shift_extent": shift,
        "zoom_extent": zoom,
        "rotation_extent_deg": rot,
        "frames_measured": float(measured.mean()),
        "moving_frames": _runs(fast, 3),
        "limits": {
            "shift": cfg.max_shift,
            "zoom": cfg.max_zoom,
            "rotation_deg": cfg.max_rotation_deg,
        },
    }


def _running_median(x: FloatArray, k: int) -> FloatArray:
    """Centred running median of ``x`` (n, c) over ``k`` frames (shorter at the ends)."""
    n = x.shape[0]
    if k <= 1 or n < 3:
        return x
    h = k // 2
    padded = np.concatenate([np.repeat(x[:1], h, axis=0), x, np.repeat(x[-1:], h, axis=0)])
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * h + 1, axis=0)
    return np.median(windows, axis=-1)


def _smoothed(x: FloatArray, k: int) -> FloatArray:
    if x.size < k:
        return x
    return np.convolve(x, np.ones(k) / k, mode="same")


def _runs(flag: np.ndarray, min_len: int) -> list[list[int]]:
    """[first, last] index ranges of runs of True at least ``min_len`` long."""
    out = []
    i, n = 0, flag.size
    while i < n:
        if flag[i]:
            j = i
            while j + 1 < n and flag[j + 1]:
                j += 1
            if j - i + 1 >= min_len:
                out.append([int(i), int(j)])
            i = j + 1
        else:
            i += 1
    return out


def log_camera_motion(report: dict[str, Any], name: str) -> None:
    """One warning when the camera moved; one note when it could not be checked."""
    if not report.get("checked"):
        logger.info(
            "%s: camera motion cannot be checked (no background motion was measured: a "
            "landmark recording without 'camera_motion', or no images)",
            name,
        )
        return
    if report["moving"] is None:
        logger.warning(
            "%s: camera motion could not be measured in %.0f %% of the frames (too little "
            "background texture beside the hands): a moving camera would not be noticed",
            name,
            100 * (1 - report["frames_measured"]),
        )
    elif report["moving"]:
        ranges = ", ".join(f"{a}-{b}" for a, b in report["moving_frames"][:6]) or "throughout"
        logger.warning(
            "%s: the CAMERA MOVES (background shifted %.0f %% of the frame width, zoomed "
            "%.0f %%, turned %.1f deg; frames %s): positions are in a moving camera frame, "
            "not the table's",
            name,
            100 * report["shift_extent"],
            100 * (math.exp(report["zoom_extent"]) - 1),
            report["rotation_extent_deg"],
            ranges,
        )
