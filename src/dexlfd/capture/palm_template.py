"""The rigid palm of a recording: a template of the palm's metric shape (Procrustes).

The wrist and the four finger MCPs keep their shape when the fingers curl; the
template is the robust median of MediaPipe's world landmarks of those points over a
clip after aligning every frame onto it (generalised Procrustes, rotation only: the
world landmarks are metric). Used by :func:`~dexlfd.capture.recording_pose.estimate_recording_pose`.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.errors import InvalidInput

__all__ = ["PALM", "full_size_palm", "kabsch", "palm_template"]

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


def _finite_palms(world_m: FloatArray, valid: BoolArray | None) -> tuple[FloatArray, BoolArray]:
    """The :data:`PALM` landmarks (n, 5, 3) [m] and the frames (n,) where all are finite.

    Raises
    ------
    InvalidInput
        When no frame (of ``valid``'s, if given) has a finite palm.
    """
    W = np.asarray(world_m, dtype=np.float64)[:, PALM]
    ok = np.asarray(np.isfinite(W).all(axis=(1, 2)), dtype=bool)
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    if not ok.any():
        raise InvalidInput("world_m: no frame with a finite palm (wrist and finger MCPs)")
    return W, ok


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
    W, ok = _finite_palms(world_m, valid)
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


def full_size_palm(
    world_m: FloatArray, valid: BoolArray | None = None, quantile: float = 90.0
) -> FloatArray:
    """The palm's in-plane shape ``(5, 2)`` [m] at its full size over a clip (centred).

    MediaPipe's world landmarks read the palm's extent along the line of sight short
    (their depth axis is compressed): a palm turned away from the camera keeps its
    image-plane extent but loses most of the other, so the clip's median palm
    (:func:`palm_template`) comes out too narrow where the palm is mostly seen
    turned (on seven real recordings its index-to-little-MCP width over its wrist-to-
    middle-MCP length is 0.37-0.73, while the same ratio's 90th percentile over each
    clip is 0.67-0.86). A rigid distance can only be read shorter than it is, never
    longer, so each of the ten distances between the :data:`PALM` points is taken at
    its ``quantile`` over the clip less what the landmarks' frame-to-frame noise adds
    to that percentile (never below the median), and the points are placed by
    classical multidimensional scaling onto the plane that holds most of them.

    Raises
    ------
    InvalidInput
        When no frame has a finite palm.
    """
    W, ok = _finite_palms(world_m, valid)
    P = W[ok]
    dist = np.linalg.norm(P[:, :, None] - P[:, None, :], axis=3)  # (m, 5, 5)
    high = np.percentile(dist, quantile, axis=0)
    if dist.shape[0] >= 3:
        # the landmarks' own frame-to-frame noise raises a high percentile too: take it
        # off (its std from the robust spread of consecutive differences), never below
        # the median
        noise = 1.4826 * np.median(np.abs(np.diff(dist, axis=0)), axis=0) / math.sqrt(2.0)
        z = NormalDist().inv_cdf(min(max(quantile / 100.0, 0.5), 0.999))
        high = np.maximum(high - z * noise, np.median(dist, axis=0))
    D2 = high**2
    k = D2.shape[0]
    J = np.eye(k) - 1.0 / k
    B = -0.5 * J @ D2 @ J
    val, vec = np.linalg.eigh(B)  # ascending
    top = np.argsort(val)[::-1][:2]
    return np.asarray(vec[:, top] * np.sqrt(np.maximum(val[top], 0.0)), dtype=np.float64)
