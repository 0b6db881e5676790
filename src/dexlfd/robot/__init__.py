"""The Panda: its constants, model terms, kinematics, friction and the MuJoCo plant."""

from __future__ import annotations

from dexlfd.geometry import Obstacle
from dexlfd.panda_ik import IkResult, rotation_error, solve_ik
from dexlfd.panda_kinematics import dh_flange, dh_tcp
from dexlfd.robot.friction import friction_torque
from dexlfd.robot.plant import PlantConfig, plan_world
from dexlfd.robot.robot_model import ModelTerms, MujocoPandaModel, RobotModel, perturbed_model
from dexlfd.robot.sim import PandaSim, SimState

__all__ = [
    "IkResult",
    "ModelTerms",
    "MujocoPandaModel",
    "Obstacle",
    "plan_world",
    "PandaSim",
    "PlantConfig",
    "RobotModel",
    "SimState",
    "dh_flange",
    "dh_tcp",
    "friction_torque",
    "perturbed_model",
    "rotation_error",
    "solve_ik",
]
