"""Pick it up where it is now, put it where it should go: a plan cut at the grasp events.

A model that carries the demonstrations' grasp and release (``LearnedModel.event_*``,
:mod:`dexlfd.learn.events`) is planned as a task, not as one motion. The learned
motion is cut at the event times into three parts, **reach** (start -> pick),
**carry** (pick -> place) and **retreat** (place -> goal); each part is a DMP of its
stretch of the model (:func:`dexlfd.plan.planner.plan_motion`: the same position and
orientation DMPs, obstacles and variance term as a whole-motion plan) reaching its
own new end with the learned shape. The modified DMP (Eq. 5.5) keeps the shape in
absolute terms, so the last centimetres before the pick come from the demonstrated
direction (e.g. from above) wherever the pick is. Each part ends at rest at its end
pose (the end shaping of :mod:`dexlfd.plan.end_shaping`) and the next starts from
there at rest: the joins are continuous in position and velocity (zero).

At the pick the arm holds still for ``2 hold`` seconds: the controller settles onto
the pick pose for ``hold``, then the gripper closes (the grasp schedule switches) and
has ``hold`` to close before the carry lifts; the same at the place, where it opens.
The grasp schedule (``Plan.grasp``) is closed from the pick's switch to the place's:
it is the model's events, never read from the opening. The gripper channel is the
learned open level while open and the learned closed level while closed, switched by
a minimum-jerk ramp over the second half of the hold.

Where the pick and place poses are: ``PlanConfig.pick``/``place`` (TCP positions in
the base frame, like the demonstrations' events) with an optional yaw (the TCP's
heading about the base z axis; the grasp's tilt stays the demonstrated one);
defaults: the demonstrated ones. The object rests on a support under the pick (and
is set down on one under the place) from the table up to the object's bottom
(``object_bottom`` below the TCP); each support's footprint shrinks to keep clear
of every obstacle, and a pick or place whose object itself would touch one is
refused. The supports are written into the plan (``support_center``/``support_size``)
for the simulator.

Time scaling: each part whose Cartesian velocity or acceleration peaks exceed the
Panda's limits is replanned slower by the factor that fits (velocity scales with
1/T, acceleration with 1/T²; the path in normalised time is unchanged), and
``meta["time_scaling"]`` says by how much.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, half_extents, signed_distance
from dexlfd.io import LearnedModel, Plan
from dexlfd.io._world import obstacle_arrays, support_arrays
from dexlfd.panda import (
    CARTESIAN_LIMITS,
    FINGER_MAX,
    GRIPPER_OPENING_MAX,
    TABLE_Z,
    check_workspace,
)
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.grasp_schedule import grasp_intervals
from dexlfd.rotations import matrix_from_quat, quat_multiply, quat_sign_continuous
from dexlfd.trajectory import minimum_jerk

__all__ = ["PART_NAMES", "heading", "plan_task", "with_heading"]

logger = logging.getLogger(__name__)

PART_NAMES = ("reach", "carry", "retreat")
SUPPORT_HALF_WIDTH = 0.05  # [m] half footprint of a support, at most
SUPPORT_GAP = 0.005  # [m] a support keeps at least this far from every obstacle
MIN_PICK_PLACE = 0.05  # [m] a place nearer the pick than this is no transport
TOP_GRASP_DEG = 45.0  # [deg] a demonstrated approach this near straight down is from above
_LIMIT_MARGIN = 0.97  # time-scale to 97 % of a limit, not onto it
_MAX_RETIME = 4  # replanning rounds per part (each one fits the measured peaks)


def heading(q: FloatArray) -> float:
    """The TCP's heading about the base z axis [rad] (ZYX Euler yaw) of quaternion ``q``."""
    R = matrix_from_quat(np.asarray(q, dtype=np.float64))
    return float(np.arctan2(R[1, 0], R[0, 0]))


def with_heading(q: FloatArray, yaw: float) -> FloatArray:
    """``q`` turned about the base z axis so that its :func:`heading` is ``yaw`` [rad]."""
    dyaw = yaw - heading(q)
    rz = np.array([0.0, 0.0, np.sin(dyaw / 2), np.cos(dyaw / 2)])
    out = quat_multiply(rz, np.asarray(q, dtype=np.float64))
    return np.asarray(out / np.linalg.norm(out), dtype=np.float64)


