"""Damped least-squares inverse kinematics for the TCP pose (a leaf: NumPy only).

Iterates ``dq = Jᵀ (J Jᵀ + λ² I)⁻¹ e + (I − J⁺J) k_n (q_rest − q)`` with the pose
error ``e = [p_d − p; log(R_d Rᵀ)]``, clipping to the joint limits. One implementation
of the pose error and the step serves one start posture (:func:`solve_ik`) and many
(:func:`solve_ik_batch`): the rows still iterating share each NumPy call (a lone row
skips the rows' bookkeeping, on the same arrays), and each iteration takes the TCP
pose and Jacobian from one pass of the robot's kinematics (``tcp_pose_jacobian``).

References
----------
.. [1] S. R. Buss, "Introduction to inverse kinematics with Jacobian transpose,
   pseudoinverse and damped least squares methods", 2004, Eq. (11).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from dexlfd._types import BoolArray, FloatArray, IntArray
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

    def tcp_pose_jacobian(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """TCP position (3,) [m], rotation (3, 3) and Jacobian (6, 7) at ``q`` [rad].

        What the IK evaluates every iteration: the two from one pass of the kinematics.
        """
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
    return _rotation_errors(np.asarray(R_d)[None], np.asarray(R)[None])[0][0]


# R_d Rᵀ flattened (9,) -> its vee (E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1])
# / 2 and half its trace: one matrix product
_VEE_TRACE = np.zeros((9, 4))
_VEE_TRACE[[7, 2, 3], [0, 1, 2]], _VEE_TRACE[[5, 6, 1], [0, 1, 2]] = 0.5, -0.5
_VEE_TRACE[[0, 4, 8], 3] = 0.5


def _rotation_errors(R_d: FloatArray, R: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`rotation_error` of each ``R_d`` (n, 3, 3) against each ``R`` (n, 3, 3).

    Returns the rotation vectors (n, 3) [rad] and their lengths, the angles (n,) [rad].

    The axis times the angle: ``v = vee(E - Eᵀ) / 2 = sin(θ) u`` with ``E = R_d Rᵀ`` and
    ``cos(θ) = (tr E - 1) / 2``; where ``sin(θ)`` vanishes, no turn (zero) or half a
    turn (π about the axis of ``E``'s symmetric part, its eigenvalue-1 eigenvector).
    """
    E = R_d @ R.transpose(0, 2, 1)
    vc = E.reshape(-1, 9) @ _VEE_TRACE
    v = vc[:, :3]
    s = np.sqrt((v * v).sum(axis=1))
    cos = vc[:, 3] - 0.5  # unclipped: arctan2 takes any
    angle = np.arctan2(s, cos)
    small = s < 1e-12
    if not small.any():
        return v * (angle / s)[:, None], angle
    out = v * np.divide(angle, s, out=np.zeros_like(s), where=~small)[:, None]  # no turn: 0
    for i in np.flatnonzero(small & (cos <= 0.0)):  # half a turn
        w, V = np.linalg.eigh(0.5 * (E[i] + E[i].T))
        out[i] = np.pi * V[:, int(np.argmax(w))]
    return out, angle


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

    The iterations of :func:`solve_ik_batch` for one start posture (one
    implementation: the two agree to the last bit).

    Parameters
    ----------
    model : KinematicModel
        Provides the TCP pose and Jacobian (``dexlfd.robot.MujocoPandaModel``,
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
    rest = q_start if q_rest is None else as_float_array(q_rest, "q_rest", shape=(7,))
    q, done, ep, er, n_iter = _iterate(
        model, (p_d[None], R_d[None]), q_start[None], rest[None],
        damping=damping, k_null=k_null, tol=(tol_p, tol_r), max_iter=max_iter,
    )  # fmt: skip
    return IkResult(q[0], bool(done[0]), int(n_iter[0]), float(ep[0]), float(er[0]))


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

    Row ``i`` is what ``solve_ik(model, p_d, R_d, q_init[i], ...)`` gives, to the
    last bit (each start is its own null-space rest; the same iterations and
    stopping rule), with the linear algebra of all the rows still iterating done in
    one NumPy call: the per-row Python overhead was ~90 % of a solve.
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
    q, done, ep, er, _ = _iterate(
        model, (p_d, R_d), q_rest, q_rest,
        damping=damping, k_null=k_null, tol=(tol_p, tol_r), max_iter=max_iter,
    )  # fmt: skip
    return IkBatch(q, done, ep, er)


_EYE6 = np.eye(6)


@functools.lru_cache(maxsize=8)
def _regularisers(damping: float) -> FloatArray:
    """λ² I of the damped step and 1e-9 I of the null-space pseudo-inverse: (2, 6, 6)."""
    reg = _EYE6 * np.array([damping**2, 1e-9])[:, None, None]
    reg.flags.writeable = False
    return reg


def _iterate(
    model: KinematicModel, target: tuple[FloatArray, FloatArray], q_init: FloatArray,
    q_rest: FloatArray, *, damping: float, k_null: float, tol: tuple[float, float],
    max_iter: int,
) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray, IntArray]:  # fmt: skip
    """The damped least-squares iterations of every row, those of the rows left at once.

    ``target``: TCP positions (n, 3) [m] and rotations (n, 3, 3); ``q_init`` and
    ``q_rest`` (n, 7) [rad]; ``tol``: position [m] and rotation [rad] tolerances.
    Returns the joints (n, 7), which rows met the tolerances, their position and
    rotation errors (n,) at the last pose evaluated, and the iterations (n,) each took.
    Each iteration evaluates the TCP pose and Jacobian together
    (``model.tcp_pose_jacobian``: one pass of the kinematics); a row that meets the
    tolerances leaves the working arrays. A lone row: :func:`_iterate_one`.
    """
    if q_init.shape[0] == 1:
        return _iterate_one(model, target, q_init, q_rest, damping=damping, k_null=k_null,
                            tol=tol, max_iter=max_iter)  # fmt: skip
    n = q_init.shape[0]
    q_out = np.minimum(np.maximum(q_init, Q_MIN), Q_MAX)  # np.clip, less overhead
    ep, er = np.full(n, np.inf), np.full(n, np.inf)
    done, n_iter = np.zeros(n, dtype=bool), np.full(n, max_iter)
    rows, (p_d, R_d), q, rest = np.arange(n), target, q_out, q_rest
    ep_w, er_w = ep, er
    reg = _regularisers(damping)
    for it in range(1, max_iter + 1):
        p, R, J = map(np.array, zip(*[model.tcp_pose_jacobian(x) for x in q], strict=True))
        dp, (dr, er_w) = p_d - p, _rotation_errors(R_d, R)
        ep_w = np.sqrt((dp * dp).sum(axis=1))
        met = (ep_w < tol[0]) & (er_w < tol[1])
        if met.any():
            fin = rows[met]
            q_out[fin], ep[fin], er[fin] = q[met], ep_w[met], er_w[met]
            done[fin], n_iter[fin] = True, it
            left = ~met
            if not left.any():
                return q_out, done, ep, er, n_iter
            rows, p_d, R_d, q, rest = rows[left], p_d[left], R_d[left], q[left], rest[left]
            dp, dr, J, ep_w, er_w = dp[left], dr[left], J[left], ep_w[left], er_w[left]
        q = _step(J, dp, dr, q, rest, k_null, reg)
    q_out[rows], ep[rows], er[rows] = q, ep_w, er_w
    return q_out, done, ep, er, n_iter


