"""Cartesian impedance control, Eqs. (5.10)–(5.15), with an external-force input.

With the dynamically consistent inverse ``J⁻¹ → J̄ = M⁻¹JᵀΛ`` of the redundant
arm, ``M J̄ = JᵀΛ`` and Eq. (5.15) reads::

    τ = JᵀΛ(ẍ_d + M_d⁻¹(D_d(ẋ_d − ẋ) + K_d(x_d − x)) − J̇q̇) + (Jᵀ − JᵀΛM_d⁻¹) F_ext + C q̇ + G

The orientation part of ``x_d − x`` is ``−e_H`` of Eq. (5.9). ``F_ext`` follows
the sign of Eq. (5.12) (``M q̈ + C q̇ + G = τ − τ_ext``, ``τ_ext = Jᵀ F_ext``), so it
is minus the wrench ``w`` the environment applies at the TCP. Substituting τ into
the plant gives the target impedance (5.11) exactly,
``M_d(ẍ_d − ẍ) + D_d(ẋ_d − ẋ) + K_d(x_d − x) = F_ext``: a push ``w`` held still
deflects the TCP by ``K_d⁻¹ w``. Without ``F_ext`` (``external_force="none"``,
the thesis's experiments) the felt stiffness is ``Λ M_d⁻¹ K_d`` instead.

``external_force`` selects where ``F_ext`` comes from:

* ``"none"``: ``F_ext = 0``;
* ``"observer"``: estimated from the joint torques with the generalized-momentum
  observer (:func:`~dexlfd.control.observer.momentum_residual`, bandwidth ``K_O``):
  ``ŵ = J̄ᵀ r = Λ J M⁻¹ r``. It lumps every unmodelled torque (friction, model
  error, payload) into ``ŵ``, so the arm also yields to those;
* ``"measured"``: ``RobotState.wrench`` (a force/torque sensor, or libfranka's
  ``O_F_ext_hat_K``); zero on a tick without one.

References
----------
.. [1] Thesis §5.2.3, Eqs. (5.10)–(5.15).
.. [2] O. Khatib, "A unified approach for motion and force control of robot
   manipulators: the operational space formulation", IEEE J-RA 3(1), 1987.
.. [3] A. De Luca, R. Mattone, "Sensorless robot collision detection and hybrid
   force/motion control", ICRA 2005 (the momentum observer).
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
    task_inertia,
)
from dexlfd.control.observer import ObserverState, momentum_residual, observer_at_rest
from dexlfd.control.pd import NullState
from dexlfd.errors import InvalidInput
from dexlfd.robot.robot_model import ModelTerms

__all__ = ["EXTERNAL_FORCES", "Impedance"]

EXTERNAL_FORCES = ("none", "observer", "measured")


@dataclass(frozen=True, slots=True)
class Impedance:
    """Cartesian impedance with desired mass, damping and stiffness per axis.

    Translation: ``M_d`` [kg], ``D_d`` [N·s/m], ``K_d`` [N/m]; rotation:
    ``M_dr`` [kg·m²], ``D_dr`` [N·m·s/rad], ``K_dr`` [N·m] (per unit of e_H).
    Defaults: critically damped, stiffness as the thesis's PD (600, 30). Without
    ``F_ext`` the felt stiffness is Λ M_d⁻¹ K_d: M_dr must be near the wrist's
    small rotational inertia (~0.01 kg·m²), or joint friction alone tilts the TCP
    by ~10°. ``external_force`` (see the module docstring) and the observer
    bandwidth ``K_O`` [1/s].
    """

    M_d: float = 1.0
    D_d: float = 49.0
    K_d: float = 600.0
    M_dr: float = 0.01
    D_dr: float = 1.1
    K_dr: float = 30.0
    k_null: float = 10.0
    d_null: float = 6.3
    external_force: str = "none"
    K_O: float = 60.0
    name: str = field(default="impedance", init=False)
    needs_joint_reference: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        check_gains(
            self, ("M_d", "K_d", "M_dr", "K_dr", "K_O"), ("D_d", "D_dr", "k_null", "d_null")
        )
        if self.external_force not in EXTERNAL_FORCES:
            raise InvalidInput(
                f"Impedance.external_force must be one of {EXTERNAL_FORCES}, "
                f"got {self.external_force!r}"
            )
        if self.external_force != "none":  # the registry key, e.g. impedance-fext
            suffix = "fext" if self.external_force == "observer" else "measured"
            object.__setattr__(self, "name", f"impedance-{suffix}")

    def init(self, robot_state: RobotState, terms: ModelTerms) -> Any:
        """The start posture (null space), plus the observer at rest if one is used."""
        rest = NullState(robot_state.q.copy())
        if self.external_force == "observer":
            return observer_at_rest(rest, robot_state, terms)
        return rest

    def step(
        self, ctrl_state: Any, robot_state: RobotState, reference: Reference, terms: ModelTerms
    ) -> tuple[FloatArray, Any]:
        """Eq. (5.15) torque, saturated, and the next state."""
        if self.external_force == "observer":
            st: ObserverState = ctrl_state
            Lam, MinvJt = task_inertia(terms)
            p_hat, r = momentum_residual(st, robot_state, terms, self.K_O)
            F_ext = -(Lam @ (MinvJt.T @ r))  # ŵ = J̄ᵀ r; Eq. (5.12) sign: F_ext = −w
            tau = saturate(self.torque(robot_state, reference, terms, st.inner.q_null, F_ext, Lam))
            return tau, ObserverState(st.inner, p_hat, r, terms.M.copy(), tau, robot_state.t)
        F_meas = None
        if self.external_force == "measured":
            if robot_state.wrench is None:
                raise InvalidInput(
                    "impedance with a measured external force needs the TCP wrench in the "
                    "robot state (a force/torque sensor); this arm reports none: use "
                    "impedance-fext (the momentum-observer estimate) instead"
                )
            F_meas = -np.asarray(robot_state.wrench, dtype=np.float64)
        tau = saturate(self.torque(robot_state, reference, terms, ctrl_state.q_null, F_meas))
        return tau, ctrl_state

    def torque(
        self, robot_state: RobotState, reference: Reference, terms: ModelTerms,
        q_null: FloatArray, F_ext: FloatArray | None = None, Lam: FloatArray | None = None,
    ) -> FloatArray:  # fmt: skip
        """Impedance torque (7,) [N·m] before saturation, Eq. (5.15).

        ``F_ext`` (6,) [N, N·m] in the sign of Eq. (5.12); None means zero. ``Lam``
        (6, 6): Λ if the caller has it already.
        """
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
        if Lam is None:
            Lam, _ = task_inertia(terms)
        if F_ext is not None:
            Md_inv = np.repeat([1.0 / self.M_d, 1.0 / self.M_dr], 3)
            a -= Md_inv * F_ext  # [1] Eq. (5.15): −JᵀΛ M_d⁻¹ F_ext
        tau = terms.J.T @ (Lam @ a) + terms.h  # [2]: M J̄ = Jᵀ Λ
        if F_ext is not None:
            tau += terms.J.T @ F_ext  # [1] Eq. (5.15): + Jᵀ F_ext
        qn, dqn = null_reference(reference, q_null)
        tau += nullspace_torque(terms, robot_state.q, dq, qn, self.k_null, self.d_null, Lam,
                                dq_null=dqn)  # fmt: skip
        return tau

    def describe(self) -> dict[str, Any]:
        """Name and gains."""
        return describe_gains(self)
