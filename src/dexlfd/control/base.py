"""The controller interface shared by every control law, and its small helpers.

A controller is a frozen dataclass of gains with two methods::

    ctrl_state = controller.init(robot_state, terms)
    tau, ctrl_state = controller.step(ctrl_state, robot_state, reference, terms)

``terms`` (:class:`~dexlfd.robot.robot_model.ModelTerms`) come from the controller's
*nominal* model (a :class:`~dexlfd.robot.robot_model.RobotModel`), never from the
plant, so the same laws can run on a real arm with libfranka's model library.
``ctrl_state`` is explicit (integrators, observers, the null-space posture), so
``step`` is a pure function of its arguments. Torques are saturated to the
Panda's limits before they leave ``step``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields
from typing import Any, Protocol, cast, runtime_checkable

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.panda import N_JOINTS, TAU_MAX
from dexlfd.robot.robot_model import ModelTerms

__all__ = [
    "Controller",
    "Reference",
    "RobotState",
    "check_gains",
    "inv3",
    "minv_jt",
    "null_reference",
    "nullspace_torque",
    "orientation_error",
    "saturate",
    "spd_solve",
    "task_inertia",
]


@dataclass(frozen=True, slots=True)
class RobotState:
    """Measured state handed to a controller."""

    t: float  # [s]
    q: FloatArray  # (7,) [rad]
    dq: FloatArray  # (7,) [rad/s]
    # measured external wrench the environment applies at the TCP (6,) [N, N·m], base
    # frame (a force/torque sensor, or the robot's own estimate); None if not measured
    wrench: FloatArray | None = None


@dataclass(frozen=True, slots=True)
class Reference:
    """Desired TCP motion at one instant (base frame).

    ``q``/``dq`` (joint reference from inverse kinematics) are only filled for
    joint-space controllers; ``q_null``/``dq_null`` only when the plan has a planned
    posture.
    """

    p: FloatArray  # (3,) [m]
    v: FloatArray  # (3,) [m/s]
    a: FloatArray  # (3,) [m/s²]
    R: FloatArray  # (3, 3) desired rotation matrix
    w: FloatArray  # (3,) [rad/s]
    q: FloatArray | None = None  # (7,) [rad]
    dq: FloatArray | None = None  # (7,) [rad/s]
    # the plan's posture (its ``joint_posture``): the null-space reference [rad] and
    # its rate [rad/s]; None: the controller's own rest posture (the start posture)
    q_null: FloatArray | None = None
    dq_null: FloatArray | None = None


@runtime_checkable
class Controller(Protocol):
    """A torque control law at 1 kHz (see the module docstring)."""

    @property
    def name(self) -> str:
        """Registry name of the law."""
        ...

    @property
    def needs_joint_reference(self) -> bool:
        """Whether ``step`` needs ``reference.q`` and ``reference.dq`` (from IK)."""
        ...

    def init(self, robot_state: RobotState, terms: ModelTerms) -> Any:
        """Initial controller state (e.g. the null-space posture, zero integrators)."""
        ...

    def step(
        self, ctrl_state: Any, robot_state: RobotState, reference: Reference, terms: ModelTerms
    ) -> tuple[FloatArray, Any]:
        """Joint torques (7,) [N·m], saturated, and the next controller state."""
        ...

    def describe(self) -> dict[str, Any]:
        """Name and gains, JSON-able."""
        ...


def check_gains(obj: Any, positive: tuple[str, ...], nonneg: tuple[str, ...] = ()) -> None:
    """Raise :class:`InvalidInput` unless the named gains are finite and > 0 (or >= 0)."""
    cls = type(obj).__name__
    for name in positive + nonneg:
        v = np.asarray(getattr(obj, name), dtype=np.float64)
        strict = name in positive
        ok = np.isfinite(v).all() and ((v > 0).all() if strict else (v >= 0).all())
        if not ok:
            raise InvalidInput(
                f"{cls}.{name} must be finite and {'> 0' if strict else '>= 0'}, "
                f"got {getattr(obj, name)!r}"
            )


def describe_gains(obj: Any) -> dict[str, Any]:
    """All dataclass fields as JSON-able values, plus the controller's name."""
    out: dict[str, Any] = {"name": obj.name}
    for f in fields(obj):
        v = getattr(obj, f.name)
        out[f.name] = np.asarray(v).tolist() if isinstance(v, np.ndarray | tuple) else v
    return out


_TAU_MIN = -TAU_MAX


def saturate(tau: FloatArray) -> FloatArray:
    """Clip joint torques to the Panda's limits ``TAU_MAX`` [N·m].

    ``np.clip``'s values, by its two ufuncs (``np.clip`` costs twice as much per call
    on a 7-vector, and the 1 kHz loop saturates every tick).
    """
    return np.minimum(np.maximum(tau, _TAU_MIN), TAU_MAX)


def orientation_error(R: FloatArray, R_d: FloatArray) -> FloatArray:
    """Quaternion orientation error of Eq. (5.9), computed from rotation matrices.

    ``e_H = (η1η2 + ε1ᵀε2)(−η1ε2 + η2ε1 − S(ε1)ε2)`` with (η1, ε1) the current and
    (η2, ε2) the desired quaternion is ``w·v`` of ``q1 ⊗ q2⁻¹``, which equals
    ``¼ vee(E − Eᵀ)`` for ``E = R R_dᵀ`` (``½ sin θ`` times the axis): the same
    value for q and −q, and cheaper than going through quaternions.

    Returns
    -------
    e_H : ndarray, shape (3,)
        Base frame [-] (≈ θ/2 for small angles θ [rad]).
    """
    e = (R @ R_d.T).ravel()  # E row-major: (E - Eᵀ)[2, 1] = e[7] - e[5], ...
    return 0.25 * (e.take(_VEE_PLUS) - e.take(_VEE_MINUS))


