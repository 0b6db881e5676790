"""Time-profile helpers shared by every stage: minimum-jerk phase, resampling, mean filter.

A leaf module (NumPy and the shared input checks). The planner's end shaping, the place segment, the
controllers' approach moves, the lift study and the synthetic demonstrations all
use the same minimum-jerk profile; every stage that moves samples to another time
grid uses :func:`resample`; motion's smoothing and learn's preprocessing share the
centred moving average :func:`mean_filter` (Eq. 4.15). Rotation angles live in
:mod:`dexlfd.rotations`.

References
----------
.. [1] T. Flash, N. Hogan (1985), The coordination of arm movements: an
   experimentally confirmed mathematical model, J. Neurosci. 5(7).
"""

from __future__ import annotations

import functools

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput

__all__ = ["FILTER_MODES", "MIN_JERK_PEAK_SPEED", "mean_filter", "minimum_jerk", "resample"]

FILTER_MODES = ("linear", "shrink", "nearest")  # mean_filter's end handling

# peak of ds/du for the minimum-jerk profile (at u = 1/2): 30/16
MIN_JERK_PEAK_SPEED = 1.875


def minimum_jerk(u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Minimum-jerk phase ``s(u) = 10u³ - 15u⁴ + 6u⁵`` and its derivatives in ``u``.

    ``u`` is clipped to [0, 1], so the profile holds 0 before and 1 after; its
    first and second derivatives are 0 at both ends [1].

    Parameters
    ----------
    u : ndarray
        Normalised time (any shape).

    Returns
    -------
    s, ds_du, d2s_du2 : ndarray
        Same shape as ``u``. Divide ``ds_du`` by the duration T [s] and ``d2s_du2``
        by T² for time derivatives.
    """
    u = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
    s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
    ds = 30.0 * u**2 * (1.0 - u) ** 2
    dds = 60.0 * u - 180.0 * u**2 + 120.0 * u**3
    return s, ds, dds


def resample(t_new: FloatArray, t: FloatArray, x: FloatArray) -> FloatArray:
    """Linear interpolation of samples ``x`` at times ``t`` onto ``t_new``, column by column.

    Parameters
    ----------
    t_new : ndarray, shape (m,)
        Query times [s] (or any monotone coordinate).
    t : ndarray, shape (n,)
        Increasing sample times.
    x : ndarray, shape (n,) or (n, ...)
        Samples; trailing axes are interpolated independently.

    Returns
    -------
    ndarray, shape (m,) or (m, ...)
        Outside ``[t[0], t[-1]]`` the edge sample is held (``np.interp``'s rule).
    """
    t_new = np.asarray(t_new, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        return np.interp(t_new, t, x)
    flat = x.reshape(x.shape[0], -1)
    out = np.empty((t_new.shape[0], flat.shape[1]))
    for j in range(flat.shape[1]):
        out[:, j] = np.interp(t_new, t, flat[:, j])
    return out.reshape((t_new.shape[0], *x.shape[1:]))


def mean_filter(x: FloatArray, k: int = 10, *, mode: str = "linear") -> FloatArray:
    """Smooth a series along axis 0 with a centred mean filter of window ``k``.

    Parameters
    ----------
    x : ndarray, shape (n,) or (n, d)
        Samples along time (axis 0), finite.
    k : int
        Window length in samples (thesis: 10), >= 1; ``k = 1`` returns a copy.
    mode : {"linear", "shrink", "nearest"}
        End handling, see Notes.

    Returns
    -------
    ndarray, same shape as ``x``
        Filtered series.

    Notes
    -----
    The thesis's Eq. (4.15) averages ``k`` samples centred on sample ``i`` and is
    only defined for ``(k-1)/2 <= i < N - (k-1)/2``; it says nothing about the ends
    and, for the even ``k = 10`` it uses, the window ``i ± 4.5`` is not a set of
    samples. We resolve both:

    * even ``k``: the centred "2×k" moving average (``k + 1`` samples, the two end
      samples weighted 1/2), i.e. the mean of the two ``k``-sample windows that
      straddle ``i``. It is symmetric, so it introduces no half-sample time shift.
    * ends (``mode="linear"``, default): the first and last ``k // 2`` samples,
      where the centred window does not fit, take the value at that sample of a
      straight line fitted by least squares to the first (last) ``k`` samples.
      Inside, a centred mean equals such a local line evaluated at its centre, so
      this continues the filter to the ends without pulling a moving series
      towards the interior and still averages the noise there (at the very end
      sample the noise variance drops to about ``4/k`` of the raw one). Start
      and goal of a motion therefore stay where they were, and a straight ramp
      passes through unchanged.
    * ``mode="shrink"``: the window shrinks symmetrically to the largest radius
      that fits, down to the raw sample at ``i = 0`` and ``i = N-1`` (keeps the
      ends exactly, including their noise).
    * ``mode="nearest"``: pad with the end values (the classic edge-padded
      filter, which pulls the ends of a moving series towards the interior).

    References
    ----------
    .. [1] Thesis Eq. (4.15).
    """
    arr = check_finite(as_float_array(x, "x"), "x")
    if arr.ndim not in (1, 2):
        raise InvalidInput(f"x must have shape (n,) or (n, d), got {arr.shape}")
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise InvalidInput(f"k (window) must be an integer >= 1, got {k!r}")
    if mode not in FILTER_MODES:
        raise InvalidInput(f"mode must be one of {FILTER_MODES}, got {mode!r}")
    n = arr.shape[0]
    if n == 0 or k == 1:
        return arr.copy()
    flat = arr.reshape(n, -1)
    r = int(k) // 2  # window radius; for even k the two outermost samples weigh 1/2
    if mode == "nearest" or (mode == "linear" and n > 2 * r and n > 2):
        # every full window at once by SciPy's compiled correlation; with "linear" the
        # r end samples on each side, where the window does not fit, are replaced below
        from scipy.ndimage import correlate1d

        weights = np.ones(2 * r + 1)
        if int(k) % 2 == 0:
            weights[0] = weights[-1] = 0.5
        out = correlate1d(flat, weights / k, axis=0, mode="nearest")  # [1] Eq. (4.15)
        if mode == "linear":
            _linear_ends(flat, out, int(k))
        return out.reshape(arr.shape)
    return _shrinking_mean(flat, int(k), mode).reshape(arr.shape)


def _shrinking_mean(flat: FloatArray, k: int, mode: str) -> FloatArray:
    """The mean filter whose window shrinks to fit at the ends (``"shrink"``; short series).

    With ``mode="linear"`` the end samples are then replaced by :func:`_linear_ends`.
    """
    n = flat.shape[0]
    r = k // 2
    S = np.concatenate([np.zeros((1, flat.shape[1])), np.cumsum(flat, axis=0)])
    i = np.arange(n)
    rho = np.minimum(r, np.minimum(i, n - 1 - i))  # largest symmetric radius that fits
    total = S[i + rho + 1] - S[i - rho]
    count = (2 * rho + 1).astype(np.float64)
    if k % 2 == 0:
        full = rho == r  # only a full-width even window gets the half-weight ends
        ends = 0.5 * (flat[i - rho] + flat[i + rho])
        total = np.where(full[:, None], total - ends, total)
        count = np.where(full, float(k), count)
    out = total / count[:, None]  # [1] Eq. (4.15)
    if mode == "linear" and n > 2 and r > 0:
        _linear_ends(flat, out, k)
    return np.asarray(out)


def _linear_ends(flat: FloatArray, out: FloatArray, k: int) -> None:
    """Replace the ``k // 2`` end samples of ``out`` (in place) by end-block line fits.

    Each end's value is a least-squares straight line through the first (last) ``k``
    samples of ``flat``, evaluated at the replaced sample (see :func:`mean_filter`):
    ``mean(y) + pos * jc @ y / (jc @ jc)`` with ``jc`` the centred sample positions, one
    small matrix per end applied to the block.
    """
    n = flat.shape[0]
    w = min(k, n)  # samples in each end fit
    e = min(k // 2, n // 2)  # samples at each end replaced
    head, tail = _end_fits(w, e)
    out[:e] = head @ flat[:w]
    out[n - e :] = tail @ flat[n - w :]


@functools.lru_cache(maxsize=64)
def _end_fits(w: int, e: int) -> tuple[FloatArray, FloatArray]:
    """The ``(e, w)`` matrices taking an end block of ``w`` samples to its ``e`` line fits."""
    jc = np.arange(w, dtype=np.float64) - (w - 1) / 2.0
    gain = jc / (jc @ jc)
    head = np.arange(e) - (w - 1) / 2.0  # replaced samples' positions in their end block
    tail = np.arange(w - e, w) - (w - 1) / 2.0
    fits = (1.0 / w + head[:, None] * gain[None, :], 1.0 / w + tail[:, None] * gain[None, :])
    for m in fits:
        m.flags.writeable = False  # shared by every call
    return fits
