"""Real-arm backend over the Franka Control Interface (libfranka's Python bindings).

:class:`FrankaArm` connects to a Franka arm (or a Franka-protocol simulator) with
the official bindings ``pylibfranka`` (libfranka 0.21.x, robot protocol 10),
reads its state, exposes libfranka's model library as a
:class:`~dexlfd.robot.model.RobotModel` (:class:`FrankaModel`), and runs a
torque policy in libfranka's read/write loop at 1 kHz behind a safety layer
(:meth:`FrankaArm.run_torque_loop`); :mod:`dexlfd.control.franka` puts our
controllers and plans into that loop. The gripper is :class:`FrankaGripper`.

Torque convention. Our controllers return the *total* joint torque, gravity
included (what a plant without gravity compensation needs). A Franka adds its
own gravity compensation ``G(q)`` (from the same model library, including the
hand and any load set with ``set_load``) to the commanded ``tau_J_d``, so the
backend sends ``tau - G(q)``. With that, a law behaves the same on the
MuJoCo plant and on the arm.

Safety. Before a motion the collision thresholds are set (a crossing makes the
robot stop itself with a reflex); every command is saturated to the Panda's
torque limits and rate-limited to Franka's 1000 N·m/s; a watchdog stops the
motion when the robot's state stream stalls; the controller's own safety stop
(non-finite state or torque, excessive tracking error) ends the motion. Any
stop — ours, a reflex reported by the robot, a dropped connection — raises
:class:`RobotStopped`, which carries the rollout recorded up to the stop.

References
----------
.. [1] Franka Robotics, libfranka 0.21 and pylibfranka documentation,
   https://frankarobotics.github.io/docs/ ("Control parameters", "libfranka").
"""

from __future__ import annotations

import ipaddress
import logging
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from types import ModuleType, TracebackType
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import DependencyNotInstalled, DexlfdError, InvalidInput, SimulationDiverged
from dexlfd.io import Rollout
from dexlfd.panda import DTAU_MAX, N_JOINTS, TAU_MAX
from dexlfd.robot.kinematics import dh_flange
from dexlfd.robot.model import ModelTerms
from dexlfd.rotations import quat_from_matrix, quat_sign_continuous

__all__ = [
    "FRANKA_SCHEME",
    "PYLIBFRANKA_REQUIREMENT",
    "FrankaArm",
    "FrankaConfig",
    "FrankaGripper",
    "FrankaModel",
    "FrankaState",
    "LoopStats",
    "PolicyOutput",
    "RobotConnectionError",
    "RobotStopped",
    "TorquePolicy",
    "import_pylibfranka",
    "parse_robot_url",
    "rate_limit",
]

logger = logging.getLogger(__name__)

PYLIBFRANKA_REQUIREMENT = "pylibfranka==0.21.3"
FRANKA_SCHEME = "franka://"
ROBOT_PROTOCOL_VERSION = 10  # libfranka 0.21.x speaks robot protocol 10
CONTROL_PERIOD_S = 1e-3  # [s] libfranka's control cycle
MAX_TORQUE_RATE = DTAU_MAX  # [N·m/s] libfranka's kMaxTorqueRate, every joint
STANDARD_GRAVITY = np.array([0.0, 0.0, -9.81])  # [m/s²] base frame
_HOST_RE = re.compile(
    r"^(?=.{1,253}$)[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?(\.[A-Za-z0-9-]+)*$"
)


class RobotConnectionError(DexlfdError):
    """The arm cannot be reached, refuses the connection or speaks another protocol version."""


class RobotStopped(SimulationDiverged):
    """A motion on the arm ended early; ``rollout`` holds the samples up to the stop."""

    def __init__(self, message: str, rollout: Rollout | None) -> None:
        super().__init__(message)
        self.rollout = rollout


def import_pylibfranka() -> ModuleType:
    """Import ``pylibfranka`` or raise :class:`DependencyNotInstalled` naming the pin."""
    try:
        import pylibfranka
    except ImportError as exc:
        raise DependencyNotInstalled(PYLIBFRANKA_REQUIREMENT, "the real-arm (Franka) path") from exc
    return pylibfranka


