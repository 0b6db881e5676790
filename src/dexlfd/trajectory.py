"""Time-profile helpers shared by every stage: minimum-jerk phase and resampling.

A leaf module (NumPy only). The planner's end shaping, the place segment, the
controllers' approach moves, the lift study and the synthetic demonstrations all
use the same minimum-jerk profile; every stage that moves samples to another time
grid uses :func:`resample`. Rotation angles live in :mod:`dexlfd.rotations`.

References
----------
.. [1] T. Flash, N. Hogan (1985), The coordination of arm movements: an
   experimentally confirmed mathematical model, J. Neurosci. 5(7).
"""

from __future__ import annotations

import numpy as np

from dexlfd._types import FloatArray

__all__ = ["MIN_JERK_PEAK_SPEED", "minimum_jerk", "resample"]

# peak of ds/du for the minimum-jerk profile (at u = 1/2): 30/16
MIN_JERK_PEAK_SPEED = 1.875


def minimum_jerk(u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Minimum-jerk phase ``s(u) = 10u³ - 15u⁴ + 6u⁵`` and its derivatives in ``u``.

    ``u`` is clipped to [0, 1], so the profile holds 0 before and 1 after; its
    first and second derivatives are 0 at both ends [1].

    Parameters
    ----------
    u : ndarray
        Normalised time (any shape).

    Returns
    -------
    s, ds_du, d2s_du2 : ndarray
        Same shape as ``u``. Divide ``ds_du`` by the duration T [s] and ``d2s_du2``
        by T² for time derivatives.
    """
    u = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
    s = u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
    ds = 30.0 * u**2 * (1.0 - u) ** 2
    dds = 60.0 * u - 180.0 * u**2 + 120.0 * u**3
    return s, ds, dds


def resample(t_new: FloatArray, t: FloatArray, x: FloatArray) -> FloatArray:
    """Linear interpolation of samples ``x`` at times ``t`` onto ``t_new``, column by column.

    Parameters
    ----------
    t_new : ndarray, shape (m,)
        Query times [s] (or any monotone coordinate).
    t : ndarray, shape (n,)
        Increasing sample times.
    x : ndarray, shape (n,) or (n, ...)
        Samples; trailing axes are interpolated independently.

    Returns
    -------
    ndarray, shape (m,) or (m, ...)
        Outside ``[t[0], t[-1]]`` the edge sample is held (``np.interp``'s rule).
    """
    t_new = np.asarray(t_new, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        return np.interp(t_new, t, x)
    flat = x.reshape(x.shape[0], -1)
    out = np.empty((t_new.shape[0], flat.shape[1]))
    for j in range(flat.shape[1]):
        out[:, j] = np.interp(t_new, t, flat[:, j])
    return out.reshape((t_new.shape[0], *x.shape[1:]))
