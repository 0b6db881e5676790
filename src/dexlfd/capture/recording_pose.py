"""The hand's pose over a whole RGB recording: all frames estimated together (offline).

Frame by frame, an RGB-only lift (:class:`~dexlfd.capture.rgb_lifting.PnPTracker`)
reads the hand's depth from its apparent size in each frame alone; on real
third-person footage that depth jumps by 6-50 cm between frames while the wrist
moves a few pixels, and the palm's orientation flips where the hand is cut by the
image border or seen edge-on. A recording is offline, so :func:`estimate_recording_pose`
uses every frame at once:

1. **Palm template** (:func:`~dexlfd.capture.palm_template.palm_template`): the rigid,
   metric shape of this person's palm (wrist and the four finger MCPs, which keep their
   shape when the fingers curl), the robust median of MediaPipe's world landmarks over the
   clip after aligning every frame onto it (generalised Procrustes, rotation only: the
   world landmarks are metric).
2. **Per-frame measurement.** Depth from the image alone: the palm landmarks'
   bearings are turned so that the palm's viewing ray is the optical axis, and the
   template's in-plane shape is fitted to them by a 2-D affine map (Huber-weighted
   least squares, :func:`~dexlfd.capture.palm_depth.affine_scale`; the frame's fit is
   :func:`~dexlfd.capture.palm_fit.fit_palm`). Under weak perspective the map's larger
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
3. **Robust smoother** (:func:`~dexlfd.capture.robust_smoother.robust_smooth`): depth [m]
   and the palm centre's normalised image coordinates ``x/z``, ``y/z`` are each smoothed
   over the whole series by a Rauch-Tung-Striebel smoother with a constant-velocity motion
   prior (white acceleration of spectral density ``q``: the acceleration penalty) and
   iteratively reweighted measurements (Cauchy weights on the residuals over their
   predicted spread), so a frame inconsistent with its neighbours is down-weighted, never
   trusted alone. The posterior standard deviation of the depth is the per-frame
   ``depth_std`` [m]; frames without a hand between seen ones get the prior's (larger)
   spread. An RGB-D source's measured palm depth enters the same smoother as a further
   measurement with its own small standard deviation.
4. **Orientation.** Frames whose palm is cut by (or near) the border, seen edge-on (by the
   world landmarks' palm normal), of low confidence, inconsistent (palm shape residual
   against the template, or the world landmarks' tilt against the image's), or in a run
   that turns more than ``max_orientation_step_deg`` away from the orientation kept around
   it (a flip, :func:`~dexlfd.capture.palm_orientation.drop_spikes`) do not set the
   orientation: it is interpolated there by slerp between the frames that set it (held at
   the ends) and marked (``orientation_set`` False).

The output keypoints are the template's palm points and the frame's own fingers
(MediaPipe's world landmarks expressed in the palm's frame) placed by the smoothed
position and the (set or interpolated) orientation, so the palm frame that the motion
stage reads (wrist, index and little-finger MCPs) is exactly the estimated one.

5. **Full-size palm.** MediaPipe's world landmarks read the palm's extent along the
   line of sight short, so the median template is too narrow and the depth reads near;
   the smoothed depth is multiplied by one factor per clip, the palm read at its full
   size (:func:`~dexlfd.capture.palm_fit.full_size_scale`,
   ``RecordingPoseConfig.depth_template_quantile``), reported in ``info`` with its
   relative uncertainty (not with an RGB-D source's measured depth).

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
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.palm_depth import finger_curl, palm_depth
from dexlfd.capture.palm_fit import PalmFit, fit_palm, frame_trust
from dexlfd.capture.palm_orientation import palm_orientation
from dexlfd.capture.palm_template import PALM
from dexlfd.capture.recording_pose_config import RecordingPoseConfig
from dexlfd.capture.robust_smoother import robust_smooth
from dexlfd.errors import InvalidInput

if TYPE_CHECKING:
    from dexlfd.capture.keypoints import KeypointSeries
    from dexlfd.capture.lifting import LiftConfig

__all__ = [
    "RecordingPose",
    "estimate_recording_pose",
    "series_with_recording_pose",
]


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
    ok = _valid_frames(uv, W, valid, n)
    fit = fit_palm(uv, W, ok, K, cfg)
    trust = frame_trust(fit, uv, K, score, cfg)
    sigma_l = trust.factor * np.sqrt(
        cfg.depth_noise**2 + (cfg.image_noise_px / np.maximum(fit.r_px, 1.0)) ** 2 + fit.fit_rel**2
    )
    dep = palm_depth(t, fit.idx, fit.z, sigma_l, finger_curl(W[fit.idx]), measured_depth_m, cfg)
    if not dep.depth_measured:  # the palm at its full size: one factor on the clip's depth
        k = fit.depth_scale
        dep = replace(dep, depth_m=k * dep.depth_m, depth_std=k * dep.depth_std)
        dep = replace(dep, measured_m=k * dep.measured_m, measured_std=k * dep.measured_std)
    pos = _palm_position(t, fit, trust.factor, dep.depth_m, K, cfg)
    usable = ~(trust.cut_palm | trust.cut_hand | trust.low)
    rot, set_mask = palm_orientation(
        fit.R_cam,
        fit.idx,
        ok,
        usable,
        usable & ~trust.edge_on & ~trust.inconsistent,
        fit.cos_world,
        math.radians(cfg.max_orientation_step_deg),
    )
    idx = fit.idx
    # keypoints: the template's palm and the frame's own fingers, in the palm's frame
    shape = np.einsum("nji,nkj->nki", fit.R_i, W[idx] - fit.m_world[:, None])  # template frame
    shape[:, PALM] = fit.T
    kp = np.full((n, 21, 3), np.nan)
    kp[idx] = np.einsum("nij,nkj->nki", rot[idx], shape) + pos[idx, None, :]
    out_rot = np.full((n, 3, 3), np.nan)
    out_rot[idx] = rot[idx]
    lw = dep.weight
    info = {
        "frames": int(ok.sum()),
        "border_cut": int((trust.cut_palm | trust.cut_hand).sum()),
        "edge_on": int(trust.edge_on.sum()),
        "low_confidence": int(trust.low.sum()),
        "inconsistent_shape": int(trust.inconsistent.sum()),
        "orientation_set": int(set_mask.sum()),
        "down_weighted": int(np.sum(lw[np.isfinite(lw)] < 0.5)),
        "template_radius_m": fit.template_radius,
        "depth_measured": dep.depth_measured,
        "depth_noise_scale": dep.noise_scale,
        "curl_beta": dep.curl_beta,
        "depth_scale": fit.depth_scale if not dep.depth_measured else 1.0,
        "depth_scale_sd": fit.depth_scale_sd if not dep.depth_measured else 0.0,
    }
    return RecordingPose(
        keypoints=kp,
        depth_m=dep.depth_m,
        depth_std=dep.depth_std,
        rotation=out_rot,
        orientation_set=set_mask,
        measured_depth_m=dep.measured_m,
        measured_depth_std=dep.measured_std,
        weight=lw,
        template=fit.T,
        info=info,
    )


def _valid_frames(uv: FloatArray, W: FloatArray, valid: BoolArray, n: int) -> BoolArray:
    """Frames with the hand and a finite palm in image and world landmarks; checks shapes."""
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
    if not ok.any():
        raise InvalidInput("no valid frame with a finite palm in image and world landmarks")
    return np.asarray(ok)


def _palm_position(
    t: FloatArray,
    fit: PalmFit,
    factor: FloatArray,
    depth: FloatArray,
    K: Intrinsics,
    cfg: RecordingPoseConfig,
) -> FloatArray:
    """The palm centre ``(n, 3)`` [m]: its normalised image coordinates smoothed, times depth."""
    n = t.size
    idx = fit.idx
    a = np.full(n, np.nan)
    b = np.full(n, np.nan)
    a[idx] = fit.ray[:, 0] / fit.ray[:, 2]
    b[idx] = fit.ray[:, 1] / fit.ray[:, 2]
    s_img = np.full(n, np.nan)
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
    return np.stack([a_s * depth, b_s * depth, depth], axis=1)


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
    if est.info["depth_scale"] != 1.0:  # Capture's typed facts
        meta["depth_scale"] = float(est.info["depth_scale"])
        meta["depth_scale_sd"] = float(est.info["depth_scale_sd"])
    return replace(
        series,
        keypoints=kp,
        valid=series.valid & np.isfinite(kp[:, [0, 4, 8]]).all(axis=(1, 2)),
        depth_std=est.depth_std,
        orientation_set=est.orientation_set,
        meta=meta,
    )
