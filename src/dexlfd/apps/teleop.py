"""Teleoperation: a live or recorded hand drives the simulated Panda, frame by frame.

For each camera frame (thesis §4.4.3, the real-time teleoperation experiment):

1. *capture + motion* - :class:`~dexlfd.motion.OnlineMotion` gives the hand's
   pose and thumb-index opening (or nothing when the hand is not seen);
2. *shaping* - :func:`~dexlfd.plan.teleop.teleop_step` retargets it relative to
   first sight, low-passes, clamps it to the workspace and rate-limits it (and
   holds while the hand is lost): the frame's *target*;
3. *tracking* - the 1 kHz loop (:class:`~dexlfd.control.TrackingSession`) runs
   for one frame interval; its reference moves from where it was to the new
   target along a straight line (slerp for orientation) with the matching
   constant velocity feed-forward. A piecewise-linear reference stays inside
   the (convex) workspace box and within the per-frame rate limits at every
   control tick; the price is one frame interval of interpolation delay.

The wall-clock latency from a frame's arrival (decoded, handed to us) to its
target being ready (capture + motion + shaping) is measured per frame. Video
files are processed as fast as possible (not paced to real time); frame times
come from the source, so the simulated robot sees the video's own timing. A
late frame (a live camera's gap) makes the reference hold its last target.

References
----------
.. [1] N. Chen, "Robust and adaptive dexterous manipulation with vision-based
   learning from multi-demonstrations", thesis, §4.4.3 (teleoperation experiment).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture import Frame
from dexlfd.control import Controller, LoopConfig, TrackingSession, TrackingStopped
from dexlfd.control.segment import ReferenceSegment
from dexlfd.errors import InvalidInput, SourceError
from dexlfd.io import Rollout
from dexlfd.motion.online import OnlinePose
from dexlfd.panda import GRIPPER_OPENING_MAX, N_JOINTS, Q_READY, SHOULDER_HEIGHT
from dexlfd.panda_ik import solve_ik
from dexlfd.plan.teleop import TeleopConfig, TeleopState, TeleopTarget, teleop_init, teleop_step
from dexlfd.robot.plant import PlantConfig
from dexlfd.robot.robot_model import RobotModel
from dexlfd.robot.sim import PandaSim
from dexlfd.rotations import matrix_from_quat, quat_from_matrix

__all__ = [
    "TeleopFrame",
    "TeleopResult",
    "TeleopRunConfig",
    "panda_teleop_config",
    "run_teleop",
    "teleop_summary",
]

logger = logging.getLogger(__name__)

GRIPPER_OPEN = GRIPPER_OPENING_MAX  # [m], the Franka Hand's full opening: the robot starts open
# Teleoperation limits for the Panda. Measured in simulation (NTSM-PD, ready pose): at
# 0.5 m/s a diagonal reach needs ~1.9 rad/s at the elbow and the loop's joint-velocity stop
# fired; beyond ~0.75 m from the shoulder the stretched elbow did the same at 0.25 m/s.
# 0.25 m/s inside 0.70 m (Panda reach 0.855 m) ran clean.
PANDA_MAX_SPEED = 0.25  # [m/s]
PANDA_REACH_RADIUS = 0.70  # [m] around the shoulder (joint-2 axis)


def panda_teleop_config(**changes: Any) -> TeleopConfig:
    """:class:`TeleopConfig` with the Panda's teleoperation limits (``changes`` override)."""
    base = {
        "max_speed": PANDA_MAX_SPEED,
        "reach_center": (0.0, 0.0, SHOULDER_HEIGHT),
        "reach_radius": PANDA_REACH_RADIUS,
    }
    return TeleopConfig(**{**base, **changes})


class FrameMotion(Protocol):
    """Anything that turns a frame into an :class:`OnlinePose` (e.g. ``OnlineMotion``)."""

    def process(self, frame: Frame) -> OnlinePose:
        """Pose of the hand in ``frame``."""
        ...


