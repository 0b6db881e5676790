"""The DMP's forcing term: phase, Gaussian basis and locally weighted regression.

Phase and basis (thesis Eq. 5.3): ``s = exp(-alpha_s tb)``; ``n_basis`` Gaussians
``psi_i(s) = exp(-h_i (s - c_i)^2)`` with centres uniform in time and widths such that
neighbours cross at 0.5; ``f(s) = sum_i w_i psi_i(s) / sum_i psi_i(s) * s``. Weights by
locally weighted regression (Eq. 5.4). The kernels skip basis functions whose
activation is below ``exp(-40)``; they serve the position DMP
(:mod:`dexlfd.plan.dmp`) and the quaternion DMP (:mod:`dexlfd.plan.quaternion_dmp`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba
import numpy as np

from dexlfd._types import FloatArray

if TYPE_CHECKING:
    from dexlfd.plan.dmp import Dmp
    from dexlfd.plan.dmp_config import DmpConfig

__all__ = ["basis_functions", "forcing", "phase"]


def phase(tb: FloatArray, alpha_s: float) -> FloatArray:
    """Canonical system ``s' = -alpha_s s``, ``s(0) = 1`` (Eq. 5.3) at normalised times."""
    return np.exp(-alpha_s * np.asarray(tb, dtype=np.float64))


def basis_functions(config: DmpConfig) -> tuple[FloatArray, FloatArray]:
    """Centres ``c`` and widths ``h`` of the Gaussians in phase, each shape (n_basis,).

    Centres are uniform in normalised time; ``h`` makes neighbours cross at 0.5.
    """
    c = np.exp(-config.alpha_s * np.linspace(0.0, 1.0, int(config.n_basis)))
    gaps = np.abs(np.diff(c))
    gaps = np.append(gaps, gaps[-1])
    h = 4.0 * np.log(2.0) / gaps**2
    return c, h


_PSI_CUT = 40.0  # exp(-40) = 4e-18: basis functions this far away are skipped


def _psi(s: FloatArray, c: FloatArray, h: FloatArray) -> FloatArray:
    """Reference (NumPy) basis activations, shape (n, N) (Eq. 5.3)."""
    return np.exp(-h[None, :] * (s[:, None] - c[None, :]) ** 2)


@numba.njit(cache=True)
def _window(sk, c, h, alpha_s):  # pragma: no cover
    """Index range ``[lo, hi)`` of the basis functions with ``h (s - c)^2 < _PSI_CUT``.

    Centres are uniform in time, so the nearest is about ``-ln(s) (N-1) / alpha_s``;
    ``h (s - c)^2`` grows monotonically away from it on both sides, so the range is
    found by walking outwards until the cut.
    """
    N = c.shape[0]
    if sk > 0.0:
        ic = int(-np.log(sk) * (N - 1) / alpha_s + 0.5)
    else:
        ic = N - 1
    ic = min(max(ic, 0), N - 1)
    lo = ic
    while lo > 0 and h[lo - 1] * (sk - c[lo - 1]) ** 2 < _PSI_CUT:
        lo -= 1
    hi = ic + 1
    while hi < N and h[hi] * (sk - c[hi]) ** 2 < _PSI_CUT:
        hi += 1
    return lo, hi


@numba.njit(cache=True)
def _forcing_kernel(s, c, h, alpha_s, W, out):  # pragma: no cover
    """``out[k] = sum_i W[:, i] psi_i(s_k) / sum_i psi_i(s_k) * s_k`` (Eq. 5.3)."""
    n = s.shape[0]
    d = W.shape[0]
    for k in range(n):
        for j in range(d):
            out[k, j] = 0.0
        tot = 0.0
        lo, hi = _window(s[k], c, h, alpha_s)
        for i in range(lo, hi):
            a = h[i] * (s[k] - c[i]) ** 2
            if a < _PSI_CUT:
                p = np.exp(-a)
                tot += p
                for j in range(d):
                    out[k, j] += W[j, i] * p
        for j in range(d):
            out[k, j] = out[k, j] / (tot + 1e-300) * s[k]


@numba.njit(cache=True)
def _lwr_kernel(s, wt, F, c, h, alpha_s, out_w):  # pragma: no cover
    """Eq. (5.4): ``w_i = sum psi_i s F wt / sum psi_i s^2 wt`` for every channel."""
    n = s.shape[0]
    N = c.shape[0]
    d = F.shape[1]
    den = np.zeros(N)
    num = np.zeros((N, d))
    for k in range(n):
        sk = s[k]
        lo, hi = _window(sk, c, h, alpha_s)
        for i in range(lo, hi):
            a = h[i] * (sk - c[i]) ** 2
            if a < _PSI_CUT:
                p = np.exp(-a) * sk * wt[k]
                den[i] += p * sk
                for j in range(d):
                    num[i, j] += p * F[k, j]
    for j in range(d):
        for i in range(N):
            out_w[j, i] = num[i, j] / (den[i] + 1e-300)


def forcing(dmp: Dmp, s: FloatArray) -> FloatArray:
    """Forcing term ``f(s) = sum(w psi) / sum(psi) * s`` (Eq. 5.3), shape (n, d)."""
    c, h = basis_functions(dmp.config)
    s = np.ascontiguousarray(s, dtype=np.float64)
    out = np.empty((s.shape[0], dmp.n_dims))
    _forcing_kernel(s, c, h, dmp.config.alpha_s, np.ascontiguousarray(dmp.weights), out)
    return out
