"""The 1 kHz loop that follows references on any :class:`~dexlfd.robot.arm.Arm`: :class:`ArmLoop`.

One tick (:meth:`ArmLoop._tick`), the same on the simulated Panda
(:class:`~dexlfd.robot.sim_arm.SimArm`) and a Franka arm
(:class:`~dexlfd.robot.franka_stream.StreamArm`):

1. *sense* - the arm's state at the tick (true state and TCP pose on the
   simulator, what the robot reports on an arm);
2. *safety stop* - :class:`~dexlfd.control.safety.SafetyStop` on it (joint
   limits, velocities, TCP errors), or a fault the arm reports (a stalled stream);
3. *law* - the controller on its nominal model at the sensed (noisy) state; a
   non-finite torque stops;
4. *hand* - on the simulator, the gripper follows the referenced opening and the
   object is grasped and released by the plan's grasp schedule
   (:class:`~dexlfd.control.grasp.GraspMonitor`);
5. *act* - the arm rate-limits (and the simulator delays) the torque and applies it.

Samples go to a :class:`~dexlfd.control.recording.Recording`. On a stop the arm
gets no torque (``act(None)``: the simulator stands still, a robot ramps to its
own gravity compensation and ends the motion) and :class:`TrackingStopped` is
raised with the rollout so far. The simulator runs in lock-step (:meth:`ArmLoop.step`,
driven by :class:`~dexlfd.control.session.TrackingSession`); a robot paces the
ticks (:meth:`ArmLoop.run`, driven by :func:`dexlfd.control.franka.run_controller`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Controller, Reference, RobotState
from dexlfd.control.grasp import GraspMonitor
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.recording import Recording
from dexlfd.control.safety import SafetyStop
from dexlfd.errors import InvalidInput, SimulationDiverged
from dexlfd.io import Rollout
from dexlfd.io.rollout_facts import GraspEvent
from dexlfd.panda import N_JOINTS
from dexlfd.robot.arm import Arm, ArmState
from dexlfd.robot.robot_model import RobotModel
from dexlfd.robot.sim import PandaSim
from dexlfd.rotations import quat_from_matrix, quat_sign_continuous

__all__ = ["RECORDED", "ArmLoop", "ReferenceFn", "TrackingStopped"]

logger = logging.getLogger(__name__)

# (tick, arm time [s]) -> Reference
ReferenceFn = Callable[[int, float], Reference]

# what the loop records per tick: name -> (shape of a sample, dtype)
RECORDED: dict[str, tuple[tuple[int, ...], Any]] = {
    "t": ((), np.float64), "q": ((N_JOINTS,), np.float64),
    "dq": ((N_JOINTS,), np.float64), "tau": ((N_JOINTS,), np.float64),
    "tau_sent": ((N_JOINTS,), np.float64), "ee_position": ((3,), np.float64),
    "ee_R": ((3, 3), np.float64), "gripper": ((), np.float64),
    "attached": ((), np.bool_), "orientation_error": ((), np.float64),
    "payload_position": ((3,), np.float64), "payload_quaternion": ((4,), np.float64),
    "ref_position": ((3,), np.float64), "ref_quaternion": ((4,), np.float64),
    "ref_gripper": ((), np.float64), "ref_R": ((3, 3), np.float64),
    "ref_quat_given": ((), np.bool_),
}  # fmt: skip


class TrackingStopped(SimulationDiverged):
    """The safety stop fired; ``rollout`` holds the samples up to the stop."""

    def __init__(self, reason: str, t: float, rollout: Rollout) -> None:
        super().__init__(f"safety stop at t={t:.3f} s: {reason}")
        self.reason = reason
        self.time = t
        self.rollout = rollout


class ArmLoop:
    """The 1 kHz loop of a controller on an arm (see the module docstring).

    Parameters
    ----------
    arm : Arm
        The simulated or a real arm (not owned: the caller closes it).
    controller : Controller
    model : RobotModel
        The controller's (nominal) model, evaluated at the sensed state.
    loop : LoopConfig
        The safety stop's bounds.
    regrasp : bool
        Simulator: grasp again when the opening closes after a release.
    capacity : int
        Samples preallocated for the recording (it grows when needed).
    rollout_of : callable, optional
        ``rollout_of(loop)``: the rollout a stop carries; default :meth:`rollout`.
    """

    def __init__(
        self,
        arm: Arm,
        controller: Controller,
        model: RobotModel,
        loop: LoopConfig,
        *,
        regrasp: bool = False,
        capacity: int = 1024,
        rollout_of: Callable[[ArmLoop], Rollout] | None = None,
    ) -> None:
        if int(capacity) < 1:
            raise InvalidInput(f"capacity must be >= 1, got {capacity}")
        self.arm, self.controller, self.model, self.loop = arm, controller, model, loop
        self.rec = Recording(RECORDED, int(capacity))
        self.k = 0  # ticks recorded
        self.stopped: str | None = None
        self.stop_t = 0.0
        self._safety = SafetyStop(loop)
        self._grasp = GraspMonitor(bool(regrasp))
        self._cs: Any = None
        self._reason = ""
        self._rollout_of = rollout_of
        sim = getattr(arm, "sim", None)
        self._sim: PandaSim | None = sim if isinstance(sim, PandaSim) else None

    @property
    def grasp_events(self) -> list[GraspEvent]:
        """Missed grasps and drops so far (``event``, ``t`` [s], ``distance_m``)."""
        return self._grasp.events

    # -- the two ways to drive it ----------------------------------------------
    def step(
        self,
        reference: Reference,
        gripper: float,
        quaternion: FloatArray | None = None,
        grasp: bool | None = None,
    ) -> None:
        """One lock-step tick: sense, law, act towards ``reference`` (see :meth:`_tick`).

        Raises
        ------
        TrackingStopped
            The safety stop fired; ``exc.rollout`` holds the samples before it.
        """
        if self.stopped is not None:
            raise InvalidInput(f"the loop stopped ({self.stopped}); cannot step on")
        self._tick(self.arm.sense(), reference, gripper, quaternion, grasp)
        self._raise_if_stopped()

    def run(
        self,
        reference_at: ReferenceFn,
        n_ticks: int,
        *,
        end_time: float | None = None,
        gripper: float = 0.0,
    ) -> None:
        """Up to ``n_ticks`` ticks paced by the arm (:meth:`~dexlfd.robot.arm.Arm.run`).

        ``reference_at(k, t)`` gives tick ``k``'s reference at arm time ``t`` [s];
        the motion ends at ``end_time`` [s] of arm time (a robot's clock: missed
        cycles skip references rather than slow the motion down). ``gripper`` is
        the finger opening recorded [m].

        Raises
        ------
        TrackingStopped
            Any stop of the loop, with the rollout so far.
        """
        if n_ticks < 1:
            raise InvalidInput(f"n_ticks must be >= 1, got {n_ticks}")

        def tick(state: ArmState) -> bool:
            k = self.k
            ref = reference_at(k, state.t)
            self._tick(state, ref, gripper, None, None)
            ended = end_time is not None and state.t >= end_time - 1e-9
            return self.stopped is not None or k == n_ticks - 1 or ended

        self.arm.run(tick, n_ticks)
        self._raise_if_stopped()

    def warm(self, state: ArmState, reference: Reference) -> None:
        """Run the safety test and the law once outside the loop; nothing is recorded.

        Lazy imports and numba's kernels load here, not in the first tick.
        """
        self._safety.check(state.q, state.dq, state.p, state.R, reference)
        self._law(state, reference)
        self._cs = None

    # -- one tick --------------------------------------------------------------
    def _tick(
        self,
        state: ArmState,
        reference: Reference,
        gripper: float,
        quaternion: FloatArray | None,
        grasp: bool | None,
    ) -> None:
        """Sense -> safety stop -> law -> hand -> act, recording row ``k``."""
        k = self.k
        self.rec.ensure(k)
        a = self.rec.a
        a["t"][k] = state.t
        a["ref_position"][k] = reference.p
        a["ref_R"][k] = reference.R  # to a quaternion when the rows are read (vectorised)
        a["ref_quat_given"][k] = given = quaternion is not None
        if given:
            a["ref_quaternion"][k] = quaternion
        a["ref_gripper"][k] = gripper
        reason, err_r = self._safety.check(state.q, state.dq, state.p, state.R, reference)
        reason = state.fault or reason
        tau = None
        if reason is None:
            tau = self._law(state, reference)
            if not all(map(math.isfinite, tau.tolist())):  # np.isfinite's test, 4x cheaper
                reason, tau = "the controller returned a non-finite torque", None
        a["q"][k], a["dq"][k] = state.q, state.dq
        a["ee_position"][k], a["ee_R"][k], a["orientation_error"][k] = state.p, state.R, err_r
        if tau is not None:
            self._hand(k, gripper, grasp)
        else:
            a["gripper"][k] = gripper
        sent = self.arm.act(tau)
        if reason is not None:
            self._stop(state.t, reason, sent)
            return
        a["tau"][k], a["tau_sent"][k] = self.arm.commanded, sent
        self.k = k + 1

    def _law(self, state: ArmState, reference: Reference) -> FloatArray:
        """The controller's torque [N·m] at the sensed state, on its model."""
        if self._cs is None:  # the first tick: the law starts from the true state
            self._cs = self.controller.init(
                RobotState(state.t, state.q, state.dq), self.model.terms(state.q, state.dq)
            )
        qm, dqm = state.q_sensed, state.dq_sensed
        terms = self.model.terms(qm, dqm)
        rs = RobotState(state.t, qm, dqm)
        tau, self._cs = self.controller.step(self._cs, rs, reference, terms)
        return tau

    def _hand(self, k: int, gripper: float, grasp: bool | None) -> None:
        """Simulator: the fingers and the grasp (read before the plant steps)."""
        sim, a = self._sim, self.rec.a
        if sim is None:
            a["gripper"][k] = gripper
            return
        a["gripper"][k] = sim.gripper_opening
        pose = sim.payload_pose()
        if pose is not None:
            a["payload_position"][k], a["payload_quaternion"][k] = pose
        self._grasp.command(sim, gripper, grasp)
        # from values read above: no second pass over the MuJoCo data on the hot path
        a["attached"][k] = self._grasp.observe(
            sim, float(a["t"][k]), a["gripper"][k], pose, a["ee_position"][k]
        )
        sim.set_gripper(gripper)

    def _stop(self, t: float, reason: str, sent: FloatArray | None) -> None:
        """Stop: the tick is kept when the arm still got a command in it (a robot's)."""
        if sent is not None:
            a, k = self.rec.a, self.k
            a["tau"][k], a["tau_sent"][k] = self.arm.commanded, sent
            self.k = k + 1
        logger.warning("safety stop at t=%.3f s: %s", t, reason)
        self.stopped, self.stop_t = f"{reason} (t={t:.3f} s)", t
        self._reason = reason

    def _raise_if_stopped(self) -> None:
        if self.stopped is not None:
            rollout = self.rollout() if self._rollout_of is None else self._rollout_of(self)
            raise TrackingStopped(self._reason, self.stop_t, rollout)

    def rollout(self) -> Rollout:
        """The recorded ticks as a plain Rollout (extras ``tau_sent``, ``orientation_error``)."""
        a = self.recorded(copy=True)
        return Rollout(
            t=a["t"], q=a["q"], dq=a["dq"], tau=a["tau"], ee_position=a["ee_position"],
            ee_quaternion=quat_sign_continuous(quat_from_matrix(a["ee_R"])),
            ref_position=a["ref_position"], ref_quaternion=a["ref_quaternion"],
            gripper=a["gripper"], stopped=self.stopped,
            extras={"tau_sent": a["tau_sent"], "orientation_error": a["orientation_error"]},
        )  # fmt: skip

    def recorded(self, k_end: int | None = None, *, copy: bool = False) -> dict[str, np.ndarray]:
        """The first ``k_end`` recorded rows (default all, at least one)."""
        k_end = self.k if k_end is None else k_end
        a = self.rec.first(max(k_end, 1))
        todo = ~a["ref_quat_given"]
        if todo.any():
            a["ref_quaternion"][todo] = quat_from_matrix(a["ref_R"][todo])
            a["ref_quat_given"][todo] = True
        return {k: v.copy() for k, v in a.items()} if copy else a