@dataclass(frozen=True, slots=True)
class _Pose:
    position: FloatArray  # (3,) [m]
    quaternion: FloatArray  # (4,)


def _event_pose(model: LearnedModel, k: int, xyz: Any, yaw: float | None) -> _Pose:
    assert model.event_position is not None and model.event_quaternion is not None
    p = model.event_position[k] if xyz is None else np.asarray(xyz, dtype=np.float64)
    q = np.asarray(model.event_quaternion[k], dtype=np.float64)
    return _Pose(p.copy(), q if yaw is None else with_heading(q, yaw))


def _check_point(name: str, p: FloatArray, cfg: PlanConfig) -> None:
    """Reach, table and obstacles for a pick or place TCP position (named ``name``)."""
    given = getattr(cfg, name) is not None
    label = name if given else f"the demonstrated {name} (give a {name} within reach)"
    check_workspace(p, label)
    if p[2] - cfg.object_bottom < TABLE_Z - 1e-3:
        raise InvalidInput(
            f"{label} {np.round(p, 4).tolist()} m puts the object's bottom "
            f"{cfg.object_bottom:g} m below the TCP under the table: z must be >= "
            f"{TABLE_Z + cfg.object_bottom:g} m"
        )
    for i, ob in enumerate(cfg.obstacles):
        if float(signed_distance(ob, p)[0]) < 0:
            raise InvalidInput(
                f"{label} {np.round(p, 4).tolist()} m is inside obstacle {i} "
                f"({ob.to_dict()}); move the {name} or the obstacle"
            )


def _support(name: str, p: FloatArray, cfg: PlanConfig, obj_half: float) -> Box | None:
    """The box the object rests on under ``p`` (None on the table), clear of obstacles.

    The footprint is at most ``2 * SUPPORT_HALF_WIDTH``, shrunk to stay
    ``SUPPORT_GAP`` from every obstacle, and never narrower than the object
    (half width ``obj_half``); an object that would itself touch an obstacle is refused.
    """
    top = float(p[2]) - cfg.object_bottom
    half = SUPPORT_HALF_WIDTH
    for i, ob in enumerate(cfg.obstacles):
        c, h = np.asarray(ob.center), np.asarray(half_extents(ob))
        if c[2] - h[2] > top:  # the obstacle is above the support's top: no conflict
            continue
        # horizontal gap between the obstacle's box and the support's axis (Chebyshev)
        gap = float(np.max(np.abs(c[:2] - p[:2]) - h[:2]))
        if gap - SUPPORT_GAP < obj_half:
            raise InvalidInput(
                f"{name} {np.round(p, 4).tolist()} m: the object there (half width "
                f"{obj_half:g} m) would stand within {SUPPORT_GAP} m of obstacle {i} "
                f"({ob.to_dict()}); move the {name} or the obstacle"
            )
        half = min(half, gap - SUPPORT_GAP)
    if top <= TABLE_Z + 1e-3:
        return None
    height = top - TABLE_Z
    return Box((float(p[0]), float(p[1]), TABLE_Z + height / 2), (2 * half, 2 * half, height))


def _slice(model: LearnedModel, t0: float, t1: float) -> LearnedModel:
    """The model's stretch ``t0..t1`` [s] (grid samples inside, plus both ends interpolated)."""
    t = model.t
    inside = (t > t0) & (t < t1)
    ts = np.concatenate([[t0], t[inside], [t1]])
    if ts.shape[0] < 8:  # a DMP wants a few samples: resample the stretch finer
        ts = np.linspace(t0, t1, 8)
    mean = np.stack([np.interp(ts, t, model.mean[:, j]) for j in range(8)], axis=1)
    mean[:, 3:7] /= np.linalg.norm(mean[:, 3:7], axis=1, keepdims=True)
    flat = model.cov.reshape(t.shape[0], -1)
    cov = np.stack([np.interp(ts, t, flat[:, j]) for j in range(64)], axis=1).reshape(-1, 8, 8)
    return LearnedModel(
        t=ts - ts[0], mean=mean, cov=cov, gmm_weights=model.gmm_weights,
        gmm_means=model.gmm_means, gmm_covs=model.gmm_covs, meta=dict(model.meta),
    )  # fmt: skip


