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

from typing import TYPE_CHECKING

from dexlfd._lazy import lazy_package

if TYPE_CHECKING:  # the names below are imported on first use (``__getattr__``)
    from dexlfd.geometry import Box, Obstacle, Sphere, signed_distance
    from dexlfd.intervals import grasp_intervals
    from dexlfd.plan.config import PlanConfig
    from dexlfd.plan.dmp import Dmp, DmpRollout, fit_dmp
    from dexlfd.plan.dmp_config import DmpConfig
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

# name -> the module it comes from: a submodule (and numba, SciPy) is imported when one
# of its names is first used, so ``dexlfd plan --help`` (which reads PlanConfig's flags)
# imports neither
_EXPORTS = {
    "Box": "dexlfd.geometry",
    "Dmp": "dexlfd.plan.dmp",
    "DmpConfig": "dexlfd.plan.dmp_config",
    "DmpRollout": "dexlfd.plan.dmp",
    "GraspScheduleConfig": "dexlfd.plan.grasp_schedule",
    "LimitReport": "dexlfd.plan.limits",
    "Obstacle": "dexlfd.geometry",
    "PlaceCorrection": "dexlfd.plan.place",
    "PlaceTiming": "dexlfd.plan.place",
    "PlanConfig": "dexlfd.plan.config",
    "QuaternionDmp": "dexlfd.plan.quaternion_dmp",
    "QuaternionRollout": "dexlfd.plan.quaternion_dmp",
    "Sphere": "dexlfd.geometry",
    "TeleopConfig": "dexlfd.plan.teleop",
    "TeleopState": "dexlfd.plan.teleop",
    "TeleopTarget": "dexlfd.plan.teleop",
    "basis_functions": "dexlfd.plan.forcing",
    "check_cartesian_limits": "dexlfd.plan.limits",
    "check_model_covariance": "dexlfd.plan.planner",
    "coupling_response": "dexlfd.plan.dmp_rollout",
    "fit_dmp": "dexlfd.plan.dmp",
    "fit_quaternion_dmp": "dexlfd.plan.quaternion_dmp",
    "forcing": "dexlfd.plan.forcing",
    "grasp_intervals": "dexlfd.intervals",
    "grasp_schedule": "dexlfd.plan.grasp_schedule",
    "intrusion": "dexlfd.plan.obstacles",
    "phase": "dexlfd.plan.forcing",
    "place_correction": "dexlfd.plan.place",
    "plan_from_model": "dexlfd.plan.pipeline",
    "release_index": "dexlfd.plan.place",
    "rollout_dmp": "dexlfd.plan.dmp_rollout",
    "rollout_quaternion_dmp": "dexlfd.plan.quaternion_dmp",
    "signed_distance": "dexlfd.geometry",
    "teleop_init": "dexlfd.plan.teleop",
    "teleop_step": "dexlfd.plan.teleop",
    "variance_level": "dexlfd.plan.obstacles",
    "variance_weight": "dexlfd.plan.obstacles",
}


__getattr__, __dir__ = lazy_package(__name__, _EXPORTS)

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
