"""The steppable 1 kHz tracking loop on the simulated Panda: :class:`TrackingSession`.

Per control tick (:meth:`TrackingSession.step`, sense → law → actuate): read
the plant's joint state and TCP pose and run the safety stop on them
(:class:`~dexlfd.control.safety.SafetyStop`); add measurement noise, evaluate
the controller's *nominal* model at the measured state and run the control law;
drive the gripper (:class:`~dexlfd.control.grasp.GraspMonitor`), rate-limit the
torque and apply it after a configurable delay (:mod:`dexlfd.control.actuation`;
one tick by default: the command computed at tick k acts during tick k+1, as on
the real robot). Samples go to a :class:`~dexlfd.control.recording.Recording`.

Safety stop: the loop raises :class:`TrackingStopped` (a
:class:`~dexlfd.errors.SimulationDiverged`) with the reason and time on a
non-finite state or torque, a joint position or velocity limit violation, or a
TCP tracking error beyond the bounds. The rollout up to the stop is attached to
the exception (``exc.rollout``) with ``meta["stopped"]`` set. The real arm's
loop is :mod:`dexlfd.control.arm_loop`, built from the same parts.
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
from dexlfd.control.actuation import TorqueDelay, rate_limit
from dexlfd.control.base import Controller, Reference, RobotState
from dexlfd.control.grasp import GraspMonitor
from dexlfd.control.loop_config import LoopConfig
from dexlfd.control.recording import Recording
from dexlfd.control.rollout_report import object_report
from dexlfd.control.safety import SafetyStop
from dexlfd.errors import InvalidInput, SimulationDiverged
from dexlfd.io import Rollout
from dexlfd.panda import N_JOINTS
from dexlfd.robot.model import RobotModel
from dexlfd.robot.sim import PandaSim, PlantConfig, SimState
from dexlfd.rotations import quat_from_matrix, quat_sign_continuous

__all__ = ["RECORDED", "TrackingSession", "TrackingStopped", "substeps"]

logger = logging.getLogger(__name__)


class TrackingStopped(SimulationDiverged):
    """The safety stop fired; ``rollout`` holds the samples up to the stop."""

    def __init__(self, reason: str, t: float, rollout: Rollout) -> None:
        super().__init__(f"safety stop at t={t:.3f} s: {reason}")
        self.reason = reason
        self.time = t
        self.rollout = rollout


def substeps(dt: float, timestep: float) -> int:
    """Physics steps per control period; raises unless ``dt`` is a whole multiple."""
    n_sub_f = dt / timestep
    n_sub = int(round(n_sub_f))
    if n_sub < 1 or abs(n_sub_f - n_sub) > 1e-9:
        raise InvalidInput(
            f"control period {dt} s must be a whole multiple of the physics step {timestep} s"
        )
    return n_sub


# what the simulated loop records per tick: name -> (shape of a sample, dtype)
RECORDED: dict[str, tuple[tuple[int, ...], Any]] = {
    "t": ((), np.float64), "q": ((N_JOINTS,), np.float64),
    "dq": ((N_JOINTS,), np.float64), "tau": ((N_JOINTS,), np.float64),
    "tau_applied": ((N_JOINTS,), np.float64), "ee_position": ((3,), np.float64),
    "ee_R": ((3, 3), np.float64), "gripper": ((), np.float64),
    "attached": ((), np.bool_), "orientation_error": ((), np.float64),
    "payload_position": ((3,), np.float64), "payload_quaternion": ((4,), np.float64),
    "ref_position": ((3,), np.float64), "ref_quaternion": ((4,), np.float64),
    "ref_gripper": ((), np.float64),
}  # fmt: skip


class TrackingSession:
    """A steppable 1 kHz tracking loop on the simulated Panda (a context manager).

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
        Extra entries for the rollout's ``meta``.
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
        regrasp: bool = False,
        noise_block: int = 1000,
        capacity: int = 1024,
    ) -> None:
        self.plant = plant = plant or PlantConfig()
        self.loop = loop = loop or LoopConfig()
        self.controller = controller
        self.model = model
        self.dt = 1.0 / loop.rate_hz
        self._n_sub = substeps(self.dt, plant.timestep)
        if int(noise_block) < 1 or int(capacity) < 1:
            raise InvalidInput(
                f"noise_block and capacity must be >= 1, got {noise_block} and {capacity}"
            )
        self._rng = rng
        self._noise_block = int(noise_block)
        self._noise_q = self._noise_dq = np.zeros((0, N_JOINTS))
        self._q0 = np.asarray(q0, dtype=np.float64)
        self._gripper0 = gripper0
        self._payload_at = payload_at
        self.meta: dict[str, Any] = {
            "controller": controller.describe(),
            "plant": plant.describe(),
            "loop": asdict(loop),
            "model": getattr(model, "description", type(model).__name__),
            "rate_hz": loop.rate_hz,
            **(meta or {}),
            "stopped": None,
        }
        self._rec = Recording(RECORDED, int(capacity))
        self.k = 0  # control ticks done
        self.stopped: str | None = None
        self._grasp = GraspMonitor(bool(regrasp))
        self._safety = SafetyStop(loop)
        self._max_step = (loop.torque_rate_limit or 0.0) / loop.rate_hz
        self._stack: contextlib.ExitStack | None = None
        self._sim: PandaSim | None = None

    # -- context manager -------------------------------------------------
    def __enter__(self) -> TrackingSession:
        stack = contextlib.ExitStack()
        try:
            # the per-tick matrices are 3x3 to 7x7: BLAS threads only add latency (on a
            # loaded machine a 6x6 inverse went from 3 us to ~40 us)
            stack.enter_context(threadpool_limits(limits=1, user_api="blas"))
            sim = stack.enter_context(
                PandaSim(self.plant, self._q0, payload_at=self._payload_at, gripper0=self._gripper0)
            )
            st0 = sim.state()
            self._cs = self.controller.init(
                RobotState(0.0, st0.q, st0.dq), self.model.terms(st0.q, st0.dq)
            )
            hold = self.model.terms(st0.q, np.zeros(N_JOINTS)).g  # before the first command
        except BaseException:
            stack.close()
            raise
        self._stack, self._sim = stack, sim
        self._delay = TorqueDelay(int(self.loop.torque_delay), hold)
        self._tau_sent = hold.copy()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the simulator (idempotent); the recording stays available."""
        if self._stack is not None:
            self._stack.close()
            self._stack = None

    @property
    def sim(self) -> PandaSim:
        """The plant (for rendering and inspection); only inside ``with``."""
        if self._sim is None or self._stack is None:
            raise InvalidInput("TrackingSession: use 'with TrackingSession(...) as s:' first")
        return self._sim

    @property
    def grasp_events(self) -> list[dict[str, Any]]:
        """Missed grasps and drops so far (``event``, ``t`` [s], ``distance_m``)."""
        return self._grasp.events

    @property
    def t(self) -> float:
        """Time of the next control tick [s]: ``k * dt``."""
        return self.k * self.dt

    # -- stepping: sense -> law -> actuate ---------------------------------
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
        if self.stopped is not None:
            raise InvalidInput(f"TrackingSession: stopped ({self.stopped}); cannot step on")
        k = self.k
        self._rec.ensure(k)
        self._record_reference(k, reference, gripper, quaternion)
        st = self._sense(k, reference)
        tau = self._law(k, st, reference)
        self._actuate(k, st, tau, gripper, grasp)
        self.k = k + 1

    def _record_reference(
        self, k: int, reference: Reference, gripper: float, quaternion: FloatArray | None
    ) -> None:
        a = self._rec.a
        a["t"][k] = k * self.dt
        a["ref_position"][k] = reference.p
        a["ref_quaternion"][k] = quat_from_matrix(reference.R) if quaternion is None else quaternion
        a["ref_gripper"][k] = gripper

    def _sense(self, k: int, reference: Reference) -> SimState:
        """True state and TCP pose of tick ``k`` (recorded); the safety stop on them."""
        st = self.sim.state()
        p, R = self.sim.tcp_pose()
        reason, err_r = self._safety.check(st.q, st.dq, p, R, reference)
        if reason is not None:
            self._stop(k, reason)
        a = self._rec.a
        a["q"][k], a["dq"][k] = st.q, st.dq
        a["ee_position"][k], a["ee_R"][k], a["orientation_error"][k] = p, R, err_r
        return st

    def _law(self, k: int, st: SimState, reference: Reference) -> FloatArray:
        """The controller's torque [N·m] at the measured (noisy) state, on its model."""
        noise_q, noise_dq = self._noise(k)
        qm, dqm = st.q + noise_q, st.dq + noise_dq
        rs = RobotState(k * self.dt, qm, dqm)
        tau, self._cs = self.controller.step(self._cs, rs, reference, self.model.terms(qm, dqm))
        if not np.isfinite(tau).all():
            self._stop(k, "the controller returned a non-finite torque")
        return tau

    def _actuate(
        self, k: int, st: SimState, tau: FloatArray, gripper: float, grasp: bool | None
    ) -> None:
        """Gripper and grasp, rate limit and delay, then one control period of the plant."""
        sim, a = self.sim, self._rec.a
        a["gripper"][k] = sim.gripper_opening
        pose = sim.payload_pose()
        if pose is not None:
            a["payload_position"][k], a["payload_quaternion"][k] = pose
        self._grasp.command(sim, gripper, grasp)
        # from values read above: no second pass over the MuJoCo data on the hot path
        a["attached"][k] = self._grasp.observe(
            sim, k * self.dt, a["gripper"][k], pose, a["ee_position"][k]
        )
        sim.set_gripper(gripper)
        if self.loop.torque_rate_limit is not None:
            tau = rate_limit(tau, self._tau_sent, self._max_step)
        self._tau_sent = a["tau"][k] = tau
        a["tau_applied"][k] = applied = self._delay.push(tau)
        sim.step(applied, self._n_sub)

    def _stop(self, k: int, reason: str) -> None:
        t = k * self.dt
        logger.warning("safety stop at t=%.3f s: %s", t, reason)
        self.stopped = f"{reason} (t={t:.3f} s)"
        raise TrackingStopped(reason, t, self.rollout(k))

    def _noise(self, k: int) -> tuple[FloatArray, FloatArray]:
        i = k % self._noise_block
        if i == 0 or self._noise_q.shape[0] == 0:
            lp, shape = self.loop, (self._noise_block, N_JOINTS)
            self._noise_q = (
                self._rng.normal(0.0, lp.q_noise, shape) if lp.q_noise else np.zeros(shape)
            )
            self._noise_dq = (
                self._rng.normal(0.0, lp.dq_noise, shape) if lp.dq_noise else np.zeros(shape)
            )
        return self._noise_q[i], self._noise_dq[i]

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
        k_end = self.k if k_end is None else k_end
        m = dict(self.meta, stopped=self.stopped, grasp_events=list(self.grasp_events))
        a = self._rec.first(max(k_end, 1))
        ee_quat = quat_sign_continuous(quat_from_matrix(a["ee_R"]))
        extras = {
            "tau_applied": a["tau_applied"], "attached": a["attached"],
            "orientation_error": a["orientation_error"], "ref_gripper": a["ref_gripper"],
        }  # fmt: skip
        if self.plant.payload_kg > 0:
            extras["payload_position"] = a["payload_position"]
            extras["payload_quaternion"] = a["payload_quaternion"]
            m["object"] = object_report(
                a["t"], a["payload_position"], a["payload_quaternion"], a["attached"]
            )
        return Rollout(
            t=a["t"], q=a["q"], dq=a["dq"], tau=a["tau"], ee_position=a["ee_position"],
            ee_quaternion=ee_quat, ref_position=a["ref_position"],
            ref_quaternion=a["ref_quaternion"], gripper=a["gripper"], meta=m, extras=extras,
        )  # fmt: skip
