"""The palm's depth in every frame of a recording: per-frame reading, then one smoothing.

Depth from the image alone (:func:`affine_scale`): the template's in-plane shape is
fitted to the palm's bearings by a 2-D affine map whose larger singular value is
``1/d`` under weak perspective. Each reading's relative standard deviation is made
metric at the local depth level (a running median); curling fingers, which make a
still hand read deeper, are corrected by ``log z_read = log z + beta (curl - median
curl)`` fitted jointly with a smooth depth (:func:`curl_corrected`); the noise level
is calibrated on the recording (:func:`noise_scale`); and the whole series, with an
RGB-D source's readings if any (:func:`measured_palm_depth`), is smoothed by
:func:`~dexlfd.capture.robust_smoother.robust_smooth` (:func:`palm_depth`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray, IntArray
from dexlfd.capture.palm_template import PALM
from dexlfd.capture.recording_pose_config import RecordingPoseConfig
from dexlfd.capture.robust_smoother import robust_smooth
from dexlfd.errors import InvalidInput

__all__ = [
    "PalmDepth",
    "affine_scale",
    "curl_corrected",
    "finger_curl",
    "measured_palm_depth",
    "noise_scale",
    "palm_depth",
    "running_median",
]


@dataclass(frozen=True, slots=True)
class PalmDepth:
    """The palm centre's depth over a recording (all arrays shape ``(n,)``).

    Attributes
    ----------
    depth_m, depth_std : ndarray
        Smoothed depth and its posterior standard deviation [m] (NaN outside the
        span of measured frames).
    weight : ndarray
        Final reweighting of each frame's reading in [0, 1] (NaN: none).
    measured_m, measured_std : ndarray
        Each frame's own reading and its calibrated std [m] (NaN where none).
    curl_beta : float
        The fitted finger-curl bias of log-depth [-] (<= 0).
    noise_scale : float
        The calibration of the readings' stds [-].
    depth_measured : bool
        Whether an RGB-D source's readings entered the smoother.
    """

    depth_m: FloatArray
    depth_std: FloatArray
    weight: FloatArray
    measured_m: FloatArray
    measured_std: FloatArray
    curl_beta: float
    noise_scale: float
    depth_measured: bool


def palm_depth(
    t: FloatArray,
    idx: IntArray,
    z: FloatArray,
    sigma_l: FloatArray,
    curl: FloatArray,
    measured_depth_m: FloatArray | None,
    cfg: RecordingPoseConfig,
) -> PalmDepth:
    """The smoothed palm depth of a recording from its per-frame readings.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Frame times [s].
    idx : ndarray of int, shape (m,)
        The valid frames.
    z, sigma_l : ndarray, shape (m,)
        Each valid frame's depth reading [m] and its relative std [-].
    curl : ndarray, shape (m,)
        Each valid frame's finger extension (:func:`finger_curl`).
    measured_depth_m : ndarray, shape (n,) or (n, 21), optional
        An RGB-D source's depth (see :func:`measured_palm_depth`).
    cfg : RecordingPoseConfig

    Returns
    -------
    PalmDepth
    """
    n = t.size
    nan_n = np.full(n, np.nan)
    good_z = np.isfinite(z) & (z > 0)
    raw = nan_n.copy()
    meas_s = nan_n.copy()
    raw[idx[good_z]] = z[good_z]
    # relative noise made metric at the local depth level (a running median: a reading
    # near zero must not look precise)
    meas_s[idx[good_z]] = sigma_l[good_z] * running_median(z[good_z], cfg.level_window)
    curl_n = nan_n.copy()
    curl_n[idx] = curl
    curl_c = curl_n - np.nanmedian(curl_n)
    meas_l, beta = curl_corrected(t, raw, meas_s, curl_c, cfg)
    scale = noise_scale(t, meas_l, meas_s, cfg)
    meas_s = meas_s * scale
    extra = measured_palm_depth(measured_depth_m, n, cfg)
    depth, depth_sd, lw = robust_smooth(
        t,
        meas_l,
        meas_s,
        cfg.depth_accel,
        cauchy_c=cfg.cauchy_c,
        iterations=cfg.iterations,
        extra=extra,
    )
    return PalmDepth(depth, depth_sd, lw, raw, meas_s, beta, scale, extra is not None)


def curl_corrected(
    t: FloatArray,
    raw: FloatArray,
    meas_s: FloatArray,
    curl_c: FloatArray,
    cfg: RecordingPoseConfig,
) -> tuple[FloatArray, float]:
    """Depth readings with the finger-curl bias removed, and the bias ``beta``.

    Curling fingers change the palm's image landmarks (a fist reads ~20 % deeper on a
    still hand): ``log z_read = log z + beta * (curl - median curl)``, ``beta`` fitted
    jointly with a smooth depth (alternating; ridge prior ``curl_prior``; the
    reference depth is smoothed harder than the output, ``curl_ref_accel``, so the
    fast shape changes stay in the residual), then removed.
    """
    beta = 0.0
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
    return raw * np.exp(-beta * curl_c), beta


def noise_scale(
    t: FloatArray, meas_l: FloatArray, meas_s: FloatArray, cfg: RecordingPoseConfig
) -> float:
    """The calibration of the readings' prior stds on this recording [-].

    The prior stds rank the frames; their level is the robust spread of the
    residuals of a first, strongly smoothed pass (clipped to ``[min_noise_scale, 1]``).
    """
    scale = 1.0
    first, _, _ = robust_smooth(t, meas_l, meas_s, cfg.depth_accel, iterations=2)
    resid = ((meas_l - first) / meas_s)[np.isfinite(meas_l)]
    if resid.size >= 10:
        scale = float(np.clip(1.4826 * np.median(np.abs(resid)), cfg.min_noise_scale, 1.0))
    return scale


def affine_scale(Q: FloatArray, q: FloatArray, iterations: int = 3) -> tuple[FloatArray, ...]:
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


def measured_palm_depth(
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


def finger_curl(W: FloatArray) -> FloatArray:
    """Finger extension per frame: fingertip-wrist over MCP-wrist distance (mean of 4) [-].

    ~1.8 for an open hand, ~0.8 for a fist (MediaPipe world landmarks ``(m, 21, 3)``).
    """
    tips = np.linalg.norm(W[:, [8, 12, 16, 20]] - W[:, [0]], axis=2).mean(axis=1)
    mcps = np.linalg.norm(W[:, [5, 9, 13, 17]] - W[:, [0]], axis=2).mean(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(tips / mcps)


def running_median(x: FloatArray, window: int) -> FloatArray:
    """Median of ``x`` over a centred window of ``window`` samples (shorter at the ends)."""
    half = max(int(window) // 2, 0)
    return np.array([np.median(x[max(0, i - half) : i + half + 1]) for i in range(x.size)])
