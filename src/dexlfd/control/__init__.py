"""Controllers (Eqs. 5.8–5.26 and robust variants) and the one 1 kHz loop, on any arm."""

from __future__ import annotations

from dexlfd.control.arm_loop import ArmLoop, TrackingStopped
from dexlfd.control.base import (
    Controller,
    Reference,
    RobotState,
    nullspace_torque,
    orientation_error,
    saturate,
)
from dexlfd.control.franka import run_controller, track_franka
from dexlfd.control.impedance import Impedance
from dexlfd.control.loop import track
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.observer import DisturbanceObserver
from dexlfd.control.pd import CartesianPd, JointPd
from dexlfd.control.reference import (
    ReferenceTrajectory,
    check_plan_workspace,
    joint_reference,
    resample_plan,
)
from dexlfd.control.registry import CONTROLLERS, make_controller
from dexlfd.control.rollout_report import tracking_summary
from dexlfd.control.segment import ReferenceSegment
from dexlfd.control.session import TrackingSession
from dexlfd.control.sliding_mode import NtsmPd, NtsmPdI, SmPd, sig
from dexlfd.control.sliding_mode_joint import JointSlidingMode

# approach_plan is plan.moves.approach_plan, re-exported because callers and
# tests/control/test_moves.py import it from control; new code imports it from plan.moves
from dexlfd.plan.moves import approach_plan

__all__ = [
    "CONTROLLERS",
    "ArmLoop",
    "CartesianPd",
    "Controller",
    "DisturbanceObserver",
    "Impedance",
    "JointPd",
    "JointSlidingMode",
    "LoopConfig",
    "NtsmPd",
    "NtsmPdI",
    "Reference",
    "ReferenceSegment",
    "ReferenceTrajectory",
    "RobotState",
    "SmPd",
    "TrackingSession",
    "TrackingStopped",
    "approach_plan",
    "check_plan_workspace",
    "joint_reference",
    "make_controller",
    "nullspace_torque",
    "orientation_error",
    "resample_plan",
    "run_controller",
    "saturate",
    "sig",
    "track",
    "track_franka",
    "tracking_summary",
]
