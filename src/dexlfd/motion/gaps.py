"""Frames without a hand: find gaps, fill only short ones, report the rest.

A missing hand is data (NaN rows plus a ``valid`` mask). Gaps of at most
``max_gap_s`` seconds between two seen frames may be filled by linear
interpolation of the keypoints (the motion is then recomputed from them); longer
gaps and gaps at either end stay NaN and are reported, never invented.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._types import BoolArray, FloatArray

__all__ = ["Gap", "fill_short_gaps", "find_gaps"]


@dataclass(frozen=True, slots=True)
class Gap:
    """A run of unseen frames ``[start, stop)`` and its duration [s]."""

    start: int
    stop: int
    duration_s: float
    interior: bool  # False when the gap touches the first or last frame

    @property
    def n_frames(self) -> int:
        """Number of missing frames."""
        return self.stop - self.start


def find_gaps(t: FloatArray, valid: BoolArray) -> list[Gap]:
    """Runs of ``valid == False``; duration measured between the seen neighbours.

    For an interior gap the duration is ``t[stop] - t[start - 1]`` (the time with
    no observation); at the ends it is the span of the missing frames.
    """
    v = np.asarray(valid, dtype=bool)
    t = np.asarray(t, dtype=np.float64)
    n = v.size
    missing = np.concatenate([[0], (~v).astype(np.int8), [0]])
    change = np.diff(missing)
    starts = np.flatnonzero(change == 1)
    stops = np.flatnonzero(change == -1)
    gaps = []
    for a, b in zip(starts, stops, strict=True):
        interior = a > 0 and b < n
        dur = float(t[b] - t[a - 1]) if interior else float(t[b - 1] - t[a])
        gaps.append(Gap(int(a), int(b), dur, bool(interior)))
    return gaps


def fill_short_gaps(
    t: FloatArray, keypoints: FloatArray, valid: BoolArray, max_gap_s: float
) -> tuple[FloatArray, BoolArray, BoolArray]:
    """Linearly interpolate keypoints across interior gaps no longer than ``max_gap_s``.

    Returns ``(keypoints, valid, filled)``: new arrays (inputs are not changed),
    ``filled`` marks the interpolated frames.
    """
    kp = np.array(keypoints, dtype=np.float64, copy=True)
    v = np.array(valid, dtype=bool, copy=True)
    filled = np.zeros_like(v)
    for gap in find_gaps(t, valid):
        if not gap.interior or gap.duration_s > max_gap_s + 1e-9:  # 1e-9: float time stamps
            continue
        a, b = gap.start - 1, gap.stop  # seen neighbours
        w = (t[gap.start : gap.stop] - t[a]) / (t[b] - t[a])
        kp[gap.start : gap.stop] = (1 - w)[:, None, None] * kp[a] + w[:, None, None] * kp[b]
        v[gap.start : gap.stop] = True
        filled[gap.start : gap.stop] = True
    return kp, v, filled
