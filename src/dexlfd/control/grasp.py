"""The simulated loop's grasp: grasp and release on the plan's schedule, and watch the hold.

A plan says when its gripper holds the object: its grasp schedule
(:func:`plan_grasp_schedule`: the plan's own ``grasp`` array, or read from its
gripper channel's closed and open levels, :mod:`dexlfd.plan.grasp_schedule`), not
an absolute width. The object is grasped where the schedule's main (longest) closed run
starts and released where it opens. A stream (teleoperation) passes the hand's own
grasp flag (motion's adaptive grasp) each tick; with ``regrasp`` the object is grasped
again whenever it closes after a release. No width threshold decides anything. A
grasp that closes on nothing ("missed") or an object that leaves the hand while
still commanded held ("dropped") is logged once per grasp and kept in
:attr:`GraspMonitor.events`; :func:`carry_failure` says afterwards whether the object
really went where the plan releases it.
"""

from __future__ import annotations

import dataclasses
import logging
from typing import Literal

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.intervals import grasp_intervals
from dexlfd.io import Plan, Rollout
from dexlfd.io.plan_facts import GraspSchedule
from dexlfd.io.rollout_facts import GraspEvent, Placement
from dexlfd.plan.grasp_schedule import GraspScheduleConfig, grasp_schedule
from dexlfd.robot.sim import PandaSim

__all__ = [
    "PLACE_TOLERANCE",
    "RELEASE_TOLERANCE",
    "SET_DOWN_SPEED",
    "UPRIGHT_DEG",
    "GraspMonitor",
    "carry_failure",
    "placement_report",
    "plan_grasp_schedule",
]

logger = logging.getLogger(__name__)

# [m] horizontal distance from the plan's release point beyond which the object was
# not put where the plan puts it (a box let go at rest lands within a few mm)
RELEASE_TOLERANCE = 0.05
PLACE_TOLERANCE = 0.02  # [m] placed: the object's centre this near the place position
UPRIGHT_DEG = 10.0  # [deg] placed upright: tilted no more than this from how it stood
SET_DOWN_SPEED = 0.1  # [m/s] set down, not dropped: it met the surface slower than this


def plan_grasp_schedule(plan: Plan) -> tuple[BoolArray, GraspSchedule]:
    """Closed flags (n,) of ``plan`` and how they were decided.

    The plan's ``grasp`` array when it has one (``source`` "plan"), else read from
    its gripper channel's levels (``"gripper levels"``, for plan files without a
    schedule; a channel that never changes has no grasp).
    """
    if plan.grasp is not None:
        closed = np.asarray(plan.grasp, dtype=bool)
        info = plan.grasp_schedule or GraspSchedule()
        return closed, dataclasses.replace(
            info, source="plan", intervals_s=grasp_intervals(plan.t, closed)
        )
    logger.warning(
        "the plan has no grasp schedule (a version-1 file): read from its gripper levels"
    )
    closed, info = grasp_schedule(plan.t, plan.gripper, GraspScheduleConfig())
    return closed, dataclasses.replace(info, source="gripper levels")


def carry_failure(rollout: Rollout, tolerance: float = RELEASE_TOLERANCE) -> str | None:
    """Why the simulated object was not carried to the plan's release point, or None.

    Reads the ``grasp_schedule`` (with ``grasp_position`` [m], ``release_t`` [s]
    and ``release_position`` [m]), ``grasp_events``, ``object_report`` and
    ``extras["attached"]`` of a rollout of :func:`~dexlfd.control.loop.track`. The
    object must have been held, never missed or dropped, have been carried (when the
    plan moves it more than ``tolerance`` horizontally, it must end at least half of
    that pick -> release distance from where it was picked) and end within
    ``tolerance`` [m] (horizontally) of where the plan lets it go (in the hand, if
    the plan never opens).
    """
    schedule = rollout.grasp_schedule or GraspSchedule()
    events = rollout.grasp_events
    if not schedule.intervals_s:
        return "the plan never closes the gripper"
    if events:
        e = events[0]
        dist = float("nan") if e.distance_m is None else e.distance_m
        return f"grasp {e.event} at t={e.t:.2f} s, {dist:.3f} m from the TCP"
    attached = rollout.extras.get("attached")
    if attached is None or not np.asarray(attached).any():
        return "the gripper never closed on it"
    obj = rollout.object_report
    final = None if obj is None else obj.final_position
    target = schedule.release_position
    if final is None:
        return "object position not recorded (the rollout has no final object position)"
    if target is None:
        return "object position not recorded (the rollout's schedule has no release position)"
    pick = schedule.grasp_position
    if pick is not None:
        travel = float(np.hypot(target[0] - pick[0], target[1] - pick[1]))
        moved = float(np.hypot(final[0] - pick[0], final[1] - pick[1]))
        if travel > tolerance and moved < 0.5 * travel:
            return (
                f"it was not carried: it ended {moved:.3f} m from where it was picked "
                f"({np.round(pick, 3).tolist()} m), the plan carries it {travel:.3f} m"
            )
    d = float(np.hypot(final[0] - target[0], final[1] - target[1]))
    if d > tolerance:
        return (
            f"it ended at {np.round(final, 3).tolist()} m, {d:.3f} m from where the plan "
            f"releases it at t={schedule.release_t or 0.0:.2f} s "
            f"({np.round(target, 3).tolist()} m; tolerance {tolerance:g} m)"
        )
    return None


