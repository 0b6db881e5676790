"""Runs of a boolean channel: when a grasp closes and opens, in samples and in seconds.

A leaf module (NumPy only). Every stage that asks "when does the hand hold?" reads the
runs of true samples of a grasp flag (a demonstration's ``grasp``, a plan's or a
rollout's schedule) here: :func:`true_runs` in sample indices, :func:`grasp_intervals`
in seconds and :func:`longest_run` for the main grasp.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from dexlfd._types import BoolArray, FloatArray

__all__ = ["grasp_intervals", "longest_run", "true_runs"]


def true_runs(mask: BoolArray) -> list[tuple[int, int]]:
    """``(start, stop)`` sample indices of every run of true samples (``stop`` exclusive)."""
    c = np.asarray(mask, dtype=np.int8).ravel()
    edges = np.flatnonzero(np.diff(np.concatenate([[0], c, [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def grasp_intervals(
    t: FloatArray, grasp: BoolArray, *, until: Literal["open", "last"] = "open"
) -> tuple[tuple[float, float], ...]:
    """``((t_close, t_end), ...)`` [s] of the closed runs of ``grasp`` on the times ``t``.

    ``until="open"``: a run ends at the first open sample after it (the last time when
    it lasts to the end), so its length is how long the hand held; ``"last"``: at its
    last closed sample.
    """
    t = np.asarray(t, dtype=np.float64)
    runs = true_runs(grasp)
    if until == "last":
        return tuple((float(t[a]), float(t[b - 1])) for a, b in runs)
    n = t.shape[0]
    return tuple((float(t[a]), float(t[min(b, n - 1)])) for a, b in runs)


def longest_run(t: FloatArray, mask: BoolArray, *, inside: bool = False) -> tuple[int, int] | None:
    """Sample indices ``(start, stop)`` of the longest run of true samples, or None.

    ``stop`` is the first false sample after it (``n`` when the run lasts to the end);
    a run's length is ``t[stop] - t[start]`` (to the last time at the end). A tie goes
    to the earlier run. ``inside``: only runs that touch neither end count.
    """
    t = np.asarray(t, dtype=np.float64)
    n = t.shape[0]
    runs = [(a, b) for a, b in true_runs(mask) if not inside or (a > 0 and b < n)]
    if not runs:
        return None
    return max(runs, key=lambda r: t[min(r[1], n - 1)] - t[r[0]])
