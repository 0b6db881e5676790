"""Learned-model file: GMR mean and covariance on a time grid plus the GMM."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io._npz import ArraySpec
from dexlfd.io._record import Record
from dexlfd.io.model_facts import GraspEventsFound

__all__ = ["LearnedModel", "load_model", "save_model"]


@dataclass(frozen=True, eq=False)
class LearnedModel(Record):
    """A learned trajectory with its uncertainty (contract ``model``, version 3).

    Attributes
    ----------
    t : ndarray, shape (m,)
        Query times [s].
    mean : ndarray, shape (m, 8)
        GMR mean: position [m], unit quaternion (x, y, z, w), gripper [m].
    cov : ndarray, shape (m, 8, 8)
        GMR conditional covariance Σ(t) (Eq. 4.19), SI units squared.
    gmm_weights : ndarray, shape (K,)
        Mixture weights, sum 1.
    gmm_means : ndarray, shape (K, 9)
        Component means; column 0 is time [s].
    gmm_covs : ndarray, shape (K, 9, 9)
        Component covariances.
    event_t : ndarray, shape (2,), optional
        Model time [s] of the demonstrations' grasp (the hand closes on the object)
        and release (it opens), each demonstration's event put on the model's clock
        by its DTW alignment and averaged (version 2).
    event_t_std : ndarray, shape (2,), optional
        Their spread across the demonstrations [s].
    event_position : ndarray, shape (2, 3), optional
        Mean TCP position [m] at the grasp (the pick) and at the release (the place).
    event_quaternion : ndarray, shape (2, 4), optional
        Mean TCP orientation there (unit, x, y, z, w).
    event_cov : ndarray, shape (2, 6, 6), optional
        Covariance across the demonstrations of position [m²] and orientation (the
        rotation vector from the mean, base frame) [rad²].
    event_count : ndarray of int, shape (2,), optional
        How many demonstrations had the event.

    A model without the event arrays (a version-1 file, or demonstrations without a
    grasp) plans as the motion alone.

    Typed facts (version 3; an older file's are lifted out of its ``meta``):

    frame : str
        The demonstrations' frame (``"panda_base"``; ``"camera..."`` cannot be planned).
    outliers : tuple of str
        The demonstrations flagged as outliers by their DTW distance.
    grasp_events : GraspEventsFound or None
        What was found per demonstration (:mod:`dexlfd.io.model_facts`).

    ``meta`` keeps provenance: the settings, the demonstrations, the method.
    """

    KIND: ClassVar[str] = "model"
    VERSION: ClassVar[int] = 3
    FACTS: ClassVar[tuple[str, ...]] = ("frame", "outliers", "grasp_events")
    SPECS: ClassVar[dict[str, ArraySpec]] = {
        "t": ArraySpec(("m",), unit="s"),
        "mean": ArraySpec(("m", 8)),
        "cov": ArraySpec(("m", 8, 8)),
        "gmm_weights": ArraySpec(("K",)),
        "gmm_means": ArraySpec(("K", 9)),
        "gmm_covs": ArraySpec(("K", 9, 9)),
        "event_t": ArraySpec((2,), unit="s", required=False),
        "event_t_std": ArraySpec((2,), unit="s", required=False),
        "event_position": ArraySpec((2, 3), unit="m", required=False),
        "event_quaternion": ArraySpec((2, 4), unit="x,y,z,w", required=False),
        "event_cov": ArraySpec((2, 6, 6), required=False),
        "event_count": ArraySpec((2,), kind="i", required=False),
    }
    EVENTS: ClassVar[tuple[str, ...]] = (
        "event_t", "event_t_std", "event_position", "event_quaternion", "event_cov",
        "event_count",
    )  # fmt: skip

    t: FloatArray
    mean: FloatArray
    cov: FloatArray
    gmm_weights: FloatArray
    gmm_means: FloatArray
    gmm_covs: FloatArray
    event_t: FloatArray | None = None
    event_t_std: FloatArray | None = None
    event_position: FloatArray | None = None
    event_quaternion: FloatArray | None = None
    event_cov: FloatArray | None = None
    event_count: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    frame: str = "panda_base"
    outliers: tuple[str, ...] = ()
    grasp_events: GraspEventsFound | None = None

    @classmethod
    def _facts_from_meta(
        cls, meta: dict[str, Any], version: int, where: str
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Versions 1-2 kept the facts in ``meta`` under the same names."""
        if version >= 3:
            return {}, meta
        rest = dict(meta)
        facts = {k: rest.pop(k) for k in cls.FACTS if rest.get(k) is not None}
        return facts, rest

    def __post_init__(self) -> None:
        super().__post_init__()
        given = [n for n in self.EVENTS if getattr(self, n) is not None]
        if given and len(given) != len(self.EVENTS):
            missing = sorted(set(self.EVENTS) - set(given))
            raise InvalidInput(f"LearnedModel: event arrays come together; missing {missing}")
        if given:
            q = np.asarray(self.event_quaternion)
            if not np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6):
                raise InvalidInput("LearnedModel.event_quaternion must be unit quaternions")
            t = np.asarray(self.event_t)
            if not (self.t[0] <= t[0] < t[1] <= self.t[-1]):
                raise InvalidInput(
                    f"LearnedModel.event_t must be grasp < release within the model's "
                    f"{self.t[0]:g}..{self.t[-1]:g} s, got {t.tolist()}"
                )

    @property
    def has_events(self) -> bool:
        """Whether the model carries the demonstrations' grasp and release."""
        return self.event_t is not None


def save_model(path: str | os.PathLike[str], model: LearnedModel) -> Path:
    """Write ``model`` to ``path`` atomically."""
    return model._save(path)


def load_model(path: str | os.PathLike[str]) -> LearnedModel:
    """Read and check a learned-model file; raises :class:`~dexlfd.errors.InvalidFile`."""
    return LearnedModel._load(path)
