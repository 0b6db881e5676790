"""Dynamic time warping of multi-channel series: exact path in linear-ish memory (Eq. 4.16).

The accumulated cost ``C(i, j) = E(i, j) + min{C(i-1, j), C(i, j-1),
C(i-1, j-1)}`` (Eq. 4.16) is computed row by row, keeping only two rows of
floats; for the backtrack each cell stores which predecessor won, in 2 bits
(four cells per byte). A 4000 × 4000 problem thus needs 4 MB instead of the
128 MB of a float matrix, and the path is still exact. An optional
Sakoe–Chiba band restricts (and stores) only cells near the diagonal. A grid has
at most :data:`MAX_CELLS` cells, and the compiled recursion runs in chunks of rows so
that Ctrl-C interrupts it promptly.

``E(i, j)`` is the Euclidean distance between sample ``i`` of ``x`` and sample
``j`` of ``y`` after dividing each channel by ``scale`` (so that metres and
unit quaternions are comparable, see :func:`channel_scales`).

Ties are broken towards the diagonal step, then the step that advances ``x``
(``i - 1, j``), then the step that advances ``y``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from dexlfd._types import FloatArray, IntArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput

__all__ = [
    "MAX_CELLS",
    "DtwResult",
    "accumulated_cost",
    "channel_scales",
    "check_dtw_size",
    "dtw",
    "sakoe_chiba_bounds",
]

_DIAG, _UP, _LEFT = 0, 1, 2  # predecessor codes: (i-1, j-1), (i-1, j), (i, j-1)
# cells of one DTW grid: 1e9 take 250 MB of path codes and seconds per pair (a 31600 x
# 31600 grid: two 17-minute demonstrations at 30 Hz, aligned without a band)
MAX_CELLS = 1_000_000_000
_CHUNK_CELLS = 1 << 22  # cells per compiled call: Python (and Ctrl-C) runs between calls


@dataclass(frozen=True, slots=True)
class DtwResult:
    """Optimal DTW alignment of two series.

    Attributes
    ----------
    path : ndarray of int, shape (L, 2)
        Matched index pairs ``(i, j)`` from ``(0, 0)`` to ``(n-1, m-1)``; both
        columns are non-decreasing and advance by at most 1 per row.
    cost : float
        Accumulated cost ``C(n-1, m-1)`` (Eq. 4.16), in scaled units.
    """

    path: IntArray
    cost: float

    @property
    def normalized_cost(self) -> float:
        """Mean matched distance, ``cost / len(path)``; comparable across lengths."""
        return self.cost / self.path.shape[0]


@njit(cache=True)
def _dtw_rows(x, yT, lo, hi, offs, bits, prev, cur, erow, i0, i1):  # pragma: no cover
    """Forward recursion over rows ``i0 .. i1 - 1`` with 2-bit predecessor codes.

    ``yT`` is ``y`` transposed (d, m) so the distance row vectorises over
    columns. ``prev``/``cur`` are row buffers of length m + 1 holding column
    ``j`` at index ``j + 1`` (index 0 is a permanent +inf boundary), both
    filled with +inf before row 0; ``prev`` holds row ``i0 - 1`` on entry;
    ``erow`` (m,) is scratch; ``bits`` must be zeroed before row 0. The bands
    ``lo``/``hi`` are non-decreasing, so a cell outside the previous row's band
    is either never written (+inf) or the single stale cell left of it, which is
    reset. The recurrence is written with selects, not branches, because which
    predecessor wins is data-dependent. The buffers swap roles every row: returns
    True when the last row computed is in ``cur`` (an odd number of rows), so the
    caller swaps them before the next chunk.
    """
    d = x.shape[1]
    inf = np.inf
    for i in range(i0, i1):
        li = lo[i]
        hi_i = hi[i]
        # distance row E(i, li..hi) into erow[0..w): loops from 0 over contiguous
        # 1-D row slices, which LLVM vectorises (a 2-D slice yT[:, li:hi] is strided
        # and 4x slower)
        w = hi_i + 1 - li
        for jj in range(w):
            erow[jj] = 0.0
        for c in range(d):
            xc = x[i, c]
            yc = yT[c, li : hi_i + 1]
            for jj in range(w):
                diff = xc - yc[jj]
                erow[jj] += diff * diff
        for jj in range(w):
            erow[jj] = math.sqrt(erow[jj])
        cur[li] = inf  # column li - 1 of this row: outside the band
        left = inf
        acc = 0
        base = offs[i] - li
        for j in range(li, hi_i + 1):
            diag = prev[j]
            up = prev[j + 1]
            if i == 0 and j == 0:
                diag = 0.0  # C(0, 0) = E(0, 0)
            up_lt = up < diag
            m1 = up if up_lt else diag
            c1 = 1 if up_lt else 0
            left_lt = left < m1
            best = left if left_lt else m1
            code = 2 if left_lt else c1
            left = erow[j - li] + best  # [1] Eq. (4.16)
            cur[j + 1] = left
            # collect 4 codes in a register: a read-modify-write of the same byte
            # per cell would chain every cell through memory
            cell = base + j
            shift = (cell & 3) << 1
            acc |= code << shift
            if shift == 6:
                bits[cell >> 2] |= np.uint8(acc)
                acc = 0
        if acc != 0:
            bits[(base + hi_i) >> 2] |= np.uint8(acc)
        tmp = prev
        prev = cur
        cur = tmp
    return (i1 - i0) % 2 == 1


@njit(cache=True)
def _dtw_backtrack(lo, offs, bits, n, m, path):  # pragma: no cover
    """Follow the 2-bit predecessor codes from ``(n-1, m-1)``; path written backwards.

    Returns the path's length.
    """
    i = n - 1
    j = m - 1
    k = 0
    while True:
        path[k, 0] = i
        path[k, 1] = j
        k += 1
        if i == 0 and j == 0:
            break
        cell = offs[i] + j - lo[i]
        code = (bits[cell >> 2] >> ((cell & 3) << 1)) & 3
        if code == 0:
            i -= 1
            j -= 1
        elif code == 1:
            i -= 1
        else:
            j -= 1
    return k


def sakoe_chiba_bounds(n: int, m: int, band: int | None) -> tuple[IntArray, IntArray]:
    """Column range ``[lo[i], hi[i]]`` of each row of an ``n × m`` DTW grid.

    The band follows the straight line from ``(0, 0)`` to ``(n-1, m-1)`` with
    radius ``band`` cells. A radius too small to keep the corners connected
    (when one series is much longer) is widened to the smallest one that does.
    ``band=None`` gives the full grid.
    """
    if band is None or n == 1 or m == 1:
        return np.zeros(n, np.intp), np.full(n, m - 1, np.intp)
    slope = (m - 1) / (n - 1)
    r = max(float(band), math.ceil((slope - 1.0) / 2.0), 1.0)
    centre = np.arange(n) * slope
    lo = np.clip(np.floor(centre - r), 0, m - 1).astype(np.intp)
    hi = np.clip(np.ceil(centre + r), 0, m - 1).astype(np.intp)
    return lo, hi


def channel_scales(
    series: Sequence[FloatArray],
    groups: Sequence[Sequence[int]] | None = None,
    *,
    floor: float = 1e-12,
) -> FloatArray:
    """Per-channel divisors that make channel groups comparable in DTW.

    Each group (e.g. the 3 position channels) gets one scale, the RMS standard
    deviation of its channels over all samples of all series pooled, so a group
    keeps its internal geometry (Euclidean distance in metres stays Euclidean)
    while groups in different units weigh alike.

    Parameters
    ----------
    series : sequence of ndarray, each (n_i, d)
        The series to be compared.
    groups : sequence of sequences of int, optional
        Channel indices per group; channels in no group form their own group.
        Default: all channels one group.
    floor : float
        Smallest scale; a constant group gets scale 1 instead of a tiny one.

    Returns
    -------
    ndarray, shape (d,)
        Divisor per channel.
    """
    stacked = np.concatenate([np.asarray(s, np.float64) for s in series], axis=0)
    d = stacked.shape[1]
    var = stacked.var(axis=0)
    if groups is None:
        groups = [list(range(d))]
    scale = np.ones(d)
    seen: set[int] = set()
    all_groups = [list(g) for g in groups]
    all_groups += [[c] for c in range(d) if c not in {i for g in all_groups for i in g}]
    for g in all_groups:
        if not g:
            continue
        bad = [c for c in g if not 0 <= c < d or c in seen]
        if bad:
            raise InvalidInput(f"groups: channel(s) {bad} out of range 0..{d - 1} or repeated")
        seen.update(g)
        s = float(np.sqrt(np.mean(var[g])))
        scale[g] = s if s > floor else 1.0
    return scale


def dtw(
    x: FloatArray,
    y: FloatArray,
    *,
    scale: FloatArray | None = None,
    band: int | None = None,
) -> DtwResult:
    """Exact DTW path and cost between ``x`` and ``y`` (Eq. 4.16).

    Parameters
    ----------
    x : ndarray, shape (n,) or (n, d)
        First series (rows of the grid), finite.
    y : ndarray, shape (m,) or (m, d)
        Second series (columns), finite, same channel count.
    scale : ndarray, shape (d,), optional
        Positive divisor per channel applied before the Euclidean distance.
    band : int, optional
        Sakoe–Chiba radius in cells around the diagonal; ``None``: no band.

    Returns
    -------
    DtwResult
        Path ``(L, 2)`` and accumulated cost.

    References
    ----------
    .. [1] Thesis Eq. (4.16); Sakoe & Chiba (1978), IEEE Trans. ASSP 26(1).
    """
    xa, ya = _scaled_pair(x, y, scale)
    if band is not None and (isinstance(band, bool) or int(band) != band or band < 0):
        raise InvalidInput(f"band must be a non-negative integer or None, got {band!r}")
    return _dtw_impl(xa, ya, None if band is None else int(band))


def _scaled_pair(
    x: FloatArray, y: FloatArray, scale: FloatArray | None
) -> tuple[FloatArray, FloatArray]:
    """``x`` and ``y`` checked as series with one channel count, divided by ``scale``."""
    xa = _as_series(x, "x")
    ya = _as_series(y, "y")
    if xa.shape[1] != ya.shape[1]:
        raise InvalidInput(
            f"x and y must have the same number of channels, got {xa.shape[1]} and {ya.shape[1]}"
        )
    if scale is None:
        return xa, ya
    s = check_finite(as_float_array(scale, "scale", shape=(xa.shape[1],)), "scale")
    if (s <= 0).any():
        raise InvalidInput(f"scale must be > 0 per channel, got {s}")
    return xa / s, ya / s


def _as_series(v: FloatArray, name: str) -> FloatArray:
    a = as_float_array(v, name)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 1:
        raise InvalidInput(f"{name} must have shape (n,) or (n, d) with n >= 1, got {a.shape}")
    return check_finite(a, name)


def check_dtw_size(n: int, m: int, band: int | None) -> int:
    """Cells of an ``n × m`` DTW grid with Sakoe–Chiba radius ``band``; at most MAX_CELLS.

    Raises :class:`InvalidInput` beyond :data:`MAX_CELLS`, before any work.
    """
    lo, hi = sakoe_chiba_bounds(n, m, band)
    return _check_cells(n, m, int((hi - lo + 1).sum()))


def _check_cells(n: int, m: int, cells: int) -> int:
    """``cells`` of an ``n × m`` grid, or :class:`InvalidInput` beyond MAX_CELLS."""
    if cells > MAX_CELLS:
        raise InvalidInput(
            f"DTW of {n} x {m} samples spans {cells:.3g} cells "
            f"({cells / 4 / 1024**2:.0f} MiB of path codes); at most {MAX_CELLS:.3g} "
            "(two series of ~31600 samples): narrow band_fraction or use shorter "
            "(or subsampled) series",
            param="band_fraction",
        )
    return cells


def _dtw_impl(x: FloatArray, y: FloatArray, band: int | None) -> DtwResult:
    """Unchecked DTW on already scaled, contiguous float arrays.

    The rows are computed in chunks of about ``_CHUNK_CELLS`` cells, returning to
    Python between chunks so that Ctrl-C (a pending signal) interrupts within
    milliseconds; only the grid's size is checked (:func:`check_dtw_size`).
    """
    n, m = x.shape[0], y.shape[0]
    lo, hi = sakoe_chiba_bounds(n, m, band)
    widths = hi - lo + 1
    _check_cells(n, m, int(widths.sum()))
    offs = np.zeros(n, np.intp)
    np.cumsum(widths[:-1], out=offs[1:])
    n_cells = int(offs[-1] + widths[-1])
    bits = np.zeros((n_cells + 3) // 4, np.uint8)
    prev = np.full(m + 1, np.inf)
    cur = np.full(m + 1, np.inf)
    erow = np.empty(m)
    xc, yT = np.ascontiguousarray(x), np.ascontiguousarray(y.T)
    rows = max(1, _CHUNK_CELLS // int(widths.max()))
    for i0 in range(0, n, rows):
        if _dtw_rows(xc, yT, lo, hi, offs, bits, prev, cur, erow, i0, min(i0 + rows, n)):
            prev, cur = cur, prev
    path = np.empty((n + m - 1, 2), np.intp)
    length = _dtw_backtrack(lo, offs, bits, n, m, path)
    return DtwResult(path=path[:length][::-1].copy(), cost=float(prev[m]))


def accumulated_cost(
    x: FloatArray, y: FloatArray, *, scale: FloatArray | None = None
) -> FloatArray:
    """Full accumulated-cost matrix ``C`` (n, m) in NumPy (Eq. 4.16), for small inputs.

    A readable reference for :func:`dtw` and for figures of the worked example
    (Figs. 4.7–4.9). Memory is O(n·m) floats: use :func:`dtw` for long series.
    Anti-diagonals are independent of each other's cells, so each is one
    vectorised step.
    """
    xa, ya = _scaled_pair(x, y, scale)
    E = np.linalg.norm(xa[:, None, :] - ya[None, :, :], axis=2)
    n, m = E.shape
    C = np.full((n + 1, m + 1), np.inf)  # padded: row/column 0 are the boundary
    C[0, 0] = 0.0
    for s in range(2, n + m + 1):  # anti-diagonal i + j = s in padded indices
        i = np.arange(max(1, s - m), min(n, s - 1) + 1)
        j = s - i
        best = np.minimum(np.minimum(C[i - 1, j - 1], C[i - 1, j]), C[i, j - 1])
        C[i, j] = E[i - 1, j - 1] + best  # [1] Eq. (4.16)
    return C[1:, 1:]
