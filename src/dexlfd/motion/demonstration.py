"""Keypoint series -> :class:`~dexlfd.io.Demonstration` (the motion stage's output).

References
----------
.. [1] Thesis, Section 4.2, Eqs. (4.10)-(4.14).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any, cast

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import as_float_array, check_positive, check_time
from dexlfd.errors import InvalidDemonstration, InvalidInput
from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import Phases
from dexlfd.motion.definition import EULER_MODES, HANDS, mount_quat, pose_from_keypoints
from dexlfd.motion.gaps import Gap, fill_short_gaps, find_gaps
from dexlfd.motion.grasp import (
    GRASP_METHODS,
    GraspConfig,
    GraspResult,
    aperture_ratio,
    detect_grasp,
)
from dexlfd.motion.phases import PhaseConfig, track_phases
from dexlfd.motion.quality import jitter_mm
from dexlfd.motion.smoothing import SmoothingConfig, smooth_keypoints
from dexlfd.rotations import quat_angle

__all__ = ["HAND_APERTURE_MAX_M", "MotionConfig", "demonstration_from_keypoints"]

# widest thumb-tip to index-tip distance of a human hand [m] (a large adult hand spans
# ~0.2 m from thumb to index tip); the gripper channel is clipped to [0, this]
HAND_APERTURE_MAX_M = 0.2

logger = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class MotionConfig:
    """Settings of the motion definition (thesis Section 4.2)."""

    hand: str = "right"  # "right" or "left": sets the rest pose of Eq. (4.11)
    grasp_threshold: float = 0.1  # d_bar [m], thesis Section 4.2.3 (grasp_method="absolute")
    grasp_hysteresis: float = 0.01  # release above threshold + this [m]
    grasp_method: str = "adaptive"  # key of motion.grasp.GRASP_METHODS ("closure": phases)
    grasp_min_duration_s: float = 0.15  # grasp/release states shorter than this are dropped
    max_gap_s: float = 0.1  # interior gaps up to this long are interpolated [s]; 0 = never
    mount: str = "thesis"  # hand-to-gripper rotation, key of motion.definition.MOUNTS
    euler_mode: str = "heading"  # "heading", "thesis" (printed Eq. 4.11), "triad" or "palm"
    smoothing: str = "none"  # keypoint smoothing: "none", "one_euro" or "mean" (smoothing.py)
    phases: PhaseConfig = field(default_factory=PhaseConfig)  # grasp_method "closure"

    def __post_init__(self) -> None:
        if self.hand not in HANDS:
            raise InvalidInput(f"hand must be one of {HANDS}, got {self.hand!r}")
        check_positive(self.grasp_threshold, "grasp_threshold")
        check_positive(self.grasp_hysteresis, "grasp_hysteresis", strict=False)
        check_positive(self.max_gap_s, "max_gap_s", strict=False)
        if self.grasp_method not in GRASP_METHODS:
            raise InvalidInput(
                f"grasp_method must be one of {GRASP_METHODS}, got {self.grasp_method!r}"
            )
        self.grasp_config()  # validates the grasp settings
        SmoothingConfig(method=self.smoothing)
        mount_quat(self.mount)
        if self.euler_mode not in EULER_MODES:
            raise InvalidInput(f"euler_mode must be one of {EULER_MODES}, got {self.euler_mode!r}")

    def grasp_config(self) -> GraspConfig:
        """The :class:`~dexlfd.motion.grasp.GraspConfig` of these settings."""
        return GraspConfig(
            method=self.grasp_method,
            threshold_m=self.grasp_threshold,
            hysteresis_m=self.grasp_hysteresis,
            min_duration_s=self.grasp_min_duration_s,
        )


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def demonstration_from_keypoints(
    t: FloatArray,
    keypoints: FloatArray,
    valid: Any = None,
    cfg: MotionConfig | None = None,
    *,
    meta: Mapping[str, Any] | None = None,
    extras: Mapping[str, np.ndarray] | None = None,
    world_m: FloatArray | None = None,
    frame: str | None = None,
) -> Demonstration:
    """Derive the end-effector motion from a hand keypoint series.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Frame times [s], strictly increasing.
    keypoints : ndarray, shape (n, 21, 3)
        Landmarks in the robot base frame [m]; NaN where the hand was unseen.
    valid : ndarray of bool, shape (n,), optional
        Frames where the hand was seen; default: frames whose wrist, thumb tip and
        index tip are finite.
    cfg : MotionConfig, optional
    meta, extras : mapping, optional
        Carried into the result (``meta["motion"]`` and ``meta["gaps"]`` are added;
        extras gain ``euler`` (n, 3) yaw/pitch/roll [rad], ``interpolated`` (n,) and
        ``aperture_ratio`` (n,), see :func:`~dexlfd.motion.grasp.aperture_ratio`; an
        ``extras["uv_px"]`` (n, 21, 2) is used by it and, with ``grasp_method="closure"``,
        gives the palm's motion; ``phases`` then lists the episodes found,
        :mod:`dexlfd.motion.phases`; an ``extras["depth_std"]`` (n,) [m] is made NaN
        where the pose is not valid and interpolated over filled gaps, an
        ``extras["orientation_set"]`` (n,) False there).
    world_m : ndarray, shape (n, 21, 3), optional
        MediaPipe's world landmarks (not stored): with ``grasp_method="closure"`` the
        finger curl and 3-D aperture read them; default the keypoints (the same
        shape for the RGB lifts, which place the world landmarks rigidly).
    frame : str, optional
        The coordinate frame of the keypoints (the result's ``frame``).

    Returns
    -------
    Demonstration
        ``position``/``quaternion``/``gripper`` NaN exactly where not ``valid``.

    Raises
    ------
    InvalidDemonstration
        When no frame has a hand.
    """
    cfg = cfg or MotionConfig()
    t = check_time(t, "t", min_len=1)
    kp = as_float_array(keypoints, "keypoints", shape=(t.size, 21, 3))
    v = _valid_frames(kp, valid, t.shape)
    kp = np.where(v[:, None, None], kp, np.nan)
    kp, v, filled = fill_short_gaps(t, kp, v, cfg.max_gap_s)
    raw_jitter = jitter_mm(t, kp[:, 0], v)
    # the grasp reads the unsmoothed aperture (it has its own hysteresis and minimum
    # duration; a low-pass would shift the levels and delay every grasp)
    uv = None if extras is None else extras.get("uv_px")
    good_uv = uv is not None and np.shape(uv) == (t.size, 21, 2)
    raw_ratio = aperture_ratio(kp, uv if good_uv else None)
    raw_kp = kp
    kp = smooth_keypoints(t, kp, v, SmoothingConfig(method=cfg.smoothing))
    pose = pose_from_keypoints(kp, cfg.hand, cfg.mount, cfg.euler_mode)
    pose_ok = v & np.isfinite(pose.quaternion).all(axis=1)
    nan = ~pose_ok
    position = np.where(nan[:, None], np.nan, pose.position)
    quaternion = np.where(nan[:, None], np.nan, pose.quaternion)
    gripper = _clip_aperture(np.where(nan, np.nan, pose.gripper))
    ratio = np.where(nan, np.nan, raw_ratio)
    grasp_res, phases_info = _grasp(
        t, raw_kp, pose_ok, gripper, ratio, cfg, extras, world_m, uv if good_uv else None
    )
    gaps = find_gaps(t, pose_ok)
    _warn_gaps(filled, gaps, cfg.max_gap_s, pose_ok)
    _warn_orientation_jumps(quaternion[pose_ok], cfg.euler_mode)
    jitter = (raw_jitter, jitter_mm(t, position, pose_ok))
    full_meta = _motion_meta(meta, cfg, grasp_res.info, gaps, jitter)
    full_extras = dict(extras or {})
    full_extras["euler"] = np.where(nan[:, None], np.nan, pose.euler)
    full_extras["interpolated"] = filled
    full_extras["aperture_ratio"] = ratio
    _per_frame_pose_extras(full_extras, t, pose_ok, filled)
    return Demonstration(
        t=t,
        keypoints=kp,
        valid=pose_ok,
        position=position,
        quaternion=quaternion,
        gripper=gripper,
        grasp=grasp_res.grasp,
        meta=full_meta,
        extras=full_extras,
        frame=frame,
        phases=phases_info,
    )


def _grasp(
    t: FloatArray,
    raw_kp: FloatArray,
    pose_ok: BoolArray,
    gripper: FloatArray,
    ratio: FloatArray,
    cfg: MotionConfig,
    extras: Mapping[str, np.ndarray] | None,
    world_m: FloatArray | None,
    uv: FloatArray | None,
) -> tuple[GraspResult, Phases | None]:
    """The grasp detection, and the phases' description (None unless ``"closure"``).

    ``"closure"``: the closed runs that are grasps are read from the hand's phases
    (:func:`~dexlfd.motion.phases.track_phases`); otherwise from the gripper levels.
    """
    if cfg.grasp_method != "closure":
        return detect_grasp(t, gripper, ratio, cfg.grasp_config()), None
    cue = (extras or {}).get("carry_cue")
    phases, grasp_res = track_phases(
        t, raw_kp, pose_ok, world_m=world_m, uv_px=uv,
        grasp_cfg=cfg.grasp_config(), cfg=cfg.phases,
        carry=None if cue is None or np.shape(cue) != t.shape else np.asarray(cue, float),
    )  # fmt: skip
    return replace(grasp_res, grasp=phases.grasp), phases.describe(t)


def _per_frame_pose_extras(
    extras: dict[str, Any], t: FloatArray, ok: BoolArray, filled: BoolArray
) -> None:
    """``depth_std`` and ``orientation_set`` (if in ``extras``) made to match ``ok``, in place.

    ``depth_std`` [m] is NaN where the pose is not valid; a valid frame without one (a
    filled gap outside the estimate's span) gets it interpolated in time from the
    others. ``orientation_set`` is False where not valid and on filled frames.
    """
    if "depth_std" in extras:
        std = np.asarray(extras["depth_std"], dtype=np.float64)
        if std.shape != t.shape:
            raise InvalidInput(f"extras['depth_std'] must have shape {t.shape}, got {std.shape}")
        have = np.isfinite(std) & ok
        if have.any():
            std = np.where(ok & ~have, np.interp(t, t[have], std[have]), std)
        extras["depth_std"] = np.where(ok & np.isfinite(std), std, np.nan)
        if (ok & ~np.isfinite(extras["depth_std"])).any():
            del extras["depth_std"]  # none to carry: the contract wants it where valid
    if "orientation_set" in extras:
        flag = np.asarray(extras["orientation_set"], dtype=bool)
        if flag.shape != t.shape:
            raise InvalidInput(
                f"extras['orientation_set'] must have shape {t.shape}, got {flag.shape}"
            )
        extras["orientation_set"] = flag & ok & ~filled


def _motion_meta(
    meta: Mapping[str, Any] | None,
    cfg: MotionConfig,
    grasp_info: dict[str, Any],
    gaps: list[Gap],
    jitter_mm_before_after: tuple[float, float],
) -> dict[str, Any]:
    """``meta`` with how the motion was made: settings, grasp, smoothing, gaps, units."""
    before, after = jitter_mm_before_after
    full_meta = dict(meta or {})
    full_meta["motion"] = {
        **asdict(cfg),
        "definition": "thesis Sec. 4.2: wrist (4.10), atan2 Euler (4.11), "
        "H_x(phi)H_y(theta)H_z(psi)*mount, gripper (4.14)",
    }
    full_meta["grasp"] = grasp_info
    full_meta["smoothing"] = {
        "method": cfg.smoothing,
        "wrist_jitter_before_mm": _finite_or_none(before),
        "wrist_jitter_after_mm": _finite_or_none(after),
    }
    full_meta["gaps"] = [
        {"start": g.start, "stop": g.stop, "duration_s": g.duration_s, "interior": g.interior}
        for g in gaps
    ]
    full_meta.setdefault("units", {"t": "s", "keypoints": "m", "position": "m", "gripper": "m"})
    return full_meta


def _valid_frames(kp: FloatArray, valid: Any, shape: tuple[int, ...]) -> BoolArray:
    """Frames with a hand: ``valid`` checked against the keypoints, or where they are finite."""
    if np.isinf(kp).any():
        raise InvalidInput("keypoints must not contain inf")
    needed = cast(BoolArray, np.isfinite(kp[:, [0, 4, 8]]).all(axis=(1, 2)))
    if valid is None:
        v = needed
    else:
        v = np.asarray(valid, dtype=bool)
        if v.shape != shape:
            raise InvalidInput(f"valid must have shape {shape}, got {v.shape}")
        if (v & ~needed).any():
            i = int(np.argmax(v & ~needed))
            raise InvalidInput(f"keypoints[{i}] has NaN wrist/thumb/index where valid is true")
    if not v.any():
        raise InvalidDemonstration(f"no hand in any of the {shape[0]} frames")
    return v


def _clip_aperture(gripper: FloatArray) -> FloatArray:
    """The thumb-index distance [m] clipped to a human hand's range (warned)."""
    too_wide = gripper > HAND_APERTURE_MAX_M
    if not too_wide.any():
        return gripper
    logger.warning(
        "thumb-index distance above a hand's range (%.2f m) in %d frame(s), max %.2f m: "
        "clipped (a wrong metric scale? check the camera intrinsics and depth)",
        HAND_APERTURE_MAX_M,
        int(too_wide.sum()),
        float(np.nanmax(gripper)),
    )
    return np.where(too_wide, HAND_APERTURE_MAX_M, gripper)


def _warn_gaps(filled: BoolArray, gaps: list[Gap], max_gap_s: float, ok: BoolArray) -> None:
    """Log the frames interpolated, the interior gaps left as NaN, and a hand often missing."""
    if filled.any():
        logger.info("interpolated %d frame(s) in gaps <= %.3f s", int(filled.sum()), max_gap_s)
    for g in gaps:
        if g.interior:
            period = g.duration_s / (g.n_frames + 1)  # interior: seen frame to seen frame
            logger.warning(
                "no hand in %s (%.3f s): left as NaN (%.3f s between the seen frames around "
                "it, longer than max_gap_s=%.3f s)",
                f"frame {g.start}" if g.n_frames == 1 else f"frames {g.start}-{g.stop - 1}",
                g.n_frames * period,
                g.duration_s,
                max_gap_s,
            )
    missing = 1.0 - (ok & ~filled).mean()  # not detected (interpolated ones too)
    if missing > 0.1:
        logger.warning("hand not detected in %.1f %% of frames", 100 * missing)


def _warn_orientation_jumps(q_ok: FloatArray, euler_mode: str) -> None:
    """Warn about steps of more than 90 deg between consecutive valid orientations.

    The cause named depends on ``euler_mode``: ``"palm"`` is the rigid palm frame
    (wrist, index and little-finger bases), so a jump there is the hand or its
    tracking, never the fingers; the other modes read the thumb and index tips, and
    ``"palm"`` is the one to suggest (on the shared real video its largest step is
    12 deg against 163-173 deg for the fingertip modes, docs/capture.md).
    """
    if q_ok.shape[0] < 2:
        return
    step = np.degrees(quat_angle(q_ok[1:], q_ok[:-1]))
    n_jumps = int((step > 90).sum())
    if not n_jumps:
        return
    if euler_mode == "palm":
        why = (
            "the palm frame (wrist, index and little-finger bases) turned that far in one "
            "frame: a fast swing of the hand, or landmarks of a badly seen hand"
        )
    else:
        why = (
            f"euler_mode {euler_mode} reads the thumb and index tips, so finger motion "
            "turns it; euler_mode palm uses the rigid palm instead"
        )
        if euler_mode in ("heading", "thesis"):
            why += " (and Eq. (4.11)'s angles are singular at a vertical thumb-index vector)"
    logger.warning(
        "orientation jumps by more than 90 deg between consecutive frames %d time(s) "
        "(max %.0f deg): %s",
        n_jumps,
        step.max(),
        why,
    )
