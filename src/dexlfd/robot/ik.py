"""Damped least-squares inverse kinematics for the TCP pose: :mod:`dexlfd.panda_ik`.

Pure NumPy, in that leaf module (the planner solves it too, and may not import
:mod:`dexlfd.robot`); the robot re-exports it.
"""

from __future__ import annotations

from dexlfd.panda_ik import IkResult, KinematicModel, rotation_error, solve_ik

__all__ = ["IkResult", "KinematicModel", "rotation_error", "solve_ik"]
