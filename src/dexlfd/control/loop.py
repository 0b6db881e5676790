"""The 1 kHz tracking loop: a controller drives the simulated Panda along a plan.

:class:`TrackingSession` is the steppable loop (one ``step(reference)`` per
control tick, or ``run_until(t, reference_fn)``), for streaming references such
as teleoperation; :func:`track` runs a whole plan through one.

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
from typing import Any, ClassVar

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Controller, Reference, RobotState
from dexlfd.control.reference import ReferenceTrajectory, check_plan_workspace, resample_plan
from dexlfd.errors import InvalidInput, SimulationDiverged
from dexlfd.io import Plan, Rollout
from dexlfd.panda import DQ_MAX, DTAU_MAX, N_JOINTS, Q_MAX, Q_MIN
from dexlfd.robot.ik import solve_ik
from dexlfd.robot.model import RobotModel
from dexlfd.robot.sim import PandaSim, PlantConfig
from dexlfd.rotations import matrix_from_quat, quat_from_matrix, quat_sign_continuous

__all__ = [
    "LoopConfig",
    "TrackingSession",
    "TrackingStopped",
    "joint_reference",
    "track",
    "tracking_summary",
]

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

    Runs the plan, resampled at the control rate, through a
    :class:`TrackingSession` one tick at a time.

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
    check_plan_workspace(plan)
    dt = 1.0 / loop.rate_hz
    _substeps(dt, plant.timestep)
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
    session = TrackingSession(
        controller, model, plant, loop, rng=rng, q0=q0, gripper0=float(ref.gripper[0]),
        payload_at=payload_at, meta={"plan_meta": plan.meta}, noise_block=n, capacity=n,
    )  # fmt: skip
    with session:
        for k in range(n):
            r = Reference(
                ref.p[k], ref.v[k], ref.a[k], ref.R[k], ref.w[k],
                None if q_ref is None else q_ref[k],
                None if dq_ref is None else dq_ref[k],
            )  # fmt: skip
            session.step(r, float(ref.gripper[k]), ref.quat[k])
            if callback is not None and k % 100 == 0:
                callback(k, ref.t[k])
    return session.rollout()


def _substeps(dt: float, timestep: float) -> int:
    """Physics steps per control period; raises unless ``dt`` is a whole multiple."""
    n_sub_f = dt / timestep
    n_sub = int(round(n_sub_f))
    if n_sub < 1 or abs(n_sub_f - n_sub) > 1e-9:
        raise InvalidInput(
            f"control period {dt} s must be a whole multiple of the physics step {timestep} s"
        )
    return n_sub


class _Recording:
    """Per-tick samples in arrays that grow by doubling (no allocation per tick)."""

    FIELDS: ClassVar[dict[str, tuple[tuple[int, ...], Any]]] = {
        "t": ((), np.float64), "q": ((N_JOINTS,), np.float64),
        "dq": ((N_JOINTS,), np.float64), "tau": ((N_JOINTS,), np.float64),
        "tau_applied": ((N_JOINTS,), np.float64), "ee_position": ((3,), np.float64),
        "ee_R": ((3, 3), np.float64), "gripper": ((), np.float64),
        "attached": ((), np.bool_), "orientation_error": ((), np.float64),
        "payload_position": ((3,), np.float64), "payload_quaternion": ((4,), np.float64),
        "ref_position": ((3,), np.float64), "ref_quaternion": ((4,), np.float64),
        "ref_gripper": ((), np.float64),
    }  # fmt: skip

    def __init__(self, capacity: int) -> None:
        self.a = {k: np.zeros((capacity, *s), dtype=d) for k, (s, d) in self.FIELDS.items()}

    def ensure(self, k: int) -> None:
        """Make room for row ``k``."""
        cap = self.a["t"].shape[0]
        if k < cap:
            return
        new = max(2 * cap, k + 1)
        for key, arr in self.a.items():
            grown = np.zeros((new, *arr.shape[1:]), dtype=arr.dtype)
            grown[:cap] = arr
            self.a[key] = grown


class TrackingSession:
    """A steppable 1 kHz tracking loop on the simulated Panda (a context manager).

    :func:`track` runs a whole plan through one; streaming callers (e.g.
    teleoperation) feed references tick by tick with :meth:`step`, or let
    :meth:`run_until` ask a function for them. Per tick: safety checks on the
    true state, measurement noise, the controller on its nominal model, the
    libfranka-like torque rate limit and the torque delay, then the plant steps
    one control period. The gripper follows the referenced opening; the object
    is grasped when the opening first drops below ``loop.grasp_below`` (with
    ``regrasp``, again whenever it closes after a release) and released when
    it opens.

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
        self._n_sub = _substeps(self.dt, plant.timestep)
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
        self.regrasp = bool(regrasp)
        self.meta: dict[str, Any] = {
            "controller": controller.describe(),
            "plant": plant.describe(),
            "loop": asdict(loop),
            "model": getattr(model, "description", type(model).__name__),
            "rate_hz": loop.rate_hz,
            **(meta or {}),
            "stopped": None,
        }
        self._rec = _Recording(int(capacity))
        self.k = 0  # control ticks done
        self.stopped: str | None = None
        self._grasps = 0
        self._was_closed = False
        self._holding: bool | None = False  # None: this grasp already reported lost
        self.grasp_events: list[dict[str, Any]] = []  # missed grasps and drops
        self._lo = Q_MIN - loop.joint_limit_margin
        self._hi = Q_MAX + loop.joint_limit_margin
        self._max_step = (loop.torque_rate_limit or 0.0) / loop.rate_hz
        self._stack: contextlib.ExitStack | None = None
        self._sim: PandaSim | None = None

    # -- context manager -------------------------------------------------
    def __enter__(self) -> TrackingSession:
        stack = contextlib.ExitStack()
        try:
            stack.enter_context(_single_threaded_blas())
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
        self._delay = [hold.copy() for _ in range(int(self.loop.torque_delay))]
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
    def t(self) -> float:
        """Time of the next control tick [s]: ``k * dt``."""
        return self.k * self.dt

    # -- stepping --------------------------------------------------------
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

    def step(
        self, reference: Reference, gripper: float, quaternion: FloatArray | None = None
    ) -> None:
        """Run one control tick towards ``reference`` with finger opening ``gripper`` [m].

        ``quaternion`` (x, y, z, w) of ``reference.R`` is recorded as the
        reference orientation (computed from ``R`` when not given).

        Raises
        ------
        TrackingStopped
            The safety stop fired; ``exc.rollout`` holds the samples before it.
        """
        sim = self.sim
        if self.stopped is not None:
            raise InvalidInput(f"TrackingSession: stopped ({self.stopped}); cannot step on")
        loop, rec, k = self.loop, self._rec, self.k
        rec.ensure(k)
        a = rec.a
        t = k * self.dt
        a["t"][k] = t
        a["ref_position"][k] = reference.p
        a["ref_quaternion"][k] = quat_from_matrix(reference.R) if quaternion is None else quaternion
        a["ref_gripper"][k] = gripper
        st = sim.state()
        noise_q, noise_dq = self._noise(k)
        reason = None
        if not (np.isfinite(st.q).all() and np.isfinite(st.dq).all()):
            reason = "non-finite joint state (the simulation diverged)"
        elif ((st.q < self._lo) | (st.q > self._hi)).any():
            j = int(np.argmax((st.q < self._lo) | (st.q > self._hi)))
            reason = (
                f"joint {j + 1} position {st.q[j]:.4f} rad outside its limits "
                f"[{Q_MIN[j]:.4f}, {Q_MAX[j]:.4f}]"
            )
        elif (np.abs(st.dq) > DQ_MAX).any():
            j = int(np.argmax(np.abs(st.dq) > DQ_MAX))
            reason = f"joint {j + 1} velocity {st.dq[j]:.3f} rad/s beyond {DQ_MAX[j]} rad/s"
        p_true, R_true = sim.tcp_pose()
        err_p = float(np.linalg.norm(p_true - reference.p))
        E = R_true @ reference.R.T
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
            qm = st.q + noise_q
            dqm = st.dq + noise_dq
            terms = self.model.terms(qm, dqm)
            tau, self._cs = self.controller.step(self._cs, RobotState(t, qm, dqm), reference, terms)
            if not np.isfinite(tau).all():
                reason = "the controller returned a non-finite torque"
        if reason is not None:
            logger.warning("safety stop at t=%.3f s: %s", t, reason)
            self.stopped = f"{reason} (t={t:.3f} s)"
            raise TrackingStopped(reason, t, self.rollout(k))
        a["q"][k], a["dq"][k], a["tau"][k] = st.q, st.dq, tau
        a["ee_position"][k] = p_true
        a["ee_R"][k] = R_true
        a["orientation_error"][k] = err_r
        a["gripper"][k] = sim.gripper_opening
        pose = sim.payload_pose()
        if pose is not None:
            a["payload_position"][k], a["payload_quaternion"][k] = pose
        closed = gripper < loop.grasp_below
        if closed and not self._was_closed and (self.regrasp or self._grasps == 0):
            sim.grasp()
            self._grasps += 1
        elif self._grasps and sim.attached and not closed:
            sim.release()
        self._was_closed = closed
        # from values read above: no second pass over the MuJoCo data on the hot path
        holding = pose is not None and sim.holds(a["gripper"][k], pose[0], p_true)
        if sim.attached and not holding and self._holding is not None:
            event = "dropped" if self._holding else "missed"
            pos = sim.payload_position()
            dist = float(np.linalg.norm(pos - p_true)) if pos is not None else float("nan")
            logger.warning(
                "grasp %s at t=%.3f s: the object is %.3f m from the TCP, gripper %.3f m",
                event, t, dist, sim.gripper_opening,
            )  # fmt: skip
            self.grasp_events.append({"event": event, "t": t, "distance_m": dist})
            self._holding = None  # report once per grasp
        elif holding:
            self._holding = True
        elif not sim.attached:
            self._holding = False
        a["attached"][k] = holding
        sim.set_gripper(gripper)
        if loop.torque_rate_limit is not None:
            tau = np.clip(tau, self._tau_sent - self._max_step, self._tau_sent + self._max_step)
            a["tau"][k] = tau
        self._tau_sent = tau
        self._delay.append(tau)
        applied = self._delay.pop(0)
        a["tau_applied"][k] = applied
        sim.step(applied, self._n_sub)
        self.k = k + 1

    def run_until(
        self,
        t_end: float,
        reference_fn: Callable[[float], tuple[Reference, float, FloatArray | None]],
    ) -> int:
        """Step while the next tick's time is before ``t_end`` [s]; returns the ticks run.

        ``reference_fn(t)`` gives ``(reference, gripper, quaternion or None)``
        for tick time ``t`` [s].
        """
        n = 0
        eps = 1e-9 * self.dt
        while self.t < t_end - eps:
            r, g, quat = reference_fn(self.t)
            self.step(r, g, quat)
            n += 1
        return n

    def rollout(self, k_end: int | None = None) -> Rollout:
        """The recorded samples (the first ``k_end``, default all done) as a Rollout."""
        k_end = self.k if k_end is None else k_end
        m = dict(self.meta, stopped=self.stopped, grasp_events=list(self.grasp_events))
        k_end = max(k_end, 1)
        a = {key: arr[:k_end] for key, arr in self._rec.a.items()}
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


