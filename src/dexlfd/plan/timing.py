"""Time scaling of a sampled plan: slow each moving stretch by its own factor.

A plan that stops (a pick-and-place plan holds still at the pick and the place)
falls into *moving stretches* between samples at rest. Slowing a stretch by a factor
``f`` maps its time ``t -> t0 + f (t - t0)``: the path is unchanged, velocity scales
by ``1/f`` and acceleration by ``1/f²``. Because a stretch starts and ends at rest,
different factors on neighbouring stretches keep velocity continuous (zero at the
seam). The retimed plan is resampled onto the plan's own uniform rate (positions,
velocities and accelerations linearly, which at a 1 kHz plan rate is exact to
micrometres; orientations spherically; the grasp schedule and flags by the last
sample at or before).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from dexlfd.errors import InvalidInput
from dexlfd.io import Plan
from dexlfd.io.plan_facts import Retimed
from dexlfd.panda import CARTESIAN_LIMITS
from dexlfd.rotations import quat_sign_continuous
from dexlfd.trajectory import resample

__all__ = ["cartesian_scale", "moving_stretches", "retime", "stretch_times"]

_REST = 1e-9  # [m/s, rad/s] a sample at rest


def moving_stretches(plan: Plan) -> list[tuple[int, int]]:
    """Sample ranges ``[k0, k1]`` (inclusive) between samples at rest.

    ``k0`` and ``k1`` are the rest samples around a run of moving ones (or the
    plan's ends).
    """
    speed = np.linalg.norm(plan.velocity, axis=1) + np.linalg.norm(plan.angular_velocity, axis=1)
    moving = speed > _REST
    out: list[tuple[int, int]] = []
    k, n = 0, plan.n_samples
    while k < n:
        if not moving[k]:
            k += 1
            continue
        k0 = max(k - 1, 0)
        while k < n and moving[k]:
            k += 1
        out.append((k0, min(k, n - 1)))
    return out


def cartesian_scale(plan: Plan, k0: int, k1: int, margin: float = 0.97) -> tuple[float, str]:
    """Factor (>= 1) that brings samples ``k0..k1`` under ``margin`` of the Cartesian limits.

    Returns the factor and the limit that needed the most (``""`` when none).
    """
    sl = slice(k0, k1 + 1)
    t = plan.t[sl]
    omega = plan.angular_velocity[sl]
    omega_dot = np.gradient(omega, t, axis=0) if t.shape[0] > 1 else np.zeros_like(omega)
    peaks = {
        "translational_velocity": (float(np.linalg.norm(plan.velocity[sl], axis=1).max()), 1),
        "translational_acceleration": (
            float(np.linalg.norm(plan.acceleration[sl], axis=1).max()),
            2,
        ),
        "rotational_velocity": (float(np.linalg.norm(omega, axis=1).max()), 1),
        "rotational_acceleration": (float(np.linalg.norm(omega_dot, axis=1).max()), 2),
    }
    factor, which = 1.0, ""
    for name, (value, power) in peaks.items():
        f = (value / (margin * CARTESIAN_LIMITS[name][0])) ** (1.0 / power)
        if f > factor:
            factor, which = f, name.replace("_", " ")
    return factor, which


def retime(plan: Plan, stretches: Sequence[tuple[int, int]], factors: Sequence[float]) -> Plan:
    """The plan with stretch ``i`` (sample range, inclusive) slowed by ``factors[i]`` (>= 1).

    Samples outside the stretches (at rest) keep their duration. Resampled onto the
    plan's own rate (its median step); its ``retimed`` records the factors.
    """
    if len(stretches) != len(factors):
        raise InvalidInput(f"got {len(factors)} factors for {len(stretches)} stretches")
    if any(not (np.isfinite(f) and f >= 1.0) for f in factors):
        raise InvalidInput(f"time-scaling factors must be >= 1, got {list(factors)}")
    n = plan.n_samples
    f = np.ones(n)  # factor of the interval [k, k+1] (last entry unused)
    for (k0, k1), fac in zip(stretches, factors, strict=True):
        f[k0:k1] = fac
    dt = np.diff(plan.t)
    tau = np.concatenate([[0.0], np.cumsum(dt * f[:-1])])
    # a sample's derivative scale: its interval's factor (at rest samples it is moot)
    fs = f.copy()
    fs[-1] = f[-2] if n > 1 else 1.0
    step = float(np.median(dt))
    m = int(np.floor(tau[-1] / step + 1e-9)) + 1
    t_new = np.minimum(np.arange(m) * step, tau[-1])

    def lin(x: np.ndarray) -> np.ndarray:
        return resample(t_new, tau, x)

    from scipy.spatial.transform import Rotation, Slerp

    quat = Slerp(tau, Rotation.from_quat(quat_sign_continuous(plan.quaternion)))(t_new).as_quat()
    idx = np.clip(np.searchsorted(tau, t_new + 1e-12, side="right") - 1, 0, n - 1)
    arrays: dict[str, Any] = {
        "t": t_new,
        "position": lin(plan.position),
        "velocity": lin(plan.velocity / fs[:, None]),
        "acceleration": lin(plan.acceleration / fs[:, None] ** 2),
        "quaternion": quat_sign_continuous(quat),
        "angular_velocity": lin(plan.angular_velocity / fs[:, None]),
        "gripper": lin(plan.gripper),
    }
    if plan.grasp is not None:
        arrays["grasp"] = np.asarray(plan.grasp)[idx]
    extras: dict[str, np.ndarray] = {}
    for key, val in plan.extras.items():
        v = np.asarray(val)
        if v.shape[:1] != (n,):
            extras[key] = v
        elif v.dtype.kind == "f":
            extras[key] = lin(v)
        else:
            extras[key] = v[idx]
    retimed = Retimed(
        stretches_s=tuple((float(tau[a]), float(tau[b])) for a, b in stretches),
        factors=tuple(float(x) for x in factors),
        largest=float(max(factors, default=1.0)),
        duration_before_s=float(plan.t[-1]),
        duration_s=float(t_new[-1]),
    )
    meta = {**plan.meta, "duration": float(t_new[-1])}
    poses: dict[str, Any] = {"pick": plan.pick, "place": plan.place}
    grasp = arrays.get("grasp")
    if grasp is not None and grasp.any():
        on = np.flatnonzero(grasp)
        for key, k in (("pick", int(on[0])), ("place", min(int(on[-1]) + 1, m - 1))):
            pose = poses[key]
            if pose is not None and pose.t is not None:
                poses[key] = dataclasses.replace(pose, t=float(t_new[k]))
    return dataclasses.replace(plan, **arrays, meta=meta, extras=extras, retimed=retimed, **poses)


def stretch_times(plan: Plan, stretches: Sequence[tuple[int, int]]) -> list[list[float]]:
    """``[[t0, t1], ...]`` [s] of the stretches."""
    return [[float(plan.t[a]), float(plan.t[b])] for a, b in stretches]
