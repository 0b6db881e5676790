"""Pick it up where it is now, put it where it should go: a plan cut at the grasp events.

A model that carries the demonstrations' grasp and release (``LearnedModel.event_*``,
:mod:`dexlfd.learn.events`) is planned as a task, not as one motion. The learned
motion is cut at the event times into three parts, **reach** (start -> pick),
**carry** (pick -> place) and **retreat** (place -> end); each part is a DMP of its
stretch of the model (:func:`dexlfd.plan.planner.plan_motion`: the same position and
orientation DMPs, obstacles and variance term as a whole-motion plan) reaching its
own new end with the learned shape. The modified DMP (Eq. 5.5) keeps the shape in
absolute terms, so the last centimetres before the pick come from the demonstrated
direction wherever the pick is. Each part ends at rest at its end pose (the end
shaping of :mod:`dexlfd.plan.end_shaping`) and the next starts from there at rest:
the joins are continuous in position and velocity (zero).

The robot moves from its own pose: the reach starts at the TCP of the Panda's ready
pose (``PlanConfig.start``: a given position, or ``"demonstrated"`` for the person's
start); the person's start and end only shape the motion. The retreat ends at the
demonstrated end expressed relative to the place when the arm can end there clear
of every obstacle, else at the ready pose (:func:`dexlfd.plan.task_poses.retreat_end`;
the plan's meta entry ``retreat_end`` says which and why); a learned retreat the coupling cannot
keep clear falls back to the ready pose too. Nothing is refused for where the
person's hand started or ended.

The pick and place orientation is a top-down grasp with the demonstrated heading by
default (:mod:`dexlfd.plan.task_poses`). At the pick the arm holds still for
``2 hold`` seconds: the controller settles onto the pick pose for ``hold``, then the
gripper closes (the grasp schedule switches) and has ``hold`` to close before the
carry lifts; the same at the place, where it opens, and the open hand rises
straight up above the placed object (an obstacle of its own size for the retreat)
before the learned retreat (:mod:`dexlfd.plan.task_assemble`).

Timing: the carry (and a reach or retreat between the person's own start or end)
lasts as long as the person's stretch did; the reach from the robot's start and the
retreat to the ready pose are the robot's own moves, timed by its speed and limits
(:mod:`dexlfd.plan.part_timing`; ``meta["part_timing"]`` says which part was timed
by whom). Time scaling: each part whose Cartesian velocity or acceleration peaks exceed the
Panda's limits is retimed slower by the factor that fits (velocity scales with
1/T, acceleration with 1/T²; the path in normalised time is unchanged);
``Plan.time_scaling.slowdowns`` lists each with its interval and the
duration it added (the joint-space ones follow, :mod:`dexlfd.plan.pipeline`).
"""

from __future__ import annotations

import dataclasses
import logging
import re

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, signed_distance
from dexlfd.io import LearnedModel, Plan
from dexlfd.io._world import obstacle_arrays, support_arrays
from dexlfd.panda import check_workspace
from dexlfd.plan.config import PlanConfig
from dexlfd.plan.envelope import (
    envelope_clearance,
)
from dexlfd.plan.part_obstacles import grown, part_obstacles, supports_of
from dexlfd.plan.part_timing import (
    part_timing_info,
    robot_factor,
    scale_needed,
    speed_cap,
)
from dexlfd.plan.planner import check_plan_size, plan_motion
from dexlfd.plan.reach import check_top_down
from dexlfd.plan.task_assemble import PART_NAMES, Parts, assemble, levels, log_summary
from dexlfd.plan.task_poses import (
    Pose,
    check_hand_clear,
    check_point,
    event_pose,
    heading,
    heading_turn,
    object_size,
    placed_object,
    pose_dict,
    ready_pose,
    retreat_end,
    rise_height,
    start_pose,
    top_down,
)
from dexlfd.plan.timing import retime
from dexlfd.trajectory import minimum_jerk

__all__ = ["MIN_PICK_PLACE", "plan_task"]

logger = logging.getLogger(__name__)

MIN_PICK_PLACE = 0.05  # [m] a place nearer the pick than this is no transport
TOP_GRASP_DEG = 45.0  # [deg] a demonstrated approach this near straight down is from above
# [m] after the release the open hand rises clear of the placed object, and the
# retreat keeps above that (a person's hand that sank to the table beside the drop is
# not followed), starting and ending this far over it: a dip next to an end is ramped
RETREAT_ROOM = 0.02
_MAX_RETIME = 4  # replanning rounds per part (each one fits the measured peaks)


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


