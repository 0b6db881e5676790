"""Plan a new motion from a learned model: new start/goal, obstacles, duration.

:func:`plan_from_model` is the sequence of the plan's steps:

1. *position* -- a modified DMP (Eq. 5.5, :mod:`dexlfd.plan.dmp`) fitted to the GMR
   mean position and rolled out from the new start to the new goal;
2. *clearance* -- the path bent around obstacles by the variance-aware Gams coupling
   (Eqs. 5.6-5.7, :mod:`dexlfd.plan.clearance`);
3. *end shaping* -- the DMP's goal residual blended out and the plan brought to rest
   at the goal (:mod:`dexlfd.plan.end_shaping`);
4. *gripper* -- the learned opening schedule played back in phase, and, with a
   place surface, the held object lowered onto it before release
   (:mod:`dexlfd.plan.place`);
5. *orientation* -- a quaternion DMP (Ude et al. 2014,
   :mod:`dexlfd.plan.quaternion_dmp`) ending exactly at the goal orientation;

then the Cartesian limits are checked and the :class:`dexlfd.io.Plan` assembled.
Obstacles: by default (``enforce_clearance=True``) the coupling is *shaped*
(:mod:`dexlfd.plan.coupling`): the path clears each obstacle by ``margin`` plus at
most ``band`` [m] over it, bends up to ``variance_clearance`` [m] further where the
demonstrations disagreed and returns to the learned path after it.
``enforce_clearance=False`` is the thesis's law as printed, which guarantees nothing.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.geometry import Box
from dexlfd.io import LearnedModel, Plan
from dexlfd.io._world import obstacle_arrays, support_arrays
from dexlfd.io.plan import MAX_DURATION_S
from dexlfd.io.plan_facts import Limits, ObstaclePass, PlaceCorrection
from dexlfd.panda import GRIPPER_OPENING_MAX, check_workspace
from dexlfd.plan.clearance import AvoidanceSettings, avoid_obstacles, check_clearance
from dexlfd.plan.config import MAX_MOTION_S, PlanConfig
from dexlfd.plan.descent import descend_once
from dexlfd.plan.dmp import fit_dmp
from dexlfd.plan.dmp_rollout import _rollout_impl
from dexlfd.plan.end_shaping import Path, Window, blend_orientation_goal, end_window, settle_at_goal
from dexlfd.plan.floor import lift_above_floor
from dexlfd.plan.grasp_schedule import grasp_schedule
from dexlfd.plan.limits import check_cartesian_limits
from dexlfd.plan.obstacles import distance, variance_level
from dexlfd.plan.place import set_down
from dexlfd.plan.quaternion_dmp import fit_quaternion_dmp, rollout_quaternion_dmp
from dexlfd.plan.reach import reach_clear
from dexlfd.plan.task_poses import start_pose
from dexlfd.rotations import quat_sign_continuous
from dexlfd.trajectory import resample

__all__ = [
    "check_model_covariance",
    "check_plan_size",
    "plan_motion",
]

logger = logging.getLogger(__name__)

MAX_SAMPLES = 3_600_001  # e.g. 600 s at 6 kHz: larger plans are a typo, not a task
_COARSE = 300  # model grids with fewer samples are resampled (cubic spline) ...
_FIT_SAMPLES = 1000  # ... to this many before fitting


@dataclass(frozen=True, slots=True)
class _Channels:
    """The learned model read for planning.

    Time [s] and its normalised phase, mean position (m, 3) [m], unit quaternions
    (m, 4) (sign-continuous), gripper (m,) [m], positional covariance (m, 3, 3) [m²].
    """

    t: FloatArray
    tb: FloatArray
    position: FloatArray
    quaternion: FloatArray
    gripper: FloatArray
    cov_p: FloatArray


@dataclass(frozen=True, slots=True)
class _Task:
    """Where and how long: start, goal [m], duration T [s], normalised grid (n,)."""

    start: FloatArray
    goal: FloatArray
    T: float
    tb: FloatArray


def _fit_grid(t: FloatArray, x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Resample a coarse model grid with a cubic spline for the DMP fit.

    The forcing target needs x''; finite differences on a coarse grid (a GMR evaluated
    at 50-200 times) lose centimetres, a C2 spline through the same points does not.
    """
    if t.shape[0] >= _COARSE:
        return t, x
    tf = np.linspace(t[0], t[-1], _FIT_SAMPLES)
    return tf, np.asarray(CubicSpline(t, x, axis=0)(tf), dtype=np.float64)