@dataclass(frozen=True, slots=True)
class TeleopRunConfig:
    """Settings of a teleoperation run.

    Attributes
    ----------
    shaping : TeleopConfig
        Retargeting, filter, workspace and rate limits (default
        :func:`panda_teleop_config`).
    plant : PlantConfig
        The simulated world (payload waits between the open fingers at the start pose).
    loop : LoopConfig
        The 1 kHz loop's sensing and safety settings.
    frame_interval_s : float
        Nominal camera frame interval [s]: each target is reached this long
        after its frame.
    q0 : tuple of 7 floats
        Start joints [rad] (the Panda's "ready" pose by default).
    """

    shaping: TeleopConfig = field(default_factory=lambda: panda_teleop_config())
    plant: PlantConfig = field(default_factory=PlantConfig)
    loop: LoopConfig = field(default_factory=LoopConfig)
    frame_interval_s: float = 1.0 / 30.0
    q0: tuple[float, ...] = tuple(float(v) for v in Q_READY)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.frame_interval_s) and 0 < self.frame_interval_s <= 1.0):
            raise InvalidInput(
                f"frame_interval_s must be in (0, 1] s, got {self.frame_interval_s!r}"
            )
        if len(self.q0) != N_JOINTS or not np.isfinite(self.q0).all():
            raise InvalidInput(f"q0 must be {N_JOINTS} finite joint angles, got {self.q0!r}")


@dataclass(frozen=True, slots=True)
class TeleopFrame:
    """What happened at one camera frame (handed to ``on_frame``)."""

    frame: Frame
    pose: OnlinePose
    target: TeleopTarget
    latency_s: float  # wall time from arrival to target [s]
    t_robot: float  # simulated time at the end of this frame's interval [s]


@dataclass(frozen=True, slots=True)
class TeleopResult:
    """A teleoperation run: the 1 kHz rollout and the per-frame record.

    ``rollout.extras`` also hold the per-frame arrays (``frame_t``,
    ``frame_detected``, ``frame_latency_s``, ``hand_position``,
    ``hand_quaternion``, ``hand_gripper``, ``target_position``,
    ``target_quaternion``, ``target_gripper``, ``target_tracking``).
    """

    rollout: Rollout
    n_frames: int
    stopped: str | None  # safety-stop reason, None if it ran to the end
    interrupted: bool  # Ctrl-C
    wall_s: float  # wall time of the whole loop [s]

    @property
    def frames(self) -> dict[str, np.ndarray]:
        """Per-frame arrays (see the class docstring)."""
        return {k: v for k, v in self.rollout.extras.items() if k.split("_")[0] in _FRAME_KEYS}


_FRAME_KEYS = ("frame", "hand", "target")


