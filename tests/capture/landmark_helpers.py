"""Synthetic landmark recordings with a known answer: a rigid hand seen by a pinhole camera."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dexlfd.capture import Intrinsics


def hand_template() -> np.ndarray:
    """A rigid, non-planar 21-point hand [m], wrist at the origin, fingers along -y."""
    pts = [(0.0, 0.0, 0.0)]
    # thumb: out to the side and forward
    pts += [(-0.025 - 0.015 * k, -0.02 - 0.012 * k, -0.01 - 0.004 * k) for k in range(4)]
    for x, length in ((-0.02, 0.07), (0.0, 0.078), (0.02, 0.072), (0.037, 0.058)):
        base_y = -0.085
        for k in range(4):
            pts.append((x, base_y - k * length / 3.0, -0.006 * k + 0.004 * (x > 0)))
    return np.asarray(pts)


def synthetic_recording(
    path: Path,
    n: int = 60,
    size: tuple[int, int] = (640, 480),
    hfov_deg: float = 60.0,
    fps: float = 30.0,
    with_meta: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Write a landmark recording of one hand translating (no rotation) in front of an
    ideal camera; return (wrist positions (n, 3) in the camera frame [m], t (n,))."""
    from dexlfd.capture.landmark_recording import LandmarkRecording, save_landmark_recording

    K = Intrinsics.from_fov(size[0], size[1], hfov_deg)
    hand = hand_template()
    t = np.arange(n) / fps
    s = np.linspace(0.0, 1.0, n)
    wrist = np.stack([-0.15 + 0.3 * s, 0.05 + 0.05 * np.sin(np.pi * s), 0.6 + 0.2 * s], axis=1)
    image = np.full((n, 2, 21, 3), np.nan)
    world = np.full((n, 2, 21, 3), np.nan)
    labels = np.full((n, 2), -1, np.int8)
    scores = np.full((n, 2), np.nan)
    for i in range(n):
        p = hand + wrist[i]
        u = K.fx * p[:, 0] / p[:, 2] + K.cx + 0.5  # corner convention (camera_models)
        v = K.fy * p[:, 1] / p[:, 2] + K.cy + 0.5
        image[i, 0, :, 0] = u / size[0]
        image[i, 0, :, 1] = v / size[1]
        image[i, 0, :, 2] = (p[:, 2] - p[0, 2]) / 0.5
        world[i, 0] = hand - hand[9]  # MediaPipe's world landmarks are hand-centred
        labels[i, 0] = 0  # MediaPipe's "Left" on an unmirrored image: the person's right
        scores[i, 0] = 0.95
    arrays = {
        "t_s": t,
        "image_xyz": image,
        "world_xyz_m": world,
        "label_selfie": labels,
        "label_score": scores,
        "frame_size_px": np.array(size, dtype=np.int64),
    }
    if with_meta:
        save_landmark_recording(path, LandmarkRecording(**arrays, meta={"note": "synthetic"}))
    else:
        np.savez(path, **arrays)  # as another program would write it: no meta
    return wrist, t
