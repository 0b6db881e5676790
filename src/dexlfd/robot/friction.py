r"""Joint friction of the Panda as identified by Gaz et al. (2019).

.. math:: \tau_{f,i}(\dot q_i) = \frac{\varphi_{1,i}}{1 + e^{-\varphi_{2,i}(\dot q_i
   + \varphi_{3,i})}} - \frac{\varphi_{1,i}}{1 + e^{-\varphi_{2,i}\varphi_{3,i}}}

A smooth Coulomb law (level ``phi1`` [N·m], reached within ~``4/phi2`` [rad/s])
with an offset, plus an optional linear viscous term. Zero at zero velocity.

References
----------
.. [1] C. Gaz, M. Cognetti, A. Oliva, P. Robuffo Giordano, A. De Luca, "Dynamic
   identification of the Franka Emika Panda robot with retrieval of feasible
   parameters using penalty-based optimization", IEEE RA-L 4(4), 2019 (friction model).
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.panda import FRICTION_PHI1, FRICTION_PHI2, FRICTION_PHI3

__all__ = ["FrictionLaw", "friction_torque"]


def friction_torque(
    dq: FloatArray, scale: float = 1.0, viscous: FloatArray | float = 0.0
) -> FloatArray:
    """Friction torque that opposes joint motion.

    Parameters
    ----------
    dq : ndarray, shape (..., 7)
        Joint velocities [rad/s].
    scale : float
        Multiplies the identified sigmoid levels ``phi1`` [-].
    viscous : float or ndarray, shape (7,)
        Extra linear viscous coefficient [N·m·s/rad].

    Returns
    -------
    tau_f : ndarray, shape (..., 7)
        Friction torque [N·m] in the convention ``tau = M qdd + C qd + g + tau_f``.
    """
    return FrictionLaw(scale, viscous)(dq)


class FrictionLaw:
    """:func:`friction_torque` with its constants computed once (the plant's physics step).

    Parameters
    ----------
    scale, viscous
        As for :func:`friction_torque`.
    """

    def __init__(self, scale: float = 1.0, viscous: FloatArray | float = 0.0) -> None:
        self._phi1 = scale * FRICTION_PHI1
        self._minus_phi2 = -FRICTION_PHI2
        self._offset = self._phi1 / (1.0 + np.exp(-FRICTION_PHI2 * FRICTION_PHI3))  # [1]
        self._viscous = np.asarray(viscous)

    def rows(self) -> FloatArray:
        """(5, 7): φ1 (scaled), −φ2, φ3, the offset and the viscous coefficient per joint."""
        n = FRICTION_PHI1.shape[0]
        return np.array([
            self._phi1, self._minus_phi2, FRICTION_PHI3, self._offset,
            np.broadcast_to(self._viscous, (n,)),
        ], dtype=np.float64)  # fmt: skip

    def __call__(self, dq: FloatArray) -> FloatArray:
        """Friction torque [N·m] at joint velocities ``dq`` [rad/s] (shape (..., 7))."""
        sig = self._phi1 / (1.0 + np.exp(self._minus_phi2 * (dq + FRICTION_PHI3)))  # [1]
        return sig - self._offset + self._viscous * dq