def _scale_needed(plan: Plan) -> float:
    """The duration factor that brings the part's Cartesian peaks under the limits (>= 1)."""
    omega_dot = np.gradient(plan.angular_velocity, plan.t, axis=0)
    peaks = {
        "translational_velocity": (np.linalg.norm(plan.velocity, axis=1).max(), 1),
        "translational_acceleration": (np.linalg.norm(plan.acceleration, axis=1).max(), 2),
        "rotational_velocity": (np.linalg.norm(plan.angular_velocity, axis=1).max(), 1),
        "rotational_acceleration": (np.linalg.norm(omega_dot, axis=1).max(), 2),
    }
    factor = 1.0
    for name, (value, power) in peaks.items():
        limit = _LIMIT_MARGIN * CARTESIAN_LIMITS[name][0]
        factor = max(factor, float(value / limit) ** (1.0 / power))
    return factor


def _plan_part(sub: LearnedModel, cfg: PlanConfig, name: str, T: float) -> tuple[Plan, float]:
    """One part at duration ``T`` [s], slowed until it meets the Cartesian limits.

    The DMPs, the coupling and the end shaping run in normalised time, so a slower
    part is the same path retimed (:func:`dexlfd.plan.timing.retime` over the whole
    part): velocity / f, acceleration / f²; no second plan (and no second linear
    programme for its obstacles).
    """
    from dexlfd.plan.planner import plan_motion
    from dexlfd.plan.timing import retime

    part = plan_motion(sub, dataclasses.replace(cfg, duration=T), quiet_limits=True)
    scale = 1.0
    for _ in range(_MAX_RETIME):
        need = _scale_needed(part)
        if need <= 1.0 + 1e-6:
            return part, scale
        part = retime(part, [(0, part.n_samples - 1)], [need * 1.01])
        scale *= need * 1.01
    logger.warning("%s: still beyond the Cartesian limits after %.2fx slower", name, scale)
    return part, scale


def _ramp(n: int, a: float, b: float) -> FloatArray:
    """``n`` samples from ``a`` to ``b`` along a minimum-jerk profile."""
    s = minimum_jerk(np.linspace(0.0, 1.0, n))[0]
    return np.asarray(a + (b - a) * s, dtype=np.float64)


def _levels(model: LearnedModel, t_g: float, t_r: float) -> tuple[float, float]:
    """The learned open and closed openings [m]: the channel's max, and its min while held."""
    g = np.clip(model.mean[:, 7], 0.0, GRIPPER_OPENING_MAX)
    held = (model.t >= t_g) & (model.t <= t_r)
    closed = float(g[held].min()) if held.any() else float(g.min())
    return float(g.max()), closed


def _approach_direction(
    model: LearnedModel, t_g: float, length: float, pick: _Pose, yaw: float | None
) -> tuple[FloatArray, FloatArray]:
    """Unit direction (3,) of the final approach to the pick, and the demonstrated one.

    The demonstrated direction runs from the learned mean position ``length`` of path
    before the grasp time to the mean position at it (turned about z with the pick's
    heading when a yaw is given). Within :data:`TOP_GRASP_DEG` of straight down it is
    a grasp from above, approached straight down: the fingertips pass the object's
    top while they descend, and a slanted descent with the controller's lag of a
    centimetre sweeps them into it (seen in simulation: the box knocked over at one
    pick in four with the 25 deg slant of the demonstrations). A more slanted
    demonstration is a side grasp, approached along its own direction.
    """
    t, p = model.t, model.mean[:, :3]
    before = t <= t_g
    pts = np.vstack([p[before], np.array([np.interp(t_g, t, p[:, j]) for j in range(3)])])
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    back = np.cumsum(seg[::-1])
    k = int(np.searchsorted(back, length))
    start = pts[max(0, len(pts) - 2 - k)]
    d = pts[-1] - start
    if np.linalg.norm(d) < 1e-6:
        return np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, -1.0])
    d = d / np.linalg.norm(d)
    if yaw is not None and model.event_quaternion is not None:
        dyaw = yaw - heading(model.event_quaternion[0])
        c, s = np.cos(dyaw), np.sin(dyaw)
        d = np.array([c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]])
    if np.degrees(np.arccos(np.clip(-d[2], -1.0, 1.0))) <= TOP_GRASP_DEG:
        return np.array([0.0, 0.0, -1.0]), np.asarray(d, dtype=np.float64)
    return np.asarray(d, dtype=np.float64), np.asarray(d, dtype=np.float64)


