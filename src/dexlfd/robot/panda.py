"""Named constants of the Franka Emika Panda (arm, hand, limits, kinematics).

Limits are Franka's published figures for the Panda (FE-3),
https://frankaemika.github.io/docs/control_parameters.html ("Limits for Panda").
The kinematic table is the thesis's Table 3.1 (Craig's modified DH convention).

References
----------
.. [1] Franka Emika, "Robot and interface specifications: limits for Panda".
.. [2] C. Gaz, M. Cognetti, A. Oliva, P. Robuffo Giordano, A. De Luca, "Dynamic
   identification of the Franka Emika Panda robot with retrieval of feasible
   parameters using penalty-based optimization", IEEE RA-L 4(4), 2019.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ARM_JOINT_NAMES",
    "DH_A",
    "DH_ALPHA",
    "DH_D",
    "DQ_MAX",
    "DTAU_MAX",
    "FINGER_MAX",
    "FLANGE_D",
    "FRICTION_PHI1",
    "FRICTION_PHI2",
    "FRICTION_PHI3",
    "HAND_YAW",
    "MAX_PAYLOAD",
    "N_JOINTS",
    "Q_MAX",
    "Q_MIN",
    "Q_READY",
    "REACH",
    "SHOULDER_HEIGHT",
    "TAU_MAX",
    "TCP_OFFSET",
]

N_JOINTS = 7
ARM_JOINT_NAMES = tuple(f"panda_joint{i}" for i in range(1, N_JOINTS + 1))

# [1] joint position limits [rad]
Q_MIN = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
Q_MAX = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
# [1] joint velocity limits [rad/s]
DQ_MAX = np.array([2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100])
# [1] joint torque limits [N·m]
TAU_MAX = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
DTAU_MAX = 1000.0  # [N·m/s], [1] maximum rate of the commanded torque (all joints)
MAX_PAYLOAD = 3.0  # [kg], Panda's rated payload (thesis §3.1.1)
REACH = 0.855  # [m], Panda's reach from the shoulder (joint 2 axis)
SHOULDER_HEIGHT = 0.333  # [m], joint-2 axis above the base (Table 3.1, d1)

# Franka's "ready" pose [rad]: a well-conditioned, gripper-down posture
Q_READY = np.array([0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4])

# Thesis Table 3.1 rows for joints 1..7 (modified DH: a_{i-1}, d_i, alpha_{i-1})
DH_A = np.array([0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088])  # [m]
DH_D = np.array([0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0])  # [m]
DH_ALPHA = np.array([0.0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2])
FLANGE_D = 0.107  # [m], Table 3.1 "Flange" row

HAND_YAW = -np.pi / 4  # [rad], hand mounted at -45° about the flange z axis
TCP_OFFSET = 0.1034  # [m], TCP (between the fingertips) past the flange along z
FINGER_MAX = 0.04  # [m], travel of each finger (opening 0..0.08 m)

# [2] sigmoidal joint friction tau_f = phi1 / (1 + exp(-phi2 (dq + phi3))) - const:
# Coulomb-like level phi1 [N·m], steepness phi2 [s/rad], offset phi3 [rad/s]
FRICTION_PHI1 = np.array([0.54615, 0.87224, 0.64068, 1.2794, 0.83904, 0.30301, 0.56489])
FRICTION_PHI2 = np.array([5.1181, 9.0657, 10.136, 5.5903, 8.3469, 17.133, 10.336])
FRICTION_PHI3 = np.array([0.039533, 0.025882, -0.04607, 0.036194, 0.026226, -0.021047, 0.0035526])
