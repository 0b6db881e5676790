"""The Panda: its constants, model terms, kinematics, friction and the MuJoCo plant."""

from __future__ import annotations

from dexlfd.robot.friction import friction_torque
from dexlfd.robot.ik import IkResult, rotation_error, solve_ik
from dexlfd.robot.kinematics import dh_flange, dh_tcp
from dexlfd.robot.model import ModelTerms, MujocoPandaModel, RobotModel, perturbed_model
from dexlfd.robot.sim import (
    Obstacle,
    PandaSim,
    PlantConfig,
    SimState,
    plan_world,
)

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