def parse_robot_url(url: str) -> str:
    """Host of a ``franka://HOST`` robot address (an IPv4 address or a host name).

    Raises
    ------
    InvalidInput
        If ``url`` is not of that form.
    """
    if not isinstance(url, str) or not url.startswith(FRANKA_SCHEME):
        raise InvalidInput(f"--robot must be 'mujoco' or 'franka://HOST', got {url!r}")
    host = url[len(FRANKA_SCHEME) :].rstrip("/")
    try:
        ipaddress.IPv4Address(host)
        return host
    except ValueError:
        pass
    if not _HOST_RE.match(host) or host.replace(".", "").isdigit():
        raise InvalidInput(
            f"--robot franka://HOST needs an IPv4 address or host name, got {host!r} in {url!r}"
        )
    return host


@dataclass(frozen=True, slots=True)
class FrankaConfig:
    """Safety and connection settings of the real-arm path.

    The collision thresholds are those of libfranka's examples
    (``setDefaultBehavior``); a contact torque/force above the upper ones makes
    the robot stop with a reflex.
    """

    lower_torque_thresholds: tuple[float, ...] = (20.0, 20.0, 18.0, 18.0, 16.0, 14.0, 12.0)
    upper_torque_thresholds: tuple[float, ...] = (20.0, 20.0, 18.0, 18.0, 16.0, 14.0, 12.0)
    lower_force_thresholds: tuple[float, ...] = (20.0, 20.0, 20.0, 25.0, 25.0, 25.0)  # N, N·m
    upper_force_thresholds: tuple[float, ...] = (20.0, 20.0, 20.0, 25.0, 25.0, 25.0)
    max_torque_rate: float = MAX_TORQUE_RATE  # [N·m/s]
    # [s] longest tolerated gap between two robot states: below libfranka's 1 s network
    # timeout, above the stalls of a busy non-real-time host (measured up to ~0.2 s)
    watchdog_s: float = 0.25
    realtime: bool = False  # True: libfranka's kEnforce (needs a real-time kernel)
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)  # [m/s²]

    def __post_init__(self) -> None:
        for name, n in (
            ("lower_torque_thresholds", N_JOINTS),
            ("upper_torque_thresholds", N_JOINTS),
            ("lower_force_thresholds", 6),
            ("upper_force_thresholds", 6),
        ):
            v = np.asarray(getattr(self, name), dtype=np.float64)
            if v.shape != (n,) or not np.isfinite(v).all() or (v <= 0).any():
                raise InvalidInput(f"FrankaConfig.{name} must be {n} values > 0, got {v.tolist()}")
        if not (np.isfinite(self.max_torque_rate) and self.max_torque_rate > 0):
            raise InvalidInput(
                f"FrankaConfig.max_torque_rate must be > 0 N·m/s, got {self.max_torque_rate}"
            )
        if not (np.isfinite(self.watchdog_s) and self.watchdog_s >= 2 * CONTROL_PERIOD_S):
            raise InvalidInput(f"FrankaConfig.watchdog_s must be >= 0.002 s, got {self.watchdog_s}")


@dataclass(frozen=True, slots=True)
class FrankaState:
    """One robot state, converted from libfranka's column-major lists.

    Attributes
    ----------
    q, dq, tau_J : ndarray, shape (7,)
        Joint positions [rad], velocities [rad/s], measured link-side torques [N·m].
    O_T_EE : ndarray, shape (4, 4)
        Base-to-end-effector (TCP) transform, translation [m].
    F_T_EE : ndarray, shape (4, 4)
        Flange-to-end-effector transform (the configured hand/TCP).
    mode : str
        Robot mode (``"Idle"``, ``"Move"``, ``"Reflex"``, ...).
    errors : str
        Active error flags as libfranka prints them (``"[]"`` when none).
    """

    q: FloatArray
    dq: FloatArray
    tau_J: FloatArray  # noqa: N815 - libfranka's name
    O_T_EE: FloatArray
    F_T_EE: FloatArray
    mode: str
    errors: str


