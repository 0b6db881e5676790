"""From a learned model to a plan the Panda can follow: :func:`plan_from_model`.

A model with the demonstrations' grasp events is planned as a pick-and-place task
(:func:`dexlfd.plan.task.plan_task`), one without as one motion
(:func:`dexlfd.plan.planner.plan_motion`); then (``PlanConfig.feasible``: by
default for a pick-and-place, and for one motion with ``on_limit="scale"``) the
plan is slowed where the Panda's joint limits need it
(:func:`dexlfd.plan.feasibility.make_feasible`) and ``Plan.time_scaling`` lists
every slow-down: the Cartesian ones of the task's parts and the joint-space ones,
each with its factor, the interval it applies to and the duration it added.

Last, when there are obstacles and the caller gives an arm posture planner (the
robot's, :func:`dexlfd.robot.arm_posture.plan_arm_posture`: ``dexlfd plan``,
``teach`` and ``demo`` all pass it), the arm's links are kept clear too: the planner
picks the elbow posture along the plan (``Plan.joint_posture``, ``Plan.arm_posture``)
with the same kinematics model. The planner is passed in, so this package needs
nothing of the robot's simulation; without obstacles the step is skipped and the
plan is the same, array for array.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from typing import Protocol

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Obstacle
from dexlfd.io import LearnedModel, Plan
from dexlfd.io.plan_facts import Feasibility, TimeScaling
from dexlfd.panda_ik import KinematicModel
from dexlfd.panda_kinematics import DhPanda
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.feasibility import make_feasible
from dexlfd.plan.planner import _read_model, plan_motion
from dexlfd.plan.task import MIN_PICK_PLACE, plan_task

__all__ = [
    "PHASE_ARM_POSTURE",
    "PHASE_PLAN",
    "PHASE_TIME_SCALING",
    "ArmPosturePlanner",
    "plan_from_model",
]

logger = logging.getLogger(__name__)

PHASE_PLAN = "plan the motion"  # the phases :func:`plan_from_model` reports
PHASE_TIME_SCALING = "time scaling"
PHASE_ARM_POSTURE = "arm posture"


class ArmPosturePlanner(Protocol):
    """Keeps the arm's links ``margin`` [m] off ``obstacles`` along ``plan``.

    ``qs`` is the plan's inverse kinematics with ``model`` (the kinematics the plan was
    made feasible with): times (m,) [s] and joints (m, 7) [rad] at
    :data:`dexlfd.plan.arm_room.ARM_RATE_HZ`, computed here, so the robot's side needs
    nothing of the planner. Returns ``plan`` with its planned posture
    (``joint_posture``, ``arm_posture``), or with ``arm_posture.planned`` false where
    none keeps them out.
    """

    def __call__(
        self, plan: Plan, obstacles: tuple[Obstacle, ...], margin: float,
        qs: tuple[FloatArray, FloatArray], model: KinematicModel,
    ) -> Plan:  # fmt: skip
        """``plan`` with the arm's posture chosen (see the class)."""
        ...


def plan_from_model(
    model: LearnedModel,
    config: PlanConfig | None = None,
    kinematics: KinematicModel | None = None,
    on_phase: Callable[[str], None] | None = None,
    arm: ArmPosturePlanner | None = None,
) -> Plan:
    """Plan from a learned model: a pick-and-place task, or one motion, made feasible.

    A model with the demonstrations' grasp events (``model.has_events``) is planned
    as reach, carry and retreat through the pick and place poses
    (:func:`dexlfd.plan.task.plan_task`), unless ``config.task == "motion"``; a model
    without events as one motion (:func:`~dexlfd.plan.planner.plan_motion`; a pick or
    place given is then ignored, with a warning that says why). With
    ``config.feasible`` the plan is then slowed where the Panda's joint limits need it,
    with the inverse kinematics of ``kinematics`` (the caller's robot model, e.g. the
    MuJoCo Panda; default Table 3.1's, :class:`dexlfd.panda_kinematics.DhPanda`).
    ``on_phase(name)`` is called as each phase starts (a progress bar): "plan the
    motion" then, when the plan is made feasible, "time scaling", then, with ``arm``
    and obstacles, "arm posture": ``arm`` keeps the arm's links clear of
    ``config.obstacles`` by ``config.margin`` (:class:`ArmPosturePlanner`, with
    ``kinematics``; without obstacles it is not called), and where no elbow posture
    keeps a link out of an obstacle the hand's path is re-planned round it widened
    (:func:`dexlfd.plan.arm_room.keep_links_clear`).
    """
    cfg = config or PlanConfig()
    phase = on_phase or (lambda name: None)
    if not isinstance(model, LearnedModel):
        raise InvalidInput(f"model must be a dexlfd.io.LearnedModel, got {type(model).__name__}")
    if arm is None or not cfg.obstacles:
        return _plan_hand(model, cfg, kinematics, phase)
    from dexlfd.plan.arm_room import keep_links_clear

    calls: list[PlanConfig] = []

    def hand(c: PlanConfig) -> Plan:
        """The hand's plan for ``c``: the phases reported once, on the first."""
        first = not calls
        calls.append(c)
        plan = _plan_hand(model, c, kinematics, phase if first else (lambda name: None))
        if first:
            phase(PHASE_ARM_POSTURE)
        return plan

    return keep_links_clear(hand, cfg, arm, kinematics or DhPanda())