def _iterate_one(
    model: KinematicModel, target: tuple[FloatArray, FloatArray], q_init: FloatArray,
    q_rest: FloatArray, *, damping: float, k_null: float, tol: tuple[float, float],
    max_iter: int,
) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray, IntArray]:  # fmt: skip
    """:func:`_iterate` of a lone row (1, ...): the same arithmetic, array for array.

    The pose error and the step are those of every row (:func:`_rotation_errors`,
    :func:`_step`, on the same (1, ...) shapes); only the rows' bookkeeping is left
    out: it was most of a warm-started solve's time (a plan's IK solves one sample at
    a time, each from the previous one's joints).
    """
    (p_d, R_d), reg = target, _regularisers(damping)
    q = np.minimum(np.maximum(q_init, Q_MIN), Q_MAX)
    ep = er = np.full(1, np.inf)
    for it in range(1, max_iter + 1):
        # C order, as the rows' np.array makes them (a Jacobian in Fortran order, e.g.
        # DhPanda's, took other BLAS paths: other last bits)
        p, R, J = (np.ascontiguousarray(a)[None] for a in model.tcp_pose_jacobian(q[0]))
        dp, (dr, er) = p_d - p, _rotation_errors(R_d, R)
        ep = np.sqrt((dp * dp).sum(axis=1))
        if ep[0] < tol[0] and er[0] < tol[1]:
            return q, np.ones(1, dtype=bool), ep, er, np.full(1, it)
        q = _step(J, dp, dr, q, q_rest, k_null, reg)
    return q, np.zeros(1, dtype=bool), ep, er, np.full(1, max_iter)


def _step(
    J: FloatArray, dp: FloatArray, dr: FloatArray, q: FloatArray, rest: FloatArray,
    k_null: float, reg: FloatArray,
) -> FloatArray:  # fmt: skip
    """One damped least-squares step of every row: the joints (n, 7) [rad] after it.

    ``J`` (n, 6, 7) the TCP Jacobians at ``q``, ``dp`` and ``dr`` (n, 3) the position
    [m] and rotation [rad] errors, ``rest`` the null-space rest postures.
    """
    # [1] Eq. (11), and the null-space pull projected, (I - J⁺J) k = k - Jᵀ (J Jᵀ)⁻¹ J k
    # (J⁺ regularised by 1e-9 I): the two 6x6 systems in one solve
    Jt = J.transpose(0, 2, 1)
    pull = k_null * (rest - q)
    A = (J @ Jt)[:, None] + reg
    # right-hand sides: the pose error e = [p_d - p; log(R_d Rᵀ)], and J k
    b = np.concatenate([dp, dr, (J @ pull[:, :, None])[:, :, 0]], axis=1).reshape(-1, 2, 6, 1)
    x = np.linalg.solve(A, b)[:, :, :, 0]
    dq = pull + (Jt @ (x[:, 0] - x[:, 1])[:, :, None])[:, :, 0]
    return np.minimum(np.maximum(q + dq, Q_MIN), Q_MAX)  # np.clip, less overhead