def _state_from(raw: Any) -> FrankaState:
    return FrankaState(
        q=np.array(raw.q),
        dq=np.array(raw.dq),
        tau_J=np.array(raw.tau_J),
        O_T_EE=np.array(raw.O_T_EE).reshape(4, 4, order="F"),
        F_T_EE=np.array(raw.F_T_EE).reshape(4, 4, order="F"),
        mode=str(raw.robot_mode).rsplit(".", 1)[-1],
        errors=str(raw.current_errors),
    )


class FrankaModel:
    """libfranka's model library behind the :class:`~dexlfd.robot.model.RobotModel` interface.

    M, C·q̇, G and the zero Jacobian of the end-effector frame come from the
    robot's model (column-major flat lists, reshaped here); J̇q̇ is a central
    difference of that Jacobian along q̇ (libfranka has no J̇); the TCP pose of
    an arbitrary ``q`` comes from the DH table (Table 3.1, identical for Panda
    and FR3) times the robot's flange-to-TCP transform ``F_T_EE``, while
    :meth:`terms_at` uses the pose the robot itself reports.

    Parameters
    ----------
    model : pylibfranka.Model
        From ``Robot.load_model()``.
    state : pylibfranka.RobotState
        A state of that robot; a private scratch copy is kept, whose ``q``/``dq``
        are overwritten per call (the model reads the end-effector mass,
        ``F_T_EE`` and the load from it).
    gravity : ndarray, shape (3,)
        Gravity acceleration in the base frame [m/s²]. Used when the robot
        reports zero base acceleration ``O_ddP_O`` (the protocol simulators do).
    """

    n_joints = N_JOINTS

    def __init__(self, model: Any, state: Any, gravity: FloatArray = STANDARD_GRAVITY) -> None:
        self._model = model
        self._scratch = state
        reported = np.array(state.O_ddP_O)
        self.gravity_vector = reported if np.linalg.norm(reported) > 1.0 else np.asarray(gravity)
        if np.linalg.norm(reported) <= 1.0:
            logger.info(
                "robot reports base acceleration %s; computing gravity with %s m/s²",
                reported.tolist(),
                np.asarray(gravity).tolist(),
            )
        self._scratch.O_ddP_O = self.gravity_vector.tolist()
        self.F_T_EE = np.array(state.F_T_EE).reshape(4, 4, order="F")
        self._fd_step = 1e-6  # [rad] central-difference step for J̇q̇ (error O(step²))

    def _set(self, q: FloatArray, dq: FloatArray) -> None:
        self._scratch.q = q.tolist()
        self._scratch.dq = dq.tolist()

    def _jacobian(self) -> FloatArray:
        return np.array(self._model.zero_jacobian(self._scratch)).reshape(6, N_JOINTS, order="F")

    def _jdq(self, q: FloatArray, dq: FloatArray) -> FloatArray:
        speed = float(np.linalg.norm(dq))
        if speed < 1e-12:
            return np.zeros(6)
        u = dq / speed
        h = self._fd_step
        self._scratch.q = (q + h * u).tolist()
        J_plus = self._jacobian()
        self._scratch.q = (q - h * u).tolist()
        J_minus = self._jacobian()
        self._scratch.q = q.tolist()
        # dJ/dt = Σ ∂J/∂q_i q̇_i = |q̇| · (directional derivative along u)
        return ((J_plus - J_minus) / (2 * h)) @ dq * speed

    def _dynamics(self, q: FloatArray, dq: FloatArray) -> tuple[FloatArray, ...]:
        self._set(q, dq)
        m = self._model
        M = np.array(m.mass(self._scratch)).reshape(N_JOINTS, N_JOINTS, order="F")
        c = np.array(m.coriolis(self._scratch))
        g = np.array(m.gravity(self._scratch))
        J = self._jacobian()
        return M, c, g, J, self._jdq(q, dq)

    def terms(self, q: FloatArray, dq: FloatArray) -> ModelTerms:
        """Model terms at ``(q, dq)``; the TCP pose from the DH table and ``F_T_EE``."""
        M, c, g, J, Jdq = self._dynamics(q, dq)
        p, R = self.tcp_pose(q)
        return ModelTerms(M=M, h=c + g, g=g, J=J, Jdq=Jdq, p=p, R=R)

    def terms_at(self, state: FrankaState) -> ModelTerms:
        """Model terms at a measured state, with the TCP pose the robot reports."""
        M, c, g, J, Jdq = self._dynamics(state.q, state.dq)
        T = state.O_T_EE
        return ModelTerms(M=M, h=c + g, g=g, J=J, Jdq=Jdq, p=T[:3, 3].copy(), R=T[:3, :3].copy())

    def tcp_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """TCP position (3,) [m] and rotation (3, 3) at ``q``."""
        T = dh_flange(np.asarray(q, dtype=np.float64)) @ self.F_T_EE
        return T[:3, 3].copy(), T[:3, :3].copy()

    def tcp_jacobian(self, q: FloatArray) -> FloatArray:
        """Zero Jacobian (6, 7) of the end-effector frame at ``q``."""
        self._set(np.asarray(q, dtype=np.float64), np.zeros(N_JOINTS))
        return self._jacobian()


