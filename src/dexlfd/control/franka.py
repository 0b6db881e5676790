"""Our controllers on a Franka arm: the real-arm counterpart of :func:`dexlfd.control.track`.

:func:`track_franka` tracks a :class:`~dexlfd.io.Plan` with any registered
controller on a connected :class:`~dexlfd.robot.franka.FrankaArm` (a real arm or
a Franka-protocol simulator): the plan is resampled to 1 kHz, joint-space laws
get an IK joint reference from the measured joints, the controller's model is
libfranka's model library (:class:`~dexlfd.robot.franka_model.FrankaModel`), and
the loop's safety stop (:func:`~dexlfd.control.safety.make_safety_check`, the
bounds of :class:`~dexlfd.control.LoopConfig`) runs on every measured state in
the arm's 1 kHz loop (:func:`~dexlfd.control.arm_loop.run_torque_loop`). A real
arm cannot be reset to the plan's start: the plan must start at the TCP, or
``approach=True`` first moves there along :func:`~dexlfd.plan.moves.approach_plan`.

    with FrankaArm("172.16.0.2") as arm:
        rollout, stats = track_franka(arm, plan, make_controller("ntsm-pd"), approach=True)
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np

from dexlfd.control.arm_loop import LoopStats, PolicyOutput, TorquePolicy, run_torque_loop
from dexlfd.control.base import Controller, Reference, RobotState
from dexlfd.control.grasp import plan_grasp_schedule
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.reference import (
    ReferenceTrajectory,
    check_plan_workspace,
    joint_reference,
    resample_plan,
)
from dexlfd.control.safety import SafetyCheck, make_safety_check
from dexlfd.errors import InvalidInput
from dexlfd.io import Plan, Rollout
from dexlfd.panda import GRIPPER_OPENING_MAX
from dexlfd.plan.moves import approach_plan
from dexlfd.robot.franka import FrankaArm
from dexlfd.robot.libfranka import CONTROL_PERIOD_S, FrankaState
from dexlfd.robot.model import ModelTerms

__all__ = [
    "SafetyCheck",
    "approach_plan",
    "controller_policy",
    "make_safety_check",
    "run_controller",
    "split_at_grasp_events",
    "track_franka",
]

logger = logging.getLogger(__name__)

ReferenceFn = Callable[[int, float], Reference]  # (cycle, robot time [s]) -> Reference


def controller_policy(
    controller: Controller, reference_at: ReferenceFn, safety_check: SafetyCheck | None = None
) -> TorquePolicy:
    """Wrap a controller as the arm's torque policy (restarts its state at cycle 0)."""
    box: dict[str, Any] = {}

    def policy(i: int, t: float, state: FrankaState, terms: ModelTerms) -> PolicyOutput:
        rs = RobotState(t=t, q=state.q, dq=state.dq)
        ref = reference_at(i, t)
        if i == 0:
            box["cs"] = controller.init(rs, terms)
        tau, box["cs"] = controller.step(box["cs"], rs, ref, terms)
        stop = safety_check(rs, ref, terms) if safety_check is not None else None
        return PolicyOutput(tau=tau, ref_p=ref.p, ref_R=ref.R, stop=stop)

    return policy


def run_controller(
    arm: FrankaArm,
    controller: Controller,
    reference_at: ReferenceFn,
    n_steps: int,
    *,
    safety_check: SafetyCheck | None = None,
    end_time: float | None = None,
    meta: dict[str, Any] | None = None,
) -> tuple[Rollout, LoopStats]:
    """Run ``controller`` against ``reference_at(i, t)`` for up to ``n_steps`` cycles.

    See :func:`~dexlfd.control.arm_loop.run_torque_loop` for the loop, its
    safety layer and :class:`~dexlfd.robot.libfranka.RobotStopped`.
    """
    return run_torque_loop(
        arm,
        controller_policy(controller, reference_at, safety_check),
        n_steps,
        end_time=end_time,
        meta={"controller": controller.describe(), **(meta or {})},
    )


