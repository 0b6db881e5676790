"""Offscreen MP4 of a rollout replayed in the MuJoCo scene.

Needs an OpenGL context: on a machine without a display set ``MUJOCO_GL=egl``
(Mesa's llvmpipe works) before MuJoCo is imported. Frames are written with
OpenCV's ``mp4v`` codec.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from dexlfd.errors import DependencyNotInstalled, InvalidFile, InvalidInput
from dexlfd.io import Rollout
from dexlfd.robot.sim import PandaSim, PlantConfig

__all__ = ["render_rollout_video"]

logger = logging.getLogger(__name__)


def render_rollout_video(
    rollout: Rollout,
    plant: PlantConfig,
    path: str | os.PathLike[str],
    *,
    fps: float = 30.0,
    width: int = 640,
    height: int = 480,
    callback: Callable[[int, float], None] | None = None,
) -> Path:
    """Replay ``rollout`` (joints, gripper, object pose) and write an MP4 at ``fps``.

    Returns the written path. Raises :class:`InvalidFile` if the video cannot be
    written and :class:`DependencyNotInstalled` without OpenCV.
    """
    try:
        import cv2
    except ImportError as exc:  # pragma: no cover
        raise DependencyNotInstalled("opencv-contrib-python", "writing MP4 videos") from exc
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidInput(f"fps must be > 0, got {fps!r}")
    out = Path(path)
    n_frames = max(1, int(np.floor((rollout.t[-1] - rollout.t[0]) * fps)) + 1)
    idx = np.searchsorted(rollout.t, rollout.t[0] + np.arange(n_frames) / fps)
    idx = np.clip(idx, 0, rollout.n_samples - 1)
    pos = rollout.extras.get("payload_position")
    quat = rollout.extras.get("payload_quaternion")
    fourcc = cv2.VideoWriter_fourcc(*"mp4v")  # type: ignore[attr-defined]
    writer = cv2.VideoWriter(str(out), fourcc, fps, (width, height))
    if not writer.isOpened():
        raise InvalidFile(f"cannot write video {out} (OpenCV VideoWriter failed)")
    try:
        payload_at = None
        if pos is not None and quat is not None:
            from dexlfd.rotations import matrix_from_quat

            payload_at = (pos[0], matrix_from_quat(quat[0]))
        with PandaSim(plant, rollout.q[0], payload_at=payload_at) as sim:
            for i, k in enumerate(idx):
                payload = None if pos is None or quat is None else (pos[k], quat[k])
                sim.set_pose(rollout.q[k], float(rollout.gripper[k]), payload)
                frame = sim.render(width, height)
                writer.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
                if callback is not None:
                    callback(i, float(rollout.t[k]))
    finally:
        writer.release()
    logger.info("wrote %s (%d frames at %g fps)", out, n_frames, fps)
    return out