def check_plan_size(T: float, rate_hz: float) -> int:
    """Samples of a plan of duration ``T`` [s] at ``rate_hz``; InvalidInput beyond the bounds.

    A motion lasts at most :data:`~dexlfd.plan.config.MAX_MOTION_S` and a plan holds
    at most ``MAX_SAMPLES``; checked before planning, for the default duration (the
    model's) too.
    """
    if T > MAX_MOTION_S:
        raise InvalidInput(
            f"duration {T:.6g} s (default: the model's) is longer than the {MAX_MOTION_S:g} s "
            "a planned motion may last",
            param="duration",
        )
    n = int(round(T * rate_hz)) + 1
    if n > MAX_SAMPLES:
        raise InvalidInput(
            f"rate_hz {rate_hz:g} over a duration of {T:g} s gives {n} samples; at most "
            f"{MAX_SAMPLES} (e.g. {MAX_DURATION_S:g} s at "
            f"{(MAX_SAMPLES - 1) / MAX_DURATION_S / 1000:g} kHz) are planned at once",
            param="rate_hz",
        )
    return n


def check_model_covariance(model: LearnedModel) -> None:
    """Raise :class:`InvalidInput` unless every ``model.cov[k]`` is symmetric PSD.

    A GMR covariance is symmetric positive semi-definite by construction; anything
    else is a damaged or hand-edited file, and the variance term would read nonsense
    from it (a negative determinant). Tolerances are relative to the largest entry.
    """
    cov = np.asarray(model.cov, dtype=np.float64)
    scale = max(float(np.abs(cov).max()), 1e-300)
    asym = np.abs(cov - np.swapaxes(cov, -1, -2)).max(axis=(1, 2))
    bad = np.flatnonzero(asym > 1e-6 * scale)
    if bad.size:
        k = int(bad[0])
        raise InvalidInput(
            f"cov[{k}] (t = {model.t[k]:.3f} s) is not symmetric (|C - C^T| up to "
            f"{asym[k]:.3g}; {bad.size} of {cov.shape[0]} samples): not a covariance"
        )
    eig_min = np.linalg.eigvalsh(0.5 * (cov + np.swapaxes(cov, -1, -2)))[:, 0]
    bad = np.flatnonzero(eig_min < -1e-9 * scale)
    if bad.size:
        k = int(bad[0])
        raise InvalidInput(
            f"cov[{k}] (t = {model.t[k]:.3f} s) has a negative eigenvalue "
            f"{eig_min[k]:.3g} ({bad.size} of {cov.shape[0]} samples): a covariance "
            "must be positive semi-definite"
        )


