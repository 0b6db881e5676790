"""Align several demonstrations to one reference by DTW (thesis §4.3.2, §4.4.4).

Every demonstration is warped onto the reference's time steps: where several
of its samples match one reference sample (many-to-one), their mean is taken,
as in the thesis ("If one point corresponds to multiple points, we set the
average value as the regularized value"). Where one sample matches several
reference samples it is repeated. The result is ``(N, m, d)``: all
demonstrations on the reference's ``m`` time steps.

The reference is selectable by index (the thesis picked series 5 by hand) or,
by default, the *medoid*: the demonstration with the least total DTW distance
to the others. Distances here are normalised DTW costs (cost divided by path
length, i.e. the mean matched distance), so a short demonstration is not
favoured merely for having fewer samples to sum over.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray, IntArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput
from dexlfd.learn.dtw import DtwResult, _dtw_impl, channel_scales, check_dtw_size

__all__ = [
    "AlignmentResult",
    "align_to_reference",
    "pairwise_dtw",
    "select_medoid",
    "warp_to_reference",
]


@dataclass(frozen=True, slots=True)
class AlignmentResult:
    """Demonstrations warped onto a reference's time steps.

    Attributes
    ----------
    reference_index : int
        Index of the reference series.
    aligned : ndarray, shape (N, m, d)
        Every series on the reference's ``m`` samples (the reference unchanged).
    distances : ndarray, shape (N,)
        Normalised DTW distance of each series to the reference (0 for itself),
        in scaled units.
    costs : ndarray, shape (N,)
        Accumulated DTW cost to the reference (Eq. 4.16), scaled units.
    paths : tuple of ndarray (L_i, 2)
        Path ``i`` pairs (sample of series i, sample of the reference).
    scale : ndarray, shape (d,)
        Channel divisors used in the distance.
    pairwise : ndarray, shape (N, N) or None
        Normalised DTW distances between all pairs, when the medoid was sought.
    """

    reference_index: int
    aligned: FloatArray
    distances: FloatArray
    costs: FloatArray
    paths: tuple[IntArray, ...]
    scale: FloatArray
    pairwise: FloatArray | None = None


def warp_to_reference(x: FloatArray, path: IntArray, m: int) -> FloatArray:
    """Put ``x`` on the reference's ``m`` samples along a DTW ``path``.

    Parameters
    ----------
    x : ndarray, shape (n, d)
        Series to warp.
    path : ndarray of int, shape (L, 2)
        Pairs (index into ``x``, index into the reference), monotone and
        continuous from ``(0, 0)`` to ``(n-1, m-1)``.
    m : int
        Reference length.

    Returns
    -------
    ndarray, shape (m, d)
        For each reference sample, the mean of the samples of ``x`` matched to it.
    """
    pi, pj = path[:, 0], path[:, 1]
    # pj is non-decreasing and hits every reference sample, so each sample's
    # matches are one contiguous run of the path: sum runs with reduceat
    starts = np.flatnonzero(np.concatenate([[True], pj[1:] != pj[:-1]]))
    if starts.size != m or pj[-1] != m - 1:
        raise InvalidInput(f"path does not cover the {m} reference samples")
    sums = np.add.reduceat(x[pi], starts, axis=0)
    counts = np.diff(np.append(starts, pj.size))
    return sums / counts[:, None]


def pairwise_dtw(
    series: Sequence[FloatArray], *, band_fraction: float | None = None
) -> tuple[FloatArray, dict[tuple[int, int], DtwResult]]:
    """DTW between all pairs of (already scaled) series.

    Returns the symmetric matrix of normalised distances (N, N) and the
    results keyed ``(a, b)`` with ``a < b`` (path columns: a's sample, b's sample).
    """
    N = len(series)
    D = np.zeros((N, N))
    results: dict[tuple[int, int], DtwResult] = {}
    for a in range(N):
        for b in range(a + 1, N):
            r = _dtw_impl(series[a], series[b], _band(series[a], series[b], band_fraction))
            results[(a, b)] = r
            D[a, b] = D[b, a] = r.normalized_cost
    return D, results


def select_medoid(pairwise: FloatArray) -> int:
    """Index of the series with the least total distance to the others (ties: lowest)."""
    return int(np.argmin(np.asarray(pairwise).sum(axis=1)))


def _band(x: FloatArray, y: FloatArray, band_fraction: float | None) -> int | None:
    if band_fraction is None:
        return None
    return int(math.ceil(band_fraction * max(x.shape[0], y.shape[0])))


def align_to_reference(
    series: Sequence[FloatArray],
    *,
    reference: int | str = "medoid",
    scale: FloatArray | None = None,
    groups: Sequence[Sequence[int]] | None = None,
    band_fraction: float | None = None,
    names: Sequence[str] | None = None,
) -> AlignmentResult:
    """Align every series to a reference series by multi-channel DTW.

    Parameters
    ----------
    series : sequence of ndarray, each (n_i, d)
        Finite series with the same channel count ``d``; lengths may differ.
    reference : int or "medoid"
        Index of the reference series, or ``"medoid"`` (least total DTW
        distance to the others).
    scale : ndarray, shape (d,), optional
        Channel divisors for the distance; default :func:`channel_scales` over
        ``series`` with ``groups``.
    groups : sequence of sequences of int, optional
        Channel groups sharing one scale (e.g. position, quaternion, gripper).
    band_fraction : float, optional
        Sakoe–Chiba radius as a fraction of the longer series' length.
    names : sequence of str, optional
        Names of the series (e.g. files) in messages; default ``series[i]``.

    Returns
    -------
    AlignmentResult

    References
    ----------
    .. [1] Thesis §4.3.2 and §4.4.4, Eq. (4.16).
    """
    arrs = _check_series(series)
    if band_fraction is not None and not (0 < band_fraction <= 1):
        raise InvalidInput(f"band_fraction must be in (0, 1] or None, got {band_fraction!r}")
    _check_grids(arrs, reference, band_fraction, names)
    scale = _scale(arrs, scale, groups)
    scaled = [np.ascontiguousarray(a / scale) for a in arrs]
    ref, pairwise, results = _reference(scaled, reference, band_fraction)
    aligned, distances, costs, paths = _warp_all(arrs, scaled, ref, results, band_fraction)
    return AlignmentResult(
        reference_index=ref,
        aligned=aligned,
        distances=distances,
        costs=costs,
        paths=tuple(paths),
        scale=np.asarray(scale, dtype=np.float64),
        pairwise=pairwise,
    )


def _check_series(series: Sequence[FloatArray]) -> list[FloatArray]:
    """Finite (n_i, d) arrays, one channel count for all."""
    if len(series) == 0:
        raise InvalidInput("series: need at least one series to align, got none")
    arrs = []
    for i, s in enumerate(series):
        a = as_float_array(s, f"series[{i}]")
        if a.ndim == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[0] < 1:
            raise InvalidInput(f"series[{i}] must have shape (n, d) with n >= 1, got {a.shape}")
        arrs.append(check_finite(a, f"series[{i}]"))
    d = arrs[0].shape[1]
    for i, a in enumerate(arrs):
        if a.shape[1] != d:
            raise InvalidInput(
                f"series[{i}] has {a.shape[1]} channels, but series[0] has {d}; "
                "all series must have the same channels"
            )
    return arrs


def _check_grids(
    arrs: Sequence[FloatArray],
    reference: int | str,
    band_fraction: float | None,
    names: Sequence[str] | None,
) -> None:
    """Refuse, before any DTW runs, a pair whose grid exceeds :data:`~dexlfd.learn.dtw.MAX_CELLS`.

    With ``"medoid"`` every pair is aligned, else every series with the reference (an
    index out of range is left to :func:`_reference`).
    """
    N = len(arrs)
    if isinstance(reference, str):
        pairs = [(a, b) for a in range(N) for b in range(a + 1, N)]
    elif isinstance(reference, int) and 0 <= reference < N:
        pairs = [(i, reference) for i in range(N) if i != reference]
    else:
        return
    for a, b in pairs:
        x, y = arrs[a], arrs[b]
        try:
            check_dtw_size(x.shape[0], y.shape[0], _band(x, y, band_fraction))
        except InvalidInput as exc:
            na, nb = (f"series[{a}]", f"series[{b}]") if names is None else (names[a], names[b])
            raise InvalidInput(f"{na} and {nb}: {exc}", param=exc.param) from None


def _scale(
    arrs: Sequence[FloatArray],
    scale: FloatArray | None,
    groups: Sequence[Sequence[int]] | None,
) -> FloatArray:
    """The channel divisors: given (checked) or :func:`channel_scales` of ``arrs``."""
    if scale is None:
        return channel_scales(arrs, groups)
    d = arrs[0].shape[1]
    s = check_finite(as_float_array(scale, "scale", shape=(d,)), "scale")
    if (s <= 0).any():
        raise InvalidInput(f"scale must be > 0 per channel, got {s}")
    return s


def _reference(
    scaled: Sequence[FloatArray], reference: int | str, band_fraction: float | None
) -> tuple[int, FloatArray | None, dict[tuple[int, int], DtwResult]]:
    """Reference index; with ``"medoid"`` also the pairwise distances and their DTW results."""
    if isinstance(reference, str):
        if reference != "medoid":
            raise InvalidInput(f"reference must be 'medoid' or an index, got {reference!r}")
        pairwise, results = pairwise_dtw(scaled, band_fraction=band_fraction)
        return select_medoid(pairwise), pairwise, results
    if isinstance(reference, bool) or int(reference) != reference:
        raise InvalidInput(f"reference must be 'medoid' or an index, got {reference!r}")
    ref, N = int(reference), len(scaled)
    if not 0 <= ref < N:
        raise InvalidInput(f"reference index {ref} out of range for {N} series (0..{N - 1})")
    return ref, None, {}


def _warp_all(
    arrs: Sequence[FloatArray],
    scaled: Sequence[FloatArray],
    ref: int,
    results: dict[tuple[int, int], DtwResult],
    band_fraction: float | None,
) -> tuple[FloatArray, FloatArray, FloatArray, list[IntArray]]:
    """Every series warped onto the reference: aligned (N, m, d), distances, costs, paths."""
    N, m, d = len(arrs), arrs[ref].shape[0], arrs[ref].shape[1]
    aligned = np.empty((N, m, d))
    distances = np.zeros(N)
    costs = np.zeros(N)
    paths: list[IntArray] = []
    for i in range(N):
        if i == ref:
            path = np.stack([np.arange(m), np.arange(m)], axis=1)
            aligned[i] = arrs[i]
        else:
            key = (min(i, ref), max(i, ref))
            r = results.get(key)
            if r is None:
                r = _dtw_impl(
                    scaled[key[0]], scaled[key[1]], _band(arrs[i], arrs[ref], band_fraction)
                )
            # orient as (sample of series i, sample of the reference)
            path = r.path if i < ref else r.path[:, ::-1].copy()
            aligned[i] = warp_to_reference(arrs[i], path, m)
            distances[i] = r.normalized_cost
            costs[i] = r.cost
        paths.append(path)
    return aligned, distances, costs, paths
