"""Teleoperation reference shaping: hand poses at camera rate → safe robot targets.

Each camera frame gives a hand pose (or nothing, when the hand was not seen).
:func:`teleop_step` turns it into the next end-effector target:

1. *Retargeting* - relative motion: the hand's displacement from where it was
   first seen, scaled by ``scale``, is added to the robot's start pose; the
   hand's rotation relative to its first orientation is applied to the robot's
   start orientation. The operator need not stand where the robot is.
2. *Workspace clamping* - the command stays inside an axis-aligned box.
   An optional ball (``reach_radius`` around ``reach_center``, e.g. the
   shoulder) keeps it inside the arm's comfortable reach as well.
3. *Rate limits* - linear speed, angular speed and gripper speed are bounded,
   so a re-detected hand far away, or a tracking glitch, produces a bounded
   ramp, never a jump.
4. *Filtering* - a first-order low-pass with time constant ``smoothing_s``
   (exact discretisation for the actual frame interval, so it behaves the
   same at 15 or 60 Hz). It comes after the clamp and the limits: a low-pass
   keeps its input's box and speed bounds (at a steady frame rate) and turns
   the ramps' velocity steps into smooth starts and stops, which keeps the
   arm's joint velocities away from their limits.
5. *Loss of the hand* - the target holds its last value; when the hand comes
   back, the rate limits make the robot resume smoothly.

Pure functions with explicit state: ``state, target =
teleop_step(state, t, measurement, cfg)``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dexlfd._params import check_params, param
from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.panda import (
    CARTESIAN_LIMITS,
    GRIPPER_OPENING_MAX,
    GRIPPER_SPEED_MAX,
    REACH,
    SHOULDER,
)
from dexlfd.rotations import quat_conjugate, quat_exp, quat_log, quat_multiply, quat_normalize

V_MAX = CARTESIAN_LIMITS["translational_velocity"][0]  # [m/s]
W_MAX = CARTESIAN_LIMITS["rotational_velocity"][0]  # [rad/s]

__all__ = ["TeleopConfig", "TeleopState", "TeleopTarget", "teleop_init", "teleop_step"]


@dataclass(frozen=True, slots=True)
class TeleopConfig:
    """Limits and filter settings of teleoperation (SI units)."""

    workspace_min: tuple[float, float, float] = (0.25, -0.45, 0.05)  # [m], base frame
    workspace_max: tuple[float, float, float] = (0.75, 0.45, 0.75)  # [m]
    scale: float = param(
        1.0, "robot/hand displacement ratio", lo=0.0, hi=10.0, lo_open=True
    )  # robot displacement per hand displacement [-]
    smoothing_s: float = param(
        0.08, "low-pass time constant (longer: a robot that never catches up with the hand)",
        unit="s", lo=0.0, hi=2.0,
    )  # fmt: skip
    max_speed: float = param(
        0.5, "TCP speed limit (the Panda's at most)", unit="m/s", lo=0.0, hi=V_MAX,
        lo_open=True, aliases=("--max-speed",),
    )  # fmt: skip
    max_angular_speed: float = param(
        1.5, "TCP angular speed limit (the Panda's at most)", unit="rad/s", lo=0.0, hi=W_MAX,
        lo_open=True, aliases=("--max-angular-speed",),
    )  # fmt: skip
    max_gripper_speed: float = param(
        0.15, "gripper speed limit (the Franka Hand's at most)", unit="m/s", lo=0.0,
        hi=GRIPPER_SPEED_MAX, lo_open=True, aliases=("--max-gripper-speed",),
    )  # fmt: skip
    gripper_range: tuple[float, float] = (0.0, GRIPPER_OPENING_MAX)  # Franka Hand opening [m]
    # optional ball the command must also stay in (e.g. around the shoulder, inside the
    # arm's reach, away from the stretched-arm singularity); None: box only
    reach_center: tuple[float, float, float] = SHOULDER  # [m], base frame (the shoulder)
    reach_radius: float | None = param(
        None, "keep the TCP within this distance of the shoulder (the Panda's reach at most)",
        unit="m", lo=0.0, hi=REACH, lo_open=True, aliases=("--reach-radius",),
    )  # fmt: skip

    def __post_init__(self) -> None:
        lo, hi = np.asarray(self.workspace_min), np.asarray(self.workspace_max)
        if lo.shape != (3,) or hi.shape != (3,) or not (lo < hi).all():
            raise InvalidInput(
                f"workspace_min must be < workspace_max on every axis, got "
                f"{self.workspace_min} and {self.workspace_max}"
            )
        check_params(self)  # scale, smoothing_s, the speed limits, reach_radius


@dataclass(frozen=True, slots=True)
class TeleopTarget:
    """Commanded end-effector target for one camera frame."""

    t: float  # [s]
    position: FloatArray  # (3,) [m]
    quaternion: FloatArray  # (4,) x, y, z, w
    gripper: float  # [m]
    tracking: bool  # False while holding because the hand is lost


@dataclass(frozen=True, slots=True)
class TeleopState:
    """Memory of the shaper between frames."""

    t: float
    robot_p0: FloatArray
    robot_q0: FloatArray
    hand_p0: FloatArray | None  # hand pose at first sight (retargeting anchor)
    hand_q0: FloatArray | None
    filtered_p: FloatArray  # retargeted command after clamp and rate limits (filter input)
    filtered_q: FloatArray
    filtered_g: float
    target: TeleopTarget


def teleop_init(
    t: float, position: FloatArray, quaternion: FloatArray, gripper: float
) -> TeleopState:
    """Start shaping at the robot's current pose (the first target holds it)."""
    p = np.asarray(position, dtype=np.float64).reshape(3)
    q = quat_normalize(np.asarray(quaternion, dtype=np.float64).reshape(4))
    if not (np.isfinite(p).all() and np.isfinite(q).all() and np.isfinite(gripper)):
        raise InvalidInput("teleop_init: robot position, quaternion and gripper must be finite")
    target = TeleopTarget(float(t), p, q, float(gripper), tracking=False)
    return TeleopState(float(t), p, q, None, None, p, q, float(gripper), target)


