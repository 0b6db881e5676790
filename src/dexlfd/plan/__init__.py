"""Planning with dynamic movement primitives (thesis Section 5.1).

Modified DMP (Eq. 5.5, published decoupled form: ``dmp``, ``forcing``, ``dmp_rollout``),
quaternion DMP for orientation, obstacles with the variance-aware Gams coupling
(Eqs. 5.6-5.7: ``obstacles``, ``coupling``, ``clearance``), end shaping, placing, and
:func:`plan_from_model` (``planner``, settings in ``config``), which turns a learned
model into a :class:`dexlfd.io.Plan`. ``teleop`` shapes live hand poses into targets.

Example
-------
>>> from dexlfd.plan import Box, PlanConfig, plan_from_model  # doctest: +SKIP
>>> plan = plan_from_model(model, PlanConfig(goal=(0.5, 0.2, 0.3),
...                        obstacles=(Box((0.45, 0.0, 0.2), (0.1, 0.1, 0.4)),)))
"""

from __future__ import annotations

from dexlfd.geometry import Box, Obstacle, Sphere, signed_distance
from dexlfd.intervals import grasp_intervals
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.dmp import Dmp, DmpConfig, DmpRollout, fit_dmp
from dexlfd.plan.dmp_rollout import coupling_response, rollout_dmp
from dexlfd.plan.forcing import basis_functions, forcing, phase
from dexlfd.plan.grasp_schedule import GraspScheduleConfig, grasp_schedule
from dexlfd.plan.limits import (
    LimitReport,
    check_cartesian_limits,
)
from dexlfd.plan.obstacles import intrusion, variance_level, variance_weight
from dexlfd.plan.pipeline import plan_from_model
from dexlfd.plan.place import PlaceCorrection, PlaceTiming, place_correction, release_index
from dexlfd.plan.planner import check_model_covariance
from dexlfd.plan.quaternion_dmp import (
    QuaternionDmp,
    QuaternionRollout,
    fit_quaternion_dmp,
    rollout_quaternion_dmp,
)
from dexlfd.plan.teleop import (
    TeleopConfig,
    TeleopState,
    TeleopTarget,
    teleop_init,
    teleop_step,
)

__all__ = [
    "Box",
    "Dmp",
    "DmpConfig",
    "DmpRollout",
    "GraspScheduleConfig",
    "LimitReport",
    "Obstacle",
    "PlaceCorrection",
    "PlaceTiming",
    "PlanConfig",
    "QuaternionDmp",
    "QuaternionRollout",
    "Sphere",
    "TeleopConfig",
    "TeleopState",
    "TeleopTarget",
    "basis_functions",
    "check_cartesian_limits",
    "check_model_covariance",
    "coupling_response",
    "fit_dmp",
    "fit_quaternion_dmp",
    "forcing",
    "grasp_intervals",
    "grasp_schedule",
    "intrusion",
    "phase",
    "place_correction",
    "plan_from_model",
    "release_index",
    "rollout_dmp",
    "rollout_quaternion_dmp",
    "signed_distance",
    "teleop_init",
    "teleop_step",
    "variance_level",
    "variance_weight",
]
