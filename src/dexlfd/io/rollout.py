"""Rollout file: what the robot (simulated or real) did while tracking a plan."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.geometry import Obstacle
from dexlfd.io._npz import ArraySpec
from dexlfd.io._record import Record
from dexlfd.io._world import WORLD_SPECS, obstacles_from_arrays
from dexlfd.panda import N_JOINTS  # the Panda's arm joints

__all__ = ["Rollout", "load_rollout", "save_rollout"]


@dataclass(frozen=True, eq=False)
class Rollout(Record):
    """A tracked trajectory (contract ``rollout``, version 2).

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

    ``meta["stopped"]`` holds the reason when a safety stop cut the rollout
    short; the samples up to the stop are kept.
    """

    KIND: ClassVar[str] = "rollout"
    VERSION: ClassVar[int] = 2
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

    @property
    def obstacles(self) -> tuple[Obstacle, ...]:
        """The simulated obstacles as :mod:`dexlfd.geometry` shapes."""
        return obstacles_from_arrays(self.obstacle_center, self.obstacle_size, self.obstacle_radius)


def save_rollout(path: str | os.PathLike[str], rollout: Rollout) -> Path:
    """Write ``rollout`` to ``path`` atomically."""
    return rollout._save(path)


def load_rollout(path: str | os.PathLike[str]) -> Rollout:
    """Read and check a rollout file; raises :class:`~dexlfd.errors.InvalidFile`."""
    return Rollout._load(path)
