"""Track a whole plan on the simulated Panda: :func:`track`.

The plan is checked against the workspace, resampled at the control rate
(:mod:`dexlfd.control.reference`) and run through a
:class:`~dexlfd.control.session.TrackingSession`, one tick at a time; see there
for what a tick does and for the safety stop (:class:`TrackingStopped`). The
real-arm counterpart is :func:`dexlfd.control.franka.track_franka`.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.control.base import Controller
from dexlfd.control.grasp import placement_report, plan_grasp_schedule
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.posture_hold import hold_where_planned
from dexlfd.control.reference import (
    ReferenceTrajectory,
    check_plan_workspace,
    joint_reference,
    resample_plan,
)
from dexlfd.control.session import TrackingSession
from dexlfd.errors import InvalidInput
from dexlfd.intervals import longest_run
from dexlfd.io import Plan, Rollout
from dexlfd.io._world import obstacle_arrays, support_arrays
from dexlfd.io.plan_facts import GraspSchedule
from dexlfd.io.rollout_facts import TaskPoses
from dexlfd.panda_ik import solve_ik
from dexlfd.robot.plant import PlantConfig
from dexlfd.robot.robot_model import RobotModel
from dexlfd.robot.sim_arm import substeps
from dexlfd.rotations import matrix_from_quat

__all__ = [
    "SAMPLES_EVERY",
    "track",
]

logger = logging.getLogger(__name__)

SAMPLES_EVERY = 1000  # ticks between two calls of track's ``samples`` (1 s at 1 kHz)


def track(
    plan: Plan,
    controller: Controller,
    model: RobotModel,
    plant: PlantConfig | None = None,
    loop: LoopConfig | None = None,
    *,
    rng: np.random.Generator,
    q0: FloatArray | None = None,
    callback: Callable[[int, float], None] | None = None,
    samples: Callable[[dict[str, np.ndarray]], None] | None = None,
) -> Rollout:
    """Track ``plan`` with ``controller`` on the simulated Panda.

    Runs the plan, resampled at the control rate, through a
    :class:`TrackingSession` one tick at a time; the arm's own posture is held where
    the plan says (``arm_posture.hold_s``, :mod:`dexlfd.control.posture_hold`).

    Parameters
    ----------
    plan : Plan
        TCP trajectory; resampled to the control rate.
    controller : Controller
        Control law (see :mod:`dexlfd.control.base`).
    model : RobotModel
        The controller's (nominal) model; the plant is built from ``plant``.
    plant : PlantConfig, optional
        The simulated world (payload, friction, contacts); default: no object.
    loop : LoopConfig, optional
        Rate, sensing noise, torque delay and safety bounds.
    rng : numpy.random.Generator
        Source of the measurement noise.
    q0 : ndarray, shape (7,), optional
        Initial joints [rad]; default: IK to the plan's first pose.
    callback : callable, optional
        Called as ``callback(tick, t)`` every 100 ticks.
    samples : callable, optional
        Called as ``samples(rows)`` every :data:`SAMPLES_EVERY` ticks with the rows
        recorded so far (:meth:`TrackingSession.samples`: views, valid during the
        call): the rollout as it is simulated, for a video rendered meanwhile.

    Returns
    -------
    Rollout
        One sample per control tick; ``meta`` records controller, gains, plant,
        loop settings and ``stopped`` (None when the plan was completed).

    Raises
    ------
    InvalidInput
        The plan leaves the workspace or its first pose has no IK solution.
    TrackingStopped
        The safety stop fired (rollout so far in ``exc.rollout``).
    """
    plant = plant or PlantConfig()
    loop = loop or LoopConfig()
    if not isinstance(plan, Plan):
        raise InvalidInput(f"plan must be a dexlfd.io.Plan, got {type(plan).__name__}")
    plant = _task_world(plan, plant)
    check_plan_workspace(plan)
    dt = 1.0 / loop.rate_hz
    substeps(dt, plant.timestep)
    ref = resample_plan(plan, dt)
    q0 = _start_joints(model, ref) if q0 is None else q0
    q_ref = dq_ref = None
    if controller.needs_joint_reference:
        q_ref, dq_ref = joint_reference(model, ref, q0)
    n = ref.n
    closed, carried, schedule = _grasp_schedule(plan, ref, loop)
    # open phases open to the plan's open level: a hand half-closed on the way to
    # the object (a learned channel) must not sweep the object off its pedestal
    open_level = ref.gripper if schedule.open_level is None else schedule.open_level
    opening = np.where(closed, ref.gripper, open_level)
    controller = hold_where_planned(controller, plan)
    session = TrackingSession(
        controller, model, plant, loop, rng=rng, q0=q0, gripper0=float(opening[0]),
        payload_at=_payload_pose(plan, ref, carried, plant),
        meta={"plan_meta": plan.meta},
        facts={"grasp_schedule": schedule, "task": _task_poses(plan)},
        noise_block=n, capacity=n,
    )  # fmt: skip
    with session:
        _run(session, ref, (q_ref, dq_ref), opening, carried, callback, samples)
    rollout = session.rollout()
    rollout = dataclasses.replace(
        rollout, grasp=closed[: rollout.n_samples],
        **obstacle_arrays(plan.obstacles), **support_arrays(plan.supports),
    )  # fmt: skip
    if plant.payload_kg > 0 and plan.place_pose is not None:
        placement = placement_report(rollout)
        rollout = dataclasses.replace(rollout, placement=placement)
        logger.info(
            "placement: %s (carried %s, %.1f mm from the place, tilt %.1f deg, set down at "
            "%.3f m/s)", "ok" if placement.ok else placement.failure,
            placement.carried, 1e3 * _or_nan(placement.error_m),
            placement.tilt_deg, _or_nan(placement.set_down_speed_mps),
        )  # fmt: skip
    return rollout


def _run(
    session: TrackingSession, ref: ReferenceTrajectory, joint_ref: tuple[Any, Any],
    opening: FloatArray, carried: BoolArray, callback: Callable[[int, float], None] | None,
    samples: Callable[[dict[str, np.ndarray]], None] | None,
) -> None:  # fmt: skip
    """:func:`track`'s ticks: the reference one tick at a time, the watchers told."""
    q_ref, dq_ref = joint_ref
    watched = callback is not None or samples is not None
    for k in range(ref.n):
        session.step(
            ref.reference(k, q_ref, dq_ref), float(opening[k]), ref.quat[k], bool(carried[k])
        )
        if watched and k % 50 == 0:  # one test a tick when nobody watches
            if callback is not None and k % 100 == 0:
                callback(k, ref.t[k])
            if samples is not None and k % SAMPLES_EVERY == 0:
                samples(session.samples())