def _placed_hull(place: FloatArray, cfg: PlanConfig) -> Box:
    """The placed object with the open fingers' span around it (a box) [m].

    The object's centre is the place TCP position, ``object_bottom`` its half height;
    horizontally it is widened by the open hand's finger travel on each side.
    """
    half = cfg.object_half_width + FINGER_MAX
    return Box(
        (float(place[0]), float(place[1]), float(place[2])),
        (2 * half, 2 * half, 2 * cfg.object_bottom),
    )


def _vertical_rise(cfg: PlanConfig) -> float:
    """How far the open hand rises straight up after the release [m].

    Twice the object's height below the TCP plus 2 cm: the open fingers clear it
    before the learned retreat moves sideways.
    """
    return max(cfg.approach, 2 * cfg.object_bottom + 0.02)


def plan_task(model: LearnedModel, cfg: PlanConfig) -> Plan:
    """Plan reach, carry and retreat through the pick and place poses (module docstring).

    Raises
    ------
    InvalidInput
        A pick or place out of reach, under the table, inside an obstacle, or a place
        too near the pick; a bad start or goal (as for a whole-motion plan).
    """
    assert model.event_t is not None
    t_g, t_r = (float(v) for v in model.event_t)
    t0, t1 = float(model.t[0]), float(model.t[-1])
    pick = _event_pose(model, 0, cfg.pick, cfg.pick_yaw)
    place = _event_pose(model, 1, cfg.place, cfg.place_yaw)
    up, rise = np.array([0.0, 0.0, cfg.approach]), np.array([0.0, 0.0, _vertical_rise(cfg)])
    for name, pose in (("pick", pick), ("place", place)):
        _check_point(name, pose.position, cfg)
    approach_dir, demo_dir = _approach_direction(model, t_g, cfg.approach, pick, cfg.pick_yaw)
    pre_grasp = pick.position - cfg.approach * approach_dir
    check_workspace(pre_grasp, f"the approach to the pick ({cfg.approach:g} m before it)")
    for name, point in (("pick", pick.position + up), ("place", place.position + rise)):
        check_workspace(
            point, f"{name} + the vertical approach {point[2] - pick.position[2]:.2f} m"
        )
    dist = float(np.linalg.norm(place.position[:2] - pick.position[:2]))
    if np.linalg.norm(place.position - pick.position) < MIN_PICK_PLACE:
        raise InvalidInput(
            f"place {np.round(place.position, 4).tolist()} m is "
            f"{np.linalg.norm(place.position - pick.position):.3f} m from the pick: it must "
            f"be at least {MIN_PICK_PLACE} m away (a place equal to the pick moves nothing)"
        )
    obj_half = cfg.object_half_width
    supports = [
        s for s in (
            _support("pick", pick.position, cfg, obj_half),
            _support("place", place.position, cfg, obj_half),
        ) if s is not None
    ]  # fmt: skip
    T_total = cfg.duration if cfg.duration is not None else t1 - t0
    from dexlfd.plan.planner import check_plan_size

    check_plan_size(T_total, cfg.rate_hz)
    bounds = [(t0, t_g), (t_g, t_r), (t_r, t1)]
    starts = [
        None if cfg.start is None else np.asarray(cfg.start),
        pick.position + up,
        place.position + rise,
    ]
    start_qs = [None if cfg.start_quat is None else np.asarray(cfg.start_quat),
                pick.quaternion, place.quaternion]  # fmt: skip
    ends = [
        (pre_grasp, pick.quaternion),
        (place.position + up, place.quaternion),
        (None if cfg.goal is None else np.asarray(cfg.goal),
         None if cfg.goal_quat is None else np.asarray(cfg.goal_quat)),
    ]  # fmt: skip
    parts: list[Plan] = []
    scales: list[float] = []
    # the retreat passes the object it just set down: its hull with the open fingers
    # around it is an obstacle of that part (the learned retreat sweeps sideways and down)
    placed = _placed_hull(place.position, cfg)
    for i, ((a, b), (p_end, q_end)) in enumerate(zip(bounds, ends, strict=True)):
        sub = _slice(model, a, b)
        p_start, q_start = starts[i], start_qs[i]
        part_cfg = dataclasses.replace(
            cfg, start=None if p_start is None else tuple(p_start),
            goal=None if p_end is None else tuple(p_end),
            start_quat=None if q_start is None else tuple(q_start),
            goal_quat=None if q_end is None else tuple(q_end),
            start_velocity=cfg.start_velocity if i == 0 else "zero",
            place_surface_z=None, task="motion", pick=None, place=None,
            obstacles=(*cfg.obstacles, placed) if i == 2 else cfg.obstacles,
        )  # fmt: skip
        part, scale = _plan_part(sub, part_cfg, PART_NAMES[i], T_total * (b - a) / (t1 - t0))
        parts.append(part)
        scales.append(scale)
    plan = _assemble(model, cfg, parts, scales, pick, place, (t_g, t_r), approach_dir)
    plan.meta["approach"]["demonstrated_direction"] = demo_dir.tolist()
    plan.meta["approach"]["demonstrated_from_vertical_deg"] = float(
        np.degrees(np.arccos(np.clip(-demo_dir[2], -1.0, 1.0)))
    )
    world = {**obstacle_arrays(cfg.obstacles), **support_arrays(supports)}
    plan = dataclasses.replace(plan, **world)
    logger.info(
        "plan: pick-and-place over %.2f s: reach %.2f s, carry %.2f s (%.3f m), retreat "
        "%.2f s%s", plan.t[-1], parts[0].t[-1], parts[1].t[-1], dist, parts[2].t[-1],
        "" if max(scales) <= 1.0 else
        " (slowed " + ", ".join(f"{n} {s:.2f}x" for n, s in zip(PART_NAMES, scales,
                                                                 strict=True) if s > 1) + ")",
    )  # fmt: skip
    return plan


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


