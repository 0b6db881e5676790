"""Forward kinematics of the Panda from the thesis's DH table (Table 3.1), pure NumPy.

An implementation independent of the MuJoCo model (which is built from the
URDF), used to check it and wherever a model-free forward kinematics is handy: a
leaf module (NumPy only) the planner may use. :class:`DhPanda` gives the TCP pose
and its geometric Jacobian (both from one chain of transforms) for
:func:`dexlfd.panda_ik.solve_ik`.
The table uses Craig's modified convention:
``T_i = Rot_x(alpha_{i-1}) Trans_x(a_{i-1}) Rot_z(theta_i) Trans_z(d_i)``.

References
----------
.. [1] J. J. Craig, Introduction to Robotics, 3rd ed., Eq. (3.6).
"""

from __future__ import annotations

import math

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.panda import DH_A, DH_ALPHA, DH_D, FLANGE_D, HAND_YAW, N_JOINTS, TCP_OFFSET

__all__ = ["DhPanda", "dh_flange", "dh_tcp"]


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


def _link1(a: float, ca: float, sa: float, d: float, theta: float) -> FloatArray:
    """One modified-DH transform (4, 4) (scalar :func:`_link`, for the IK's inner loop)."""
    ct, st = math.cos(theta), math.sin(theta)
    return np.array([
        [ct, -st, 0.0, a],
        [st * ca, ct * ca, -sa, -sa * d],
        [st * sa, ct * sa, ca, ca * d],
        [0.0, 0.0, 0.0, 1.0],
    ])  # fmt: skip  # [1] Eq. (3.6)


_CA, _SA = np.cos(DH_ALPHA).tolist(), np.sin(DH_ALPHA).tolist()


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


# flange -> TCP: Table 3.1's flange row, then the hand's -45 deg about z and 0.1034 m
_FLANGE_TCP = _link1(0.0, 1.0, 0.0, FLANGE_D, 0.0) @ _link1(0.0, 1.0, 0.0, TCP_OFFSET, HAND_YAW)


class DhPanda:
    """The Panda's TCP kinematics from Table 3.1 (no MuJoCo): pose and Jacobian.

    The Jacobian is the geometric one of the modified-DH chain: joint ``i`` turns
    about frame ``i``'s z axis ``z_i`` through its origin ``o_i``, so its column is
    ``[z_i x (p - o_i); z_i]`` (base frame, rows linear then angular).
    """

    n_joints = N_JOINTS

    def _frames(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Joint axes (7, 3), joint origins (7, 3) [m] and the TCP transform (4, 4)."""
        q = np.asarray(q, dtype=np.float64)
        T = np.eye(4)
        z, o = np.empty((N_JOINTS, 3)), np.empty((N_JOINTS, 3))
        for i in range(N_JOINTS):
            T = T @ _link1(float(DH_A[i]), _CA[i], _SA[i], float(DH_D[i]), float(q[i]))
            z[i], o[i] = T[:3, 2], T[:3, 3]
        return z, o, T @ _FLANGE_TCP

    def tcp_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """TCP position (3,) [m] and rotation matrix (3, 3) at ``q`` [rad]."""
        T = self._frames(q)[2]
        return T[:3, 3].copy(), T[:3, :3].copy()

    def tcp_jacobian(self, q: FloatArray) -> FloatArray:
        """TCP Jacobian (6, 7) at ``q`` [rad]: rows linear [m/rad] then angular [-]."""
        return self._jacobian(*self._frames(q))

    def tcp_pose_jacobian(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`tcp_pose` and :meth:`tcp_jacobian` at ``q`` from one chain of transforms."""
        z, o, T = self._frames(q)
        return T[:3, 3].copy(), T[:3, :3].copy(), self._jacobian(z, o, T)

    @staticmethod
    def _jacobian(z: FloatArray, o: FloatArray, T: FloatArray) -> FloatArray:
        """The geometric Jacobian (6, 7) from the joint axes, origins and TCP transform."""
        return np.vstack([np.cross(z, T[:3, 3] - o).T, z.T])
