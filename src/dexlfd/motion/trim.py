"""Idle start and end of a demonstration: motion onset and offset.

A recording usually begins before the hand moves and ends after it stops. The
onset is the first frame where the wrist's speed (central differences over the
seen frames) exceeds ``max(min_speed_m_s, speed_fraction * p95 speed)`` for at
least ``min_duration_s``; the offset is the last such frame. A margin is kept on
both sides, and every grasp change is kept inside. Without such motion nothing
is trimmed (and the quality report says "no motion"); neither when the wrist's
extent (5-95 % box diagonal) is below ``min_travel_m`` (tracking noise alone can
exceed the speed threshold).

Only a hand that is seen and still is idle: a frame where the hand is lost between
two seen frames is never cut (the kept span reaches over every such frame, so the
quality report sees the loss). Frames before the hand is first seen or after it is
last seen (not yet, or no longer, in view) may be cut. A grasp's release is a grasp
change, so it is kept with ``margin_s`` after it even when the track breaks before
the hand moves away.

:func:`cut_demonstration` keeps a span of frames (the recording's time axis and
``source_frames``); :mod:`dexlfd.motion.episodes` cuts one demonstration per
pick-and-place with it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import check_positive
from dexlfd.intervals import true_runs
from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import Trim

__all__ = [
    "TrimConfig",
    "cut_demonstration",
    "interior_losses",
    "motion_span",
    "trim_demonstration",
    "wrist_speed",
]


@dataclass(frozen=True, slots=True)
class TrimConfig:
    """Settings of :func:`motion_span`."""

    min_speed_m_s: float = 0.03  # moving means faster than this [m/s] ...
    speed_fraction: float = 0.15  # ... and faster than this fraction of the 95th pct speed
    min_duration_s: float = 0.1  # for at least this long [s]
    margin_s: float = 0.3  # kept before the onset and after the offset [s]
    min_travel_m: float = 0.02  # a wrist whose 5-95 % extent is below this did not move [m]

    def __post_init__(self) -> None:
        check_positive(self.min_speed_m_s, "min_speed_m_s")
        check_positive(self.speed_fraction, "speed_fraction", strict=False)
        check_positive(self.min_duration_s, "min_duration_s", strict=False)
        check_positive(self.margin_s, "margin_s", strict=False)
        check_positive(self.min_travel_m, "min_travel_m", strict=False)


def wrist_speed(t: FloatArray, position: FloatArray, valid: BoolArray) -> FloatArray:
    """Speed [m/s] of ``position`` (n, 3) by central differences over seen frames; NaN elsewhere."""
    t = np.asarray(t, dtype=np.float64)
    p = np.asarray(position, dtype=np.float64)
    v = np.asarray(valid, dtype=bool) & np.isfinite(p).all(axis=1)
    out = np.full(t.size, np.nan)
    idx = np.flatnonzero(v)
    if idx.size >= 2:
        vel = np.gradient(p[idx], t[idx], axis=0)
        out[idx] = np.linalg.norm(vel, axis=1)
    return out


def motion_span(
    t: FloatArray,
    position: FloatArray,
    valid: BoolArray,
    grasp: BoolArray | None = None,
    cfg: TrimConfig | None = None,
) -> tuple[int, int, bool]:
    """``(start, stop, moved)``: the frames ``[start, stop)`` to keep.

    ``moved`` is False when the wrist never moves (then ``(0, n)``).
    """
    cfg = cfg or TrimConfig()
    t = np.asarray(t, dtype=np.float64)
    n = t.size
    speed = wrist_speed(t, position, valid)
    ok = np.isfinite(speed)
    if ok.sum() < 3:
        return 0, n, False
    p = np.asarray(position, dtype=np.float64)[ok]
    lo, hi = np.percentile(p, [5, 95], axis=0)
    if np.linalg.norm(hi - lo) < cfg.min_travel_m:  # tracking noise only
        return 0, n, False
    thr = max(cfg.min_speed_m_s, cfg.speed_fraction * float(np.percentile(speed[ok], 95)))
    fast = ok & (speed > thr)
    # keep only runs of fast frames lasting min_duration_s
    runs = [(a, b) for a, b in true_runs(fast)
            if t[b - 1] - t[a] >= cfg.min_duration_s - 1e-9]  # fmt: skip
    if not runs:
        return 0, n, False
    first, last = int(runs[0][0]), int(runs[-1][1] - 1)
    if grasp is not None and grasp.size == n:
        changes = np.flatnonzero(np.diff(np.asarray(grasp, dtype=np.int8))) + 1
        if changes.size:
            first, last = min(first, int(changes[0]) - 1), max(last, int(changes[-1]))
    start = int(np.searchsorted(t, t[max(first, 0)] - cfg.margin_s, side="left"))
    stop = int(np.searchsorted(t, t[min(last, n - 1)] + cfg.margin_s, side="right"))
    lost = interior_losses(valid)
    if lost.size:  # lost is not idle: keep every interior loss with its seen neighbours
        start, stop = min(start, int(lost[0]) - 1), max(stop, int(lost[-1]) + 2)
    return (*_on_seen(start, stop, valid), True)


def _on_seen(start: int, stop: int, valid: BoolArray) -> tuple[int, int]:
    """``[start, stop)`` widened to begin and end on seen frames.

    A span edge inside a loss moves out to the seen frame before (start) or after
    (stop) it, so a loss the span touches stays interior; an edge before the first
    or after the last seen frame moves in to that frame.
    """
    seen = np.flatnonzero(np.asarray(valid, dtype=bool))
    if seen.size == 0:
        return start, stop
    before = seen[seen <= start]
    after = seen[seen >= stop - 1]
    start = int(before[-1]) if before.size else int(seen[0])
    stop = int(after[0]) + 1 if after.size else int(seen[-1]) + 1
    return start, stop


def interior_losses(valid: BoolArray) -> np.ndarray:
    """Indices of the frames without a hand between the first and the last seen frame."""
    v = np.asarray(valid, dtype=bool)
    seen = np.flatnonzero(v)
    if seen.size == 0:
        return seen
    return np.flatnonzero(~v[seen[0] : seen[-1] + 1]) + seen[0]


def trim_demonstration(demo: Demonstration, cfg: TrimConfig | None = None) -> Demonstration:
    """``demo`` cut to its motion span; its ``trim`` records what was cut.

    Times keep their original values (the first kept frame is at ``t[start]``);
    every per-frame extra is cut alike. Without motion the demonstration is
    returned whole, with ``trim.moved`` False.
    """
    n = demo.n_samples
    start, stop, moved = motion_span(demo.t, demo.position, demo.valid, demo.grasp, cfg)
    detected = np.asarray(demo.extras.get("detected", demo.valid), dtype=bool)
    info = Trim(
        moved=moved,
        start=start,
        stop=stop,
        n_original=n,
        onset_s=float(demo.t[start]) if moved else None,
        offset_s=float(demo.t[stop - 1]) if moved else None,
        cut_start_s=float(demo.t[start] - demo.t[0]),
        cut_end_s=float(demo.t[-1] - demo.t[stop - 1]),
        detection_rate_original=float(detected.mean()) if detected.size else 0.0,
        settings={k: float(v) for k, v in asdict(cfg or TrimConfig()).items()},
    )
    return cut_demonstration(replace(demo, trim=info), start, stop)


def cut_demonstration(demo: Demonstration, start: int, stop: int) -> Demonstration:
    """Frames ``[start, stop)`` of ``demo``, every per-frame extra cut alike.

    Times keep their values; ``source_frames`` (``[first, stop)`` in the
    recording, default the whole demonstration) is updated.
    """
    n = demo.n_samples
    if not 0 <= start < stop <= n:
        raise ValueError(f"cut [{start}, {stop}) outside the demonstration's {n} frames")
    first, _ = demo.source_frames or (0, n)
    source_frames = (int(first + start), int(first + stop))
    if (start, stop) == (0, n):
        return replace(demo, source_frames=source_frames)
    sl = slice(start, stop)
    extras = {
        k: (v[sl] if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == n else v)
        for k, v in demo.extras.items()
    }
    return replace(
        demo,
        t=demo.t[sl],
        keypoints=demo.keypoints[sl],
        valid=demo.valid[sl],
        position=demo.position[sl],
        quaternion=demo.quaternion[sl],
        gripper=demo.gripper[sl],
        grasp=demo.grasp[sl],
        extras=extras,
        source_frames=source_frames,
    )
