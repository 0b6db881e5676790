"""The rigid palm of a recording: a template of the palm's metric shape (Procrustes).

The wrist and the four finger MCPs keep their shape when the fingers curl; the
template is the robust median of MediaPipe's world landmarks of those points over a
clip after aligning every frame onto it (generalised Procrustes, rotation only: the
world landmarks are metric). Used by :func:`~dexlfd.capture.recording_pose.estimate_recording_pose`.
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidInput

__all__ = ["PALM", "kabsch", "palm_template"]

# MediaPipe landmarks on the palm's rigid bones: wrist, index, middle, ring, pinky MCP
PALM = (0, 5, 9, 13, 17)


def kabsch(src: FloatArray, dst: FloatArray, w: FloatArray | None = None) -> FloatArray:
    """Rotations ``(..., 3, 3)`` taking centred ``src (..., k, 3)`` best onto ``dst``."""
    if w is None:
        H = np.einsum("...ki,...kj->...ij", dst, src)
    else:
        H = np.einsum("...k,...ki,...kj->...ij", w, dst, src)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(U @ Vt))
    D = np.zeros(H.shape)
    D[..., 0, 0] = 1.0
    D[..., 1, 1] = 1.0
    D[..., 2, 2] = np.where(d == 0, 1.0, d)
    return np.asarray(U @ D @ Vt)


def palm_template(
    world_m: FloatArray, valid: BoolArray | None = None, iterations: int = 3
) -> tuple[FloatArray, FloatArray]:
    """The rigid palm of a recording: robust median of the world palm points (Procrustes).

    Parameters
    ----------
    world_m : ndarray, shape (n, 21, 3)
        MediaPipe world landmarks per frame [m].
    valid : ndarray of bool, shape (n,), optional
        Frames to use (default: those with finite palm points).
    iterations : int
        Passes of align-then-median.

    Returns
    -------
    (template, residual) : ndarray (5, 3), ndarray (n,)
        The centred template [m] of the :data:`PALM` landmarks, and each frame's RMS
        distance to it after the best rotation [m] (NaN where not used).

    Raises
    ------
    InvalidInput
        When no frame has a finite palm.
    """
    W = np.asarray(world_m, dtype=np.float64)[:, PALM]
    ok = np.isfinite(W).all(axis=(1, 2))
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    if not ok.any():
        raise InvalidInput("world_m: no frame with a finite palm (wrist and finger MCPs)")
    P = W[ok] - W[ok].mean(axis=1, keepdims=True)
    T = np.median(P, axis=0)
    for _ in range(int(iterations)):
        T = T - T.mean(axis=0)
        R = kabsch(np.broadcast_to(T, P.shape), P)  # template -> frame
        aligned = np.einsum("nji,nkj->nki", R, P)  # frames in the template's frame
        T = np.median(aligned, axis=0)
    T = T - T.mean(axis=0)
    R = kabsch(np.broadcast_to(T, P.shape), P)
    res = np.full(W.shape[0], np.nan)
    res[ok] = np.sqrt(np.mean(np.sum((np.einsum("nij,kj->nki", R, T) - P) ** 2, axis=2), axis=1))
    return T, res
