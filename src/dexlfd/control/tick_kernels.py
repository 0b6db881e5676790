"""The 1 kHz tick's arithmetic as numba kernels: the sliding-mode laws and the safety test.

:func:`sliding_tick` is one tick of the Cartesian sliding-mode laws of
:mod:`dexlfd.control.sliding_mode` (thesis Eqs. (5.9), (5.16)-(5.26), the integral and
the decoupling of NTSM-PD-I, the null-space posture of
:func:`dexlfd.control.base.nullspace_torque`); :func:`safety_errors` the tests of
:meth:`dexlfd.control.safety.SafetyStop.check`. The same arithmetic in plain loops over
3-, 6- and 7-vectors, compiled once (``njit(cache=True)``, numba's on-disk cache), so
that the loop pays one call instead of dozens of small NumPy calls (each ~1 us of
dispatch on arrays this small). Sums run in another order than BLAS's, so the values
agree with the NumPy expressions to round-off (``tests/control/test_tick_reference.py``
checks them against the equations written with ``np.linalg.inv`` and quaternions).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.sliding_mode import LAW_NTSM, LAW_SM_SLOPE, READING_CODES
from dexlfd.panda import TAU_MAX

__all__ = [
    "kernel_signatures",
    "safety_errors",
    "sliding_tick",
    "warm_kernels",
]

_FORCE, _DETERMINANT = READING_CODES["force"], READING_CODES["determinant"]  # ints: numba
EPS_P, EPS_TASK = 1e-6, 1e-6  # regularisation of J_p M⁻¹ J_pᵀ and of J M⁻¹ Jᵀ
_TAU_MAX = np.ascontiguousarray(TAU_MAX, dtype=np.float64)


@numba.njit(cache=True)
def _clip(x: float, bound: float) -> float:
    """``x`` clipped to ±``bound`` (``np.clip``'s value: a NaN stays NaN)."""
    if x > bound:
        return bound
    if x < -bound:
        return -bound
    return x


@numba.njit(cache=True)
def _mv(A: FloatArray, x: FloatArray) -> FloatArray:
    """``A x`` for a small (n, k) ``A``."""
    n, k = A.shape
    y = np.zeros(n)
    for i in range(n):
        for j in range(k):
            y[i] += A[i, j] * x[j]
    return y


@numba.njit(cache=True)
def _mm_t(A: FloatArray, B: FloatArray) -> FloatArray:
    """``A Bᵀ`` for small (n, k) ``A`` and (m, k) ``B``."""
    n, k = A.shape
    m = B.shape[0]
    C = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            for r in range(k):
                C[i, j] += A[i, r] * B[j, r]
    return C


@numba.njit(cache=True)
def _inv3(A: FloatArray) -> FloatArray:
    """Inverse of a 3x3 matrix by cofactors (:func:`dexlfd.control.base.inv3`'s formula)."""
    a, b, c = A[0, 0], A[0, 1], A[0, 2]
    d, e, f = A[1, 0], A[1, 1], A[1, 2]
    g, h, i = A[2, 0], A[2, 1], A[2, 2]
    c0, c1, c2 = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * c0 + b * c1 + c * c2
    out = np.empty((3, 3))
    out[0, 0], out[0, 1], out[0, 2] = c0 / det, (c * h - b * i) / det, (b * f - c * e) / det
    out[1, 0], out[1, 1], out[1, 2] = c1 / det, (a * i - c * g) / det, (c * d - a * f) / det
    out[2, 0], out[2, 1], out[2, 2] = c2 / det, (b * g - a * h) / det, (a * e - b * d) / det
    return out


@numba.njit(cache=True)
def _spd_solve(A: FloatArray, y: FloatArray) -> FloatArray:
    """``A⁻¹ y`` for a symmetric positive-definite ``A`` by Cholesky (``A`` is not changed)."""
    n = A.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        L[j, j] = math.sqrt(s)
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    x = np.empty(n)
    for i in range(n):  # L x' = y
        s = y[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):  # Lᵀ x = x'
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]
    return x


