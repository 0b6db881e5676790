"""PD control laws: joint PD with gravity compensation and the thesis's Cartesian PD.

References
----------
.. [1] Thesis §5.2.2, Eqs. (5.8)–(5.9); §5.3.3 gains.
.. [2] F. Caccavale, C. Natale, B. Siciliano, L. Villani, "Six-DOF impedance control
   based on angle/axis representations", IEEE T-RA 15(2), 1999 (the quaternion error).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import (
    Reference,
    RobotState,
    check_gains,
    describe_gains,
    null_reference,
    nullspace_torque,
    orientation_error,
    saturate,
)
from dexlfd.robot.robot_model import ModelTerms

__all__ = ["CartesianPd", "JointPd", "NullState", "rotational_pd"]


@dataclass(frozen=True, slots=True)
class NullState:
    """State of a memoryless law: just the null-space rest posture [rad]."""

    q_null: FloatArray


class Memoryless:
    """Mixin of the laws without memory: state = start posture, describe = gains."""

    __slots__ = ()

    def init(self, robot_state: RobotState, terms: ModelTerms) -> NullState:
        """No memory beyond the start posture."""
        return NullState(robot_state.q.copy())

    def describe(self) -> dict[str, Any]:
        """Name and gains."""
        return describe_gains(self)

    def step(
        self,
        ctrl_state: NullState,
        robot_state: RobotState,
        reference: Reference,
        terms: ModelTerms,
    ) -> tuple[FloatArray, NullState]:
        """The law's :meth:`torque`, saturated; the state does not change."""
        return saturate(self.torque(robot_state, reference, terms, ctrl_state.q_null)), ctrl_state

    def torque(
        self, robot_state: RobotState, reference: Reference, terms: ModelTerms, q_null: FloatArray
    ) -> FloatArray:
        """Joint torque (7,) [N·m] before saturation; ``q_null`` is the rest posture [rad]."""
        raise NotImplementedError


def rotational_pd(
    terms: ModelTerms, dq: FloatArray, ref: Reference, K_H: float, D_H: float
) -> FloatArray:
    """Moment (3,) [N·m] of the rotational PD, Eq. (5.9): −K_H e_H − D_H (ω − ω_d)."""
    e_H = orientation_error(terms.R, ref.R)  # [1] Eq. (5.9), [2]
    w = terms.J[3:] @ dq
    return -K_H * e_H - D_H * (w - ref.w)  # [1] Eq. (5.9)


@dataclass(frozen=True, slots=True)
class JointPd(Memoryless):
    """Joint-space PD plus gravity with inertia-shaped gains.

    ``τ = M(q) (ω² (q_d − q) + 2ζω (q̇_d − q̇)) + G(q)``: gain matrices
    ``K = ω² M``, ``D = 2ζω M`` give every joint mode the bandwidth ω.
    Fixed diagonal gains (Franka's example: K = 600…50, D = 50…10) are unstable
    on this link-side model with a 1 ms torque delay: joint 7 has 0.007 kg·m²
    and, near q2 = 0, joints 1 and 3 form a mode of ~0.02 kg·m²
    (D·dt/I > 1); the real arm's rotor inertia hides this.
    """

    omega: float = 30.0  # [rad/s]
    zeta: float = 1.0  # [-]
    name: str = field(default="joint-pd", init=False)
    needs_joint_reference: bool = field(default=True, init=False)

    def __post_init__(self) -> None:
        check_gains(self, ("omega", "zeta"))

    def torque(
        self, robot_state: RobotState, reference: Reference, terms: ModelTerms, q_null: FloatArray
    ) -> FloatArray:
        """Joint PD + G(q) (needs ``reference.q``/``reference.dq``)."""
        q_d = reference.q if reference.q is not None else q_null
        dq_d = reference.dq if reference.dq is not None else np.zeros_like(q_d)
        w = self.omega
        a = w * w * (q_d - robot_state.q) + 2.0 * self.zeta * w * (dq_d - robot_state.dq)
        return terms.M @ a + terms.g


@dataclass(frozen=True, slots=True)
class CartesianPd(Memoryless):
    """Cartesian PD on translation and rotation plus C·q̇ + G (the thesis's "PD [55]").

    ``τ = J_pᵀ(−K_p e_p − D_p ė_p) + J_Hᵀ(−K_H e_H − D_H ė_H) + C q̇ + G + τ_null``
    with ``e_p = p − p_d`` ([1] Eqs. (5.8)–(5.9); gains of §5.3.3).
    """

    K_p: float = 600.0  # [N/m]
    D_p: float = 28.3  # [N·s/m]
    K_H: float = 30.0  # [N·m] per unit of e_H
    D_H: float = 3.5  # [N·m·s/rad]
    k_null: float = 10.0  # [N·m/rad]
    d_null: float = 6.3  # [N·m·s/rad]
    name: str = field(default="pd", init=False)
    needs_joint_reference: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        check_gains(self, ("K_p", "K_H"), ("D_p", "D_H", "k_null", "d_null"))

    def torque(
        self, robot_state: RobotState, reference: Reference, terms: ModelTerms, q_null: FloatArray
    ) -> FloatArray:
        """Cartesian PD torque."""
        dq = robot_state.dq
        e_p = terms.p - reference.p
        de_p = terms.J[:3] @ dq - reference.v
        F = -self.K_p * e_p - self.D_p * de_p  # [1] Eq. (5.8)
        m = rotational_pd(terms, dq, reference, self.K_H, self.D_H)
        tau = terms.J[:3].T @ F + terms.J[3:].T @ m + terms.h
        qn, dqn = null_reference(reference, q_null)
        tau += nullspace_torque(terms, robot_state.q, dq, qn, self.k_null, self.d_null,
                                dq_null=dqn)  # fmt: skip
        return tau
