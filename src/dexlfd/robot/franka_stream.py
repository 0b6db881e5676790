"""libfranka's torque stream of one motion, for both bindings (FR3 and FER).

:class:`TorqueControl` wraps pylibfranka's read/write object
(``start_torque_control()``), :class:`CallbackTorqueControl` libfranka 0.9's
``Robot.control(callback)`` (the FER's binding). Both run one motion's cycles with
:meth:`TorqueControl.run`: ``sent, last = step(state, dt)`` per robot state, and
turn libfranka's errors into :class:`RobotLinkError` with the reason.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from dexlfd._types import FloatArray
from dexlfd.robot.libfranka import FrankaState, RobotConnectionError, state_from

__all__ = ["CallbackTorqueControl", "CycleStep", "RobotLinkError", "TorqueControl", "link_error"]

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
    rate-limits the command itself (:mod:`dexlfd.control.arm_loop`), as on the FR3 path.
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
