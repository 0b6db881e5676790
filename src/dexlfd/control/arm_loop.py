"""The real arm's 1 kHz loop: a torque policy in libfranka's read/write stream.

:func:`run_torque_loop` is the counterpart of
:class:`~dexlfd.control.session.TrackingSession` on a connected
:class:`~dexlfd.robot.franka.FrankaArm`, built from the same parts: the
policy runs the safety stop (:func:`~dexlfd.control.safety.make_safety_check`),
the command goes through the same torque rate limit
(:func:`~dexlfd.control.actuation.rate_limit`, ``FrankaConfig.max_torque_rate``)
and the samples into a :class:`~dexlfd.control.recording.Recording`. There is
no torque delay to simulate: the arm has its own.

Torque convention: the policy returns the *total* joint torque, gravity
included; the arm adds its own gravity compensation ``G(q)``, so the loop sends
``tau - G(q)`` (see :mod:`dexlfd.robot.franka`). Any stop (the policy's safety
stop, a non-finite torque, a stalled state stream, a reflex or error reported
by the robot, a dropped connection) raises
:class:`~dexlfd.robot.libfranka.RobotStopped` with the rollout so far.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.actuation import rate_limit
from dexlfd.control.recording import Recording
from dexlfd.errors import InvalidInput
from dexlfd.io import Rollout
from dexlfd.panda import N_JOINTS
from dexlfd.robot.franka import FRANKA_SCHEME, FrankaArm, RobotLinkError, TorqueControl
from dexlfd.robot.libfranka import CONTROL_PERIOD_S, FrankaState, RobotStopped
from dexlfd.robot.model import ModelTerms
from dexlfd.rotations import quat_from_matrix, quat_sign_continuous, rotation_angle

__all__ = ["RECORDED", "LoopStats", "PolicyOutput", "TorquePolicy", "run_torque_loop"]

logger = logging.getLogger(__name__)

# what the arm's loop records per cycle: name -> (shape of a sample, dtype)
RECORDED: dict[str, tuple[tuple[int, ...], Any]] = {
    "t": ((), np.float64), "q": ((N_JOINTS,), np.float64), "dq": ((N_JOINTS,), np.float64),
    "tau": ((N_JOINTS,), np.float64), "tau_sent": ((N_JOINTS,), np.float64),
    "tau_J": ((N_JOINTS,), np.float64), "p": ((3,), np.float64), "R": ((3, 3), np.float64),
    "ref_p": ((3,), np.float64), "ref_R": ((3, 3), np.float64),
    "compute": ((), np.float64), "period": ((), np.float64),
}  # fmt: skip


@dataclass(frozen=True, slots=True)
class LoopStats:
    """Timing of one run of the torque loop.

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


@dataclass(frozen=True, slots=True)
class PolicyOutput:
    """What a torque policy returns for one cycle.

    Attributes
    ----------
    tau : ndarray, shape (7,)
        Total joint torque [N·m], gravity included.
    ref_p : ndarray, shape (3,)
        Reference TCP position [m] (recorded).
    ref_R : ndarray, shape (3, 3)
        Reference TCP rotation (recorded).
    stop : str or None
        A reason to stop now (the controller loop's safety stop), or None.
    """

    tau: FloatArray
    ref_p: FloatArray
    ref_R: FloatArray  # noqa: N815 - R: the rotation matrix
    stop: str | None = None


# policy(cycle, robot time [s], state, model terms) -> PolicyOutput
TorquePolicy = Callable[[int, float, FrankaState, ModelTerms], PolicyOutput]


