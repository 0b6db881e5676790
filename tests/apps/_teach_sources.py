"""Synthetic teach sources: pick-and-place demonstrations filmed by a known camera.

The seeded synthetic pick-and-places (base frame, with a synthetic hand) are moved into
the frame of a camera at a known pose, as an uncalibrated recording would give them:
the task frame estimated from them can be checked against the true camera.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

CAMERA_PITCH_DEG = 45.0  # looking down at the table
CAMERA_POSITION = (-0.35, 0.05, 0.65)  # [m], base frame: behind the robot's base, above it


def camera_to_base(pitch_deg: float = CAMERA_PITCH_DEG) -> np.ndarray:
    """A camera looking along base +x, pitched down by ``pitch_deg`` (x right, y down)."""
    s, c = np.sin(np.radians(pitch_deg)), np.cos(np.radians(pitch_deg))
    z_b = np.array([c, 0.0, -s])  # optical axis
    x_b = np.array([0.0, -1.0, 0.0])  # image right
    y_b = np.cross(z_b, x_b)  # image down
    T = np.eye(4)
    T[:3, :3] = np.stack([x_b, y_b, z_b], axis=1)
    T[:3, 3] = CAMERA_POSITION
    return T


def write_camera_demos(
    folder: Path, n: int = 4, seed: int = 0, source: str = "cam-A"
) -> list[Path]:
    """``n`` synthetic pick-and-places in the camera frame, as demonstration files."""
    from dataclasses import replace

    from dexlfd.datasets import demonstration_with_hand, pick_place_demonstrations
    from dexlfd.io import save_demonstration
    from dexlfd.motion.task_frame import apply_frame

    rng = np.random.default_rng(seed)
    base2cam = np.linalg.inv(camera_to_base())
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, demo in enumerate(pick_place_demonstrations(n, rng)):
        demo = demonstration_with_hand(demo, rng)
        cam = apply_frame(
            demo, base2cam, frame_name="camera (no extrinsics: x right, y down, z forward)"
        )
        cam = replace(cam, meta={**cam.meta, "source": source})
        paths.append(save_demonstration(folder / f"take_{i}.npz", cam))
    return paths
