"""Facts of the Franka Emika Panda (arm, hand, limits, kinematics, workspace).

A leaf module (NumPy only) that every stage may import: the planner checks a
start against the reach, the controller a reference, the robot its commands, all
with these numbers and with :func:`check_workspace`, the one workspace rule.

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

from dexlfd.errors import InvalidInput

__all__ = [
    "ARM_JOINT_NAMES",
    "BASE_RADIUS",
    "CARTESIAN_LIMITS",
    "DH_A",
    "DH_ALPHA",
    "DH_D",
    "DDQ_MAX",
    "DQ_MAX",
    "DTAU_MAX",
    "FINGER_MAX",
    "GRIPPER_FORCE_MAX",
    "GRIPPER_OPENING_MAX",
    "GRIPPER_SPEED_MAX",
    "FLANGE_D",
    "FRICTION_PHI1",
    "FRICTION_PHI2",
    "FRICTION_PHI3",
    "HAND_ENVELOPE",
    "HAND_YAW",
    "MAX_PAYLOAD",
    "MIN_REACH",
    "N_JOINTS",
    "Q_MAX",
    "Q_MIN",
    "Q_READY",
    "REACH",
    "SHOULDER",
    "SHOULDER_HEIGHT",
    "TABLE_Z",
    "TAU_MAX",
    "TCP_OFFSET",
    "check_workspace",
    "workspace_violation",
]

N_JOINTS = 7
ARM_JOINT_NAMES = tuple(f"panda_joint{i}" for i in range(1, N_JOINTS + 1))

# [1] joint position limits [rad]
Q_MIN = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
Q_MAX = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
# [1] joint velocity limits [rad/s]
DQ_MAX = np.array([2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100])
# [rad/s²], [1] joint acceleration limits
DDQ_MAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
# [1] joint torque limits [N·m]
TAU_MAX = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
DTAU_MAX = 1000.0  # [N·m/s], [1] maximum rate of the commanded torque (all joints)
MAX_PAYLOAD = 3.0  # [kg], Panda's rated payload (thesis §3.1.1)
REACH = 0.855  # [m], Panda's reach from the shoulder (joint 2 axis)
MM_HINT_M = 10.0  # [m] a coordinate this large was surely meant in millimetres
SHOULDER_HEIGHT = 0.333  # [m], joint-2 axis above the base (Table 3.1, d1)
SHOULDER = (0.0, 0.0, SHOULDER_HEIGHT)  # [m], joint-2 axis in the base frame
# Folded fully (joint 4 at its -3.07 rad limit) the wrist stays ~0.1 m from the
# shoulder and the hand adds 0.3 m beyond it: a TCP nearer than this to the shoulder
# would be inside the arm's own links (and a singular, unreachable pose)
MIN_REACH = 0.2  # [m]
TABLE_Z = 0.0  # [m], the base plane the robot stands on (the table)
BASE_RADIUS = 0.15  # [m], links 0/1 envelope around the base axis, below the shoulder

# [1] Cartesian limits, name -> (limit, unit)
CARTESIAN_LIMITS: dict[str, tuple[float, str]] = {
    "translational_velocity": (1.7, "m/s"),
    "translational_acceleration": (13.0, "m/s^2"),
    "rotational_velocity": (2.5, "rad/s"),
    "rotational_acceleration": (25.0, "rad/s^2"),
}

# Franka's "ready" pose [rad]: a well-conditioned, gripper-down posture
Q_READY = np.array([0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4])

# Thesis Table 3.1 rows for joints 1..7 (modified DH: a_{i-1}, d_i, alpha_{i-1})
DH_A = np.array([0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088])  # [m]
DH_D = np.array([0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0])  # [m]
DH_ALPHA = np.array([0.0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2])
FLANGE_D = 0.107  # [m], Table 3.1 "Flange" row

HAND_YAW = -np.pi / 4  # [rad], hand mounted at -45° about the flange z axis
TCP_OFFSET = 0.1034  # [m], TCP (between the fingertips) past the flange along z
# [m] half depth (along the TCP's x), half width (along its y, the fingers' closing
# direction), height above the TCP (up along -z) and reach below it (the fingertip
# pads) of a box around the TCP holding the Franka Hand's body, its open fingers and
# the flange link (link 7): the packaged collision geometry spans x +-0.044,
# y -0.104..0.100, z -0.158..0.0095 in the TCP frame (tests/robot check it), rounded
# up. The wrist and forearm above it are not in it: link 6 and joint 6's housing
# reach 0.138 m from the TCP's axis 0.16-0.29 m above it (a forearm can still rub an
# obstacle's top edge while the hand comes down 2 cm beside it)
HAND_ENVELOPE = (0.045, 0.105, 0.16, 0.01)
FINGER_MAX = 0.04  # [m], travel of each finger (opening 0..0.08 m)
GRIPPER_OPENING_MAX = 2 * FINGER_MAX  # [m], the Franka Hand's full opening
GRIPPER_SPEED_MAX = 0.2  # [m/s], Franka Hand finger speed (libfranka Gripper::move)
GRIPPER_FORCE_MAX = 140.0  # [N], Franka Hand continuous grasp force

# [2] sigmoidal joint friction tau_f = phi1 / (1 + exp(-phi2 (dq + phi3))) - const:
# Coulomb-like level phi1 [N·m], steepness phi2 [s/rad], offset phi3 [rad/s]
FRICTION_PHI1 = np.array([0.54615, 0.87224, 0.64068, 1.2794, 0.83904, 0.30301, 0.56489])
FRICTION_PHI2 = np.array([5.1181, 9.0657, 10.136, 5.5903, 8.3469, 17.133, 10.336])
FRICTION_PHI3 = np.array([0.039533, 0.025882, -0.04607, 0.036194, 0.026226, -0.021047, 0.0035526])


def workspace_violation(points: np.ndarray) -> tuple[int, str] | None:
    """The first TCP position the Panda cannot take, and why; None if all can be taken.

    The one workspace rule of dexlfd, for a start, a goal and every sample of a plan:
    a TCP position [m] in the base frame is taken if it is within :data:`REACH` of the
    shoulder but not nearer than :data:`MIN_REACH` (inside the arm's own links), not
    below the table (z < :data:`TABLE_Z`) and not inside the base (within
    :data:`BASE_RADIUS` of its axis below the shoulder).

    Parameters
    ----------
    points : ndarray, shape (3,) or (n, 3)
        TCP positions [m].

    Returns
    -------
    (index, reason) or None
        ``reason`` is a sentence fragment such as ``"0.912 m from the Panda's shoulder
        [0.0, 0.0, 0.333], beyond its reach of 0.855 m"``.
    """
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    dist = np.linalg.norm(p - np.asarray(SHOULDER), axis=1)
    radial = np.hypot(p[:, 0], p[:, 1])
    for i in range(p.shape[0]):  # first offender; vector tests below keep it cheap
        if (
            MIN_REACH <= dist[i] <= REACH
            and p[i, 2] >= TABLE_Z
            and not (radial[i] < BASE_RADIUS and p[i, 2] < SHOULDER_HEIGHT)
        ):
            continue
        where = f"{dist[i]:.3f} m from the Panda's shoulder {list(SHOULDER)}"
        if not np.isfinite(dist[i]):
            return i, "not a finite position"
        if dist[i] > REACH:
            hint = ""
            if np.abs(p[i]).max() >= MM_HINT_M:  # 500, -200, 120 meant as millimetres
                mm = ",".join(f"{v:g}" for v in p[i] / 1000.0)
                hint = f" (positions are in metres: did you mean {mm}, in millimetres?)"
            return i, f"{where}, beyond its reach of {REACH} m{hint}"
        if dist[i] < MIN_REACH:
            return i, f"{where}, inside the arm itself (at least {MIN_REACH} m)"
        if p[i, 2] < TABLE_Z:
            return i, f"below the base plane (the table): z must be >= {TABLE_Z} m"
        return i, (
            f"inside the robot's base (within {BASE_RADIUS} m of its axis below "
            f"z = {SHOULDER_HEIGHT} m)"
        )
    return None


def check_workspace(
    points: np.ndarray, name: str, t: np.ndarray | None = None, *, param: str | None = None
) -> None:
    """Raise :class:`~dexlfd.errors.InvalidInput` if a TCP position is outside the workspace.

    ``name`` says what the points are ("start", "goal", "plan position"); with ``t``
    [s] the message also names the offending sample's time. The rule is
    :func:`workspace_violation`'s. ``param``: the setting the points come from (the
    error's ``param``, shown by the command line as its flag).
    """
    bad = workspace_violation(points)
    if bad is None:
        return
    i, reason = bad
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    at = "" if p.shape[0] == 1 else f" {i}" + ("" if t is None else f" (t={float(t[i]):.3f} s)")
    raise InvalidInput(
        f"{name}{at} {np.round(p[i], 4).tolist()} m is outside the Panda's workspace: {reason}",
        param=param,
    )
