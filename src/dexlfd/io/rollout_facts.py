"""The typed facts of a rollout file: what the tracked run did, read by later stages.

Each is a frozen :class:`~dexlfd.io._facts.Fact` held by a field of
:class:`~dexlfd.io.rollout.Rollout` (its ``FACTS``), checked on load; a field's unit
is in its metadata. A rollout's grasp schedule is the plan's
:class:`~dexlfd.io.plan_facts.GraspSchedule` with the main grasp on the control grid.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

from dexlfd.io._facts import Fact

__all__ = ["GraspEvent", "ObjectReport", "Placement", "TaskPoses"]

Pose7 = tuple[float, float, float, float, float, float, float]


@dataclass(frozen=True)
class GraspEvent(Fact):
    """A grasp that missed, or an object dropped while still commanded held.

    ``missed``: the grasp closed on nothing; ``dropped``: the object left the hand.
    At ``t`` [s], ``distance_m`` from the TCP (None: the object's position unknown).
    """

    event: Literal["missed", "dropped"]
    t: float = field(metadata={"unit": "s"})
    distance_m: float | None = field(default=None, metadata={"unit": "m"})


@dataclass(frozen=True)
class ObjectReport(Fact):
    """Where the simulated object ended and how hard it met the surface.

    ``final_position`` [m], ``final_quaternion`` (x, y, z, w), ``tilt_deg`` from how
    it stood at the start, ``released_t`` [s] when the hand last let go (None: never
    held, or still held), ``release_speed`` [m/s] then, ``impact_speed`` [m/s] its
    downward speed meeting the surface and ``touch_speed`` [m/s] its whole speed then
    (:func:`dexlfd.control.rollout_report.object_report`).
    """

    final_position: tuple[float, float, float] = field(metadata={"unit": "m"})
    final_quaternion: tuple[float, float, float, float]
    tilt_deg: float = field(metadata={"unit": "deg"})
    released_t: float | None = field(default=None, metadata={"unit": "s"})
    release_speed: float | None = field(default=None, metadata={"unit": "m/s"})
    impact_speed: float | None = field(default=None, metadata={"unit": "m/s"})
    touch_speed: float | None = field(default=None, metadata={"unit": "m/s"})


@dataclass(frozen=True)
class TaskPoses(Fact):
    """The plan's pick and place TCP poses: position [m], quaternion (x, y, z, w)."""

    pick_pose: Pose7
    place_pose: Pose7


@dataclass(frozen=True)
class Placement(Fact):
    """Whether the object was carried and set down where the plan's task puts it.

    Attributes
    ----------
    ok : bool
        Carried, within the place tolerance of the place, upright and set down
        slowly (:func:`dexlfd.control.grasp.placement_report`).
    carried : bool
        Held from the pick to the release.
    error_m : float or None
        3-D distance of the object's final centre from the place position [m].
    horizontal_error_m : float or None
        Its horizontal part [m].
    tilt_deg : float or None
        How far the object ended tilted from how it stood [deg]; None when the rollout
        has no object report (a NaN given for it is stored as None).
    set_down_speed_mps : float or None
        Its downward speed meeting the surface [m/s].
    failure : str or None
        Why not ok, in one line (every reason, ``"; "``-joined).
    """

    ok: bool
    carried: bool
    error_m: float | None = field(metadata={"unit": "m"})
    horizontal_error_m: float | None = field(metadata={"unit": "m"})
    tilt_deg: float | None = field(metadata={"unit": "deg"})
    set_down_speed_mps: float | None = field(metadata={"unit": "m/s"})
    failure: str | None

    def __post_init__(self) -> None:
        tilt = self.tilt_deg
        if tilt is not None and not math.isfinite(tilt):  # "no object": absent, not a NaN
            object.__setattr__(self, "tilt_deg", None)

    def to_dict(self) -> dict[str, Any]:
        """The fields as a JSON-able dict, plus the older key names.

        ``success``, ``place_error_m`` and ``set_down_speed`` repeat ``ok``,
        ``error_m`` and ``set_down_speed_mps``.
        """
        d = dataclasses.asdict(self)
        d.update(success=self.ok, place_error_m=self.error_m,
                 set_down_speed=self.set_down_speed_mps)  # fmt: skip
        return d

    def __getitem__(self, key: str) -> Any:  # the older dict reading: report["success"]
        return self.to_dict()[key]

    def get(self, key: str, default: Any = None) -> Any:
        """``to_dict().get(key, default)``."""
        return self.to_dict().get(key, default)
