"""What a rollout achieved: the TCP tracking error and where the object ended.

:func:`tracking_summary` condenses the TCP error of any rollout (simulated or
real); :func:`object_report` reads the simulated object's path (release,
impact, tilt). The simulated loop stores the latter as the rollout's ``object_report``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io import Rollout
from dexlfd.rotations import matrix_from_quat

__all__ = ["object_report", "tracking_summary"]


def object_report(
    t: FloatArray, p: FloatArray, quat: FloatArray, attached: FloatArray
) -> dict[str, Any]:
    """Where the object ended and how hard it met the surface.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Tick times [s].
    p, quat : ndarray, shape (n, 3), (n, 4)
        Object centre [m] and orientation (x, y, z, w) per tick.
    attached : ndarray, shape (n,)
        True while the object was really in the hand.

    Returns
    -------
    dict
        ``final_position`` [m], ``final_quaternion``, ``tilt_deg`` (angle between
        its z axis now and at the start, when it stood on its support [deg]),
        ``released_t`` [s] (when the hand last let go,
        None if it never held it), ``release_speed`` [m/s] (object speed then) and
        ``impact_speed`` [m/s]: the object's downward speed (largest within 10 ms)
        when it first came within 2 mm of its resting height after it was last
        carried 2 cm or more above it: the speed it met the surface with (a dropped
        object hits at sqrt(2 g h), a placed one at the speed it was lowered);
        ``touch_speed`` [m/s] the same for its whole velocity (sliding included).
    """
    n = t.shape[0]
    # tilt from how it stood at the start (on its support, upright)
    R_rel = matrix_from_quat(quat[0]).T @ matrix_from_quat(quat[-1])
    report: dict[str, Any] = {
        "final_position": p[-1].tolist(),
        "final_quaternion": quat[-1].tolist(),
        "tilt_deg": float(np.degrees(np.arccos(np.clip(R_rel[2, 2], -1.0, 1.0)))),
        "released_t": None,
        "release_speed": None,
        "impact_speed": None,
        "touch_speed": None,
    }
    held = np.flatnonzero(attached)
    if held.size == 0 or n < 3:
        return report
    k_rel = int(held[-1]) + 1
    if k_rel >= n:
        return report  # still in the hand at the end
    vel = np.gradient(p, t, axis=0)
    v = np.linalg.norm(vel, axis=1)
    v_down = np.maximum(-vel[:, 2], 0.0)  # speed into a horizontal surface
    z_rest = p[-1, 2]
    # the last time, while held, it was 2 cm or more above where it came to rest
    high = np.flatnonzero(p[held, 2] > z_rest + 0.02)
    k0 = int(held[high[-1]]) if high.size else k_rel
    k0 = min(k0, k_rel)
    touch = np.flatnonzero(p[k0:, 2] <= z_rest + 2e-3)
    k1 = k0 + (int(touch[0]) if touch.size else n - 1 - k0)
    w = max(1, int(round(0.01 / max(float(t[1] - t[0]), 1e-9))))  # +-10 ms
    report.update(
        released_t=float(t[k_rel]),
        release_speed=float(v[k_rel]),
        impact_speed=float(v_down[max(0, k1 - w) : k1 + w + 1].max()),
        touch_speed=float(v[max(0, k1 - w) : k1 + w + 1].max()),
    )
    return report


def tracking_summary(rollout: Rollout) -> dict[str, float]:
    """TCP position error RMS and max [m], orientation error max [rad] of a rollout."""
    err = np.linalg.norm(rollout.ee_position - rollout.ref_position, axis=1)
    rot = rollout.extras.get("orientation_error", np.zeros(1))
    return {
        "position_rms_m": float(np.sqrt(np.mean(err**2))),
        "position_max_m": float(err.max()),
        "orientation_max_rad": float(np.max(rot)),
    }