def _into_ball(c: FloatArray, anchor: FloatArray, center: FloatArray, R: float) -> FloatArray:
    """``c`` moved towards ``anchor`` until it is within ``R`` of ``center``.

    With ``anchor`` inside both the box and the ball, the point stays in the box
    (a segment between two box points) and ends in the ball: on the segment
    ``anchor + s (c - anchor)`` it takes the root s of ``|x(s) - center|² = R²``.
    An anchor outside the ball falls back to the radial projection.
    """
    if float(np.linalg.norm(c - center)) <= R:
        return c
    d = c - anchor
    w = anchor - center
    A, B, C = float(d @ d), float(d @ w), float(w @ w) - R * R
    if C >= 0 or A == 0:  # anchor outside (or on) the ball
        return center + (c - center) * (R / float(np.linalg.norm(c - center)))
    s_root = (-B + np.sqrt(B * B - A * C)) / A  # the positive root (C < 0)
    return anchor + min(1.0, float(s_root)) * d


def _rate_limit_vec(prev: FloatArray, new: FloatArray, max_step: float) -> FloatArray:
    d = new - prev
    n = float(np.linalg.norm(d))
    return new if n <= max_step else prev + d * (max_step / n)


def _rate_limit_quat(prev: FloatArray, new: FloatArray, max_angle: float) -> FloatArray:
    rel = quat_multiply(new, quat_conjugate(prev))
    if rel[3] < 0:
        rel = -rel
    r = quat_log(rel)  # half rotation vector
    angle = 2 * float(np.linalg.norm(r))
    if angle > max_angle:
        r = r * (max_angle / angle)
    return quat_normalize(quat_multiply(quat_exp(r), prev))


def teleop_step(
    state: TeleopState,
    t: float,
    hand_position: FloatArray | None,
    hand_quaternion: FloatArray | None,
    hand_gripper: float | None,
    cfg: TeleopConfig,
) -> tuple[TeleopState, TeleopTarget]:
    """Advance the shaper to frame time ``t`` [s] with a hand measurement.

    Pass ``None`` (or non-finite values) when the hand was not seen: the
    target then holds. Returns the new state and the target to command.
    """
    dt = float(t) - state.t
    if not dt > 0:
        raise InvalidInput(f"teleop_step: frame time must increase, got {t} after {state.t}")
    prev = state.target
    seen = (
        hand_position is not None
        and hand_quaternion is not None
        and hand_gripper is not None
        and bool(np.isfinite(hand_position).all())
        and bool(np.isfinite(hand_quaternion).all())
        and bool(np.isfinite(hand_gripper))
    )
    if not seen:
        held = replace(prev, t=float(t), tracking=False)
        return replace(state, t=float(t), target=held), held

    hp = np.asarray(hand_position, dtype=np.float64).reshape(3)
    hq = quat_normalize(np.asarray(hand_quaternion, dtype=np.float64).reshape(4))
    hand_p0 = hp if state.hand_p0 is None else state.hand_p0
    hand_q0 = hq if state.hand_q0 is None else state.hand_q0
    cmd_p = state.robot_p0 + cfg.scale * (hp - hand_p0)
    cmd_q = quat_multiply(quat_multiply(hq, quat_conjugate(hand_q0)), state.robot_q0)
    cmd_g = float(np.clip(float(hand_gripper), *cfg.gripper_range))  # type: ignore[arg-type]

    clamped = np.clip(cmd_p, cfg.workspace_min, cfg.workspace_max)
    if cfg.reach_radius is not None:
        clamped = _into_ball(clamped, state.robot_p0, np.asarray(cfg.reach_center),
                             cfg.reach_radius)  # fmt: skip
    lp = _rate_limit_vec(state.filtered_p, clamped, cfg.max_speed * dt)
    lq = _rate_limit_quat(state.filtered_q, cmd_q, cfg.max_angular_speed * dt)
    lg = state.filtered_g + float(np.clip(cmd_g - state.filtered_g, -cfg.max_gripper_speed * dt,
                                          cfg.max_gripper_speed * dt))  # fmt: skip

    # low-pass after the limits: a first-order filter never moves faster than its input
    # (|Δy| <= max |Δu| by induction on e = u - y), and its output is a convex combination
    # of points in the box, so speed and workspace bounds survive; it also rounds off the
    # velocity steps of the ramps (acceleration <= max_speed / smoothing_s)
    a = 1.0 if cfg.smoothing_s == 0 else 1.0 - np.exp(-dt / cfg.smoothing_s)
    p = prev.position + a * (lp - prev.position)
    q = _slerp(prev.quaternion, lq, a)
    g = prev.gripper + a * (lg - prev.gripper)
    target = TeleopTarget(float(t), p, q, g, tracking=True)
    new_state = TeleopState(float(t), state.robot_p0, state.robot_q0, hand_p0, hand_q0,
                            lp, lq, lg, target)  # fmt: skip
    return new_state, target


def _slerp(q0: FloatArray, q1: FloatArray, a: float) -> FloatArray:
    rel = quat_multiply(q1, quat_conjugate(q0))
    if rel[3] < 0:
        rel = -rel
    return quat_normalize(quat_multiply(quat_exp(a * quat_log(rel)), q0))