@numba.njit(cache=True)
def _lambda_force(Mp: FloatArray, lam_sat: FloatArray, reading: int) -> FloatArray:
    """Eq. (5.25)'s λ force per reading (:func:`dexlfd.control.sliding_mode.lambda_force`)."""
    if reading == _FORCE:
        return lam_sat.copy()
    if reading == _DETERMINANT:  # M̄_p λ tanh(k_s s) / det M̄_p
        det = (
            Mp[0, 0] * (Mp[1, 1] * Mp[2, 2] - Mp[1, 2] * Mp[2, 1])
            - Mp[0, 1] * (Mp[1, 0] * Mp[2, 2] - Mp[1, 2] * Mp[2, 0])
            + Mp[0, 2] * (Mp[1, 0] * Mp[2, 1] - Mp[1, 1] * Mp[2, 0])
        )
        return _mv(Mp, lam_sat) / det
    return _mv(Mp, _mv(_inv3(np.abs(Mp).T.copy()), lam_sat))  # M̄_p |M̄_p|^{-T} λ tanh(k_s s)


@numba.njit(cache=True)
def sliding_tick(
    p: FloatArray, R: FloatArray, J: FloatArray, X: FloatArray, h: FloatArray,
    q: FloatArray, dq: FloatArray,
    ref_p: FloatArray, ref_v: FloatArray, ref_a: FloatArray, ref_R: FloatArray,
    ref_w: FloatArray, q_null: FloatArray, dq_null: FloatArray,
    gains: FloatArray, law: int, reading: int, decouple: bool,
    z: FloatArray, tau: FloatArray,
) -> None:  # fmt: skip
    """One tick of SM-PD / NTSM-PD / NTSM-PD-I: the saturated torque into ``tau`` (7,).

    Parameters
    ----------
    p, R, J, h : ndarray
        Model terms at the sensed state: TCP position (3,) [m], rotation (3, 3),
        Jacobian (6, 7), ``C q̇ + G`` (7,) [N·m].
    X : ndarray (6, 7)
        ``(M⁻¹Jᵀ)ᵀ``.
    q, dq : ndarray (7,)
        Sensed joints [rad] and velocities [rad/s].
    ref_p, ref_v, ref_a, ref_R, ref_w : ndarray
        The reference (position, velocity, acceleration, rotation, angular velocity).
    q_null, dq_null : ndarray (7,)
        Null-space posture [rad] and its rate [rad/s] (zeros when it does not move).
    gains : ndarray (12,)
        α, β, k_s, λ, κ, K_H, D_H, k_null, d_null, k_I, the integral's bound z_max
        [m·s] and its time step dt [s] (k_I = 0: no integral).
    law : int
        :data:`~dexlfd.control.sliding_mode.LAW_SM`, ``LAW_SM_SLOPE`` or ``LAW_NTSM``.
    reading : int
        :data:`~dexlfd.control.sliding_mode.READING_CODES`' value.
    decouple : bool
        Subtract the rotational moment's TCP acceleration ``J_p M⁻¹ J_Hᵀ m``.
    z : ndarray (3,)
        ∫ s dt [m·s]: read and updated in place (NTSM-PD-I; left alone when k_I = 0).
    tau : ndarray (7,)
        Output [N·m], saturated to ``TAU_MAX``.
    """
    alpha, beta, k_s, lam, kappa = gains[0], gains[1], gains[2], gains[3], gains[4]
    K_H, D_H, k_null, d_null, k_I = gains[5], gains[6], gains[7], gains[8], gains[9]
    zmax, dt = gains[10], gains[11]
    s, sat, a, m = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for i in range(3):
        de = -ref_v[i]
        w = 0.0
        for j in range(7):
            de += J[i, j] * dq[j]
            w += J[3 + i, j] * dq[j]
        e = p[i] - ref_p[i]
        if law == LAW_NTSM:  # [1] Eq. (5.25)
            ad = abs(de)
            s[i] = e + beta * math.copysign(ad**alpha, de)
            a_eq = math.copysign(ad ** (2.0 - alpha), de) / -(alpha * beta)
        else:
            s[i] = e + beta * de
            if law == LAW_SM_SLOPE:
                s[i] = s[i] / beta
            a_eq = -de / beta
        sat[i] = math.tanh(k_s * s[i])
        a[i] = a_eq + ref_a[i] - kappa * sat[i]
        m[i] = -D_H * (w - ref_w[i])
    # the rotational PD moment, Eq. (5.9): e_H = ¼ vee(E − Eᵀ), E = R R_dᵀ
    E = _mm_t(R, ref_R)
    m[0] += -K_H * (0.25 * (E[2, 1] - E[1, 2]))
    m[1] += -K_H * (0.25 * (E[0, 2] - E[2, 0]))
    m[2] += -K_H * (0.25 * (E[1, 0] - E[0, 1]))
    Lam_inv = _mm_t(J, X)  # J M⁻¹ Jᵀ (6, 6)
    Ap = Lam_inv[:3, :3].copy()
    for i in range(3):
        Ap[i, i] += EPS_P
    Mp = _inv3(Ap)  # M̄_p = (J_p M⁻¹ J_pᵀ)⁻¹
    if decouple:
        for i in range(3):
            a[i] -= Lam_inv[i, 3] * m[0] + Lam_inv[i, 4] * m[1] + Lam_inv[i, 5] * m[2]
    F = _mv(Mp, a) - _lambda_force(Mp, lam * sat, reading)
    if k_I > 0.0:  # NTSM-PD-I: −k_I ∫ s dt, anti-windup at z_max
        for i in range(3):
            z[i] = _clip(z[i] + dt * s[i], zmax)
            F[i] = F[i] - k_I * z[i]
    for j in range(7):
        t = h[j]
        for i in range(3):
            t += J[i, j] * F[i] + J[3 + i, j] * m[i]
        tau[j] = t
    if k_null != 0.0 or d_null != 0.0:  # (I − Jᵀ J̄ᵀ) τ0, J̄ᵀ τ0 = Λ (M⁻¹Jᵀ)ᵀ τ0
        tau0 = np.empty(7)
        for j in range(7):
            tau0[j] = k_null * (q_null[j] - q[j]) - d_null * dq[j] + d_null * dq_null[j]
        for i in range(6):
            Lam_inv[i, i] += EPS_TASK
        f = _spd_solve(Lam_inv, _mv(X, tau0))
        for j in range(7):
            t = tau0[j]
            for i in range(6):
                t -= J[i, j] * f[i]
            tau[j] += t
    for j in range(7):
        tau[j] = _clip(tau[j], _TAU_MAX[j])


