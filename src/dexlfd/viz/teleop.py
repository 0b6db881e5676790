"""Side-by-side teleoperation video: the hand with its skeleton | the simulated robot.

:class:`SideBySideVideo` is a ``run_teleop`` ``on_frame`` callback that renders
the robot offscreen (MuJoCo; ``MUJOCO_GL=egl`` without a display) after each
camera frame's interval and writes both halves to an H.264 MP4 through
:class:`~dexlfd.viz.video.VideoWriter` (atomic: a failed run leaves no file).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from dexlfd.errors import InvalidInput
from dexlfd.viz.capture import draw_skeleton
from dexlfd.viz.video import VideoWriter

__all__ = ["SideBySideVideo", "side_by_side"]


def side_by_side(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """``left`` scaled to ``right``'s height (aspect kept) beside ``right``; RGB uint8."""
    import cv2

    h = right.shape[0]
    w = max(2, int(round(left.shape[1] * h / left.shape[0])))
    if left.shape[:2] != (h, w):
        left = cv2.resize(left, (w, h), interpolation=cv2.INTER_AREA)
    return np.concatenate([left, right], axis=1)


class SideBySideVideo:
    """Write one side-by-side frame per camera frame (use as a context manager).

    Parameters
    ----------
    path : path-like
        Output ``.mp4``.
    fps : float
        Camera frame rate [Hz] (the video plays at the camera's speed).
    width, height : int
        Size of the robot render [px]; the camera frame is scaled to ``height``.
    camera : dict, optional
        Render camera (see :meth:`dexlfd.robot.sim.PandaSim.render`).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        fps: float,
        width: int = 480,
        height: int = 360,
        camera: dict[str, float] | None = None,
    ) -> None:
        if width < 16 or height < 16:
            raise InvalidInput(f"render size must be at least 16x16 px, got {width}x{height}")
        self.writer = VideoWriter(path, fps)
        self.size = (int(width), int(height))
        self.camera = camera

    def __call__(self, step: Any, sim: Any) -> None:
        """``run_teleop`` callback: draw the hand, render the robot, append."""
        pose = step.pose
        kp = pose.keypoints
        label = (
            f"t={step.frame.t:.2f}s  {kp.handedness} {kp.score:.2f}"
            if pose.valid
            else f"t={step.frame.t:.2f}s  no hand: holding"
        )
        uv = kp.uv_px if kp.n_hands else np.full((21, 2), np.nan)
        hand = draw_skeleton(step.frame.rgb, uv, label)
        robot = sim.render(*self.size, camera=self.camera)
        self.writer.write(side_by_side(hand, robot))

    @property
    def n_frames(self) -> int:
        """Frames written so far."""
        return self.writer.n_frames

    def close(self, ok: bool = True) -> Any:
        """Finish (``ok``) or discard the file."""
        return self.writer.close(ok=ok)

    def __enter__(self) -> SideBySideVideo:
        return self

    def __exit__(self, exc_type: object, *rest: object) -> None:
        self.close(ok=exc_type is None)
