"""The demonstrations' grasp and release, carried into the model (pick and place poses).

Each demonstration's ``grasp`` channel (true while the hand holds the object) marks
one closed run per pick-and-place. Its first sample is the **grasp** (the hand
closes on the object: the pick) and the first open sample after it the **release**
(the place). A run that touches either end of the recording has no observed close or
open and is skipped (with a warning); with several runs the longest is the task
(warned). Each event sample is put on the model's clock through the
demonstration's DTW path (the reference samples it is matched to, averaged: the
same many-to-one averaging as the alignment, Section 4.4.4), and the pose there is
the demonstration's preprocessed (gap-filled, filtered) pose, the data the GMM saw.

Across the demonstrations that enter the GMM the model keeps, per event, the mean
time and its standard deviation, the mean position and orientation (quaternions
sign-aligned, averaged and renormalised) and the 6x6 covariance of position [m²]
and orientation (rotation vector from the mean, base frame) [rad²].
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray, IntArray
from dexlfd.intervals import longest_run, true_runs
from dexlfd.io import Demonstration
from dexlfd.learn.pipeline import LearnedTrajectory
from dexlfd.rotations import quat_conjugate, quat_log, quat_multiply

__all__ = ["GraspEvents", "demonstration_events", "grasp_events"]

logger = logging.getLogger(__name__)

EVENT_NAMES = ("grasp", "release")


@dataclass(frozen=True, slots=True)
class GraspEvents:
    """The model's event arrays (:class:`dexlfd.io.LearnedModel` ``event_*``) and notes."""

    arrays: dict[str, Any] | None  # None: no demonstration had both events
    info: dict[str, Any]  # JSON-able: per demonstration, what was found


def demonstration_events(t: FloatArray, grasp: BoolArray) -> tuple[int, int] | str:
    """Sample indices ``(k_close, k_open)`` of the demonstration's closed run, or why not.

    ``k_close`` is the run's first closed sample, ``k_open`` the first open sample
    after it; a run touching either end of the recording is not a full grasp.
    """
    if not np.asarray(grasp, dtype=bool).any():
        return "the hand never closes"
    run = longest_run(t, grasp, inside=True)
    if run is None:
        return "the closed run touches the recording's start or end (no close or open seen)"
    return run


def _reference_time(path: IntArray, k: int, t_ref: FloatArray) -> float:
    """Mean reference time [s] that sample ``k`` of a series is matched to by DTW."""
    match = path[path[:, 0] == k, 1]
    return float(np.mean(t_ref[match])) if match.size else float("nan")


def _first_kept_time(demo: Demonstration) -> float:
    """Time of the first sample the preprocessing keeps (leading invalid ones are trimmed)."""
    ok = np.asarray(demo.valid, bool) & np.isfinite(demo.pose).all(axis=1)
    return float(demo.t[int(np.argmax(ok))]) if ok.any() else float(demo.t[0])


def grasp_events(
    demos: Sequence[Demonstration], names: Sequence[str], traj: LearnedTrajectory
) -> GraspEvents:
    """The grasp and release of every used demonstration on the model's clock.

    Returns :class:`GraspEvents`; ``arrays`` is None (with the reason in ``info``)
    when no used demonstration has both events.
    """
    al, t_ref = traj.alignment, traj.t_reference
    per_demo: list[dict[str, Any]] = []
    times: list[list[float]] = []
    poses: list[FloatArray] = []
    for i, (demo, name) in enumerate(zip(demos, names, strict=True)):
        if not traj.used[i]:
            per_demo.append({"name": name, "skipped": "not used (outlier)"})
            continue
        found = demonstration_events(demo.t, demo.grasp)
        if isinstance(found, str):
            logger.warning("%s: no grasp event (%s); its grasp is not learned", name, found)
            per_demo.append({"name": name, "skipped": found})
            continue
        n_runs = sum(1 for a, _ in true_runs(demo.grasp) if a > 0)  # closings seen
        if n_runs > 1:
            logger.warning(
                "%s: the hand closes %d times; the longest closed run is the grasp", name, n_runs
            )
        t_prep, x_prep = traj.series[i]
        offset = _first_kept_time(demo)
        ks = [
            int(np.clip(np.searchsorted(t_prep, demo.t[k] - offset - 1e-9), 0, len(t_prep) - 1))
            for k in found
        ]
        t_model = [_reference_time(al.paths[i], k, t_ref) for k in ks]
        if not all(np.isfinite(t_model)) or t_model[1] <= t_model[0]:
            per_demo.append({"name": name, "skipped": "events not in order after alignment"})
            continue
        times.append(t_model)
        poses.append(x_prep[ks, :7])
        per_demo.append({
            "name": name,
            "t_source_s": [float(demo.t[k]) for k in found],
            "t_model_s": t_model,
        })  # fmt: skip
    info: dict[str, Any] = {"demonstrations": per_demo, "n_with_events": len(times)}
    if not times:
        info["note"] = "no demonstration with a grasp and a release: the model has no events"
        logger.warning("learn: %s", info["note"])
        return GraspEvents(None, info)
    return GraspEvents(_statistics(np.array(times), np.stack(poses)), info)


def _statistics(times: FloatArray, poses: FloatArray) -> dict[str, Any]:
    """Mean and spread of ``times`` (N, 2) and ``poses`` (N, 2, 7) per event."""
    n = times.shape[0]
    pos = poses[:, :, :3]
    quat = poses[:, :, 3:7] / np.linalg.norm(poses[:, :, 3:7], axis=2, keepdims=True)
    quat = np.where((np.sum(quat * quat[:1], axis=2) < 0)[..., None], -quat, quat)
    q_mean = quat.mean(axis=0)
    q_mean /= np.linalg.norm(q_mean, axis=1, keepdims=True)
    rotvec = 2.0 * quat_log(quat_multiply(quat, quat_conjugate(q_mean)[None]))
    dev = np.concatenate([pos - pos.mean(axis=0), rotvec], axis=2)  # (N, 2, 6)
    cov = np.einsum("nei,nej->eij", dev, dev) / max(n - 1, 1)
    return {
        "event_t": times.mean(axis=0),
        "event_t_std": times.std(axis=0, ddof=1) if n > 1 else np.zeros(2),
        "event_position": pos.mean(axis=0),
        "event_quaternion": q_mean,
        "event_cov": cov,
        "event_count": np.full(2, n, dtype=np.int64),
    }
