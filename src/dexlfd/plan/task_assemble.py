"""Join a pick-and-place plan's parts: reach, approach, lift, carry, lower, rise, retreat.

:func:`assemble` strings the three DMP parts of :mod:`dexlfd.plan.task` together with
the straight vertical moves and the holds at the pick and the place (where the
gripper closes and opens on a minimum-jerk ramp), and writes the plan's grasp
schedule and ``meta``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.intervals import grasp_intervals
from dexlfd.io import LearnedModel, Plan
from dexlfd.io.plan_facts import (
    Approach,
    EventErrors,
    GraspSchedule,
    Slowdown,
    TaskPose,
    TimeScaling,
)
from dexlfd.panda import GRIPPER_OPENING_MAX
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.task_poses import Pose, pose_dict
from dexlfd.rotations import quat_sign_continuous
from dexlfd.trajectory import minimum_jerk

__all__ = ["PART_NAMES", "Parts", "assemble", "levels", "log_summary"]

logger = logging.getLogger("dexlfd.plan.task")  # the task planner's messages

PART_NAMES = ("reach", "carry", "retreat")


@dataclass(frozen=True)
class Parts:
    """The planned DMP parts, their Cartesian slow-down factors, the poses between them.

    ``rise`` [m] is the open hand's vertical rise off the place; ``approach_dir`` (3,)
    the final approach's unit direction; ``info`` goes into ``meta`` as it is.
    """

    plans: list[Plan]
    scales: list[float]
    pick: Pose
    place: Pose
    events: tuple[float, float]
    approach_dir: FloatArray
    rise: float
    info: dict[str, Any]
    limits: tuple[str, ...] = ()  # what set each part's slow-down (default "cartesian")


def ramp(n: int, a: float, b: float) -> FloatArray:
    """``n`` samples from ``a`` to ``b`` along a minimum-jerk profile."""
    s = minimum_jerk(np.linspace(0.0, 1.0, n))[0]
    return np.asarray(a + (b - a) * s, dtype=np.float64)


def levels(model: LearnedModel, t_g: float, t_r: float) -> tuple[float, float]:
    """The learned open and closed openings [m]: the channel's max, and its min while held."""
    g = np.clip(model.mean[:, 7], 0.0, GRIPPER_OPENING_MAX)
    held = (model.t >= t_g) & (model.t <= t_r)
    closed = float(g[held].min()) if held.any() else float(g.min())
    return float(g.max()), closed


_CHANNELS = ("position", "velocity", "acceleration", "quaternion", "angular_velocity")
_EXTRAS = ("nominal_position", "coupling_weight", "variance_level", "clearance")
_RISE_SPEED = 0.15  # [m/s] peak speed of the vertical lift and rise
# [m/s] peak speed of the lowering onto the place: an arm sagging under an unknown
# load meets the surface before the reference ends, at up to this speed
_LOWER_SPEED = 0.06


@dataclass
class _Track:
    """The plan being assembled: channels, grasp flags, opening, extras per sample."""

    chunks: dict[str, list[np.ndarray]]
    grasp: list[np.ndarray]
    grip: list[np.ndarray]
    extras: dict[str, list[np.ndarray]]

    def add(self, arrays: dict[str, np.ndarray], held: np.ndarray, grip: np.ndarray,
            extras: dict[str, np.ndarray] | None = None) -> None:  # fmt: skip
        n = arrays["position"].shape[0]
        for c in _CHANNELS:
            self.chunks.setdefault(c, []).append(np.asarray(arrays[c]))
        self.grasp.append(np.asarray(held, bool))
        self.grip.append(np.asarray(grip, np.float64))
        for key, vals in self.extras.items():
            given = None if extras is None else extras.get(key)
            if given is None:  # a hold or a vertical move: repeat the last value
                last = np.asarray(vals[-1][-1]) if vals else np.asarray(0.0)
                vals.append(np.repeat(last[None], n, axis=0))
            else:
                vals.append(given)
        for key, given in (extras or {}).items():
            if key not in self.extras:
                self.extras[key] = [given]

    def last(self) -> tuple[FloatArray, FloatArray]:
        return self.chunks["position"][-1][-1], self.chunks["quaternion"][-1][-1]


def _hold_at(p: FloatArray, q: FloatArray, n: int) -> dict[str, np.ndarray]:
    """``n`` samples at rest at ``p``, ``q``."""
    z = np.zeros((n, 3))
    return {
        "position": np.tile(p, (n, 1)), "velocity": z, "acceleration": z,
        "quaternion": np.tile(q, (n, 1)), "angular_velocity": z,
    }  # fmt: skip


