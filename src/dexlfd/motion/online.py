"""Per-frame motion for teleoperation and capture-to-demonstration conversion.

:class:`OnlineMotion` turns one frame into the end-effector command as it
arrives (keypoints -> position, quaternion, gripper, grasp), keeping the state
a stream needs: the last quaternion (sign continuity), the last Euler angles
(unwrapping) and the grasp hysteresis. A stream has no whole series to read
adaptive grasp levels or phases from, so ``grasp_method="adaptive"`` and
``"closure"`` fall back to the fixed aperture-ratio thresholds (``"ratio"``) here;
``smoothing="one_euro"`` filters the keypoints as they come (``"mean"`` needs future
frames and is not applied online).
:func:`demonstration_from_capture` converts a whole :class:`~dexlfd.capture.KeypointSeries`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io import Demonstration
from dexlfd.io.demonstration_facts import Capture, split_table
from dexlfd.motion.definition import pose_from_keypoints
from dexlfd.motion.demonstration import (
    HAND_APERTURE_MAX_M,
    MotionConfig,
    demonstration_from_keypoints,
)
from dexlfd.motion.grasp import aperture_ratio
from dexlfd.motion.smoothing import OneEuroFilter, SmoothingConfig

if TYPE_CHECKING:
    from dexlfd.capture import Frame, FrameKeypoints, HandCapture, KeypointSeries

__all__ = ["OnlineMotion", "OnlinePose", "demonstration_from_capture"]


@dataclass(frozen=True, slots=True)
class OnlinePose:
    """End-effector command for one frame (NaN and ``valid=False`` without a hand)."""

    t: float  # [s]
    valid: bool
    position: FloatArray  # (3,) [m]
    quaternion: FloatArray  # (4,) x, y, z, w
    euler: FloatArray  # (3,) yaw, pitch, roll [rad], unwrapped along the stream
    gripper: float  # [m]
    grasp: bool
    keypoints: FrameKeypoints


class OnlineMotion:
    """Frame in, pose out: ``OnlineMotion(capture, cfg).process(frame) -> OnlinePose``."""

    def __init__(self, capture: HandCapture, cfg: MotionConfig | None = None) -> None:
        self.capture = capture
        self.cfg = cfg or MotionConfig()
        self._last_q: FloatArray | None = None
        self._last_euler: FloatArray | None = None
        self._grasp = False
        # "one_euro" smooths the keypoints online; "mean" needs future frames: not online
        self._filter = (
            OneEuroFilter(SmoothingConfig()) if self.cfg.smoothing == "one_euro" else None
        )

    def process(self, frame: Frame) -> OnlinePose:
        """Track, lift and define the motion of one frame."""
        kp = self.capture.process(frame)
        nan3 = np.full(3, np.nan)
        if not kp.valid:
            if self._filter is not None:
                self._filter.reset()  # nothing is carried across a gap
            return OnlinePose(
                frame.t, False, nan3, np.full(4, np.nan), nan3, float("nan"), self._grasp, kp
            )
        points = kp.keypoints
        if self._filter is not None:
            points = self._filter.filter(points, frame.t)
        pose = pose_from_keypoints(points, self.cfg.hand, self.cfg.mount, self.cfg.euler_mode)
        euler = pose.euler
        if self._last_euler is not None:  # unwrap against the previous frame
            euler = euler - 2 * np.pi * np.round((euler - self._last_euler) / (2 * np.pi))
        q = pose.quaternion
        if self._last_q is not None and float(q @ self._last_q) < 0:
            q = -q
        g = min(float(pose.gripper), HAND_APERTURE_MAX_M)
        gc = self.cfg.grasp_config()
        if gc.method == "absolute":
            x, on, off = g, gc.threshold_m, gc.threshold_m + gc.hysteresis_m
        else:  # a stream has no whole series for adaptive levels: fixed ratio thresholds
            x = float(aperture_ratio(kp.keypoints, kp.uv_px))  # unsmoothed, as offline
            on, off = gc.ratio_threshold, gc.ratio_threshold + gc.ratio_hysteresis
        if x < on:
            self._grasp = True
        elif x > off:
            self._grasp = False
        self._last_q, self._last_euler = q, euler
        return OnlinePose(frame.t, True, pose.position, q, euler, g, self._grasp, kp)


def _frame_name(camera2base: Any) -> str:
    """``panda_base`` when extrinsics were applied, else the camera frame (stated)."""
    if camera2base is None or np.allclose(np.asarray(camera2base, dtype=float), np.eye(4)):
        return "camera (no extrinsics: x right, y down, z forward)"
    return "panda_base"


def demonstration_from_capture(
    series: KeypointSeries,
    cfg: MotionConfig | None = None,
    meta: dict[str, Any] | None = None,
) -> Demonstration:
    """A :class:`Demonstration` from captured keypoints, with the capture's info kept.

    ``extras`` gain ``confidence`` (n,), ``handedness`` (n,) int8 (1 right, -1 left,
    0 none), ``n_hands`` (n,), ``uv_px`` (n, 21, 2), ``detected`` (n,) (tracker
    found the hand, before gap filling) and ``depth_filled`` (n,), and, when the series
    has them (the whole-recording pose estimate), ``depth_std`` (n,) [m] and
    ``orientation_set`` (n,), and ``carry_cue`` (n,) (pixels moving with the hand, read by
    the phases); ``meta["capture"]`` holds the source and lifting settings.
    """
    extras = {
        "confidence": series.score,
        "handedness": series.handedness,
        "n_hands": series.n_hands,
        "uv_px": series.uv_px,
        "detected": series.valid,
        "depth_filled": series.depth_filled,
    }
    if series.depth_std is not None:
        extras["depth_std"] = series.depth_std
    if series.orientation_set is not None:
        extras["orientation_set"] = series.orientation_set
    carry = getattr(series, "carry", None)
    if carry is not None:
        extras["carry_cue"] = np.asarray(carry)
    typed = {
        "fps": series.fps,
        "image_size": series.image_size,
        "hand_choice": None if series.hand_choice is None else series.hand_choice.to_json(),
    }
    capture, provenance = split_table(Capture, {**series.meta, **typed}, "capture")
    full_meta = {
        "source": series.meta.get("source", "capture"),
        "capture": provenance,
        "detection_rate": series.detection_rate,
        **(meta or {}),
    }
    world = getattr(series, "world_m", None)  # MediaPipe's world landmarks, when kept
    demo = demonstration_from_keypoints(
        series.t, series.keypoints, series.valid, cfg, meta=full_meta, extras=extras,
        world_m=world, frame=_frame_name(series.camera2base),
    )  # fmt: skip
    return replace(demo, capture=capture)
