"""Franka Panda Cartesian limits and workspace used to check a plan.

The ``robot`` stage owns the full robot model; these few constants are repeated here
because ``plan`` comes earlier in the pipeline and must not import a later stage.

References
----------
.. [1] Franka Emika, "Robot and interface specifications: Limits for Panda",
   https://frankaemika.github.io/docs/control_parameters.html#limits-for-panda
   (Cartesian: translation 1.7 m/s, 13 m/s², 6500 m/s³; rotation 2.5 rad/s,
   25 rad/s², 12500 rad/s³).
.. [2] Franka Emika Panda datasheet: maximum reach 855 mm.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput

__all__ = [
    "CARTESIAN_LIMITS",
    "PANDA_REACH",
    "PANDA_SHOULDER",
    "PANDA_MIN_REACH",
    "TABLE_Z",
    "LimitReport",
    "check_cartesian_limits",
    "check_reach",
]

logger = logging.getLogger(__name__)

# name -> (limit, unit) [1]
CARTESIAN_LIMITS: dict[str, tuple[float, str]] = {
    "translational_velocity": (1.7, "m/s"),
    "translational_acceleration": (13.0, "m/s^2"),
    "rotational_velocity": (2.5, "rad/s"),
    "rotational_acceleration": (25.0, "rad/s^2"),
}
PANDA_SHOULDER = (0.0, 0.0, 0.333)  # joint 2 axis in the base frame [m] (DH d1)
PANDA_REACH = 0.855  # [m] from the shoulder [2]
# Folded fully (joint 4 at its -3.07 rad limit) the wrist stays ~0.1 m from the
# shoulder and the hand adds 0.3 m beyond it: a TCP nearer than this to the shoulder
# would be inside the arm's own links (and a singular, unreachable pose)
PANDA_MIN_REACH = 0.2  # [m]
TABLE_Z = 0.0  # [m] the base plane, which the robot stands on (the table)


@dataclass(frozen=True, slots=True)
class LimitReport:
    """Peak values of a plan against the Panda's Cartesian limits.

    ``peaks[name]`` is the plan's maximum norm, ``exceeded`` lists human-readable
    messages (empty if all limits hold).
    """

    peaks: dict[str, float]
    exceeded: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """True if no limit is exceeded."""
        return not self.exceeded


def check_cartesian_limits(
    velocity: FloatArray,
    acceleration: FloatArray,
    angular_velocity: FloatArray,
    angular_acceleration: FloatArray,
) -> LimitReport:
    """Compare peak norms (each input (n, 3), SI units) with :data:`CARTESIAN_LIMITS`."""
    peaks = {
        "translational_velocity": float(np.linalg.norm(velocity, axis=1).max()),
        "translational_acceleration": float(np.linalg.norm(acceleration, axis=1).max()),
        "rotational_velocity": float(np.linalg.norm(angular_velocity, axis=1).max()),
        "rotational_acceleration": float(np.linalg.norm(angular_acceleration, axis=1).max()),
    }
    exceeded = []
    for name, value in peaks.items():
        limit, unit = CARTESIAN_LIMITS[name]
        if value > limit:
            # velocity scales with 1/T, acceleration with 1/T^2
            factor = np.sqrt(value / limit) if "acceleration" in name else value / limit
            exceeded.append(
                f"{name.replace('_', ' ')} {value:.3g} {unit} exceeds the Panda's "
                f"{limit:g} {unit} by {value - limit:.3g} {unit} ({value / limit:.2f}x); "
                f"lengthen the duration by about {factor:.2f}x"
            )
    return LimitReport(peaks=peaks, exceeded=tuple(exceeded))


BASE_RADIUS = 0.15  # [m] link 0/1 envelope around the base axis
BASE_HEIGHT = 0.333  # [m] the shoulder height (Table 3.1, d1)


def check_reach(point: FloatArray, name: str) -> None:
    """Raise :class:`InvalidInput` naming ``name`` if ``point`` [m] is beyond the reach."""
    dist = float(np.linalg.norm(np.asarray(point) - np.asarray(PANDA_SHOULDER)))
    if dist < PANDA_MIN_REACH:
        raise InvalidInput(
            f"{name} {np.round(point, 4).tolist()} is {dist:.3f} m from the Panda's shoulder "
            f"{list(PANDA_SHOULDER)}, inside the arm itself (at least {PANDA_MIN_REACH} m)"
        )
    if dist > PANDA_REACH:
        raise InvalidInput(
            f"{name} {np.round(point, 4).tolist()} is {dist:.3f} m from the Panda's shoulder "
            f"{list(PANDA_SHOULDER)}, beyond its reach of {PANDA_REACH} m"
        )
    p = np.asarray(point, dtype=np.float64)
    if p[2] < TABLE_Z:
        raise InvalidInput(
            f"{name} {np.round(p, 4).tolist()} is below the base plane z = 0 (the table)"
        )
    if float(np.hypot(p[0], p[1])) < BASE_RADIUS and p[2] < BASE_HEIGHT:
        raise InvalidInput(
            f"{name} {np.round(p, 4).tolist()} is inside the robot's base (within "
            f"{BASE_RADIUS} m of its axis below z = {BASE_HEIGHT} m)"
        )