def _straight(
    p: FloatArray, q: FloatArray, delta: FloatArray, rate_hz: float, speed: float
) -> dict[str, np.ndarray]:
    """A straight minimum-jerk move by ``delta`` (3,) [m] from ``p`` at peak ``speed``.

    The first sample (``p`` itself) is dropped.
    """
    delta = np.asarray(delta, dtype=np.float64)
    T = max(0.2, 1.875 * float(np.linalg.norm(delta)) / speed)
    n = max(3, int(round(T * rate_hz)) + 1)
    s, ds, dds = minimum_jerk(np.linspace(0.0, 1.0, n))
    pos = p[None, :] + s[:, None] * delta[None, :]
    vel = (ds / T)[:, None] * delta[None, :]
    acc = (dds / T**2)[:, None] * delta[None, :]
    out = {"position": pos, "velocity": vel, "acceleration": acc,
           "quaternion": np.tile(q, (n, 1)), "angular_velocity": np.zeros((n, 3))}  # fmt: skip
    return {k: v[1:] for k, v in out.items()}


def assemble(model: LearnedModel, cfg: PlanConfig, parts: Parts) -> Plan:
    """Join reach, approach, hold, lift, carry, lower, hold, rise, retreat; schedule, meta."""
    n_hold = max(2, int(round(cfg.hold * cfg.rate_hz)))
    open_level, closed_level = levels(model, *parts.events)
    track = _Track({}, [], [], {})
    seams: dict[str, int] = {}
    spans: list[tuple[int, int]] = []

    def size() -> int:
        return sum(len(g) for g in track.grasp)

    def part(i: int) -> None:
        p = parts.plans[i]
        body = {c: np.asarray(getattr(p, c)) for c in _CHANNELS}
        extras = {k: p.extras[k] for k in _EXTRAS if k in p.extras}
        k0 = max(size() - 1, 0)
        if i > 0:  # the join sample is the previous segment's last one
            body = {c: v[1:] for c, v in body.items()}
            extras = {k: v[1:] for k, v in extras.items()}
        n = body["position"].shape[0]
        level = closed_level if i == 1 else open_level
        track.add(body, np.full(n, i == 1), np.full(n, level), extras)
        spans.append((k0, size() - 1))

    def hold_and_switch(name: str, held_before: bool) -> None:
        p, q = track.last()
        lv = (open_level, closed_level) if not held_before else (closed_level, open_level)
        track.add(_hold_at(p, q, n_hold), np.full(n_hold, held_before), np.full(n_hold, lv[0]))
        seams[name] = size()
        track.add(_hold_at(p, q, n_hold), np.full(n_hold, not held_before), ramp(n_hold, *lv))

    def straight(delta: FloatArray, held: bool, speed: float) -> None:
        p, q = track.last()
        v = _straight(p, q, delta, cfg.rate_hz, speed)
        n = v["position"].shape[0]
        track.add(v, np.full(n, held), np.full(n, closed_level if held else open_level))

    up = np.array([0.0, 0.0, 1.0])
    part(0)
    p_pre, q_pre = track.last()  # settle at the pre-grasp pose, then approach
    track.add(_hold_at(p_pre, q_pre, n_hold), np.zeros(n_hold, bool), np.full(n_hold, open_level))
    straight(cfg.approach * parts.approach_dir, held=False, speed=_LOWER_SPEED)
    hold_and_switch("pick", held_before=False)
    straight(cfg.approach * up, held=True, speed=_RISE_SPEED)
    part(1)
    straight(-cfg.approach * up, held=True, speed=_LOWER_SPEED)
    hold_and_switch("place", held_before=True)
    straight(parts.rise * up, held=False, speed=_RISE_SPEED)
    part(2)
    arrays: dict[str, Any] = {c: np.concatenate(track.chunks[c], axis=0) for c in _CHANNELS}
    t = np.arange(arrays["position"].shape[0]) / cfg.rate_hz
    closed = np.concatenate(track.grasp)
    arrays["quaternion"] = quat_sign_continuous(arrays["quaternion"])
    meta, facts = _meta(model, cfg, parts, arrays, t, (seams["pick"], seams["place"]), spans)
    schedule = GraspSchedule(
        method="model events", closed_level=closed_level, open_level=open_level,
        hold_s=cfg.hold, intervals_s=grasp_intervals(t, closed),
    )  # fmt: skip
    return Plan(
        t=t, **arrays, gripper=np.concatenate(track.grip), grasp=closed,
        pick_pose=np.concatenate([parts.pick.position, parts.pick.quaternion]),
        place_pose=np.concatenate([parts.place.position, parts.place.quaternion]),
        meta=meta,
        extras={k: np.concatenate(v, axis=0) for k, v in track.extras.items()},
        grasp_schedule=schedule, **facts,
    )  # fmt: skip