def _read_model(model: LearnedModel) -> _Channels:
    """Validate the model and split its mean into position, orientation, gripper."""
    if not isinstance(model, LearnedModel):
        raise InvalidInput(f"model must be a dexlfd.io.LearnedModel, got {type(model).__name__}")
    if model.n_samples < 4:
        raise InvalidInput(f"model has {model.n_samples} samples; a DMP needs at least 4")
    frame = model.frame
    if frame.startswith("camera"):
        raise InvalidInput(
            f"model is in the {frame} frame, not the robot base frame: record the "
            "demonstrations with the camera's extrinsics (camera-to-base transform) "
            "or a known camera pose (top-down/front)"
        )
    check_model_covariance(model)
    mean = model.mean
    quat_norm = np.linalg.norm(mean[:, 3:7], axis=1)
    if (quat_norm < 1e-6).any():
        raise InvalidInput("model.mean has zero-norm quaternions (columns 3:7)")
    if np.abs(quat_norm - 1).max() > 1e-3:
        logger.warning(
            "model mean quaternions deviate from unit norm by up to %.3g; renormalised",
            np.abs(quat_norm - 1).max(),
        )
    t = model.t
    return _Channels(
        t=t,
        tb=(t - t[0]) / (t[-1] - t[0]),
        position=mean[:, :3],
        quaternion=quat_sign_continuous(mean[:, 3:7] / quat_norm[:, None]),
        gripper=mean[:, 7],
        cov_p=model.cov[:, :3, :3],
    )


def _check_reach(x0: FloatArray, g: FloatArray, cfg: PlanConfig) -> None:
    """The workspace rule on start and goal: the caller's own values first.

    A default (the model's first or last position) out of reach is named as such,
    with the parameter that replaces it.
    """
    start = None if isinstance(cfg.start, str) else cfg.start
    given = [(n, p) for n, p, v in (("goal", g, cfg.goal), ("start", x0, start)) if v is not None]
    for name, point in given:
        check_workspace(point, name, param=name)
    for name, point, value, which in (("start", x0, cfg.start, "first"),
                                      ("goal", g, cfg.goal, "last")):  # fmt: skip
        if value is None or value == "demonstrated":
            try:
                check_workspace(point, f"the default {name} (the model's {which} position)")
            except InvalidInput as exc:
                raise InvalidInput(f"{exc}; give a {name} within reach", param=name) from None


def _task(ch: _Channels, cfg: PlanConfig) -> _Task:
    """Start, goal, duration and time grid, checked against the workspace and obstacles."""
    x0, _ = start_pose(cfg, ch.position[0], ch.quaternion[0])
    g = np.asarray(cfg.goal) if cfg.goal is not None else ch.position[-1].copy()
    _check_reach(x0, g, cfg)
    if np.linalg.norm(g - x0) < 1e-6:
        if cfg.dmp.variant == "original":
            raise InvalidInput(
                "goal equals start: the original DMP (Eq. 5.1) degenerates to a point; "
                "use the modified DMP or a different goal"
            )
        logger.warning(
            "goal equals start %s: the modified DMP keeps the demonstrated shape and "
            "returns to the start",
            np.round(x0, 4).tolist(),
        )
    T = cfg.duration if cfg.duration is not None else float(ch.t[-1] - ch.t[0])
    n = max(2, check_plan_size(T, cfg.rate_hz))
    for i, ob in enumerate(cfg.obstacles):
        for name, point, s in (("start", x0, 0.0), ("goal", g, 1.0)):
            dist = float(distance(ob, point, np.array([s]))[0])
            if dist < 0:
                raise InvalidInput(
                    f"{name} {np.round(point, 4).tolist()} is inside obstacle {i} "
                    f"({ob.spec()}); move the {name} or the obstacle",
                    param=name,
                )
            if dist < cfg.margin:
                logger.warning(
                    "%s is %.3f m from obstacle %d, closer than the margin %.3f m",
                    name, dist, i, cfg.margin,
                )  # fmt: skip
    return _Task(start=x0, goal=g, T=T, tb=np.linspace(0.0, 1.0, n))


def _position(ch: _Channels, cfg: PlanConfig, task: _Task) -> Path:
    """Modified (or original) DMP, Eq. (5.5) / (5.1): x, x', x'' per normalised time."""
    dmp = fit_dmp(*_fit_grid(ch.t, ch.position), cfg.dmp)
    v0 = dmp.v0 if cfg.start_velocity == "model" else np.zeros(3)
    return _rollout_impl(dmp, task.tb, task.start, task.goal, v0, None, None)


