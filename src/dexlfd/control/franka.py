"""Our controllers on a Franka arm: the real-arm counterpart of :func:`dexlfd.control.track`.

:func:`track_franka` tracks a :class:`~dexlfd.io.Plan` with any registered
controller on a connected :class:`~dexlfd.robot.franka.FrankaArm` (a real arm or
a Franka-protocol simulator): the plan is resampled to 1 kHz, joint-space laws
get an IK joint reference from the measured joints, the controller's model is
libfranka's model library (:class:`~dexlfd.robot.franka_model.FrankaModel`), and
the one 1 kHz loop (:class:`~dexlfd.control.arm_loop.ArmLoop`, the same as on
the simulator: the safety stop with the bounds of
:class:`~dexlfd.control.LoopConfig`, the law, the arm's rate limit) runs on the
arm's torque stream (:func:`run_controller`), paced by the robot. A real
arm cannot be reset to the plan's start: the plan must start at the TCP, or
``approach=True`` first moves there along :func:`~dexlfd.plan.moves.approach_plan`.

    with FrankaArm("172.16.0.2") as arm:
        rollout, stats = track_franka(arm, plan, make_controller("ntsm-pd"), approach=True)
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import asdict, dataclass, field
from typing import Any, NamedTuple

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.arm_loop import ArmLoop, ReferenceFn, TrackingStopped
from dexlfd.control.base import Controller, Reference
from dexlfd.control.grasp import plan_grasp_schedule
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.posture_hold import hold_where_planned
from dexlfd.control.reference import (
    ReferenceTrajectory,
    check_plan_workspace,
    joint_reference,
    resample_plan,
)
from dexlfd.errors import InvalidInput
from dexlfd.io import Plan, Rollout
from dexlfd.panda import GRIPPER_OPENING_MAX
from dexlfd.plan.moves import approach_plan
from dexlfd.robot.arm import ArmState
from dexlfd.robot.franka import FrankaArm
from dexlfd.robot.franka_stream import RobotLinkError, StreamArm
from dexlfd.robot.libfranka import CONTROL_PERIOD_S, FrankaState, RobotStopped
from dexlfd.robot.url import FRANKA_SCHEME
from dexlfd.rotations import quat_from_matrix, quat_sign_continuous

__all__ = [
    "LoopStats",
    "PlanPart",
    "run_controller",
    "split_at_grasp_events",
    "track_franka",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class LoopStats:
    """Timing of one motion on the arm.

    Attributes
    ----------
    n_cycles : int
        Control cycles run.
    wall_s : float
        Wall-clock duration [s].
    robot_s : float
        Duration in robot time (sum of the periods libfranka reports) [s].
    missed_cycles : int
        Robot-clock periods that passed without a command (period/1 ms − 1, summed).
    compute_s : ndarray, shape (n_cycles,)
        Controller + model time per cycle [s] (state in to command out).
    """

    n_cycles: int
    wall_s: float
    robot_s: float
    missed_cycles: int
    compute_s: FloatArray = field(repr=False)

    @property
    def rate_hz(self) -> float:
        """Achieved command rate over wall-clock time [Hz]."""
        return self.n_cycles / self.wall_s if self.wall_s > 0 else 0.0

    def summary(self) -> dict[str, float]:
        """JSON-able figures (rates, missed cycles, compute-time percentiles in µs)."""
        c = self.compute_s * 1e6
        return {
            "n_cycles": self.n_cycles,
            "rate_hz": self.rate_hz,
            "robot_s": self.robot_s,
            "missed_cycles": self.missed_cycles,
            "compute_us_median": float(np.median(c)) if c.size else 0.0,
            "compute_us_p99": float(np.percentile(c, 99)) if c.size else 0.0,
            "compute_us_max": float(c.max()) if c.size else 0.0,
        }


def _arm_state(state: FrankaState) -> ArmState:
    """A robot state read outside a motion, as the loop's :class:`ArmState` (time 0)."""
    T = state.O_T_EE
    p, R = T[:3, 3].copy(), T[:3, :3].copy()
    return ArmState(0.0, state.q, state.dq, p, R, state.q, state.dq, 0.0, state.tau_J)


