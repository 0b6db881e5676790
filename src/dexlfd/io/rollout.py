"""Rollout file: what the robot (simulated or real) did while tracking a plan."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.geometry import Obstacle
from dexlfd.io._facts import to_json
from dexlfd.io._npz import ArraySpec
from dexlfd.io._record import Record
from dexlfd.io._world import WORLD_SPECS, obstacles_from_arrays
from dexlfd.io.plan_facts import GraspSchedule
from dexlfd.io.rollout_facts import GraspEvent, ObjectReport, Placement, TaskPoses
from dexlfd.panda import N_JOINTS  # the Panda's arm joints

__all__ = ["Rollout", "facts_to_v2_meta", "load_rollout", "save_rollout"]


@dataclass(frozen=True, eq=False)
class Rollout(Record):
    """A tracked trajectory (contract ``rollout``, version 3).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time [s].
    q, dq, tau : ndarray, shape (n, 7)
        Joint positions [rad], velocities [rad/s], commanded torques [N·m].
    ee_position, ref_position : ndarray, shape (n, 3)
        Measured and reference TCP position [m], base frame.
    ee_quaternion, ref_quaternion : ndarray, shape (n, 4)
        Measured and reference TCP orientation, scalar-last.
    gripper : ndarray, shape (n,)
        Gripper opening [m].
    grasp : ndarray of bool, shape (n,), optional
        The grasp schedule tracked (the plan's, on the control grid; version 2).
    obstacle_center, obstacle_size, obstacle_radius, support_center, support_size
        The simulated world's obstacles and supports (as in the plan, optional).

    Typed facts (:mod:`dexlfd.io.rollout_facts`, version 3; an older file's are
    lifted out of its ``meta`` on load):

    stopped : str or None
        Why a safety stop cut the rollout short (the samples up to it are kept).
    controller : str or None
        The controller's name (its gains are in ``meta["controller"]``).
    rate_hz : float or None
        The control rate [Hz].
    payload_kg : float or None
        The simulated object's mass [kg].
    grasp_schedule : GraspSchedule or None
        The plan's schedule with the main grasp on the control grid (times [s],
        positions [m]).
    grasp_events : tuple of GraspEvent
        Grasps that missed and objects dropped.
    object_report : ObjectReport or None
        Where the simulated object ended, its tilt, release and impact speeds.
    task : TaskPoses or None
        The plan's pick and place poses.
    placement : Placement or None
        Whether the object was carried and placed (a pick-and-place with an object).

    ``meta`` keeps provenance: the controller's gains, the plant, the loop settings,
    the plan's ``meta``.
    """

    KIND: ClassVar[str] = "rollout"
    VERSION: ClassVar[int] = 3
    # 1 kHz float samples: deflate shrinks them by a fifth at ~30x the write time (a 21 s
    # rollout: 7.1 MB in 0.6 s against 9.2 MB in 0.02 s), on the path to the robot video
    COMPRESS: ClassVar[bool] = False
    FACTS: ClassVar[tuple[str, ...]] = (
        "stopped", "controller", "rate_hz", "payload_kg", "grasp_schedule", "grasp_events",
        "object_report", "task", "placement",
    )  # fmt: skip
    MIN_SAMPLES: ClassVar[int] = 1
    SPECS: ClassVar[dict[str, ArraySpec]] = {
        "t": ArraySpec(("n",), unit="s"),
        "q": ArraySpec(("n", N_JOINTS), unit="rad"),
        "dq": ArraySpec(("n", N_JOINTS), unit="rad/s"),
        "tau": ArraySpec(("n", N_JOINTS), unit="N m"),
        "ee_position": ArraySpec(("n", 3), unit="m"),
        "ee_quaternion": ArraySpec(("n", 4), unit="x,y,z,w"),
        "ref_position": ArraySpec(("n", 3), unit="m"),
        "ref_quaternion": ArraySpec(("n", 4), unit="x,y,z,w"),
        "gripper": ArraySpec(("n",), unit="m"),
        "grasp": ArraySpec(("n",), kind="b", required=False),
        **WORLD_SPECS,
    }

    t: FloatArray
    q: FloatArray
    dq: FloatArray
    tau: FloatArray
    ee_position: FloatArray
    ee_quaternion: FloatArray
    ref_position: FloatArray
    ref_quaternion: FloatArray
    gripper: FloatArray
    grasp: BoolArray | None = None
    obstacle_center: FloatArray | None = None
    obstacle_size: FloatArray | None = None
    obstacle_radius: FloatArray | None = None
    support_center: FloatArray | None = None
    support_size: FloatArray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    stopped: str | None = None
    controller: str | None = None
    rate_hz: float | None = field(default=None, metadata={"unit": "Hz"})
    payload_kg: float | None = field(default=None, metadata={"unit": "kg"})
    grasp_schedule: GraspSchedule | None = None
    grasp_events: tuple[GraspEvent, ...] = ()
    object_report: ObjectReport | None = None
    task: TaskPoses | None = None
    placement: Placement | None = None

    @classmethod
    def _facts_from_meta(
        cls, meta: dict[str, Any], version: int, where: str
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Versions 1-2 kept the facts in ``meta`` (``object``: ``object_report``).

        The controller's name and the payload come from its ``controller`` and
        ``plant`` descriptions, which stay in ``meta``.
        """
        if version >= 3:
            return {}, meta
        rest = dict(meta)
        facts: dict[str, Any] = {}
        for key in ("stopped", "rate_hz", "grasp_schedule", "grasp_events", "task"):
            value = rest.pop(key, None)
            if value is not None:
                facts[key] = value
        if rest.get("object") is not None:
            facts["object_report"] = rest.pop("object")
        placement = rest.pop("placement", None)
        if isinstance(placement, dict):  # without the older key names it repeated
            known = set(Placement.__dataclass_fields__)
            facts["placement"] = {k: v for k, v in placement.items() if k in known}
        schedule = facts.get("grasp_schedule")
        if isinstance(schedule, dict):
            known = set(GraspSchedule.__dataclass_fields__)
            facts["grasp_schedule"] = {k: v for k, v in schedule.items() if k in known}
        controller = rest.get("controller")
        name = controller.get("name") if isinstance(controller, dict) else controller
        if isinstance(name, str):
            facts["controller"] = name
        plant = rest.get("plant")
        payload = plant.get("payload_kg") if isinstance(plant, dict) else None
        if payload is not None:
            facts["payload_kg"] = payload
        return facts, rest

    @property
    def obstacles(self) -> tuple[Obstacle, ...]:
        """The simulated obstacles as :mod:`dexlfd.geometry` shapes."""
        return obstacles_from_arrays(self.obstacle_center, self.obstacle_size, self.obstacle_radius)


