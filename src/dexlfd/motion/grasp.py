"""Grasp state from the hand's aperture: the thesis's absolute threshold and an adaptive one.

The thesis grasps when the thumb-index distance ``d_ti`` falls below ``d_bar =
0.1 m`` (Section 4.2.3). On real hands a relaxed open hand already has
``d_ti`` of 6-9 cm, so that threshold calls almost every frame a grasp. This
module keeps it (``method="absolute"``) and adds two scale-free detectors on the
*aperture ratio* (:func:`aperture_ratio`): thumb-index distance over the hand's
size (wrist to middle-finger MCP), about 1 for a wide-open hand, 0.2-0.5 for a
pinch or a fist, whatever the hand's size or distance from the camera.

* ``"adaptive"`` (default): per demonstration, an open level and a closed level
  are read from the ratio's distribution (low and high percentiles); the grasp
  switches on below ``closed + close_fraction * (open - closed)`` and off above
  ``closed + open_fraction * (open - closed)`` (a Schmitt trigger, so no chatter
  between the two), and states shorter than ``min_duration_s`` are dropped. When
  the two levels are closer than ``min_contrast`` the aperture never changed:
  no grasp event, the whole demonstration is open (or closed if the ratio stays
  below ``ratio_threshold``).
* ``"ratio"``: fixed thresholds on the ratio (``ratio_threshold``, plus
  ``ratio_hysteresis``), for streams (teleoperation) where no whole series exists.
* ``"absolute"``: the thesis's ``d_ti < threshold_m`` with hysteresis.
* ``"closure"``: the hand's *closure* (:func:`hand_closure`: the aperture ratio and
  the fingers' curl, :func:`finger_curl`, each against this hand's own open and
  closed levels) marks where the hand is closed; which closed runs are grasps is
  read from what the hand does around them (closing near a stop, carrying,
  opening again) by :mod:`dexlfd.motion.phases`. A flat hand (thumb against the
  index, fingers straight) has a small aperture but no curl: it is not closed.

Unseen frames (NaN) hold the previous state in every method.

References
----------
.. [1] Thesis, Section 4.2.3, Eq. (4.14) and the threshold ``d_bar``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_positive
from dexlfd.capture.tracking import FINGER_CHAINS
from dexlfd.errors import InvalidInput

__all__ = [
    "GRASP_METHODS",
    "GraspConfig",
    "GraspResult",
    "HandClosure",
    "aperture_ratio",
    "detect_grasp",
    "drop_short_runs",
    "finger_curl",
    "grasp_state",
    "hand_closure",
    "schmitt_trigger",
]

GRASP_METHODS = ("closure", "adaptive", "ratio", "absolute")

WRIST, THUMB_TIP, INDEX_TIP, MIDDLE_MCP = 0, 4, 8, 9
# (MCP, PIP, DIP, tip) of the index, middle, ring and little fingers (MediaPipe numbering)
FINGERS = FINGER_CHAINS[1:]


def schmitt_trigger(
    x: FloatArray, on_below: float, off_above: float, initial: bool = False
) -> BoolArray:
    """True from a sample below ``on_below`` until one above ``off_above``; NaN holds.

    ``on_below <= off_above`` (the band between them keeps the last state).
    """
    g = np.asarray(x, dtype=np.float64)
    below = g < on_below
    above = g > off_above
    # state = last decisive event (below -> True, above -> False) at or before each sample
    event = np.where(below, 1, np.where(above, 0, -1))
    idx = np.where(event >= 0, np.arange(g.size), -1)
    last = np.maximum.accumulate(idx) if g.size else idx
    out = np.where(last >= 0, event[np.maximum(last, 0)] == 1, bool(initial))
    return out.astype(bool)


def grasp_state(
    gripper: FloatArray,
    threshold: float = 0.1,
    hysteresis: float = 0.01,
    initial: bool = False,
) -> BoolArray:
    """Grasp flags from an opening series with the thesis's absolute threshold.

    Parameters
    ----------
    gripper : ndarray, shape (n,)
        Thumb-index distance [m]; NaN where unseen.
    threshold : float
        Grasp starts when the opening is below this [m] (thesis: 0.1).
    hysteresis : float
        Grasp ends only when the opening exceeds ``threshold + hysteresis`` [m], >= 0.
    initial : bool
        State before the first sample.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    g = as_float_array(gripper, "gripper", ndim=1)
    threshold = check_positive(threshold, "threshold")
    hysteresis = check_positive(hysteresis, "hysteresis", strict=False)
    return schmitt_trigger(g, threshold, threshold + hysteresis, initial)