def placement_report(rollout: Rollout) -> Placement:
    """Whether the object was carried and placed where the plan's task puts it.

    Reads the rollout's ``task.place_pose`` (the plan's place TCP pose: the object's
    centre there is where it should end, as it was at the pick), its
    ``object_report`` (:func:`~dexlfd.control.rollout_report.object_report`) and
    :func:`carry_failure`. Every check that fails is named in ``failure``.
    """
    obj = rollout.object_report
    failure = carry_failure(rollout, tolerance=max(PLACE_TOLERANCE, RELEASE_TOLERANCE))
    tilt = float("nan") if obj is None else obj.tilt_deg
    speed = None if obj is None else obj.impact_speed
    place = None if rollout.task is None else rollout.task.place_pose
    final = None if obj is None else obj.final_position
    if place is None or final is None:
        return Placement(False, failure is None, None, None, tilt, speed,
                         failure or "no place pose or no object in the rollout")  # fmt: skip
    d = np.asarray(final) - np.asarray(place[:3])
    error, horizontal = float(np.linalg.norm(d)), float(np.hypot(*d[:2]))
    reasons = [] if failure is None else [f"not carried: {failure}"]
    if failure is None and (obj is None or obj.released_t is None):
        reasons.append("never released")
    if error > PLACE_TOLERANCE:
        reasons.append(
            f"placed {1e3 * error:.1f} mm from the place position "
            f"(tolerance {1e3 * PLACE_TOLERANCE:g} mm)"
        )
    if not tilt <= UPRIGHT_DEG:
        reasons.append(f"tilted {tilt:.1f} deg (upright within {UPRIGHT_DEG:g})")
    if failure is None and (speed is None or speed >= SET_DOWN_SPEED):
        shown = "an unknown speed" if speed is None else f"{speed:.3f} m/s"
        reasons.append(f"set down at {shown} (below {SET_DOWN_SPEED:g} m/s)")
    return Placement(not reasons, failure is None, error, horizontal, tilt, speed,
                     "; ".join(reasons) or None)  # fmt: skip


class GraspMonitor:
    """Grasp state of one tracking run.

    Parameters
    ----------
    regrasp : bool
        Grasp again when the opening closes after a release.
    """

    def __init__(self, regrasp: bool) -> None:
        self.regrasp = regrasp
        self.grasps = 0
        self._was_closed = False
        self._holding: bool | None = False  # None: this grasp already reported lost
        self.events: list[GraspEvent] = []  # missed grasps and drops

    def command(self, sim: PandaSim, opening: float, closed: bool | None = None) -> None:
        """Grasp or release in ``sim`` as the schedule closes or opens.

        ``closed`` is the schedule at this tick (a plan's, or a stream's hand flag);
        None: unchanged. ``opening`` [m] is the referenced opening (not used to decide).
        """
        if closed is None:  # no schedule this tick: the hand keeps its state
            closed = self._was_closed
        if closed and not self._was_closed and (self.regrasp or self.grasps == 0):
            sim.grasp()
            self.grasps += 1
        elif self.grasps and sim.attached and not closed:
            sim.release()
        self._was_closed = closed

    def observe(
        self,
        sim: PandaSim,
        t: float,
        opening: float,
        payload: tuple[FloatArray, FloatArray] | None,
        p_tcp: FloatArray,
    ) -> bool:
        """Whether the object is really in the hand at time ``t`` [s]; logs a miss or drop.

        ``opening`` [m], the object's pose ``payload`` and the TCP position
        ``p_tcp`` [m] are values the loop already read this tick.
        """
        holding = payload is not None and sim.holds(opening, payload[0], p_tcp)
        if sim.attached and not holding and self._holding is not None:
            event: Literal["missed", "dropped"] = "dropped" if self._holding else "missed"
            pos = sim.payload_position()
            dist = float(np.linalg.norm(pos - p_tcp)) if pos is not None else float("nan")
            logger.warning(
                "grasp %s at t=%.3f s: the object is %.3f m from the TCP, gripper %.3f m",
                event, t, dist, sim.gripper_opening,
            )  # fmt: skip
            known = dist if np.isfinite(dist) else None
            self.events.append(GraspEvent(event=event, t=float(t), distance_m=known))
            self._holding = None  # report once per grasp
        elif holding:
            self._holding = True
        elif not sim.attached:
            self._holding = False
        return holding