class _Cycles:
    """The loop's running state: clock, missed periods, last command, stop reason."""

    def __init__(self, arm: FrankaArm, n_steps: int, end_time: float | None) -> None:
        self.arm, self.n_steps, self.end_time = arm, n_steps, end_time
        self.rec = Recording(RECORDED, n_steps)
        self.i = 0  # cycles recorded
        self.t = 0.0  # robot time [s]
        self.missed = 0
        self.stop_reason: str | None = None
        self.tau_prev = np.zeros(N_JOINTS)  # torque mode starts from zero desired torque
        self.max_step = arm.config.max_torque_rate * CONTROL_PERIOD_S

    def clock(self, dt: float) -> None:
        """Advance robot time by the reported period ``dt`` [s]; the watchdog."""
        if self.i == 0:
            return
        self.t += dt
        self.missed += max(int(round(dt / CONTROL_PERIOD_S)) - 1, 0)
        if dt > self.arm.config.watchdog_s:
            self.stop_reason = f"watchdog: no robot state for {dt * 1e3:.0f} ms"

    def command(self, out: PolicyOutput, g: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Torque recorded (gravity included) and torque sent (rate-limited, minus ``g``)."""
        tau = out.tau
        if self.stop_reason is None and not np.isfinite(tau).all():
            self.stop_reason = "controller returned a non-finite torque"
        if self.stop_reason is None and out.stop is not None:
            self.stop_reason = out.stop
        if self.stop_reason is None:
            return tau, rate_limit(tau - g, self.tau_prev, self.max_step)
        # hold: zero desired torque (the robot keeps compensating gravity)
        sent = rate_limit(np.zeros(N_JOINTS), self.tau_prev, self.max_step)
        return (tau if np.isfinite(tau).all() else sent + g), sent  # what the joints get

    def last(self) -> bool:
        """Whether this cycle ends the motion (a stop, ``n_steps`` or the end time)."""
        return (
            self.stop_reason is not None
            or self.i == self.n_steps - 1
            or (self.end_time is not None and self.t >= self.end_time - 1e-9)
        )

    def record(self, state: FrankaState, out: PolicyOutput, tau: FloatArray, sent: FloatArray,
               dt: float, compute: float) -> None:  # fmt: skip
        """Row ``i`` of the recording."""
        a, k = self.rec.a, self.i
        a["t"][k], a["q"][k], a["dq"][k] = self.t, state.q, state.dq
        a["tau"][k], a["tau_sent"][k], a["tau_J"][k] = tau, sent, state.tau_J
        a["p"][k], a["R"][k] = state.O_T_EE[:3, 3], state.O_T_EE[:3, :3]
        a["ref_p"][k], a["ref_R"][k] = out.ref_p, out.ref_R
        a["period"][k], a["compute"][k] = dt, compute
        self.tau_prev = sent
        self.i += 1

    def rollout(self, gripper_width: float, meta: dict[str, Any]) -> Rollout | None:
        """The recorded cycles as a Rollout (None before the first)."""
        n = self.i
        if n == 0:
            return None
        a = self.rec.first(n, copy=True)
        return Rollout(
            t=a["t"], q=a["q"], dq=a["dq"], tau=a["tau"], ee_position=a["p"],
            ee_quaternion=quat_sign_continuous(quat_from_matrix(a["R"])),
            ref_position=a["ref_p"],
            ref_quaternion=quat_sign_continuous(quat_from_matrix(a["ref_R"])),
            gripper=np.full(n, gripper_width), meta=meta,
            extras={
                "orientation_error": rotation_angle(a["R"], a["ref_R"]),
                "tau_sent": a["tau_sent"], "tau_measured": a["tau_J"],
                "compute_s": a["compute"], "period_s": a["period"],
            },
        )  # fmt: skip


def run_torque_loop(
    arm: FrankaArm,
    policy: TorquePolicy,
    n_steps: int,
    *,
    end_time: float | None = None,
    gripper_width: float | None = None,
    meta: dict[str, Any] | None = None,
) -> tuple[Rollout, LoopStats]:
    """Run ``policy`` in the arm's torque read/write loop (1 kHz) with the safety layer.

    Per cycle: read the state, evaluate the model at it, ask the policy for the
    total torque, subtract the robot's own gravity compensation G(q), rate-limit
    (``max_torque_rate``) and saturate (``TAU_MAX``), send. The policy's stop
    request, a non-finite torque, a stalled state stream (``watchdog_s``), a
    reflex or error reported by the robot and a lost connection all end the
    motion: the robot is stopped and :class:`RobotStopped` raised with the
    rollout so far.

    Parameters
    ----------
    arm : FrankaArm
        A connected arm.
    policy : callable
        ``policy(i, t, state, terms)`` → :class:`PolicyOutput` for cycle ``i`` at
        robot time ``t`` [s]. Called once before the loop (``i = 0``) to warm
        caches, so it must restart whenever ``i == 0``.
    n_steps : int
        Most cycles to run (``n_steps`` ms of robot time when none is missed).
    end_time : float or None
        Robot time [s] at which the motion ends: the loop follows the robot's
        clock, so cycles missed by a busy host skip reference samples rather
        than slowing the motion down.
    gripper_width : float or None
        Finger opening recorded in the rollout [m]; default: read once before
        the loop (the hand cannot be read inside it, see
        :class:`~dexlfd.robot.franka_gripper.FrankaGripper`).
    meta : dict or None
        Extra ``meta`` for the rollout.

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
        On any early stop, with ``.rollout`` = the samples so far.
    """
    if n_steps < 1:
        raise InvalidInput(f"n_steps must be >= 1, got {n_steps}")
    model = arm.model
    if gripper_width is None:
        gripper_width = arm.gripper_width_or_zero()
    cyc = _Cycles(arm, n_steps, end_time)
    # warm-up outside the loop: a law's first call can take tens of ms (lazy
    # imports, caches); inside the loop that would stall the robot's command stream
    warm = arm.read_state()
    policy(0, 0.0, warm, model.terms_at(warm))
    wall0 = time.perf_counter()
    control = arm.torque_control()
    try:
        with control:  # leaving it releases libfranka's control lock
            _cycle_until_done(control, cyc, policy)
    except RobotLinkError as exc:
        cyc.stop_reason = str(exc)
    except BaseException:
        arm.stop_quietly()
        raise
    stats = LoopStats(
        cyc.i, time.perf_counter() - wall0, cyc.t, cyc.missed, cyc.rec.a["compute"][: cyc.i].copy()
    )
    return _finish(arm, cyc, stats, gripper_width, meta), stats


def _cycle_until_done(control: TorqueControl, cyc: _Cycles, policy: TorquePolicy) -> None:
    """The 1 kHz read → policy → write cycles of one motion (the stream drives them)."""
    model = cyc.arm.model
    listener = getattr(cyc.arm, "state_listener", None)

    def step(state: FrankaState, dt: float) -> tuple[FloatArray, bool]:
        c0 = time.perf_counter()
        cyc.clock(dt)
        terms = model.terms_at(state)
        out = policy(cyc.i, cyc.t, state, terms)
        tau, sent = cyc.command(out, terms.g)
        last = cyc.last()
        cyc.record(state, out, tau, sent, dt, time.perf_counter() - c0)
        if listener is not None:
            listener(cyc.t, state)
        return sent, last

    control.run(step, cyc.n_steps)


def _finish(
    arm: FrankaArm,
    cyc: _Cycles,
    stats: LoopStats,
    gripper_width: float,
    meta: dict[str, Any] | None,
) -> Rollout:
    """The rollout of a finished motion; stops the arm and raises on an early stop."""
    config = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(arm.config).items()}
    meta_out: dict[str, Any] = {
        "robot": f"{FRANKA_SCHEME}{arm.host}",
        "franka_binding": getattr(getattr(arm, "binding", None), "requirement", None),
        "franka_config": config,
        "torque_convention": "tau: controller output (gravity included); tau_sent = tau - G(q)",
        **(meta or {}),
        "loop": stats.summary(),
    }
    if cyc.stop_reason is not None:
        meta_out["stopped"] = cyc.stop_reason
        arm.stop_quietly()
        rollout = cyc.rollout(gripper_width, meta_out)
        logger.error("motion stopped after %d cycles: %s", cyc.i, cyc.stop_reason)
        raise RobotStopped(f"Franka at {arm.host}: motion stopped: {cyc.stop_reason}", rollout)
    rollout = cyc.rollout(gripper_width, meta_out)
    if rollout is None:  # pragma: no cover - n_steps >= 1 cycles always record one
        raise RobotStopped(f"Franka at {arm.host}: no cycle ran", None)
    logger.info(
        "tracked %d cycles: %.0f Hz, %d missed, compute median %.0f µs",
        stats.n_cycles, stats.rate_hz, stats.missed_cycles,
        stats.summary()["compute_us_median"],
    )  # fmt: skip
    return rollout
