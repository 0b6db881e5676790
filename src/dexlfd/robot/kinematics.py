"""Forward kinematics of the Panda from the thesis's DH table: :mod:`dexlfd.panda_kinematics`.

The pure kinematics live in that leaf module (the planner uses them too, and may
not import :mod:`dexlfd.robot`); the robot re-exports them.
"""

from __future__ import annotations

from dexlfd.panda_kinematics import DhPanda, dh_flange, dh_tcp

__all__ = ["DhPanda", "dh_flange", "dh_tcp"]
