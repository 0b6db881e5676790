"""Feasible by construction: slow a plan until the Panda can follow it.

:func:`make_feasible` checks a plan against the Panda's Cartesian limits (velocity,
acceleration of translation and rotation) and its joint limits along the plan's
inverse kinematics (joint velocity and acceleration, at :data:`JOINT_MARGIN` of the
limits: the controller's tracking adds its own motion), and slows each moving
stretch (between samples at rest, :func:`dexlfd.plan.timing.moving_stretches`) by
the factor its worst limit needs (:func:`dexlfd.plan.timing.retime`: the path is
unchanged). A plan that no timing can make feasible is refused with the reason: a
pose with no inverse-kinematics solution (out of reach, or not with this
orientation) or a position outside the workspace (through the table).
"""

from __future__ import annotations

import dataclasses
import functools
import logging

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io import Plan
from dexlfd.io.plan_facts import Feasibility, Slowdown
from dexlfd.panda import DDQ_MAX, DQ_MAX, check_workspace
from dexlfd.panda_ik import KinematicModel, solve_ik
from dexlfd.panda_kinematics import DhPanda
from dexlfd.plan.timing import cartesian_scale, moving_stretches, retime
from dexlfd.rotations import matrix_from_quat

__all__ = ["JOINT_MARGIN", "joint_profile", "make_feasible", "reachable"]

logger = logging.getLogger(__name__)

JOINT_MARGIN = 0.8  # plan joint velocity and acceleration at most this share of the limits
IK_RATE_HZ = 50.0  # [Hz] joint profile rate (a plan's fastest joint motions last > 0.2 s)
_IK_TOL = 2e-3  # [m] a sample whose IK misses by more is unreachable (rotation: 20x in rad)