def _plan_hand(
    model: LearnedModel, cfg: PlanConfig, kinematics: KinematicModel | None,
    phase: Callable[[str], None],
) -> Plan:  # fmt: skip
    """The hand's plan: a task or one motion, made feasible when ``cfg`` says so."""
    phase(PHASE_PLAN)
    if model.has_events and cfg.task == "auto":
        if cfg.pick is None and cfg.place is None and _carries_nothing(model):
            assert model.event_position is not None
            apart = float(np.linalg.norm(model.event_position[1] - model.event_position[0]))
            logger.warning(
                "the demonstrations close and open the hand %.3f m apart (under %g m): "
                "nothing is carried, so the model is planned as one motion (give a pick "
                "and a place to plan a pick-and-place)",
                apart, MIN_PICK_PLACE,
            )  # fmt: skip
            plan = plan_motion(model, cfg)
        else:
            _read_model(model)  # the same checks as a motion plan, before cutting it
            plan = plan_task(model, cfg)
    else:
        if not model.has_events and (cfg.pick is not None or cfg.place is not None):
            logger.warning(
                "the model has no grasp events (learned from demonstrations without a "
                "grasp, or by an older dexlfd): pick and place are ignored, planned as "
                "one motion"
            )
        plan = plan_motion(model, cfg)
    feasible = cfg.feasible
    if feasible is None:
        feasible = plan.pick_pose is not None or cfg.on_limit == "scale"
    if not feasible:
        return _account(plan, None)
    phase(PHASE_TIME_SCALING)
    return _feasible(plan, kinematics)


def _carries_nothing(model: LearnedModel) -> bool:
    """True when the demonstrated grasp and release are closer than a pick-and-place needs."""
    assert model.event_position is not None
    return bool(np.linalg.norm(model.event_position[1] - model.event_position[0]) < MIN_PICK_PLACE)


def _feasible(plan: Plan, kinematics: KinematicModel | None) -> Plan:
    """The plan slowed where the Panda's joint or Cartesian limits need it (said how much)."""
    plan, report = make_feasible(plan, kinematics)
    if report.needed:
        worst = max(report.stretches, key=lambda d: d.factor)
        logger.warning(
            "time scaling: %d slow-down(s) to meet the Panda's joint limits, at most %.2fx "
            "(%s at %.2f-%.2f s): +%.2f s, the plan lasts %.2f s instead of %.2f s",
            len(report.stretches), report.largest, worst.limit, *worst.t_s,
            report.added_s, report.duration_s, report.duration_before_s,
        )  # fmt: skip
    return _account(plan, report)


def _account(plan: Plan, joint: Feasibility | None) -> Plan:
    """``Plan.time_scaling``: every slow-down and the plan's total growth.

    ``slowdowns``: the Cartesian ones of a task's parts (``stage`` "cartesian",
    ``part``, ``t_s`` the part's interval in the task before the joint-space
    scaling, ``factor``, ``added_s``) then the joint-space ones (``stage`` "joint");
    ``added_s`` their sum; ``duration_unscaled_s`` the plan without any slow-down;
    ``duration_s`` the plan's (their difference is ``added_s``).
    """
    ts = plan.time_scaling or TimeScaling()
    slow = [dataclasses.replace(s, stage="cartesian") for s in ts.slowdowns]
    if joint is not None:
        slow += [dataclasses.replace(d, stage="joint") for d in joint.stretches]
    added = float(sum(s.added_s for s in slow))
    ts = dataclasses.replace(
        ts, slowdowns=tuple(slow), added_s=added, duration_s=float(plan.t[-1]),
        duration_unscaled_s=float(plan.t[-1]) - added, needed=bool(slow),
        largest=max([s.factor for s in slow], default=1.0),
        joint_space=joint is not None,
    )  # fmt: skip
    return dataclasses.replace(plan, time_scaling=ts)
