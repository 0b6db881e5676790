"""How long each part of a pick-and-place takes: the person's timing, or the robot's.

A part the person demonstrated (the carry; a reach from the person's own start; a
retreat to the person's end) keeps the person's duration, slowed where its peaks
exceed the Panda's Cartesian limits or the person's own speed
(:func:`scale_needed`). A part the robot makes up (the reach from its ready pose or a
given start, the retreat to the ready pose) covers a distance the person never
moved: its stretch of the person's motion only shapes the path. Its duration is the
robot's own (:func:`robot_factor`): the path at :data:`ROBOT_SPEED` peak speed and
:data:`ROBOT_TURN_RATE` peak turn rate, within the Cartesian limits (the joint limits
are met after, by the joint-space time scaling, :mod:`dexlfd.plan.feasibility`).
Timed by the person, such a reach was the person's 0.43 s reach (on a real clip)
stretched 12.8x by the speed floor; it is now as long as the robot needs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dexlfd.io import LearnedModel, Plan
from dexlfd.panda import CARTESIAN_LIMITS
from dexlfd.plan.task_assemble import PART_NAMES

__all__ = [
    "LIMIT_MARGIN",
    "ROBOT_SPEED",
    "ROBOT_TURN_RATE",
    "demonstrated_speed",
    "part_timing_info",
    "robot_factor",
    "scale_needed",
    "speed_cap",
]

LIMIT_MARGIN = 0.97  # time-scale to 97 % of a limit, not onto it
# a part may peak this much faster than the person did over its stretch (a detour
# round an obstacle adds some speed)
SPEED_MARGIN = 1.25
# [m/s] but never slower than this: a stretch where the person hardly moved (a hand
# resting after the release until the video ends) would otherwise stretch the part
# 200-fold (seen on a real take: 108 s); the controllers track a 0.25 m/s reach
# within millimetres (the six-demonstration reach, 2.7 mm at 0.5 s)
MIN_SPEED_CAP = 0.25
# [m/s] peak TCP speed of a part the robot makes up (the reach from its ready pose,
# the retreat to it; no object is held then): the fastest the default controller
# tracks to well under a centimetre. Measured on the six-demonstration reach from the
# ready pose (ntsm-pd, 1.2 kg object, the reach's largest error before the grasp):
# 0.5 m/s 17.3 mm, 0.35 m/s 7.5 mm, 0.25 m/s 4.2 mm
ROBOT_SPEED = 0.35
ROBOT_TURN_RATE = 1.0  # [rad/s] peak turn rate of such a part (the Panda's: 2.5 rad/s)


def _peaks(plan: Plan) -> dict[str, tuple[float, int]]:
    """The part's peak Cartesian rates and the power of 1/T each scales with."""
    omega_dot = np.gradient(plan.angular_velocity, plan.t, axis=0)
    return {
        "translational_velocity": (float(np.linalg.norm(plan.velocity, axis=1).max()), 1),
        "translational_acceleration": (float(np.linalg.norm(plan.acceleration, axis=1).max()), 2),
        "rotational_velocity": (float(np.linalg.norm(plan.angular_velocity, axis=1).max()), 1),
        "rotational_acceleration": (float(np.linalg.norm(omega_dot, axis=1).max()), 2),
    }


def _limits_factor(peaks: dict[str, tuple[float, int]]) -> float:
    """The duration factor (any size) that brings ``peaks`` to :data:`LIMIT_MARGIN` of a limit."""
    return max(
        float(value / (LIMIT_MARGIN * CARTESIAN_LIMITS[name][0])) ** (1.0 / power)
        for name, (value, power) in peaks.items()
    )


def scale_needed(plan: Plan, cap: float | None = None) -> tuple[float, str]:
    """The duration factor that brings the part's peaks under the limits (>= 1), and which.

    The Panda's Cartesian limits, and ``cap`` [m/s] (:func:`speed_cap`) on the
    translation.
    """
    peaks = _peaks(plan)
    factor, which = max(1.0, _limits_factor(peaks)), "cartesian"
    speed = peaks["translational_velocity"][0]
    if cap is not None and speed > cap * factor:
        factor, which = speed / cap, "demonstrated speed"
    return factor, which


def robot_factor(plan: Plan) -> float:
    """The duration factor (below 1: faster) that times a made-up part by the robot.

    The part's peak speed becomes :data:`ROBOT_SPEED` (its peak turn rate at most
    :data:`ROBOT_TURN_RATE`, every peak within :data:`LIMIT_MARGIN` of the Cartesian
    limits). Speed scales with 1/T and acceleration with 1/T², so the factor is exact
    for the same path retimed.
    """
    peaks = _peaks(plan)
    return max(
        peaks["translational_velocity"][0] / ROBOT_SPEED,
        peaks["rotational_velocity"][0] / ROBOT_TURN_RATE,
        _limits_factor(peaks),
        1e-3,
    )


def demonstrated_speed(sub: LearnedModel, T: float) -> float:
    """Peak speed [m/s] of the learned stretch ``sub`` played over ``T`` [s].

    A part that starts or ends elsewhere than the person's hand did (a given pick or
    place) covers another distance in the stretch's time; it moves no faster than the
    person did there (seen in simulation: a reach 2.5x longer than the person's, at
    0.7 m/s, left the default controller 30 mm behind its reference).
    """
    v = np.gradient(sub.mean[:, :3], sub.t, axis=0)
    return float(np.linalg.norm(v, axis=1).max()) * float(sub.t[-1]) / T


def speed_cap(sub: LearnedModel, T: float) -> float:
    """A demonstrated part's speed cap [m/s]: the person's peak with a margin, or the floor."""
    return max(SPEED_MARGIN * demonstrated_speed(sub, T), MIN_SPEED_CAP)


def part_timing_info(plans: list[Plan], scales: list[float], timed_by: list[str]) -> dict[str, Any]:
    """Who timed each part (the robot or the person) and its length before time scaling."""
    return {"timed_by": dict(zip(PART_NAMES, timed_by, strict=True)),
            "robot_speed_m_s": ROBOT_SPEED,
            "duration_unscaled_s": {n: float(p.t[-1]) / s for n, p, s in
                                    zip(PART_NAMES, plans, scales, strict=True)}}  # fmt: skip
