"""Repair of invalid frames (hand not seen) before learning.

A demonstration may contain invalid samples (NaN rows, ``valid`` false). The
leading and trailing ones are cut off (the hand entered or left the view), short
interior gaps are linearly interpolated in time, both with a WARNING; a gap
longer than ``max_gap_s`` is rejected with an error naming the demonstration,
since inventing a long stretch of motion would teach the robot a made-up path.
Interpolate quaternions only after making them sign-continuous, and
renormalise them afterwards (the caller does both).
"""

from __future__ import annotations

import logging

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidDemonstration

__all__ = ["fill_gaps"]

logger = logging.getLogger(__name__)


def fill_gaps(
    t: FloatArray,
    x: FloatArray,
    valid: BoolArray | None = None,
    *,
    max_gap_s: float = 0.5,
    name: str = "demonstration",
) -> tuple[FloatArray, FloatArray]:
    """Trim invalid ends and interpolate short interior gaps.

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
    ok = np.isfinite(x).all(axis=1)
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
            name,
            first,
            len(ok) - 1 - last,
        )
    t = t[first : last + 1]
    x = x[first : last + 1]
    ok = ok[first : last + 1]
    if ok.all():
        return t, x
    good = np.flatnonzero(ok)
    spans = t[good[1:]] - t[good[:-1]]
    holes = np.diff(good) > 1
    worst = int(np.argmax(np.where(holes, spans, -np.inf)))
    if spans[worst] > max_gap_s:
        raise InvalidDemonstration(
            f"{name}: invalid frames from t={t[good[worst]]:.3f} s to "
            f"t={t[good[worst + 1]]:.3f} s ({spans[worst]:.3f} s) exceed the "
            f"max_gap_s={max_gap_s} s that may be interpolated"
        )
    bad = np.flatnonzero(~ok)
    out = x.copy()
    for c in range(x.shape[1]):
        out[bad, c] = np.interp(t[bad], t[good], x[good, c])
    logger.warning(
        "%s: interpolated %d invalid sample(s) in %d gap(s) (longest %.3f s)",
        name,
        bad.size,
        int(holes.sum()),
        float(spans[worst]),
    )
    return t, out