def run_teleop(
    frames: Iterable[Frame],
    motion: FrameMotion,
    controller: Controller,
    model: RobotModel,
    cfg: TeleopRunConfig | None = None,
    *,
    rng: np.random.Generator,
    on_frame: Callable[[TeleopFrame, PandaSim], None] | None = None,
    clock: Callable[[], float] = time.perf_counter,
    meta: dict[str, Any] | None = None,
) -> TeleopResult:
    """Drive the simulated Panda from a stream of frames (see the module docstring).

    Parameters
    ----------
    frames : iterable of Frame
        An opened source (or any frames with increasing ``t``).
    motion : FrameMotion
        Per-frame capture and motion (``OnlineMotion``).
    controller, model :
        Control law and its nominal model.
    cfg : TeleopRunConfig, optional
    rng : numpy.random.Generator
        Measurement noise of the loop.
    on_frame : callable(TeleopFrame, PandaSim), optional
        Called after each frame's interval was simulated (e.g. to render).
    clock : callable, optional
        Wall clock [s] for the latency measurement.
    meta : dict, optional
        Extra entries for the rollout's ``meta`` (source, capture settings).

    Returns
    -------
    TeleopResult
        With the partial rollout when the safety stop fired or on Ctrl-C.

    Raises
    ------
    SourceError
        The source gave no frame at all (or fails while reading).
    InvalidInput
        Frame times do not increase.
    KeyboardInterrupt
        Only when interrupted before the first control tick (nothing to keep).
    """
    cfg = cfg or TeleopRunConfig()
    run = _TeleopRun(controller, model, cfg, rng, meta)
    rollout: Rollout | None = None
    stopped: str | None = None
    interrupted = False
    wall0 = clock()
    with run.session:
        try:
            for frame in frames:
                step = run.frame(frame, motion, clock)
                if on_frame is not None:
                    on_frame(step, run.session.sim)
        except TrackingStopped as exc:
            stopped, rollout = exc.reason, exc.rollout
        except KeyboardInterrupt:
            interrupted = True
            logger.warning("interrupted: keeping the rollout so far (%.2f s)", run.session.t)
        wall = clock() - wall0
        if interrupted and run.session.k == 0:
            raise KeyboardInterrupt  # interrupted before the robot moved: nothing to keep
        n = len(run.rows["frame_t"])
        if n == 0 and stopped is None and not interrupted:
            raise SourceError("the source gave no frames: nothing to teleoperate")
        if rollout is None:
            rollout = run.session.rollout()
    extras = dict(rollout.extras)
    if n:
        extras.update({k: np.asarray(v) for k, v in run.rows.items()})
    result = TeleopResult(_with(rollout, {}, extras), n, stopped, interrupted, wall)
    summary = teleop_summary(result)
    return replace(result, rollout=_with(rollout, {"teleop_summary": summary}, extras))


class _TeleopRun:
    """The state of a run between frames: the loop, the shaper and the current segment."""

    def __init__(
        self,
        controller: Controller,
        model: RobotModel,
        cfg: TeleopRunConfig,
        rng: np.random.Generator,
        meta: dict[str, Any] | None,
    ) -> None:
        self.model, self.cfg = model, cfg
        q0 = np.asarray(cfg.q0, dtype=np.float64)
        p0, R0 = model.tcp_pose(q0)
        self.start = (p0, quat_from_matrix(R0), GRIPPER_OPEN)
        self.joint_space = bool(controller.needs_joint_reference)
        self.rows: dict[str, list[Any]] = {k: [] for k in _ROW_KEYS}
        self.state: TeleopState | None = None  # the shaper's state, from the first frame on
        self.first_t = 0.0
        T = cfg.frame_interval_s
        self.t_prev = -T  # the first frame's step is over one nominal interval
        self.seg = ReferenceSegment(
            -T, T, self.start, self.start, (q0, q0) if self.joint_space else None
        )
        self.q_target = q0
        self.grasp = False  # the hand's grasp flag (motion's adaptive grasp), last seen
        self.session = TrackingSession(
            controller, model, cfg.plant, cfg.loop, rng=rng, q0=q0, gripper0=GRIPPER_OPEN,
            meta={"teleop": _describe(cfg), **(meta or {})}, regrasp=True,
        )  # fmt: skip

    def frame(self, frame: Frame, motion: FrameMotion, clock: Callable[[], float]) -> TeleopFrame:
        """Sense the hand, shape its target, and track one frame interval toward it."""
        arrival = clock()
        if self.state is None:
            self.first_t = frame.t
            self.state = teleop_init(self.t_prev, *self.start)
        t_rel = frame.t - self.first_t
        pose = motion.process(frame)
        seen = pose.valid
        self.state, target = teleop_step(
            self.state, t_rel,
            pose.position if seen else None, pose.quaternion if seen else None,
            pose.gripper if seen else None, self.cfg.shaping,
        )  # fmt: skip
        latency = clock() - arrival
        if seen:
            self.grasp = bool(pose.grasp)
        _append(self.rows, frame, pose, target, latency)
        self._track(t_rel, target)
        return TeleopFrame(frame, pose, target, latency, self.session.t)

    def _track(self, t_rel: float, target: TeleopTarget) -> None:
        # the segment starts at the frame's time and lasts the interval since the
        # previous frame (the shaper's rate limits were applied over it), plus what
        # is left of the previous segment if this frame came early
        seg = self.seg
        self.session.run_until(t_rel, seg.at)  # a late frame: hold the last target
        duration = (t_rel - self.t_prev) + max(0.0, seg.t0 + seg.T - t_rel)
        joints: tuple[FloatArray, FloatArray] | None = None
        if self.joint_space:
            R1 = matrix_from_quat(target.quaternion)
            q_next = solve_ik(self.model, target.position, R1, self.q_target, max_iter=50).q
            q_now = seg.at(t_rel)[0].q
            joints = (self.q_target if q_now is None else q_now, q_next)
            self.q_target = q_next
        end = (target.position, target.quaternion, target.gripper)
        self.seg = ReferenceSegment(t_rel, duration, seg.pose_at(t_rel), end, joints)
        self.session.run_until(t_rel + duration, self.seg.at, self.grasp)
        self.t_prev = t_rel


