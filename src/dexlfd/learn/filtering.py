"""Whether to mean-filter a series (Eq. 4.15): Stein's risk estimate.

The centred moving-average filter itself (its even-``k`` window and its ends,
``mode``) is :func:`dexlfd.trajectory.mean_filter`, re-exported here; motion's
smoothing uses the same one.

Whether to filter at all (:func:`filter_reduces_risk`): the filter is there to
remove sensor noise, and on a series without any it can only bend the motion
(the 2×k average flattens every curve by about ``x'' (k² − 1) h² / 24``).
Stein's unbiased risk estimate of a linear smoother ``S`` (Stein 1981),
``SURE(S) = |x − S x|² − n σ² + 2 σ² tr S``, estimates its squared error
against the noise-free series from the data alone; the raw series has
``SURE(I) = n σ²``. So filtering lowers the expected error iff
``|x − S x|² < 2 σ² (n − tr S)``. The noise variance ``σ²`` comes from second
differences, ``σ² = mean((x[i−1] − 2 x[i] + x[i+1])²) / 6`` (Gasser, Sroka &
Jennen-Steinmetz 1986), which a smooth curve barely feeds at the sample scale.
Measured: LASA handwriting (smoothed pen data) gives residual / bound 39–53
(filter off); the synthetic pick-and-place with 2 mm sensor noise 0.70 (on).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.trajectory import mean_filter

__all__ = ["filter_reduces_risk"]


def _trace(n: int, k: int, mode: str) -> float:
    """``tr S`` of the filter on ``n`` samples: 1/k inside, the end rows computed."""
    ends = np.unique(np.r_[0 : min(n, k), max(0, n - k) : n])
    unit = np.zeros((n, ends.size))
    unit[ends, np.arange(ends.size)] = 1.0
    diag_ends = mean_filter(unit, k, mode=mode)[ends, np.arange(ends.size)]
    return float(diag_ends.sum() + (n - ends.size) / k)


def filter_reduces_risk(series: Sequence[FloatArray], k: int, *, mode: str = "linear") -> bool:
    """Whether the mean filter of window ``k`` lowers Stein's risk estimate of ``series``.

    Pooled over the series and over the channels, each channel in units of its
    own noise variance (from second differences); constant channels carry no
    noise and are left out. See the module docstring.

    Parameters
    ----------
    series : sequence of ndarray, each (n_i, d)
        Finite samples, one channel count.
    k : int
        Window of the filter considered [samples].
    mode : {"linear", "shrink", "nearest"}
        End handling of the filter.

    Returns
    -------
    bool
        True when ``Σ |x − S x|² / σ²  <  Σ 2 (n − tr S)`` (False also when no
        channel has noise or a series is shorter than ``2 k``).

    References
    ----------
    .. [1] C. M. Stein (1981), Ann. Statist. 9(6), 1135–1151.
    .. [2] T. Gasser, L. Sroka, C. Jennen-Steinmetz (1986), Biometrika 73(3), 625–633.
    """
    arrs = [np.asarray(x, np.float64).reshape(len(x), -1) for x in series]
    if k <= 1 or any(a.shape[0] < 2 * k for a in arrs):
        return False
    sq = np.concatenate([(a[:-2] - 2 * a[1:-1] + a[2:]) ** 2 for a in arrs])
    noise_var = sq.mean(axis=0) / 6.0  # [2], per channel
    has_noise = noise_var > 0
    if not has_noise.any():
        return False
    residual = sum(
        float(
            (((a - mean_filter(a, k, mode=mode)) ** 2)[:, has_noise] / noise_var[has_noise]).sum()
        )
        for a in arrs
    )
    bound = 2.0 * int(has_noise.sum()) * sum(a.shape[0] - _trace(a.shape[0], k, mode) for a in arrs)
    return residual < bound  # [1]: SURE(S) < SURE(I)
