"""Unit-quaternion helpers shared by every stage.

Quaternions are unit and scalar-last ``(x, y, z, w)``, as in SciPy and ROS
messages. All functions broadcast over leading axes and never mutate inputs.
MuJoCo is scalar-first: convert only at that boundary with
:func:`wxyz_from_xyzw` / :func:`xyzw_from_wxyz`.
"""

from __future__ import annotations

import math

import numpy as np

from dexlfd._types import FloatArray

__all__ = [
    "quat_conjugate",
    "quat_exp",
    "quat_from_matrix",
    "quat_log",
    "quat_multiply",
    "quat_normalize",
    "quat_sign_continuous",
    "matrix_from_quat",
    "quat_angle",
    "rotation_angle",
    "wxyz_from_xyzw",
    "xyzw_from_wxyz",
]

_EPS = 1e-12


def quat_normalize(q: FloatArray) -> FloatArray:
    """Scale quaternions ``(..., 4)`` to unit norm (rows of zero norm become NaN)."""
    q = np.asarray(q, dtype=np.float64)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > _EPS, q / np.where(n > _EPS, n, 1.0), np.nan)


def quat_sign_continuous(q: FloatArray) -> FloatArray:
    """Flip signs along axis -2 so consecutive quaternions have a positive dot product.

    q and -q are the same rotation; averaging, filtering, regression and
    differentiation need one consistent hemisphere. NaN rows (unseen frames) are
    kept and skipped: the next valid row is compared with the last valid one.

    Parameters
    ----------
    q : ndarray, shape (..., n, 4)
        Quaternions, scalar-last.

    Returns
    -------
    ndarray, shape (..., n, 4)
        The same rotations, sign-continuous along the time axis.
    """
    q = np.array(q, dtype=np.float64, copy=True)
    flat = q.reshape(-1, q.shape[-2], 4)
    for series in flat:
        valid = np.flatnonzero(np.isfinite(series).all(axis=1))
        if valid.size < 2:
            continue
        v = series[valid]
        dots = np.einsum("ij,ij->i", v[1:], v[:-1])
        # cumulative parity of flips: a row flips when an odd number of sign changes precede it
        flips = np.concatenate([[False], np.logical_xor.accumulate(dots < 0)])
        v[flips] *= -1.0
        series[valid] = v
    return flat.reshape(q.shape)


def quat_multiply(p: FloatArray, q: FloatArray) -> FloatArray:
    """Hamilton product ``p ⊗ q`` of scalar-last quaternions, broadcasting."""
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    px, py, pz, pw = np.moveaxis(p, -1, 0)
    qx, qy, qz, qw = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
            pw * qw - px * qx - py * qy - pz * qz,
        ],
        axis=-1,
    )


def quat_conjugate(q: FloatArray) -> FloatArray:
    """Conjugate (inverse for unit quaternions)."""
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate([-q[..., :3], q[..., 3:]], axis=-1)


def quat_log(q: FloatArray) -> FloatArray:
    """Logarithm map of unit quaternions to rotation-vector halves ``(..., 3)``.

    Returns ``u * theta / 2`` for ``q = (u sin(theta/2), cos(theta/2))``, the
    convention of Ude et al. (2014); twice this is the rotation vector [rad].
    """
    q = np.asarray(q, dtype=np.float64)
    v = q[..., :3]
    w = np.clip(q[..., 3], -1.0, 1.0)
    nv = np.linalg.norm(v, axis=-1)
    angle = np.arctan2(nv, w)
    scale = np.where(nv > _EPS, angle / np.where(nv > _EPS, nv, 1.0), 1.0)
    return v * scale[..., None]


def quat_exp(r: FloatArray) -> FloatArray:
    """Exponential map, inverse of :func:`quat_log`: ``(..., 3) -> (..., 4)``."""
    r = np.asarray(r, dtype=np.float64)
    n = np.linalg.norm(r, axis=-1)
    sinc = np.where(n > _EPS, np.sin(n) / np.where(n > _EPS, n, 1.0), 1.0)
    return np.concatenate([r * sinc[..., None], np.cos(n)[..., None]], axis=-1)


