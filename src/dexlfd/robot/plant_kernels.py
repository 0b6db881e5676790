"""The simulated arm's per-tick torque arithmetic as numba kernels (one call each per tick).

:func:`rate_limit_into` is :func:`dexlfd.robot.actuation.rate_limit` and
:func:`plant_forces` the plant's generalized force (the torque saturated to ``TAU_MAX``
minus the joint friction of :class:`dexlfd.robot.friction.FrictionLaw`, and the
fingers' set point moved towards its target) of :meth:`dexlfd.robot.sim.PandaSim.step`:
the same arithmetic over the 7 joints in plain loops, compiled once
(``njit(cache=True)``, numba's on-disk cache), instead of a dozen NumPy calls of
~1 us of dispatch each on 7-vectors. The clips are exact (``np.clip``'s values); the
friction's exponential may differ from NumPy's in the last bit.
"""

from __future__ import annotations

import math

import numba

from dexlfd._types import FloatArray

__all__ = ["plant_forces", "rate_limit_into"]


@numba.njit(cache=True)
def rate_limit_into(
    tau: FloatArray, prev: FloatArray, max_step: float, tau_max: FloatArray, out: FloatArray
) -> None:
    """``clip(clip(tau, prev - max_step, prev + max_step), -tau_max, tau_max)`` into ``out``."""
    for j in range(tau.shape[0]):
        x = tau[j]
        lo, hi = prev[j] - max_step, prev[j] + max_step
        if x < lo:
            x = lo
        if x > hi:
            x = hi
        if x < -tau_max[j]:
            x = -tau_max[j]
        if x > tau_max[j]:
            x = tau_max[j]
        out[j] = x


@numba.njit(cache=True)
def plant_forces(
    tau: FloatArray, dq: FloatArray, tau_max: FloatArray, friction: FloatArray,
    with_friction: bool, ctrl: FloatArray, finger_target: float, finger_step: float,
    fingers: bool, qfrc: FloatArray,
) -> None:  # fmt: skip
    """One physics step's inputs: ``qfrc`` (7,) [N·m] and the fingers' set point ``ctrl``.

    ``qfrc = clip(tau, ±tau_max) − τ_f(dq)`` with ``friction`` (5, 7) the rows
    φ1, −φ2, φ3, the offset φ1 / (1 + e^(−φ2 φ3)) and the viscous coefficient
    (``with_friction`` False: no friction). With ``fingers``, every entry of ``ctrl``
    moves by ``finger_target − ctrl[0]`` clipped to ±``finger_step`` [m].
    """
    for j in range(qfrc.shape[0]):
        t = tau[j]
        if t < -tau_max[j]:
            t = -tau_max[j]
        if t > tau_max[j]:
            t = tau_max[j]
        if with_friction:
            v = dq[j]
            sig = friction[0, j] / (1.0 + math.exp(friction[1, j] * (v + friction[2, j])))
            t = t - (sig - friction[3, j] + friction[4, j] * v)
        qfrc[j] = t
    if fingers:
        move = finger_target - ctrl[0]
        if move < -finger_step:
            move = -finger_step
        if move > finger_step:
            move = finger_step
        for i in range(ctrl.shape[0]):
            ctrl[i] += move