def rate_limit(tau: FloatArray, tau_prev: FloatArray, max_step: float) -> FloatArray:
    """Limit each joint's torque change per cycle to ``max_step`` [N·m], then to ``TAU_MAX``."""
    return np.clip(tau_prev + np.clip(tau - tau_prev, -max_step, max_step), -TAU_MAX, TAU_MAX)


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


def _rotation_angle(R: FloatArray, R_d: FloatArray) -> FloatArray:
    """Angle [rad] of ``R R_dᵀ`` for stacks of rotation matrices ``(n, 3, 3)``."""
    tr = np.einsum("nij,nij->n", R, R_d)  # trace(R R_dᵀ)
    return np.arccos(np.clip(0.5 * (tr - 1.0), -1.0, 1.0))


class _Recorder:
    """Preallocated per-cycle arrays; ``rollout`` keeps only the filled part."""

    def __init__(self, n: int) -> None:
        self.i = 0
        self.t = np.zeros(n)
        self.q = np.zeros((n, N_JOINTS))
        self.dq = np.zeros((n, N_JOINTS))
        self.tau = np.zeros((n, N_JOINTS))
        self.tau_sent = np.zeros((n, N_JOINTS))
        self.tau_J = np.zeros((n, N_JOINTS))
        self.p = np.zeros((n, 3))
        self.R = np.zeros((n, 3, 3))
        self.ref_p = np.zeros((n, 3))
        self.ref_R = np.zeros((n, 3, 3))
        self.compute = np.zeros(n)
        self.period = np.zeros(n)

    def rollout(self, gripper_width: float, meta: dict[str, Any]) -> Rollout | None:
        n = self.i
        if n == 0:
            return None
        return Rollout(
            t=self.t[:n].copy(),
            q=self.q[:n].copy(),
            dq=self.dq[:n].copy(),
            tau=self.tau[:n].copy(),
            ee_position=self.p[:n].copy(),
            ee_quaternion=quat_sign_continuous(quat_from_matrix(self.R[:n])),
            ref_position=self.ref_p[:n].copy(),
            ref_quaternion=quat_sign_continuous(quat_from_matrix(self.ref_R[:n])),
            gripper=np.full(n, gripper_width),
            meta=meta,
            extras={
                "orientation_error": _rotation_angle(self.R[:n], self.ref_R[:n]),
                "tau_sent": self.tau_sent[:n].copy(),
                "tau_measured": self.tau_J[:n].copy(),
                "compute_s": self.compute[:n].copy(),
                "period_s": self.period[:n].copy(),
            },
        )


