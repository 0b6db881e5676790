"""Demonstrations and rollouts as LeRobot frames: one row per ``k / fps`` of the episode.

An input already on the uniform grid is copied; any other one is resampled (linear
interpolation, as :func:`dexlfd.trajectory.resample`; spherical for quaternions; the
nearest sample for flags). NaN samples (the hand unseen) are skipped by the
interpolation, so state and action hold no NaN.

Frames are made a block at a time (:meth:`Episode.frames`): what is held for a whole
episode is its frame times and, per set of columns seen at the same samples, the
indices and times of those samples; each block costs time and memory in proportion to
its own length, so an episode of millions of samples is written in linear time.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io._demonstration_v1 import facts_to_v1_meta
from dexlfd.io.demonstration import Demonstration
from dexlfd.io.rollout import Rollout, facts_to_v2_meta
from dexlfd.rotations import (
    quat_conjugate,
    quat_exp,
    quat_log,
    quat_multiply,
    quat_normalize,
    quat_sign_continuous,
)

__all__ = ["GRID_TOL_S", "Episode", "episode_of", "grid_length", "median_fps", "uniform_grid"]

GRID_TOL_S = 1e-6  # an input whose times are within this of k/fps is copied, not resampled


def grid_length(t: FloatArray, fps: int) -> int:
    """Number of frames of :func:`uniform_grid` ``(t, fps)``, without making the grid."""
    return int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1


def uniform_grid(t: FloatArray, fps: int) -> tuple[FloatArray, bool]:
    """Uniform times ``t[0] + k / fps`` covering ``t``; and whether ``t`` already is that grid.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Strictly increasing sample times [s].
    fps : int
        Frame rate of the grid [Hz].

    Returns
    -------
    grid : ndarray, shape (m,)
        ``t[0] + k / fps`` for ``k = 0 .. floor((t[-1] - t[0]) fps + 1e-9)``.
    same : bool
        True if ``t`` equals ``grid`` to :data:`GRID_TOL_S` (then nothing is resampled).
    """
    n = grid_length(t, fps)
    grid = t[0] + np.arange(n) / fps
    same = n == t.shape[0] and bool(np.all(np.abs(grid - t) <= GRID_TOL_S))
    return grid, same


def median_fps(records: Sequence[Demonstration | Rollout]) -> int:
    """The rounded median sample rate of ``records`` [Hz] (30 if none has two samples)."""
    rates = [1.0 / float(np.median(np.diff(r.t))) for r in records if r.n_samples > 1]
    return max(1, round(float(np.median(rates)))) if rates else 30


def _window(tv: FloatArray, g: FloatArray) -> slice:
    """The samples of ``tv`` that bracket the times ``g`` (np.interp needs no other)."""
    lo = max(int(np.searchsorted(tv, g[0], side="right")) - 1, 0)
    hi = int(np.searchsorted(tv, g[-1], side="left")) + 1
    return slice(lo, hi)


class _Linear:
    """Linear interpolation of each column of ``x`` (n, ...) with its NaN samples skipped.

    Columns seen at the same samples share one index of those samples; a column never
    seen is 0. :meth:`at` gives the same numbers as ``np.interp`` over the whole series.
    """

    def __init__(self, t: FloatArray, x: np.ndarray) -> None:
        self.t, self.shape = t, x.shape[1:]
        self.flat = np.asarray(x).reshape(x.shape[0], -1)
        groups: dict[bytes, list[int]] = {}
        for c in range(self.flat.shape[1]):
            seen = np.isfinite(self.flat[:, c])
            groups.setdefault(np.packbits(seen).tobytes(), []).append(c)
        # per group: its columns, the samples seen (None: all) and their times
        self.groups: list[tuple[np.ndarray, np.ndarray | None, FloatArray]] = []
        for cols in groups.values():
            seen = np.isfinite(self.flat[:, cols[0]])
            if seen.all():
                self.groups.append((np.asarray(cols), None, t))
            elif seen.any():
                idx = np.flatnonzero(seen)
                self.groups.append((np.asarray(cols), idx, t[idx]))

    def at(self, g: FloatArray) -> FloatArray:
        """Values at the times ``g`` (a block of the grid), shape ``(len(g), ...)``."""
        out = np.zeros((g.shape[0], self.flat.shape[1]))
        for cols, idx, tv in self.groups:
            w = _window(tv, g)
            rows = np.arange(w.start, min(w.stop, tv.shape[0])) if idx is None else idx[w]
            block = np.asarray(self.flat[rows][:, cols], dtype=np.float64)
            for j, c in enumerate(cols):
                out[:, c] = np.interp(g, tv[w], block[:, j])
        return out.reshape((g.shape[0], *self.shape))


class _Slerp:
    """Spherical interpolation of unit quaternions ``q`` (n, 4), NaN rows skipped."""

    def __init__(self, t: FloatArray, q: FloatArray) -> None:
        ok = np.isfinite(q).all(axis=1)
        self.tv, self.qv = t[ok], quat_sign_continuous(np.asarray(q[ok], dtype=np.float64))

    def at(self, g: FloatArray) -> FloatArray:
        """Quaternions at the times ``g``, shape ``(len(g), 4)``."""
        tv, qv = self.tv, self.qv
        if tv.shape[0] == 0:
            return np.tile([0.0, 0.0, 0.0, 1.0], (g.shape[0], 1))
        if tv.shape[0] == 1:
            return np.tile(qv[0], (g.shape[0], 1))
        k = np.clip(np.searchsorted(tv, g, side="right") - 1, 0, tv.shape[0] - 2)
        s = np.clip((g - tv[k]) / (tv[k + 1] - tv[k]), 0.0, 1.0)
        rel = quat_log(quat_multiply(quat_conjugate(qv[k]), qv[k + 1]))  # half rotation vector
        out: FloatArray = quat_normalize(quat_multiply(qv[k], quat_exp(s[:, None] * rel)))
        return out


def _nearest(t: FloatArray, x: np.ndarray, g: FloatArray) -> np.ndarray:
    """Value of ``x`` (n, ...) at the sample nearest to each time of ``g``."""
    if t.shape[0] == 1:
        return np.asarray(x[np.zeros(g.shape[0], dtype=np.intp)])
    k = np.clip(np.searchsorted(t, g), 1, t.shape[0] - 1)
    left = (g - t[k - 1]) <= (t[k] - g)
    return np.asarray(x[np.where(left, k - 1, k)])


@dataclass(frozen=True)
class Episode:
    """One record as frames: its start time, meta, frame times, and its frames by block.

    ``make(lo, hi)`` returns the feature columns of frames ``lo .. hi - 1`` (feature
    key -> (hi - lo, d) or (hi - lo,)); :meth:`frames` is the way to call it.
    """

    t0: float
    meta: dict[str, Any]
    times: FloatArray  # the episode's frame times [s], on the input's clock
    make: Callable[[int, int], dict[str, np.ndarray]]

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return int(self.times.shape[0])

    def frames(self, lo: int = 0, hi: int | None = None) -> dict[str, np.ndarray]:
        """The feature columns of frames ``lo .. hi - 1`` (default: every frame)."""
        return self.make(lo, self.n_frames if hi is None else hi)


def _with_action(state_at: Callable[[int, int], np.ndarray], m: int, lo: int, hi: int) -> Any:
    """State of frames ``lo..hi-1`` and its action: the next frame's state (the last: its own)."""
    state = state_at(lo, min(hi + 1, m))
    action = state[1:] if hi < m else np.concatenate([state[1:], state[-1:]], axis=0)
    return state[: hi - lo], action


