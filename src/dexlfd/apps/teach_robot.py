"""``teach``'s robot stages: the plan to the new pick and place, the simulation, the video.

The plan starts at the robot's ready pose (the person's start and end only shape the
motion), picks at ``Placement.pick`` with a top-down grasp and sets the object down at
``Placement.place``; it is slowed where the Panda's limits need it. The simulation
tracks it with the chosen controller carrying the object (its mass unknown to the
controller) and judges the placement (:func:`placement_verdict`). The video replays
that rollout (nothing is simulated twice).
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    from dexlfd.apps.teach import TeachConfig
    from dexlfd.apps.teach_frame import Placement
    from dexlfd.geometry import Obstacle
    from dexlfd.io import LearnedModel, Plan, Rollout
    from dexlfd.viz.robot_video_stream import VideoStream

__all__ = [
    "obstacle_clearance",
    "payload_half_size",
    "placement_verdict",
    "plan_lift",
    "render_video",
    "simulate_plan",
    "stream_video",
    "teach_plan",
]

logger = logging.getLogger(__name__)

# the robot video's render switches (dexlfd.viz.robot_video): neither the key light's
# shadow nor MuJoCo's 4x multisampling. Each frame then costs a twelfth of the CPU
# (llvmpipe, 480x360: 3 ms instead of 35; 8 ms with the multisampling, 20 ms with the
# shadow alone); the robot, the object, its supports and the table stay as clear, the
# edges step a little. The 10 s clip's video (254 frames): 1.6 s of CPU and 1.3 s in
# one process, where two processes took 2.2 s (a second interpreter's start-up costs
# more than its half of the frames); with the multisampling 3.6 s of CPU. Its encoder
# is x264's ultrafast fed YUV 4:2:0 (fast_encode): ffmpeg's CPU 2.3 -> 0.7 ms a frame
# (+0.15-0.3 ms to convert), the file ~3.5x larger (0.56 MB for the clip's 21 s).
VIDEO_SHADOWS, VIDEO_ANTIALIAS, VIDEO_FAST_ENCODE = False, False, True
VIDEO_WORKERS = 1  # processes rendering the robot video at once (software OpenGL: CPU-bound)


def _plan_config(placement: Placement, obstacles: tuple[Obstacle, ...] = ()) -> Any:
    """The :class:`~dexlfd.plan.PlanConfig` of the pick and place (from the ready pose)."""
    from dexlfd.plan import PlanConfig

    size = placement.object_size
    return PlanConfig(
        obstacles=obstacles,
        pick=placement.pick,
        pick_yaw=placement.pick_yaw,
        place=placement.place,
        place_yaw=placement.place_yaw,
        object_size=size,
        # the TCP holds the object at its middle; its footprint keeps clear of obstacles
        object_bottom=size[2] / 2,
        object_half_width=max(size[0], size[1]) / 2,
    )


def _named_as_default(exc: Exception, placement: Placement) -> Exception:
    """``exc`` about the pick or place the user did not give, said as the default one.

    The planner names a pick or place by its setting (``pick [x, y, z] m is inside
    obstacle 0 ...``: :func:`dexlfd.plan.task_poses.check_point`, the one check of a
    pick or place inside an obstacle, and the like; the command line shows a given one
    by its flag, ``--pick [x, y, z] m ...``). For teach's default pick or place that
    reads as if the user had typed it: it is called ``the default pick (set it with
    --pick)`` instead.
    """
    from dexlfd.errors import InvalidInput

    name, text = getattr(exc, "param", None), str(exc)
    if name not in ("pick", "place") or name not in placement.defaults:
        return exc
    if not text.startswith(name):
        return exc
    return InvalidInput(f"the default {name} (set it with --{name}){text[len(name) :]}")


def teach_plan(
    model: LearnedModel, placement: Placement, obstacles: tuple[Obstacle, ...] = ()
) -> tuple[Plan, dict[str, Any]]:
    """The pick-and-place plan and its time scaling (how much it was slowed, and where).

    The planner starts a pick-and-place at the ready pose, grasps from above with the
    demonstrated heading and slows the plan where the Panda's limits need it
    (``Plan.time_scaling``); with obstacles the elbow is planned to keep the arm's
    links clear, as ``dexlfd plan`` does (:func:`~dexlfd.robot.arm_posture.plan_arm_posture`).
    """
    from dexlfd.errors import InvalidInput
    from dexlfd.io.plan_facts import TimeScaling
    from dexlfd.plan import plan_from_model
    from dexlfd.robot import MujocoPandaModel  # the simulated robot's kinematics, as plan's
    from dexlfd.robot.arm_posture import plan_arm_posture

    try:
        plan = plan_from_model(
            model, _plan_config(placement, obstacles), MujocoPandaModel(), arm=plan_arm_posture
        )
    except InvalidInput as exc:
        raise _named_as_default(exc, placement) from exc
    ts = plan.time_scaling or TimeScaling()
    before = ts.duration_unscaled_s
    return plan, {
        "needed": bool(ts.needed), "largest": 1.0 if ts.largest is None else ts.largest,
        "duration_before_s": float(plan.t[-1]) if before is None else before,
        "duration_s": float(plan.t[-1]), "slowdowns": [s.to_json() for s in ts.slowdowns],
    }  # fmt: skip


def plan_lift(plan: Plan) -> float | None:
    """The carry's lift [m]: the highest TCP while the gripper holds, over the pick's height."""
    held = getattr(plan, "grasp", None)
    if held is None or not np.asarray(held).any():
        return None
    k = np.flatnonzero(np.asarray(held, dtype=bool))
    z = plan.position[k[0] : k[-1] + 1, 2]
    return float(z.max() - plan.position[k[0], 2])


def payload_half_size(object_size: tuple[float, ...]) -> tuple[float, float, float]:
    """The simulated box's half sizes [m] in the TCP frame for the planned ``object_size``.

    ``object_size`` is (width across the fingers, depth, height) [m] as the plan was
    made for it; the plant's box has x the depth, y across the fingers (at most the
    Franka Hand's opening), z the height. The plan holds the object at its middle
    (the TCP ``height / 2`` over its bottom), so a simulated box of another height
    would be carried that much lower or higher than planned: set down on a raised
    support, a taller box met it while the hand still pushed down and tipped over
    (seen on a real recording: the default 6 cm box under a plan for a 3.6 cm object,
    tilted 90 deg on the support).
    """
    from dexlfd.panda import FINGER_MAX

    width, depth, height = (float(v) for v in object_size)
    return depth / 2, min(width / 2, FINGER_MAX), height / 2


def simulate_plan(
    plan: Plan, cfg: TeachConfig, object_size: tuple[float, ...] | None = None,
    samples: Callable[[dict[str, np.ndarray]], None] | None = None,
) -> Rollout:  # fmt: skip
    """Track ``plan`` on the simulated Panda with ``cfg.controller`` carrying the object.

    As ``dexlfd simulate`` does: the controller's model has ``cfg.model_error`` and does
    not know the object's ``cfg.payload_kg``; friction, measurement noise (unless
    switched off) and the one-tick torque delay. The object is the box the plan was
    made for (``object_size``, :func:`payload_half_size`; None: the plant's default).
    ``samples`` is handed the samples as they are simulated (:func:`~dexlfd.control.track`'s).
    """
    from dexlfd.control import LoopConfig, make_controller, track
    from dexlfd.robot import PlantConfig, perturbed_model, plan_world

    plant = PlantConfig(payload_kg=cfg.payload_kg, obstacles=plan_world(plan),
                        friction_scale=1.0 if cfg.friction else 0.0,
                        **_size_kw(object_size))  # fmt: skip
    loop = LoopConfig()
    if not cfg.noise:
        loop = dataclasses.replace(loop, q_noise=0.0, dq_noise=0.0)
    model = perturbed_model(cfg.model_error, np.random.default_rng([cfg.seed, 1]))
    return track(
        plan, make_controller(cfg.controller), model, plant, loop,
        rng=np.random.default_rng([cfg.seed, 2]), samples=samples,
    )  # fmt: skip


CLEARANCE_STEP_S = 0.01  # [s] the simulated arm's clearance is measured this often


def obstacle_clearance(rollout: Rollout, obstacles: tuple[Obstacle, ...]) -> dict[str, Any] | None:
    """How near the simulated arm came to ``obstacles``: None without obstacles.

    ``{"min_m", "obstacle", "body", "t_s"}``: the least distance [m] (negative: they
    overlapped) of the arm's links, hand and fingers (MuJoCo's collision geometry,
    :func:`dexlfd.robot.arm_clearance.arm_clearance`) from any obstacle, every
    :data:`CLEARANCE_STEP_S` of the rollout; which obstacle, which body and when.
    """
    if not obstacles:
        return None
    from dexlfd.robot.arm_clearance import ARM_LINKS, HAND_BODIES, arm_clearance

    dt = float(np.median(np.diff(rollout.t))) if rollout.t.shape[0] > 1 else CLEARANCE_STEP_S
    step = max(1, round(CLEARANCE_STEP_S / max(dt, 1e-6)))  # a stopped rollout may be short
    idx = np.arange(0, rollout.t.shape[0], step)
    q = np.asarray(rollout.q)[idx, :7]
    bodies = (*ARM_LINKS, *HAND_BODIES)
    per, worst = arm_clearance(q, obstacles, bodies=bodies)
    i = int(np.argmin(per.min(axis=1)))
    body, k = worst[i]
    return {"min_m": round(float(per[i, k]), 4), "obstacle": i, "body": body,
            "t_s": round(float(rollout.t[idx[k]]), 2)}  # fmt: skip


def placement_verdict(rollout: Rollout) -> dict[str, Any]:
    """``{"ok", "error_m", "tilt_deg", "set_down_speed_mps", "carried", "failure"}``.

    The simulator's placement check (:func:`dexlfd.control.grasp.placement_report`):
    carried, placed within 2 cm of the place, upright within 10 deg, set down slower
    than 0.1 m/s; ``failure`` names every check that failed (None when ok).
    """
    from dexlfd.control.grasp import placement_report

    r = placement_report(rollout)

    def num(value: float | None) -> float | None:
        return None if value is None or not np.isfinite(value) else float(value)

    return {
        "ok": bool(r.ok), "error_m": num(r.error_m), "tilt_deg": num(r.tilt_deg),
        "set_down_speed_mps": num(r.set_down_speed_mps), "carried": bool(r.carried),
        "failure": r.failure,
    }  # fmt: skip


def _size_kw(object_size: tuple[float, ...] | None) -> dict[str, Any]:
    return {} if object_size is None else {"payload_half_size": payload_half_size(object_size)}


def _video_plant(plan: Plan, payload_kg: float, object_size: tuple[float, ...] | None) -> Any:
    """The replayed scene's world: the object, the plan's supports and obstacles."""
    from dexlfd.robot import PlantConfig, plan_world

    return PlantConfig(payload_kg=payload_kg, obstacles=plan_world(plan),
                       **_size_kw(object_size))  # fmt: skip


def render_video(
    rollout: Rollout, plan: Plan, path: Path, *, payload_kg: float, caption: str,
    size_px: tuple[int, int], fps: float, object_size: tuple[float, ...] | None = None,
) -> Path:  # fmt: skip
    """The rollout replayed as an MP4 (the object, the supports; no new simulation).

    Rendered by :data:`VIDEO_WORKERS` processes at once, with :data:`VIDEO_SHADOWS`,
    :data:`VIDEO_ANTIALIAS` and :data:`VIDEO_FAST_ENCODE`.
    """
    from dexlfd.viz.robot_video import render_rollout_video

    w, h = size_px
    return render_rollout_video(rollout, _video_plant(plan, payload_kg, object_size), path,
                                fps=fps, width=w, height=h, caption=caption,
                                workers=VIDEO_WORKERS, shadows=VIDEO_SHADOWS,
                                antialias=VIDEO_ANTIALIAS,
                                fast_encode=VIDEO_FAST_ENCODE)  # fmt: skip


def stream_video(
    plan: Plan, path: Path, *, payload_kg: float, caption: str, size_px: tuple[int, int],
    fps: float, object_size: tuple[float, ...] | None = None,
) -> VideoStream | None:  # fmt: skip
    """:func:`render_video`'s video, drawn while the plan is simulated (:class:`VideoStream`).

    Feed it the simulation's samples (:func:`simulate_plan`'s ``samples``), then
    the rollout (``finish``); None when this process cannot fork a renderer (it has
    an OpenGL context): :func:`render_video` it after the simulation.
    """
    from dexlfd.viz.robot_video import Scene
    from dexlfd.viz.robot_video_stream import VideoStream

    scene = Scene(_video_plant(plan, payload_kg, object_size), caption, *size_px,
                  shadows=VIDEO_SHADOWS, antialias=VIDEO_ANTIALIAS,
                  fast_encode=VIDEO_FAST_ENCODE)  # fmt: skip
    return VideoStream.start(scene, path, fps, payload=payload_kg > 0)
