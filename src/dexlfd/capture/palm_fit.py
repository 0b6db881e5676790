"""Each frame's own palm fit, and how far the frame may be trusted.

Per valid frame: the palm template's orientation in MediaPipe's world frame
(Kabsch), the viewing ray through the palm's pixel centre, the palm in camera axes,
and the depth read from the image (the template's in-plane shape fitted to the
palm's bearings, :func:`~dexlfd.capture.palm_depth.affine_scale`); then the flags
that lower a frame's weight or keep it from setting the orientation: a palm cut by
(or near) the image border, seen edge-on, inconsistent with the template or the
image's tilt, or of low tracker confidence. Step 2 of
:func:`~dexlfd.capture.recording_pose.estimate_recording_pose`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dexlfd._types import BoolArray, FloatArray, IntArray
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.palm_depth import affine_scale
from dexlfd.capture.palm_orientation import rotation_to
from dexlfd.capture.palm_template import PALM, full_size_palm, kabsch, palm_template
from dexlfd.capture.recording_pose_config import RecordingPoseConfig
from dexlfd.capture.tracking import FINGER_CHAINS, WRIST

__all__ = [
    "FrameTrust",
    "PalmFit",
    "combined_depth",
    "fit_palm",
    "frame_trust",
    "full_size_scale",
    "hand_scale",
    "near_border",
    "rigid_fingers",
]


@dataclass(frozen=True, slots=True)
class PalmFit:
    """Each valid frame's own palm fit (arrays over the valid frames ``idx``)."""

    idx: IntArray
    T: FloatArray  # the palm template (5, 3) [m]
    template_radius: float  # its RMS radius [m]
    R_i: FloatArray  # template -> MediaPipe world frame
    R_cam: FloatArray  # template -> camera
    ray: FloatArray  # unit viewing ray through the palm's pixel centre
    m_world: FloatArray  # centre of the world palm points [m]
    up: FloatArray  # the palm's image landmarks [px]
    z: FloatArray  # depth read from the image [m]
    fit_rel: FloatArray  # affine fit's residual over the palm's radius [-]
    r_px: FloatArray  # the palm's pixel radius [px]
    shape_rel: FloatArray  # world palm's residual against the template, relative [-]
    cos_world: FloatArray  # |cos| of the world palm normal's angle to the ray
    cos_image: FloatArray  # the image's |cos tilt| (affine singular value ratio)
    depth_scale: float = 1.0  # the clip's factor on the depth, the palm at full size [-]
    depth_scale_sd: float = 0.0  # its relative uncertainty [-]


def fit_palm(
    uv: FloatArray, W: FloatArray, ok: BoolArray, K: Intrinsics, cfg: RecordingPoseConfig
) -> PalmFit:
    """The template, and per valid frame its orientation, viewing ray and image depth."""
    T, shape_res = palm_template(W, ok, cfg.template_iterations)
    template_radius = float(np.sqrt(np.mean(np.sum(T**2, axis=1))))
    idx = np.flatnonzero(ok)
    Wp = W[idx][:, PALM]
    m_world = Wp.mean(axis=1)
    R_i = kabsch(np.broadcast_to(T, Wp.shape), Wp - m_world[:, None])  # template -> world
    # the viewing ray through the palm's pixel centre, and the palm in camera axes
    up = uv[idx][:, PALM]
    c_px = up.mean(axis=1)
    ray = np.stack(
        [(c_px[:, 0] - 0.5 - K.cx) / K.fx, (c_px[:, 1] - 0.5 - K.cy) / K.fy, np.ones(len(idx))],
        axis=1,
    )
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    R_ray = rotation_to(ray)
    R_cam = R_ray @ R_i  # template -> camera
    # depth: the template's in-plane shape fitted to the palm's bearings (weak perspective
    # about the palm's own ray), distance = 1 / the affine map's larger singular value
    _, _, Vt = np.linalg.svd(T)
    Q = T @ Vt[:2].T
    bear = np.stack(
        [(up[..., 0] - 0.5 - K.cx) / K.fx, (up[..., 1] - 0.5 - K.cy) / K.fy, np.ones(up.shape[:2])],
        axis=-1,
    )
    turned = np.einsum("nji,nkj->nki", R_ray, bear)
    s1, s2, fit_rel = affine_scale(Q, turned[..., :2] / turned[..., 2:3])
    with np.errstate(divide="ignore", invalid="ignore"):
        z = ray[:, 2] / s1
        cos_image = s2 / s1
    depth_scale, scale_sd = 1.0, 0.0
    if cfg.depth_template_quantile > 0:
        q = cfg.depth_template_quantile
        k = [
            full_size_scale(turned, ray, z, full_size_palm(W, ok, p))
            for p in (q, max(2.0 * q - 100.0, 0.0), (q + 100.0) / 2.0)
        ]
        # how much the factor depends on which frames count as full size: half its
        # relative spread from (2 q - 100) to (q + 100) / 2 (80 to 95 about 90) [-]
        depth_scale, scale_sd = k[0], abs(math.log(k[2] / k[1])) / 2.0
    r_px = np.sqrt(np.mean(np.sum((up - c_px[:, None]) ** 2, axis=2), axis=1))
    normal = np.einsum("nij,j->ni", R_cam, Vt[2])
    cos_world = np.abs(np.sum(normal * ray, axis=1))
    if cfg.depth_hand_weight > 0:
        # the more the palm is foreshortened (its normal away from the ray), the more the
        # whole hand's reading counts
        # the hand at its size over the clip: the palm template (turned as fitted) with
        # the fingers hung from it at their straight lengths
        Wr = W[idx].copy()
        Wr[:, PALM] = np.einsum("nij,kj->nki", R_i, T) + m_world[:, None]
        z_hand = ray[:, 2] / hand_scale(uv[idx], rigid_fingers(Wr), R_ray, K)
        z = combined_depth(z, z_hand, cfg.depth_hand_weight * (1.0 - cos_world))
    return PalmFit(
        idx,
        T,
        template_radius,
        R_i,
        R_cam,
        ray,
        m_world,
        up,
        z,
        fit_rel,
        r_px,
        shape_res[idx] / template_radius,
        cos_world,
        cos_image,
        depth_scale,
        scale_sd,
    )


