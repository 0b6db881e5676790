"""Simple point-to-point moves as :class:`~dexlfd.io.Plan`: an approach and a lift.

Both run on one minimum-jerk phase (:func:`dexlfd.trajectory.minimum_jerk`) with
analytic velocity and acceleration. :func:`approach_plan` brings the TCP from
one pose to another (a straight line and a slerp), e.g. to a plan's start before
a real arm tracks it; :func:`lift_plan` is the control studies' stand-in for a
DMP plan: a lift over an obstacle, the shape of the thesis's §5.3.3 (Fig. 5.9).
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io import Plan
from dexlfd.rotations import quat_sign_continuous
from dexlfd.trajectory import MIN_JERK_PEAK_SPEED, minimum_jerk

__all__ = ["GRIPPER_DOWN_XYZW", "approach_plan", "lift_plan"]

GRIPPER_DOWN_XYZW = (1.0, 0.0, 0.0, 0.0)  # TCP z axis pointing down, x forward


def approach_plan(
    p_from: FloatArray,
    R_from: FloatArray,
    p_to: FloatArray,
    R_to: FloatArray,
    *,
    gripper: float = 0.0,
    max_speed: float = 0.1,
    max_angular_speed: float = 0.5,
    min_duration: float = 1.0,
    dt: float = 0.01,
) -> Plan:
    """A minimum-jerk straight line (and slerp) from one TCP pose to another.

    The duration makes the peak speed (``MIN_JERK_PEAK_SPEED`` = 1.875 × the
    mean for minimum jerk) at most ``max_speed`` [m/s] and ``max_angular_speed``
    [rad/s], and at least ``min_duration`` [s]. Rotation:
    ``R(s) = exp(s θ k̂) R_from`` with ``θ k̂ = log(R_to R_fromᵀ)`` in the base
    frame, so ``ω = θ k̂ ṡ``.
    """
    from scipy.spatial.transform import Rotation

    rotvec = Rotation.from_matrix(R_to @ R_from.T).as_rotvec()
    dist = float(np.linalg.norm(p_to - p_from))
    angle = float(np.linalg.norm(rotvec))
    T = max(
        min_duration,
        MIN_JERK_PEAK_SPEED * dist / max_speed,
        MIN_JERK_PEAK_SPEED * angle / max_angular_speed,
    )
    n = int(np.ceil(T / dt)) + 1
    t = np.linspace(0.0, T, n)
    s, ds, dds = minimum_jerk(t / T)
    sd, sdd = ds / T, dds / T**2
    d = p_to - p_from
    R = Rotation.from_rotvec(s[:, None] * rotvec) * Rotation.from_matrix(R_from)
    return Plan(
        t=t,
        position=p_from + s[:, None] * d,
        velocity=sd[:, None] * d,
        acceleration=sdd[:, None] * d,
        quaternion=quat_sign_continuous(R.as_quat()),
        angular_velocity=sd[:, None] * rotvec,
        gripper=np.full(n, gripper),
        meta={"source": "dexlfd.plan.moves.approach_plan", "duration_s": T},
    )


def lift_plan(
    duration: float = 6.0,
    *,
    x: float = 0.45,
    y_start: float = -0.25,
    y_end: float = 0.25,
    z_low: float = 0.25,
    z_high: float = 0.55,
    gripper: float = 0.05,
    dt: float = 0.01,
) -> Plan:
    """Lift plan: y from ``y_start`` to ``y_end`` [m], z ``z_low`` → ``z_high`` → ``z_low``.

    The TCP moves along y at constant ``x`` [m] while z rises and falls (a sin²
    bump), both driven by one minimum-jerk phase, gripper pointing down.

    Parameters
    ----------
    duration : float
        Movement time [s].
    gripper : float
        Gripper opening [m] held throughout (closed on the object from t = 0).
    dt : float
        Sample spacing [s] of the plan.
    """
    if not (np.isfinite(duration) and duration > 0 and np.isfinite(dt) and 0 < dt < duration):
        raise InvalidInput(f"need 0 < dt < duration, got dt={dt!r}, duration={duration!r}")
    n = int(round(duration / dt)) + 1
    t = np.linspace(0.0, duration, n)
    s, ds, dds = minimum_jerk(t / duration)
    sd, sdd = ds / duration, dds / duration**2
    h, dy = z_high - z_low, y_end - y_start
    sin2, cos2 = np.sin(2 * np.pi * s), np.cos(2 * np.pi * s)
    pos = np.stack([np.full(n, x), y_start + dy * s, z_low + h * np.sin(np.pi * s) ** 2], 1)
    # d/dt sin²(πs) = π sin(2πs) ṡ
    vel = np.stack([np.zeros(n), dy * sd, h * np.pi * sin2 * sd], 1)
    acc = np.stack([np.zeros(n), dy * sdd, h * np.pi * (2 * np.pi * cos2 * sd**2 + sin2 * sdd)], 1)
    return Plan(
        t=t,
        position=pos,
        velocity=vel,
        acceleration=acc,
        quaternion=np.tile(GRIPPER_DOWN_XYZW, (n, 1)),
        angular_velocity=np.zeros((n, 3)),
        gripper=np.full(n, gripper),
        grasp=np.ones(n, bool),
        meta={"source": "dexlfd.plan.moves.lift_plan", "duration_s": duration},
    )
