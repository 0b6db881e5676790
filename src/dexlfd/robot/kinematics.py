"""Forward kinematics of the Panda from the thesis's DH table (Table 3.1), pure NumPy.

An implementation independent of the MuJoCo model (which is built from the
URDF), used to check it and wherever a model-free forward kinematics is handy.
The table uses Craig's modified convention:
``T_i = Rot_x(alpha_{i-1}) Trans_x(a_{i-1}) Rot_z(theta_i) Trans_z(d_i)``.

References
----------
.. [1] J. J. Craig, Introduction to Robotics, 3rd ed., Eq. (3.6).
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.panda import DH_A, DH_ALPHA, DH_D, FLANGE_D, HAND_YAW, N_JOINTS, TCP_OFFSET

__all__ = ["dh_flange", "dh_tcp"]


def _link(a: float, alpha: float, d: FloatArray, theta: FloatArray) -> FloatArray:
    """Modified-DH transforms ``(..., 4, 4)`` for broadcast joint angles."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros((*np.shape(theta), 4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = ct, -st, a  # [1] Eq. (3.6)
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st * ca, ct * ca, -sa, -sa * d
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = st * sa, ct * sa, ca, ca * d
    T[..., 3, 3] = 1.0
    return T


def dh_flange(q: FloatArray) -> FloatArray:
    """Base-to-flange transforms from Table 3.1.

    Parameters
    ----------
    q : ndarray, shape (..., 7)
        Joint angles [rad].

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
        Homogeneous transforms, translation in [m].
    """
    q = np.asarray(q, dtype=np.float64)
    T = np.broadcast_to(np.eye(4), (*q.shape[:-1], 4, 4)).copy()
    for i in range(N_JOINTS):
        T = T @ _link(DH_A[i], DH_ALPHA[i], np.asarray(DH_D[i]), q[..., i])
    flange = _link(0.0, 0.0, np.asarray(FLANGE_D), np.zeros(q.shape[:-1]))
    return T @ flange


def dh_tcp(q: FloatArray) -> FloatArray:
    """Base-to-TCP transforms ``(..., 4, 4)``: flange, −45° about z, 0.1034 m along z."""
    q = np.asarray(q, dtype=np.float64)
    hand = _link(0.0, 0.0, np.asarray(TCP_OFFSET), np.full(q.shape[:-1], HAND_YAW))
    return dh_flange(q) @ hand
