"""Learned-model file: GMR mean and covariance on a time grid plus the GMM."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io._npz import ArraySpec
from dexlfd.io._record import Record

__all__ = ["LearnedModel", "load_model", "save_model"]


@dataclass(frozen=True, eq=False)
class LearnedModel(Record):
    """A learned trajectory with its uncertainty (contract ``model``, version 1).

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
    """

    KIND: ClassVar[str] = "model"
    VERSION: ClassVar[int] = 1
    SPECS: ClassVar[dict[str, ArraySpec]] = {
        "t": ArraySpec(("m",), unit="s"),
        "mean": ArraySpec(("m", 8)),
        "cov": ArraySpec(("m", 8, 8)),
        "gmm_weights": ArraySpec(("K",)),
        "gmm_means": ArraySpec(("K", 9)),
        "gmm_covs": ArraySpec(("K", 9, 9)),
    }

    t: FloatArray
    mean: FloatArray
    cov: FloatArray
    gmm_weights: FloatArray
    gmm_means: FloatArray
    gmm_covs: FloatArray
    meta: dict[str, Any] = field(default_factory=dict)
    extras: dict[str, np.ndarray] = field(default_factory=dict)


def save_model(path: str | os.PathLike[str], model: LearnedModel) -> Path:
    """Write ``model`` to ``path`` atomically."""
    return model._save(path)


def load_model(path: str | os.PathLike[str]) -> LearnedModel:
    """Read and check a learned-model file; raises :class:`~dexlfd.errors.InvalidFile`."""
    return LearnedModel._load(path)