def _or_nan(value: float | None) -> float:
    """``value``, or NaN where the report has none (printed as ``nan``)."""
    return float("nan") if value is None else float(value)


def _task_world(plan: Plan, plant: PlantConfig) -> PlantConfig:
    """The plant with the plan's task world: its supports (and no own pedestal).

    The object stands on the plan's support under the pick (the plan kept it clear
    of every obstacle) and is set down on the one under the place; supports the
    caller's plant already holds are not added twice.
    """
    if plan.pick_pose is None:
        return plant
    missing = tuple(s for s in plan.supports if s not in plant.obstacles)
    return dataclasses.replace(plant, obstacles=(*plant.obstacles, *missing), pedestal=False)


def _task_poses(plan: Plan) -> TaskPoses | None:
    """The plan's pick and place poses for the rollout's ``task`` (None: no task)."""
    if plan.pick_pose is None or plan.place_pose is None:
        return None
    return TaskPoses(
        pick_pose=tuple(float(v) for v in plan.pick_pose),  # type: ignore[arg-type]
        place_pose=tuple(float(v) for v in plan.place_pose),  # type: ignore[arg-type]
    )


def _start_joints(model: RobotModel, ref: ReferenceTrajectory) -> FloatArray:
    """IK joints [rad] at the reference's first pose; raises when there is none.

    Solved from the plan's planned posture, when it has one.
    """
    ik = solve_ik(model, ref.p[0], ref.R[0], None if ref.q_null is None else ref.q_null[0])
    if not ik.converged:
        raise InvalidInput(
            f"no inverse-kinematics solution for the plan's first pose "
            f"{np.round(ref.p[0], 3).tolist()} m (residual {ik.position_error:.2e} m, "
            f"{ik.rotation_error:.2e} rad)"
        )
    return ik.q


