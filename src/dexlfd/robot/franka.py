"""A Franka arm over the Franka Control Interface (libfranka's Python bindings).

:class:`FrankaArm` connects to a Franka arm (or a Franka-protocol simulator) with
the official bindings ``pylibfranka`` (libfranka 0.21.x, robot protocol 10),
reads its state, exposes libfranka's model library as a
:class:`~dexlfd.robot.robot_model.RobotModel` (:class:`~dexlfd.robot.franka_model.FrankaModel`),
sets the load and the collision behaviour, and opens libfranka's torque
read/write stream (:meth:`FrankaArm.torque_control`; as the loop's arm
interface: :class:`~dexlfd.robot.franka_stream.StreamArm`). The one 1 kHz loop
runs a controller in that stream behind the safety layer
(:func:`dexlfd.control.franka.run_controller`); the hand is
:class:`~dexlfd.robot.franka_gripper.FrankaGripper`.

Torque convention. Our controllers return the *total* joint torque, gravity
included (what a plant without gravity compensation needs). A Franka adds its
own gravity compensation ``G(q)`` (from the same model library, including the
hand and any load set with ``set_load``) to the commanded ``tau_J_d``, so the
loop sends ``tau - G(q)``. With that, a law behaves the same on the MuJoCo
plant and on the arm.

Safety. Before a motion the collision thresholds of :class:`FrankaConfig` are
set (a crossing makes the robot stop itself with a reflex); the loop's own
safety layer is described in :mod:`dexlfd.control.arm_loop`.

References
----------
.. [1] Franka Robotics, libfranka 0.21 and pylibfranka documentation,
   https://frankarobotics.github.io/docs/ ("Control parameters", "libfranka").
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd.errors import DependencyNotInstalled, InvalidInput
from dexlfd.panda import DTAU_MAX, MAX_PAYLOAD, N_JOINTS
from dexlfd.robot.franka_bindings import (
    BINDINGS,
    GENERATIONS,
    FrankaBinding,
    binding_for,
    generation_of_protocol,
    import_binding,
    mismatch_message,
    server_version_of,
)
from dexlfd.robot.franka_gripper import FrankaGripper
from dexlfd.robot.franka_model import FrankaModel
from dexlfd.robot.franka_stream import (
    CallbackTorqueControl,
    TorqueControl,
)
from dexlfd.robot.libfranka import (
    CONTROL_PERIOD_S,
    FrankaState,
    RobotConnectionError,
    RobotStopped,
    state_from,
)
from dexlfd.robot.url import FRANKA_SCHEME, parse_robot_url

__all__ = [
    "MAX_TORQUE_RATE",
    "FrankaArm",
    "FrankaConfig",
]

logger = logging.getLogger(__name__)

MAX_TORQUE_RATE = DTAU_MAX  # [N·m/s] libfranka's kMaxTorqueRate, every joint


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


class FrankaArm:
    """A Franka arm over libfranka: connect, read, model, load, torque stream.

    Use as a context manager; it stops any motion on exit::

        with FrankaArm("127.0.0.1") as arm:
            rollout, stats = track_franka(arm, plan, make_controller("ntsm-pd"))  # control

    Raises
    ------
    DependencyNotInstalled
        Without ``pylibfranka``.
    InvalidInput
        ``host`` is not an IPv4 address or host name.
    RobotConnectionError
        Wrong host, nothing listening, or a protocol version mismatch.
    """

    def __init__(
        self, host: str, config: FrankaConfig | None = None, generation: str = "auto"
    ) -> None:
        self.host = parse_robot_url(FRANKA_SCHEME + str(host))  # checked before libfranka
        self.config = config or FrankaConfig()
        if generation not in GENERATIONS:
            raise InvalidInput(f"generation must be one of {GENERATIONS}, got {generation!r}")
        self.generation = generation
        self.binding: FrankaBinding = (
            BINDINGS["fr3"] if generation == "auto" else binding_for(generation)
        )
        self._plf: Any = None if generation == "auto" else import_binding(self.binding)
        self._bindings = self._candidates()  # a missing binding is reported here
        # called with (robot time [s], state) every cycle of a motion, e.g. a ROS 2
        # publisher; it runs inside the 1 kHz loop, so it must take microseconds
        self.state_listener: Callable[[float, FrankaState], None] | None = None
        self._robot: Any = None
        self._model: FrankaModel | None = None
        self._gripper: FrankaGripper | None = None

    # -- lifecycle -----------------------------------------------------------------------
    def _candidates(self) -> list[FrankaBinding]:
        """The bindings to try: the one asked for, or (auto) every installed one, FR3 first."""
        if self.generation != "auto":
            return [self.binding]
        installed = []
        for b in BINDINGS.values():
            try:
                import_binding(b)
            except DependencyNotInstalled:
                continue
            installed.append(b)
        if not installed:
            raise DependencyNotInstalled(
                "pylibfranka", "the real-arm path (an FR3; a FER needs 'dexlfd[franka-fer]')",
                extra="franka",
            )  # fmt: skip
        return installed

    def _open(self) -> Any:
        """The libfranka Robot of the right generation; a mismatch is one line naming it."""
        candidates = self._bindings
        for binding in candidates:
            plf = import_binding(binding)
            mode = (
                plf.RealtimeConfig.kEnforce if self.config.realtime else plf.RealtimeConfig.kIgnore
            )
            refused: tuple[type[BaseException], ...] = (
                RuntimeError, getattr(plf, "FrankaException", RuntimeError),
            )  # fmt: skip
            try:
                robot = plf.Robot(self.host, mode)
            except refused as exc:
                version = server_version_of(exc)
                if version is None:
                    raise self._connect_error(plf, exc) from exc
                found = generation_of_protocol(version)
                if found != binding.generation and any(b.generation == found for b in candidates):
                    logger.info("Franka at %s speaks protocol %d: %s", self.host, version, found)
                    continue  # auto: the other generation's binding is installed
                raise RobotConnectionError(mismatch_message(self.host, binding, version)) from exc
            self.binding, self._plf = binding, plf
            logger.info("Franka at %s: %s over %s", self.host, binding.label, binding.requirement)
            return robot
        raise RobotConnectionError(f"Franka at {self.host}: no installed binding accepted it")

    def _connect_error(self, plf: Any, exc: BaseException) -> RobotConnectionError:
        network = getattr(plf, "NetworkException", None)
        text = str(exc)
        if (network is not None and isinstance(exc, network)) or "connection" in text.lower():
            return RobotConnectionError(
                f"cannot reach a Franka arm at {self.host}: {text} "
                "(wrong host, FCI not enabled, or the simulator is not running)"
            )
        return RobotConnectionError(f"Franka at {self.host}: {text}")

    def connect(self) -> FrankaArm:
        """Open the connection, load the model and set the collision behaviour."""
        self._robot = self._open()
        fer = self.binding.callback_stream
        frame = self._plf.Frame.kEndEffector if fer else None
        try:
            raw = self._robot.read_once()
            self._model = FrankaModel(
                self._robot.load_model(), raw, np.asarray(self.config.gravity), frame=frame
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
        state = state_from(raw)
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

    def __exit__(self, *exc: object) -> None:
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
        """The robot's model library as a :class:`~dexlfd.robot.robot_model.RobotModel`."""
        self._require()
        assert self._model is not None  # set in connect
        return self._model

    def read_state(self) -> FrankaState:
        """One state read outside a motion."""
        robot = self._require()
        try:
            return state_from(robot.read_once())
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
            Payload mass [kg], 0 ≤ mass ≤ ``MAX_PAYLOAD`` (3 kg).
        com : sequence of 3 floats
            Centre of mass in the flange frame [m].
        inertia : sequence of 9 floats or None
            Inertia tensor about the centre of mass [kg·m²], column-major; ``None`` =
            a point mass.
        """
        com_a = np.asarray(com, dtype=np.float64)
        inertia_a = np.zeros(9) if inertia is None else np.asarray(inertia, dtype=np.float64)
        if not (np.isfinite(mass) and 0.0 <= mass <= MAX_PAYLOAD):
            raise InvalidInput(f"set_load: mass must be in [0, {MAX_PAYLOAD:g}] kg, got {mass}")
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
        self._model = FrankaModel(
            robot.load_model(), robot.read_once(), self.model.gravity_vector, frame=self.model.frame
        )
        logger.info("load set: %.3f kg at %s m (flange frame)", mass, com_a.tolist())

    @property
    def gripper(self) -> FrankaGripper:
        """The hand (connected on first use)."""
        self._require()
        if self._gripper is None:
            self._gripper = FrankaGripper(self.host, self._plf)
        return self._gripper

    # -- the torque stream ---------------------------------------------------------------------
    def torque_control(self) -> TorqueControl:
        """Start libfranka's torque control; the stream of one motion.

        Raises
        ------
        RobotStopped
            If the robot refuses to start (no rollout).
        """
        robot = self._require()
        if self.binding.callback_stream:
            return CallbackTorqueControl(robot, self._plf, self.host)
        try:
            active = robot.start_torque_control()
        except RuntimeError as exc:
            raise RobotStopped(
                f"Franka at {self.host}: cannot start torque control: {exc}", None
            ) from exc
        return TorqueControl(active, self._plf, self.host)

    def gripper_width_or_zero(self) -> float:
        """The hand's opening [m], or 0 with a warning when it cannot be read."""
        try:
            return self.gripper.width()
        except RobotConnectionError as exc:
            logger.warning("no gripper reading (%s); recording an opening of 0 m", exc)
            return 0.0

    def stop_quietly(self) -> None:
        """Stop a motion after an error (a link already gone stops the robot itself)."""
        if self._robot is None:
            return
        try:
            self._robot.stop()
        except Exception as exc:  # link already gone: the robot stops itself on timeout
            logger.debug("stop after error: %s", exc)