class FrankaGripper:
    """The Franka Hand over its own protocol (port 1338).

    Every command blocks until the hand finishes, and pylibfranka holds
    Python's GIL while it waits (measured: a grasp stalls a concurrent
    1 kHz loop for 0.7 s), so gripper commands run between arm motions.
    """

    def __init__(self, host: str, plf: ModuleType) -> None:
        self._plf = plf
        try:
            self._gripper = plf.Gripper(host)
        except Exception as exc:
            raise RobotConnectionError(f"gripper at {host}: {exc}") from exc
        self.host = host

    def _call(self, what: str, fn: Callable[[], bool]) -> bool:
        try:
            ok = bool(fn())
        except Exception as exc:
            raise RobotConnectionError(f"gripper at {self.host}: {what} failed: {exc}") from exc
        logger.info("gripper %s -> %s (width %.4f m)", what, ok, self.width())
        return ok

    def homing(self) -> bool:
        """Calibrate the fingers (moves to the maximum width and back)."""
        return self._call("homing", self._gripper.homing)

    def move(self, width: float, speed: float = 0.05) -> bool:
        """Move the fingers to ``width`` [m] at ``speed`` [m/s]."""
        if not (0.0 <= width <= 0.08 and 0.0 < speed <= 0.2):
            raise InvalidInput(
                "gripper move: width must be in [0, 0.08] m and speed in (0, 0.2] m/s, "
                f"got {width}, {speed}"
            )
        return self._call(f"move({width:.4f})", lambda: self._gripper.move(width, speed))

    def grasp(
        self,
        width: float = 0.0,
        speed: float = 0.05,
        force: float = 40.0,
        epsilon_inner: float = 0.08,
        epsilon_outer: float = 0.08,
    ) -> bool:
        """Close on an object: True if it is held with a width in [width − ε_in, width + ε_out]."""
        if not (0.0 <= width <= 0.08 and 0.0 < speed <= 0.2 and 0.0 < force <= 140.0):
            raise InvalidInput(
                f"gripper grasp: width in [0, 0.08] m, speed in (0, 0.2] m/s, force in (0, 140] N; "
                f"got {width}, {speed}, {force}"
            )
        return self._call(
            f"grasp({width:.4f}, {force:.0f} N)",
            lambda: self._gripper.grasp(width, speed, force, epsilon_inner, epsilon_outer),
        )

    def width(self) -> float:
        """Current finger opening [m]."""
        try:
            return float(self._gripper.read_once().width)
        except Exception as exc:
            raise RobotConnectionError(f"gripper at {self.host}: read failed: {exc}") from exc

    def is_grasped(self) -> bool:
        """Whether the hand reports holding an object."""
        return bool(self._gripper.read_once().is_grasped)


