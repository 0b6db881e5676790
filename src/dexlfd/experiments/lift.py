"""The control studies' lift plan; it lives in :mod:`dexlfd.plan.moves` (re-exported here)."""

from __future__ import annotations

from dexlfd.plan.moves import GRIPPER_DOWN_XYZW, lift_plan

__all__ = ["GRIPPER_DOWN_XYZW", "lift_plan"]