def object_report(
    t: FloatArray, p: FloatArray, quat: FloatArray, attached: FloatArray
) -> dict[str, Any]:
    """Where the object ended and how hard it met the surface.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Tick times [s].
    p, quat : ndarray, shape (n, 3), (n, 4)
        Object centre [m] and orientation (x, y, z, w) per tick.
    attached : ndarray, shape (n,)
        True while the object was really in the hand.

    Returns
    -------
    dict
        ``final_position`` [m], ``final_quaternion``, ``tilt_deg`` (angle between
        its z axis now and at the start, when it stood on its support [deg]),
        ``released_t`` [s] (when the hand last let go,
        None if it never held it), ``release_speed`` [m/s] (object speed then) and
        ``impact_speed`` [m/s]: the object's downward speed (largest within 10 ms)
        when it first came within 2 mm of its resting height after it was last
        carried 2 cm or more above it: the speed it met the surface with (a dropped
        object hits at sqrt(2 g h), a placed one at the speed it was lowered);
        ``touch_speed`` [m/s] the same for its whole velocity (sliding included).
    """
    n = t.shape[0]
    # tilt from how it stood at the start (on its support, upright)
    R_rel = matrix_from_quat(quat[0]).T @ matrix_from_quat(quat[-1])
    report: dict[str, Any] = {
        "final_position": p[-1].tolist(),
        "final_quaternion": quat[-1].tolist(),
        "tilt_deg": float(np.degrees(np.arccos(np.clip(R_rel[2, 2], -1.0, 1.0)))),
        "released_t": None,
        "release_speed": None,
        "impact_speed": None,
        "touch_speed": None,
    }
    held = np.flatnonzero(attached)
    if held.size == 0 or n < 3:
        return report
    k_rel = int(held[-1]) + 1
    if k_rel >= n:
        return report  # still in the hand at the end
    vel = np.gradient(p, t, axis=0)
    v = np.linalg.norm(vel, axis=1)
    v_down = np.maximum(-vel[:, 2], 0.0)  # speed into a horizontal surface
    z_rest = p[-1, 2]
    # the last time, while held, it was 2 cm or more above where it came to rest
    high = np.flatnonzero(p[held, 2] > z_rest + 0.02)
    k0 = int(held[high[-1]]) if high.size else k_rel
    k0 = min(k0, k_rel)
    touch = np.flatnonzero(p[k0:, 2] <= z_rest + 2e-3)
    k1 = k0 + (int(touch[0]) if touch.size else n - 1 - k0)
    w = max(1, int(round(0.01 / max(float(t[1] - t[0]), 1e-9))))  # +-10 ms
    report.update(
        released_t=float(t[k_rel]),
        release_speed=float(v[k_rel]),
        impact_speed=float(v_down[max(0, k1 - w) : k1 + w + 1].max()),
        touch_speed=float(v[max(0, k1 - w) : k1 + w + 1].max()),
    )
    return report


def tracking_summary(rollout: Rollout) -> dict[str, float]:
    """TCP position error RMS and max [m], orientation error max [rad] of a rollout."""
    err = np.linalg.norm(rollout.ee_position - rollout.ref_position, axis=1)
    rot = rollout.extras.get("orientation_error", np.zeros(1))
    return {
        "position_rms_m": float(np.sqrt(np.mean(err**2))),
        "position_max_m": float(err.max()),
        "orientation_max_rad": float(np.max(rot)),
    }