def _variance(ch: _Channels, tb: FloatArray, cfg: PlanConfig) -> Callable[[FloatArray], FloatArray]:
    """``n -> nu`` (n_samples,): the variance level along ``n`` on the plan grid.

    ``cfg.variance_measure == "metres"``: the standard deviation along ``n`` against
    ``variance_clearance`` (0 without extra clearance); ``"relative"``: normalised on the
    model's own samples. Then resampled.
    """
    scale = None
    if cfg.variance_measure == "metres":
        if cfg.variance_clearance <= 0:  # no extra clearance asked: the variance is moot
            return lambda n: np.zeros(tb.shape)
        scale = cfg.variance_clearance

    def along(n: FloatArray) -> FloatArray:
        return resample(tb, ch.tb, variance_level(ch.cov_p, n, scale))

    return along


def _avoidance(cfg: PlanConfig) -> AvoidanceSettings:
    """The settings obstacle avoidance reads (:mod:`dexlfd.plan.clearance`)."""
    return AvoidanceSettings(
        dmp=cfg.dmp, margin=cfg.margin, band=cfg.band,
        variance_clearance=cfg.variance_clearance, influence=cfg.influence,
        k1=cfg.k1, k2=cfg.k2, c=cfg.c, variance_aware=cfg.variance_aware,
        enforce_clearance=cfg.enforce_clearance,
    )  # fmt: skip


def _gripper(ch: _Channels, tb: FloatArray) -> FloatArray:
    """The learned opening schedule in phase, clipped to the hand's range [m]."""
    gripper = resample(tb, ch.tb, ch.gripper)
    if gripper.min() < 0.0 or gripper.max() > GRIPPER_OPENING_MAX:
        logger.info(
            "gripper schedule %.3f..%.3f m clipped to the hand's range 0..%.2f m",
            gripper.min(), gripper.max(), GRIPPER_OPENING_MAX,
        )  # fmt: skip
        gripper = np.clip(gripper, 0.0, GRIPPER_OPENING_MAX)
    return gripper


_Bent = tuple[
    list[dict[str, Any]], tuple[FloatArray, FloatArray], tuple[float, float], PlaceCorrection | None
]


def _bend(ch: _Channels, cfg: PlanConfig, task: _Task, nominal: Path, gripper: FloatArray) -> tuple[
    Path, _Bent
]:  # fmt: skip
    """``nominal`` bent round the obstacles, brought to rest at the goal, set down, floored.

    With ``descend_to_goal`` it descends once after its top (:mod:`.descent`). Returns
    the path and the obstacles' records, ``(nu, k2 nu)``, the goal residual [m] and end
    speed, and the place correction (:func:`plan_motion`'s steps 2-4).
    """
    tb, win = task.tb, end_window(task.tb)
    path, obstacles, terms = avoid_obstacles(
        cfg.obstacles, _avoidance(cfg), tb, nominal, _variance(ch, tb, cfg), win
    )
    path, end_err, end_speed = settle_at_goal(tb, task.T, path, task.goal, win)
    path, place = set_down(tb, task.T, path, gripper, cfg.place_surface_z, cfg.object_bottom)
    path = _descend(tb, path, cfg.descend_to_goal)
    path, lifted = lift_above_floor(tb, path, cfg.z_floor)
    if lifted > 0:
        logger.info("the path dipped under its floor z = %.3f m: lifted by %.1f mm there",
                    cfg.z_floor, 1e3 * lifted)  # fmt: skip
        # a lift that reaches into the descent from a dip before it: the descent again
        path = _descend(tb, path, cfg.descend_to_goal)
    return path, (obstacles, terms, (end_err, end_speed), place)


def _descend(tb: FloatArray, path: Path, on: bool) -> Path:
    """``path`` descending once from its top to the goal when ``on`` (:mod:`.descent`)."""
    if not on:
        return path
    path, lift, ok = descend_once(tb, path)
    if lift > 0 or not ok:
        logger.log(logging.INFO if ok else logging.WARNING, "the path came down and climbed "
                   "back after its top: %s", f"bridged, lifted by {1e3 * lift:.1f} mm there"
                   if ok else "no smooth descent above it fits there, kept")  # fmt: skip
    return path


