"""Pose channels: position, unit quaternion (x, y, z, w), gripper opening (thesis §4.4).

What is specific to end-effector poses, around the channel-agnostic pipeline
(:mod:`dexlfd.learn.pipeline`): the 8 channel names and their DTW scale groups,
quaternions made unit and sign-continuous within a demonstration and flipped
into one hemisphere across demonstrations before learning, and the GMR result
renormalised afterwards with Σ(t) mapped through the normalisation's Jacobian.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array
from dexlfd.errors import InvalidDemonstration
from dexlfd.learn.preprocess import warn
from dexlfd.rotations import quat_sign_continuous

__all__ = [
    "POSE_CHANNELS",
    "POSE_GROUPS",
    "QUATERNION",
    "check_pose_series",
    "renormalize_quaternion",
    "same_hemisphere",
]

POSE_CHANNELS = ("x", "y", "z", "qx", "qy", "qz", "qw", "gripper")
POSE_GROUPS = ((0, 1, 2), (3, 4, 5, 6), (7,))  # position [m], quaternion [-], gripper [m]
QUATERNION = slice(3, 7)
_QUAT_NORM_TOL = 1e-3  # larger deviations from unit norm are reported when renormalising
_QUAT_NORM_MIN = 0.5  # below this a "quaternion" is not a rotation that was meant


def _prepare_quaternions(q: FloatArray, name: str, msgs: list[str]) -> FloatArray:
    """Renormalise (with a warning) and make sign-continuous; NaN rows are kept."""
    norms = np.linalg.norm(q, axis=1)
    ok = np.isfinite(norms)
    if (norms[ok] < _QUAT_NORM_MIN).any():
        i = int(np.flatnonzero(ok & (norms < _QUAT_NORM_MIN))[0])
        raise InvalidDemonstration(
            f"{name}: quaternion at sample {i} has norm {norms[i]:.3g}; expected unit "
            "quaternions (x, y, z, w)"
        )
    dev = np.abs(norms[ok] - 1.0)
    if dev.size and dev.max() > _QUAT_NORM_TOL:
        warn(
            msgs, f"{name}: quaternions not unit (norm off by up to {dev.max():.3g}); renormalised"
        )
    return quat_sign_continuous(q / norms[:, None])


def check_pose_series(x: FloatArray, name: str, msgs: list[str]) -> FloatArray:
    """A pose series (n, 8) as a new array with unit, sign-continuous quaternions.

    Raises :class:`~dexlfd.errors.InvalidDemonstration` for a wrong shape, inf
    values or a quaternion far from unit norm; NaN rows (invalid frames) are kept.
    """
    x_arr = as_float_array(x, f"{name}: pose")
    if x_arr.ndim != 2 or x_arr.shape[1] != len(POSE_CHANNELS):
        raise InvalidDemonstration(
            f"{name}: pose must have shape (n, 8) = position, quaternion, gripper; "
            f"got {x_arr.shape}"
        )
    if np.isinf(x_arr).any():
        raise InvalidDemonstration(f"{name}: pose contains inf values")
    x_arr = x_arr.copy()
    x_arr[:, QUATERNION] = _prepare_quaternions(x_arr[:, QUATERNION], name, msgs)
    return x_arr


def same_hemisphere(x: FloatArray, anchor: FloatArray | None) -> FloatArray | None:
    """Flip ``x``'s quaternions (in place) into ``anchor``'s hemisphere; return the anchor.

    The anchor is the first valid quaternion of the first demonstration that has
    one; ``None`` until then (the same rotations, one sign for all demonstrations).
    """
    ok = np.isfinite(x).all(axis=1)
    if not ok.any():
        return anchor
    first_q = x[int(np.argmax(ok)), QUATERNION]
    if anchor is None:
        return first_q
    if float(first_q @ anchor) < 0:
        x[:, QUATERNION] *= -1.0
    return anchor


def renormalize_quaternion(mean: FloatArray, cov: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit quaternion mean and Σ mapped by J = (I - q̂ q̂ᵀ)/|q| on the quaternion block."""
    q = mean[:, QUATERNION]
    nq = np.linalg.norm(q, axis=1)
    qh = q / nq[:, None]
    T = np.broadcast_to(np.eye(mean.shape[1]), cov.shape).copy()
    T[:, QUATERNION, QUATERNION] = (np.eye(4)[None] - qh[:, :, None] * qh[:, None, :]) / nq[
        :, None, None
    ]
    out = mean.copy()
    out[:, QUATERNION] = qh
    cov_out = T @ cov @ np.swapaxes(T, 1, 2)
    return out, 0.5 * (cov_out + np.swapaxes(cov_out, 1, 2))
