"""When a plan's gripper holds the object: its grasp schedule, read from its own levels.

A plan's gripper channel is the learned opening schedule (a smooth regression of the
demonstrations' thumb-index distance). An absolute width (the thesis's 0.1 m, or
6 cm) says nothing about it: a hand that stays between 3 and 6 cm still closes and
opens. As motion's adaptive grasp (:mod:`dexlfd.motion.grasp`) does for a hand, the
schedule is read from the channel's own closed and open levels (its minimum and
maximum: the channel is smooth, there is no noise to guard against): the hand closes
below ``closed + close_fraction * (open - closed)`` and opens above ``closed +
open_fraction * (open - closed)`` (a Schmitt trigger), and states shorter than
``min_duration_s`` are dropped. With ``open_fraction = 0.5`` the release is where
:func:`dexlfd.plan.place.release_index` sets the object down. A channel that changes
by less than ``min_contrast`` has no grasp event: it is closed throughout when it
stays below ``single_state_below`` (a fixed-width plan such as a lift), else open.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.motion.grasp import drop_short_runs, schmitt_trigger

__all__ = ["GraspScheduleConfig", "grasp_intervals", "grasp_schedule"]


@dataclass(frozen=True, slots=True)
class GraspScheduleConfig:
    """How a plan's grasp schedule is read from its gripper channel (module docstring).

    ``close_fraction``, ``open_fraction`` [-] of the way from the closed to the open
    level; ``min_contrast`` [m]; ``min_duration_s`` [s]; ``single_state_below`` [m].
    """

    close_fraction: float = 1 / 3
    open_fraction: float = 0.5
    min_contrast: float = 0.005
    min_duration_s: float = 0.15
    single_state_below: float = 0.06

    def __post_init__(self) -> None:
        if not 0 < self.close_fraction <= self.open_fraction < 1:
            raise InvalidInput(
                "need 0 < close_fraction <= open_fraction < 1, got "
                f"{self.close_fraction}, {self.open_fraction}"
            )
        for name in ("min_contrast", "single_state_below"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InvalidInput(f"GraspScheduleConfig.{name} must be > 0, got {v!r}")
        if not (np.isfinite(self.min_duration_s) and self.min_duration_s >= 0):
            raise InvalidInput(f"min_duration_s must be >= 0, got {self.min_duration_s!r}")


def grasp_intervals(t: FloatArray, closed: BoolArray) -> list[list[float]]:
    """``[[t_close, t_open], ...]`` [s] of the closed runs; an open end is the last time."""
    c = np.asarray(closed, dtype=np.int8)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], c, [0]])))
    t_end = np.append(t, t[-1])
    return [[float(t[a]), float(t_end[b])] for a, b in zip(edges[::2], edges[1::2], strict=True)]


def grasp_schedule(
    t: FloatArray, gripper: FloatArray, cfg: GraspScheduleConfig | None = None
) -> tuple[BoolArray, dict[str, Any]]:
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
    info : dict
        ``closed_level``, ``open_level`` [m], ``close_below``, ``open_above`` [m] (or
        ``single_state``), ``intervals_s`` (:func:`grasp_intervals`): JSON-able.
    """
    cfg = cfg or GraspScheduleConfig()
    t = np.asarray(t, dtype=np.float64)
    g = np.asarray(gripper, dtype=np.float64)
    if g.shape != t.shape or g.size == 0 or not np.isfinite(g).all():
        raise InvalidInput(f"gripper must be {t.shape[0]} finite openings [m], got {g.shape}")
    lo, hi = float(g.min()), float(g.max())
    info: dict[str, Any] = {"method": "plan levels", "closed_level": lo, "open_level": hi}
    if hi - lo < cfg.min_contrast:
        held = bool(np.median(g) < cfg.single_state_below)
        closed = np.full(g.shape, held)
        info["single_state"] = "closed" if held else "open"
    else:
        on = lo + cfg.close_fraction * (hi - lo)
        off = lo + cfg.open_fraction * (hi - lo)
        closed = drop_short_runs(schmitt_trigger(g, on, off), t, cfg.min_duration_s)
        info.update(close_below=on, open_above=off)
    info["intervals_s"] = grasp_intervals(t, closed)
    return closed, info
