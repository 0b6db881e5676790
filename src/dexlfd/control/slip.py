"""How far the object slid in the hand while it was carried: :func:`carry_slip`.

A grasp that holds keeps the object where it closed on it, relative to the hand;
one that is too weak lets it slide (down, under its weight and the carry's
accelerations) or drop. The slip is read from a simulated rollout: the object's
centre in the TCP frame, from the moment it leaves its support (lifted
:data:`LIFT_OFF` above where it stood) until the hand lets it go.
"""

from __future__ import annotations

import numpy as np

from dexlfd.io import Rollout
from dexlfd.rotations import matrix_from_quat

__all__ = ["LIFT_OFF", "carry_slip"]

LIFT_OFF = 0.01  # [m] the object is off its support (carried) once this far above its start


def carry_slip(rollout: Rollout) -> float | None:
    """Largest displacement [m] of the object in the TCP frame during the carry.

    From the first tick the object is :data:`LIFT_OFF` above its starting height
    (its pose in the hand then is the reference) to the last tick the hand holds it
    (``extras["attached"]``). None when the rollout has no object or the object was
    never lifted.
    """
    p = rollout.extras.get("payload_position")
    attached = rollout.extras.get("attached")
    if p is None or attached is None:
        return None
    p, attached = np.asarray(p), np.asarray(attached, dtype=bool)
    lifted = np.flatnonzero(attached & (p[:, 2] >= p[0, 2] + LIFT_OFF))
    if lifted.size == 0:
        return None
    k0 = int(lifted[0])
    open_after = np.flatnonzero(~attached[k0:])
    k1 = k0 + (int(open_after[0]) if open_after.size else attached.size - k0)
    R = matrix_from_quat(rollout.ee_quaternion[k0:k1])  # (m, 3, 3), TCP axes in the base
    d = p[k0:k1] - rollout.ee_position[k0:k1]
    rel = np.einsum("kji,kj->ki", R, d)  # the object's centre in the TCP frame
    return float(np.linalg.norm(rel - rel[0], axis=1).max())