def run_controller(
    arm: FrankaArm,
    controller: Controller,
    reference_at: ReferenceFn,
    n_steps: int,
    *,
    loop: LoopConfig | None = None,
    end_time: float | None = None,
    gripper_width: float | None = None,
    meta: dict[str, Any] | None = None,
) -> tuple[Rollout, LoopStats]:
    """Run ``controller`` against ``reference_at(i, t)`` for up to ``n_steps`` robot cycles.

    The one loop (:class:`~dexlfd.control.arm_loop.ArmLoop`) on the arm's torque
    stream (:class:`~dexlfd.robot.franka_stream.StreamArm`), paced by the robot:
    per cycle the state, the safety stop (``loop``'s bounds), the law on
    libfranka's model (``arm.model``), then ``tau - G(q)`` rate-limited to
    ``FrankaConfig.max_torque_rate`` and sent. The law runs once before the
    motion (its first call can take tens of ms). ``end_time`` [s] of robot time
    ends the motion (missed cycles skip references); ``gripper_width`` [m] is
    recorded (default: read once before; the hand cannot be read inside the loop).

    Returns
    -------
    rollout : Rollout
        Measured and reference TCP poses, joints, commanded torques (``tau``,
        gravity included; the sent ``tau_sent``, measured ``tau_measured``,
        ``orientation_error``, ``compute_s`` and ``period_s`` in ``extras``).
    stats : LoopStats

    Raises
    ------
    RobotStopped
        On any early stop (the safety stop, a non-finite torque, the watchdog, a
        reflex or error reported by the robot, a lost connection), with
        ``.rollout`` = the samples so far.
    """
    if n_steps < 1:
        raise InvalidInput(f"n_steps must be >= 1, got {n_steps}")
    model = arm.model
    if gripper_width is None:
        gripper_width = arm.gripper_width_or_zero()
    start = arm.read_state()
    wall0 = time.perf_counter()
    control = arm.torque_control()
    stream = StreamArm(
        control, model.gravity, arm.config.max_torque_rate, arm.config.watchdog_s,
        getattr(arm, "state_listener", None),
    )  # fmt: skip
    follow = ArmLoop(stream, controller, model, loop or LoopConfig(), capacity=n_steps)
    follow.warm(_arm_state(start), reference_at(0, 0.0))
    reason = None
    try:
        with control:  # leaving it releases libfranka's control lock
            follow.run(reference_at, n_steps, end_time=end_time, gripper=gripper_width)
    except TrackingStopped as exc:
        reason = exc.reason
    except RobotLinkError as exc:
        reason = str(exc)
    except BaseException:
        arm.stop_quietly()
        raise
    n = follow.k
    stats = LoopStats(
        n, time.perf_counter() - wall0, stream.t, stream.missed, np.array(stream.compute[:n])
    )
    meta = {"controller": controller.describe(), **(meta or {})}
    return _finish(arm, follow, stream, stats, reason, gripper_width, meta), stats


def _arm_rollout(
    follow: ArmLoop,
    stream: StreamArm,
    gripper_width: float,
    meta: dict[str, Any],
    stopped: str | None = None,
) -> Rollout | None:
    """The recorded cycles as a Rollout (None before the first); ``stopped``: why not done."""
    n = follow.k
    if n == 0:
        return None
    a = follow.recorded(copy=True)
    return Rollout(
        t=a["t"], q=a["q"], dq=a["dq"], tau=a["tau"], ee_position=a["ee_position"],
        ee_quaternion=quat_sign_continuous(quat_from_matrix(a["ee_R"])),
        ref_position=a["ref_position"],
        ref_quaternion=quat_sign_continuous(a["ref_quaternion"]),
        gripper=np.full(n, gripper_width), meta=meta, stopped=stopped,
        controller=follow.controller.name,
        extras={
            "orientation_error": a["orientation_error"], "tau_sent": a["tau_sent"],
            "tau_measured": np.array(stream.tau_measured[:n]),
            "compute_s": np.array(stream.compute[:n]), "period_s": np.array(stream.periods[:n]),
        },
    )  # fmt: skip


