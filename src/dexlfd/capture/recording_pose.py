"""The hand's pose over a whole RGB recording: all frames estimated together (offline).

Frame by frame, an RGB-only lift (:class:`~dexlfd.capture.rgb_lifting.PnPTracker`)
reads the hand's depth from its apparent size in each frame alone; on real
third-person footage that depth jumps by 6-50 cm between frames while the wrist
moves a few pixels, and the palm's orientation flips where the hand is cut by the
image border or seen edge-on. A recording is offline, so :func:`estimate_recording_pose`
uses every frame at once:

1. **Palm template** (:func:`palm_template`): the rigid, metric shape of this
   person's palm (wrist and the four finger MCPs, which keep their shape when the
   fingers curl), the robust median of MediaPipe's world landmarks over the clip after
   aligning every frame onto it (generalised Procrustes, rotation only: the world
   landmarks are metric).
2. **Per-frame measurement.** Depth from the image alone: the palm landmarks'
   bearings are turned so that the palm's viewing ray is the optical axis, and the
   template's in-plane shape is fitted to them by a 2-D affine map (Huber-weighted
   least squares, :func:`_affine_scale`). Under weak perspective the map's larger
   singular value is ``1/d`` (distance along the ray) whatever the palm's
   orientation, so the world landmarks' orientation flips never move the depth. Its
   standard deviation (relative) comes from a base level, the pixel noise over the
   palm's pixel radius and the fit's residual, times factors for a palm cut by or
   near the image border and a low tracker confidence; the level is calibrated on
   the recording (the robust spread of the residuals of a first smoothing pass).
   The palm's orientation ``R_ray R_i`` is MediaPipe's: ``R_i`` takes the
   template onto the frame's world palm points (Kabsch), and ``R_ray`` (the
   smallest rotation taking the optical axis onto the palm's ray) turns MediaPipe's
   ray-aligned world frame into the camera's.
   Curling fingers shrink MediaPipe's palm in the image (a still hand making a fist
   reads deeper): ``log z_read = log z + beta (curl - median curl)`` with a curl
   measure from the world landmarks is fitted jointly with a smooth depth
   (alternating, ridge prior, ``beta <= 0``: a curled hand only ever reads deeper)
   and removed.
3. **Robust smoother** (:func:`robust_smooth`): depth [m] and the palm centre's
   normalised image coordinates ``x/z``, ``y/z`` are each smoothed over the whole
   series by a Rauch-Tung-Striebel smoother with a constant-velocity motion prior
   (white acceleration of spectral density ``q``: the acceleration penalty) and
   iteratively reweighted measurements (Cauchy weights on the residuals over
   their predicted spread), so a frame inconsistent with its neighbours is
   down-weighted, never trusted alone. The posterior standard deviation of the
   depth is the per-frame ``depth_std`` [m]; frames without a
   hand between seen ones get the prior's (larger) spread. An RGB-D source's
   measured palm depth enters the same smoother as a further measurement with its
   own small standard deviation.
4. **Orientation.** Frames whose palm is cut by (or near) the border, seen edge-on
   (by the world landmarks' palm normal), of low confidence, inconsistent (palm
   shape residual against the template, or the world landmarks' tilt against the
   image's), or in a run that turns more than ``max_orientation_step_deg`` away
   from the orientation kept around it (a flip, :func:`_drop_spikes`) do not set
   the orientation: it is interpolated there by slerp between the frames that set
   it (held at the ends) and marked (``orientation_set`` False).

The output keypoints are the template's palm points and the frame's own fingers
(MediaPipe's world landmarks expressed in the palm's frame) placed by the smoothed
position and the (set or interpolated) orientation, so the palm frame that the motion
stage reads (wrist, index and little-finger MCPs) is exactly the estimated one.

Assumptions (an APPROXIMATION, like every RGB-only lift): the metric size is
MediaPipe's hand-size prior (a hand 10 % larger than it reads 10 % nearer); without
intrinsics an ideal camera with ``CaptureConfig.assumed_hfov_deg`` (60 deg) is assumed,
which scales all depths alike (with a wider true field of view the hand is nearer than
it reads); depth motion is recovered up to that common scale, which ``depth_std``
(the frame-to-frame uncertainty) does not include.

The live, causal path stays :class:`~dexlfd.capture.rgb_lifting.PnPTracker`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import check_positive
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.errors import InvalidInput

if TYPE_CHECKING:
    from dexlfd.capture.keypoints import KeypointSeries
    from dexlfd.capture.lifting import LiftConfig

__all__ = [
    "PALM",
    "RecordingPose",
    "RecordingPoseConfig",
    "estimate_recording_pose",
    "palm_template",
    "robust_smooth",
    "series_with_recording_pose",
]

# MediaPipe landmarks on the palm's rigid bones: wrist, index, middle, ring, pinky MCP
PALM = (0, 5, 9, 13, 17)


@dataclass(frozen=True, slots=True)
class RecordingPoseConfig:
    """Settings of :func:`estimate_recording_pose` (defaults tuned on real recordings).

    Depth noise is relative (log-depth) before the per-recording calibration; image noise
    and its prior are in pixels, the depth prior in metres.
    """

    depth_noise: float = 0.06  # base std of a frame's log-depth (MediaPipe scale noise) [-]
    depth_accel: float = 0.25  # motion prior: depth acceleration noise density [m/s^1.5]
    image_noise_px: float = 3.0  # base std of the palm centre's pixel [px]
    image_accel_px: float = 1200.0  # motion prior: pixel acceleration density [px/s^1.5]
    measured_depth_noise: float = 0.01  # relative std of an RGB-D depth reading [-]
    level_window: int = 31  # frames of the running median that makes relative noise metric
    border_margin_px: float = 8.0  # a palm point this close to the border is cut [px]
    border_factor: float = 6.0  # std multiplier of a frame whose palm is cut by the border
    hand_cut_factor: float = 2.0  # std multiplier where only a finger is outside the image
    min_score: float = 0.6  # tracker confidence below which a frame is down-weighted
    low_score_factor: float = 3.0  # std multiplier of a low-confidence frame
    edge_on_deg: float = 72.0  # palm normal this far from the viewing ray: seen edge-on [deg]
    max_shape_rel: float = 0.25  # palm shape residual over template radius: inconsistent [-]
    max_tilt_disagreement: float = 0.35  # |cos tilt| of world landmarks vs image: inconsistent
    max_orientation_step_deg: float = 30.0  # a run turning this far from the kept ones: flip
    cauchy_c: float = 2.5  # Cauchy scale of the reweighting, in residual stds [-]
    min_noise_scale: float = 0.05  # lowest calibration of the depth noise level [-]
    curl_prior: float = 0.3  # prior std of the finger-curl depth bias (log-depth per unit)
    curl_iterations: int = 4  # alternations of curl bias and smooth depth (0: no correction)
    curl_ref_accel: float = 0.06  # depth prior of the reference the curl bias is fit to
    iterations: int = 6  # reweighting passes of the smoother
    template_iterations: int = 3  # Procrustes passes of the palm template

    def __post_init__(self) -> None:
        for name in (
            "depth_noise",
            "depth_accel",
            "image_noise_px",
            "image_accel_px",
            "measured_depth_noise",
            "border_factor",
            "hand_cut_factor",
            "low_score_factor",
            "max_shape_rel",
            "max_tilt_disagreement",
            "max_orientation_step_deg",
            "cauchy_c",
            "min_noise_scale",
            "curl_prior",
            "curl_ref_accel",
        ):
            check_positive(getattr(self, name), name)
        check_positive(self.border_margin_px, "border_margin_px", strict=False)
        if not 0.0 <= self.min_score <= 1.0:
            raise InvalidInput(f"min_score must be in [0, 1], got {self.min_score}")
        if not 0.0 < self.edge_on_deg < 90.0:
            raise InvalidInput(f"edge_on_deg must be in (0, 90), got {self.edge_on_deg}")
        if int(self.curl_iterations) < 0:
            raise InvalidInput(f"curl_iterations must be >= 0, got {self.curl_iterations}")
        for name in ("iterations", "template_iterations", "level_window"):
            if int(getattr(self, name)) < 1:
                raise InvalidInput(f"{name} must be >= 1, got {getattr(self, name)}")


@dataclass(frozen=True, slots=True)
class RecordingPose:
    """The whole-recording estimate, camera frame (x right, y down, z forward).

    Attributes
    ----------
    keypoints : ndarray, shape (n, 21, 3)
        Landmarks [m]; NaN where the input was not valid.
    depth_m, depth_std : ndarray, shape (n,)
        The palm centre's smoothed depth and its posterior standard deviation [m];
        finite over the span of seen frames (gaps get the motion prior's spread),
        NaN before the first and after the last.
    rotation : ndarray, shape (n, 3, 3)
        The palm's rotation (template frame -> camera); NaN where not valid.
    orientation_set : ndarray of bool, shape (n,)
        True where the frame's own fit set the orientation; False where it was
        interpolated (or the frame is not valid).
    measured_depth_m, measured_depth_std : ndarray, shape (n,)
        The per-frame depth measurement and its prior std [m] (NaN where none).
    weight : ndarray, shape (n,)
        The final reweighting of each frame's depth measurement in [0, 1] (NaN: none).
    template : ndarray, shape (5, 3)
        The palm template [m] (:data:`PALM` landmarks, centred).
    info : dict
        Counts for the file's meta (JSON-able).
    """

    keypoints: FloatArray
    depth_m: FloatArray
    depth_std: FloatArray
    rotation: FloatArray
    orientation_set: BoolArray
    measured_depth_m: FloatArray
    measured_depth_std: FloatArray
    weight: FloatArray
    template: FloatArray
    info: dict[str, Any] = field(default_factory=dict)


# ---------------------------------------------------------------- rotations (batched)


def _kabsch(src: FloatArray, dst: FloatArray, w: FloatArray | None = None) -> FloatArray:
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


def _rotation_to(d: FloatArray) -> FloatArray:
    """Smallest rotations ``(n, 3, 3)`` taking the optical axis (0, 0, 1) onto unit ``d``."""
    axis = np.stack([-d[:, 1], d[:, 0], np.zeros(len(d))], axis=1)  # e_z x d
    s = np.linalg.norm(axis, axis=1)
    c = d[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(s[:, None] > 1e-12, axis / s[:, None], 0.0)
    Kx = np.zeros((len(d), 3, 3))
    Kx[:, 0, 1], Kx[:, 0, 2] = -k[:, 2], k[:, 1]
    Kx[:, 1, 0], Kx[:, 1, 2] = k[:, 2], -k[:, 0]
    Kx[:, 2, 0], Kx[:, 2, 1] = -k[:, 1], k[:, 0]
    eye = np.broadcast_to(np.eye(3), Kx.shape)
    return np.asarray(eye + s[:, None, None] * Kx + (1 - c)[:, None, None] * (Kx @ Kx))


def _angle(Ra: FloatArray, Rb: FloatArray) -> FloatArray:
    """Angles [rad] between rotations ``(..., 3, 3)``."""
    tr = np.einsum("...ij,...ij->...", Ra, Rb)
    return np.asarray(np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0)))


def _slerp(Ra: FloatArray, Rb: FloatArray, s: float) -> FloatArray:
    """The rotation a fraction ``s`` of the way from ``Ra`` to ``Rb``."""
    from dexlfd.rotations import (
        matrix_from_quat,
        quat_conjugate,
        quat_exp,
        quat_from_matrix,
        quat_log,
        quat_multiply,
    )

    qa, qb = quat_from_matrix(Ra), quat_from_matrix(Rb)
    if float(np.dot(qa, qb)) < 0:
        qb = -qb
    rel = quat_multiply(quat_conjugate(qa), qb)
    return np.asarray(matrix_from_quat(quat_multiply(qa, quat_exp(s * quat_log(rel)))))


# ---------------------------------------------------------------- template


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
        R = _kabsch(np.broadcast_to(T, P.shape), P)  # template -> frame
        aligned = np.einsum("nji,nkj->nki", R, P)  # frames in the template's frame
        T = np.median(aligned, axis=0)
    T = T - T.mean(axis=0)
    R = _kabsch(np.broadcast_to(T, P.shape), P)
    res = np.full(W.shape[0], np.nan)
    res[ok] = np.sqrt(np.mean(np.sum((np.einsum("nij,kj->nki", R, T) - P) ** 2, axis=2), axis=1))
    return T, res


# ---------------------------------------------------------------- smoother


def robust_smooth(
    t: FloatArray,
    z: FloatArray,
    std: FloatArray,
    accel: float,
    *,
    cauchy_c: float = 2.5,
    iterations: int = 6,
    extra: tuple[FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Robust whole-series smoothing of a scalar: RTS with a constant-velocity prior.

    The state is the value and its rate; between samples the rate takes white
    acceleration of spectral density ``accel**2`` (the acceleration penalty of a
    cubic smoothing spline). Each pass runs a Kalman filter forward and the
    Rauch-Tung-Striebel smoother back, then reweights every measurement by the
    Cauchy weight ``1 / (1 + (r / (c s))**2)`` of its residual ``r`` over its
    spread ``s`` (measurement std and the estimate's own); an outlier's weight goes
    to zero, so no single frame can pull the estimate.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times [s], strictly increasing.
    z, std : ndarray, shape (n,)
        Measurements and their standard deviations (NaN: no measurement).
    accel : float
        Acceleration noise density [unit / s^1.5].
    cauchy_c : float
        Cauchy scale [stds].
    iterations : int
        Reweighting passes (1: a plain smoother).
    extra : (z2, std2), optional
        A second measurement per frame (e.g. a depth sensor's), reweighted alike.

    Returns
    -------
    (mean, std, weight) : ndarray (n,) each
        Posterior mean and standard deviation (NaN outside the span of measured
        frames), and the final weight of each measurement (NaN where none).
    """
    t = np.asarray(t, dtype=np.float64)
    zs = [np.asarray(z, dtype=np.float64)]
    ss = [np.asarray(std, dtype=np.float64)]
    if extra is not None:
        zs.append(np.asarray(extra[0], dtype=np.float64))
        ss.append(np.asarray(extra[1], dtype=np.float64))
    has = [np.isfinite(a) & np.isfinite(b) & (b > 0) for a, b in zip(zs, ss, strict=True)]
    n = t.size
    mean = np.full(n, np.nan)
    sd = np.full(n, np.nan)
    any_has = np.logical_or.reduce(has)
    if not any_has.any():
        return mean, sd, np.full(n, np.nan)
    first = int(np.argmax(any_has))
    last = int(n - 1 - np.argmax(any_has[::-1]))
    weights = [np.where(h, 1.0, np.nan) for h in has]
    q = float(accel) ** 2
    for it in range(max(1, int(iterations))):
        var = [
            np.where(h, s**2 / np.maximum(w, 1e-6), np.nan)
            for h, s, w in zip(has, ss, weights, strict=True)
        ]
        mean_s, var_s = _rts(
            t[first : last + 1],
            [a[first : last + 1] for a in zs],
            [v[first : last + 1] for v in var],
            q,
        )
        mean[first : last + 1] = mean_s
        sd[first : last + 1] = np.sqrt(var_s)
        if it == int(iterations) - 1:
            break
        for k, (h, zk, sk) in enumerate(zip(has, zs, ss, strict=True)):
            spread = np.sqrt(sk**2 + sd**2)
            r = np.where(h, (zk - mean) / (cauchy_c * spread), np.nan)
            weights[k] = np.where(h, 1.0 / (1.0 + r**2), np.nan)
    return mean, sd, weights[0]


def _rts(
    t: FloatArray, zs: list[FloatArray], vs: list[FloatArray], q: float
) -> tuple[FloatArray, FloatArray]:
    """Kalman filter + RTS smoother of a constant-velocity scalar; value mean and variance.

    Plain floats (the 2x2 algebra written out): a few microseconds per frame.
    """
    n = t.size
    tl = t.tolist()
    meas = [
        [(z, v) for z, v in zip(zk.tolist(), vk.tolist(), strict=True)]
        for zk, vk in zip(zs, vs, strict=True)
    ]
    first = [m[0][0] for m in meas if math.isfinite(m[0][0]) and math.isfinite(m[0][1])]
    x0, x1 = (first[0] if first else 0.0), 0.0
    p00, p01, p11 = 1e6, 0.0, 1e6
    filt: list[tuple[float, float, float, float, float]] = []
    pred: list[tuple[float, float, float, float, float]] = []
    for i in range(n):
        if i > 0:
            dt = tl[i] - tl[i - 1]
            x0 = x0 + dt * x1
            p00, p01, p11 = (
                p00 + 2 * dt * p01 + dt * dt * p11 + q * dt**3 / 3,
                p01 + dt * p11 + q * dt * dt / 2,
                p11 + q * dt,
            )
        pred.append((x0, x1, p00, p01, p11))
        for m in meas:
            z, v = m[i]
            if math.isfinite(z) and math.isfinite(v):
                s = p00 + v
                g0, g1 = p00 / s, p01 / s
                r = z - x0
                x0, x1 = x0 + g0 * r, x1 + g1 * r
                p00, p01, p11 = p00 - g0 * p00, p01 - g0 * p01, p11 - g1 * p01
        filt.append((x0, x1, p00, p01, p11))
    mean = np.empty(n)
    var = np.empty(n)
    s0, s1, s00, s01, s11 = filt[-1]
    mean[-1], var[-1] = s0, s00
    for i in range(n - 2, -1, -1):
        dt = tl[i + 1] - tl[i]
        f0, f1, f00, f01, f11 = filt[i]
        q0, q1, q00, q01, q11 = pred[i + 1]
        # C = Pf F^T Pp^-1, F = [[1, dt], [0, 1]]
        a00, a01 = f00 + dt * f01, f01  # (Pf F^T) row 0
        a10, a11 = f01 + dt * f11, f11  # row 1
        det = q00 * q11 - q01 * q01
        i00, i01, i11 = q11 / det, -q01 / det, q00 / det
        c00, c01 = a00 * i00 + a01 * i01, a00 * i01 + a01 * i11
        c10, c11 = a10 * i00 + a11 * i01, a10 * i01 + a11 * i11
        d0, d1 = s0 - q0, s1 - q1
        e00, e01, e11 = s00 - q00, s01 - q01, s11 - q11
        s0, s1 = f0 + c00 * d0 + c01 * d1, f1 + c10 * d0 + c11 * d1
        # Ps = Pf + C E C^T
        ce00, ce01 = c00 * e00 + c01 * e01, c00 * e01 + c01 * e11
        ce10, ce11 = c10 * e00 + c11 * e01, c10 * e01 + c11 * e11
        s00 = f00 + ce00 * c00 + ce01 * c01
        s01 = f01 + ce00 * c10 + ce01 * c11
        s11 = f11 + ce10 * c10 + ce11 * c11
        mean[i], var[i] = s0, s00
    return mean, np.maximum(var, 0.0)


# ---------------------------------------------------------------- estimator


def estimate_recording_pose(
    t: FloatArray,
    uv_px: FloatArray,
    world_m: FloatArray,
    valid: BoolArray,
    K: Intrinsics,
    score: FloatArray | None = None,
    measured_depth_m: FloatArray | None = None,
    cfg: RecordingPoseConfig | None = None,
) -> RecordingPose:
    """The hand's camera-frame pose in every frame of a recording, estimated together.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Frame times [s], strictly increasing.
    uv_px : ndarray, shape (n, 21, 2)
        Image landmarks [px], corner convention (see :mod:`dexlfd.capture.lifting`).
    world_m : ndarray, shape (n, 21, 3)
        MediaPipe world landmarks [m].
    valid : ndarray of bool, shape (n,)
        Frames with the hand.
    K : Intrinsics
        The camera (its ``width``/``height`` are the image size for the border test).
    score : ndarray, shape (n,), optional
        Tracker confidence per frame.
    measured_depth_m : ndarray, shape (n,) or (n, 21), optional
        An RGB-D source's depth at the landmarks [m] (NaN: hole); the mean of the palm
        landmarks' readings within 3 cm of their median (at least 3 of 5) measures
        the palm centre's depth.
    cfg : RecordingPoseConfig, optional

    Returns
    -------
    RecordingPose
    """
    cfg = cfg or RecordingPoseConfig()
    t = np.asarray(t, dtype=np.float64)
    n = t.size
    uv = np.asarray(uv_px, dtype=np.float64)
    W = np.asarray(world_m, dtype=np.float64)
    if uv.shape != (n, 21, 2) or W.shape != (n, 21, 3):
        raise InvalidInput(
            f"uv_px and world_m must have shapes ({n}, 21, 2) and ({n}, 21, 3), "
            f"got {uv.shape} and {W.shape}"
        )
    ok = (
        np.asarray(valid, dtype=bool)
        & np.isfinite(uv[:, PALM]).all(axis=(1, 2))
        & np.isfinite(W[:, PALM]).all(axis=(1, 2))
    )
    nan_n = np.full(n, np.nan)
    if not ok.any():
        raise InvalidInput("no valid frame with a finite palm in image and world landmarks")
    T, shape_res = palm_template(W, ok, cfg.template_iterations)
    r_T = float(np.sqrt(np.mean(np.sum(T**2, axis=1))))
    idx = np.flatnonzero(ok)
    Wp = W[idx][:, PALM]
    m_world = Wp.mean(axis=1)
    R_i = _kabsch(np.broadcast_to(T, Wp.shape), Wp - m_world[:, None])  # template -> world
    # the viewing ray through the palm's pixel centre, and the palm in camera axes
    up = uv[idx][:, PALM]
    c_px = up.mean(axis=1)
    ray = np.stack(
        [(c_px[:, 0] - 0.5 - K.cx) / K.fx, (c_px[:, 1] - 0.5 - K.cy) / K.fy, np.ones(len(idx))],
        axis=1,
    )
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    R_ray = _rotation_to(ray)
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
    s1, s2, fit_rel = _affine_scale(Q, turned[..., :2] / turned[..., 2:3])
    with np.errstate(divide="ignore", invalid="ignore"):
        z = ray[:, 2] / s1
    r_px = np.sqrt(np.mean(np.sum((up - c_px[:, None]) ** 2, axis=2), axis=1))
    # how each frame may be trusted
    cut_palm = _near_border(up, K, cfg.border_margin_px)
    cut_hand = _near_border(uv[idx], K, 0.0)  # a landmark outside the image
    # seen edge-on: the world landmarks' palm normal far from the ray; inconsistent: also
    # where that tilt disagrees with the image's (the affine map's singular value ratio
    # is the cosine of the palm's tilt from the ray)
    normal = np.einsum("nij,j->ni", R_cam, Vt[2])
    cos_world = np.abs(np.sum(normal * ray, axis=1))
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_image = s2 / s1
    cos_edge = math.cos(math.radians(cfg.edge_on_deg))
    edge_on = cos_world < cos_edge
    shape_rel = shape_res[idx] / r_T
    inconsistent = (
        (shape_rel > cfg.max_shape_rel)
        | (fit_rel > cfg.max_shape_rel)
        | ~(np.abs(cos_world - cos_image) <= cfg.max_tilt_disagreement)
    )
    sc = np.ones(len(idx)) if score is None else np.asarray(score, dtype=np.float64)[idx]
    low = sc < cfg.min_score  # an unknown (NaN) confidence is not held against a frame
    factor = np.where(cut_palm, cfg.border_factor, np.where(cut_hand, cfg.hand_cut_factor, 1.0))
    factor *= np.where(low, cfg.low_score_factor, 1.0)
    sigma_l = factor * np.sqrt(
        cfg.depth_noise**2 + (cfg.image_noise_px / np.maximum(r_px, 1.0)) ** 2 + fit_rel**2
    )
    good_z = np.isfinite(z) & (z > 0)
    meas_l = nan_n.copy()
    meas_s = nan_n.copy()
    meas_l[idx[good_z]] = z[good_z]
    # relative noise made metric at the local depth level (a running median: a reading
    # near zero must not look precise)
    meas_s[idx[good_z]] = sigma_l[good_z] * _running_median(z[good_z], cfg.level_window)
    # curling fingers change the palm's image landmarks (a fist reads ~20 % deeper on a
    # still hand): log z_read = log z + beta * (curl - median curl), beta fitted jointly
    # with a smooth depth (alternating; ridge prior curl_prior; the reference depth is
    # smoothed harder than the output, curl_ref_accel, so the fast shape changes stay
    # in the residual), then removed
    curl = nan_n.copy()
    curl[idx] = _curl(W[idx])
    curl_c = curl - np.nanmedian(curl)
    beta = 0.0
    raw = meas_l.copy()
    for _ in range(cfg.curl_iterations):
        meas_l = raw * np.exp(-beta * curl_c)
        first, _, _ = robust_smooth(t, meas_l, meas_s, cfg.curl_ref_accel, iterations=2)
        ok_r = np.isfinite(raw) & np.isfinite(first) & (first > 0) & np.isfinite(curl_c)
        if ok_r.sum() < 10:
            break
        r = np.log(raw[ok_r] / first[ok_r])  # what the smooth depth leaves, with the curl
        wr = (first[ok_r] / meas_s[ok_r]) ** 2  # 1 / relative variance
        cc = curl_c[ok_r]
        beta = float(np.sum(wr * cc * r) / (np.sum(wr * cc**2) + 1.0 / cfg.curl_prior**2))
        # the mechanism only makes a curled hand read deeper (beta < 0); a positive fit is
        # real depth motion that goes with the grasp (the hand closes where it is far)
        beta = min(beta, 0.0)
    meas_l = raw * np.exp(-beta * curl_c)
    # the prior stds rank the frames; their level is calibrated on this recording: the
    # robust spread of the residuals of a first, strongly smoothed pass
    noise_scale = 1.0
    first, _, _ = robust_smooth(t, meas_l, meas_s, cfg.depth_accel, iterations=2)
    resid = ((meas_l - first) / meas_s)[np.isfinite(meas_l)]
    if resid.size >= 10:
        noise_scale = float(np.clip(1.4826 * np.median(np.abs(resid)), cfg.min_noise_scale, 1.0))
    meas_s = meas_s * noise_scale
    extra = _measured_depth(measured_depth_m, n, cfg)
    depth, depth_sd, lw = robust_smooth(
        t,
        meas_l,
        meas_s,
        cfg.depth_accel,
        cauchy_c=cfg.cauchy_c,
        iterations=cfg.iterations,
        extra=extra,
    )
    # the palm centre's normalised image coordinates, smoothed alike
    a = nan_n.copy()
    b = nan_n.copy()
    a[idx] = ray[:, 0] / ray[:, 2]
    b[idx] = ray[:, 1] / ray[:, 2]
    s_img = nan_n.copy()
    s_img[idx] = cfg.image_noise_px * factor
    a_s, _, _ = robust_smooth(
        t,
        a,
        s_img / K.fx,
        cfg.image_accel_px / K.fx,
        cauchy_c=cfg.cauchy_c,
        iterations=cfg.iterations,
    )
    b_s, _, _ = robust_smooth(
        t,
        b,
        s_img / K.fy,
        cfg.image_accel_px / K.fy,
        cauchy_c=cfg.cauchy_c,
        iterations=cfg.iterations,
    )
    pos = np.stack([a_s * depth, b_s * depth, depth], axis=1)
    # orientation: trusted frames set it, the others are interpolated
    trusted = ~(cut_palm | cut_hand | edge_on | low | inconsistent)
    rot = np.full((n, 3, 3), np.nan)
    rot[idx] = R_cam
    if not trusted.any():  # every frame edge-on or doubtful: the most face-on uncut ones
        usable = ~(cut_palm | cut_hand | low)
        if not usable.any():
            usable = np.ones(len(idx), bool)  # all cut or doubtful: the flips still go
        trusted = usable & (cos_world >= np.percentile(cos_world[usable], 90))
    set_mask = np.zeros(n, bool)
    set_mask[idx[trusted]] = True
    set_mask = _drop_spikes(rot, set_mask, math.radians(cfg.max_orientation_step_deg))
    rot = _fill_rotations(rot, set_mask, ok)
    # keypoints: the template's palm and the frame's own fingers, in the palm's frame
    shape = np.einsum("nji,nkj->nki", R_i, W[idx] - m_world[:, None])  # template frame
    shape[:, PALM] = T
    kp = np.full((n, 21, 3), np.nan)
    kp[idx] = np.einsum("nij,nkj->nki", rot[idx], shape) + pos[idx, None, :]
    out_rot = np.full((n, 3, 3), np.nan)
    out_rot[idx] = rot[idx]
    md = nan_n.copy()
    md[idx[good_z]] = z[good_z]
    info = {
        "frames": int(ok.sum()),
        "border_cut": int((cut_palm | cut_hand).sum()),
        "edge_on": int(edge_on.sum()),
        "low_confidence": int(low.sum()),
        "inconsistent_shape": int(inconsistent.sum()),
        "orientation_set": int(set_mask.sum()),
        "down_weighted": int(np.sum(lw[np.isfinite(lw)] < 0.5)),
        "template_radius_m": r_T,
        "depth_measured": extra is not None,
        "depth_noise_scale": noise_scale,
        "curl_beta": beta,
    }
    return RecordingPose(
        keypoints=kp,
        depth_m=depth,
        depth_std=depth_sd,
        rotation=out_rot,
        orientation_set=set_mask,
        measured_depth_m=md,
        measured_depth_std=meas_s,
        weight=lw,
        template=T,
        info=info,
    )


def _affine_scale(Q: FloatArray, q: FloatArray, iterations: int = 3) -> tuple[FloatArray, ...]:
    """Per frame, the 2-D affine map of the planar template onto the image (Huber LS).

    ``q (m, 5, 2)`` are the palm's normalised image coordinates in a camera turned
    to look along the palm's ray, ``Q (5, 2)`` the template's in-plane coordinates
    [m]. Under weak perspective ``q_k = A Q_k + c`` with ``A = (1/d) P R B``: the
    2x2 block of a rotation has singular values 1 and ``|cos tilt|``, so the larger
    singular value of ``A`` is ``1/d`` whatever the palm's orientation (the
    direction along the tilt axis is never foreshortened). Image noise biases the
    larger singular value up where the two are close (a palm facing the camera): by
    ~1.5 % at 1 px noise on a palm of 23 px radius (the depth reads that much nearer).
    Returns ``(s1, s2, rel)``: both singular values [1/m] and the RMS residual over the
    image points' RMS radius [-].
    """
    m = q.shape[0]
    X = np.concatenate([Q, np.ones((Q.shape[0], 1))], axis=1)  # (k, 3)
    w = np.ones((m, Q.shape[0]))
    coef = np.zeros((m, 3, 2))
    resid = np.zeros(q.shape[:2])
    for _ in range(int(iterations)):
        XtW = X.T[None] * w[:, None, :]  # (m, 3, k)
        coef = np.linalg.solve(XtW @ X[None] + 1e-12 * np.eye(3), XtW @ q)
        resid = np.linalg.norm(q - X[None] @ coef, axis=2)
        scale = 1.4826 * np.median(resid, axis=1, keepdims=True) + 1e-9
        w = np.minimum(1.0, 1.5 * scale / np.maximum(resid, 1e-12))
    sv = np.linalg.svd(coef[:, :2, :], compute_uv=False)
    qc = q - q.mean(axis=1, keepdims=True)
    radius = np.sqrt(np.mean(np.sum(qc**2, axis=2), axis=1))
    rel = np.sqrt(np.mean(resid**2, axis=1)) / np.maximum(radius, 1e-12)
    return sv[:, 0].astype(np.float64), sv[:, 1].astype(np.float64), np.asarray(rel, np.float64)


def _measured_depth(
    measured: FloatArray | None, n: int, cfg: RecordingPoseConfig
) -> tuple[FloatArray, FloatArray] | None:
    """Log-depth readings of an RGB-D source and their std, or None."""
    if measured is None:
        return None
    d = np.asarray(measured, dtype=np.float64)
    if d.shape == (n, 21):
        d = d[:, PALM]
        with np.errstate(invalid="ignore"):
            good = np.isfinite(d) & (d > 0)
        enough = good.sum(axis=1) >= 3  # at least 3 of the 5 palm landmarks read
        out = np.full(n, np.nan)
        dd = np.where(good, d, np.nan)[enough]
        med = np.nanmedian(dd, axis=1, keepdims=True)
        near = np.abs(dd - med) <= 0.03  # a reading off the hand (background) is dropped
        out[enough] = np.sum(np.where(near, dd, 0.0), axis=1) / np.sum(near, axis=1)
        d = out
    elif d.shape != (n,):
        raise InvalidInput(f"measured_depth_m must have shape ({n},) or ({n}, 21), got {d.shape}")
    d = np.where(np.isfinite(d) & (d > 0), d, np.nan)
    return d, d * cfg.measured_depth_noise


def _curl(W: FloatArray) -> FloatArray:
    """Finger extension per frame: fingertip-wrist over MCP-wrist distance (mean of 4) [-].

    ~1.8 for an open hand, ~0.8 for a fist (MediaPipe world landmarks ``(m, 21, 3)``).
    """
    tips = np.linalg.norm(W[:, [8, 12, 16, 20]] - W[:, [0]], axis=2).mean(axis=1)
    mcps = np.linalg.norm(W[:, [5, 9, 13, 17]] - W[:, [0]], axis=2).mean(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(tips / mcps)


def _near_border(uv: FloatArray, K: Intrinsics, margin: float) -> BoolArray:
    """Frames ``(m,)`` with a point of ``uv (m, k, 2)`` within ``margin`` px of the border."""
    u, v = uv[..., 0], uv[..., 1]
    near = (u < margin) | (u > K.width - margin) | (v < margin) | (v > K.height - margin)
    return np.asarray(near.any(axis=1))


def _running_median(x: FloatArray, window: int) -> FloatArray:
    """Median of ``x`` over a centred window of ``window`` samples (shorter at the ends)."""
    half = max(int(window) // 2, 0)
    return np.array([np.median(x[max(0, i - half) : i + half + 1]) for i in range(x.size)])


def _drop_spikes(rot: FloatArray, set_mask: BoolArray, max_step: float) -> BoolArray:
    """Unset the trusted frames whose orientation is a flip away from the others.

    The trusted frames are split into runs wherever consecutive ones turn by more
    than ``max_step``. The longest run is kept; going outwards from it, a run is kept
    when its first (last) frame is within ``max_step * sqrt(gap)`` of the last kept
    frame (``gap`` counted in frames), otherwise it is unset: a flip of one frame or a
    few between consistent ones, or a stretch whose world landmarks flipped, loses
    the flipped frames only.
    """
    out = set_mask.copy()
    ids = np.flatnonzero(out)
    if ids.size < 2:
        return out
    step = _angle(rot[ids[1:]], rot[ids[:-1]])
    runs = np.split(ids, np.flatnonzero(step > max_step) + 1)
    if len(runs) == 1:
        return out
    k0 = max(range(len(runs)), key=lambda k: runs[k].size)

    def close(a: int, b: int) -> bool:
        return bool(_angle(rot[a], rot[b]) <= max_step * math.sqrt(abs(b - a)))

    last = int(runs[k0][-1])
    for run in runs[k0 + 1 :]:
        if close(last, int(run[0])):
            last = int(run[-1])
        else:
            out[run] = False
    first = int(runs[k0][0])
    for run in reversed(runs[:k0]):
        if close(int(run[-1]), first):
            first = int(run[0])
        else:
            out[run] = False
    return out


def _fill_rotations(rot: FloatArray, set_mask: BoolArray, ok: BoolArray) -> FloatArray:
    """Valid frames without a set orientation: slerp between the set ones around, or held."""
    out = rot.copy()
    ids = np.flatnonzero(set_mask)
    if not ids.size:
        return out
    for i in np.flatnonzero(ok & ~set_mask):
        k = int(np.searchsorted(ids, i))
        if k == 0:
            out[i] = rot[ids[0]]
        elif k == ids.size:
            out[i] = rot[ids[-1]]
        else:
            a, b = ids[k - 1], ids[k]
            out[i] = _slerp(rot[a], rot[b], (i - a) / (b - a))
    return out


# ---------------------------------------------------------------- a series


def series_with_recording_pose(
    series: KeypointSeries,
    lift: LiftConfig,
    cfg: RecordingPoseConfig | None = None,
    *,
    measured_depth: bool = False,
) -> KeypointSeries:
    """``series`` with its keypoints replaced by the whole-recording estimate (base frame).

    Needs the series' world landmarks (``series.world_m``) and the intrinsics the
    lift used (``lift.intrinsics``); the estimate is mapped by ``lift.camera2base``.
    With ``measured_depth`` (an RGB-D source lifted by the ``pinhole`` model) the
    series' own keypoints carry the depth image's reading at each landmark: their
    camera-frame depth enters the same smoother as a measurement (holes are NaN).
    The series gains ``depth_std`` (n,) [m] and ``orientation_set`` (n,) and
    ``meta["recording_pose"]``. Returned unchanged when it has no world landmarks.
    """
    from dexlfd.capture.transforms import apply_transform

    if series.world_m is None or lift.intrinsics is None or not series.valid.any():
        return series
    cfg = cfg or RecordingPoseConfig()
    depth = None
    if measured_depth:
        cam = apply_transform(
            np.asarray(np.linalg.inv(lift.camera2base), np.float64), series.keypoints
        )
        depth = np.where(series.valid[:, None], cam[..., 2], np.nan)
    est = estimate_recording_pose(
        series.t,
        series.uv_px,
        series.world_m,
        series.valid,
        lift.intrinsics,
        series.score,
        measured_depth_m=depth,
        cfg=cfg,
    )
    kp = apply_transform(lift.camera2base, est.keypoints)
    from dataclasses import asdict

    meta = {**series.meta, "recording_pose": {**est.info, "settings": asdict(cfg)}}
    return replace(
        series,
        keypoints=kp,
        valid=series.valid & np.isfinite(kp[:, [0, 4, 8]]).all(axis=(1, 2)),
        depth_std=est.depth_std,
        orientation_set=est.orientation_set,
        meta=meta,
    )
