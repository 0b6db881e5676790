"""From a commanded torque to the joints: the torque rate limit and the delay line.

Every :class:`~dexlfd.robot.arm.Arm` limits how fast its command changes as
libfranka's ``limit_rate`` does (1000 N·m/s by default); the simulated arm also
delays the command by whole ticks, as the real arm's communication does.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.panda import TAU_MAX

__all__ = ["TorqueDelay", "rate_limit"]


def rate_limit(tau: FloatArray, tau_prev: FloatArray, max_step: float) -> FloatArray:
    """Limit each joint's torque change per cycle to ``max_step`` [N·m], then to ``TAU_MAX``.

    ``clip(tau, tau_prev - max_step, tau_prev + max_step)`` saturated to ±``TAU_MAX``
    (``np.clip``'s values, by its ufuncs: half the cost per call on a 7-vector).
    """
    step = np.minimum(np.maximum(tau, tau_prev - max_step), tau_prev + max_step)
    return np.minimum(np.maximum(step, _TAU_MIN), TAU_MAX)


_TAU_MIN = -TAU_MAX


class TorqueDelay:
    """A delay line of ``ticks`` control ticks, primed with ``hold`` (7,) [N·m].

    :meth:`push` takes the command of this tick and returns the one that acts
    now: ``ticks`` pushes earlier (``hold`` at first); ``ticks = 0`` is no delay.
    """

    def __init__(self, ticks: int, hold: FloatArray) -> None:
        self._line: deque[FloatArray] = deque(hold.copy() for _ in range(int(ticks)))

    def push(self, tau: FloatArray) -> FloatArray:
        """Queue ``tau`` and return the torque applied during this tick."""
        self._line.append(tau)
        return self._line.popleft()
