"""Hand keypoints in the robot base frame: one frame's and a whole source's.

:class:`FrameKeypoints` is what :class:`~dexlfd.capture.HandCapture` gives per frame,
:class:`KeypointSeries` what :func:`~dexlfd.capture.track_source` gives for a source
(time axis first), ready for :func:`dexlfd.motion.demonstration_from_capture`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd.capture.tracking import HandObservation
from dexlfd.io.demonstration_facts import HandChoice

__all__ = ["HANDEDNESS_CODE", "FrameKeypoints", "KeypointSeries", "no_hand", "series_from_rows"]

HANDEDNESS_CODE = {"right": 1, "left": -1}


@dataclass(frozen=True, slots=True)
class FrameKeypoints:
    """Result of one frame: base-frame landmarks (NaN if no hand) and tracker info."""

    t: float
    keypoints: FloatArray  # (21, 3) [m], base frame
    valid: bool
    uv_px: FloatArray  # (21, 2) [px]
    score: float  # handedness confidence, NaN without a hand
    handedness: str  # "right", "left" or "" without a hand
    n_hands: int
    depth_filled: int  # landmarks whose depth was filled from the others
    observation: HandObservation | None = None


@dataclass(frozen=True, slots=True)
class KeypointSeries:
    """Keypoints of a whole source (time axis first) and how they were made.

    ``world_m`` holds the tracker's world landmarks where it gave them (RGB-only
    lifts use them); ``depth_std`` and ``orientation_set`` are set by the
    whole-recording pose estimate
    (:func:`~dexlfd.capture.recording_pose.series_with_recording_pose`). The facts
    later stages read are typed fields (``fps``, ``image_size``, ``hand_choice``,
    ``camera2base``; None: not known); ``meta`` holds provenance (the source, the
    tracker's and the lifting's settings and reports).
    """

    t: FloatArray  # (n,) [s]
    keypoints: FloatArray  # (n, 21, 3) [m], base frame, NaN where unseen
    valid: BoolArray  # (n,)
    uv_px: FloatArray  # (n, 21, 2) [px]
    score: FloatArray  # (n,) handedness confidence
    handedness: np.ndarray  # (n,) int8: 1 right, -1 left, 0 none
    n_hands: np.ndarray  # (n,) int
    depth_filled: np.ndarray  # (n,) int
    meta: dict[str, Any]
    world_m: FloatArray | None = None  # (n, 21, 3) [m] MediaPipe world landmarks, NaN unseen
    depth_std: FloatArray | None = None  # (n,) [m] depth uncertainty (whole-recording pose)
    orientation_set: BoolArray | None = None  # (n,) the frame's own fit set the orientation
    carry: FloatArray | None = None  # (n,) pixels moving with the hand (capture.carry_cue)
    fps: float | None = None  # [frame/s] the source's frame rate
    image_size: tuple[int, int] | None = None  # (width, height) [px] of the tracked frames
    hand_choice: HandChoice | None = None  # which tracked hand was kept and why
    camera2base: FloatArray | None = None  # (4, 4) the extrinsics the keypoints were put with

    @property
    def detection_rate(self) -> float:
        """Fraction of frames with a hand."""
        return float(self.valid.mean()) if self.valid.size else 0.0

    @property
    def majority_hand(self) -> str:
        """The hand seen most often ("right" if none)."""
        return "left" if (self.handedness == -1).sum() > (self.handedness == 1).sum() else "right"


def no_hand(t: float) -> FrameKeypoints:
    """The result of a frame at ``t`` [s] without a hand (NaN keypoints, not valid)."""
    return FrameKeypoints(
        t, np.full((21, 3), np.nan), False, np.full((21, 2), np.nan), math.nan, "", 0, 0
    )


def series_from_rows(
    rows: Sequence[FrameKeypoints], meta: dict[str, Any], **facts: Any
) -> KeypointSeries:
    """Per-frame results stacked along time into a :class:`KeypointSeries`.

    ``meta`` is its provenance, ``facts`` its typed fields (``fps``, ``image_size``,
    ``hand_choice``, ``camera2base``).
    """
    return KeypointSeries(
        t=np.array([r.t for r in rows]),
        keypoints=np.stack([r.keypoints for r in rows]),
        valid=np.array([r.valid for r in rows]),
        uv_px=np.stack([r.uv_px for r in rows]),
        score=np.array([r.score for r in rows]),
        handedness=np.array([HANDEDNESS_CODE.get(r.handedness, 0) for r in rows], np.int8),
        n_hands=np.array([r.n_hands for r in rows]),
        depth_filled=np.array([r.depth_filled for r in rows]),
        meta=meta,
        world_m=_world_rows(rows),
        carry=_carry_rows(rows),
        **facts,
    )


def _carry_rows(rows: Sequence[FrameKeypoints]) -> FloatArray | None:
    """The rows' carry cue ``(n,)`` (NaN where unmeasured), None if no row has one."""
    cue = np.array(
        [math.nan if r.observation is None else float(r.observation.carry) for r in rows]
    )
    return cue if np.isfinite(cue).any() else None


def _world_rows(rows: Sequence[FrameKeypoints]) -> FloatArray | None:
    """The rows' world landmarks ``(n, 21, 3)`` (NaN without one), None if no row has any."""
    if not any(r.observation is not None for r in rows):
        return None
    nan = np.full((21, 3), np.nan)
    return np.stack(
        [nan if r.observation is None else np.asarray(r.observation.world_m, float) for r in rows]
    )
