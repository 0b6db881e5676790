"""Demonstrations and rollouts as LeRobot frames: one row per ``k / fps`` of the episode.

An input already on the uniform grid is copied; any other one is resampled (linear
interpolation, :func:`dexlfd.trajectory.resample`; spherical for quaternions; the
nearest sample for flags). NaN samples (the hand unseen) are skipped by the
interpolation, so state and action hold no NaN.
"""

from __future__ import annotations

from collections.abc import Sequence
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
from dexlfd.trajectory import resample

__all__ = ["GRID_TOL_S", "Episode", "episode_of", "median_fps", "uniform_grid"]

GRID_TOL_S = 1e-6  # an input whose times are within this of k/fps is copied, not resampled


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
    n = int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    grid = t[0] + np.arange(n) / fps
    same = n == t.shape[0] and bool(np.all(np.abs(grid - t) <= GRID_TOL_S))
    return grid, same


def median_fps(records: Sequence[Demonstration | Rollout]) -> int:
    """The rounded median sample rate of ``records`` [Hz] (30 if none has two samples)."""
    rates = [1.0 / float(np.median(np.diff(r.t))) for r in records if r.n_samples > 1]
    return max(1, round(float(np.median(rates)))) if rates else 30


def _interp(t: FloatArray, x: np.ndarray, grid: FloatArray) -> FloatArray:
    """Linear interpolation of each column of ``x`` (n, ...) at ``grid``; NaN samples skipped.

    Columns seen at the same samples are resampled together; a column never seen is 0.
    """
    flat = np.asarray(x, dtype=np.float64).reshape(x.shape[0], -1)
    out = np.zeros((grid.shape[0], flat.shape[1]))
    seen, group = np.unique(np.isfinite(flat), axis=1, return_inverse=True)
    for g in range(seen.shape[1]):
        ok, cols = seen[:, g], np.flatnonzero(group.reshape(-1) == g)
        if ok.any():
            out[:, cols] = resample(grid, t[ok], flat[np.ix_(ok, cols)])
    return out.reshape((grid.shape[0], *x.shape[1:]))


def _slerp(t: FloatArray, q: FloatArray, grid: FloatArray) -> FloatArray:
    """Spherical interpolation of unit quaternions ``q`` (n, 4) at ``grid`` (NaN rows skipped)."""
    ok = np.isfinite(q).all(axis=1)
    if not ok.any():
        return np.tile([0.0, 0.0, 0.0, 1.0], (grid.shape[0], 1))
    tv, qv = t[ok], quat_sign_continuous(q[ok])
    k = np.clip(np.searchsorted(tv, grid, side="right") - 1, 0, max(tv.shape[0] - 2, 0))
    if tv.shape[0] == 1:
        return np.tile(qv[0], (grid.shape[0], 1))
    s = np.clip((grid - tv[k]) / (tv[k + 1] - tv[k]), 0.0, 1.0)
    rel = quat_log(quat_multiply(quat_conjugate(qv[k]), qv[k + 1]))  # half rotation vector
    out: FloatArray = quat_normalize(quat_multiply(qv[k], quat_exp(s[:, None] * rel)))
    return out


def _nearest(t: FloatArray, x: np.ndarray, grid: FloatArray) -> np.ndarray:
    """Value of ``x`` (n, ...) at the sample nearest to each time of ``grid``."""
    x = np.asarray(x)
    if t.shape[0] == 1:
        return x[np.zeros(grid.shape[0], dtype=np.intp)]
    k = np.clip(np.searchsorted(t, grid), 1, t.shape[0] - 1)
    left = (grid - t[k - 1]) <= (t[k] - grid)
    return x[np.where(left, k - 1, k)]


@dataclass(frozen=True)
class Episode:
    """One record as frames: the feature columns, its start time, meta and frame times."""

    columns: dict[str, np.ndarray]  # feature key -> (m, d) or (m,)
    t0: float
    meta: dict[str, Any]
    times: FloatArray  # the episode's frame times [s], on the input's clock

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return int(self.times.shape[0])


def _demo_episode(demo: Demonstration, fps: int) -> Episode:
    t = demo.t
    grid, same = uniform_grid(t, fps)
    if not demo.valid.any():
        raise InvalidInput("a demonstration with no valid sample (hand never seen) has no motion")
    if same:
        pos, quat, grip = (
            _interp(t, demo.position, t),
            _slerp(t, demo.quaternion, t),
            _interp(t, demo.gripper, t),
        )
        valid, grasp, kp = demo.valid, demo.grasp, np.array(demo.keypoints)
        # copied samples stay bit-identical where they were valid
        pos[demo.valid], quat[demo.valid] = demo.position[demo.valid], demo.quaternion[demo.valid]
        grip[demo.valid] = demo.gripper[demo.valid]
    else:
        pos, quat = _interp(t, demo.position, grid), _slerp(t, demo.quaternion, grid)
        grip, kp = _interp(t, demo.gripper, grid), _interp(t, demo.keypoints, grid)
        kp[np.isnan(_nearest(t, demo.keypoints, grid))] = np.nan  # unseen stays unseen
        valid, grasp = _nearest(t, demo.valid, grid), _nearest(t, demo.grasp, grid)
    state = np.concatenate([pos, quat, grip[:, None]], axis=1)
    action = np.concatenate([state[1:], state[-1:]], axis=0)
    return Episode(
        {
            "observation.state": state,
            "action": action,
            "observation.hand_keypoints": kp.reshape(kp.shape[0], -1),
            "observation.hand_visible": np.asarray(valid, dtype=bool),
            "observation.grasp": np.asarray(grasp, dtype=bool),
        },
        float(t[0]),
        facts_to_v1_meta(demo),
        np.asarray(t if same else grid, dtype=np.float64),
    )


def _rollout_episode(ro: Rollout, fps: int) -> Episode:
    t = ro.t
    grid, same = uniform_grid(t, fps)
    g = t if same else grid

    def lin(x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=np.float64) if same else _interp(t, x, grid)

    def rot(q: np.ndarray) -> np.ndarray:
        return np.asarray(q, dtype=np.float64) if same else _slerp(t, q, grid)

    grip = lin(ro.gripper)[:, None]
    state = np.concatenate([lin(ro.ee_position), rot(ro.ee_quaternion), grip, lin(ro.q)], axis=1)
    action = np.concatenate([lin(ro.ref_position), rot(ro.ref_quaternion), grip], axis=1)
    cols = {
        "observation.state": state,
        "observation.velocity": lin(ro.dq),
        "observation.effort": lin(ro.tau),
        "action": action,
    }
    assert all(c.shape[0] == g.shape[0] for c in cols.values())
    return Episode(cols, float(t[0]), facts_to_v2_meta(ro), np.asarray(g, dtype=np.float64))


def episode_of(record: Demonstration | Rollout, fps: int) -> Episode:
    """The frames of one demonstration or rollout at ``fps`` [Hz] (module docstring)."""
    if isinstance(record, Demonstration):
        return _demo_episode(record, fps)
    return _rollout_episode(record, fps)
