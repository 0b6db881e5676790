"""The arm interface of the 1 kHz loop: :class:`Arm` (sense, act) and :class:`ArmState`.

Two arms implement it: the simulated Panda
(:class:`~dexlfd.robot.sim_arm.SimArm`: the MuJoCo plant with its friction,
measurement noise, torque rate limit and delay) and a Franka arm's torque stream
(:class:`~dexlfd.robot.franka_stream.StreamArm`, FR3 and FER). One loop,
:class:`dexlfd.control.arm_loop.ArmLoop`, follows a plan on either.

Per tick the loop gets the state at the tick (:meth:`Arm.sense`), computes a
torque and hands it to :meth:`Arm.act`. The simulator advances one period per
``act`` (lock-step, :func:`run_lockstep`); a real arm paces the ticks itself
(:meth:`Arm.run` calls the loop's tick once per robot state and sends what it
acted).

Torque convention: ``act`` takes the *total* joint torque, gravity included (what
a plant without gravity compensation needs); an arm that compensates gravity
itself (a Franka) subtracts its own ``G(q)`` before sending.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from dexlfd._types import FloatArray

__all__ = ["Arm", "ArmState", "Tick", "run_lockstep"]


@dataclass(frozen=True, slots=True)
class ArmState:
    """What an arm reports at one tick.

    Attributes
    ----------
    t : float
        The arm's clock [s] (robot time on a real arm), 0 at the first tick.
    q, dq : ndarray, shape (7,)
        Joint positions [rad] and velocities [rad/s]: the simulator's true ones,
        a robot's measured ones (recorded and checked by the safety stop).
    p : ndarray, shape (3,)
        TCP position [m] (the simulator's true one, the pose a robot reports).
    R : ndarray, shape (3, 3)
        TCP rotation.
    q_sensed, dq_sensed : ndarray, shape (7,)
        What the controller sees: the simulator adds measurement noise.
    period : float
        Arm clock since the previous tick [s] (one period unless a robot's
        cycles were missed).
    tau_measured : ndarray, shape (7,), or None
        Measured joint torques [N·m] (a robot's ``tau_J``); None on the simulator.
    fault : str or None
        A reason the arm itself gives to stop now (e.g. a stalled state stream).
    """

    t: float
    q: FloatArray
    dq: FloatArray
    p: FloatArray
    R: FloatArray  # noqa: N815 - R: the rotation matrix
    q_sensed: FloatArray
    dq_sensed: FloatArray
    period: float
    tau_measured: FloatArray | None = None
    fault: str | None = None


# one tick of the loop: it acts on the arm for this state and returns whether it was the last
Tick = Callable[[ArmState], bool]


@runtime_checkable
class Arm(Protocol):
    """A 7-DoF torque-controlled arm at a fixed tick period (see the module docstring)."""

    @property
    def period(self) -> float:
        """Tick period [s]."""
        ...

    @property
    def commanded(self) -> FloatArray:
        """The last command as a total torque (7,) [N·m], after the arm's rate limit."""
        ...

    def sense(self) -> ArmState:
        """The state at this tick."""
        ...

    def act(self, tau: FloatArray | None, last: bool = False) -> FloatArray | None:
        """Send total torque ``tau`` (7,) [N·m] for this tick; returns what the arm sends.

        The arm rate-limits the command (and the simulator delays it: it returns
        the torque applied during the tick); ``None`` stops: a robot ramps to its
        own gravity compensation and ends the motion, the simulator applies
        nothing and returns None. ``last`` ends the motion after this tick.
        """
        ...

    def run(self, tick: Tick, n_ticks: int) -> None:
        """Call ``tick`` once per state (it calls :meth:`act`), up to ``n_ticks`` or the last."""
        ...

    def close(self) -> None:
        """Release what the arm holds (idempotent)."""
        ...


def run_lockstep(arm: Arm, tick: Tick, n_ticks: int) -> None:
    """:meth:`Arm.run` of an arm that waits for each command: sense, tick, act."""
    for _ in range(n_ticks):
        if tick(arm.sense()):
            return
