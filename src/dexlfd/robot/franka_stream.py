"""libfranka's torque stream of one motion, for both bindings (FR3 and FER).

:class:`TorqueControl` wraps pylibfranka's read/write object
(``start_torque_control()``), :class:`CallbackTorqueControl` libfranka 0.9's
``Robot.control(callback)`` (the FER's binding). Both run one motion's cycles with
:meth:`TorqueControl.run`: ``sent, last = step(state, dt)`` per robot state, and
turn libfranka's errors into :class:`RobotLinkError` with the reason.
:class:`StreamArm` is either stream as an :class:`~dexlfd.robot.arm.Arm` (the
loop's interface: sense, act; the robot paces the ticks).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.panda import N_JOINTS
from dexlfd.robot.actuation import rate_limit
from dexlfd.robot.arm import ArmState, Tick
from dexlfd.robot.libfranka import (
    CONTROL_PERIOD_S,
    FrankaState,
    RobotConnectionError,
    state_from,
)

__all__ = [
    "CallbackTorqueControl",
    "CycleStep",
    "RobotLinkError",
    "StreamArm",
    "TorqueControl",
    "link_error",
]

# one cycle of a torque stream: (state, robot-clock period [s]) -> (torque to send, last)
CycleStep = Callable[[FrankaState, float], tuple[FloatArray, bool]]


class RobotLinkError(RobotConnectionError):
    """The torque stream broke (reflex, robot error, lost link); the text says which."""


class TorqueControl:
    """libfranka's torque read/write stream (a context manager; one per motion).

    :meth:`read` gives the next state and the robot-clock period since the last
    one, :meth:`write` sends a torque; both raise :class:`RobotLinkError` with a
    reason when the robot reports a reflex or error or the link drops. Leaving the
    ``with`` block drops libfranka's control object, which releases its control
    lock ("another control or read operation is running" otherwise).
    """

    def __init__(self, active: Any, plf: Any, host: str) -> None:
        self._active = active
        self._plf = plf
        self.host = host

    def __enter__(self) -> TorqueControl:
        return self

    def __exit__(self, *exc: object) -> None:
        self._active = None

    def run(self, step: CycleStep, n_steps: int) -> None:
        """Run up to ``n_steps`` cycles: read, ``sent, last = step(state, dt)``, write."""
        for _ in range(n_steps):
            state, dt = self.read()
            sent, last = step(state, dt)
            self.write(sent, last)
            if last:
                return

    def read(self) -> tuple[FrankaState, float]:
        """The next robot state and the period [s] the robot clock reports for it."""
        try:
            raw, period = self._active.readOnce()
            return state_from(raw), period.to_sec()
        except Exception as exc:
            link = self._link_error(exc)
            if link is None:
                raise
            raise link from exc

    def write(self, tau: FloatArray, finished: bool) -> None:
        """Send the desired torque ``tau`` (7,) [N·m] (gravity excluded); ``finished`` ends."""
        cmd = self._plf.Torques(tau.tolist())
        cmd.motion_finished = finished
        try:
            self._active.writeOnce(cmd)
        except Exception as exc:
            link = self._link_error(exc)
            if link is None:
                raise
            raise link from exc

    def _link_error(self, exc: BaseException) -> RobotLinkError | None:
        """The error of libfranka as a :class:`RobotLinkError`; None for anything else."""
        return link_error(self._plf, self.host, exc)


class CallbackTorqueControl(TorqueControl):
    """libfranka < 0.13's torque stream (the FER's): ``Robot.control(callback)``.

    libfranka calls the callback once per robot state (1 kHz) and sends the torque
    it returns; :meth:`run` hands each call to ``step``. libfranka's own rate limit
    and low-pass filter are off (``limit_rate=False``, cutoff 1 kHz = off): the loop
    rate-limits the command itself (:class:`StreamArm`), as on the FR3 path.
    """

    def __init__(self, robot: Any, plf: Any, host: str) -> None:
        super().__init__(None, plf, host)
        self._robot = robot

    def run(self, step: CycleStep, n_steps: int) -> None:
        """Run up to ``n_steps`` cycles inside ``Robot.control``."""
        plf, count = self._plf, [0]

        def callback(raw: Any, period: Any) -> Any:
            sent, last = step(state_from(raw), period.to_sec())
            count[0] += 1
            cmd = plf.Torques(sent.tolist())
            cmd.motion_finished = bool(last or count[0] >= n_steps)
            return cmd

        try:
            self._robot.control(callback, limit_rate=False, cutoff_frequency=1000.0)
        except RuntimeError as exc:
            raise link_error(plf, self.host, exc) or exc from exc

    def read(self) -> tuple[FrankaState, float]:
        """Not available: libfranka 0.9 drives the cycle (see :meth:`run`)."""
        raise RobotConnectionError("the FER's torque stream is callback-driven: use run()")

    def write(self, tau: FloatArray, finished: bool) -> None:
        """Not available: libfranka 0.9 drives the cycle (see :meth:`run`)."""
        raise RobotConnectionError("the FER's torque stream is callback-driven: use run()")


def link_error(plf: Any, host: str, exc: BaseException) -> RobotLinkError | None:
    """A libfranka error of either binding as a :class:`RobotLinkError`; None otherwise."""
    network = getattr(plf, "NetworkException", None)
    if network is not None and isinstance(exc, network):
        return RobotLinkError(f"connection to {host} lost: {exc}")
    franka_exc = getattr(plf, "FrankaException", RuntimeError)
    if isinstance(exc, RuntimeError | franka_exc):
        return RobotLinkError(_describe_robot_error(host, exc))
    return None


def _describe_robot_error(host: str, exc: BaseException) -> str:
    text = str(exc)
    if "reflex" in text.lower():
        return f"the robot reported a reflex: {text}"
    if any(w in text.lower() for w in ("timeout", "tcp", "udp", "closed connection")):
        return f"connection to {host} lost: {text}"
    return f"the robot reported an error: {text}"


class StreamArm:
    """One motion's torque stream as an :class:`~dexlfd.robot.arm.Arm` (FR3 and FER).

    The robot paces the ticks: :meth:`run` hands each state to the loop's tick and
    sends what it acted. :meth:`act` takes the total torque, subtracts the robot's
    own gravity compensation ``G(q)`` (``gravity(q)``, libfranka's model), limits
    the rate (``max_torque_rate`` [N·m/s], from zero desired torque at the start)
    and saturates; ``None`` ramps to zero desired torque (the robot holds itself)
    and ends the motion. The arm's clock is the robot's: the periods it reports
    (missed cycles counted); a period beyond ``watchdog_s`` is a fault.

    Attributes
    ----------
    commanded : ndarray, shape (7,)
        The last command as a total torque (sent + ``G(q)``) [N·m].
    missed : int
        Robot-clock periods that passed without a command.
    """

    def __init__(
        self,
        control: TorqueControl,
        gravity: Callable[[FloatArray], FloatArray],
        max_torque_rate: float,
        watchdog_s: float,
        listener: Callable[[float, FrankaState], None] | None = None,
        capacity: int = 1024,
    ) -> None:
        self.control = control
        self._gravity = gravity
        self._max_step = max_torque_rate * CONTROL_PERIOD_S
        self._watchdog_s = watchdog_s
        self._listener = listener
        self._sent = np.zeros(N_JOINTS)  # torque mode starts from zero desired torque
        self._g = np.zeros(N_JOINTS)
        self._state: FrankaState | None = None
        self._pending: tuple[FloatArray, bool] | None = None
        self._in_run = False
        self.commanded = np.zeros(N_JOINTS)
        self.k = 0  # states sensed
        self.t = 0.0  # robot time [s]
        self.missed = 0
        self.compute: list[float] = []  # [s] per cycle: state in to command out
        self.periods: list[float] = []
        self.tau_measured: list[FloatArray] = []

    @property
    def period(self) -> float:
        """Libfranka's control period [s]."""
        return CONTROL_PERIOD_S

    def observe(self, state: FrankaState, dt: float) -> ArmState:
        """The :class:`ArmState` of robot state ``state`` that came ``dt`` [s] after the last."""
        fault = None
        if self.k > 0:
            self.t += dt
            self.missed += max(int(round(dt / CONTROL_PERIOD_S)) - 1, 0)
            if dt > self._watchdog_s:
                fault = f"watchdog: no robot state for {dt * 1e3:.0f} ms"
        self.k += 1
        self._state = state
        self._g = self._gravity(state.q)
        self.periods.append(dt)
        self.tau_measured.append(state.tau_J)
        T = state.O_T_EE
        return ArmState(
            self.t, state.q, state.dq, T[:3, 3].copy(), T[:3, :3].copy(), state.q, state.dq,
            dt, state.tau_J, fault,
        )  # fmt: skip

    def sense(self) -> ArmState:
        """Read the next state (read/write stream only: the FR3's)."""
        return self.observe(*self.control.read())

    def act(self, tau: FloatArray | None, last: bool = False) -> FloatArray:
        """The command for the last state: ``tau`` minus ``G(q)``, rate-limited.

        Sent at once outside :meth:`run`; returns the torque sent (gravity excluded).
        """
        if tau is None:
            sent = rate_limit(np.zeros(N_JOINTS), self._sent, self._max_step)
            last = True
        else:
            sent = rate_limit(tau - self._g, self._sent, self._max_step)
        self._sent, self.commanded = sent, sent + self._g
        self._pending = (sent, last)
        if not self._in_run:
            self.control.write(sent, last)
        return sent

    def run(self, tick: Tick, n_ticks: int) -> None:
        """Up to ``n_ticks`` robot cycles: state, ``tick`` (which acts), send."""

        def step(state: FrankaState, dt: float) -> tuple[FloatArray, bool]:
            c0 = time.perf_counter()
            self._pending = None
            last = tick(self.observe(state, dt))
            pending = self._pending
            if pending is None:  # the tick did not act: hold and end
                pending = (self.act(None), True)
            sent, finished = pending
            self.compute.append(time.perf_counter() - c0)
            if self._listener is not None:
                self._listener(self.t, state)
            return sent, bool(last or finished)

        self._in_run = True
        try:
            self.control.run(step, n_ticks)
        finally:
            self._in_run = False

    def close(self) -> None:
        """Leave the stream (releases libfranka's control lock)."""
        self.control.__exit__(None, None, None)
