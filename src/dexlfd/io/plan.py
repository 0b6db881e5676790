"""Plan file: a time-stamped Cartesian pose + gripper trajectory to execute, with its task."""

from __future__ import annotations

import dataclasses
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.geometry import Box, Obstacle, obstacle_from_dict
from dexlfd.io._clock import on_part_clock
from dexlfd.io._npz import ArraySpec
from dexlfd.io._record import Record
from dexlfd.io._world import WORLD_SPECS, obstacle_arrays, obstacles_from_arrays
from dexlfd.io.plan_facts import (
    Approach,
    ArmPosture,
    EventErrors,
    Feasibility,
    GraspSchedule,
    Limits,
    ObstaclePass,
    PlaceCorrection,
    Retimed,
    TaskPose,
    TimeScaling,
)
from dexlfd.panda import Q_MAX, Q_MIN

__all__ = ["MAX_DURATION_S", "Plan", "load_plan", "save_plan"]

logger = logging.getLogger(__name__)

# [s] ten minutes: a tabletop task lasts seconds. Tracking records every 1 ms control tick
# (plan, reference and rollout: about 1.1 MB per second of plan), so this also bounds what
# simulating a plan holds in memory (under 1 GB at the bound).
MAX_DURATION_S = 600.0


@dataclass(frozen=True, eq=False)
class Plan(Record):
    """An executable end-effector trajectory (contract ``plan``, version 3).

    A plan lasts at most :data:`MAX_DURATION_S` (``t[-1] - t[0]``).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time [s].
    position, velocity, acceleration : ndarray, shape (n, 3)
        TCP position [m], velocity [m/s], acceleration [m/s²], base frame.
    quaternion : ndarray, shape (n, 4)
        TCP orientation, unit, scalar-last.
    angular_velocity : ndarray, shape (n, 3)
        [rad/s], base frame.
    gripper : ndarray, shape (n,)
        Gripper opening [m].
    grasp : ndarray of bool, shape (n,), optional
        The grasp schedule: true while the hand holds the object (version 2; every
        plan ``dexlfd plan`` writes has it; a version-1 file may lack it).
    pick_pose, place_pose : ndarray, shape (7,), optional
        TCP pose (position [m], quaternion x, y, z, w) where the schedule closes
        and where it opens again; present when the plan has a grasp.
    joint_posture : ndarray, shape (n, 7), optional
        The arm's planned joints [rad] (its elbow chosen so the links clear the
        obstacles); the controllers' null-space reference. Absent: the start posture.
    obstacle_center, obstacle_size : ndarray, shape (B, 3), optional
        The obstacles the plan avoids [m] (:mod:`dexlfd.io._world`).
    obstacle_radius : ndarray, shape (B,), optional
        A sphere's radius [m], 0 for a box.
    support_center, support_size : ndarray, shape (S, 3), optional
        Boxes on the table the object rests on (pick pedestal, place surface) [m].

    Typed facts (:mod:`dexlfd.io.plan_facts`, version 3; an older file's are lifted
    out of its ``meta`` on load):

    frame : str
        The frame of the poses (``"panda_base"``).
    task : str or None
        ``"pick-and-place"`` for a task plan.
    goal_error : float or None
        Distance [m] of the plan's end from the goal.
    obstacle_passes : tuple of ObstaclePass
        How the plan passes each obstacle (side, coupling, clearance [m]).
    grasp_schedule : GraspSchedule or None
        How ``grasp`` was decided, and its closed intervals [s].
    place_correction : PlaceCorrection or None
        A motion plan's lowering of the object onto a surface.
    pick, place : TaskPose or None
        A task's pick and place poses, with when the plan is there [s].
    limits : Limits or None
        Peaks against the Panda's Cartesian limits.
    feasibility, time_scaling, retimed : optional
        The joint-space slow-downs, every slow-down with the plan's growth [s], the
        last retiming.
    approach : Approach or None
        A task's final approach direction and length [m].
    event_errors : EventErrors or None
        A task's distance from its pick and place poses at the switches.
    arm_posture : ArmPosture or None
        How ``joint_posture`` was chosen and what the links clear with it.

    ``meta`` keeps provenance: the settings, the model's source, the method.
    A version-1 file's obstacles (its ``meta["settings"]["obstacles"]``) are read
    into the arrays once, on load.
    """

    KIND: ClassVar[str] = "plan"
    VERSION: ClassVar[int] = 3
    FACTS: ClassVar[tuple[str, ...]] = (
        "frame", "task", "goal_error", "obstacle_passes", "grasp_schedule",
        "place_correction", "pick", "place", "limits", "feasibility", "time_scaling",
        "retimed", "approach", "event_errors", "arm_posture",
    )  # fmt: skip
    UNIT_QUATERNIONS: ClassVar[tuple[str, ...]] = ("quaternion",)
    SPECS: ClassVar[dict[str, ArraySpec]] = {
        "t": ArraySpec(("n",), unit="s"),
        "position": ArraySpec(("n", 3), unit="m"),
        "velocity": ArraySpec(("n", 3), unit="m/s"),
        "acceleration": ArraySpec(("n", 3), unit="m/s^2"),
        "quaternion": ArraySpec(("n", 4), unit="x,y,z,w"),
        "angular_velocity": ArraySpec(("n", 3), unit="rad/s"),
        "gripper": ArraySpec(("n",), unit="m"),
        "grasp": ArraySpec(("n",), kind="b", required=False),
        "pick_pose": ArraySpec((7,), unit="m,x,y,z,w", required=False),
        "place_pose": ArraySpec((7,), unit="m,x,y,z,w", required=False),
        "joint_posture": ArraySpec(("n", 7), unit="rad", required=False),
        **WORLD_SPECS,
    }

    t: FloatArray
    position: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    quaternion: FloatArray
    angular_velocity: FloatArray
    gripper: FloatArray
    grasp: BoolArray | None = None
    pick_pose: FloatArray | None = None
    place_pose: FloatArray | None = None
    joint_posture: FloatArray | None = None
    obstacle_center: FloatArray | None = None
    obstacle_size: FloatArray | None = None
    obstacle_radius: FloatArray | None = None
    support_center: FloatArray | None = None
    support_size: FloatArray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    frame: str = "panda_base"
    task: str | None = None
    goal_error: float | None = field(default=None, metadata={"unit": "m"})
    obstacle_passes: tuple[ObstaclePass, ...] = ()
    grasp_schedule: GraspSchedule | None = None
    place_correction: PlaceCorrection | None = None
    pick: TaskPose | None = None
    place: TaskPose | None = None
    limits: Limits | None = None
    feasibility: Feasibility | None = None
    time_scaling: TimeScaling | None = None
    retimed: Retimed | None = None
    approach: Approach | None = None
    event_errors: EventErrors | None = None
    arm_posture: ArmPosture | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        span = float(self.t[-1] - self.t[0])
        if span > MAX_DURATION_S:
            raise InvalidInput(
                f"Plan.t spans {span:.6g} s; a plan lasts at most {MAX_DURATION_S:g} s "
                "(its rollout is recorded at 1 kHz)"
            )
        qp = self.joint_posture
        if qp is not None and ((qp < Q_MIN - 1e-6).any() or (qp > Q_MAX + 1e-6).any()):
            raise InvalidInput("Plan.joint_posture must lie within the Panda's joint limits")
        for name in ("pick_pose", "place_pose"):
            pose = getattr(self, name)
            if pose is not None and not np.isclose(np.linalg.norm(pose[3:]), 1.0, atol=1e-6):
                raise InvalidInput(f"Plan.{name}[3:7] must be a unit quaternion (x, y, z, w)")

    @classmethod
    def _facts_from_meta(
        cls, meta: dict[str, Any], version: int, where: str
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Versions 1-2 kept the facts in ``meta`` (same entries; see the class)."""
        if version >= 3:
            return {}, meta
        rest = dict(meta)
        facts: dict[str, Any] = {}
        renamed = {"obstacles": "obstacle_passes", "grasp": "grasp_schedule"}
        for key in ("frame", "task", "goal_error", "obstacles", "grasp", "pick", "place",
                    "limits", "feasibility", "time_scaling", "retimed", "approach",
                    "event_errors"):  # fmt: skip
            value = rest.pop(key, None)
            if value is not None:
                facts[renamed.get(key, key)] = value
        place = facts.get("place")
        if isinstance(place, dict) and "position" not in place:  # not a task's pose
            if "surface_z" in place:
                facts["place_correction"] = facts.pop("place")
            else:  # a hand-made file's bare support: read into the arrays below
                rest["place"] = facts.pop("place")
        passes = facts.get("obstacle_passes")
        if isinstance(passes, list):
            settings = rest.get("settings")
            margin = settings.get("margin") if isinstance(settings, dict) else None
            known = set(ObstaclePass.__dataclass_fields__)
            facts["obstacle_passes"] = [
                {"margin": margin, **{k: v for k, v in p.items() if k in known}}
                if isinstance(p, dict) else p
                for p in passes
            ]  # fmt: skip
        return facts, rest

    def part(self, a: int, b: int) -> Plan:
        """Samples ``a..b`` (inclusive) as a plan by itself, on its own clock from 0.

        The per-sample arrays (and extras) are sliced, ``t`` starts at 0; the world,
        the poses and ``meta`` are the plan's. Every typed fact comes along with its
        times on the part's clock: instants shifted by the part's start, spans (the
        held posture's ``arm_posture.hold_s``, the grasp intervals, the slow-downs)
        shifted and cut to the part, those outside it dropped
        (:func:`dexlfd.io._clock.on_part_clock`); the rest is the plan's as it is.
        """
        n = self.t.shape[0]
        if not 0 <= a < b < n:
            raise InvalidInput(f"Plan.part: samples {a}..{b} are not a stretch of 0..{n - 1}")
        sl = slice(a, b + 1)
        start, end = (float(self.t[k] - self.t[0]) for k in (a, b))
        cut: dict[str, Any] = {
            name: getattr(self, name)[sl]
            for name, spec in self.SPECS.items()
            if spec.shape[0] == "n" and getattr(self, name) is not None
        }
        cut["t"] = self.t[sl] - self.t[a]
        extras = {k: v[sl] if v.shape[:1] == (n,) else v for k, v in self.extras.items()}
        facts = {name: on_part_clock(getattr(self, name), start, end) for name in self.FACTS}
        return dataclasses.replace(self, **cut, **facts, extras=extras)

    @property
    def obstacles(self) -> tuple[Obstacle, ...]:
        """The plan's obstacles as :mod:`dexlfd.geometry` shapes."""
        return obstacles_from_arrays(self.obstacle_center, self.obstacle_size, self.obstacle_radius)

    @property
    def supports(self) -> tuple[Box, ...]:
        """The supports the object rests on, as boxes."""
        shapes = obstacles_from_arrays(self.support_center, self.support_size)
        return tuple(s for s in shapes if isinstance(s, Box))


def save_plan(path: str | os.PathLike[str], plan: Plan) -> Path:
    """Write ``plan`` to ``path`` atomically."""
    return plan._save(path)


def load_plan(path: str | os.PathLike[str]) -> Plan:
    """Read and check a plan file; raises :class:`~dexlfd.errors.InvalidFile`.

    A version-1 plan (obstacles only in ``meta``) gets its obstacle arrays here.
    """
    plan = Plan._load(path)
    if plan.obstacle_center is None:
        entries = (plan.meta.get("settings") or {}).get("obstacles") or []
        place = plan.place_correction
        support = place.support.to_json() if place and place.support else None
        bare = plan.meta.get("place")
        if support is None and isinstance(bare, dict):
            support = bare.get("support")
        try:
            obstacles = tuple(obstacle_from_dict(ob) for ob in entries)
            supports = (obstacle_from_dict(support),) if support else ()
        except (InvalidInput, KeyError, TypeError, ValueError) as exc:
            raise InvalidFile(f"{path}: meta obstacles unreadable: {exc}") from exc
        world: dict[str, Any] = obstacle_arrays(obstacles)
        if supports:
            world["support_center"] = np.array([supports[0].center])
            world["support_size"] = np.array([supports[0].size])  # type: ignore[union-attr]
        plan = dataclasses.replace(plan, **world)
    if plan.grasp is None:
        logger.info("%s: a version-1 plan without a grasp schedule", path)
    return plan