def full_size_scale(
    turned: FloatArray, ray: FloatArray, z: FloatArray, Q_full: FloatArray
) -> float:
    """The clip's one depth factor [-]: the palm's depth read against its full size.

    ``Q_full`` (:func:`~dexlfd.capture.palm_template.full_size_palm`) is the palm at
    its full size; ``z`` [m] the frames' depths read against the clip's median palm
    (from the bearings ``turned`` about each ``ray``). The factor is the median over
    the frames of the two readings' ratio: one number for the clip, applied to the
    smoothed depth (:func:`~dexlfd.capture.recording_pose.estimate_recording_pose`),
    so the depth's motion, every direction the recording's positions take and the
    palm's orientation stay as they were and only the scale moves. 1.0 when no frame
    has both readings.
    """
    s1, _, _ = affine_scale(Q_full, turned[..., :2] / turned[..., 2:3])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = (ray[:, 2] / s1) / z
    ratio = ratio[np.isfinite(ratio) & (ratio > 0)]
    return float(np.median(ratio)) if ratio.size else 1.0


def hand_scale(uv: FloatArray, W: FloatArray, R_ray: FloatArray, K: Intrinsics) -> FloatArray:
    """Per frame, ``1/d``: the whole hand's image size over its metric size.

    All 21 landmarks, the fingers' bones as well as the palm: their bearings turned
    to look along the palm's ray (``R_ray`` per frame), against MediaPipe's world
    landmarks, which are expressed in that ray-aligned frame, so the fingers'
    foreshortening is the same in both and a palm seen edge-on still has the
    fingers' full extent to read the scale from. Weak perspective about the ray:
    ``q_k - q_mean = (1/d) (W_k - W_mean)_xy``, fitted by least squares over the
    landmarks (``(m,)``, NaN where it cannot be read).
    """
    bear = np.stack(
        [(uv[..., 0] - 0.5 - K.cx) / K.fx, (uv[..., 1] - 0.5 - K.cy) / K.fy, np.ones(uv.shape[:2])],
        axis=-1,
    )
    turned = np.einsum("nji,nkj->nki", R_ray, bear)
    q = turned[..., :2] / turned[..., 2:3]
    q = q - q.mean(axis=1, keepdims=True)
    w = W[..., :2] - W[..., :2].mean(axis=1, keepdims=True)
    den = np.sum(w * w, axis=(1, 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.sum(q * w, axis=(1, 2)) / den
    return np.asarray(np.where((den > 0) & (s > 0), s, np.nan), dtype=np.float64)


def rigid_fingers(W: FloatArray) -> FloatArray:
    """World landmarks ``(m, 21, 3)`` with each finger bone at its straight-finger length.

    MediaPipe's world landmarks shorten a finger's bones against the palm as it curls
    (on five real recordings the fingers' length over the palm's drops from ~0.85-1.1
    open to ~0.6-0.9 curled), while the image shows the real, rigid bones foreshortened
    by their turn only, and a hand's size is the same all through a clip. Each bone
    keeps the frame's own direction (the joint angles) and takes the clip's length of
    that bone at zero bend [m]: the intercept of the bone's length against its finger's
    bend (sum of its joint angles) over the clip, by least squares, clipped to the
    lengths seen. With fewer than 5 frames or no spread of bend the median is used. The
    palm is left as it is (:func:`fit_palm` puts the clip's palm template there), and
    the landmarks' centroid is kept.
    """
    W = np.asarray(W, dtype=np.float64)
    out = W.copy()
    if W.shape[0] == 0:
        return out
    for chain in FINGER_CHAINS:
        pts = W[:, (WRIST, *chain)]  # (m, 5, 3): from the wrist to the fingertip
        bones = np.diff(pts, axis=1)  # (m, 4, 3)
        length = np.linalg.norm(bones, axis=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            unit = bones / length[..., None]
            cos = np.clip(np.sum(unit[:, 1:] * unit[:, :-1], axis=2), -1.0, 1.0)
        bend = np.sum(np.arccos(cos), axis=1)  # the finger's three joints
        ok = np.isfinite(bend) & np.isfinite(length).all(axis=1)
        for j in range(1, 4):
            ref = _straight_length(bend[ok], length[ok, j])
            prev = out[:, chain[j - 1]]
            out[:, chain[j]] = prev + ref * unit[:, j]
    return out - out.mean(axis=1, keepdims=True) + W.mean(axis=1, keepdims=True)


def _straight_length(bend: FloatArray, length: FloatArray) -> float:
    """A bone's length at zero bend from its lengths against its finger's bend."""
    if length.size == 0:
        return float("nan")
    med = float(np.median(length))
    if length.size < 5 or np.std(bend) < 1e-3:
        return med
    _, intercept = np.polyfit(bend, length, 1)
    return float(np.clip(intercept, np.percentile(length, 5), np.percentile(length, 99)))


def combined_depth(
    z_palm: FloatArray, z_hand: FloatArray, hand_weight: float | FloatArray
) -> FloatArray:
    """Each frame's two depth readings combined in log-depth: ``hand_weight`` on the hand's.

    The palm's reading (its template's affine fit) reads the hand too far when the palm
    turns edge-on or the fingers curl over it; the whole hand's (:func:`hand_scale`)
    keeps the fingers' extent but follows their landmarks' noise. A frame with one
    reading keeps it.
    """
    lp, lh = np.log(z_palm), np.log(z_hand)
    w = np.asarray(hand_weight, dtype=np.float64)
    both = np.exp(w * lh + (1.0 - w) * lp)
    return np.asarray(
        np.where(
            np.isfinite(lp) & np.isfinite(lh), both, np.where(np.isfinite(lh), z_hand, z_palm)
        ),
        dtype=np.float64,
    )


@dataclass(frozen=True, slots=True)
class FrameTrust:
    """How far each valid frame may be trusted (arrays over the valid frames)."""

    cut_palm: BoolArray  # a palm point near the image border
    cut_hand: BoolArray  # a landmark outside the image
    edge_on: BoolArray  # palm normal far from the viewing ray
    inconsistent: BoolArray  # palm shape or tilt disagrees
    low: BoolArray  # low tracker confidence
    factor: FloatArray  # std multiplier of the frame's measurements [-]


def frame_trust(
    fit: PalmFit,
    uv: FloatArray,
    K: Intrinsics,
    score: FloatArray | None,
    cfg: RecordingPoseConfig,
) -> FrameTrust:
    """Border cuts, edge-on and inconsistent palms, low confidence, and the std factor."""
    cut_palm = near_border(fit.up, K, cfg.border_margin_px)
    cut_hand = near_border(uv[fit.idx], K, 0.0)  # a landmark outside the image
    # seen edge-on: the world landmarks' palm normal far from the ray; inconsistent: also
    # where that tilt disagrees with the image's (the affine map's singular value ratio
    # is the cosine of the palm's tilt from the ray)
    cos_edge = math.cos(math.radians(cfg.edge_on_deg))
    edge_on = fit.cos_world < cos_edge
    inconsistent = (
        (fit.shape_rel > cfg.max_shape_rel)
        | (fit.fit_rel > cfg.max_shape_rel)
        | ~(np.abs(fit.cos_world - fit.cos_image) <= cfg.max_tilt_disagreement)
    )
    n_ok = len(fit.idx)
    sc = np.ones(n_ok) if score is None else np.asarray(score, dtype=np.float64)[fit.idx]
    low = sc < cfg.min_score  # an unknown (NaN) confidence is not held against a frame
    factor = np.where(cut_palm, cfg.border_factor, np.where(cut_hand, cfg.hand_cut_factor, 1.0))
    factor *= np.where(low, cfg.low_score_factor, 1.0)
    return FrameTrust(cut_palm, cut_hand, edge_on, inconsistent, low, factor)


def near_border(uv: FloatArray, K: Intrinsics, margin: float) -> BoolArray:
    """Frames ``(m,)`` with a point of ``uv (m, k, 2)`` within ``margin`` px of the border."""
    u, v = uv[..., 0], uv[..., 1]
    near = (u < margin) | (u > K.width - margin) | (v < margin) | (v > K.height - margin)
    return np.asarray(near.any(axis=1))
