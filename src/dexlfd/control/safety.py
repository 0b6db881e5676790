"""The safety stop of the 1 kHz loop: the state and tracking-error tests of a tick.

One rule on every arm (:class:`~dexlfd.control.arm_loop.ArmLoop`, the simulated
Panda's and a real arm's): stop on a non-finite joint state, a joint beyond its
limits (plus ``LoopConfig.joint_limit_margin``) or its velocity limit, or a TCP
position/orientation error beyond ``LoopConfig``'s bounds.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Reference
from dexlfd.control.loop_config import LoopConfig
from dexlfd.panda import DQ_MAX, Q_MAX, Q_MIN

__all__ = ["SafetyStop"]


class SafetyStop:
    """The stop tests with ``loop``'s bounds (joint limits widened by its margin)."""

    def __init__(self, loop: LoopConfig) -> None:
        self.loop = loop
        self._lo = Q_MIN - loop.joint_limit_margin
        self._hi = Q_MAX + loop.joint_limit_margin
        # the tick's test as plain floats (a NaN fails every comparison)
        self._bounds = tuple(
            zip(self._lo.tolist(), self._hi.tolist(), DQ_MAX.tolist(), strict=True)
        )

    def joint_reason(self, q: FloatArray, dq: FloatArray) -> str | None:
        """Why the joint state ``q`` [rad], ``dq`` [rad/s] must stop the loop, or None."""
        ok = True
        for qj, dqj, (lo, hi, vmax) in zip(q.tolist(), dq.tolist(), self._bounds, strict=True):
            if not (lo <= qj <= hi and -vmax <= dqj <= vmax):
                ok = False
                break
        if ok:  # the tick's case; the tests below name what is wrong
            return None
        if not (np.isfinite(q).all() and np.isfinite(dq).all()):
            return "non-finite joint state"
        out = (q < self._lo) | (q > self._hi)
        if out.any():
            j = int(np.argmax(out))
            return (
                f"joint {j + 1} position {q[j]:.4f} rad outside its limits "
                f"[{Q_MIN[j]:.4f}, {Q_MAX[j]:.4f}]"
            )
        fast = np.abs(dq) > DQ_MAX
        if fast.any():
            j = int(np.argmax(fast))
            return f"joint {j + 1} velocity {dq[j]:.3f} rad/s beyond {DQ_MAX[j]} rad/s"
        return None

    def pose_reason(self, err_p: float, err_r: float) -> str | None:
        """Why TCP errors ``err_p`` [m] and ``err_r`` [rad] must stop the loop, or None."""
        lp = self.loop
        if err_p > lp.max_position_error:
            return f"TCP position error {err_p:.4f} m beyond the bound {lp.max_position_error} m"
        if err_r > lp.max_orientation_error:
            return (
                f"TCP orientation error {err_r:.3f} rad beyond the bound "
                f"{lp.max_orientation_error} rad"
            )
        return None

    def check(
        self, q: FloatArray, dq: FloatArray, p: FloatArray, R: FloatArray, ref: Reference
    ) -> tuple[str | None, float]:
        """The first reason to stop at joints ``q``, ``dq`` and TCP pose ``p``, ``R``.

        Returns
        -------
        reason : str or None
            Joint tests first, then the TCP errors against ``ref``.
        orientation_error : float
            Angle [rad] between ``R`` and ``ref.R`` (recorded by the loops).
        """
        ok, err_p, err_r = _safety_errors()(
            q, dq, p, R, ref.p, ref.R, self._lo, self._hi, DQ_MAX
        )  # one call: the tick's case, a joint test failed only names it below
        reason = None if ok else self.joint_reason(q, dq)
        return reason or self.pose_reason(err_p, err_r), err_r


@functools.cache
def _safety_errors() -> Callable[..., tuple[bool, float, float]]:
    """:func:`~dexlfd.control.tick_kernels.safety_errors` (numba imported at the first tick)."""
    from dexlfd.control.tick_kernels import safety_errors

    return safety_errors
