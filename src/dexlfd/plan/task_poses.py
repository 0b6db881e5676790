"""Where a pick-and-place plan goes: the robot's own start, the grasp poses, the placed object.

The robot starts where it stands: its ready pose (:data:`dexlfd.panda.Q_READY`, the
TCP :func:`ready_pose`), not where the person's hand started. The pick and place
orientation is by default a **top-down grasp** (the TCP's z axis straight down, the
fingers closing horizontally, the Franka Hand's natural grasp of an object standing
on a surface) turned to the demonstrated heading about the base z axis
(:func:`heading`); ``grasp_orientation="demonstrated"`` keeps the person's hand
orientation (its tilt included). A grasp tilted by an angle sets the object down
tilted by the same angle if it slides in the fingers on the way (seen in simulation:
21-41 deg from a person's 20-30 deg tilted hand), so top-down is the default.

The placed object is a box of its own size (``PlanConfig.object_size``, default from
the learned grasp aperture: width = depth = the closed gripper level, height twice
``object_bottom``): the retreat keeps clear of it (:func:`placed_object`). The
retreat ends, unless a goal is given, where the person's hand ended relative to the
place (turned with the place's heading) when the arm can reach that pose clear of
every obstacle, else at the ready pose (:func:`retreat_end`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box, half_extents, signed_distance
from dexlfd.io import LearnedModel
from dexlfd.panda import GRIPPER_OPENING_MAX, Q_READY, TABLE_Z, check_workspace
from dexlfd.plan.config import PlanConfig
from dexlfd.rotations import matrix_from_quat, quat_from_matrix, quat_multiply

__all__ = [
    "Pose",
    "event_pose",
    "heading",
    "heading_turn",
    "placed_object",
    "ready_pose",
    "retreat_end",
    "start_pose",
    "with_heading",
]

SUPPORT_HALF_WIDTH = 0.05  # [m] half footprint of a support, at most
SUPPORT_GAP = 0.005  # [m] a support keeps at least this far from every obstacle
RISE_CLEARANCE = 0.03  # [m] the open hand rises this far above the placed object's top
TOP_DOWN = np.diag([1.0, -1.0, -1.0])  # TCP z straight down, x along the base x axis


@dataclass(frozen=True, slots=True)
class Pose:
    """A TCP pose: position (3,) [m] and unit quaternion (x, y, z, w)."""

    position: FloatArray
    quaternion: FloatArray


def heading(q: FloatArray) -> float:
    """The TCP's heading about the base z axis [rad] (ZYX Euler yaw) of quaternion ``q``."""
    R = matrix_from_quat(np.asarray(q, dtype=np.float64))
    return float(np.arctan2(R[1, 0], R[0, 0]))


def heading_turn(q_a: FloatArray, q_b: FloatArray) -> tuple[float, float]:
    """The heading [rad] of ``q_a`` and the turn [rad] to ``q_b``'s, the short way round."""
    yaw_a, yaw_b = heading(q_a), heading(q_b)
    return yaw_a, float(np.angle(np.exp(1j * (yaw_b - yaw_a))))


def with_heading(q: FloatArray, yaw: float) -> FloatArray:
    """``q`` turned about the base z axis so that its :func:`heading` is ``yaw`` [rad]."""
    dyaw = yaw - heading(q)
    rz = np.array([0.0, 0.0, np.sin(dyaw / 2), np.cos(dyaw / 2)])
    out = quat_multiply(rz, np.asarray(q, dtype=np.float64))
    return np.asarray(out / np.linalg.norm(out), dtype=np.float64)


def top_down(yaw: float | FloatArray) -> FloatArray:
    """The top-down grasp orientation (TCP z straight down) with heading ``yaw`` [rad].

    ``yaw`` a number: one quaternion (4,); an array (n,): one per heading (n, 4), the
    same values as one at a time (``TOP_DOWN``'s entries are 0 and 1 in magnitude, so
    the product with it is exact however it is summed).
    """
    yaws = np.asarray(yaw, dtype=np.float64)
    c, s = np.cos(yaws), np.sin(yaws)
    Rz = np.zeros((*yaws.shape, 3, 3))
    Rz[..., 0, 0], Rz[..., 0, 1], Rz[..., 1, 0], Rz[..., 1, 1] = c, -s, s, c
    Rz[..., 2, 2] = 1.0
    return np.asarray(quat_from_matrix(Rz @ TOP_DOWN), dtype=np.float64)


