"""Demonstration quality: which demonstrations are far from the others (robust z-score).

A demonstration whose DTW distance to the reference is unusually large (a
botched attempt, a tracking failure) would widen the learned variance and pull
the mean. Its distance is scored by the modified z-score of Iglewicz & Hoaglin,
``z = 0.6745 (d - median) / MAD``, computed over the non-reference
demonstrations (the reference's own distance is 0 by construction and would
bias the statistics); ``z > threshold`` (default 3.5, their recommendation)
flags an outlier. Only large distances are flagged: being close to the
reference is never a defect.

With the handful of demonstrations typical here (5 non-reference distances
for the thesis's 6), the MAD of the inliers can be tiny by chance, which would
flag a demonstration only slightly further away than the rest. The MAD is
therefore floored at ``rel_mad_floor`` (default 0.1) times the median, so a
demonstration must be at least about ``0.1 * 3.5 / 0.6745 ≈ 52 %`` further
from the reference than the median one to be flagged.

Beyond single outliers, the demonstrations may follow two different ways
(around an obstacle on the left or on the right): their mean then matches
neither. Given all pairwise DTW distances, the demonstrations are split into
two groups by average-linkage clustering; if both groups have at least 2
members and the mean distance between groups exceeds ``mode_ratio`` (default
5) times the mean distance within groups, they are reported as two modes. On
the LASA handwriting set the three multi-modal shapes give ratios 19–30, all
27 others at most 3.2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._types import BoolArray, FloatArray, IntArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput

__all__ = ["MIN_DEMOS_FOR_OUTLIERS", "QualityReport", "assess_quality"]

MIN_DEMOS_FOR_OUTLIERS = 4  # reference + 3 others: fewer give no meaningful median/MAD
_MAD_TO_SIGMA = 0.6745  # Phi^-1(3/4): MAD of a normal distribution in units of sigma


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
    modes : ndarray of int, shape (N,) or None
        Group (0 or 1) of each demonstration when two modes were found, else None.
    mode_separation : float
        Between-group over within-group mean DTW distance of the best 2-group
        split (0 when not computed).
    """

    distances: FloatArray
    robust_z: FloatArray
    outlier: BoolArray
    reference_index: int
    threshold: float
    note: str = ""
    modes: IntArray | None = None
    mode_separation: float = 0.0


def assess_quality(
    distances: FloatArray,
    reference_index: int,
    *,
    threshold: float = 3.5,
    rel_mad_floor: float = 0.1,
    pairwise: FloatArray | None = None,
    mode_ratio: float = 5.0,
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
    rel_mad_floor : float
        Lower bound of the MAD relative to the median distance, >= 0.
    pairwise : ndarray, shape (N, N), optional
        All pairwise DTW distances; enables the two-mode check.
    mode_ratio : float
        Between/within distance ratio above which two groups are two modes.

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
    if not rel_mad_floor >= 0:
        raise InvalidInput(f"rel_mad_floor must be >= 0, got {rel_mad_floor!r}")
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
        mad = max(float(np.median(np.abs(v - med))), rel_mad_floor * med)
        if mad > 0:
            z[others] = _MAD_TO_SIGMA * (v - med) / mad
        else:
            note = "all distances to the reference are 0: no outliers"
    modes, separation = None, 0.0
    if pairwise is not None:
        P = check_finite(as_float_array(pairwise, "pairwise", shape=(N, N)), "pairwise")
        labels, separation = _two_groups(P)
        if labels is not None and separation > mode_ratio:
            modes = labels
    return QualityReport(
        distances=d.copy(),
        robust_z=z,
        outlier=z > threshold,
        reference_index=int(reference_index),
        threshold=float(threshold),
        note=note,
        modes=modes,
        mode_separation=separation,
    )


def _two_groups(P: FloatArray) -> tuple[IntArray | None, float]:
    """Best 2-group split by average linkage and its between/within distance ratio."""
    N = P.shape[0]
    if N < 4:
        return None, 0.0
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import squareform

    sym = 0.5 * (P + P.T)
    np.fill_diagonal(sym, 0.0)
    labels = fcluster(linkage(squareform(sym, checks=False), "average"), 2, "maxclust") - 1
    a = labels == 0
    b = ~a
    if a.sum() < 2 or b.sum() < 2:
        return None, 0.0
    within = np.concatenate(
        [sym[np.ix_(g, g)][np.triu_indices(int(g.sum()), 1)] for g in (a, b)]
    ).mean()
    between = sym[np.ix_(a, b)].mean()
    if within <= 0:
        return (labels.astype(np.intp), float("inf")) if between > 0 else (None, 0.0)
    return labels.astype(np.intp), float(between / within)
