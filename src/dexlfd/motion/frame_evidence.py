"""What besides the lifts tells the task frame: the table plane, depth error, hand size.

Helpers of :mod:`dexlfd.motion.task_frame`: :func:`plane_check` (may the plane
through the grasp and release points be fused with the lifts' up?),
:func:`depth_error` and :func:`depth_angle` (how far an RGB-only depth read from the
hand's size tilts a measured direction), :func:`hand_length` and
:func:`scale_uncertainty` (how sure the metric scale is).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io import Demonstration
from dexlfd.motion.lifts import LiftEvent

__all__ = [
    "HAND_LENGTH_M",
    "angle_deg",
    "depth_angle",
    "depth_error",
    "hand_length",
    "plane_check",
    "scale_uncertainty",
]

MIN_PLANE_SPREAD_M = 0.05  # RMS spread across the points' main line for a plane [m]
MAX_PLANE_RMS_M = 0.02  # the points fit one plane within this (RMS) [m]
# depth-difference error of an RGB-only lift, at least [m]: the synthetic pixel scenes of
# benchmarks/bench_task_frame.py read the depth 1-3 cm off within a grasp and up to 8 cm
# across a grasp's start or end
DEPTH_ERROR_FLOOR_M = 0.03
PLANE_RMS_FLOOR_M = 0.003  # the plane's tilt sigma uses at least this residual [m]
MAX_PLANE_ANGLE_DEG = 20.0  # plane normal and lifts agree within this to be fused [deg]
HAND_LENGTH_M = 0.185  # adult wrist to middle fingertip [m]
HAND_LENGTH_REL_SD = 0.065  # its 1-sigma spread over adults, relative [-]
_HAND_CHAIN = (0, 9, 10, 11, 12)  # wrist, middle MCP, PIP, DIP, tip: bend-free length


def angle_deg(a: FloatArray, b: FloatArray) -> float:
    """Angle [deg] between unit vectors ``a`` and ``b``."""
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))))


def plane_check(points: FloatArray, up: FloatArray) -> tuple[FloatArray | None, float, dict]:
    """Normal (towards ``up``) of the plane through ``points`` if it may be fused.

    Returns ``(normal or None, its 1-sigma angle [rad], info)``.
    """
    info: dict[str, Any] = {"n_points": int(points.shape[0]), "used": False}
    if points.shape[0] < 3:
        info["reason"] = "fewer than 3 grasp and release points"
        return None, np.inf, info
    c = points - points.mean(axis=0)
    _, s, Vt = np.linalg.svd(c, full_matrices=False)
    n_pts = points.shape[0]
    spread, rms = s[1] / np.sqrt(n_pts), s[2] / np.sqrt(n_pts)
    normal = Vt[2] if np.dot(Vt[2], up) >= 0 else -Vt[2]
    angle = angle_deg(normal, up)
    info.update(spread_m=float(spread), rms_m=float(rms), angle_deg=angle)
    if spread < MIN_PLANE_SPREAD_M:
        info["reason"] = f"the points lie along a line (spread {100 * spread:.1f} cm)"
    elif rms > MAX_PLANE_RMS_M:
        info["reason"] = f"the points are not on one plane (RMS {100 * rms:.1f} cm)"
    elif angle > MAX_PLANE_ANGLE_DEG:
        info["reason"] = f"the plane's normal is {angle:.0f} deg off the lifts"
    else:
        info["used"] = True
        # not divided by sqrt(n): the points' depths share the lifting's slow biases
        sigma = max(rms, PLANE_RMS_FLOOR_M) / spread
        return normal, float(sigma), info
    return None, np.inf, info


def hand_length(demos: Sequence[Demonstration]) -> tuple[float, float]:
    """Median bend-free hand length [m] over the frames, and its relative spread."""
    lengths = []
    for d in demos:
        kp = np.asarray(d.keypoints)[:, _HAND_CHAIN]
        seg = np.linalg.norm(np.diff(kp, axis=1), axis=2).sum(axis=1)
        lengths.append(seg[np.isfinite(seg)])
    L = np.concatenate(lengths) if lengths else np.empty(0)
    if L.size < 2:
        return float("nan"), float("nan")
    q25, q50, q75 = np.percentile(L, [25, 50, 75])
    return float(q50), float((q75 - q25) / 1.349 / q50)  # IQR -> sigma of a normal


def scale_uncertainty(hand_m: float, hand_rel: float) -> tuple[float, float]:
    """1-sigma relative scale error and the scale an average adult hand would suggest.

    The lifting's metres are MediaPipe's hand size: a hand read 10 % small puts every
    point 10 % near. Adults' hands spread ``HAND_LENGTH_REL_SD``; the recorded hand's
    length spreads over the frames (``hand_rel``); and a hand read far from the adult
    average (MediaPipe read 0.14-0.19 m on five real recordings) says the reading
    itself may be off by that much, so its log-distance from the average counts too.
    The scale itself is not corrected: on those recordings dividing by the reading
    did not bring the carried distances closer to a person's estimates.
    """
    if not np.isfinite(hand_m) or hand_m <= 0:
        return HAND_LENGTH_REL_SD, float("nan")
    parts = [HAND_LENGTH_REL_SD, hand_rel if np.isfinite(hand_rel) else 0.0]
    parts.append(float(np.log(HAND_LENGTH_M / hand_m)))
    return float(np.sqrt(np.sum(np.square(parts)))), HAND_LENGTH_M / hand_m


def depth_error(demos: Sequence[Demonstration], events: list[LiftEvent]) -> float:
    """1-sigma error [m] of a depth difference between an event and its lift.

    Twice the median ``extras["depth_std"]`` at the events (two depths differ), at
    least ``DEPTH_ERROR_FLOOR_M`` when the depth is read from the hand's size
    (``capture.depth == "approximate"``: the read changes with the hand's
    shape as it closes); 0 for demonstrations without a depth uncertainty.
    """
    vals = []
    approximate = False
    for i, d in enumerate(demos):
        approximate |= d.depth_approximate
        std = d.extras.get("depth_std")
        if std is None:
            continue
        idx = [k for e in events if e.demo == i for k in (e.grasp_index, e.release_index)]
        vals += [float(std[k]) for k in idx if k < std.size and np.isfinite(std[k])]
    err = 2.0 * float(np.median(vals)) if vals else 0.0
    return max(err, DEPTH_ERROR_FLOOR_M) if approximate else err


def depth_angle(depth_err: float, direction: FloatArray, sight: FloatArray, L: float) -> float:
    """Angle [rad] a depth error tilts ``direction`` measured over a length ``L`` [m].

    Only the part of the depth error across ``direction`` tilts it: most when the
    line of sight is square to it (a level camera and a vertical lift).
    """
    if depth_err <= 0 or L <= 0:
        return 0.0
    return float(np.arctan(depth_err * np.linalg.norm(np.cross(direction, sight)) / L))
