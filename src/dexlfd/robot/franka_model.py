"""libfranka's model library behind the :class:`~dexlfd.robot.robot_model.RobotModel` interface."""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.panda import N_JOINTS
from dexlfd.panda_kinematics import dh_flange
from dexlfd.robot.libfranka import FrankaState
from dexlfd.robot.robot_model import ModelTerms

__all__ = ["STANDARD_GRAVITY", "FrankaModel"]

logger = logging.getLogger(__name__)

STANDARD_GRAVITY = np.array([0.0, 0.0, -9.81])  # [m/s²] base frame


class FrankaModel:
    """libfranka's model library behind the :class:`~dexlfd.robot.robot_model.RobotModel` interface.

    M, C·q̇, G and the zero Jacobian of the end-effector frame come from the
    robot's model (column-major flat lists, reshaped here); J̇q̇ is a central
    difference of that Jacobian along q̇ (libfranka has no J̇); the TCP pose of
    an arbitrary ``q`` comes from the DH table (Table 3.1, identical for Panda
    and FR3) times the robot's flange-to-TCP transform ``F_T_EE``, while
    :meth:`terms_at` uses the pose the robot itself reports.

    Parameters
    ----------
    model : pylibfranka.Model
        From ``Robot.load_model()``.
    state : pylibfranka.RobotState
        A state of that robot; a private scratch copy is kept, whose ``q``/``dq``
        are overwritten per call (the model reads the end-effector mass,
        ``F_T_EE`` and the load from it).
    gravity : ndarray, shape (3,)
        Gravity acceleration in the base frame [m/s²]. Used when the robot
        reports zero base acceleration ``O_ddP_O`` (the protocol simulators do).
    frame : libfranka Frame or None
        ``Frame.kEndEffector`` of libfranka 0.9 (the FER's binding, whose model
        calls name the frame and take gravity as an argument); None for 0.21.
    """

    n_joints = N_JOINTS

    def __init__(
        self, model: Any, state: Any, gravity: FloatArray = STANDARD_GRAVITY, frame: Any = None
    ) -> None:
        self._model = model
        self.frame = frame
        self._scratch = state
        reported = np.array(getattr(state, "O_ddP_O", np.zeros(3)))  # libfranka 0.9 has none
        self.gravity_vector = reported if np.linalg.norm(reported) > 1.0 else np.asarray(gravity)
        if np.linalg.norm(reported) <= 1.0:
            logger.info(
                "robot reports base acceleration %s; computing gravity with %s m/s²",
                reported.tolist(),
                np.asarray(gravity).tolist(),
            )
        self.F_T_EE = np.array(state.F_T_EE).reshape(4, 4, order="F")
        self._fd_step = 1e-6  # [rad] central-difference step for J̇q̇ (error O(step²))
        if frame is None:
            self._scratch.O_ddP_O = self.gravity_vector.tolist()
        else:  # libfranka 0.9's states are read-only: its explicit-argument calls
            self._load = (list(state.I_total), float(state.m_total), list(state.F_x_Ctotal))
            self._frames = (list(state.F_T_EE), list(state.EE_T_K))
            self._q: list[float] = list(state.q)
            self._dq: list[float] = list(state.dq)

    def _set(self, q: FloatArray, dq: FloatArray | None = None) -> None:
        if self.frame is None:
            self._scratch.q = q.tolist()
            if dq is not None:
                self._scratch.dq = dq.tolist()
        else:
            self._q = q.tolist()
            if dq is not None:
                self._dq = dq.tolist()

    def _jacobian(self) -> FloatArray:
        m = self._model
        if self.frame is None:
            J = m.zero_jacobian(self._scratch)
        else:  # libfranka 0.9 (FER): frame, q, F_T_EE, EE_T_K
            J = m.zero_jacobian(self.frame, self._q, *self._frames)
        return np.array(J).reshape(6, N_JOINTS, order="F")

    def _jdq(self, q: FloatArray, dq: FloatArray) -> FloatArray:
        speed = float(np.linalg.norm(dq))
        if speed < 1e-12:
            return np.zeros(6)
        u = dq / speed
        h = self._fd_step
        self._set(q + h * u)
        J_plus = self._jacobian()
        self._set(q - h * u)
        J_minus = self._jacobian()
        self._set(q)
        # dJ/dt = Σ ∂J/∂q_i q̇_i = |q̇| · (directional derivative along u)
        return ((J_plus - J_minus) / (2 * h)) @ dq * speed

    def _dynamics(self, q: FloatArray, dq: FloatArray) -> tuple[FloatArray, ...]:
        self._set(q, dq)
        m = self._model
        if self.frame is None:  # libfranka 0.21 reads gravity from the state's O_ddP_O
            M = m.mass(self._scratch)
            c = m.coriolis(self._scratch)
            g = m.gravity(self._scratch)
        else:  # libfranka 0.9 takes the load and gravity as arguments
            I_total, m_total, F_x_Ctotal = self._load
            M = m.mass(self._q, I_total, m_total, F_x_Ctotal)
            c = m.coriolis(self._q, self._dq, I_total, m_total, F_x_Ctotal)
            g = m.gravity(self._q, m_total, F_x_Ctotal, self.gravity_vector.tolist())
        M = np.array(M).reshape(N_JOINTS, N_JOINTS, order="F")
        J = self._jacobian()
        return M, np.array(c), np.array(g), J, self._jdq(q, dq)

    def gravity(self, q: FloatArray) -> FloatArray:
        """Gravity torque G(q) (7,) [N·m]: what the robot compensates itself."""
        self._set(q)
        if self.frame is None:
            return np.array(self._model.gravity(self._scratch))
        _I, m_total, F_x_Ctotal = self._load
        return np.array(
            self._model.gravity(self._q, m_total, F_x_Ctotal, self.gravity_vector.tolist())
        )

    def terms(self, q: FloatArray, dq: FloatArray) -> ModelTerms:
        """Model terms at ``(q, dq)``; the TCP pose from the DH table and ``F_T_EE``."""
        M, c, g, J, Jdq = self._dynamics(q, dq)
        p, R = self.tcp_pose(q)
        return ModelTerms(M=M, h=c + g, g=g, J=J, Jdq=Jdq, p=p, R=R)

    def terms_at(self, state: FrankaState) -> ModelTerms:
        """Model terms at a measured state, with the TCP pose the robot reports."""
        M, c, g, J, Jdq = self._dynamics(state.q, state.dq)
        T = state.O_T_EE
        return ModelTerms(M=M, h=c + g, g=g, J=J, Jdq=Jdq, p=T[:3, 3].copy(), R=T[:3, :3].copy())

    def tcp_pose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """TCP position (3,) [m] and rotation (3, 3) at ``q``."""
        T = dh_flange(np.asarray(q, dtype=np.float64)) @ self.F_T_EE
        return T[:3, 3].copy(), T[:3, :3].copy()

    def tcp_jacobian(self, q: FloatArray) -> FloatArray:
        """Zero Jacobian (6, 7) of the end-effector frame at ``q``."""
        self._set(np.asarray(q, dtype=np.float64), np.zeros(N_JOINTS))
        return self._jacobian()

    def tcp_pose_jacobian(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`tcp_pose` and :meth:`tcp_jacobian` at ``q`` (the robot's model gives each)."""
        return (*self.tcp_pose(q), self.tcp_jacobian(q))
