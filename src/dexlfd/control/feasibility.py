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
import logging
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.control.reference import check_plan_workspace
from dexlfd.errors import InvalidInput
from dexlfd.io import Plan
from dexlfd.panda import DDQ_MAX, DQ_MAX
from dexlfd.plan.timing import cartesian_scale, moving_stretches, retime
from dexlfd.robot.ik import solve_ik
from dexlfd.robot.model import RobotModel
from dexlfd.rotations import matrix_from_quat

__all__ = ["JOINT_MARGIN", "joint_profile", "make_feasible"]

logger = logging.getLogger(__name__)

JOINT_MARGIN = 0.8  # plan joint velocity and acceleration at most this share of the limits
IK_RATE_HZ = 50.0  # [Hz] joint profile rate (a plan's fastest joint motions last > 0.2 s)
_IK_TOL = 2e-3  # [m] a sample whose IK misses by more is unreachable (rotation: 20x in rad)


def joint_profile(
    plan: Plan, model: RobotModel, rate_hz: float = IK_RATE_HZ
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
    plan: Plan, model: RobotModel, *, max_rounds: int = 3
) -> tuple[Plan, dict[str, Any]]:
    """The plan slowed where the Panda's limits need it, and what was done (JSON-able).

    Returns the plan (``meta["feasibility"]`` holds the report) and the report:
    ``needed`` (bool), ``largest`` (the largest slow-down factor), ``stretches``
    (per moving stretch: ``t_s`` [s] before scaling, ``factor``, ``limit``),
    ``duration_before_s``, ``duration_s``, and the joint peaks as shares of the
    limits (``joint_velocity_ratio``, ``joint_acceleration_ratio``) after scaling.

    Raises
    ------
    InvalidInput
        A position outside the workspace or a pose without an IK solution.
    """
    check_plan_workspace(plan)
    duration_before = float(plan.t[-1])
    done: list[dict[str, Any]] = []  # per moving stretch of the plan as given
    for round_ in range(max_rounds):
        stretches = moving_stretches(plan)
        t, _q, dq, ddq = joint_profile(plan, model)
        factors = []
        for i, (k0, k1) in enumerate(stretches):
            f, which = _stretch_factor(plan, k0, k1, t, dq, ddq)
            factors.append(1.0 if f <= 1.0 else _SAFETY * f)
            if round_ == 0:
                done.append({"t_s": [float(plan.t[k0]), float(plan.t[k1])], "factor": 1.0,
                             "limit": which})  # fmt: skip
            if f > 1.0 and i < len(done) and len(done) == len(stretches):
                done[i]["factor"] *= _SAFETY * f
                done[i]["limit"] = done[i]["limit"] or which
        if all(f == 1.0 for f in factors):
            break
        plan = retime(plan, stretches, factors)
    else:
        t, _q, dq, ddq = joint_profile(plan, model)
    done = [d for d in done if d["factor"] > 1.0]
    report: dict[str, Any] = {
        "needed": bool(done),
        "largest": max([d["factor"] for d in done], default=1.0),
        "stretches": done,
        "duration_before_s": duration_before,
        "duration_s": float(plan.t[-1]),
        "joint_velocity_ratio": float((np.abs(dq) / DQ_MAX).max()),
        "joint_acceleration_ratio": float((np.abs(ddq) / DDQ_MAX).max()),
        "joint_margin": JOINT_MARGIN,
    }
    for d in done:
        logger.info(
            "time scaling: %.2f-%.2f s slowed %.2fx (%s)", d["t_s"][0], d["t_s"][1],
            d["factor"], d["limit"],
        )  # fmt: skip
    if done:
        logger.info(
            "time scaling: the plan now lasts %.2f s (was %.2f s); joint peaks %.0f %% of "
            "the velocity and %.0f %% of the acceleration limits",
            plan.t[-1], duration_before, 100 * report["joint_velocity_ratio"],
            100 * report["joint_acceleration_ratio"],
        )  # fmt: skip
    return dataclasses.replace(plan, meta={**plan.meta, "feasibility": report}), report