def facts_to_v2_meta(rollout: Rollout) -> dict[str, Any]:
    """``rollout.meta`` with its typed facts put back where version 2 held them.

    The inverse of the lifting on load (``object``: the object report; the controller's
    name and the payload inside its ``controller`` and ``plant`` descriptions): for a
    place that holds one ``meta`` table per record, a LeRobot episode's ``dexlfd/meta``.
    """
    meta = dict(rollout.meta)
    for key in ("stopped", "rate_hz", "grasp_schedule", "task", "placement"):
        value = getattr(rollout, key)
        if value is not None:
            meta[key] = to_json(value)
    if rollout.grasp_events:
        meta["grasp_events"] = to_json(rollout.grasp_events)
    if rollout.object_report is not None:
        meta["object"] = to_json(rollout.object_report)
    if rollout.controller is not None:
        gains = meta.get("controller")
        meta["controller"] = (
            {**gains, "name": rollout.controller} if isinstance(gains, dict) else rollout.controller
        )
    if rollout.payload_kg is not None:
        plant = meta.get("plant")
        meta["plant"] = {**(plant if isinstance(plant, dict) else {}),
                         "payload_kg": rollout.payload_kg}  # fmt: skip
    return meta


def save_rollout(path: str | os.PathLike[str], rollout: Rollout) -> Path:
    """Write ``rollout`` to ``path`` atomically."""
    return rollout._save(path)


def load_rollout(path: str | os.PathLike[str]) -> Rollout:
    """Read and check a rollout file; raises :class:`~dexlfd.errors.InvalidFile`."""
    return Rollout._load(path)
