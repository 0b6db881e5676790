"""File contracts between the stages (docs/file-formats.md): versioned ``.npz``, atomic writes."""

from __future__ import annotations

from dexlfd.io._atomic import atomic_write
from dexlfd.io.demonstration import Demonstration, load_demonstration, save_demonstration
from dexlfd.io.model import LearnedModel, load_model, save_model
from dexlfd.io.plan import Plan, load_plan, save_plan
from dexlfd.io.rollout import Rollout, load_rollout, save_rollout

__all__ = [
    "Demonstration",
    "LearnedModel",
    "Plan",
    "Rollout",
    "atomic_write",
    "load_demonstration",
    "load_model",
    "load_plan",
    "load_rollout",
    "save_demonstration",
    "save_model",
    "save_plan",
    "save_rollout",
]
