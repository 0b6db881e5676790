"""The joint-space sliding-mode law of Eqs. (5.16)-(5.22), as printed.

With the joint error ``e = q_d − q`` (the state ``x₁`` of Eq. 5.16 and
``x₂ = ė``), the surface of Eq. (5.17) with slope ``c`` (the print's λ in 5.17,
c in 5.21) is ``s = c e + ė``. The reaching law ``ṡ = −ε sgn(s) − p s``
(below Eq. 5.18) solved for q̈ is Eq. (5.21)::

    q̈ = c (q̇_d − q̇) + q̈_d + ε sgn(s) + p s

(printed ``c q̇_d − q̇``: the parenthesis is lost, the derivation needs
``c ė``), and Eq. (5.22) turns it into a torque with the nominal model::

    τ = M(q) q̈ + C(q̇, q) q̇ + G(q)

(printed ``C(q̇, q)`` without the ``q̇``). ``sgn`` is Eq. (5.20)'s sign
function; ``phi`` > 0 (ours, off by default) replaces it by ``tanh(s / φ)``.

The thesis gives no joint-space gains (its §5.3.3 gains are the Cartesian
laws'). Ours: with ε = 0 the law is the joint PD ``M(p c e + (p + c) ė)``, so
``c = p = ω`` is critically damped with bandwidth ω; the defaults c = p = 30
1/s match :class:`~dexlfd.control.pd.JointPd` (ω = 30 rad/s), so the switching
term ε sgn(s) is the only difference. Static stiffness per joint: the load
torque ``d`` settles at ``p c e + ε sgn(e) = M⁻¹ d``.

``q̈_d`` is the backward difference of the reference's joint velocity between
control ticks (what a controller fed a joint stream has), kept in the state.

References
----------
.. [1] Thesis §5.2.4, Eqs. (5.16)-(5.22).
.. [2] J.-J. E. Slotine, W. Li, Applied Nonlinear Control, Prentice Hall 1991, §7.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.base import Reference, RobotState, check_gains, describe_gains, saturate
from dexlfd.robot.robot_model import ModelTerms

__all__ = ["JointSlidingMode", "JointSmState", "joint_sm_acceleration"]


def joint_sm_acceleration(
    e: FloatArray, de: FloatArray, ddq_d: FloatArray, c: float, p: float, epsilon: float,
    phi: float = 0.0,
) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """Surface ``s`` (7,) and the commanded joint acceleration of Eq. (5.21) (7,) [rad/s²].

    Parameters
    ----------
    e, de : ndarray (7,)
        ``q_d − q`` [rad] and ``q̇_d − q̇`` [rad/s].
    ddq_d : ndarray (7,)
        Reference joint acceleration [rad/s²].
    c, p : float
        Surface slope [1/s] and proportional reaching gain [1/s].
    epsilon : float
        Switching gain [rad/s²].
    phi : float
        Boundary layer [rad/s]; 0 = the sign function of Eq. (5.20).
    """
    s = c * e + de  # [1] Eq. (5.17): s = λ x₁ + x₂
    sw = np.sign(s) if phi == 0.0 else np.tanh(s / phi)  # [1] Eq. (5.20)
    return s, c * de + ddq_d + epsilon * sw + p * s  # [1] Eq. (5.21)


@dataclass(frozen=True, slots=True)
class JointSmState:
    """Last reference joint velocity [rad/s] and its time [s] (for q̈_d)."""

    dq_d: FloatArray
    t: float


@dataclass(frozen=True, slots=True)
class JointSlidingMode:
    """Joint-space sliding mode, Eq. (5.22): ``τ = M q̈ + C q̇ + G`` with q̈ of Eq. (5.21).

    ``c`` [1/s] surface slope, ``p`` [1/s] proportional reaching gain, ``epsilon``
    [rad/s²] switching gain, ``phi`` [rad/s] optional boundary layer (0 = sgn).
    """

    c: float = 30.0
    p: float = 30.0
    epsilon: float = 0.5
    phi: float = 0.0
    name: str = field(default="sm-joint", init=False)
    needs_joint_reference: bool = field(default=True, init=False)

    def __post_init__(self) -> None:
        check_gains(self, ("c",), ("p", "epsilon", "phi"))

    def init(self, robot_state: RobotState, terms: ModelTerms) -> JointSmState:
        """No reference seen yet: q̈_d = 0 on the first tick (the NaN time)."""
        return JointSmState(np.zeros_like(robot_state.dq), float("nan"))

    def step(
        self, ctrl_state: JointSmState, robot_state: RobotState, reference: Reference,
        terms: ModelTerms,
    ) -> tuple[FloatArray, JointSmState]:  # fmt: skip
        """Eq. (5.22) torque, saturated; needs ``reference.q`` and ``reference.dq``."""
        q_d = reference.q if reference.q is not None else robot_state.q
        dq_d = reference.dq if reference.dq is not None else np.zeros_like(q_d)
        dt = robot_state.t - ctrl_state.t
        ddq_d = (dq_d - ctrl_state.dq_d) / dt if dt > 0 else np.zeros_like(q_d)
        _, ddq = joint_sm_acceleration(
            q_d - robot_state.q, dq_d - robot_state.dq, ddq_d, self.c, self.p, self.epsilon,
            self.phi,
        )  # fmt: skip
        tau = terms.M @ ddq + terms.h  # [1] Eq. (5.22)
        return saturate(tau), JointSmState(np.array(dq_d, dtype=np.float64), robot_state.t)

    def describe(self) -> dict[str, Any]:
        """Name and gains."""
        return describe_gains(self)