def _demo_episode(demo: Demonstration, fps: int) -> Episode:
    t = demo.t
    if not demo.valid.any():
        raise InvalidInput("a demonstration with no valid sample (hand never seen) has no motion")
    grid, same = uniform_grid(t, fps)
    times = np.asarray(t if same else grid, dtype=np.float64)
    pos, quat = _Linear(t, demo.position), _Slerp(t, demo.quaternion)
    grip = _Linear(t, demo.gripper)
    kp = None if same else _Linear(t, demo.keypoints)

    def state_at(lo: int, hi: int) -> np.ndarray:
        g = times[lo:hi]
        p, q, gr = pos.at(g), quat.at(g), grip.at(g)
        if same:  # copied samples stay bit-identical where they were valid
            v = demo.valid[lo:hi]
            p[v], q[v], gr[v] = (
                demo.position[lo:hi][v],
                demo.quaternion[lo:hi][v],
                demo.gripper[lo:hi][v],
            )
        return np.concatenate([p, q, gr[:, None]], axis=1)

    def make(lo: int, hi: int) -> dict[str, np.ndarray]:
        g = times[lo:hi]
        state, action = _with_action(state_at, times.shape[0], lo, hi)
        if same:
            keypoints = np.array(demo.keypoints[lo:hi])
            valid, grasp = demo.valid[lo:hi], demo.grasp[lo:hi]
        else:
            assert kp is not None
            keypoints = kp.at(g)
            keypoints[np.isnan(_nearest(t, demo.keypoints, g))] = np.nan  # unseen stays unseen
            valid, grasp = _nearest(t, demo.valid, g), _nearest(t, demo.grasp, g)
        return {
            "observation.state": state,
            "action": action,
            "observation.hand_keypoints": keypoints.reshape(keypoints.shape[0], -1),
            "observation.hand_visible": np.asarray(valid, dtype=bool),
            "observation.grasp": np.asarray(grasp, dtype=bool),
        }

    return Episode(float(t[0]), facts_to_v1_meta(demo), times, make)


