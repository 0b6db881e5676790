"""Demonstration quality: which demonstrations are far from the others (robust z-score).

A demonstration whose DTW distance to the reference is unusually large (a
botched attempt, a tracking failure) would widen the learned variance and pull
the mean. Its distance is scored by the modified z-score of Iglewicz & Hoaglin,
``z = 0.6745 (d - median) / MAD``, computed over the non-reference
demonstrations (the reference's own distance is 0 by construction and would
bias the statistics); ``z > threshold`` (default 3.5, their recommendation)
flags an outlier. Only large distances are flagged: being close to the
reference is never a defect.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput

__all__ = ["MIN_DEMOS_FOR_OUTLIERS", "QualityReport", "assess_quality"]

MIN_DEMOS_FOR_OUTLIERS = 4  # reference + 3 others: fewer give no meaningful median/MAD
_MAD_TO_SIGMA = 0.6745  # Phi^-1(3/4): MAD of a normal distribution in units of sigma
_MEANAD_TO_SIGMA = 0.7979  # sqrt(2/pi): mean absolute deviation of a normal in sigma


@dataclass(frozen=True, slots=True)
class QualityReport:
    """Per-demonstration distance to the reference and outlier flags.

    Attributes
    ----------
    distances : ndarray, shape (N,)
        Normalised DTW distance to the reference (scaled units).
    robust_z : ndarray, shape (N,)
        Modified z-score of each distance (0 for the reference).
    outlier : ndarray of bool, shape (N,)
        True where ``robust_z > threshold``.
    reference_index : int
    threshold : float
    note : str
        Why no flags could be computed, if so.
    """

    distances: FloatArray
    robust_z: FloatArray
    outlier: BoolArray
    reference_index: int
    threshold: float
    note: str = ""


def assess_quality(
    distances: FloatArray, reference_index: int, *, threshold: float = 3.5
) -> QualityReport:
    """Score each demonstration's distance to the reference; flag outliers.

    Parameters
    ----------
    distances : ndarray, shape (N,)
        DTW distance of each demonstration to the reference (>= 0).
    reference_index : int
        The reference (excluded from the statistics, never flagged).
    threshold : float
        Modified z-score above which a demonstration is an outlier.

    Returns
    -------
    QualityReport

    References
    ----------
    .. [1] Iglewicz & Hoaglin (1993), How to Detect and Handle Outliers, ASQC.
    """
    d = check_finite(as_float_array(distances, "distances", ndim=1), "distances")
    N = d.shape[0]
    if not 0 <= reference_index < N:
        raise InvalidInput(f"reference_index {reference_index} out of range for {N} distances")
    if not threshold > 0:
        raise InvalidInput(f"threshold must be > 0, got {threshold!r}")
    z = np.zeros(N)
    others = np.delete(np.arange(N), reference_index)
    note = ""
    if N < MIN_DEMOS_FOR_OUTLIERS:
        note = (
            f"{N} demonstration(s): at least {MIN_DEMOS_FOR_OUTLIERS} are needed to flag outliers"
        )
    else:
        v = d[others]
        med = float(np.median(v))
        mad = float(np.median(np.abs(v - med)))
        if mad > 1e-12 * max(med, 1e-300):
            z[others] = _MAD_TO_SIGMA * (v - med) / mad
        else:
            # more than half the distances coincide: fall back to the mean absolute
            # deviation (Iglewicz & Hoaglin's suggestion for MAD = 0)
            meanad = float(np.mean(np.abs(v - med)))
            if meanad > 0:
                z[others] = _MEANAD_TO_SIGMA * (v - med) / meanad
            else:
                note = "all distances to the reference are equal: no outliers"
    return QualityReport(
        distances=d.copy(),
        robust_z=z,
        outlier=z > threshold,
        reference_index=int(reference_index),
        threshold=float(threshold),
        note=note,
    )
