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

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput
from dexlfd.panda import Q_MAX, Q_MIN, Q_READY

__all__ = ["IkBatch", "IkResult", "KinematicModel", "rotation_error", "solve_ik", "solve_ik_batch"]


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


def _rotation_errors(R_d: FloatArray, R: FloatArray) -> FloatArray:
    """:func:`rotation_error` of ``R_d`` (n, 3, 3) against each of ``R`` (n, 3, 3): (n, 3)."""
    E = R_d @ R.transpose(0, 2, 1)
    v = 0.5 * np.stack(
        [E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0], E[:, 1, 0] - E[:, 0, 1]], axis=1
    )
    s = np.sqrt((v * v).sum(axis=1))
    c = np.clip(0.5 * (np.trace(E, axis1=1, axis2=2) - 1.0), -1.0, 1.0)
    out = v * (np.arctan2(s, c) / np.where(s < 1e-12, 1.0, s))[:, None]
    for i in np.flatnonzero(s < 1e-12):  # no turn, or half a turn: the one-pose rule
        out[i] = rotation_error(R_d[i], R[i])
    return out


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


@dataclass(frozen=True, slots=True)
class IkBatch:
    """Outcome of :func:`solve_ik_batch`: one row per start posture."""

    q: FloatArray  # (n, 7) [rad]
    converged: BoolArray  # (n,)
    position_error: FloatArray  # (n,) [m]
    rotation_error: FloatArray  # (n,) [rad]


def solve_ik_batch(
    model: KinematicModel, p_d: FloatArray, R_d: FloatArray, q_init: FloatArray,
    *, damping: float = 1e-2, k_null: float = 0.1, tol_p: float = 1e-7,
    tol_r: float = 1e-6, max_iter: int = 300,
) -> IkBatch:  # fmt: skip
    """:func:`solve_ik` from each of several start postures at once.

    Row ``i`` is what ``solve_ik(model, p_d, R_d, q_init[i], ...)`` gives (each start
    is its own null-space rest; the same iterations and stopping rule), with the
    linear algebra of all the rows still iterating done in one NumPy call: the
    per-row Python overhead was ~90 % of a solve. The errors are measured as
    :func:`solve_ik` does, up to the last bit of a sum (the converged postures agree
    to ~1e-15 rad; a row exactly at a tolerance may take one iteration more or less).
    ``q_init`` (n, 7) [rad]; the target: one TCP pose for every row, ``p_d`` (3,) [m]
    and ``R_d`` (3, 3) as in :func:`solve_ik`, or one a row, (n, 3) and (n, 3, 3).
    """
    q_rest = as_float_array(q_init, "q_init", shape=(None, 7))
    n = q_rest.shape[0]
    p_d = check_finite(as_float_array(p_d, "p_d"), "p_d")
    R_d = check_finite(as_float_array(R_d, "R_d"), "R_d")
    if p_d.shape == (3,) and R_d.shape == (3, 3):
        p_d, R_d = np.broadcast_to(p_d, (n, 3)), np.broadcast_to(R_d, (n, 3, 3))
    elif p_d.shape != (n, 3) or R_d.shape != (n, 3, 3):
        raise InvalidInput(
            f"p_d and R_d must have shapes (3,) and (3, 3), or ({n}, 3) and ({n}, 3, 3) "
            f"(one a start posture), got {p_d.shape} and {R_d.shape}"
        )
    q = np.clip(q_rest.copy(), Q_MIN, Q_MAX)
    ep, er = np.full(n, np.inf), np.full(n, np.inf)
    done = np.zeros(n, dtype=bool)
    eye6, eye7 = np.eye(6), np.eye(7)
    lam2 = damping**2
    for _ in range(max_iter):
        live = np.flatnonzero(~done)
        if live.size == 0:
            break
        poses = [model.tcp_pose(q[i]) for i in live]
        p = np.array([pose[0] for pose in poses])
        R = np.array([pose[1] for pose in poses])
        e = np.concatenate([p_d[live] - p, _rotation_errors(R_d[live], R)], axis=1)
        ep[live] = np.sqrt((e[:, :3] * e[:, :3]).sum(axis=1))
        er[live] = np.sqrt((e[:, 3:] * e[:, 3:]).sum(axis=1))
        met = (ep[live] < tol_p) & (er[live] < tol_r)
        done[live[met]] = True
        live, e = live[~met], e[~met]
        if live.size == 0:
            break
        J = np.array([model.tcp_jacobian(q[i]) for i in live])
        Jt = J.transpose(0, 2, 1)
        JJt = J @ Jt
        dq = (Jt @ np.linalg.solve(JJt + lam2 * eye6, e[:, :, None]))[:, :, 0]
        Jpinv = Jt @ np.linalg.solve(JJt + 1e-9 * eye6, eye6)
        pull = (k_null * (q_rest[live] - q[live]))[:, :, None]
        dq += ((eye7 - Jpinv @ J) @ pull)[:, :, 0]
        q[live] = np.clip(q[live] + dq, Q_MIN, Q_MAX)
    return IkBatch(q, done, ep, er)