def _rollout_episode(ro: Rollout, fps: int) -> Episode:
    t = ro.t
    grid, same = uniform_grid(t, fps)
    times = np.asarray(t if same else grid, dtype=np.float64)

    def lin(x: np.ndarray) -> Callable[[int, int], np.ndarray]:
        if same:
            return lambda lo, hi: np.asarray(x[lo:hi], dtype=np.float64)
        f = _Linear(t, x)
        return lambda lo, hi: f.at(times[lo:hi])

    def rot(q: np.ndarray) -> Callable[[int, int], np.ndarray]:
        if same:
            return lambda lo, hi: np.asarray(q[lo:hi], dtype=np.float64)
        f = _Slerp(t, q)
        return lambda lo, hi: f.at(times[lo:hi])

    grip, ee_p, ee_q = lin(ro.gripper), lin(ro.ee_position), rot(ro.ee_quaternion)
    q, dq, tau = lin(ro.q), lin(ro.dq), lin(ro.tau)
    ref_p, ref_q = lin(ro.ref_position), rot(ro.ref_quaternion)

    def make(lo: int, hi: int) -> dict[str, np.ndarray]:
        gr = grip(lo, hi)[:, None]
        return {
            "observation.state": np.concatenate(
                [ee_p(lo, hi), ee_q(lo, hi), gr, q(lo, hi)], axis=1
            ),
            "observation.velocity": dq(lo, hi),
            "observation.effort": tau(lo, hi),
            "action": np.concatenate([ref_p(lo, hi), ref_q(lo, hi), gr], axis=1),
        }

    return Episode(float(t[0]), facts_to_v2_meta(ro), times, make)


def episode_of(record: Demonstration | Rollout, fps: int) -> Episode:
    """The frames of one demonstration or rollout at ``fps`` [Hz] (module docstring)."""
    if isinstance(record, Demonstration):
        return _demo_episode(record, fps)
    return _rollout_episode(record, fps)
