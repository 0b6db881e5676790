"""Quaternion DMP for the end-effector orientation (Ude et al. 2014).

In normalised time ``tb = t / delta`` with angular velocity ``eta = delta * omega``
(base frame) and the orientation error to the goal ``e_g = 2 log(g * conj(q))``
(a rotation vector [rad]), the transformation system is the orientation analogue of
the modified position DMP (Eq. 5.5, published decoupled form)::

    eta' = Kb (e_g - e_g0 s) - Db eta + Kb f(s)
    q'   = 1/2 eta * q

with ``e_g0 = 2 log(g * conj(q0))``. Ude et al. (2014) use ``Kb e_g - Db eta + f``;
the extra ``- Kb e_g0 s`` term (as in Pastor et al. 2009 for positions) removes the
jump of the spring when the start or goal orientation changes, so a new goal
orientation is reached without an initial acceleration spike, and ``f`` is learned
independently of the start-goal rotation. Gains ``Kb``, ``Db``, phase and basis are
those of :class:`dexlfd.plan.dmp_config.DmpConfig`.

Integration: semi-implicit Euler on ``eta`` with the exponential map for ``q``
(``q <- exp(h/2 eta) * q`` keeps ``q`` unit to rounding), ``n_sub`` sub-steps per
output sample.

References
----------
.. [1] Ude, Nemec, Petric, Morimoto (2014), Orientation in Cartesian space dynamic
   movement primitives, ICRA.
.. [2] Pastor, Hoffmann, Asfour, Schaal (2009), Learning and generalization of motor
   skills by learning from demonstration, ICRA.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numba
import numpy as np

from dexlfd._types import FloatArray
from dexlfd._validation import check_trajectory
from dexlfd.errors import InvalidInput
from dexlfd.plan.dmp_config import DmpConfig
from dexlfd.plan.forcing import _forcing_kernel, _lwr_kernel, basis_functions, phase
from dexlfd.rotations import quat_conjugate, quat_log, quat_multiply, quat_sign_continuous

__all__ = ["QuaternionDmp", "QuaternionRollout", "fit_quaternion_dmp", "rollout_quaternion_dmp"]

logger = logging.getLogger(__name__)

_EPS = 1e-12
_MAX_SUBSTEP = 2.5e-4  # Euler step in normalised time (first-order error ~ 1e-3 rad)


@dataclass(frozen=True, eq=False)
class QuaternionDmp:
    """A fitted orientation DMP.

    Attributes
    ----------
    config : DmpConfig
    weights : ndarray, shape (3, n_basis)
    q0, g : ndarray, shape (4,)
        Demonstrated start and goal orientation (x, y, z, w).
    eta0 : ndarray, shape (3,)
        Demonstrated initial angular velocity per normalised time [rad].
    duration : float
        Demonstration duration [s].
    """

    config: DmpConfig
    weights: FloatArray
    q0: FloatArray
    g: FloatArray
    eta0: FloatArray
    duration: float


@dataclass(frozen=True, eq=False)
class QuaternionRollout:
    """``t`` (n,) [s], ``q`` (n, 4) unit, ``omega`` (n, 3) [rad/s], ``omegad`` (n, 3) [rad/s²]."""

    t: FloatArray
    q: FloatArray
    omega: FloatArray
    omegad: FloatArray


def _rotvec_between(q_to: FloatArray, q_from: FloatArray) -> FloatArray:
    """Rotation vector ``2 log(q_to * conj(q_from))`` [rad], broadcasting."""
    r = quat_multiply(q_to, quat_conjugate(q_from))
    r = np.where(r[..., 3:] < 0, -r, r)  # shortest rotation
    return 2.0 * quat_log(r)


def _angular_velocity(tb: FloatArray, q: FloatArray) -> FloatArray:
    """Base-frame angular velocity per normalised time at the samples, shape (n, 3)."""
    d = _rotvec_between(q[1:], q[:-1]) / np.diff(tb)[:, None]  # at midpoints
    mid = 0.5 * (tb[1:] + tb[:-1])
    eta = np.empty((tb.shape[0], 3))
    for j in range(3):
        eta[:, j] = np.interp(tb, mid, d[:, j])
    # linear extrapolation at both ends (np.interp holds the edge value)
    if tb.shape[0] > 2:
        eta[0] = d[0] + (d[0] - d[1]) * (mid[0] - tb[0]) / (mid[1] - mid[0])
        eta[-1] = d[-1] + (d[-1] - d[-2]) * (tb[-1] - mid[-1]) / (mid[-1] - mid[-2])
    return eta


def fit_quaternion_dmp(
    t: FloatArray, q: FloatArray, config: DmpConfig | None = None
) -> QuaternionDmp:
    """Fit an orientation DMP to a quaternion demonstration.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times [s], strictly increasing.
    q : ndarray, shape (n, 4)
        Orientations (x, y, z, w); renormalised and made sign-continuous here.
    config : DmpConfig, optional
        ``variant`` is ignored (always the decoupled form).

    Returns
    -------
    QuaternionDmp
    """
    cfg = config or DmpConfig()
    t, q = check_trajectory(t, q, x_name="q", n_dims=4, min_len=4)
    norms = np.linalg.norm(q, axis=1)
    if (norms < 1e-6).any():
        raise InvalidInput("q: contains zero-norm quaternions")
    q = quat_sign_continuous(q / norms[:, None])
    duration = float(t[-1] - t[0])
    tb = (t - t[0]) / duration
    eta = _angular_velocity(tb, q)
    etad = np.gradient(eta, tb, axis=0, edge_order=2)
    g = q[-1]
    e_g = _rotvec_between(g[None, :], q)
    e_g0 = e_g[0]
    s = phase(tb, cfg.alpha_s)
    Kb, Db = cfg.K_bar, cfg.D_bar
    f_t = (etad + Db * eta) / Kb - e_g + e_g0[None, :] * s[:, None]
    c, h = basis_functions(cfg)
    w = np.empty((3, c.shape[0]))
    _lwr_kernel(s, np.gradient(tb), np.ascontiguousarray(f_t), c, h, cfg.alpha_s, w)  # Eq. (5.4)
    return QuaternionDmp(
        config=cfg, weights=w, q0=q[0].copy(), g=g.copy(), eta0=eta[0].copy(), duration=duration
    )


@numba.njit(cache=True)
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):  # pragma: no cover
    return (
        a3 * b0 + a0 * b3 + a1 * b2 - a2 * b1,
        a3 * b1 - a0 * b2 + a1 * b3 + a2 * b0,
        a3 * b2 + a0 * b1 - a1 * b0 + a2 * b3,
        a3 * b3 - a0 * b0 - a1 * b1 - a2 * b2,
    )


@numba.njit(cache=True)
def _quat_rollout(q0, eta0, g, e_g0, s, fK, Kb, Db, h, n_sub, out_q, out_eta):  # pragma: no cover
    n = s.shape[0]
    qx, qy, qz, qw = q0[0], q0[1], q0[2], q0[3]
    ex, ey, ez = eta0[0], eta0[1], eta0[2]
    hs = h / n_sub
    for k in range(n):
        out_q[k, 0] = qx
        out_q[k, 1] = qy
        out_q[k, 2] = qz
        out_q[k, 3] = qw
        out_eta[k, 0] = ex
        out_eta[k, 1] = ey
        out_eta[k, 2] = ez
        if k == n - 1:
            break
        for m in range(n_sub):
            a = m / n_sub
            sk = s[k] * (1.0 - a) + s[k + 1] * a
            f0 = fK[k, 0] * (1.0 - a) + fK[k + 1, 0] * a
            f1 = fK[k, 1] * (1.0 - a) + fK[k + 1, 1] * a
            f2 = fK[k, 2] * (1.0 - a) + fK[k + 1, 2] * a
            # e_g = 2 log(g * conj(q)), shortest rotation
            rx, ry, rz, rw = _qmul(g[0], g[1], g[2], g[3], -qx, -qy, -qz, qw)
            if rw < 0.0:
                rx, ry, rz, rw = -rx, -ry, -rz, -rw
            nv = np.sqrt(rx * rx + ry * ry + rz * rz)
            if nv > 1e-12:
                sc = 2.0 * np.arctan2(nv, rw) / nv
            else:
                sc = 2.0
            ex += hs * (Kb * (sc * rx - e_g0[0] * sk) - Db * ex + f0)
            ey += hs * (Kb * (sc * ry - e_g0[1] * sk) - Db * ey + f1)
            ez += hs * (Kb * (sc * rz - e_g0[2] * sk) - Db * ez + f2)
            # q <- exp(hs/2 eta) * q
            th = 0.5 * hs * np.sqrt(ex * ex + ey * ey + ez * ez)
            if th > 1e-15:
                sn = np.sin(th) / th * 0.5 * hs
            else:
                sn = 0.5 * hs
            qx, qy, qz, qw = _qmul(sn * ex, sn * ey, sn * ez, np.cos(th), qx, qy, qz, qw)
            nq = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
            qx, qy, qz, qw = qx / nq, qy / nq, qz / nq, qw / nq


def rollout_quaternion_dmp(
    dmp: QuaternionDmp,
    *,
    q0: FloatArray | None = None,
    g: FloatArray | None = None,
    duration: float | None = None,
    n_steps: int = 1001,
    n_sub: int | None = None,
) -> QuaternionRollout:
    """Integrate an orientation DMP from ``q0`` to ``g`` (unit, x, y, z, w).

    The demonstrated initial angular velocity (per normalised time) is kept.
    ``n_sub`` Euler sub-steps per output step (default: steps of at most 2.5e-4 in
    normalised time).
    Inputs are assumed checked by the caller (see :func:`dexlfd.plan.plan_from_model`).
    """
    cfg = dmp.config
    T = dmp.duration if duration is None else float(duration)
    if not np.isfinite(T) or T <= 0:
        raise InvalidInput(f"duration must be > 0 [s], got {duration!r}")
    q0_ = dmp.q0 if q0 is None else np.asarray(q0, dtype=np.float64)
    g_ = dmp.g if g is None else np.asarray(g, dtype=np.float64)
    if float(np.dot(q0_, g_)) < 0:
        g_ = -g_
    n = int(n_steps)
    tb = np.linspace(0.0, 1.0, n)
    s = phase(tb, cfg.alpha_s)
    c, h = basis_functions(cfg)
    fK = np.empty((n, 3))
    _forcing_kernel(s, c, h, cfg.alpha_s, np.ascontiguousarray(dmp.weights), fK)
    fK *= cfg.K_bar
    e_g0 = _rotvec_between(g_, q0_)
    h_out = float(tb[1] - tb[0])
    sub = int(np.ceil(h_out / _MAX_SUBSTEP - 1e-9)) if n_sub is None else int(n_sub)
    out_q = np.empty((n, 4))
    out_eta = np.empty((n, 3))
    _quat_rollout(
        q0_,
        dmp.eta0,
        g_,
        e_g0,
        s,
        np.ascontiguousarray(fK),
        cfg.K_bar,
        cfg.D_bar,
        h_out,
        max(1, sub),
        out_q,
        out_eta,
    )
    omega = out_eta / T
    omegad = np.gradient(omega, tb * T, axis=0)
    return QuaternionRollout(t=tb * T, q=out_q, omega=omega, omegad=omegad)
