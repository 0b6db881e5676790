"""How far the object slid in the hand while it was carried: :func:`carry_slip`.

A grasp that holds keeps the object where it closed on it, relative to the hand;
one that is too weak lets it slide (down, under its weight and the carry's
accelerations) or drop. The slip is read from a simulated rollout: the object's
centre in the TCP frame while it is carried: held, and at least :data:`LIFT_OFF`
above both where it stood and where it ends (setting it down on a support pushes it
in the hand; that is not slip).
"""

from __future__ import annotations

import numpy as np

from dexlfd.io import Rollout
from dexlfd.rotations import matrix_from_quat

__all__ = ["LIFT_OFF", "carry_slip"]

LIFT_OFF = 0.01  # [m] the object is off its support (carried) once this far above its start


def carry_slip(rollout: Rollout) -> float | None:
    """Largest displacement [m] of the object in the TCP frame during the carry.

    From the first tick the hand holds it (``extras["attached"]``) :data:`LIFT_OFF`
    above its starting and its final height (its pose in the hand then is the
    reference) to the last such tick. None when the rollout has no object or the
    object was never lifted.
    """
    p = rollout.extras.get("payload_position")
    attached = rollout.extras.get("attached")
    if p is None or attached is None:
        return None
    p, attached = np.asarray(p), np.asarray(attached, dtype=bool)
    z = p[:, 2]
    lifted = np.flatnonzero(attached & (z >= max(z[0], z[-1]) + LIFT_OFF))
    if lifted.size == 0:
        return None
    k0, k1 = int(lifted[0]), int(lifted[-1]) + 1
    R = matrix_from_quat(rollout.ee_quaternion[k0:k1])  # (m, 3, 3), TCP axes in the base
    d = p[k0:k1] - rollout.ee_position[k0:k1]
    rel = np.einsum("kji,kj->ki", R, d)  # the object's centre in the TCP frame
    return float(np.linalg.norm(rel - rel[0], axis=1).max())