def _plan_part(
    sub: LearnedModel, cfg: PlanConfig, name: str, T: float, labels: tuple[str, str],
    robot_timed: bool = False,
) -> tuple[Plan, float, str]:  # fmt: skip
    """One part, timed by the person (``T`` [s]) or by the robot, slowed to the limits.

    Returns the part, its slow-down factor and what set it (``"cartesian"`` or
    ``"demonstrated speed"``, :func:`~dexlfd.plan.part_timing.scale_needed`).
    ``robot_timed``: a part the person never made (the reach from the ready pose, the
    retreat to it) takes the robot's own duration
    (:func:`~dexlfd.plan.part_timing.robot_factor`), not ``T`` slowed to a speed cap;
    that duration is no slow-down.

    The DMPs, the coupling and the end shaping run in normalised time, so a slower
    part is the same path retimed (:func:`dexlfd.plan.timing.retime` over the whole
    part): velocity / f, acceleration / f²; no second plan (and no second linear
    programme for its obstacles). A robot-timed part is planned twice (the second
    time at its own duration, which may be shorter than ``T``).
    """
    part = _motion(sub, cfg, name, T, labels)
    cap = None
    if robot_timed:
        factor = robot_factor(part)
        if abs(factor - 1.0) > 1e-3:
            part = _motion(sub, cfg, name, T * factor, labels)
    else:
        cap = speed_cap(sub, T)
    scale, why = 1.0, "cartesian"
    for _ in range(_MAX_RETIME):
        need, which = scale_needed(part, cap)
        if need <= 1.0 + 1e-6:
            return part, scale, why
        part = retime(part, [(0, part.n_samples - 1)], [need * 1.01])
        why = which if scale == 1.0 else why  # the first (largest) slow-down's reason
        scale *= need * 1.01
    logger.warning("%s: still beyond the Cartesian limits after %.2fx slower", name, scale)
    return part, scale, why


def _motion(
    sub: LearnedModel, cfg: PlanConfig, name: str, T: float, labels: tuple[str, str]
) -> Plan:
    """The part's motion over ``T`` [s] (top-down held upright), its errors named by ``labels``.

    An error names the part and its ends by ``labels`` (start, end): a start or goal
    the user never gave is not called "start" or "goal".
    """
    try:
        part = plan_motion(sub, dataclasses.replace(cfg, duration=T), quiet_limits=True)
    except InvalidInput as exc:
        msg = re.sub(
            r"\b(the )?start\b", labels[0], re.sub(r"\b(the )?goal\b", labels[1], str(exc))
        )
        raise InvalidInput(f"the {name} from {labels[0]} to {labels[1]}: {msg}") from None
    if cfg.grasp_orientation == "top-down" and cfg.start_quat and cfg.goal_quat:
        part = _upright(part, np.asarray(cfg.start_quat), np.asarray(cfg.goal_quat))
    return part


def _upright(part: Plan, q_a: FloatArray, q_b: FloatArray) -> Plan:
    """The part held top-down all along, its heading turning from ``q_a``'s to ``q_b``'s.

    With a top-down grasp the orientation the person's hand took between the pick and
    the place means nothing to a parallel gripper: an RGB-tracked palm swings by tens
    of degrees (seen on real takes: the learned carry tilted the TCP until the Panda
    could not follow it, the inverse kinematics missing by 2-4 deg), and a held object
    should stay upright. So the part keeps the gripper pointing straight down, and only
    its heading about the base z axis moves, along a minimum-jerk profile over the
    part (at rest at both ends, as every part starts and ends at rest).
    """
    t = np.asarray(part.t, dtype=np.float64)
    T = float(t[-1] - t[0])
    yaw_a, dyaw = heading_turn(q_a, q_b)  # the short way round
    s, ds, _ = minimum_jerk((t - t[0]) / T)
    q = top_down(yaw_a + dyaw * s)
    # sign-continuous: each sample flipped when it points away from its (flipped)
    # predecessor; a flip only negates the products, so the parity of the raw
    # neighbours' sign changes says which samples end up flipped
    away = np.einsum("ij,ij->i", q[1:], q[:-1]) < 0
    flip = np.concatenate([[False], np.cumsum(away) % 2 == 1])
    q[flip] = -q[flip]
    omega = np.zeros((t.shape[0], 3))
    omega[:, 2] = dyaw * ds / T
    return dataclasses.replace(part, quaternion=q, angular_velocity=omega)


