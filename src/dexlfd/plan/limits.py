"""A plan's peaks against the Panda's Cartesian limits, and its start/goal reach.

The numbers (limits, reach, table) are the Panda's facts in :mod:`dexlfd.panda`.

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
from dexlfd.panda import CARTESIAN_LIMITS

__all__ = [
    "LimitReport",
    "check_cartesian_limits",
]

logger = logging.getLogger(__name__)


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