def aperture_ratio(keypoints: FloatArray, uv_px: FloatArray | None = None) -> FloatArray:
    """Scale-free aperture: thumb-index distance over wrist-to-middle-MCP length, ``(...,)``.

    From the 3-D keypoints ``(..., 21, 3)`` (any consistent unit). With the image
    landmarks ``uv_px`` ``(..., 21, 2)`` the same ratio in the image is averaged
    in: MediaPipe's depth of a thumb pointing at the camera is unreliable (the
    3-D ratio drops for an open hand) while the image ratio is immune to it, and
    foreshortening (which biases the image ratio) does not affect the 3-D one.
    NaN where a landmark is missing or the hand size is zero.
    """
    kp = np.asarray(keypoints, dtype=np.float64)

    def ratio(p: FloatArray) -> FloatArray:
        num = np.linalg.norm(p[..., THUMB_TIP, :] - p[..., INDEX_TIP, :], axis=-1)
        den = np.linalg.norm(p[..., MIDDLE_MCP, :] - p[..., WRIST, :], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(den > 0, num / den, np.nan)

    r = ratio(kp)
    if uv_px is not None:
        r2 = ratio(np.asarray(uv_px, dtype=np.float64))
        r = np.where(np.isfinite(r2), 0.5 * (r + r2), r)
    return r


def _flexion_deg(a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
    """Bend [deg] at ``b`` of the chain ``a-b-c``: 0 for a straight chain."""
    u, v = b - a, c - b
    nu, nv = np.linalg.norm(u, axis=-1), np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.sum(u * v, axis=-1) / (nu * nv)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def finger_curl(points: FloatArray) -> FloatArray:
    """Mean bend [deg] of the PIP and DIP joints of the four fingers, shape ``(...,)``.

    From 3-D landmarks ``(..., 21, 3)``: MediaPipe's metric world landmarks (or any
    rigid placement of them) give joint angles that do not depend on the monocular
    depth. About 10-30 deg for a flat or spread hand, 50-100 deg for fingers wrapped
    around an object or a fist. The thumb is left out (its joints bend in a pinch and
    in a flat hand alike); NaN where a landmark is missing.
    """
    p = np.asarray(points, dtype=np.float64)
    bends = []
    for mcp, pip, dip, tip in FINGERS:
        bends.append(_flexion_deg(p[..., mcp, :], p[..., pip, :], p[..., dip, :]))
        bends.append(_flexion_deg(p[..., pip, :], p[..., dip, :], p[..., tip, :]))
    return np.mean(np.stack(bends, axis=-1), axis=-1)


def _levels(x: FloatArray, percentiles: tuple[float, float]) -> tuple[float, float]:
    ok = x[np.isfinite(x)]
    if ok.size == 0:
        return float("nan"), float("nan")
    lo, hi = np.percentile(ok, percentiles)
    return float(lo), float(hi)


@dataclass(frozen=True, slots=True)
class HandClosure:
    """:func:`hand_closure`'s result: the closure and its two parts, 0 open .. 1 closed."""

    closure: FloatArray  # (n,) NaN where unseen
    aperture: FloatArray  # (n,) the aperture ratio's part
    curl: FloatArray  # (n,) the finger curl's part
    info: dict[str, Any]  # the levels read (JSON-able)


def hand_closure(
    ratio: FloatArray,
    curl: FloatArray,
    cfg: GraspConfig | None = None,
) -> HandClosure:
    """How closed the hand is in each frame, 0 (this hand's open level) .. 1 (closed).

    The mean of two scale-free parts, each against this hand's own levels (low and
    high percentiles ``cfg.level_percentiles`` over the recording): the aperture
    ratio (closed when low) and the finger curl (closed when high). A part whose
    levels differ by less than its minimum contrast (``min_contrast`` for the
    ratio, ``min_curl_contrast_deg`` for the curl) never changed: it reads 0 (open)
    throughout, so a hand that never closes has no closure. A flat hand with the
    thumb against the index scores on the aperture only, half of a wrapped hand,
    and a curl below ``flat_curl_deg`` (straight fingers) caps the closure at
    ``open_below``: a flat hand is never closed.

    Returns
    -------
    HandClosure
    """
    cfg = cfg or GraspConfig()
    r = np.asarray(ratio, dtype=np.float64)
    c = np.asarray(curl, dtype=np.float64)
    r_lo, r_hi = _levels(r, cfg.level_percentiles)
    c_lo, c_hi = _levels(c, cfg.level_percentiles)
    parts = []
    r_span, c_span = r_hi - r_lo, c_hi - c_lo
    if np.isfinite(r_span) and r_span >= cfg.min_contrast:
        parts.append(np.clip((r_hi - r) / r_span, 0.0, 1.0))
    else:
        parts.append(np.where(np.isfinite(r), 0.0, np.nan))
    if np.isfinite(c_span) and c_span >= cfg.min_curl_contrast_deg:
        parts.append(np.clip((c - c_lo) / c_span, 0.0, 1.0))
    else:
        parts.append(np.where(np.isfinite(c), 0.0, np.nan))
    closure = 0.5 * (parts[0] + parts[1])
    closure = np.where(c < cfg.flat_curl_deg, np.minimum(closure, cfg.open_below), closure)
    closure = np.where(np.isfinite(r) & np.isfinite(c), closure, np.nan)
    info = {"ratio_levels": [r_lo, r_hi], "curl_levels_deg": [c_lo, c_hi]}
    return HandClosure(closure, parts[0], parts[1], info)


def drop_short_runs(state: BoolArray, t: FloatArray, min_duration_s: float) -> BoolArray:
    """Remove runs of equal state shorter than ``min_duration_s`` (they take the previous state).

    A run's duration is counted from its first sample to the first sample of the
    next run; the shortest run goes first, so a one-frame release inside a grasp
    is removed before the grasp's halves are judged. The first and last runs are
    kept (the recording may start or end in any state).
    """
    s = np.array(state, dtype=bool, copy=True)
    t = np.asarray(t, dtype=np.float64)
    if s.size < 2 or min_duration_s <= 0:
        return s
    while True:  # drop the shortest too-short interior run; its neighbours merge
        edges = np.flatnonzero(np.diff(s.astype(np.int8))) + 1
        if edges.size < 2:
            return s
        starts, stops = edges[:-1], edges[1:]  # interior runs (not the first or last)
        dur = t[stops] - t[starts]
        k = int(np.argmin(dur))
        if dur[k] >= min_duration_s - 1e-9:
            return s
        s[starts[k] : stops[k]] = s[starts[k] - 1]


@dataclass(frozen=True, slots=True)
class GraspConfig:
    """How the grasp is detected (see the module docstring); ratios are unitless."""

    method: str = "adaptive"  # one of GRASP_METHODS
    threshold_m: float = 0.1  # "absolute": d_ti below this grasps [m] (thesis d_bar)
    hysteresis_m: float = 0.01  # "absolute": release above threshold_m + this [m]
    ratio_threshold: float = 0.55  # "ratio": grasp below this aperture ratio [-]
    ratio_hysteresis: float = 0.15  # "ratio": release above ratio_threshold + this [-]
    level_percentiles: tuple[float, float] = (5.0, 95.0)  # "adaptive": closed, open levels
    close_fraction: float = 1 / 3  # "adaptive": grasp below closed + this * (open - closed)
    open_fraction: float = 0.5  # "adaptive": release above closed + this * (open - closed)
    min_contrast: float = 0.25  # "adaptive": open - closed below this: no grasp change [-]
    min_duration_s: float = 0.15  # shorter grasp/release states are dropped [s]
    min_curl_contrast_deg: float = 10.0  # "closure": curl levels closer than this: no change
    flat_curl_deg: float = 15.0  # "closure": fingers bent less than this are straight [deg]
    close_above: float = 0.5  # "closure": the hand is closed above this closure [-] ...
    open_below: float = 0.35  # ... and open again below this one [-]

    def __post_init__(self) -> None:
        if self.method not in GRASP_METHODS:
            raise InvalidInput(f"grasp method must be one of {GRASP_METHODS}, got {self.method!r}")
        check_positive(self.threshold_m, "threshold_m")
        check_positive(self.hysteresis_m, "hysteresis_m", strict=False)
        check_positive(self.ratio_threshold, "ratio_threshold")
        check_positive(self.ratio_hysteresis, "ratio_hysteresis", strict=False)
        check_positive(self.min_contrast, "min_contrast")
        check_positive(self.min_duration_s, "min_duration_s", strict=False)
        check_positive(self.min_curl_contrast_deg, "min_curl_contrast_deg")
        check_positive(self.flat_curl_deg, "flat_curl_deg", strict=False)
        if not 0 < self.open_below <= self.close_above < 1:
            raise InvalidInput(
                f"need 0 < open_below <= close_above < 1, got {self.open_below}, {self.close_above}"
            )
        lo, hi = self.level_percentiles
        if not 0 <= lo < hi <= 100:
            raise InvalidInput(f"level_percentiles must satisfy 0 <= lo < hi <= 100, got {lo, hi}")
        if not 0 < self.close_fraction <= self.open_fraction < 1:
            raise InvalidInput(
                "need 0 < close_fraction <= open_fraction < 1, got "
                f"{self.close_fraction}, {self.open_fraction}"
            )


@dataclass(frozen=True, slots=True)
class GraspResult:
    """Grasp flags and how they were decided."""

    grasp: BoolArray  # (n,)
    ratio: FloatArray  # (n,) aperture ratio [-]
    info: dict[str, Any]  # method, levels and thresholds (JSON-able)
    closure: HandClosure | None = None  # "closure": hand_closure's result


def detect_grasp(
    t: FloatArray,
    gripper: FloatArray,
    ratio: FloatArray,
    cfg: GraspConfig | None = None,
    *,
    curl: FloatArray | None = None,
) -> GraspResult:
    """Grasp flags of a whole demonstration.

    With ``method="closure"`` the flags say where the hand is *closed*
    (:func:`hand_closure` with hysteresis); :func:`dexlfd.motion.phases.hand_phases`
    keeps those closed runs that are grasps.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times [s].
    gripper : ndarray, shape (n,)
        Thumb-index distance [m] (used by ``method="absolute"``); NaN where unseen.
    ratio : ndarray, shape (n,)
        Aperture ratio (:func:`aperture_ratio`); NaN where unseen.
    cfg : GraspConfig, optional
    curl : ndarray, shape (n,), optional
        Finger curl [deg] (:func:`finger_curl`); needed by ``method="closure"``.

    Returns
    -------
    GraspResult
    """
    cfg = cfg or GraspConfig()
    t = np.asarray(t, dtype=np.float64)
    g = np.asarray(gripper, dtype=np.float64)
    r = np.asarray(ratio, dtype=np.float64)
    info: dict[str, Any] = {"method": cfg.method, "min_duration_s": cfg.min_duration_s}
    if cfg.method == "closure":
        if curl is None:
            raise InvalidInput('grasp method "closure" needs the finger curl (curl=...)')
        hc = hand_closure(r, np.asarray(curl, dtype=np.float64), cfg)
        info.update(hc.info, close_above=cfg.close_above, open_below=cfg.open_below)
        x, on, off = 1.0 - hc.closure, 1.0 - cfg.close_above, 1.0 - cfg.open_below
        flags = drop_short_runs(schmitt_trigger(x, on, off), t, cfg.min_duration_s)
        return GraspResult(flags, r, info, hc)
    if cfg.method == "absolute":
        on, off, x = cfg.threshold_m, cfg.threshold_m + cfg.hysteresis_m, g
        info.update(close_below_m=on, open_above_m=off)
    elif cfg.method == "ratio":
        on, off, x = cfg.ratio_threshold, cfg.ratio_threshold + cfg.ratio_hysteresis, r
        info.update(close_below=on, open_above=off)
    else:
        x = r
        ok = r[np.isfinite(r)]
        if ok.size == 0:
            return GraspResult(np.zeros(r.shape, bool), r, {**info, "events": "no aperture"})
        closed, opened = (float(v) for v in np.percentile(ok, cfg.level_percentiles))
        info.update(closed_level=closed, open_level=opened)
        span = opened - closed
        if span < cfg.min_contrast:
            # the aperture never changed: one state for the whole demonstration
            held = bool(np.median(ok) < cfg.ratio_threshold)
            info.update(single_state="closed" if held else "open", contrast=span)
            return GraspResult(np.full(r.shape, held), r, info)
        on = closed + cfg.close_fraction * span
        off = closed + cfg.open_fraction * span
        info.update(close_below=on, open_above=off, contrast=span)
    flags = drop_short_runs(schmitt_trigger(x, on, off), t, cfg.min_duration_s)
    return GraspResult(flags, r, info)