def track_franka(
    arm: FrankaArm,
    plan: Plan,
    controller: Controller,
    loop: LoopConfig | None = None,
    *,
    max_start_gap: float = 0.01,
    approach: bool = False,
    gripper: bool = False,
) -> tuple[Rollout, LoopStats]:
    """Track ``plan`` with ``controller`` on the arm, from its current pose.

    Parameters
    ----------
    arm : FrankaArm
        A connected arm.
    plan : Plan
        TCP trajectory; resampled to 1 kHz and followed on the robot's clock.
    controller : Controller
        Control law; its model is libfranka's (``arm.model``).
    loop : LoopConfig, optional
        Safety bounds (``rate_hz`` must be 1000; noise and delay do not apply).
    max_start_gap : float
        Largest accepted distance [m] between the TCP and the plan's start.
    approach : bool
        If the TCP is farther than that, first move to the plan's start along
        :func:`~dexlfd.plan.moves.approach_plan` (same controller and safety stop).
    gripper : bool
        Execute the plan's gripper channel: the plan is split where its grasp
        schedule switches (:func:`split_at_grasp_events`); between the parts the
        arm holds still while the hand grasps (closing) or opens to the plan's
        width (pylibfranka blocks on gripper commands, so they cannot run inside the 1 kHz loop).

    Returns
    -------
    rollout : Rollout
    stats : LoopStats

    Raises
    ------
    InvalidInput
        Plan outside the workspace, or not starting at the TCP (without ``approach``).
    RobotStopped
        Any early stop (safety stop, reflex, lost connection, watchdog), with
        the rollout so far in ``exc.rollout``.
    """
    loop = loop or LoopConfig()
    if not isinstance(plan, Plan):
        raise InvalidInput(f"plan must be a dexlfd.io.Plan, got {type(plan).__name__}")
    if gripper:
        return _track_with_gripper(arm, plan, controller, loop, max_start_gap, approach)
    if abs(loop.rate_hz - 1.0 / CONTROL_PERIOD_S) > 1e-9:
        raise InvalidInput(f"a Franka runs at 1000 Hz; LoopConfig.rate_hz is {loop.rate_hz}")
    check_plan_workspace(plan)
    ref = resample_plan(plan, CONTROL_PERIOD_S)
    start = _at_start(arm, ref, controller, loop, max_start_gap, approach, float(plan.gripper[0]))
    q_ref = dq_ref = None
    if controller.needs_joint_reference:
        q_ref, dq_ref = joint_reference(arm.model, ref, start.q)

    def reference_at(i: int, t: float) -> Reference:
        k = min(int(round(t / CONTROL_PERIOD_S)), ref.n - 1)  # the robot's clock
        return ref.reference(k, q_ref, dq_ref)

    return run_controller(
        arm,
        controller,
        reference_at,
        ref.n,
        safety_check=make_safety_check(loop),
        end_time=float(ref.t[-1]),
        meta={"loop_config": asdict(loop), "plan_meta": plan.meta},
    )


def _at_start(
    arm: FrankaArm,
    ref: ReferenceTrajectory,
    controller: Controller,
    loop: LoopConfig,
    max_start_gap: float,
    approach: bool,
    gripper: float,
) -> FrankaState:
    """The arm's state at the reference's start (moving there first with ``approach``).

    Raises
    ------
    InvalidInput
        The TCP is farther than ``max_start_gap`` [m] from the start (after the approach).
    """
    start = arm.read_state()
    gap = float(np.linalg.norm(start.O_T_EE[:3, 3] - ref.p[0]))
    if gap > max_start_gap and approach:
        logger.info("approaching the plan's start (%.1f mm away)", gap * 1e3)
        p, R = start.O_T_EE[:3, 3], start.O_T_EE[:3, :3]
        to_start = approach_plan(p, R, ref.p[0], ref.R[0], gripper=gripper)
        track_franka(arm, to_start, controller, loop, max_start_gap=max_start_gap)
        start = arm.read_state()
        gap = float(np.linalg.norm(start.O_T_EE[:3, 3] - ref.p[0]))
    if gap > max_start_gap:
        raise InvalidInput(
            f"the plan starts {gap * 1e3:.1f} mm from the arm's TCP "
            f"{np.round(start.O_T_EE[:3, 3], 4).tolist()} m (limit {max_start_gap * 1e3:.0f} mm); "
            "plan from the arm's current pose or pass approach=True"
        )
    return start


