"""Plan file: a time-stamped Cartesian pose + gripper trajectory to execute."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io._npz import ArraySpec
from dexlfd.io._record import Record

__all__ = ["Plan", "load_plan", "save_plan"]


@dataclass(frozen=True, eq=False)
class Plan(Record):
    """An executable end-effector trajectory (contract ``plan``, version 1).

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
    """

    KIND: ClassVar[str] = "plan"
    VERSION: ClassVar[int] = 1
    UNIT_QUATERNIONS: ClassVar[tuple[str, ...]] = ("quaternion",)
    SPECS: ClassVar[dict[str, ArraySpec]] = {
        "t": ArraySpec(("n",), unit="s"),
        "position": ArraySpec(("n", 3), unit="m"),
        "velocity": ArraySpec(("n", 3), unit="m/s"),
        "acceleration": ArraySpec(("n", 3), unit="m/s^2"),
        "quaternion": ArraySpec(("n", 4), unit="x,y,z,w"),
        "angular_velocity": ArraySpec(("n", 3), unit="rad/s"),
        "gripper": ArraySpec(("n",), unit="m"),
    }

    t: FloatArray
    position: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    quaternion: FloatArray
    angular_velocity: FloatArray
    gripper: FloatArray
    meta: dict[str, Any] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)


def save_plan(path: str | os.PathLike[str], plan: Plan) -> Path:
    """Write ``plan`` to ``path`` atomically."""
    return plan._save(path)


def load_plan(path: str | os.PathLike[str]) -> Plan:
    """Read and check a plan file; raises :class:`~dexlfd.errors.InvalidFile`."""
    return Plan._load(path)