def _approach_direction(
    model: LearnedModel, t_g: float, length: float, yaw: float | None
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


def _check_task(cfg: PlanConfig, pick: Pose, place: Pose, approach_dir: FloatArray) -> None:
    """Pick and place within reach, clear, apart; the vertical moves within reach."""
    for name, pose in (("pick", pick), ("place", place)):
        check_point(name, pose.position, cfg)
        if cfg.grasp_orientation == "top-down":
            check_top_down(name, pose.position, cfg.approach)
    pre_grasp = pick.position - cfg.approach * approach_dir
    check_workspace(
        pre_grasp, f"the approach to the pick ({cfg.approach:g} m before it)", param="pick"
    )
    point = pick.position + [0.0, 0.0, cfg.approach]
    check_workspace(point, f"pick + the vertical approach {cfg.approach:.2f} m", param="pick")
    if np.linalg.norm(place.position - pick.position) < MIN_PICK_PLACE:
        raise InvalidInput(
            f"place {np.round(place.position, 4).tolist()} m is "
            f"{np.linalg.norm(place.position - pick.position):.3f} m from the pick: it must "
            f"be at least {MIN_PICK_PLACE} m away (a place equal to the pick moves nothing)",
            param="place",
        )


def _start(model: LearnedModel, cfg: PlanConfig) -> tuple[Pose, str]:
    """The reach's start pose and where it came from (the ready pose by default).

    A given start position without ``start_quat`` has the ready pose's orientation
    (the robot's, not the person's hand's).
    """
    start = "ready" if cfg.start is None else cfg.start
    q_default = model.mean[0, 3:7] / np.linalg.norm(model.mean[0, 3:7])
    if start != "demonstrated":
        q_default = ready_pose().quaternion
    p, q = start_pose(dataclasses.replace(cfg, start=start), model.mean[0, :3], q_default)
    source = start if isinstance(start, str) else "given start"
    return Pose(p, q), {"ready": "ready pose", "demonstrated": "demonstrated start"}.get(
        source, source
    )


def _part_cfg(
    cfg: PlanConfig, i: int, a: Pose, b: Pose, obstacles: tuple, floor: float
) -> PlanConfig:
    """Part ``i``'s settings: from ``a`` to ``b`` past ``obstacles``, above ``floor``, from rest.

    Every part starts at rest, the reach too (the robot stands at its start), unless
    it starts where the person started (``start="demonstrated"``, the old plans).
    ``floor`` [m] is the lowest TCP height (:attr:`PlanConfig.z_floor`): a learned
    motion that dips lower between its ends is lifted there, not refused. The carry
    (``i == 1``) descends once onto the point above the place
    (:attr:`PlanConfig.descend_to_goal`): a learned descent that overshoots it and
    climbs back would set the object down, lift it and set it down again.
    """
    moving = i == 0 and cfg.start == "demonstrated"
    return dataclasses.replace(
        cfg, z_floor=floor, top_down_reach=cfg.grasp_orientation == "top-down",
        descend_to_goal=i == 1,
        start=tuple(a.position), goal=tuple(b.position),
        start_quat=tuple(a.quaternion), goal_quat=tuple(b.quaternion),
        start_velocity=cfg.start_velocity if moving else "zero",
        place_surface_z=None, task="motion", pick=None, place=None, obstacles=obstacles,
    )  # fmt: skip


def _floor(i: int, floor: float, rise_z: float, end: Pose) -> float:
    """Part ``i``'s lowest TCP height [m]: the retreat's ``rise_z`` (or a lower goal's)."""
    if i < 2:
        return floor
    return max(floor, min(rise_z, float(end.position[2])))


def plan_task(model: LearnedModel, cfg: PlanConfig) -> Plan:
    """Plan reach, carry and retreat through the pick and place poses (module docstring).

    Raises
    ------
    InvalidInput
        A pick or place out of reach, under the table, inside an obstacle, or a place
        too near the pick; a given start or goal out of reach or inside an obstacle; a
        model without grasp events (plan it as one motion: ``task="motion"``).
    """
    if not model.has_events or model.event_t is None:
        raise InvalidInput(
            "a pick-and-place needs a model with grasp events (where the hand closed and "
            "opened); this model has none: plan it as one motion (PlanConfig task='motion')"
        )
    t_g, t_r = (float(v) for v in model.event_t)
    t0, t1 = float(model.t[0]), float(model.t[-1])
    pick, place = event_pose(model, 0, cfg), event_pose(model, 1, cfg)
    approach_dir, demo_dir = _approach_direction(model, t_g, cfg.approach, cfg.pick_yaw)
    if cfg.grasp_orientation == "top-down":  # a top-down grasp is approached from above
        approach_dir = np.array([0.0, 0.0, -1.0])
    _check_task(cfg, pick, place, approach_dir)
    size = object_size(model, cfg, levels(model, t_g, t_r)[1])
    for name, pose in (("pick", pick), ("place", place)):
        check_hand_clear(name, pose, size, cfg)
    supports, place_support = supports_of(pick, place, cfg)
    T_total = cfg.duration if cfg.duration is not None else t1 - t0
    check_plan_size(T_total, cfg.rate_hz)
    placed = placed_object(place, size, cfg.object_bottom)
    rise = rise_height(place, placed, cfg) + RETREAT_ROOM  # the retreat stays above rise_z
    check_workspace(
        place.position + [0.0, 0.0, rise], f"place + the vertical rise {rise:.2f} m", param="place"
    )
    start, start_source = _start(model, cfg)
    retreat_obstacles = (*cfg.obstacles, placed)
    rise_z = float(place.position[2]) + rise - RETREAT_ROOM
    end, end_source, why = retreat_end(model, cfg, place, retreat_obstacles, rise_z + RETREAT_ROOM)
    # each part keeps the hand (and, carried, the object) clear: the obstacles grown by
    # the room they take around the TCP over the part's orientations
    carried = (None, size, None)
    # no part takes the TCP lower than the lower of the pick and the place: the held
    # object's bottom stays above the surfaces it leaves and meets, the hand above the
    # table (a demonstrated carry that sagged is lifted, :mod:`dexlfd.plan.floor`)
    floor = float(min(pick.position[2], place.position[2]))
    up = np.array([0.0, 0.0, cfg.approach])
    bounds = [(t0, t_g), (t_g, t_r), (t_r, t1)]
    poses = [(start, Pose(pick.position - cfg.approach * approach_dir, pick.quaternion)),
             (Pose(pick.position + up, pick.quaternion), Pose(place.position + up,
                                                               place.quaternion)),
             (Pose(place.position + [0.0, 0.0, rise], place.quaternion), end)]  # fmt: skip
    labels = _labels(start_source, end_source)
    plans, scales, whys, timed_by = [], [], [], []
    for i, ((a, b), (p_a, p_b)) in enumerate(zip(bounds, poses, strict=True)):
        T = T_total * (b - a) / (t1 - t0)
        a_q, b_q = (start, pick, place)[i].quaternion, (pick, place, end)[i].quaternion
        obstacles = part_obstacles(i, (a_q, b_q), carried[i], placed, place_support, cfg)
        # the reach from the robot's own start and the retreat to anywhere but the
        # person's end are the robot's moves: timed by the robot, not by the person
        robot = (i == 0 and start_source != "demonstrated start") or (
            i == 2 and end_source != "demonstrated end"
        )
        try:
            part, scale, limit = _plan_part(
                _slice(model, a, b), _part_cfg(cfg, i, p_a, p_b, obstacles,
                                                _floor(i, floor, rise_z, p_b)),
                PART_NAMES[i], T, labels[i], robot_timed=robot,
            )  # fmt: skip
        except InvalidInput as exc:
            if i != 2 or end_source != "demonstrated end":
                raise
            why, end, end_source = f"the learned retreat to it: {exc}", ready_pose(), "ready pose"
            obstacles = grown(cfg.obstacles, place.quaternion, end.quaternion, None, cfg, placed)
            robot = True
            part, scale, limit = _plan_part(
                _slice(model, a, b), _part_cfg(cfg, i, p_a, end, obstacles,
                                                _floor(i, floor, rise_z, end)),
                PART_NAMES[i], T, (labels[2][0], "the ready pose"), robot_timed=True,
            )  # fmt: skip
        plans.append(part)
        scales.append(scale)
        whys.append(limit)
        timed_by.append("robot" if robot else "person")
    if why is not None:
        logger.info("the retreat ends at the ready pose, not at %s", why)
    info = {
        "start_pose": pose_dict(start, source=start_source),
        "retreat_end": pose_dict(end, source=end_source, why_not_demonstrated=why),
        "object": {"size_m": size.tolist(), "given": cfg.object_size is not None,
                   "placed_box": placed.to_dict(), "bottom_below_tcp_m": cfg.object_bottom},
        "part_timing": part_timing_info(plans, scales, timed_by),
    }  # fmt: skip
    plan = assemble(model, cfg, Parts(plans, scales, pick, place, (t_g, t_r), approach_dir,
                                      rise, info, tuple(whys)))  # fmt: skip
    plan = _with_scene(plan, cfg, demo_dir, supports, size)
    dist = float(np.linalg.norm(place.position[:2] - pick.position[:2]))
    log_summary(plan, plans, timed_by, (start_source, end_source), dist)
    return plan


def _labels(start_source: str, end_source: str) -> list[tuple[str, str]]:
    """What each part starts and ends at, for the messages of a part that cannot be planned."""
    start_label = {"given start": "start"}.get(start_source, f"the {start_source}")
    return [(start_label, "the approach point before the pick"),
            ("the lift point above the pick", "the point above the place"),
            ("the rise point above the placed object",
             "goal" if end_source == "given goal" else f"the {end_source} (give a goal "
             "to end elsewhere)")]  # fmt: skip


def _with_scene(
    plan: Plan, cfg: PlanConfig, demo_dir: FloatArray, supports: list[Box], size: FloatArray
) -> Plan:
    """``plan`` with the demonstrated approach, the obstacles, supports and hand clearance."""
    assert plan.approach is not None  # assemble's
    approach = dataclasses.replace(
        plan.approach, demonstrated_direction=tuple(demo_dir.tolist()),
        demonstrated_from_vertical_deg=float(
            np.degrees(np.arccos(np.clip(-demo_dir[2], -1.0, 1.0)))),
    )  # fmt: skip
    plan = dataclasses.replace(
        plan, approach=approach, **obstacle_arrays(cfg.obstacles), **support_arrays(supports)
    )
    return _hand_clearance(plan, cfg, size)


def _hand_clearance(plan: Plan, cfg: PlanConfig, size: FloatArray) -> Plan:
    """The plan's clearance is the hand's and the held object's (module :mod:`.envelope`).

    ``extras["clearance"]`` (n,) [m] from the nearest obstacle, the meta entry ``clearance``
    the minimum per obstacle (and the TCP's, for comparison), each obstacle record's
    ``min_clearance``. A plan whose hand or object would overlap an obstacle anywhere
    (the vertical moves and holds included) is refused.
    """
    if not cfg.obstacles:
        return plan
    assert plan.grasp is not None
    per = envelope_clearance(cfg.obstacles, plan.position, plan.quaternion, plan.grasp,
                             size, cfg.object_bottom)  # fmt: skip
    tcp = np.stack([signed_distance(ob, plan.position) for ob in cfg.obstacles])
    worst = int(np.argmin(per.min(axis=1)))
    k = int(np.argmin(per[worst]))
    if per[worst, k] < 0 and cfg.enforce_clearance:
        what = "the held object or the hand" if plan.grasp[k] else "the hand"
        raise InvalidInput(
            f"{what} would touch obstacle {worst} ({cfg.obstacles[worst].spec()}) at "
            f"t={plan.t[k]:.2f} s (TCP {np.round(plan.position[k], 3).tolist()} m, overlap "
            f"{-1e3 * per[worst, k]:.0f} mm): move the pick, the place or the obstacle"
        )
    info = {"of": "the hand (fingers, body, flange link) in cells and the held object, as boxes",
            "min_m": float(per.min()), "per_obstacle_min_m": per.min(axis=1).tolist(),
            "tcp_per_obstacle_min_m": tcp.min(axis=1).tolist()}  # fmt: skip
    logger.info(
        "clearance of the hand and the held object: %.1f mm (the TCP's: %.1f mm)",
        1e3 * info["min_m"], 1e3 * float(tcp.min()),
    )  # fmt: skip
    if info["min_m"] < cfg.margin - 1e-6:
        logger.warning(
            "the hand or the held object passes %.3f m from obstacle %d, less than the "
            "margin %g m", info["min_m"], worst, cfg.margin,
        )  # fmt: skip
    extras = {**plan.extras, "clearance": per.min(axis=0)}
    return dataclasses.replace(plan, extras=extras, meta={**plan.meta, "clearance": info})
