"""The hand's lift after each grasp and its set-down before each release.

People pick an object up and set it down nearly vertically: in the moments after
the hand closes on an object it rises, and before it opens again it comes down.
:func:`lift_events` measures both, per grasp run of the demonstration's ``grasp``
channel (:func:`dexlfd.intervals.grasp_intervals`), as displacements of the
end-effector (TCP) position that point **up**:

* the **lift**: from the TCP at the grasp (the first closed sample) to the first
  sample of the grasp's first half that is ``reach`` away from it;
* the **set-down**, reversed: from the TCP at the release (the first open sample)
  to the last sample of the grasp's second half that is ``reach`` away.

Both use the same ``reach`` (the smaller of the two sides' largest distance, at
most ``MAX_REACH_M``): a lift leans towards the place and a set-down leans back
towards the pick, so on a symmetric carry the two leans are mirror images and
cancel in their sum (:func:`episode_up`). Each side also gets its straightness
(displacement over the path length walked to get there: a hand that wanders
first is a poor witness of "up"). A side whose reach is under ``MIN_REACH_M`` is
not used (the hand slid the object, or tracking lost it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray, IntArray
from dexlfd.intervals import grasp_intervals
from dexlfd.io import Demonstration

__all__ = ["MAX_REACH_M", "MIN_REACH_M", "LiftEvent", "episode_up", "lift_events"]

# the lift / set-down is measured this far from the event, at most [m]. A trade-off
# (benchmarks/bench_task_frame.py): an RGB-only depth errs by centimetres, so a longer
# move gives a truer direction (synthetic pixel scenes at 20/40/60 deg tilt: 16/9/3.5
# deg up error at 0.10 m, 9/7.5/3.3 at 0.15, 7/4/2.3 at 0.20), but a move past a corner
# (lift 12 cm, then carry up a slope to a shelf) leans into the carry (shelf test: < 1
# deg at 0.10 m, 32 deg at 0.15)
MAX_REACH_M = 0.10
MIN_REACH_M = 0.02  # a hand that moves less than this after a grasp did not lift [m]
_HALF_WINDOW = 2  # the TCP at an event: medoid of +-2 samples (one-frame jumps)


@dataclass(frozen=True, slots=True)
class LiftEvent:
    """One grasp run of one demonstration: its events' TCP points and up-pointing moves.

    ``grasp_point`` / ``release_point`` are NaN when the run has no observed close /
    open (it touches the recording's start / end); ``lift`` / ``set_down`` (3,) [m]
    are NaN when that side was not measured (see ``reason``).
    """

    demo: int  # index of the demonstration
    grasp_index: int  # first closed sample
    release_index: int  # first open sample after the run (n when never seen open)
    grasp_point: FloatArray  # (3,) TCP at the grasp [m]
    release_point: FloatArray  # (3,) TCP at the release [m]
    lift: FloatArray  # (3,) displacement after the grasp [m]
    set_down: FloatArray  # (3,) displacement before the release, reversed [m]
    lift_straightness: float  # |lift| / path length [-]
    set_down_straightness: float  # [-]
    reason: str  # "" when both sides were measured, else why not

    @property
    def n_events(self) -> int:
        """How many of the lift and the set-down were measured (0, 1 or 2)."""
        return int(np.isfinite(self.lift).all()) + int(np.isfinite(self.set_down).all())


def _point(p: FloatArray, k: int) -> FloatArray:
    """TCP [m] at sample ``k``: the medoid of the seen samples within ``_HALF_WINDOW``.

    The medoid (the sample nearest to the others) ignores a one-frame jump and,
    unlike a per-axis median, turns with the frame.
    """
    window = p[max(k - _HALF_WINDOW, 0) : k + _HALF_WINDOW + 1]
    window = window[np.isfinite(window).all(axis=1)]
    if window.shape[0] == 0:
        return np.full(3, np.nan)
    dist = np.linalg.norm(window[:, None] - window[None], axis=2).sum(axis=1)
    return np.array(window[int(np.argmin(dist))])


def _side(p: FloatArray, origin: FloatArray, order: IntArray) -> tuple[FloatArray, FloatArray]:
    """Displacements from ``origin`` and path lengths along the samples ``order``."""
    seg = p[order]
    ok = np.isfinite(seg).all(axis=1)
    seg = seg[ok]
    if seg.shape[0] == 0:
        return np.empty((0, 3)), np.empty(0)
    steps = np.linalg.norm(np.diff(np.vstack([origin, seg]), axis=0), axis=1)
    return seg - origin, np.cumsum(steps)


def _at_reach(disp: FloatArray, path: FloatArray, reach: float) -> tuple[FloatArray, float]:
    """The first displacement at least ``reach`` long and its straightness."""
    dist = np.linalg.norm(disp, axis=1)
    k = int(np.argmax(dist >= reach - 1e-12))
    return disp[k], float(dist[k] / path[k]) if path[k] > 0 else 0.0


def _measure(p: FloatArray, a: int, r: int, n: int, scale: float = 1.0) -> tuple[FloatArray, ...]:
    """Grasp and release points, lift and set-down, their straightness; NaN when unseen.

    ``scale`` multiplies the reaches (:data:`MIN_REACH_M`, :data:`MAX_REACH_M`).
    """
    nan3 = np.full(3, np.nan)
    g_pt = _point(p, a) if a > 0 else nan3
    r_pt = _point(p, r) if r < n else nan3
    mid = (a + r) // 2
    sides = []
    for origin, order in ((g_pt, np.arange(a + 1, mid + 1)), (r_pt, np.arange(r - 1, mid - 1, -1))):
        if np.isfinite(origin).all():
            sides.append(_side(p, origin, order))
        else:
            sides.append((np.empty((0, 3)), np.empty(0)))
    far = [float(np.linalg.norm(d, axis=1).max()) if d.shape[0] else 0.0 for d, _ in sides]
    usable = [f >= scale * MIN_REACH_M for f in far]
    reach = min([scale * MAX_REACH_M] + [f for f, u in zip(far, usable, strict=True) if u])
    out: list[FloatArray | float] = [g_pt, r_pt]
    for (disp, path), use in zip(sides, usable, strict=True):
        out.extend(_at_reach(disp, path, reach) if use else (nan3, float("nan")))
    return tuple(np.asarray(x, dtype=np.float64) for x in out)


def lift_events(demo: Demonstration, index: int = 0) -> list[LiftEvent]:
    """The lift and set-down of every grasp run of ``demo`` (position in any frame [m]).

    ``index`` is stored as :attr:`LiftEvent.demo`. Runs with neither side measured
    are returned too, with the reason (for the caller's report).
    """
    t = np.asarray(demo.t, dtype=np.float64)
    p = np.where(np.asarray(demo.valid, bool)[:, None], demo.position, np.nan)
    # the reaches in the depth's units as read before its full-size factor (the lift's
    # direction is measured over the same stretch of the motion as without it)
    cap = demo.capture
    scale = 1.0 if cap is None or cap.depth_scale is None else float(cap.depth_scale)
    n = t.size
    out = []
    for t0, t1 in grasp_intervals(t, demo.grasp, until="last"):
        a = int(np.searchsorted(t, t0))
        r = int(np.searchsorted(t, t1)) + 1  # first open sample (n: never seen open)
        g_pt, r_pt, lift, s_lift, down, s_down = _measure(p, a, r, n, scale)
        why = []
        if a == 0:
            why.append("the grasp starts with the recording (no close seen)")
        if r >= n:
            why.append("the grasp lasts to the recording's end (no release seen)")
        if not why and not np.isfinite(lift).all():
            why.append(f"the hand moved less than {100 * MIN_REACH_M:.0f} cm after the grasp")
        if not why and not np.isfinite(down).all():
            why.append(f"the hand moved less than {100 * MIN_REACH_M:.0f} cm before the release")
        out.append(
            LiftEvent(
                index, a, r, g_pt, r_pt, lift, down, float(s_lift), float(s_down), "; ".join(why)
            )
        )
    return out


def episode_up(event: LiftEvent) -> tuple[FloatArray, float] | None:
    """The up direction (unit, (3,)) one grasp run gives and its weight [m], or None.

    With both sides the sum of the unit lift and unit set-down (their leans along
    the carry cancel), else the one side measured. The weight is the reach times the
    straightness (summed over the sides): long, straight moves count more.
    """
    vecs, weight = [], 0.0
    sides = (
        (event.lift, event.lift_straightness),
        (event.set_down, event.set_down_straightness),
    )
    for v, s in sides:
        if np.isfinite(v).all():
            norm = float(np.linalg.norm(v))
            vecs.append(v / norm)
            weight += norm * s
    if not vecs:
        return None
    u = np.sum(vecs, axis=0)
    norm = float(np.linalg.norm(u))
    if norm < 1e-9:
        return None
    return u / norm, weight
