"""A smooth lift over an obstacle as a :class:`~dexlfd.io.Plan` (stand-in for a DMP plan).

The TCP moves along y at constant x while z rises and falls (a sin² bump), both
driven by one minimum-jerk phase, gripper pointing down; analytic velocity and
acceleration. It mirrors the shape of the thesis's lift over an obstacle
(§5.3.3, Fig. 5.9) until a planned variance-avoidance DMP path is used.
"""

from __future__ import annotations

import numpy as np

from dexlfd.errors import InvalidInput
from dexlfd.io import Plan

__all__ = ["lift_plan"]

GRIPPER_DOWN_XYZW = (1.0, 0.0, 0.0, 0.0)  # TCP z axis pointing down, x forward


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
    u = t / duration
    s = 10 * u**3 - 15 * u**4 + 6 * u**5  # minimum-jerk phase
    sd = (30 * u**2 - 60 * u**3 + 30 * u**4) / duration
    sdd = (60 * u - 180 * u**2 + 120 * u**3) / duration**2
    h = z_high - z_low
    pos = np.stack(
        [np.full(n, x), y_start + (y_end - y_start) * s, z_low + h * np.sin(np.pi * s) ** 2], 1
    )
    # d/dt sin²(πs) = π sin(2πs) ṡ
    vel = np.stack([np.zeros(n), (y_end - y_start) * sd, h * np.pi * np.sin(2 * np.pi * s) * sd], 1)
    acc = np.stack(
        [
            np.zeros(n),
            (y_end - y_start) * sdd,
            h * np.pi * (2 * np.pi * np.cos(2 * np.pi * s) * sd**2 + np.sin(2 * np.pi * s) * sdd),
        ],
        1,
    )
    return Plan(
        t=t,
        position=pos,
        velocity=vel,
        acceleration=acc,
        quaternion=np.tile(GRIPPER_DOWN_XYZW, (n, 1)),
        angular_velocity=np.zeros((n, 3)),
        gripper=np.full(n, gripper),
        meta={"source": "dexlfd.experiments.lift.lift_plan", "duration_s": duration},
    )