def _with(rollout: Rollout, meta: dict[str, Any], extras: dict[str, np.ndarray]) -> Rollout:
    return replace(rollout, meta={**rollout.meta, **meta}, extras=extras)


_ROW_KEYS = (
    "frame_t", "frame_detected", "frame_latency_s", "hand_position", "hand_quaternion",
    "hand_gripper", "target_position", "target_quaternion", "target_gripper", "target_tracking",
)  # fmt: skip


def _append(
    rows: dict[str, list[Any]], frame: Frame, pose: OnlinePose, target: TeleopTarget, lat: float
) -> None:
    rows["frame_t"].append(frame.t)
    rows["frame_detected"].append(pose.valid)
    rows["frame_latency_s"].append(lat)
    rows["hand_position"].append(pose.position)
    rows["hand_quaternion"].append(pose.quaternion)
    rows["hand_gripper"].append(pose.gripper)
    rows["target_position"].append(target.position)
    rows["target_quaternion"].append(target.quaternion)
    rows["target_gripper"].append(target.gripper)
    rows["target_tracking"].append(target.tracking)


def _describe(cfg: TeleopRunConfig) -> dict[str, Any]:
    return {
        "shaping": asdict(cfg.shaping),
        "frame_interval_s": cfg.frame_interval_s,
        "q0": list(cfg.q0),
        "interpolation": "linear position/gripper, slerp orientation, constant-velocity "
        "feed-forward; each target reached one frame interval after its frame",
    }


def teleop_summary(result: TeleopResult) -> dict[str, Any]:
    """Frames, detection rate, latency median/p99 [ms], tracking RMS/max [m], speed.

    Tracking errors are the TCP's distance from the 1 kHz reference.
    """
    ro = result.rollout
    lat = np.asarray(ro.extras.get("frame_latency_s", np.zeros(0)), dtype=np.float64)
    det = np.asarray(ro.extras.get("frame_detected", np.zeros(0, bool)), dtype=bool)
    err = np.linalg.norm(ro.ee_position - ro.ref_position, axis=1)
    sim_s = float(ro.t[-1] - ro.t[0]) + 1.0 / float(ro.rate_hz or 1000.0)
    return {
        "frames": int(result.n_frames),
        "detection_rate": float(det.mean()) if det.size else 0.0,
        "latency_median_ms": float(np.median(lat) * 1e3) if lat.size else float("nan"),
        "latency_p99_ms": float(np.percentile(lat, 99) * 1e3) if lat.size else float("nan"),
        "tracking_rms_m": float(np.sqrt(np.mean(err**2))),
        "tracking_max_m": float(err.max()),
        "simulated_s": sim_s,
        "wall_s": float(result.wall_s),
        "speed_vs_real_time": sim_s / result.wall_s if result.wall_s > 0 else float("inf"),
        "stopped": result.stopped,
        "interrupted": bool(result.interrupted),
    }