def _meta(
    model: LearnedModel,
    cfg: PlanConfig,
    parts: Parts,
    arrays: dict[str, np.ndarray],
    t: FloatArray,
    seams: tuple[int, int],
    spans: list[tuple[int, int]],
) -> tuple[dict[str, Any], dict[str, Any]]:
    """``Plan.meta`` of a pick-and-place (its parts, the model's events) and its facts.

    The facts: the task, the pick and place poses, the errors at the events, the
    approach, the Cartesian slow-downs, the obstacle passes of every part, and the
    reach's goal error and limits.
    """
    (k_pick, k_place), pick, place = seams, parts.pick, parts.place
    pos, quat = arrays["position"], arrays["quaternion"]
    pose_err = EventErrors(
        pick_position_error_m=float(np.linalg.norm(pos[k_pick] - pick.position)),
        place_position_error_m=float(np.linalg.norm(pos[k_place] - place.position)),
        pick_angle_error_deg=float(np.degrees(_angle(quat[k_pick], pick.quaternion))),
        place_angle_error_deg=float(np.degrees(_angle(quat[k_place], place.quaternion))),
    )
    slowdowns = []
    limits = parts.limits or ("cartesian",) * len(parts.scales)
    for name, (k0, k1), s, lim in zip(PART_NAMES, spans, parts.scales, limits, strict=True):
        if s > 1.0:
            span = float(t[k1] - t[k0])
            slowdowns.append(Slowdown(part=name, t_s=(float(t[k0]), float(t[k1])), factor=s,
                                      limit=lim, added_s=span * (1.0 - 1.0 / s)))  # fmt: skip
    reach = parts.plans[0]
    facts: dict[str, Any] = dict(
        frame=reach.frame,
        task="pick-and-place",
        goal_error=reach.goal_error,
        limits=reach.limits,
        pick=TaskPose.from_json(
            pose_dict(pick, given=cfg.pick is not None, t=float(t[k_pick])), "pick"
        ),
        place=TaskPose.from_json(
            pose_dict(place, given=cfg.place is not None, t=float(t[k_place])), "place"
        ),
        event_errors=pose_err,
        approach=Approach(
            direction=tuple(parts.approach_dir.tolist()),
            from_vertical_deg=float(np.degrees(np.arccos(np.clip(-parts.approach_dir[2], -1, 1)))),
            length_m=cfg.approach,
        ),
        time_scaling=TimeScaling(
            slowdowns=tuple(slowdowns), per_part=dict(zip(PART_NAMES, parts.scales, strict=True))
        ),
        obstacle_passes=tuple(r for p in parts.plans for r in p.obstacle_passes),
    )
    meta = dict(reach.meta)
    meta.update(
        start=pos[0].tolist(),
        goal=pos[-1].tolist(),
        duration=float(t[-1]),
        grasp_orientation=cfg.grasp_orientation,
        model_events={"t": [float(v) for v in parts.events],
                      "t_std": np.asarray(model.event_t_std).tolist()},
        vertical={"lift_lower_m": cfg.approach, "rise_m": parts.rise,
                  "peak_speed_m_s": _RISE_SPEED, "lowering_peak_speed_m_s": _LOWER_SPEED},
        parts=[{"name": nm, "t_s": [float(t[k0]), float(t[k1])], "duration": float(p.t[-1]),
                "time_scale": s, "goal_error": p.goal_error,
                "obstacles": [r.to_json() for r in p.obstacle_passes],
                "limits": None if p.limits is None else p.limits.to_json()}
               for nm, p, s, (k0, k1) in zip(PART_NAMES, parts.plans, parts.scales, spans,
                                             strict=True)],
    )  # fmt: skip
    meta.update(parts.info)
    return meta, facts


def _angle(q_a: FloatArray, q_b: FloatArray) -> float:
    d = abs(float(np.dot(q_a, q_b))) / float(np.linalg.norm(q_a) * np.linalg.norm(q_b))
    return 2.0 * float(np.arccos(min(1.0, d)))


def log_summary(
    plan: Plan, plans: list[Plan], timed_by: list[str], sources: tuple[str, str], dist: float
) -> None:
    """One line: the parts' durations, who timed them, where the plan starts and ends."""
    logger.info(
        "plan: pick-and-place over %.2f s from the %s: reach %.2f s (timed by the %s), carry "
        "%.2f s (%.3f m), retreat %.2f s to the %s (timed by the %s)%s", plan.t[-1],
        sources[0], plans[0].t[-1], timed_by[0], plans[1].t[-1], dist, plans[2].t[-1],
        sources[1], timed_by[2], _scaling_text(plan),
    )  # fmt: skip


def _scaling_text(plan: Plan) -> str:
    """`` (slowed reach 1.20x over 0.00-1.93 s: +0.32 s, ...)`` or ``""``."""
    slow = () if plan.time_scaling is None else plan.time_scaling.slowdowns
    if not slow:
        return ""
    return " (" + ", ".join(
        f"{s.part} slowed {s.factor:.2f}x ({s.limit}) over {s.t_s[0]:.2f}-"
        f"{s.t_s[1]:.2f} s: +{s.added_s:.2f} s" for s in slow
    ) + ")"  # fmt: skip
