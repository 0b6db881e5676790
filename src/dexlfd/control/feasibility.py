"""Moved to :mod:`dexlfd.plan.feasibility` (planning is feasible by construction there)."""

from __future__ import annotations

from dexlfd.plan.feasibility import JOINT_MARGIN, joint_profile, make_feasible

__all__ = ["JOINT_MARGIN", "joint_profile", "make_feasible"]