def tilt_deg(q: FloatArray) -> float:
    """Angle [deg] between the TCP's z axis and straight down."""
    R = matrix_from_quat(np.asarray(q, dtype=np.float64))
    return float(np.degrees(np.arccos(np.clip(-R[2, 2], -1.0, 1.0))))


def ready_pose() -> Pose:
    """The TCP pose at the Panda's ready joints :data:`~dexlfd.panda.Q_READY` (by FK)."""
    from dexlfd.panda_kinematics import dh_tcp

    T = dh_tcp(Q_READY)
    return Pose(np.asarray(T[:3, 3], dtype=np.float64), np.asarray(quat_from_matrix(T[:3, :3])))


def start_pose(
    cfg: PlanConfig, p_model: FloatArray, q_model: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The plan's start position [m] and orientation from ``cfg.start``/``start_quat``.

    A position given; ``"ready"``: the TCP at the Panda's ready pose; None or
    ``"demonstrated"``: the model's (``p_model``, ``q_model``). The orientation is
    ``start_quat`` when given, else the ready pose's for ``"ready"`` and the model's
    otherwise.
    """
    if cfg.start == "ready":
        ready = ready_pose()
        p, q = ready.position, ready.quaternion
    elif cfg.start is None or isinstance(cfg.start, str):
        p, q = np.array(p_model, dtype=np.float64), np.asarray(q_model, dtype=np.float64)
    else:
        p, q = np.asarray(cfg.start, dtype=np.float64), np.asarray(q_model, dtype=np.float64)
    if cfg.start_quat is not None:
        q = np.asarray(cfg.start_quat, dtype=np.float64)
    return p, q


def _half_turns(model: LearnedModel) -> int:
    """Half turns to take off the demonstrated headings for a top-down grasp.

    A parallel gripper grasps the same at heading ψ and ψ ± 180 deg, but the Panda's
    last joint does not turn that far either way: a person's heading of 170 deg asks
    for a top-down TCP the arm cannot reach within its limits (seen on real takes,
    the inverse kinematics missing by 3-4 deg). The pick's demonstrated heading is
    folded into [-90, 90] deg of the ready pose's (0), and the place's turned by the
    same half turns, so the object still turns as the person turned it.
    """
    assert model.event_quaternion is not None
    return int(np.round(heading(np.asarray(model.event_quaternion[0])) / np.pi))


def event_pose(model: LearnedModel, k: int, cfg: PlanConfig) -> Pose:
    """The pick (``k = 0``) or place (``k = 1``) TCP pose.

    The given or demonstrated position (the place's height ``object_bottom`` above
    ``place_surface_z`` when that is set: the object is set down on that surface);
    the top-down or demonstrated orientation (``cfg.grasp_orientation``) with the
    given or the demonstrated heading.
    """
    assert model.event_position is not None and model.event_quaternion is not None
    xyz, yaw = (cfg.pick, cfg.pick_yaw) if k == 0 else (cfg.place, cfg.place_yaw)
    p = np.array(model.event_position[k] if xyz is None else xyz, dtype=np.float64)
    if k == 1 and cfg.place_surface_z is not None:  # set down on that surface
        p[2] = float(cfg.place_surface_z) + cfg.object_bottom
    q_demo = np.asarray(model.event_quaternion[k], dtype=np.float64)
    if cfg.grasp_orientation == "top-down":
        if yaw is None:
            yaw = heading(q_demo) - np.pi * _half_turns(model)
        return Pose(np.array(p, dtype=np.float64), top_down(yaw))
    yaw = heading(q_demo) if yaw is None else yaw
    return Pose(np.array(p, dtype=np.float64), with_heading(q_demo, yaw))


def object_size(model: LearnedModel, cfg: PlanConfig, closed_level: float) -> FloatArray:
    """Width (across the fingers), depth, height [m] of the object carried.

    ``cfg.object_size`` when given; else the learned closed gripper level (the width
    the fingers closed to; depth the same) and twice ``object_bottom`` (the TCP holds
    it at its middle).
    """
    if cfg.object_size is not None:
        return np.asarray(cfg.object_size, dtype=np.float64)
    w = float(np.clip(closed_level, 0.01, GRIPPER_OPENING_MAX))
    return np.array([w, w, max(2.0 * cfg.object_bottom, 0.01)])


def placed_object(place: Pose, size: FloatArray, object_bottom: float) -> Box:
    """The object standing at the place: an axis-aligned box around its true footprint.

    Its bottom is ``object_bottom`` below the place TCP, its footprint (width along
    the TCP's y axis, the fingers' closing direction, and depth) turned with the
    place's heading; the box is that footprint's bounding box.
    """
    yaw = heading(place.quaternion)
    c, s = abs(np.cos(yaw)), abs(np.sin(yaw))
    w, d, h = (float(v) for v in size)
    ex, ey = d * c + w * s, d * s + w * c  # bounding box of the turned footprint
    bottom = float(place.position[2]) - object_bottom
    return Box((float(place.position[0]), float(place.position[1]), bottom + h / 2), (ex, ey, h))


def rise_height(place: Pose, placed: Box, cfg: PlanConfig) -> float:
    """How far the open hand rises straight up after the release [m].

    To :data:`RISE_CLEARANCE` above the placed object's top (at least ``approach``):
    the fingers clear it before the learned retreat moves sideways; a tilted hand's
    lowest edge (:func:`dexlfd.plan.envelope.envelope`) clears it by as much.
    """
    from dexlfd.plan.envelope import envelope

    below = -min(float(lo[2]) for lo, _ in envelope(place.quaternion))  # the hand's, below the TCP
    top = float(placed.center[2] + half_extents(placed)[2])
    return max(cfg.approach, top + RISE_CLEARANCE + below - float(place.position[2]))


def _end_problem(p: FloatArray, q: FloatArray, cfg: PlanConfig, obstacles: tuple) -> str | None:
    """Why the arm cannot end its retreat at ``p``, ``q`` (None: it can)."""
    try:
        check_workspace(p, "end")
    except InvalidInput as exc:
        return str(exc)
    from dexlfd.plan.envelope import envelope, inflate

    for i, ob in enumerate(obstacles):
        d = min(float(signed_distance(inflate(ob, lo, hi), p)[0]) for lo, hi in envelope(q))
        if d < cfg.margin:
            return f"the hand {d:.3f} m from obstacle {i} (margin {cfg.margin:g} m)"
    from dexlfd.plan.feasibility import reachable

    return reachable(p, q)


def retreat_end(
    model: LearnedModel, cfg: PlanConfig, place: Pose, obstacles: tuple, min_z: float = -np.inf
) -> tuple[Pose, str, str | None]:
    """Where the retreat ends, where that came from, and why not the demonstrated end.

    ``obstacles`` are the retreat's (the user's and the placed object). The given
    goal (``PlanConfig.goal``); else the person's end relative to the place, no lower
    than ``min_z`` [m] (the rise point over the placed object: a hand that came to rest
    on the table beside it is no place for the arm to end), when the arm can end there
    clear of every obstacle (``"demonstrated end"``); else the ready pose
    (``"ready pose"``, with the reason).
    """
    if cfg.goal is not None:
        q = place.quaternion if cfg.goal_quat is None else np.asarray(cfg.goal_quat)
        return Pose(np.asarray(cfg.goal, dtype=np.float64), q), "given goal", None
    assert model.event_position is not None and model.event_quaternion is not None
    dyaw = heading(place.quaternion) - heading(model.event_quaternion[1])
    c, s = np.cos(dyaw), np.sin(dyaw)
    off = model.mean[-1, :3] - model.event_position[1]
    p = place.position + np.array([c * off[0] - s * off[1], s * off[0] + c * off[1], off[2]])
    p[2] = max(float(p[2]), float(min_z))
    if cfg.grasp_orientation == "top-down":
        q = place.quaternion
    else:
        q = with_heading(model.mean[-1, 3:7] / np.linalg.norm(model.mean[-1, 3:7]),
                         heading(model.mean[-1, 3:7]) + dyaw)  # fmt: skip
    if cfg.goal_quat is not None:
        q = np.asarray(cfg.goal_quat)
    why = _end_problem(p, q, cfg, obstacles)
    if why is None:
        return Pose(p, q), "demonstrated end", None
    ready = ready_pose()
    return ready, "ready pose", f"the demonstrated end {np.round(p, 3).tolist()} m: {why}"


def check_point(name: str, p: FloatArray, cfg: PlanConfig) -> None:
    """Reach, table and obstacles for a pick or place TCP position (named ``name``)."""
    given = getattr(cfg, name) is not None
    label = name if given else f"the demonstrated {name} (give a {name} within reach)"
    check_workspace(p, label, param=name)
    if p[2] - cfg.object_bottom < TABLE_Z - 1e-3:
        raise InvalidInput(
            f"{label} {np.round(p, 4).tolist()} m puts the object's bottom "
            f"{cfg.object_bottom:g} m below the TCP under the table: z must be >= "
            f"{TABLE_Z + cfg.object_bottom:g} m",
            param=name,
        )
    for i, ob in enumerate(cfg.obstacles):
        if float(signed_distance(ob, p)[0]) < 0:
            raise InvalidInput(
                f"{label} {np.round(p, 4).tolist()} m is inside obstacle {i} "
                f"({ob.spec()}); move the {name} or the obstacle",
                param=name,
            )


def check_hand_clear(name: str, pose: Pose, size: FloatArray, cfg: PlanConfig) -> None:
    """The hand and the object at the pick or place pose (and ``approach`` above) clear.

    Raises
    ------
    InvalidInput
        The hand (fingers, body, flange link) or the object overlaps an obstacle there.
    """
    from dexlfd.plan.envelope import envelope_clearance

    if not cfg.obstacles:
        return
    p = np.stack([pose.position, pose.position + [0.0, 0.0, cfg.approach]])
    q = np.tile(pose.quaternion, (2, 1))
    per = envelope_clearance(cfg.obstacles, p, q, np.ones(2, bool), size, cfg.object_bottom)
    i = int(np.argmin(per.min(axis=1)))
    if per[i].min() < 0:
        label = name if getattr(cfg, name) is not None else f"the demonstrated {name}"
        raise InvalidInput(
            f"{label} {np.round(pose.position, 4).tolist()} m: the hand or the object there "
            f"would overlap obstacle {i} ({cfg.obstacles[i].spec()}) by "
            f"{-1e3 * per[i].min():.1f} mm (the hand spans 0.21 m across the fingers); move "
            f"the {name}, turn its heading or move the obstacle",
            param=name,
        )


def support(name: str, p: FloatArray, cfg: PlanConfig, obj_half: float) -> Box | None:
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
                f"({ob.spec()}); move the {name} or the obstacle",
                param=name,
            )
        half = min(half, gap - SUPPORT_GAP)
    if top <= TABLE_Z + 1e-3:
        return None
    height = top - TABLE_Z
    return Box((float(p[0]), float(p[1]), TABLE_Z + height / 2), (2 * half, 2 * half, height))


def pose_dict(pose: Pose, **extra: Any) -> dict[str, Any]:
    """A pose for ``Plan.meta``: position, quaternion, heading and tilt [deg]."""
    return {
        "position": pose.position.tolist(), "quaternion": pose.quaternion.tolist(),
        "yaw_deg": float(np.degrees(heading(pose.quaternion))),
        "tilt_deg": tilt_deg(pose.quaternion), **extra,
    }  # fmt: skip