# vee(E - Eᵀ) = (E21 - E12, E02 - E20, E10 - E01), as flat indices of E
_VEE_PLUS, _VEE_MINUS = np.array([7, 2, 3]), np.array([5, 6, 1])


_EPS6 = 1e-6 * np.eye(6)


def minv_jt(terms: ModelTerms) -> FloatArray:
    """M⁻¹Jᵀ (7, 6): from the backend if it supplied it, else solved here."""
    if terms.MinvJt is not None:
        return terms.MinvJt
    return cast(FloatArray, np.linalg.solve(terms.M, terms.J.T))


def inv3(A: FloatArray) -> FloatArray:
    """Inverse of a 3×3 matrix by cofactors (cheaper than LAPACK at this size)."""
    (a, b, c), (d, e, f), (g, h, i) = A.tolist()
    co = [e * i - f * h, f * g - d * i, d * h - e * g]  # cofactors of row 0
    det = a * co[0] + b * co[1] + c * co[2]
    return (
        np.array(
            [
                [co[0], c * h - b * i, b * f - c * e],
                [co[1], a * i - c * g, c * d - a * f],
                [co[2], b * g - a * h, a * e - b * d],
            ]
        )
        / det
    )


def task_inertia(terms: ModelTerms) -> tuple[FloatArray, FloatArray]:
    """Operational-space inertia Λ = (J M⁻¹ Jᵀ)⁻¹ (6, 6) and M⁻¹Jᵀ (7, 6).

    Λ⁻¹ is regularised by 1e-6 I near singular configurations.
    """
    MinvJt = minv_jt(terms)
    Lam = cast(FloatArray, np.linalg.inv(terms.J @ MinvJt + _EPS6))
    return Lam, MinvJt


def translational_inertia(terms: ModelTerms) -> FloatArray:
    """M̄_p = (J_p M⁻¹ J_pᵀ)⁻¹ (3, 3) [kg], the inertia felt at the TCP along x, y, z."""
    MinvJt = minv_jt(terms)
    return inv3(terms.J[:3] @ MinvJt[:, :3] + 1e-6 * np.eye(3))


def null_reference(
    reference: Reference, q_rest: FloatArray
) -> tuple[FloatArray, FloatArray | None]:
    """The null-space posture [rad] and its rate [rad/s]: the plan's, else ``q_rest``."""
    if reference.q_null is None:
        return q_rest, None
    return reference.q_null, reference.dq_null


def nullspace_torque(
    terms: ModelTerms,
    q: FloatArray,
    dq: FloatArray,
    q_null: FloatArray,
    k_null: float,
    d_null: float,
    Lam: FloatArray | None = None,
    *,
    MinvJt: FloatArray | None = None,
    Lam_inv: FloatArray | None = None,
    dq_null: FloatArray | None = None,
) -> FloatArray:
    """Posture torque for the redundant 7th DoF, projected into the task null space.

    ``τ_n = (I − Jᵀ J̄ᵀ)(k_n (q_null − q) − d_n q̇)`` (``d_n (q̇_null − q̇)`` when the
    posture moves, ``dq_null``) with the dynamically consistent
    inverse ``J̄ = M⁻¹ Jᵀ Λ``, so it does not disturb the TCP (Khatib 1987).
    The caller may pass what it has already: ``Lam`` (6, 6), or ``Lam_inv`` = J M⁻¹ Jᵀ
    (6, 6, without the regularisation), and ``MinvJt`` (7, 6, :func:`minv_jt`).
    Without ``Lam``, ``Λ (M⁻¹Jᵀ)ᵀ τ0`` is solved by Cholesky (:func:`spd_solve`).
    """
    if k_null == 0.0 and d_null == 0.0:
        return np.zeros(N_JOINTS)
    if MinvJt is None:
        MinvJt = minv_jt(terms)
    tau0 = k_null * (q_null - q) - d_null * dq
    if dq_null is not None:
        tau0 = tau0 + d_null * dq_null
    y = MinvJt.T @ tau0
    if Lam is not None:
        f = Lam @ y
    else:
        f = spd_solve((terms.J @ MinvJt if Lam_inv is None else Lam_inv) + _EPS6, y)
    return tau0 - terms.J.T @ f  # J̄ᵀ τ0 = Λ (M⁻¹Jᵀ)ᵀ τ0


def spd_solve(A: FloatArray, y: FloatArray) -> FloatArray:
    """``A⁻¹ y`` for a symmetric positive-definite ``A`` (n, n), by Cholesky.

    MuJoCo's dense Cholesky (``mju_cholFactor``/``mju_cholSolve``): at the 6 x 6 of
    the task-space inertia a quarter of ``np.linalg.inv``'s cost per tick, and no
    explicit inverse. ``A`` is not modified.
    """
    mj = _mujoco()
    L = np.array(A, dtype=np.float64)  # factorised in place
    mj.mju_cholFactor(L, 0.0)
    x = np.empty(L.shape[0])
    mj.mju_cholSolve(x, L, np.ascontiguousarray(y, dtype=np.float64))
    return x


@functools.cache
def _mujoco() -> Any:
    from dexlfd.robot.robot_model import import_mujoco

    return import_mujoco()


def require_shape(x: FloatArray, shape: tuple[int, ...], name: str) -> None:
    """Raise :class:`InvalidInput` if ``x`` does not have ``shape``."""
    if np.shape(x) != shape:
        raise InvalidInput(f"{name} must have shape {shape}, got {np.shape(x)}")
