"""Robust whole-series smoothing of a scalar: an RTS smoother with Cauchy reweighting.

A constant-velocity prior (white acceleration: the acceleration penalty of a cubic
smoothing spline) and iteratively reweighted measurements, so a sample inconsistent
with its neighbours is down-weighted, never trusted alone. Used for the palm's depth
and image position by :func:`~dexlfd.capture.recording_pose.estimate_recording_pose`.
"""

from __future__ import annotations

import math

import numpy as np

from dexlfd._types import FloatArray

__all__ = ["robust_smooth"]


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
