"""When a plan's gripper holds the object: its grasp schedule, read from its own levels.

A plan's gripper channel is the learned opening schedule (a smooth regression of the
demonstrations' thumb-index distance). An absolute width (the thesis's 0.1 m, or
6 cm) says nothing about it: a hand that stays between 3 and 6 cm still closes and
opens. As motion's adaptive grasp (:mod:`dexlfd.motion.grasp`) does for a hand, the
schedule is read from the channel's own closed and open levels (its minimum and
maximum: the channel is smooth, there is no noise to guard against): the hand closes
below ``closed + close_fraction * (open - closed)`` and opens above ``closed +
open_fraction * (open - closed)`` (a Schmitt trigger), and states shorter than
``min_duration_s`` are dropped, a closed run at the plan's very start or end too (a
recording may begin or end mid-grasp; a plan's grasp is one it closes and holds).
The object is carried over the main closed run (:func:`dexlfd.intervals.longest_run`),
and :func:`dexlfd.plan.place.release_index` sets it down where that run opens (this
schedule: one rule for "when the plan releases"). A channel that changes
by less than ``min_contrast`` has no grasp event (an absolute width says nothing about
holding: a plan that holds throughout, such as a lift, says so in its ``grasp`` array).
Plans written by dexlfd carry their schedule (``Plan.grasp``); this reading is for
plan files without one.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.intervals import grasp_intervals
from dexlfd.io.plan_facts import GraspSchedule
from dexlfd.motion.grasp import drop_short_runs, schmitt_trigger

__all__ = ["GraspScheduleConfig", "grasp_schedule"]


@dataclass(frozen=True, slots=True)
class GraspScheduleConfig:
    """How a plan's grasp schedule is read from its gripper channel (module docstring).

    ``close_fraction``, ``open_fraction`` [-] of the way from the closed to the open
    level; ``min_contrast`` [m]; ``min_duration_s`` [s].
    """

    close_fraction: float = 1 / 3
    open_fraction: float = 0.5
    min_contrast: float = 0.005
    min_duration_s: float = 0.15

    def __post_init__(self) -> None:
        if not 0 < self.close_fraction <= self.open_fraction < 1:
            raise InvalidInput(
                "need 0 < close_fraction <= open_fraction < 1, got "
                f"{self.close_fraction}, {self.open_fraction}"
            )
        v = self.min_contrast
        if not (np.isfinite(v) and v > 0):
            raise InvalidInput(f"GraspScheduleConfig.min_contrast must be > 0, got {v!r}")
        if not (np.isfinite(self.min_duration_s) and self.min_duration_s >= 0):
            raise InvalidInput(f"min_duration_s must be >= 0, got {self.min_duration_s!r}")


def grasp_schedule(
    t: FloatArray, gripper: FloatArray, cfg: GraspScheduleConfig | None = None
) -> tuple[BoolArray, GraspSchedule]:
    """Closed flags (n,) of a plan's gripper channel and how they were decided.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Plan time [s].
    gripper : ndarray, shape (n,)
        Planned opening [m].
    cfg : GraspScheduleConfig, optional

    Returns
    -------
    closed : ndarray of bool, shape (n,)
    info : GraspSchedule
        ``closed_level``, ``open_level`` [m], ``close_below``, ``open_above`` [m] (or
        ``single_state``), ``intervals_s`` [s] (:func:`dexlfd.intervals.grasp_intervals`).
    """
    cfg = cfg or GraspScheduleConfig()
    t = np.asarray(t, dtype=np.float64)
    g = np.asarray(gripper, dtype=np.float64)
    if g.shape != t.shape or g.size == 0 or not np.isfinite(g).all():
        raise InvalidInput(f"gripper must be {t.shape[0]} finite openings [m], got {g.shape}")
    lo, hi = float(g.min()), float(g.max())
    info = GraspSchedule(method="plan levels", closed_level=lo, open_level=hi)
    if hi - lo < cfg.min_contrast:
        # no change, no event: an absolute width cannot say whether it holds anything
        closed = np.zeros(g.shape, bool)
        info = dataclasses.replace(info, single_state="no event")
    else:
        on = lo + cfg.close_fraction * (hi - lo)
        off = lo + cfg.open_fraction * (hi - lo)
        closed = drop_short_runs(schmitt_trigger(g, on, off), t, cfg.min_duration_s)
        closed = _drop_short_end_grasps(closed, t, cfg.min_duration_s)
        info = dataclasses.replace(info, close_below=on, open_above=off)
    return closed, dataclasses.replace(info, intervals_s=grasp_intervals(t, closed))


def _drop_short_end_grasps(closed: BoolArray, t: FloatArray, min_duration_s: float) -> BoolArray:
    """Open a closed run at the very start or end shorter than ``min_duration_s`` [s].

    :func:`~dexlfd.motion.grasp.drop_short_runs` keeps the end runs (a recording may
    start or end in any state); a plan's gripper closed for a moment at its start
    (a relaxed hand) or end is not a grasp. Durations as
    :func:`dexlfd.intervals.grasp_intervals`.
    """
    out = np.array(closed, dtype=bool, copy=True)
    if out.all() or not out.any():
        return out
    opened = np.flatnonzero(~out)
    if out[0] and t[opened[0]] - t[0] < min_duration_s - 1e-9:
        out[: opened[0]] = False
    if out[-1] and t[-1] - t[opened[-1] + 1] < min_duration_s - 1e-9:
        out[opened[-1] + 1 :] = False
    return out