def _assemble(
    model: LearnedModel,
    cfg: PlanConfig,
    parts: list[Plan],
    scales: list[float],
    pick: _Pose,
    place: _Pose,
    events: tuple[float, float],
    approach_dir: FloatArray,
) -> Plan:
    """Join reach, approach, hold, lift, carry, lower, hold, rise, retreat; schedule, meta."""
    n_hold = max(2, int(round(cfg.hold * cfg.rate_hz)))
    open_level, closed_level = _levels(model, *events)
    track = _Track({}, [], [], {})
    seams: dict[str, int] = {}

    def part(i: int) -> None:
        p = parts[i]
        body = {c: np.asarray(getattr(p, c)) for c in _CHANNELS}
        extras = {k: p.extras[k] for k in _EXTRAS if k in p.extras}
        if i > 0:  # the join sample is the previous segment's last one
            body = {c: v[1:] for c, v in body.items()}
            extras = {k: v[1:] for k, v in extras.items()}
        n = body["position"].shape[0]
        level = closed_level if i == 1 else open_level
        track.add(body, np.full(n, i == 1), np.full(n, level), extras)

    def hold_and_switch(name: str, held_before: bool) -> None:
        p, q = track.last()
        levels = (open_level, closed_level) if not held_before else (closed_level, open_level)
        track.add(_hold_at(p, q, n_hold), np.full(n_hold, held_before), np.full(n_hold, levels[0]))
        seams[name] = sum(len(g) for g in track.grasp)
        track.add(_hold_at(p, q, n_hold), np.full(n_hold, not held_before),
                  _ramp(n_hold, *levels))  # fmt: skip

    def straight(delta: FloatArray, held: bool, speed: float) -> None:
        p, q = track.last()
        v = _straight(p, q, delta, cfg.rate_hz, speed)
        n = v["position"].shape[0]
        track.add(v, np.full(n, held), np.full(n, closed_level if held else open_level))

    up = np.array([0.0, 0.0, 1.0])
    part(0)
    p_pre, q_pre = track.last()  # settle at the pre-grasp pose, then approach
    track.add(_hold_at(p_pre, q_pre, n_hold), np.zeros(n_hold, bool), np.full(n_hold, open_level))
    straight(cfg.approach * approach_dir, held=False, speed=_LOWER_SPEED)
    hold_and_switch("pick", held_before=False)
    straight(cfg.approach * up, held=True, speed=_RISE_SPEED)
    part(1)
    straight(-cfg.approach * up, held=True, speed=_LOWER_SPEED)
    hold_and_switch("place", held_before=True)
    straight(_vertical_rise(cfg) * up, held=False, speed=_RISE_SPEED)
    part(2)
    arrays = {c: np.concatenate(track.chunks[c], axis=0) for c in _CHANNELS}
    n = arrays["position"].shape[0]
    t = np.arange(n) / cfg.rate_hz
    closed = np.concatenate(track.grasp)
    arrays["quaternion"] = quat_sign_continuous(arrays["quaternion"])
    k_pick, k_place = seams["pick"], seams["place"]
    pose_err = {
        "pick_position_error_m": float(np.linalg.norm(arrays["position"][k_pick] - pick.position)),
        "place_position_error_m": float(
            np.linalg.norm(arrays["position"][k_place] - place.position)
        ),
        "pick_angle_error_deg": float(np.degrees(_angle(arrays["quaternion"][k_pick],
                                                        pick.quaternion))),
        "place_angle_error_deg": float(np.degrees(_angle(arrays["quaternion"][k_place],
                                                         place.quaternion))),
    }  # fmt: skip
    meta = dict(parts[0].meta)
    meta.update(
        task="pick-and-place",
        start=arrays["position"][0].tolist(),
        goal=arrays["position"][-1].tolist(),
        duration=float(t[-1]),
        pick={"position": pick.position.tolist(), "quaternion": pick.quaternion.tolist(),
              "yaw_deg": float(np.degrees(heading(pick.quaternion))),
              "given": cfg.pick is not None, "t": float(t[k_pick])},
        place={"position": place.position.tolist(), "quaternion": place.quaternion.tolist(),
               "yaw_deg": float(np.degrees(heading(place.quaternion))),
               "given": cfg.place is not None, "t": float(t[k_place])},
        event_errors=pose_err,
        model_events={"t": [float(v) for v in events],
                      "t_std": np.asarray(model.event_t_std).tolist()},
        approach={"direction": approach_dir.tolist(),
                  "from_vertical_deg": float(np.degrees(np.arccos(np.clip(-approach_dir[2],
                                                                          -1, 1)))),
                  "length_m": cfg.approach},
        vertical={"lift_lower_m": cfg.approach, "rise_m": _vertical_rise(cfg),
                  "peak_speed_m_s": _RISE_SPEED, "lowering_peak_speed_m_s": _LOWER_SPEED},
        parts=[{"name": nm, "duration": float(p.t[-1]), "time_scale": s,
                "goal_error": p.meta.get("goal_error"), "obstacles": p.meta.get("obstacles"),
                "limits": p.meta.get("limits")}
               for nm, p, s in zip(PART_NAMES, parts, scales, strict=True)],
        time_scaling={"needed": max(scales) > 1.0, "largest": max(scales),
                      "per_part": dict(zip(PART_NAMES, scales, strict=True))},
        grasp={"method": "model events", "closed_level": closed_level,
               "open_level": open_level, "hold_s": cfg.hold,
               "intervals_s": grasp_intervals(t, closed)},
        obstacles=[r for p in parts for r in (p.meta.get("obstacles") or [])],
    )  # fmt: skip
    return Plan(
        t=t, **arrays, gripper=np.concatenate(track.grip), grasp=closed,
        pick_pose=np.concatenate([pick.position, pick.quaternion]),
        place_pose=np.concatenate([place.position, place.quaternion]),
        meta=meta,
        extras={k: np.concatenate(v, axis=0) for k, v in track.extras.items()},
    )  # fmt: skip


def _angle(q_a: FloatArray, q_b: FloatArray) -> float:
    d = abs(float(np.dot(q_a, q_b))) / float(np.linalg.norm(q_a) * np.linalg.norm(q_b))
    return 2.0 * float(np.arccos(min(1.0, d)))
