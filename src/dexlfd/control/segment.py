"""A straight-line reference segment between two poses (the teleoperation reference).

Each camera frame of a teleoperation run gives a new target; the 1 kHz loop
tracks a piecewise-linear reference through them: position and gripper opening
interpolated linearly, orientation by slerp, with the constant slopes as the
velocity feed-forward. A straight segment stays inside a convex workspace box
and within per-frame rate limits at every control tick.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Reference
from dexlfd.panda import N_JOINTS
from dexlfd.rotations import (
    matrix_from_quat,
    quat_conjugate,
    quat_exp,
    quat_log,
    quat_multiply,
    quat_normalize,
)

__all__ = ["ReferenceSegment"]


class ReferenceSegment:
    """Straight-line reference from one pose to the next over ``[t0, t0 + T]``.

    Position and gripper opening are interpolated linearly, orientation by
    slerp; velocity and angular velocity are the constant slopes inside the
    segment (zero after it, where the end pose holds), acceleration is zero.
    Joint-space controllers also get a linearly interpolated joint reference.

    Parameters
    ----------
    t0 : float
        Start time [s].
    duration : float
        Length T [s], > 0.
    start, end : (position (3,) [m], quaternion (4,) xyzw, gripper opening [m])
        The poses at ``t0`` and ``t0 + T``.
    joints : ((7,), (7,)) [rad], optional
        Joint reference at the start and the end (joint-space controllers).
    """

    def __init__(
        self,
        t0: float,
        duration: float,
        start: tuple[FloatArray, FloatArray, float],
        end: tuple[FloatArray, FloatArray, float],
        joints: tuple[FloatArray, FloatArray] | None = None,
    ) -> None:
        self.t0, self.T = float(t0), float(duration)
        (self.p0, q0, self.g0), (self.p1, q1, self.g1) = start, end
        self.q0 = quat_normalize(q0)
        q1 = quat_normalize(q1)
        if float(q1 @ self.q0) < 0:  # shortest way; q and -q are the same rotation
            q1 = -q1
        self.q1 = q1
        self._half_rotvec = quat_log(quat_multiply(q1, quat_conjugate(self.q0)))
        self.v = (self.p1 - self.p0) / self.T
        self.w = 2.0 * self._half_rotvec / self.T  # base frame [rad/s]
        self._zero = np.zeros(3)
        self.joints = joints
        self._R1 = matrix_from_quat(self.q1)

    def at(self, t: float) -> tuple[Reference, float, FloatArray]:
        """Reference, gripper opening [m] and quaternion at time ``t`` [s]."""
        s = (t - self.t0) / self.T
        qj = dqj = None
        if s >= 1.0:
            if self.joints is not None:
                qj, dqj = self.joints[1], np.zeros(N_JOINTS)
            ref = Reference(self.p1, self._zero, self._zero, self._R1, self._zero, qj, dqj)
            return ref, self.g1, self.q1
        s = max(s, 0.0)
        q = quat_normalize(quat_multiply(quat_exp(s * self._half_rotvec), self.q0))
        if self.joints is not None:
            j0, j1 = self.joints
            qj, dqj = j0 + s * (j1 - j0), (j1 - j0) / self.T
        p = self.p0 + s * (self.p1 - self.p0)
        ref = Reference(p, self.v, self._zero, matrix_from_quat(q), self.w, qj, dqj)
        return ref, self.g0 + s * (self.g1 - self.g0), q

    def pose_at(self, t: float) -> tuple[FloatArray, FloatArray, float]:
        """(position, quaternion, gripper) at ``t`` (the start of the next segment)."""
        ref, g, q = self.at(t)
        return ref.p, q, g