def joint_profile(
    plan: Plan, model: KinematicModel, rate_hz: float = IK_RATE_HZ
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Times (m,) [s], joints q (m, 7) [rad], dq [rad/s], ddq [rad/s²] along ``plan``.

    Inverse kinematics at ``rate_hz``, each sample warm-started from the previous one
    (the branch stays continuous), derivatives by central differences.

    Raises
    ------
    InvalidInput
        A pose with no inverse-kinematics solution within the joint limits.
    """
    step = max(1, int(round(1.0 / (rate_hz * float(np.median(np.diff(plan.t)))))))
    idx = np.unique(np.append(np.arange(0, plan.n_samples, step), plan.n_samples - 1))
    R = matrix_from_quat(plan.quaternion[idx])
    qs = np.empty((idx.shape[0], 7))
    q = solve_ik(model, plan.position[idx[0]], R[0]).q
    for j, k in enumerate(idx):
        ik = solve_ik(model, plan.position[k], R[j], q, max_iter=50)
        if ik.position_error > _IK_TOL:
            ik = solve_ik(model, plan.position[k], R[j], q, max_iter=500)
        if ik.position_error > _IK_TOL or ik.rotation_error > 20 * _IK_TOL:
            raise InvalidInput(
                f"the plan is not reachable at t={plan.t[k]:.3f} s: TCP "
                f"{np.round(plan.position[k], 4).tolist()} m has no joint configuration "
                f"within the Panda's limits (inverse kinematics misses by "
                f"{1e3 * ik.position_error:.1f} mm, {np.degrees(ik.rotation_error):.1f} deg); "
                "no timing can fix that: move the pick, place, start or goal"
            )
        q = ik.q
        qs[j] = q
    t = np.asarray(plan.t[idx], dtype=np.float64)
    dq = np.asarray(np.gradient(qs, t, axis=0), dtype=np.float64)
    ddq = np.asarray(np.gradient(dq, t, axis=0), dtype=np.float64)
    return t, qs, dq, ddq


@functools.lru_cache(maxsize=1)
def _panda() -> KinematicModel:
    """The default kinematics: Table 3.1's (no MuJoCo; the caller may pass the robot's)."""
    return DhPanda()


def reachable(p: FloatArray, q: FloatArray, model: KinematicModel | None = None) -> str | None:
    """Why the Panda cannot take TCP position ``p`` [m] with orientation ``q`` (None: it can).

    Inverse kinematics within the joint limits from the ready pose.
    """
    R = matrix_from_quat(np.asarray(q, dtype=np.float64))
    ik = solve_ik(model or _panda(), np.asarray(p, dtype=np.float64), R, max_iter=500)
    if ik.position_error > _IK_TOL or ik.rotation_error > 20 * _IK_TOL:
        return (
            f"no joint configuration within the Panda's limits reaches it (inverse "
            f"kinematics misses by {1e3 * ik.position_error:.1f} mm, "
            f"{np.degrees(ik.rotation_error):.1f} deg)"
        )
    return None


_SAFETY = 1.05  # slow down 5 % more than the measured peaks need (one round, not several)


def _stretch_factor(
    plan: Plan, k0: int, k1: int, t: FloatArray, dq: FloatArray, ddq: FloatArray
) -> tuple[float, str]:
    """The slow-down samples ``k0..k1`` need (>= 1 when over a limit) and which limit."""
    sel = (t >= plan.t[k0] - 1e-9) & (t <= plan.t[k1] + 1e-9)
    f, which = cartesian_scale(plan, k0, k1)
    if sel.any():
        rv = np.abs(dq[sel]) / (JOINT_MARGIN * DQ_MAX)
        ra = np.abs(ddq[sel]) / (JOINT_MARGIN * DDQ_MAX)
        if rv.max() > f:
            f, which = float(rv.max()), f"joint {int(np.argmax(rv.max(axis=0))) + 1} velocity"
        if np.sqrt(ra.max()) > f:
            j = int(np.argmax(ra.max(axis=0))) + 1
            f, which = float(np.sqrt(ra.max())), f"joint {j} acceleration"
    return f, which


def make_feasible(
    plan: Plan, model: KinematicModel | None = None, *, max_rounds: int = 3
) -> tuple[Plan, Feasibility]:
    """The plan slowed where the Panda's limits need it, and what was done.

    ``model``: the kinematics for the inverse kinematics (anything with ``tcp_pose``
    and ``tcp_jacobian``; the caller passes the robot's, e.g. the MuJoCo Panda, which
    is faster; default :class:`dexlfd.panda_kinematics.DhPanda`, Table 3.1's).
    Returns the plan (its ``feasibility`` holds the report) and the report:
    ``needed`` (bool), ``largest`` (the largest slow-down factor), ``stretches``
    (every slow-down, each round's: ``t_s`` [s] the interval it applies to, in the
    plan's time after the previous slow-downs, ``factor``, ``limit`` and
    ``added_s``, the duration it added), ``added_s`` (their sum: the plan's growth,
    ``duration_s - duration_before_s``, to the resampling's step), ``duration_before_s``,
    ``duration_s``, and the joint peaks as shares of the limits
    (``joint_velocity_ratio``, ``joint_acceleration_ratio``) after scaling.

    Raises
    ------
    InvalidInput
        A position outside the workspace or a pose without an IK solution.
    """
    if model is None:
        model = _panda()
    check_workspace(plan.position, "plan position", plan.t)
    duration_before = float(plan.t[-1])
    done: list[Slowdown] = []  # every slow-down applied, in application order
    for _round in range(max_rounds):
        stretches = moving_stretches(plan)
        t, _q, dq, ddq = joint_profile(plan, model)
        factors = []
        for k0, k1 in stretches:
            f, which = _stretch_factor(plan, k0, k1, t, dq, ddq)
            factor = 1.0 if f <= 1.0 else _SAFETY * f
            factors.append(factor)
            if factor > 1.0:
                span = float(plan.t[k1] - plan.t[k0])
                done.append(Slowdown(t_s=(float(plan.t[k0]), float(plan.t[k1])), factor=factor,
                                     limit=which, added_s=span * (factor - 1.0)))  # fmt: skip
        if all(f == 1.0 for f in factors):
            break
        plan = retime(plan, stretches, factors)
    else:
        t, _q, dq, ddq = joint_profile(plan, model)
    report = Feasibility(
        needed=bool(done),
        largest=max([d.factor for d in done], default=1.0),
        stretches=tuple(done),
        added_s=float(sum(d.added_s for d in done)),
        duration_before_s=duration_before,
        duration_s=float(plan.t[-1]),
        joint_velocity_ratio=float((np.abs(dq) / DQ_MAX).max()),
        joint_acceleration_ratio=float((np.abs(ddq) / DDQ_MAX).max()),
        joint_margin=JOINT_MARGIN,
    )
    for d in done:
        logger.info(
            "time scaling (joint space): %.2f-%.2f s slowed %.2fx (%s): +%.2f s",
            d.t_s[0], d.t_s[1], d.factor, d.limit, d.added_s,
        )  # fmt: skip
    if done:
        logger.info(
            "time scaling (joint space): the plan now lasts %.2f s (was %.2f s, +%.2f s); "
            "joint peaks %.0f %% of the velocity and %.0f %% of the acceleration limits",
            plan.t[-1], duration_before, report.added_s,
            100 * report.joint_velocity_ratio, 100 * report.joint_acceleration_ratio,
        )  # fmt: skip
    return dataclasses.replace(plan, feasibility=report), report