def _finish(
    arm: FrankaArm,
    follow: ArmLoop,
    stream: StreamArm,
    stats: LoopStats,
    reason: str | None,
    gripper_width: float,
    meta: dict[str, Any],
) -> Rollout:
    """The rollout of a finished motion; stops the arm and raises on an early stop."""
    config = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(arm.config).items()}
    meta_out: dict[str, Any] = {
        "robot": f"{FRANKA_SCHEME}{arm.host}",
        "franka_binding": getattr(getattr(arm, "binding", None), "requirement", None),
        "franka_config": config,
        "torque_convention": "tau: commanded total torque (gravity included, rate-limited); "
        "tau_sent = tau - G(q)",
        **meta,
        "loop": stats.summary(),
    }
    if reason is not None:
        arm.stop_quietly()
        rollout = _arm_rollout(follow, stream, gripper_width, meta_out, reason)
        logger.error("motion stopped after %d cycles: %s", follow.k, reason)
        raise RobotStopped(f"Franka at {arm.host}: motion stopped: {reason}", rollout)
    rollout = _arm_rollout(follow, stream, gripper_width, meta_out)
    if rollout is None:  # pragma: no cover - n_steps >= 1 cycles always record one
        raise RobotStopped(f"Franka at {arm.host}: no cycle ran", None)
    logger.info(
        "tracked %d cycles: %.0f Hz, %d missed, compute median %.0f µs",
        stats.n_cycles, stats.rate_hz, stats.missed_cycles,
        stats.summary()["compute_us_median"],
    )  # fmt: skip
    return rollout


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

    As in simulation (:func:`dexlfd.control.track`), the arm's own posture is held
    where the plan says (``arm_posture.hold_s``,
    :func:`~dexlfd.control.posture_hold.hold_where_planned`); each part is a plan on
    its own clock, its spans shifted by its start (:func:`split_at_grasp_events`).

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
    controller = hold_where_planned(controller, plan)
    q_ref = dq_ref = None
    if controller.needs_joint_reference:
        q_ref, dq_ref = joint_reference(arm.model, ref, start.q)

    def reference_at(i: int, t: float) -> Reference:
        k = min(int(round(t / CONTROL_PERIOD_S)), ref.n - 1)  # the robot's clock
        return ref.reference(k, q_ref, dq_ref)

    return run_controller(
        arm, controller, reference_at, ref.n, loop=loop, end_time=float(ref.t[-1]),
        meta={"loop_config": asdict(loop), "plan_meta": plan.meta},
    )  # fmt: skip


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
            "plan from the arm's current pose or pass approach=True",
            param="approach",
        )
    return start


class PlanPart(NamedTuple):
    """A part of a plan between grasp events (:func:`split_at_grasp_events`).

    ``plan`` is the part as a plan by itself, on its own clock from 0; ``event`` what
    follows it (``"grasp"``, ``"open"``, None after the last); ``start_s`` [s] where it
    starts on the whole plan's clock.
    """

    plan: Plan
    event: str | None
    start_s: float


def split_at_grasp_events(plan: Plan) -> list[PlanPart]:
    """Parts of ``plan`` between grasp events, each with the event that follows it.

    An event is where the plan's grasp schedule (:func:`~dexlfd.control.grasp.
    plan_grasp_schedule`) switches: ``"grasp"`` when it closes, ``"open"`` when it
    opens; the last part has ``None``. Parts share their boundary sample. Each is a
    plan by itself on its own clock from 0 (:meth:`Plan.part <dexlfd.io.Plan.part>`):
    its stretch of the samples and of the planned posture (``joint_posture``), the
    plan's world, and its typed facts with their times shifted to its start, the
    spans where the arm holds its own posture (``arm_posture.hold_s``) among them.
    """
    closed, _info = plan_grasp_schedule(plan)
    whole = dataclasses.replace(plan, grasp=closed)
    cuts = [int(k) for k in np.flatnonzero(closed[1:] != closed[:-1]) + 1]
    bounds = [0, *cuts, plan.t.size - 1]
    parts: list[PlanPart] = []
    for j in range(len(bounds) - 1):
        a, b = bounds[j], bounds[j + 1]
        if b - a < 1:
            continue
        event = None if j == len(bounds) - 2 else ("grasp" if closed[b] else "open")
        parts.append(PlanPart(whole.part(a, b), event, float(plan.t[a] - plan.t[0])))
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
    for k, (part, event, start_s) in enumerate(parts):
        # the part is a plan on its own clock: track_franka holds where it says
        ro, st = track_franka(
            arm, part, controller, loop, max_start_gap=max_start_gap,
            approach=approach and k == 0,
        )  # fmt: skip
        # plan time, not the wall time the hand took
        rollouts.append(dataclasses.replace(ro, t=ro.t + start_s))
        stats.append(st)
        if event == "grasp":
            ok = arm.gripper.grasp(
                width=0.0, epsilon_inner=GRIPPER_OPENING_MAX, epsilon_outer=GRIPPER_OPENING_MAX
            )
            logger.info("grasp at t=%.3f s: %s", start_s + part.t[-1], ok)
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
    arrays: dict[str, Any] = {
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
    last = parts[-1]
    return Rollout(
        **arrays, meta=meta, extras=extras, stopped=last.stopped, controller=last.controller
    )
