"""Rolling a DMP out: exact discretisation of its linear transformation system.

For fixed forcing the transformation system of :mod:`dexlfd.plan.dmp` is linear in
``(x, v)``, so each step uses the exact transition of the continuous system with the
inputs interpolated linearly between samples (first-order hold); the only error is
the input interpolation. :func:`coupling_response` is the response to a coupling
velocity alone (Eq. 5.6's ``c F`` term), which the planner superposes on the
uncoupled rollout.
"""

from __future__ import annotations

import functools

import numba
import numpy as np
import scipy.linalg

from dexlfd._types import FloatArray
from dexlfd._validation import as_float_array, check_finite
from dexlfd.errors import InvalidInput
from dexlfd.plan.dmp import Dmp, DmpRollout
from dexlfd.plan.dmp_config import DmpConfig
from dexlfd.plan.forcing import forcing, phase

__all__ = ["coupling_response", "rollout_dmp"]


@functools.lru_cache(maxsize=64)
def _transition(Kb: float, Db: float, h: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Exact first-order-hold discretisation of ``z' = A z + r`` over a step ``h``.

    ``z_{k+1} = Phi z_k + M0 r_k + M1 (r_{k+1} - r_k) / h`` with ``A = [[0,1],[-Kb,-Db]]``
    (from the exponential of the augmented matrix ``[[A, I, 0], [0, 0, I], [0, 0, 0]]``).
    """
    aug = np.zeros((6, 6))
    aug[0:2, 0:2] = [[0.0, 1.0], [-Kb, -Db]]
    aug[0:2, 2:4] = np.eye(2)
    aug[2:4, 4:6] = np.eye(2)
    E = scipy.linalg.expm(aug * h)
    return E[0:2, 0:2].copy(), E[0:2, 2:4].copy(), E[0:2, 4:6].copy()


@numba.njit(cache=True)
def _transition_row(r, Phi, M0, M1h, x, v, rx, rv, drx, drv):  # pragma: no cover
    """Row ``r`` of ``Phi z + M0 r_k + M1 (r_{k+1} - r_k) / h`` (``M1h = M1 / h``)."""
    return (
        Phi[r, 0] * x
        + Phi[r, 1] * v
        + M0[r, 0] * rx
        + M0[r, 1] * rv
        + M1h[r, 0] * drx
        + M1h[r, 1] * drv
    )


@numba.njit(cache=True)
def _linear_rollout(Phi, M0, M1, h, x0, v0, rx, rv, out_x, out_v):  # pragma: no cover
    """Step ``z = (x, v)`` with inputs ``rx`` (to x') and ``rv`` (to v'), each (n, d)."""
    n, d = rx.shape
    M1h = M1 / h
    for j in range(d):
        x = x0[j]
        v = v0[j]
        out_x[0, j] = x
        out_v[0, j] = v
        for k in range(n - 1):
            drx = rx[k + 1, j] - rx[k, j]
            drv = rv[k + 1, j] - rv[k, j]
            xn = _transition_row(0, Phi, M0, M1h, x, v, rx[k, j], rv[k, j], drx, drv)
            v = _transition_row(1, Phi, M0, M1h, x, v, rx[k, j], rv[k, j], drx, drv)
            x = xn
            out_x[k + 1, j] = x
            out_v[k + 1, j] = v


def _rollout_impl(
    dmp: Dmp,
    tb: FloatArray,
    x0: FloatArray,
    g: FloatArray,
    v0: FloatArray,
    u: FloatArray | None,
    ud: FloatArray | None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unchecked rollout on a uniform normalised grid; returns x, x', x'' (normalised)."""
    cfg = dmp.config
    Kb, Db = cfg.K_bar, cfg.D_bar
    n = tb.shape[0]
    s = phase(tb, cfg.alpha_s)
    f = forcing(dmp, s)
    if cfg.variant == "modified":
        rv = Kb * g[None, :] - Kb * (g - x0)[None, :] * s[:, None] + Kb * f  # Eq. (5.5)
    else:
        rv = Kb * g[None, :] + (g - x0)[None, :] * f  # Eq. (5.1)
    rx = np.zeros_like(rv) if u is None else np.ascontiguousarray(u, dtype=np.float64)
    if ud is not None:
        rv = rv + ud  # the c F' term of Eq. (5.6)
    h = float(tb[1] - tb[0])
    Phi, M0, M1 = _transition(Kb, Db, h)
    x = np.empty((n, g.shape[0]))
    v = np.empty_like(x)
    _linear_rollout(Phi, M0, M1, h, x0, v0, rx, np.ascontiguousarray(rv), x, v)
    xd: FloatArray = v + rx
    rxd: FloatArray = np.zeros_like(rx) if u is None else np.gradient(rx, h, axis=0)
    xdd: FloatArray = -Kb * x - Db * v + rv + rxd
    return x, xd, xdd


def rollout_dmp(
    dmp: Dmp,
    *,
    x0: FloatArray | None = None,
    g: FloatArray | None = None,
    duration: float | None = None,
    n_steps: int = 1001,
    v0: FloatArray | None = None,
    coupling: FloatArray | None = None,
) -> DmpRollout:
    """Integrate a fitted DMP from ``x0`` to ``g`` over ``duration``.

    Parameters
    ----------
    dmp : Dmp
    x0, g : ndarray, shape (d,), optional
        New start and goal [m]; default: the demonstration's.
    duration : float, optional
        Movement duration [s] (temporal scaling); default: the demonstration's.
    n_steps : int
        Number of output samples, uniform from 0 to ``duration``.
    v0 : ndarray, shape (d,), optional
        Initial velocity [m/s]; default: the demonstrated initial velocity,
        rescaled to the new duration.
    coupling : ndarray, shape (n_steps, d), optional
        Coupling velocity ``c F(t)`` of Eq. (5.6) per normalised time [m]; its
        derivative is added to the acceleration equation.

    Returns
    -------
    DmpRollout
    """
    d = dmp.n_dims
    x0_ = dmp.x0 if x0 is None else check_finite(as_float_array(x0, "x0", shape=(d,)), "x0")
    g_ = dmp.g if g is None else check_finite(as_float_array(g, "g", shape=(d,)), "g")
    T = dmp.duration if duration is None else float(duration)
    if not np.isfinite(T) or T <= 0:
        raise InvalidInput(f"duration must be > 0 [s], got {duration!r}")
    if int(n_steps) < 2:
        raise InvalidInput(f"n_steps must be >= 2, got {n_steps}")
    n = int(n_steps)
    v0_ = (
        dmp.v0
        if v0 is None
        else check_finite(as_float_array(v0, "v0", shape=(d,)), "v0") * T  # to per-tb
    )
    tb = np.linspace(0.0, 1.0, n)
    u = ud = None
    if coupling is not None:
        u = check_finite(as_float_array(coupling, "coupling", shape=(n, d)), "coupling")
        ud = np.gradient(u, tb, axis=0)
    x, xd, xdd = _rollout_impl(dmp, tb, x0_, g_, v0_, u, ud)
    return DmpRollout(t=tb * T, x=x, xd=xd / T, xdd=xdd / T**2)


def coupling_response(
    config: DmpConfig, n_steps: int, u: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Response of the DMP to a coupling velocity alone (zero state, no forcing).

    The DMP is linear in its state for fixed forcing, so a coupled rollout equals the
    uncoupled one plus this response; the planner uses that to scale coupling gains in
    closed form.

    Parameters
    ----------
    config : DmpConfig
    n_steps : int
        Samples on the uniform normalised grid ``[0, 1]``.
    u : ndarray, shape (n_steps, d)
        Coupling velocity per normalised time (``c F`` of Eq. 5.6).

    Returns
    -------
    x, xd, xdd : ndarray, shape (n_steps, d)
        Displacement and its first two derivatives per normalised time.
    """
    Kb, Db = config.K_bar, config.D_bar
    tb = np.linspace(0.0, 1.0, int(n_steps))
    h = float(tb[1] - tb[0])
    rx = np.ascontiguousarray(u, dtype=np.float64)
    rv = np.ascontiguousarray(np.gradient(rx, h, axis=0))  # the c F' term of Eq. (5.6)
    Phi, M0, M1 = _transition(Kb, Db, h)
    d = rx.shape[1]
    x = np.empty_like(rx)
    v = np.empty_like(rx)
    _linear_rollout(Phi, M0, M1, h, np.zeros(d), np.zeros(d), rx, rv, x, v)
    xd = v + rx
    xdd = -Kb * x - Db * v + rv + np.gradient(rx, h, axis=0)
    return x, xd, xdd