def _grasp_schedule(
    plan: Plan, ref: ReferenceTrajectory, loop: LoopConfig
) -> tuple[BoolArray, BoolArray, GraspSchedule]:
    """The plan's grasp schedule on the control grid, and its main grasp.

    Returns the closed flags (the gripper's schedule), the flags of the main (longest)
    closed run only (when the object is grasped and carried,
    :func:`~dexlfd.intervals.longest_run`) and the schedule (for the rollout's
    ``grasp_schedule``) with ``grasp_t`` [s] and ``grasp_position`` [m] (where
    the main run closes, None if never), ``release_t`` [s] and ``release_position``
    [m] (where it opens again; the plan's end if it never does).
    """
    closed_plan, info = plan_grasp_schedule(plan)
    k_plan = np.searchsorted(plan.t - plan.t[0], ref.t + 1e-9, side="right") - 1
    closed = closed_plan[np.clip(k_plan, 0, closed_plan.shape[0] - 1)]
    carried = np.zeros_like(closed)
    info = dataclasses.replace(
        info, grasp_t=None, grasp_position=None, release_t=None, release_position=None
    )
    run = longest_run(ref.t, closed)
    if run is not None:
        k0, k1 = run
        carried[k0:k1] = True
        k1 = min(k1, ref.n - 1)
        info = dataclasses.replace(
            info, grasp_t=float(ref.t[k0]), grasp_position=_vec3(ref.p[k0]),
            release_t=float(ref.t[k1]), release_position=_vec3(ref.p[k1]),
        )  # fmt: skip
    return closed, carried, info


def _vec3(p: FloatArray) -> tuple[float, float, float]:
    return (float(p[0]), float(p[1]), float(p[2]))


def _upright(R_tcp: FloatArray) -> FloatArray:
    """The object's rotation at a pick with TCP rotation ``R_tcp``: standing upright.

    The object stands on its support: its z axis vertical (the box's z along the
    TCP's, flipped with it), its y axis (across the fingers) the TCP's y turned
    horizontal. A tilted grasp closes on an upright object, not on one spawned
    tilted on its support (which falls flat and reads as tilted at the end).
    """
    y = np.array([R_tcp[0, 1], R_tcp[1, 1], 0.0])
    if np.linalg.norm(y) < 1e-6:  # the fingers close vertically: keep the TCP's x heading
        x = np.array([R_tcp[0, 0], R_tcp[1, 0], 0.0])
        y = np.cross([0.0, 0.0, np.sign(R_tcp[2, 2]) or -1.0], x / np.linalg.norm(x))
    y /= np.linalg.norm(y)
    z = np.array([0.0, 0.0, -1.0 if R_tcp[2, 2] <= 0 else 1.0])
    return np.asarray(np.column_stack([np.cross(y, z), y, z]), dtype=np.float64)


def _payload_pose(
    plan: Plan, ref: ReferenceTrajectory, closed: BoolArray, plant: PlantConfig
) -> tuple[FloatArray, FloatArray]:
    """TCP pose where the object waits.

    The plan's pick pose, else where the main grasp (``closed``) closes.
    """
    if plan.pick_pose is not None:
        return plan.pick_pose[:3].copy(), _upright(matrix_from_quat(plan.pick_pose[3:]))
    k_grasp = int(np.argmax(closed)) if closed.any() else -1
    if plant.payload_kg > 0 and k_grasp < 0:
        logger.warning("the plan never closes the gripper: the object is not picked up")
    return ref.p[max(k_grasp, 0)], ref.R[max(k_grasp, 0)]
