"""Damped least-squares inverse kinematics for the TCP pose (a leaf: NumPy only).

Iterates ``dq = Jᵀ (J Jᵀ + λ² I)⁻¹ e + (I − J⁺J) k_n (q_rest − q)`` with the pose
error ``e = [p_d − p; log(R_d Rᵀ)]``, clipping to the joint limits.

References
----------
.. [1] S. R. Buss, "Introduction to inverse kinematics with Jacobian transpose,
   pseudoinverse and damped least squares methods", 2004, Eq. (11).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.panda import Q_MAX, Q_MIN, Q_READY

__all__ = ["IkResult", "KinematicModel", "rotation_error", "solve_ik"]


class KinematicModel(Protocol):
    """What the IK needs of a robot: its TCP pose and Jacobian (the MuJoCo model, DH)."""

    def tcp_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """TCP position (3,) [m] and rotation matrix (3, 3) at ``q`` [rad]."""
        ...

    def tcp_jacobian(self, q: FloatArray) -> FloatArray:
        """TCP Jacobian (6, 7), rows linear then angular, base frame."""
        ...


@dataclass(frozen=True, slots=True)
class IkResult:
    """Outcome of :func:`solve_ik`."""

    q: FloatArray
    converged: bool
    n_iter: int
    position_error: float  # [m]
    rotation_error: float  # [rad]


def rotation_error(R_d: FloatArray, R: FloatArray) -> FloatArray:
    """Rotation vector (3,) [rad] of ``R_d Rᵀ``: turning ``R`` by it gives ``R_d``."""
    E = R_d @ R.T
    v = 0.5 * np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
    s = np.linalg.norm(v)
    c = np.clip(0.5 * (np.trace(E) - 1.0), -1.0, 1.0)
    angle = np.arctan2(s, c)
    if s < 1e-12:
        if c > 0:
            return np.zeros(3)
        # 180°: axis from the symmetric part
        w, V = np.linalg.eigh(0.5 * (E + E.T))
        return np.pi * V[:, int(np.argmax(w))]
    return v * (angle / s)


def solve_ik(
    model: KinematicModel,
    p_d: FloatArray,
    R_d: FloatArray,
    q_init: FloatArray | None = None,
    *,
    damping: float = 1e-2,
    k_null: float = 0.1,
    tol_p: float = 1e-7,
    tol_r: float = 1e-6,
    max_iter: int = 300,
    q_rest: FloatArray | None = None,
) -> IkResult:
    """TCP inverse kinematics by damped least squares.

    Parameters
    ----------
    model : KinematicModel
        Provides ``tcp_pose`` and ``tcp_jacobian`` (``dexlfd.robot.MujocoPandaModel``,
        :class:`dexlfd.panda_kinematics.DhPanda`).
    p_d : ndarray, shape (3,)
        Target TCP position [m].
    R_d : ndarray, shape (3, 3)
        Target TCP rotation matrix.
    q_init : ndarray, shape (7,), optional
        Start and null-space rest posture [rad]; default Franka's ready pose.
    damping : float
        Damping λ [-] of the least-squares step.
    k_null : float
        Null-space pull towards ``q_rest`` per iteration [-].
    q_rest : ndarray, shape (7,), optional
        The null-space rest posture [rad]; default ``q_init``.

    Returns
    -------
    IkResult
        ``q`` within the joint limits and whether the tolerances were met.
    """
    p_d = check_finite(as_float_array(p_d, "p_d", shape=(3,)), "p_d")
    R_d = check_finite(as_float_array(R_d, "R_d", shape=(3, 3)), "R_d")
    q_start = Q_READY if q_init is None else as_float_array(q_init, "q_init", shape=(7,))
    q = np.clip(q_start.copy(), Q_MIN, Q_MAX)
    if q_rest is not None:
        q_rest = as_float_array(q_rest, "q_rest", shape=(7,))
    else:
        q_rest = q_start
    lam2 = damping**2
    ep = er = np.inf
    for it in range(1, max_iter + 1):
        p, R = model.tcp_pose(q)
        e = np.concatenate([p_d - p, rotation_error(R_d, R)])
        ep, er = float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))
        if ep < tol_p and er < tol_r:
            return IkResult(q, True, it, ep, er)
        J = model.tcp_jacobian(q)
        JJt = J @ J.T + lam2 * np.eye(6)
        dq = J.T @ np.linalg.solve(JJt, e)  # [1] Eq. (11)
        Jpinv = J.T @ np.linalg.solve(J @ J.T + 1e-9 * np.eye(6), np.eye(6))
        dq += (np.eye(7) - Jpinv @ J) @ (k_null * (q_rest - q))
        q = np.clip(q + dq, Q_MIN, Q_MAX)
    return IkResult(q, False, max_iter, ep, er)