def _orientation(ch: _Channels, cfg: PlanConfig, task: _Task, win: Window) -> Path:
    """Quaternion DMP ending exactly at the goal orientation.

    Returns q (n, 4), omega and omega' (n, 3) [rad/s, rad/s²].
    """
    t_q, quat_fit = _fit_grid(ch.t, ch.quaternion)
    qdmp = fit_quaternion_dmp(t_q, quat_fit / np.linalg.norm(quat_fit, axis=1)[:, None], cfg.dmp)
    if cfg.start_velocity == "zero":
        qdmp = dataclasses.replace(qdmp, eta0=np.zeros(3))
    _, q0 = start_pose(cfg, ch.position[0], ch.quaternion[0])
    qg = np.asarray(cfg.goal_quat) if cfg.goal_quat is not None else ch.quaternion[-1]
    T, n = task.T, task.tb.shape[0]
    qr = rollout_quaternion_dmp(qdmp, q0=q0, g=qg, duration=T, n_steps=n)
    win_, dwin, ddwin = win
    return blend_orientation_goal(
        qr.q, qr.omega, qr.omegad, qg, 1.0 - win_, -dwin / T, -ddwin / T**2
    )


def _check_limits(
    cfg: PlanConfig, T: float, path: Path, orientation: Path, quiet: bool = False
) -> Limits:
    """The Panda's Cartesian limits (warn, or raise with ``on_limit="raise"``)."""
    (_x, velocity, acceleration), (_q, omega, omegad) = path, orientation
    report = check_cartesian_limits(velocity, acceleration, omega, omegad)
    for msg in () if quiet or cfg.on_limit == "scale" else report.exceeded:
        if cfg.on_limit == "raise":
            raise InvalidInput(f"duration {T:g} s: {msg}", param="duration")
        logger.warning("duration %g s: %s", T, msg)
    return Limits(peaks=dict(report.peaks), exceeded=tuple(report.exceeded))


_UNITS = {
    "t": "s",
    "position": "m",
    "velocity": "m/s",
    "acceleration": "m/s^2",
    "angular_velocity": "rad/s",
    "gripper": "m",
}


def _meta(model: LearnedModel, cfg: PlanConfig, task: _Task, facts: dict[str, Any]) -> dict:
    """``Plan.meta`` (provenance): units, settings, task, and the steps' ``facts``."""
    settings = dataclasses.asdict(cfg)
    settings["obstacles"] = [ob.to_dict() for ob in cfg.obstacles]
    return {
        "units": dict(_UNITS),
        "settings": settings,
        "start": task.start.tolist(),
        "goal": task.goal.tolist(),
        "duration": task.T,
        **facts,
        "model_meta": {k: v for k, v in model.meta.items() if k in ("source", "software")},
        "method": "modified DMP (Pastor 2009) + quaternion DMP (Ude 2014) + "
        "variance-aware Gams coupling (thesis Eq. 5.7)",
    }