@numba.njit(cache=True)
def safety_errors(
    q: FloatArray, dq: FloatArray, p: FloatArray, R: FloatArray, ref_p: FloatArray,
    ref_R: FloatArray, lo: FloatArray, hi: FloatArray, vmax: FloatArray,
) -> tuple[bool, float, float]:  # fmt: skip
    """Joints inside ``lo``..``hi`` [rad] and ±``vmax`` [rad/s] (False on a NaN); TCP errors.

    Returns
    -------
    joints_ok : bool
    err_p : float
        ``|p − ref_p|`` [m].
    err_r : float
        Angle [rad] between ``R`` and ``ref_R``: ``arccos((trace(R ref_Rᵀ) − 1) / 2)``,
        the argument clipped to [−1, 1].
    """
    ok = True
    for j in range(q.shape[0]):
        if not (lo[j] <= q[j] <= hi[j] and -vmax[j] <= dq[j] <= vmax[j]):
            ok = False
            break
    d0, d1, d2 = p[0] - ref_p[0], p[1] - ref_p[1], p[2] - ref_p[2]
    tr = 0.0
    for i in range(3):
        for j in range(3):
            tr += R[i, j] * ref_R[i, j]
    c = 0.5 * (tr - 1.0)
    return ok, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2), math.acos(min(max(c, -1.0), 1.0))


def kernel_signatures() -> list[tuple[object, tuple[object, ...]]]:
    """Each tick kernel (these and the simulated arm's) with the argument types the loop uses."""
    from numba import boolean, float64, int64

    from dexlfd.robot.plant_kernels import plant_forces, rate_limit_into

    a1, a2 = float64[::1], float64[:, ::1]  # C-contiguous 1-D and 2-D
    return [
        (
            sliding_tick,
            (
                a1,
                a2,
                a2,
                a2,
                a1,
                a1,
                a1,
                a1,
                a1,
                a1,
                a2,
                a1,
                a1,
                a1,
                a1,
                int64,
                int64,
                boolean,
                a1,
                a1,
            ),
        ),  # fmt: skip
        (safety_errors, (a1, a1, a1, a2, a1, a2, a1, a1, a1)),
        (plant_forces, (a1, a1, a1, a2, boolean, a1, float64, float64, boolean, a1)),
        (rate_limit_into, (a1, a1, float64, a1, a1)),
    ]


def warm_kernels() -> int:
    """Compile (or load from numba's cache) every tick kernel; returns how many.

    A fresh install compiles them once (about 5 s of CPU, most of it the sliding law's);
    ``dexlfd demo`` does it in the background beside the planner's kernels.
    """
    sigs = kernel_signatures()
    for kernel, args in sigs:
        kernel.compile(args)  # type: ignore[attr-defined]
    return len(sigs)
