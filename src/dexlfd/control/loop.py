"""The 1 kHz tracking loop: a controller drives the simulated Panda along a plan.

Per control tick: read the plant's joint state, add measurement noise, evaluate
the controller's *nominal* model at the measured state, run the control law,
and apply the torque after a configurable delay (one tick by default: the
command computed at tick k acts during tick k+1, as on the real robot). The
gripper follows the plan's opening; the object is grasped when the opening
first drops below ``grasp_below`` and released when it opens again.

Safety stop: the loop raises :class:`TrackingStopped` (a
:class:`~dexlfd.errors.SimulationDiverged`) with the reason and time on a
non-finite state or torque, a joint position or velocity limit violation, or a
TCP tracking error beyond the bounds. The rollout up to the stop is attached to
the exception (``exc.rollout``) with ``meta["stopped"]`` set.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Controller, Reference, RobotState
from dexlfd.control.reference import ReferenceTrajectory, check_workspace, resample_plan
from dexlfd.errors import InvalidInput, SimulationDiverged
from dexlfd.io import Plan, Rollout
from dexlfd.robot.ik import solve_ik
from dexlfd.robot.model import RobotModel
from dexlfd.robot.panda import DQ_MAX, DTAU_MAX, N_JOINTS, Q_MAX, Q_MIN
from dexlfd.robot.sim import PandaSim, PlantConfig
from dexlfd.rotations import quat_from_matrix, quat_sign_continuous

__all__ = ["LoopConfig", "TrackingStopped", "joint_reference", "track", "tracking_summary"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class LoopConfig:
    """Settings of the control loop and of the sensing it sees.

    Attributes
    ----------
    rate_hz : float
        Control rate [Hz]; the plant's time step must divide its period.
    q_noise, dq_noise : float
        Standard deviation of the joint position [rad] and velocity [rad/s]
        measurement noise (Gaussian, white).
    torque_delay : int
        Control ticks between computing a torque and the plant applying it.
    torque_rate_limit : float or None
        Commanded torques change by at most this [N·m/s] per tick, as libfranka's
        ``limit_rate`` does (its default: on, 1000 N·m/s); None switches it off.
    max_position_error : float
        TCP position error [m] that triggers the safety stop.
    max_orientation_error : float
        TCP orientation error [rad] that triggers the safety stop.
    joint_limit_margin : float
        Tolerance [rad] beyond the joint limits before the stop.
    grasp_below : float
        Gripper opening [m] below which the plan is grasping.
    """

    rate_hz: float = 1000.0
    q_noise: float = 1e-5
    dq_noise: float = 1e-3
    torque_delay: int = 1
    torque_rate_limit: float | None = DTAU_MAX
    max_position_error: float = 0.1
    max_orientation_error: float = 0.6
    joint_limit_margin: float = 0.01
    grasp_below: float = 0.06

    def __post_init__(self) -> None:
        for name in ("rate_hz", "q_noise", "dq_noise", "torque_delay", "max_position_error"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float | np.number):
                raise InvalidInput(f"LoopConfig.{name} must be a number, got {v!r}")
        for name in ("rate_hz", "max_position_error", "max_orientation_error", "grasp_below"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InvalidInput(f"LoopConfig.{name} must be > 0, got {v!r}")
        for name in ("q_noise", "dq_noise", "joint_limit_margin"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise InvalidInput(f"LoopConfig.{name} must be >= 0, got {v!r}")
        if self.torque_rate_limit is not None and not (
            np.isfinite(self.torque_rate_limit) and self.torque_rate_limit > 0
        ):
            raise InvalidInput(
                f"LoopConfig.torque_rate_limit must be > 0 or None, got {self.torque_rate_limit!r}"
            )
        if int(self.torque_delay) != self.torque_delay or self.torque_delay < 0:
            raise InvalidInput(
                f"LoopConfig.torque_delay must be an integer >= 0, got {self.torque_delay!r}"
            )


class TrackingStopped(SimulationDiverged):
    """The safety stop fired; ``rollout`` holds the samples up to the stop."""

    def __init__(self, reason: str, t: float, rollout: Rollout) -> None:
        super().__init__(f"safety stop at t={t:.3f} s: {reason}")
        self.reason = reason
        self.time = t
        self.rollout = rollout


def _single_threaded_blas() -> Any:
    """Limit BLAS/LAPACK to one thread for the loop (if threadpoolctl is present).

    The per-tick matrices are 3×3 to 7×7: waking BLAS threads only adds latency,
    and on a loaded machine a 6×6 inverse went from 3 µs to ~40 µs.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - comes with scikit-learn
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def joint_reference(
    model: RobotModel, ref: ReferenceTrajectory, q0: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Joint positions (n, 7) [rad] and velocities (n, 7) [rad/s] along ``ref`` by IK.

    Each sample is solved from the previous one (warm start), so the branch
    stays continuous.
    """
    qs = np.empty((ref.n, N_JOINTS))
    q = q0
    for k in range(ref.n):
        q = solve_ik(model, ref.p[k], ref.R[k], q, max_iter=50).q
        qs[k] = q
    dqs = np.gradient(qs, ref.t, axis=0)
    return qs, dqs


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
) -> Rollout:
    """Track ``plan`` with ``controller`` on the simulated Panda.

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
    check_workspace(plan)
    dt = 1.0 / loop.rate_hz
    n_sub_f = dt / plant.timestep
    n_sub = int(round(n_sub_f))
    if n_sub < 1 or abs(n_sub_f - n_sub) > 1e-9:
        raise InvalidInput(
            f"control period {dt} s must be a whole multiple of the physics step {plant.timestep} s"
        )
    ref = resample_plan(plan, dt)
    if q0 is None:
        ik = solve_ik(model, ref.p[0], ref.R[0])
        if not ik.converged:
            raise InvalidInput(
                f"no inverse-kinematics solution for the plan's first pose "
                f"{np.round(ref.p[0], 3).tolist()} m (residual {ik.position_error:.2e} m, "
                f"{ik.rotation_error:.2e} rad)"
            )
        q0 = ik.q
    q_ref = dq_ref = None
    if controller.needs_joint_reference:
        q_ref, dq_ref = joint_reference(model, ref, q0)

    closed = ref.gripper < loop.grasp_below
    k_grasp = int(np.argmax(closed)) if closed.any() else -1
    if plant.payload_kg > 0 and k_grasp < 0:
        logger.warning("the plan never closes the gripper: the object is not picked up")
    payload_at = (ref.p[max(k_grasp, 0)], ref.R[max(k_grasp, 0)])

    n = ref.n
    rec = {
        "q": np.zeros((n, N_JOINTS)), "dq": np.zeros((n, N_JOINTS)),
        "tau": np.zeros((n, N_JOINTS)), "tau_applied": np.zeros((n, N_JOINTS)),
        "ee_position": np.zeros((n, 3)), "ee_quaternion": np.zeros((n, 4)),
        "gripper": np.zeros(n), "attached": np.zeros(n, dtype=bool),
        "orientation_error": np.zeros(n),
        "payload_position": np.zeros((n, 3)), "payload_quaternion": np.zeros((n, 4)),
    }  # fmt: skip
    ee_R = np.zeros((n, 3, 3))
    noise_q = rng.normal(0.0, loop.q_noise, (n, N_JOINTS)) if loop.q_noise else np.zeros((n, 7))
    noise_dq = rng.normal(0.0, loop.dq_noise, (n, N_JOINTS)) if loop.dq_noise else np.zeros((n, 7))
    meta: dict[str, Any] = {
        "controller": controller.describe(),
        "plant": plant.describe(),
        "loop": asdict(loop),
        "model": getattr(model, "description", type(model).__name__),
        "rate_hz": loop.rate_hz,
        "plan_meta": plan.meta,
        "stopped": None,
    }

    def finish(k_end: int, stopped: str | None) -> Rollout:
        m = dict(meta, stopped=stopped)
        k_end = max(k_end, 1)
        rec["ee_quaternion"][:k_end] = quat_sign_continuous(quat_from_matrix(ee_R[:k_end]))
        return Rollout(
            t=ref.t[:k_end], q=rec["q"][:k_end], dq=rec["dq"][:k_end], tau=rec["tau"][:k_end],
            ee_position=rec["ee_position"][:k_end], ee_quaternion=rec["ee_quaternion"][:k_end],
            ref_position=ref.p[:k_end], ref_quaternion=ref.quat[:k_end],
            gripper=rec["gripper"][:k_end], meta=m,
            extras={
                "tau_applied": rec["tau_applied"][:k_end], "attached": rec["attached"][:k_end],
                "orientation_error": rec["orientation_error"][:k_end],
                "ref_gripper": ref.gripper[:k_end],
                **(
                    {
                        "payload_position": rec["payload_position"][:k_end],
                        "payload_quaternion": rec["payload_quaternion"][:k_end],
                    }
                    if plant.payload_kg > 0
                    else {}
                ),
            },
        )  # fmt: skip

    lo, hi = Q_MIN - loop.joint_limit_margin, Q_MAX + loop.joint_limit_margin
    with (
        _single_threaded_blas(),
        PandaSim(plant, q0, payload_at=payload_at, gripper0=float(ref.gripper[0])) as sim,
    ):
        st0 = sim.state()
        cs = controller.init(RobotState(0.0, st0.q, st0.dq), model.terms(st0.q, st0.dq))
        hold = model.terms(st0.q, np.zeros(N_JOINTS)).g  # before the first command: hold
        delay = [hold.copy() for _ in range(int(loop.torque_delay))]
        tau_sent = hold.copy()
        max_step = (loop.torque_rate_limit or 0.0) / loop.rate_hz
        for k in range(n):
            st = sim.state()
            t = ref.t[k]
            reason = None
            if not (np.isfinite(st.q).all() and np.isfinite(st.dq).all()):
                reason = "non-finite joint state (the simulation diverged)"
            elif ((st.q < lo) | (st.q > hi)).any():
                j = int(np.argmax((st.q < lo) | (st.q > hi)))
                reason = (
                    f"joint {j + 1} position {st.q[j]:.4f} rad outside its limits "
                    f"[{Q_MIN[j]:.4f}, {Q_MAX[j]:.4f}]"
                )
            elif (np.abs(st.dq) > DQ_MAX).any():
                j = int(np.argmax(np.abs(st.dq) > DQ_MAX))
                reason = f"joint {j + 1} velocity {st.dq[j]:.3f} rad/s beyond {DQ_MAX[j]} rad/s"
            p_true, R_true = sim.tcp_pose()
            err_p = float(np.linalg.norm(p_true - ref.p[k]))
            E = R_true @ ref.R[k].T
            err_r = float(np.arccos(np.clip(0.5 * (np.trace(E) - 1.0), -1.0, 1.0)))
            if reason is None and err_p > loop.max_position_error:
                reason = (
                    f"TCP position error {err_p:.4f} m beyond the bound {loop.max_position_error} m"
                )
            elif reason is None and err_r > loop.max_orientation_error:
                reason = (
                    f"TCP orientation error {err_r:.3f} rad beyond the bound "
                    f"{loop.max_orientation_error} rad"
                )
            if reason is None:
                qm = st.q + noise_q[k]
                dqm = st.dq + noise_dq[k]
                terms = model.terms(qm, dqm)
                r = Reference(
                    ref.p[k], ref.v[k], ref.a[k], ref.R[k], ref.w[k],
                    None if q_ref is None else q_ref[k],
                    None if dq_ref is None else dq_ref[k],
                )  # fmt: skip
                tau, cs = controller.step(cs, RobotState(t, qm, dqm), r, terms)
                if not np.isfinite(tau).all():
                    reason = "the controller returned a non-finite torque"
            if reason is not None:
                logger.warning("safety stop at t=%.3f s: %s", t, reason)
                raise TrackingStopped(reason, t, finish(k, f"{reason} (t={t:.3f} s)"))
            rec["q"][k], rec["dq"][k], rec["tau"][k] = st.q, st.dq, tau
            rec["ee_position"][k] = p_true
            ee_R[k] = R_true
            rec["orientation_error"][k] = err_r
            rec["gripper"][k] = sim.gripper_opening
            pose = sim.payload_pose()
            if pose is not None:
                rec["payload_position"][k], rec["payload_quaternion"][k] = pose
            if k == k_grasp:
                sim.grasp()
            elif k_grasp >= 0 and k > k_grasp and sim.attached and not closed[k]:
                sim.release()
            rec["attached"][k] = sim.attached
            sim.set_gripper(ref.gripper[k])
            if loop.torque_rate_limit is not None:
                tau = np.clip(tau, tau_sent - max_step, tau_sent + max_step)
                rec["tau"][k] = tau
            tau_sent = tau
            delay.append(tau)
            applied = delay.pop(0)
            rec["tau_applied"][k] = applied
            sim.step(applied, n_sub)
            if callback is not None and k % 100 == 0:
                callback(k, t)
    return finish(n, None)


def tracking_summary(rollout: Rollout) -> dict[str, float]:
    """TCP position error RMS and max [m], orientation error max [rad] of a rollout."""
    err = np.linalg.norm(rollout.ee_position - rollout.ref_position, axis=1)
    rot = rollout.extras.get("orientation_error", np.zeros(1))
    return {
        "position_rms_m": float(np.sqrt(np.mean(err**2))),
        "position_max_m": float(err.max()),
        "orientation_max_rad": float(np.max(rot)),
    }
