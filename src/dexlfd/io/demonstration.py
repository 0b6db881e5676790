"""Demonstration file: hand keypoints and the end-effector motion derived from them."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io._npz import ArraySpec, check_arrays
from dexlfd.io._record import Record
from dexlfd.io.demonstration_facts import (
    AppliedFrame,
    Episode,
    Phases,
    Quality,
    RecordingSummary,
    Trim,
)

__all__ = ["Demonstration", "load_demonstration", "save_demonstration"]

N_LANDMARKS = 21


@dataclass(frozen=True, eq=False)
class Demonstration(Record):
    """One demonstration (file contract ``demonstration`` of docs/file-formats.md, version 2).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time [s], strictly increasing.
    keypoints : ndarray, shape (n, 21, 3)
        MediaPipe hand landmarks in the robot base frame [m]; NaN where unseen.
    valid : ndarray, shape (n,)
        True where the hand was seen.
    position : ndarray, shape (n, 3)
        End-effector position [m], base frame; NaN exactly where not ``valid``.
    quaternion : ndarray, shape (n, 4)
        End-effector orientation, unit, scalar-last; NaN where not ``valid``.
    gripper : ndarray, shape (n,)
        Gripper opening [m]; NaN where not ``valid``.
    grasp : ndarray, shape (n,)
        True while grasping.

    Optional arrays (kept in ``extras``, checked when present, see ``OPTIONAL``):
    ``depth_std`` (n,) [m], the camera-depth uncertainty of each frame (the
    whole-recording pose estimate of RGB-only video), NaN exactly where not
    ``valid``, otherwise >= 0; ``orientation_set`` (n,) bool, True where the frame's
    own palm fit set the orientation (False: interpolated between such frames).

    Typed facts (``FACTS``, :mod:`dexlfd.io.demonstration_facts`; None: not known):
    ``frame`` the coordinate frame of the positions, ``task_frame`` the transform
    that moved them there, ``source_frames`` ``[first, stop)`` of the recording
    [frame], ``phases`` the recording's episodes, ``episode`` the pick-and-place this
    one was cut for, ``trim`` the idle frames cut, ``recording`` the whole
    recording's figures, ``quality`` the verdict. ``meta`` keeps provenance and
    free text; a version-1 file's facts are read from its ``meta``.
    """

    KIND: ClassVar[str] = "demonstration"
    VERSION: ClassVar[int] = 2
    MIN_SAMPLES: ClassVar[int] = 1
    UNIT_QUATERNIONS: ClassVar[tuple[str, ...]] = ("quaternion",)
    FACTS: ClassVar[tuple[str, ...]] = (
        "frame", "task_frame", "source_frames", "phases", "episode", "trim", "recording",
        "quality",
    )  # fmt: skip
    SPECS: ClassVar[dict[str, ArraySpec]] = {
        "t": ArraySpec(("n",), unit="s"),
        "keypoints": ArraySpec(("n", N_LANDMARKS, 3), nan="any", unit="m"),
        "valid": ArraySpec(("n",), kind="b"),
        "position": ArraySpec(("n", 3), nan="invalid", unit="m"),
        "quaternion": ArraySpec(("n", 4), nan="invalid", unit="x,y,z,w"),
        "gripper": ArraySpec(("n",), nan="invalid", unit="m"),
        "grasp": ArraySpec(("n",), kind="b"),
    }

    # optional arrays of the contract: in ``extras`` when present, checked like SPECS
    OPTIONAL: ClassVar[dict[str, ArraySpec]] = {
        "depth_std": ArraySpec(("n",), nan="invalid", unit="m", required=False),
        "orientation_set": ArraySpec(("n",), kind="b", required=False),
    }

    t: FloatArray
    keypoints: FloatArray
    valid: BoolArray
    position: FloatArray
    quaternion: FloatArray
    gripper: FloatArray
    grasp: BoolArray
    meta: dict[str, Any] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    frame: str | None = None
    task_frame: AppliedFrame | None = None
    source_frames: tuple[int, int] | None = field(default=None, metadata={"unit": "frame"})
    phases: Phases | None = None
    episode: Episode | None = None
    trim: Trim | None = None
    recording: RecordingSummary | None = None
    quality: Quality | None = None

    @classmethod
    def _facts_from_meta(
        cls, meta: dict[str, Any], version: int, where: str
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """A version-1 file's facts, lifted out of its ``meta`` (see ``FACTS``)."""
        if version >= 2:
            return {}, meta
        from dexlfd.io._demonstration_v1 import facts_from_v1_meta

        return facts_from_v1_meta(meta)

    def __post_init__(self) -> None:
        super().__post_init__()
        present = {k: self.extras[k] for k in self.OPTIONAL if k in self.extras}
        if not present:
            return
        specs = {"t": self.SPECS["t"], "valid": self.SPECS["valid"], **self.OPTIONAL}
        checked = check_arrays(
            {"t": self.t, "valid": self.valid, **present}, specs, "Demonstration", InvalidInput
        )
        std = checked.get("depth_std")
        if std is not None and (std[self.valid] < 0).any():
            raise InvalidInput("Demonstration: array 'depth_std' must be >= 0 where valid")
        extras = dict(self.extras)
        for k in present:
            extras[k] = checked[k]
        object.__setattr__(self, "extras", extras)

    @property
    def depth_std(self) -> FloatArray | None:
        """Per-frame depth uncertainty [m] (``extras["depth_std"]``), None if absent."""
        return self.extras.get("depth_std")

    @property
    def pose(self) -> FloatArray:
        """The 8 learning channels ``(n, 8)``: position, quaternion, gripper."""
        return np.concatenate([self.position, self.quaternion, self.gripper[:, None]], axis=1)


def save_demonstration(path: str | os.PathLike[str], demo: Demonstration) -> Path:
    """Write ``demo`` to ``path`` atomically."""
    return demo._save(path)


def load_demonstration(path: str | os.PathLike[str]) -> Demonstration:
    """Read and check a demonstration file; raises :class:`~dexlfd.errors.InvalidFile`."""
    return Demonstration._load(path)