def plan_motion(
    model: LearnedModel, config: PlanConfig | None = None, *, quiet_limits: bool = False
) -> Plan:
    """Plan one end-effector motion from a learned model (one DMP, Section 5.3.1).

    Parameters
    ----------
    model : LearnedModel
        GMR mean (position, quaternion, gripper) and covariance over time.
    config : PlanConfig, optional

    Returns
    -------
    Plan
        Sampled at ``config.rate_hz`` from 0 to the duration. ``meta`` holds the
        settings, obstacles (with the chosen direction, the coupling's Eq. 5.7
        ``gain``, the ``thesis_weight`` ``k2 nu``, ``displacement`` and
        ``required_lift`` [m] and ``min_clearance`` [m]) and the limit check;
        ``extras`` holds ``nominal_position`` (n, 3) (the path without obstacles),
        ``coupling_weight`` (n,) (the thesis weight ``k2 nu``), ``variance_level``
        (n,) (``nu``), ``grasp`` (n,) bool (the gripper's grasp schedule, read from
        its own levels, :mod:`dexlfd.plan.grasp_schedule`; how in ``grasp_schedule``)
        and with obstacles ``clearance`` (n,) [m].

    Raises
    ------
    InvalidInput
        Bad configuration (named), start/goal outside the Panda's reach or inside an
        obstacle, an obstacle that cannot be cleared, or (``on_limit="raise"``) a
        plan beyond the Panda's Cartesian limits (``quiet_limits``: the caller checks).
    """
    cfg = config or PlanConfig()
    ch = _read_model(model)
    task = _task(ch, cfg)
    T, tb, win = task.T, task.tb, end_window(task.tb)
    nominal_path = _position(ch, cfg, task)
    gripper = _gripper(ch, tb)

    def bend(nominal: Path) -> tuple[Path, _Bent]:
        return _bend(ch, cfg, task, nominal, gripper)

    if cfg.top_down_reach:
        # the move outward of the reach band is bent round the obstacles in turn; the
        # thesis's coupling guarantees no clearance, so only the shaped one is redone
        near = cfg.obstacles if cfg.enforce_clearance else ()
        path, bent, pushed = reach_clear(tb, nominal_path, bend, near, cfg.margin)
        if pushed > 0:
            logger.info("the path passed too near the base for a top-down hand: moved "
                        "%.1f mm outward there", 1e3 * pushed)  # fmt: skip
    else:
        path, bent = bend(nominal_path)
    obstacles, (nu, w), (end_err, end_speed), place = bent
    x = path[0]
    clearance = check_clearance(
        cfg.obstacles,
        x,
        nominal_path[0],
        cfg.margin,
        cfg.enforce_clearance,
        obstacles,
        band=cfg.band if cfg.enforce_clearance else None,
        phase=tb,
    )
    quaternion, omega, omegad = _orientation(ch, cfg, task, win)
    physical = (x, path[1] / T, path[2] / T**2)
    limits = _check_limits(cfg, T, physical, (quaternion, omega, omegad), quiet_limits)
    facts = {"dmp_goal_residual": end_err, "dmp_end_speed": end_speed}
    closed, schedule = grasp_schedule(tb * T, gripper)
    passes = tuple(
        ObstaclePass.from_json({**r, "margin": cfg.margin}, f"obstacle {i}")
        for i, r in enumerate(obstacles)
    )
    extras: dict[str, np.ndarray] = {
        "nominal_position": nominal_path[0], "coupling_weight": w, "variance_level": nu,
    }  # fmt: skip
    if clearance is not None:
        extras["clearance"] = clearance
    logger.info(
        "plan: %d samples over %.2f s, goal error %.2f mm, %d obstacle(s)",
        tb.shape[0], T, 1e3 * end_err, len(cfg.obstacles),
    )  # fmt: skip
    return Plan(
        t=tb * T, position=x, velocity=physical[1], acceleration=physical[2],
        quaternion=quaternion, angular_velocity=omega, gripper=gripper,
        grasp=closed, **_world(cfg, place),
        meta=_meta(model, cfg, task, facts), extras=extras,
        goal_error=float(np.linalg.norm(x[-1] - task.goal)), obstacle_passes=passes,
        grasp_schedule=schedule,
        place_correction=place, limits=limits,
    )  # fmt: skip


def _world(cfg: PlanConfig, place: PlaceCorrection | None) -> dict[str, Any]:
    """The plan's obstacles and the place support as the contract's arrays."""
    world: dict[str, Any] = obstacle_arrays(cfg.obstacles)
    support = None if place is None else place.support
    world.update(support_arrays([Box(support.center, support.size)] if support else []))
    return world
