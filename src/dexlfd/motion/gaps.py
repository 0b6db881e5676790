"""Frames without a hand: find gaps, interpolate the short ones, report or reject the rest.

A missing hand is data (NaN rows plus a ``valid`` mask). One rule for every
stage: a gap is a run of unseen frames; an *interior* gap of at most
``max_gap_s`` seconds between two seen frames may be bridged by linear
interpolation in time (:func:`dexlfd.trajectory.resample`); nothing is
invented at either end or across a longer gap. The two policies built on it:

* :func:`fill_short_gaps` (motion stage, keypoints): fill the short interior
  gaps, leave the others NaN and report them;
* :func:`fill_gaps` (learning stage, finished demonstrations): cut the invalid
  ends off (the hand entered or left the view), fill the short interior gaps,
  both with a WARNING, and reject a longer gap with an error naming the
  demonstration, since learning a made-up stretch of motion would teach the
  robot a path nobody showed. Interpolate quaternions only after making them
  sign-continuous, and renormalise them afterwards (the caller does both).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import cast

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidDemonstration
from dexlfd.trajectory import resample

__all__ = ["Gap", "fill_gaps", "fill_short_gaps", "find_gaps"]

logger = logging.getLogger(__name__)

_T_TOL = 1e-9  # [s] float time stamps: a gap this much over max_gap_s still counts as short


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

    def is_short(self, max_gap_s: float) -> bool:
        """An interior gap no longer than ``max_gap_s`` [s]: one that may be interpolated."""
        return self.interior and self.duration_s <= max_gap_s + _T_TOL


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


def _interpolate(t: FloatArray, x: FloatArray, gap: Gap) -> None:
    """Fill ``x[gap]`` in place, linear in time between the seen neighbours (any trailing shape)."""
    a, b = gap.start - 1, gap.stop
    x[gap.start : gap.stop] = resample(t[gap.start : gap.stop], t[[a, b]], x[[a, b]])


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
        if gap.is_short(max_gap_s):
            _interpolate(t, kp, gap)
            v[gap.start : gap.stop] = True
            filled[gap.start : gap.stop] = True
    return kp, v, filled


def fill_gaps(
    t: FloatArray,
    x: FloatArray,
    valid: BoolArray | None = None,
    *,
    max_gap_s: float = 0.5,
    name: str = "demonstration",
) -> tuple[FloatArray, FloatArray]:
    """Trim invalid ends and interpolate short interior gaps; reject a long one.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Time [s], strictly increasing.
    x : ndarray, shape (n, d)
        Samples; a row is invalid if it has a NaN or ``valid`` is false there.
    valid : ndarray of bool, shape (n,), optional
        Validity mask; default all rows without NaN.
    max_gap_s : float
        Longest interior gap that is interpolated [s] (time between the two
        valid samples around it).
    name : str
        How to name the series in messages (e.g. its file).

    Returns
    -------
    t, x : ndarray
        Trimmed times (n',) and finite samples (n', d).

    Raises
    ------
    InvalidDemonstration
        inf values, no valid sample, or a gap longer than ``max_gap_s``.
    """
    if np.isinf(x).any():
        raise InvalidDemonstration(f"{name}: contains inf values (expected finite or NaN)")
    ok = cast(BoolArray, np.isfinite(x).all(axis=1))
    if valid is not None:
        ok &= np.asarray(valid, bool)
    if not ok.any():
        raise InvalidDemonstration(f"{name}: has no valid sample")
    if ok.all():
        return t, x
    first = int(np.argmax(ok))
    last = int(len(ok) - 1 - np.argmax(ok[::-1]))
    if first > 0 or last < len(ok) - 1:
        logger.warning(
            "%s: dropped %d invalid sample(s) at the start and %d at the end",
            name, first, len(ok) - 1 - last,
        )  # fmt: skip
    t, x, ok = t[first : last + 1], x[first : last + 1], ok[first : last + 1]
    gaps = find_gaps(t, ok)  # all interior now
    if not gaps:
        return t, x
    worst = max(gaps, key=lambda g: g.duration_s)
    if not worst.is_short(max_gap_s):
        raise InvalidDemonstration(
            f"{name}: invalid frames from t={t[worst.start - 1]:.3f} s to "
            f"t={t[worst.stop]:.3f} s ({worst.duration_s:.3f} s) exceed the "
            f"max_gap_s={max_gap_s} s that may be interpolated"
        )
    out = np.array(x, dtype=np.float64, copy=True)
    for gap in gaps:
        _interpolate(t, out, gap)
    logger.warning(
        "%s: interpolated %d invalid sample(s) in %d gap(s) (longest %.3f s)",
        name, sum(g.n_frames for g in gaps), len(gaps), worst.duration_s,
    )  # fmt: skip
    return t, out
