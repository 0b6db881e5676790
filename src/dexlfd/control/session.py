"""The simulated Panda's steppable 1 kHz loop: :class:`TrackingSession`.

The one loop (:class:`~dexlfd.control.arm_loop.ArmLoop`: sense, safety stop,
law, hand, act; see there) on the MuJoCo plant as an arm
(:class:`~dexlfd.robot.sim_arm.SimArm`: measurement noise, the libfranka-like
torque rate limit and a delay of ``LoopConfig.torque_delay`` ticks, one by
default: the command computed at tick k acts during tick k+1, as on the real
robot), stepped in lock-step. Samples become a :class:`~dexlfd.io.Rollout`.

Safety stop: :class:`~dexlfd.control.arm_loop.TrackingStopped` (a
:class:`~dexlfd.errors.SimulationDiverged`) with the reason and time on a
non-finite state or torque, a joint position or velocity limit violation, or a
TCP tracking error beyond the bounds. The rollout up to the stop is attached to
the exception (``exc.rollout``) with its ``stopped`` set.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from dexlfd._types import FloatArray
from dexlfd.control.arm_loop import ArmLoop
from dexlfd.control.base import Controller, Reference
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.rollout_report import object_report
from dexlfd.errors import InvalidInput
from dexlfd.io import Rollout
from dexlfd.io.rollout_facts import GraspEvent, ObjectReport
from dexlfd.panda import N_JOINTS
from dexlfd.robot.plant import PlantConfig
from dexlfd.robot.robot_model import RobotModel
from dexlfd.robot.sim import PandaSim
from dexlfd.robot.sim_arm import SimArm, SimSensing, plant_arm, substeps
from dexlfd.rotations import quat_from_matrix, quat_sign_continuous

__all__ = ["TrackingSession"]

logger = logging.getLogger(__name__)


class TrackingSession:
    """The 1 kHz loop on the simulated Panda, steppable (a context manager).

    :func:`track` runs a whole plan through one; streaming callers (e.g.
    teleoperation) feed references tick by tick with :meth:`step`, or let
    :meth:`run_until` ask a function for them. Per tick (:meth:`step`): sense
    (true state, TCP pose, safety stop), law (measurement noise, the controller
    on its nominal model), actuate (gripper and grasp, the libfranka-like torque
    rate limit and the torque delay, then the plant steps one control period).
    The gripper follows the referenced opening; the object is grasped when the
    plan's grasp schedule (``grasp`` of :meth:`step`: a plan's, or a stream's hand
    flag) first closes and released when it opens (with ``regrasp``, again whenever
    it closes after a release); a tick without it keeps the hand's state.

    Parameters
    ----------
    controller, model, plant, loop
        As for :func:`track`.
    rng : numpy.random.Generator
        Source of the measurement noise, drawn in blocks of ``noise_block``
        ticks (joint positions first, then velocities).
    q0 : ndarray, shape (7,)
        Initial joints [rad].
    gripper0 : float, optional
        Initial finger opening [m] (see :class:`~dexlfd.robot.sim.PandaSim`).
    payload_at : (position (3,), rotation (3, 3)), optional
        TCP pose where the object waits; default the TCP pose at ``q0``.
    meta : dict, optional
        Extra entries for the rollout's ``meta`` (provenance).
    facts : dict, optional
        Typed facts of the rollout (:class:`~dexlfd.io.Rollout`'s fields, e.g. the
        ``grasp_schedule`` and ``task`` of the plan it follows).
    regrasp : bool
        Grasp again when the opening closes after a release.
    noise_block : int
        Ticks of noise drawn at once (:func:`track` draws the whole plan's).
    capacity : int
        Samples preallocated for the recording (it grows when needed).

    Examples
    --------
    >>> with TrackingSession(ctrl, model, rng=rng, q0=Q_READY) as s:  # doctest: +SKIP
    ...     s.run_until(1.0, lambda t: (reference_at(t), 0.08, None))
    ...     rollout = s.rollout()
    """

    def __init__(
        self,
        controller: Controller,
        model: RobotModel,
        plant: PlantConfig | None = None,
        loop: LoopConfig | None = None,
        *,
        rng: np.random.Generator,
        q0: FloatArray,
        gripper0: float | None = None,
        payload_at: tuple[FloatArray, FloatArray] | None = None,
        meta: dict[str, Any] | None = None,
        facts: dict[str, Any] | None = None,
        regrasp: bool = False,
        noise_block: int = 1000,
        capacity: int = 1024,
    ) -> None:
        self.plant = plant = plant or PlantConfig()
        self.loop = loop = loop or LoopConfig()
        self.controller = controller
        self.model = model
        self.dt = 1.0 / loop.rate_hz
        substeps(self.dt, plant.timestep)
        if int(noise_block) < 1 or int(capacity) < 1:
            raise InvalidInput(
                f"noise_block and capacity must be >= 1, got {noise_block} and {capacity}"
            )
        self._rng = rng
        self._noise_block = int(noise_block)
        self._capacity = int(capacity)
        self._regrasp = bool(regrasp)
        self._q0 = np.asarray(q0, dtype=np.float64)
        self._gripper0 = gripper0
        self._payload_at = payload_at
        self.meta: dict[str, Any] = {
            "controller": controller.describe(),
            "plant": plant.describe(),
            "loop": asdict(loop),
            "model": getattr(model, "description", type(model).__name__),
            **(meta or {}),
        }
        self.facts: dict[str, Any] = dict(facts or {})
        self._stack: contextlib.ExitStack | None = None
        self._arm: SimArm | None = None
        self._loop: ArmLoop | None = None

    # -- context manager -------------------------------------------------
    def __enter__(self) -> TrackingSession:
        stack = contextlib.ExitStack()
        lp = self.loop
        sensing = SimSensing(
            self.dt, lp.q_noise, lp.dq_noise, int(lp.torque_delay), lp.torque_rate_limit
        )
        try:
            # the per-tick matrices are 3x3 to 7x7: BLAS threads only add latency (on a
            # loaded machine a 6x6 inverse went from 3 us to ~40 us)
            stack.enter_context(threadpool_limits(limits=1, user_api="blas"))
            hold = self.model.terms(self._q0, np.zeros(N_JOINTS)).g  # before the first command
            arm = plant_arm(
                self.plant, sensing, self._q0, hold, rng=self._rng,
                noise_block=self._noise_block, payload_at=self._payload_at,
                gripper0=self._gripper0,
            )  # fmt: skip
            stack.callback(arm.close)
        except BaseException:
            stack.close()
            raise
        self._stack, self._arm = stack, arm
        self._loop = ArmLoop(
            arm, self.controller, self.model, lp, regrasp=self._regrasp,
            capacity=self._capacity, rollout_of=lambda _loop: self.rollout(),
        )  # fmt: skip
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the simulator (idempotent); the recording stays available."""
        if self._stack is not None:
            self._stack.close()
            self._stack = None

    def _running(self) -> ArmLoop:
        if self._loop is None or self._stack is None:
            raise InvalidInput("TrackingSession: use 'with TrackingSession(...) as s:' first")
        return self._loop

    @property
    def sim(self) -> PandaSim:
        """The plant (for rendering and inspection); only inside ``with``."""
        self._running()
        assert self._arm is not None  # set with the loop
        return self._arm.sim

    @property
    def k(self) -> int:
        """Control ticks done."""
        return 0 if self._loop is None else self._loop.k

    @property
    def stopped(self) -> str | None:
        """The stop's reason and time, or None."""
        return None if self._loop is None else self._loop.stopped

    @property
    def grasp_events(self) -> list[GraspEvent]:
        """Missed grasps and drops so far (``event``, ``t`` [s], ``distance_m``)."""
        return [] if self._loop is None else self._loop.grasp_events

    def samples(self) -> dict[str, np.ndarray]:
        """The rows recorded so far, every field (views: valid until the next tick)."""
        loop = self._running()
        return loop.rec.first(loop.k)

    @property
    def t(self) -> float:
        """Time of the next control tick [s]: ``k * dt``."""
        return self.k * self.dt

    # -- stepping ----------------------------------------------------------
    def step(
        self,
        reference: Reference,
        gripper: float,
        quaternion: FloatArray | None = None,
        grasp: bool | None = None,
    ) -> None:
        """Run one control tick towards ``reference`` with finger opening ``gripper`` [m].

        ``quaternion`` (x, y, z, w) of ``reference.R`` is recorded as the
        reference orientation (computed from ``R`` when not given). ``grasp`` is
        the grasp schedule at this tick (True: holding); None: unchanged.

        Raises
        ------
        TrackingStopped
            The safety stop fired; ``exc.rollout`` holds the samples before it.
        """
        self._running().step(reference, gripper, quaternion, grasp)

    def run_until(
        self,
        t_end: float,
        reference_fn: Callable[[float], tuple[Reference, float, FloatArray | None]],
        grasp: bool | None = None,
    ) -> int:
        """Step while the next tick's time is before ``t_end`` [s]; returns the ticks run.

        ``reference_fn(t)`` gives ``(reference, gripper, quaternion or None)``
        for tick time ``t`` [s]; ``grasp`` is the schedule over these ticks (the
        hand's flag of a stream; None: unchanged).
        """
        n = 0
        eps = 1e-9 * self.dt
        while self.t < t_end - eps:
            r, g, quat = reference_fn(self.t)
            self.step(r, g, quat, grasp)
            n += 1
        return n

    def rollout(self, k_end: int | None = None) -> Rollout:
        """The recorded samples (the first ``k_end``, default all done) as a Rollout."""
        loop = self._loop
        if loop is None:
            raise InvalidInput("TrackingSession: nothing recorded yet")
        m = dict(self.meta)
        facts: dict[str, Any] = {
            "stopped": self.stopped, "controller": str(self.controller.name),
            "rate_hz": float(self.loop.rate_hz), "payload_kg": float(self.plant.payload_kg),
            "grasp_events": tuple(self.grasp_events), **self.facts,
        }  # fmt: skip
        a = loop.recorded(k_end)
        ee_quat = quat_sign_continuous(quat_from_matrix(a["ee_R"]))
        extras = {
            "tau_applied": a["tau_sent"], "attached": a["attached"],
            "orientation_error": a["orientation_error"], "ref_gripper": a["ref_gripper"],
        }  # fmt: skip
        if self.plant.payload_kg > 0:
            extras["payload_position"] = a["payload_position"]
            extras["payload_quaternion"] = a["payload_quaternion"]
            report = object_report(
                a["t"], a["payload_position"], a["payload_quaternion"], a["attached"]
            )
            facts["object_report"] = ObjectReport.from_json(report, "object report")
        return Rollout(
            t=a["t"], q=a["q"], dq=a["dq"], tau=a["tau"], ee_position=a["ee_position"],
            ee_quaternion=ee_quat, ref_position=a["ref_position"],
            ref_quaternion=a["ref_quaternion"], gripper=a["gripper"], meta=m, extras=extras,
            **facts,
        )  # fmt: skip