def split_at_grasp_events(plan: Plan) -> list[tuple[Plan, str | None]]:
    """Parts of ``plan`` between grasp events, each with the event that follows it.

    An event is where the plan's grasp schedule (:func:`~dexlfd.control.grasp.
    plan_grasp_schedule`) switches: ``"grasp"`` when it closes, ``"open"`` when it
    opens; the last part has ``None``. Parts share their boundary sample and keep
    the plan's time stamps.
    """
    closed, _info = plan_grasp_schedule(plan)
    cuts = [int(k) for k in np.flatnonzero(closed[1:] != closed[:-1]) + 1]
    bounds = [0, *cuts, plan.t.size - 1]
    parts: list[tuple[Plan, str | None]] = []
    for j in range(len(bounds) - 1):
        a, b = bounds[j], bounds[j + 1]
        if b - a < 1:
            continue
        sl = slice(a, b + 1)
        part = Plan(
            t=plan.t[sl], position=plan.position[sl], velocity=plan.velocity[sl],
            acceleration=plan.acceleration[sl], quaternion=plan.quaternion[sl],
            angular_velocity=plan.angular_velocity[sl], gripper=plan.gripper[sl],
            grasp=closed[sl], meta=plan.meta,
        )  # fmt: skip
        event = None if j == len(bounds) - 2 else ("grasp" if closed[b] else "open")
        parts.append((part, event))
    return parts


def _track_with_gripper(
    arm: FrankaArm,
    plan: Plan,
    controller: Controller,
    loop: LoopConfig,
    max_start_gap: float,
    approach: bool,
) -> tuple[Rollout, LoopStats]:
    parts = split_at_grasp_events(plan)
    rollouts: list[Rollout] = []
    stats: list[LoopStats] = []
    for k, (part, event) in enumerate(parts):
        ro, st = track_franka(
            arm, part, controller, loop, max_start_gap=max_start_gap, approach=approach and k == 0
        )
        # plan time, not the wall time the hand took
        rollouts.append(dataclasses.replace(ro, t=ro.t + (part.t[0] - plan.t[0])))
        stats.append(st)
        if event == "grasp":
            ok = arm.gripper.grasp(
                width=0.0, epsilon_inner=GRIPPER_OPENING_MAX, epsilon_outer=GRIPPER_OPENING_MAX
            )
            logger.info("grasp at t=%.3f s: %s", part.t[-1] - plan.t[0], ok)
        elif event == "open":
            arm.gripper.move(float(np.clip(part.gripper[-1], 0.0, GRIPPER_OPENING_MAX)))
    if len(rollouts) == 1:
        return rollouts[0], stats[0]
    return _concatenate(rollouts), LoopStats(
        n_cycles=sum(s.n_cycles for s in stats),
        wall_s=sum(s.wall_s for s in stats),
        robot_s=sum(s.robot_s for s in stats),
        missed_cycles=sum(s.missed_cycles for s in stats),
        compute_s=np.concatenate([s.compute_s for s in stats]),
    )


def _concatenate(parts: list[Rollout]) -> Rollout:
    """One rollout from consecutive parts (a repeated boundary time is kept once)."""
    starts = [0] + [
        1 if p.t[0] <= prev.t[-1] else 0 for prev, p in zip(parts[:-1], parts[1:], strict=True)
    ]
    per_sample = [
        n for n, spec in parts[0].SPECS.items()
        if spec.shape[0] == "n" and all(getattr(p, n) is not None for p in parts)
    ]  # fmt: skip
    arrays = {
        n: np.concatenate([getattr(p, n)[k:] for p, k in zip(parts, starts, strict=True)])
        for n in per_sample
    }
    arrays.update({
        n: getattr(parts[0], n) for n, spec in parts[0].SPECS.items()
        if spec.shape[0] != "n" and getattr(parts[0], n) is not None
    })  # fmt: skip
    extras = {
        name: np.concatenate([p.extras[name][k:] for p, k in zip(parts, starts, strict=True)])
        for name in parts[0].extras
        if all(name in p.extras for p in parts)
    }
    meta = dict(parts[-1].meta, gripper_events=len(parts) - 1)
    return Rollout(**arrays, meta=meta, extras=extras)