def matrix_from_quat(q: FloatArray) -> FloatArray:
    """Rotation matrices ``(..., 3, 3)`` from unit quaternions ``(..., 4)``."""
    x, y, z, w = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def quat_from_matrix(R: FloatArray) -> FloatArray:
    """Unit quaternions ``(..., 4)`` with ``w >= 0`` from rotation matrices ``(..., 3, 3)``.

    Uses the numerically stable branch selection of Shepperd (1978).
    """
    R = np.asarray(R, dtype=np.float64)
    shape = R.shape[:-2]
    m = R.reshape(-1, 3, 3)
    tr = np.trace(m, axis1=1, axis2=2)
    d = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2], tr], axis=1)
    k = np.argmax(d, axis=1)
    q = np.empty((m.shape[0], 4))
    for branch in range(4):
        sel = k == branch
        if not sel.any():
            continue
        s = m[sel]
        if branch == 3:
            r = np.sqrt(1.0 + tr[sel]) * 2.0
            q[sel] = np.stack(
                [
                    (s[:, 2, 1] - s[:, 1, 2]) / r,
                    (s[:, 0, 2] - s[:, 2, 0]) / r,
                    (s[:, 1, 0] - s[:, 0, 1]) / r,
                    0.25 * r,
                ],
                axis=1,
            )
        else:
            i, j, kk = branch, (branch + 1) % 3, (branch + 2) % 3
            r = np.sqrt(1.0 + s[:, i, i] - s[:, j, j] - s[:, kk, kk]) * 2.0
            out = np.empty((s.shape[0], 4))
            out[:, i] = 0.25 * r
            out[:, j] = (s[:, j, i] + s[:, i, j]) / r
            out[:, kk] = (s[:, kk, i] + s[:, i, kk]) / r
            out[:, 3] = (s[:, kk, j] - s[:, j, kk]) / r
            q[sel] = out
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(q[:, 3:] < 0, -q, q)
    return q.reshape(*shape, 4)


def rotation_angle(R_a: FloatArray, R_b: FloatArray) -> FloatArray:
    """Angle [rad] of the rotation between ``R_a`` and ``R_b`` (``(..., 3, 3)`` each).

    ``arccos((trace(R_a R_bᵀ) - 1) / 2)``, in [0, pi]; the argument is clipped so
    round-off never gives NaN. One pair of (3, 3) matrices (the 1 kHz loop's safety
    check, every tick) is done in scalar arithmetic, at a fraction of the array path's cost.
    """
    if np.ndim(R_a) == 2 and np.ndim(R_b) == 2:
        c = 0.5 * (float(np.vdot(R_a, R_b)) - 1.0)  # trace(R_a R_bᵀ) = sum of R_a * R_b
        return np.asarray(math.acos(min(max(c, -1.0), 1.0)))
    tr = np.einsum("...ij,...ij->...", np.asarray(R_a, float), np.asarray(R_b, float))
    return np.arccos(np.clip(0.5 * (tr - 1.0), -1.0, 1.0))


def quat_angle(q_a: FloatArray, q_b: FloatArray) -> FloatArray:
    """Angle [rad] of the rotation between unit quaternions ``q_a`` and ``q_b`` (``(..., 4)``).

    ``2 arccos(|q_a · q_b|)``, in [0, pi]: q and -q give the same angle.
    """
    dots = np.abs(np.sum(np.asarray(q_a, float) * np.asarray(q_b, float), axis=-1))
    return 2.0 * np.arccos(np.clip(dots, 0.0, 1.0))


def wxyz_from_xyzw(q: FloatArray) -> FloatArray:
    """Scalar-last to scalar-first (MuJoCo)."""
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def xyzw_from_wxyz(q: FloatArray) -> FloatArray:
    """Scalar-first (MuJoCo) to scalar-last."""
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)