class FrankaArm:
    """A Franka arm over libfranka: connect, read, model, run a controller at 1 kHz.

    Use as a context manager; it stops any motion on exit::

        with FrankaArm("127.0.0.1") as arm:
            rollout, stats = track_franka(arm, plan, make_controller("ntsm-pd"))

    Raises
    ------
    DependencyNotInstalled
        Without ``pylibfranka``.
    InvalidInput
        ``host`` is not an IPv4 address or host name.
    RobotConnectionError
        Wrong host, nothing listening, or a protocol version mismatch.
    """

    def __init__(self, host: str, config: FrankaConfig | None = None) -> None:
        self.host = parse_robot_url(FRANKA_SCHEME + str(host))  # checked before libfranka
        self.config = config or FrankaConfig()
        self._plf = import_pylibfranka()
        self._robot: Any = None
        self._model: FrankaModel | None = None
        self._gripper: FrankaGripper | None = None

    # -- lifecycle -----------------------------------------------------------------------
    def connect(self) -> FrankaArm:
        """Open the connection, load the model and set the collision behaviour."""
        plf = self._plf
        mode = plf.RealtimeConfig.kEnforce if self.config.realtime else plf.RealtimeConfig.kIgnore
        try:
            self._robot = plf.Robot(self.host, mode)
        except plf.NetworkException as exc:
            raise RobotConnectionError(
                f"cannot reach a Franka arm at {self.host}: {exc} "
                "(wrong host, FCI not enabled, or the simulator is not running)"
            ) from exc
        except plf.FrankaException as exc:  # IncompatibleVersionException and kin
            raise RobotConnectionError(
                f"Franka at {self.host} refused the connection: {exc} (dexlfd uses "
                f"{PYLIBFRANKA_REQUIREMENT}, robot protocol {ROBOT_PROTOCOL_VERSION})"
            ) from exc
        except RuntimeError as exc:
            raise RobotConnectionError(f"Franka at {self.host}: {exc}") from exc
        try:
            raw = self._robot.read_once()
            self._model = FrankaModel(
                self._robot.load_model(), raw, np.asarray(self.config.gravity)
            )
            c = self.config
            self._robot.set_collision_behavior(
                list(c.lower_torque_thresholds),
                list(c.upper_torque_thresholds),
                list(c.lower_force_thresholds),
                list(c.upper_force_thresholds),
            )
        except RuntimeError as exc:
            self.close()
            raise RobotConnectionError(f"Franka at {self.host}: setup failed: {exc}") from exc
        state = _state_from(raw)
        p_dh, _ = self._model.tcp_pose(state.q)
        gap = float(np.linalg.norm(p_dh - state.O_T_EE[:3, 3]))
        if gap > 1e-3:
            self.close()
            raise RobotConnectionError(
                f"Franka at {self.host}: its TCP position differs from the Panda/FR3 DH table "
                f"by {gap * 1e3:.1f} mm; not a Panda or FR3?"
            )
        logger.info("connected to Franka at %s: mode %s, q %s", self.host, state.mode, state.q)
        if state.mode in ("Reflex", "Other", "UserStopped") or state.errors != "[]":
            logger.warning(
                "Franka at %s is in mode %s with errors %s: check the arm, then "
                "FrankaArm.recover() (automatic error recovery)",
                self.host,
                state.mode,
                state.errors,
            )
        return self

    def recover(self) -> FrankaState:
        """Run libfranka's automatic error recovery (after a reflex); returns the new state.

        Raises
        ------
        RobotConnectionError
            If the robot refuses (e.g. manual recovery or the user stop is needed).
        """
        robot = self._require()
        try:
            robot.automatic_error_recovery()
        except RuntimeError as exc:
            raise RobotConnectionError(f"Franka at {self.host}: recovery failed: {exc}") from exc
        for _ in range(100):  # states already in flight may predate the recovery
            state = self.read_state()
            if state.mode != "Reflex":
                break
        logger.info("Franka at %s recovered: mode %s", self.host, state.mode)
        return state

    def close(self) -> None:
        """Stop any motion and drop the connection (idempotent)."""
        if self._robot is not None:
            try:
                self._robot.stop()
            except Exception as exc:  # the link may already be gone
                logger.debug("stop on close: %s", exc)
        self._robot = None
        self._gripper = None

    def __enter__(self) -> FrankaArm:
        return self.connect()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- state, model, load, gripper ---------------------------------------------------------
    def _require(self) -> Any:
        if self._robot is None:
            raise RobotConnectionError(
                f"Franka at {self.host}: not connected (use 'with FrankaArm(...)')"
            )
        return self._robot

    @property
    def model(self) -> FrankaModel:
        """The robot's model library as a :class:`~dexlfd.robot.model.RobotModel`."""
        self._require()
        assert self._model is not None  # set in connect
        return self._model

    def read_state(self) -> FrankaState:
        """One state read outside a motion."""
        robot = self._require()
        try:
            return _state_from(robot.read_once())
        except RuntimeError as exc:
            raise RobotConnectionError(f"Franka at {self.host}: read failed: {exc}") from exc

    def set_load(
        self,
        mass: float,
        com: Sequence[float] = (0.0, 0.0, 0.0),
        inertia: Sequence[float] | None = None,
    ) -> None:
        """Tell the robot about a known payload.

        Parameters
        ----------
        mass : float
            Payload mass [kg], 0 ≤ mass ≤ 3.
        com : sequence of 3 floats
            Centre of mass in the flange frame [m].
        inertia : sequence of 9 floats or None
            Inertia tensor about the centre of mass [kg·m²], column-major; ``None`` =
            a point mass.
        """
        com_a = np.asarray(com, dtype=np.float64)
        inertia_a = np.zeros(9) if inertia is None else np.asarray(inertia, dtype=np.float64)
        if not (np.isfinite(mass) and 0.0 <= mass <= 3.0):
            raise InvalidInput(f"set_load: mass must be in [0, 3] kg, got {mass}")
        if com_a.shape != (3,) or inertia_a.shape != (9,):
            raise InvalidInput(
                "set_load: com must have 3 values and inertia 9, "
                f"got {com_a.shape}, {inertia_a.shape}"
            )
        robot = self._require()
        try:
            robot.set_load(float(mass), com_a.tolist(), inertia_a.tolist())
        except RuntimeError as exc:
            raise RobotConnectionError(f"Franka at {self.host}: set_load failed: {exc}") from exc
        self._model = FrankaModel(robot.load_model(), robot.read_once(), self.model.gravity_vector)
        logger.info("load set: %.3f kg at %s m (flange frame)", mass, com_a.tolist())

    @property
    def gripper(self) -> FrankaGripper:
        """The hand (connected on first use)."""
        self._require()
        if self._gripper is None:
            self._gripper = FrankaGripper(self.host, self._plf)
        return self._gripper

    # -- the 1 kHz loop ------------------------------------------------------------------------
    def run_torque_loop(
        self,
        policy: TorquePolicy,
        n_steps: int,
        *,
        end_time: float | None = None,
        gripper_width: float | None = None,
        meta: dict[str, Any] | None = None,
    ) -> tuple[Rollout, LoopStats]:
        """Run ``policy`` in libfranka's torque read/write loop (1 kHz) with the safety layer.

        Per cycle: read the state, evaluate the model at it, ask the policy for
        the total torque, subtract the robot's own gravity compensation G(q),
        rate-limit (``max_torque_rate``) and saturate (``TAU_MAX``), send. The
        policy's stop request, a non-finite torque, a stalled state stream
        (``watchdog_s``), a reflex or error reported by the robot and a lost
        connection all end the motion: the robot is stopped and
        :class:`RobotStopped` raised with the rollout so far.

        Parameters
        ----------
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
            the loop (the hand cannot be read inside it, see :class:`FrankaGripper`).
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
        robot = self._require()
        model = self.model
        plf = self._plf
        if gripper_width is None:
            gripper_width = self._gripper_width_or_zero()
        rec = _Recorder(n_steps)
        max_step = self.config.max_torque_rate * CONTROL_PERIOD_S
        tau_prev = np.zeros(N_JOINTS)  # torque mode starts from zero desired torque
        base_meta: dict[str, Any] = {
            "robot": f"{FRANKA_SCHEME}{self.host}",
            "franka_config": {
                k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self.config).items()
            },
            "torque_convention": "tau: controller output (gravity included); tau_sent = tau - G(q)",
            **(meta or {}),
        }
        stop_reason: str | None = None
        missed = 0
        t = 0.0
        # warm-up outside the loop: a law's first call can take tens of ms (lazy
        # imports, caches); inside the loop that would stall the robot's command stream
        warm = self.read_state()
        policy(0, 0.0, warm, model.terms_at(warm))
        wall0 = time.perf_counter()
        try:
            control = robot.start_torque_control()
        except RuntimeError as exc:
            raise RobotStopped(
                f"Franka at {self.host}: cannot start torque control: {exc}", None
            ) from exc
        try:
            for i in range(n_steps):
                raw, period = control.readOnce()
                c0 = time.perf_counter()
                dt = period.to_sec()
                if i > 0:
                    t += dt
                    missed += max(int(round(dt / CONTROL_PERIOD_S)) - 1, 0)
                    if dt > self.config.watchdog_s:
                        stop_reason = f"watchdog: no robot state for {dt * 1e3:.0f} ms"
                state = _state_from(raw)
                terms = model.terms_at(state)
                out = policy(i, t, state, terms)
                tau = out.tau
                if stop_reason is None and not np.isfinite(tau).all():
                    stop_reason = "controller returned a non-finite torque"
                if stop_reason is None and out.stop is not None:
                    stop_reason = out.stop
                if stop_reason is None:
                    tau_sent = rate_limit(tau - terms.g, tau_prev, max_step)
                else:  # hold: zero desired torque (the robot keeps compensating gravity)
                    tau_sent = rate_limit(np.zeros(N_JOINTS), tau_prev, max_step)
                    if not np.isfinite(tau).all():  # record what the joints get instead
                        tau = tau_sent + terms.g
                cmd = plf.Torques(tau_sent.tolist())
                last = (
                    stop_reason is not None
                    or i == n_steps - 1
                    or (end_time is not None and t >= end_time - 1e-9)
                )
                cmd.motion_finished = last
                control.writeOnce(cmd)
                tau_prev = tau_sent
                k = rec.i
                rec.t[k], rec.q[k], rec.dq[k] = t, state.q, state.dq
                rec.tau[k], rec.tau_sent[k], rec.tau_J[k] = tau, tau_sent, state.tau_J
                rec.p[k] = state.O_T_EE[:3, 3]
                rec.R[k] = state.O_T_EE[:3, :3]
                rec.ref_p[k] = out.ref_p
                rec.ref_R[k] = out.ref_R
                rec.period[k] = dt
                rec.compute[k] = time.perf_counter() - c0
                rec.i += 1
                if last:
                    break
        except plf.NetworkException as exc:
            stop_reason = f"connection to {self.host} lost: {exc}"
        except (RuntimeError, plf.FrankaException) as exc:
            stop_reason = _describe_robot_error(self.host, exc)
        except BaseException:
            self._stop_quietly()
            raise
        finally:
            # libfranka holds its control lock until the ActiveControl object dies
            # ("another control or read operation is running" otherwise)
            del control
        wall = time.perf_counter() - wall0
        stats = LoopStats(rec.i, wall, t, missed, rec.compute[: rec.i].copy())
        meta_out = {**base_meta, "loop": stats.summary()}
        if stop_reason is not None:
            meta_out["stopped"] = stop_reason
            self._stop_quietly()
            rollout = rec.rollout(gripper_width, meta_out)
            logger.error("motion stopped after %d cycles: %s", rec.i, stop_reason)
            raise RobotStopped(f"Franka at {self.host}: motion stopped: {stop_reason}", rollout)
        rollout = rec.rollout(gripper_width, meta_out)
        if rollout is None:  # pragma: no cover - n_steps >= 1 cycles always record one
            raise RobotStopped(f"Franka at {self.host}: no cycle ran", None)
        logger.info(
            "tracked %d cycles: %.0f Hz, %d missed, compute median %.0f µs",
            stats.n_cycles,
            stats.rate_hz,
            stats.missed_cycles,
            stats.summary()["compute_us_median"],
        )
        return rollout, stats

    def _gripper_width_or_zero(self) -> float:
        try:
            return self.gripper.width()
        except RobotConnectionError as exc:
            logger.warning("no gripper reading (%s); recording an opening of 0 m", exc)
            return 0.0

    def _stop_quietly(self) -> None:
        if self._robot is None:
            return
        try:
            self._robot.stop()
        except Exception as exc:  # link already gone: the robot stops itself on timeout
            logger.debug("stop after error: %s", exc)


def _describe_robot_error(host: str, exc: BaseException) -> str:
    text = str(exc)
    if "reflex" in text.lower():
        return f"the robot reported a reflex: {text}"
    if any(w in text.lower() for w in ("timeout", "tcp", "udp", "closed connection")):
        return f"connection to {host} lost: {text}"
    return f"the robot reported an error: {text}"
