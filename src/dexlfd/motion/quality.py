"""Quality report of one recorded demonstration: is it usable, and if not, why.

:func:`quality_report` measures what a user needs before teaching a robot with a
recording: how often the hand was seen and the longest gap, which hand was
followed and why, the grasp intervals, how far the wrist travelled, how much
the tracking jitters, the largest orientation step; and it lists warnings when
the recording is not usable as a pick-and-place demonstration (hand lost, no
grasp event, no motion, motion that is mostly tracking noise). :func:`format_quality`
prints it in a few lines.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.io import Demonstration
from dexlfd.rotations import quat_angle

__all__ = [
    "format_quality",
    "grasp_intervals",
    "jitter_dominated",
    "jitter_mm",
    "quality_report",
]

MIN_DETECTION = 0.8  # a recording seen in fewer frames has lost the hand
MAX_GAP_S = 0.5  # an interior gap longer than this loses the hand
MIN_TRAVEL_M = 0.02  # a wrist moving less than this did not move
# Jitter-dominated motion (see jitter_dominated): a real pick-and-place wrist path is
# 2.5-3.6 times its 5-95 % extent (MimicPlay's real play demo 3.6, the synthetic
# pick-and-place demos 2.5-2.9); the still hand of the shared video (frames of fists
# and pinches, no transport) gives 14.8 with the shape-gated pnp lift (15.8 before).
MAX_PATH_RATIO = 8.0  # wrist path / extent above which the motion is mostly jitter [-]
MAX_P99_SPEED = 2.0  # 99th-percentile wrist speed above which steps are jumps [m/s]
MAX_ORIENTATION_STEP_DEG = 90.0  # a larger step between seen frames is a tracking flip


def jitter_mm(t: FloatArray, position: FloatArray, valid: BoolArray, window: int = 5) -> float:
    """RMS distance [mm] of the wrist from its centred ``window``-frame mean, over seen runs.

    The hand's own motion over 5 frames (1/6 s) is nearly linear, which a centred
    mean leaves almost unchanged; what remains is tracking noise. NaN when no run is
    at least ``window`` frames long.
    """
    p = np.asarray(position, dtype=np.float64)
    v = np.asarray(valid, dtype=bool) & np.isfinite(p).all(axis=1)
    m = np.concatenate([[0], v.astype(np.int8), [0]])
    starts = np.flatnonzero(np.diff(m) == 1)
    stops = np.flatnonzero(np.diff(m) == -1)
    res = []
    kernel = np.ones(window) / window
    for a, b in zip(starts, stops, strict=True):
        if b - a < window:
            continue
        seg = p[a:b]
        mean = np.stack([np.convolve(seg[:, k], kernel, mode="valid") for k in range(3)], 1)
        h = window // 2
        res.append(seg[h : h + mean.shape[0]] - mean)
    if not res:
        return float("nan")
    r = np.concatenate(res)
    return float(1000 * np.sqrt(np.mean(np.sum(r**2, axis=1))))


def jitter_dominated(path_m: float, extent_m: float, p99_speed: float) -> str | None:
    """Why the wrist's motion is mostly tracking noise, or None when it is not.

    A hand carrying something travels a path a few times its extent (there and
    back, approach and retreat: 2.5-3.6 on the demos measured, see
    ``MAX_PATH_RATIO``); noise on a still or barely moving hand adds path without
    extent (14.8-15.8 on the shared video's still hand). A path over 8 times the
    extent (about twice the largest real ratio, half the still hand's) is called
    jitter. Independently, a 99th-percentile wrist speed above 2 m/s (faster than
    a hand moves objects; the still hand gave 1.04 m/s before the shape gate,
    0.23 after, MimicPlay's 8 fps play demo 1.57) means the steps are jumps.
    """
    if extent_m > 0 and path_m > MAX_PATH_RATIO * extent_m:
        return (
            f"jitter-dominated motion: the wrist's path ({100 * path_m:.1f} cm) is "
            f"{path_m / extent_m:.0f} times its extent ({100 * extent_m:.1f} cm)"
        )
    if p99_speed > MAX_P99_SPEED:
        return (
            f"jumpy motion: the wrist moves faster than {p99_speed:.2f} m/s in 1 % of the "
            f"frames (a hand carrying things stays below {MAX_P99_SPEED:g} m/s)"
        )
    return None


def grasp_intervals(t: FloatArray, grasp: BoolArray) -> list[tuple[float, float]]:
    """``(start_s, end_s)`` of every grasp (end: time of the last grasping frame)."""
    g = np.concatenate([[0], np.asarray(grasp, dtype=np.int8), [0]])
    starts = np.flatnonzero(np.diff(g) == 1)
    stops = np.flatnonzero(np.diff(g) == -1) - 1
    return [(float(t[a]), float(t[b])) for a, b in zip(starts, stops, strict=True)]


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def quality_report(demo: Demonstration) -> dict[str, Any]:
    """Figures and warnings of one demonstration (JSON-able, for ``meta["quality"]``)."""
    t, v = demo.t, demo.valid
    detected = np.asarray(demo.extras.get("detected", v), dtype=bool)
    gaps = [g for g in demo.meta.get("gaps", []) if g.get("interior")]
    longest = max((float(g["duration_s"]) for g in gaps), default=0.0)
    p = demo.position[v]
    if p.shape[0]:
        lo, hi = np.percentile(p, [5, 95], axis=0)
        extent = float(np.linalg.norm(hi - lo))
        steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
        path = float(np.sum(steps))
        dt = np.diff(t[v])
        speed = steps[dt > 0] / dt[dt > 0]
        p99_speed = float(np.percentile(speed, 99)) if speed.size else 0.0
    else:
        extent = path = p99_speed = 0.0
    q = demo.quaternion[v]
    step = 0.0
    if q.shape[0] > 1:
        step = float(np.degrees(quat_angle(q[1:], q[:-1])).max())
    intervals = grasp_intervals(t, demo.grasp)
    choice = demo.meta.get("capture", {}).get("hand_choice") or {}
    hand = choice.get("hand") or demo.meta.get("motion", {}).get("hand")
    rate = float(detected.mean()) if detected.size else 0.0
    warnings = []
    if rate < MIN_DETECTION or longest > MAX_GAP_S:
        warnings.append(f"hand lost: seen in {_pct(rate)} of frames, longest gap {longest:.2f} s")
    if not intervals:
        warnings.append("no grasp event: the aperture never closed and reopened")
    if extent < MIN_TRAVEL_M:
        warnings.append(f"no motion: the wrist moved {100 * extent:.1f} cm")
    elif (jitter := jitter_dominated(path, extent, p99_speed)) is not None:
        warnings.append(jitter)
    if step > MAX_ORIENTATION_STEP_DEG:
        warnings.append(
            f"orientation flips: a step of {step:.0f} deg between seen frames "
            f"(above {MAX_ORIENTATION_STEP_DEG:.0f} deg)"
        )
    trim = demo.meta.get("trim", {})
    return {
        "usable": not warnings,
        "warnings": warnings,
        "n_frames": int(t.size),
        "n_frames_recorded": int(trim.get("n_original", t.size)),
        "detection_rate_recorded": float(trim.get("detection_rate_original", rate)),
        "duration_s": float(t[-1] - t[0]) if t.size else 0.0,
        "detection_rate": rate,
        "n_gaps": len(gaps),  # interior gaps left unfilled
        "n_interpolated": int(np.sum(demo.extras.get("interpolated", np.zeros(0, bool)))),
        "longest_gap_s": longest,
        "hand": hand,
        "hand_reason": choice.get("reason", "the configured hand"),
        "grasp_intervals_s": [list(iv) for iv in intervals],
        "grasp_method": demo.meta.get("grasp", {}).get("method"),
        "travel_extent_m": extent,
        "travel_path_m": path,
        "p99_speed_m_s": p99_speed,
        "jitter_mm": _finite_or_none(jitter_mm(t, demo.position, v)),
        "max_orientation_step_deg": step,
        "trimmed": (
            {"start_s": trim.get("cut_start_s"), "end_s": trim.get("cut_end_s")}
            if trim.get("moved")
            else None
        ),
    }


def _pct(x: float) -> str:
    """A detection rate as every line prints it (one decimal)."""
    return f"{100 * x:.1f} %"


def _mm(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.1f} mm"


def format_quality(name: str, q: dict[str, Any]) -> str:
    """A few lines summarising :func:`quality_report`'s result for ``name``."""
    iv = ", ".join(f"{a:.1f}-{b:.1f} s" for a, b in q["grasp_intervals_s"]) or "none"
    lines = [
        f"{name}: {q['n_frames']} frames ({q['duration_s']:.1f} s), hand seen in "
        f"{_pct(q['detection_rate'])} of them, {q['n_gaps']} gap(s) left (longest "
        f"{q['longest_gap_s']:.2f} s), {q.get('n_interpolated', 0)} frame(s) interpolated",
        f"  hand: {q['hand']} ({q['hand_reason']})",
        f"  grasp ({q['grasp_method']}): {iv}",
        f"  wrist travel {100 * q['travel_extent_m']:.1f} cm (path "
        f"{100 * q['travel_path_m']:.1f} cm), jitter {_mm(q['jitter_mm'])}, largest "
        f"orientation step {q['max_orientation_step_deg']:.0f} deg",
    ]
    if q.get("trimmed") and (q["trimmed"]["start_s"] or q["trimmed"]["end_s"]):
        n_rec = q.get("n_frames_recorded", q["n_frames"])
        lines.append(
            f"  trimmed {q['trimmed']['start_s']:.2f} s at the start, "
            f"{q['trimmed']['end_s']:.2f} s at the end (hand still, or not in view; "
            f"of all {n_rec} frames recorded the hand was seen in "
            f"{_pct(q.get('detection_rate_recorded', q['detection_rate']))})"
        )
    lines += [f"  WARNING: {w}" for w in q["warnings"]]
    if q["usable"]:
        lines.append("  usable")
    else:
        lines.append("  NOT USABLE as a pick-and-place demonstration (see the warnings)")
    return "\n".join(lines)
