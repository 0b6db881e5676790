"""Cartesian impedance control, Eqs. (5.10)–(5.15).

With the dynamically consistent inverse ``J⁻¹ → J̄ = M⁻¹JᵀΛ`` of the redundant
arm, ``M J̄ = JᵀΛ`` and Eq. (5.15) without a measured external force reads
``τ = JᵀΛ(ẍ_d + M_d⁻¹(D_d(ẋ_d − ẋ) + K_d(x_d − x)) − J̇q̇) + C q̇ + G``. The
orientation part of ``x_d − x`` is ``−e_H`` of Eq. (5.9).

References
----------
.. [1] Thesis §5.2.3, Eqs. (5.10)–(5.15).
.. [2] O. Khatib, "A unified approach for motion and force control of robot
   manipulators: the operational space formulation", IEEE J-RA 3(1), 1987.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import (
    Reference,
    RobotState,
    check_gains,
    nullspace_torque,
    orientation_error,
    task_inertia,
)
from dexlfd.control.pd import Memoryless
from dexlfd.robot.model import ModelTerms

__all__ = ["Impedance"]


@dataclass(frozen=True, slots=True)
class Impedance(Memoryless):
    """Cartesian impedance with desired mass, damping and stiffness per axis.

    Translation: ``M_d`` [kg], ``D_d`` [N·s/m], ``K_d`` [N/m]; rotation:
    ``M_dr`` [kg·m²], ``D_dr`` [N·m·s/rad], ``K_dr`` [N·m] (per unit of e_H).
    Defaults: critically damped, stiffness as the thesis's PD (600, 30). The felt
    stiffness is Λ M_d⁻¹ K_d: M_dr must be near the wrist's small rotational
    inertia (~0.01 kg·m²), or joint friction alone tilts the TCP by ~10°.
    """

    M_d: float = 1.0
    D_d: float = 49.0
    K_d: float = 600.0
    M_dr: float = 0.01
    D_dr: float = 1.1
    K_dr: float = 30.0
    k_null: float = 10.0
    d_null: float = 6.3
    name: str = field(default="impedance", init=False)
    needs_joint_reference: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        check_gains(self, ("M_d", "K_d", "M_dr", "K_dr"), ("D_d", "D_dr", "k_null", "d_null"))

    def torque(
        self, robot_state: RobotState, reference: Reference, terms: ModelTerms, q_null: FloatArray
    ) -> FloatArray:
        """Impedance torque, Eq. (5.15) with F_ext = 0."""
        dq = robot_state.dq
        xd = terms.J @ dq
        a = np.empty(6)
        a[:3] = (
            reference.a
            + (self.D_d * (reference.v - xd[:3]) + self.K_d * (reference.p - terms.p)) / self.M_d
        )  # [1] Eq. (5.15)
        a[3:] = (
            self.D_dr * (reference.w - xd[3:]) - self.K_dr * orientation_error(terms.R, reference.R)
        ) / self.M_dr
        a -= terms.Jdq  # [1] Eq. (5.14): ẍ = J q̈ + J̇ q̇
        Lam, _ = task_inertia(terms)
        tau = terms.J.T @ (Lam @ a) + terms.h  # [2]: M J̄ = Jᵀ Λ
        tau += nullspace_torque(terms, robot_state.q, dq, q_null, self.k_null, self.d_null, Lam)
        return tau
