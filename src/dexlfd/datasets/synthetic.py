"""Seeded synthetic pick-and-place demonstrations (clearly labelled synthetic).

A hand picks a sponge-like object at ``pick`` and places it at ``place``,
passing over a cup between them. Each demonstration has its own duration, a
smooth monotone time warp, a small spatial offset of the via points and
sensor-like noise, like several human demonstrations of the same task.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io import Demonstration
from dexlfd.rotations import quat_multiply, quat_normalize, quat_sign_continuous
from dexlfd.trajectory import minimum_jerk

__all__ = ["PickPlaceConfig", "pick_place_demonstrations", "pick_place_reference"]

# gripper pointing down: 180 deg about base x, scalar-last
_Q_DOWN = np.array([1.0, 0.0, 0.0, 0.0])


@dataclass(frozen=True, slots=True)
class PickPlaceConfig:
    """Task geometry and variability of the synthetic demonstrations."""

    pick: tuple[float, float, float] = (0.45, -0.25, 0.12)  # object [m], base frame
    place: tuple[float, float, float] = (0.45, 0.25, 0.12)  # target [m]
    lift_height: float = 0.30  # height gained over the cup [m]
    open_width: float = 0.08  # gripper opening before/after the grasp [m]
    object_width: float = 0.04  # opening while holding the sponge [m]
    yaw_swing: float = 0.35  # yaw change along the carry [rad]
    duration_range: tuple[float, float] = (5.0, 10.0)  # [s]
    rate_hz: float = 30.0
    warp_strength: float = 0.25  # 0: uniform timing; < 0.5 keeps the warp monotone
    via_jitter: float = 0.02  # std of via-point offsets between demos [m]
    position_noise: float = 0.002  # sensor noise std [m]
    angle_noise: float = 0.01  # orientation noise std [rad]
    gripper_noise: float = 0.001  # [m]
    extra: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        lo, hi = self.duration_range
        if not 0 < lo <= hi:
            raise InvalidInput(
                f"duration_range must satisfy 0 < lo <= hi, got {self.duration_range}"
            )
        if not 0 <= self.warp_strength < 0.5:
            raise InvalidInput(f"warp_strength must be in [0, 0.5), got {self.warp_strength}")
        if self.rate_hz <= 0:
            raise InvalidInput(f"rate_hz must be > 0, got {self.rate_hz}")


def pick_place_reference(
    phase: FloatArray, cfg: PickPlaceConfig, offset: FloatArray | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Noise-free task at phase ``phase`` in [0, 1].

    Returns position (n, 3) [m], quaternion (n, 4) and gripper opening (n,) [m].
    Segments: approach (0-0.2), grasp (0.2-0.3), lift-carry-lower (0.3-0.8),
    release (0.8-0.9), retreat (0.9-1).
    """
    s = np.asarray(phase, dtype=np.float64)
    off = np.zeros(4) if offset is None else np.asarray(offset, dtype=np.float64)
    pick = np.asarray(cfg.pick)
    place = np.asarray(cfg.place)
    above = np.array([0.0, 0.0, 0.10])
    start = pick + above + np.array([-0.05, -0.05, 0.05]) + off[:3] * np.array([1, 1, 0.5])
    end = place + above + np.array([-0.05, 0.05, 0.05])

    pos = np.empty((s.size, 3))
    seg = [(0.0, 0.2), (0.2, 0.3), (0.3, 0.8), (0.8, 0.9), (0.9, 1.0)]
    for k, (a, b) in enumerate(seg):
        m = (s >= a) & (s <= b) if k == len(seg) - 1 else (s >= a) & (s < b)
        u = minimum_jerk((s[m] - a) / (b - a))[0]
        if k == 0:
            pos[m] = start + (pick - start) * u[:, None]
        elif k == 1:
            pos[m] = pick
        elif k == 2:
            horizontal = pick + (place - pick) * u[:, None]
            bump = (cfg.lift_height + off[3]) * np.sin(np.pi * u) ** 2
            pos[m] = horizontal + bump[:, None] * np.array([0.0, 0.0, 1.0])
        elif k == 3:
            pos[m] = place
        else:
            pos[m] = place + (end - place) * u[:, None]

    carry = minimum_jerk((s - 0.3) / 0.5)[0]
    yaw = cfg.yaw_swing * carry
    q_yaw = np.stack([np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2), np.cos(yaw / 2)], 1)
    quat = quat_multiply(q_yaw, _Q_DOWN)

    close = minimum_jerk((s - 0.2) / 0.08)[0]
    reopen = minimum_jerk((s - 0.8) / 0.08)[0]
    grip = cfg.open_width + (cfg.object_width - cfg.open_width) * (close - reopen)
    return pos, quat_sign_continuous(quat), grip


def pick_place_demonstrations(
    n_demos: int, rng: np.random.Generator, cfg: PickPlaceConfig | None = None
) -> list[Demonstration]:
    """Generate ``n_demos`` synthetic pick-and-place demonstrations.

    Parameters
    ----------
    n_demos : int
        Number of demonstrations, >= 1.
    rng : numpy.random.Generator
        Source of all randomness (durations, warps, offsets, noise).
    cfg : PickPlaceConfig, optional
        Task geometry and variability.

    Returns
    -------
    list of Demonstration
        With ``meta["source"] == "synthetic"``; keypoints are NaN (pose-level
        data: no hand was simulated), ``valid`` is all true.
    """
    cfg = cfg or PickPlaceConfig()
    if int(n_demos) < 1:
        raise InvalidInput(f"n_demos must be >= 1, got {n_demos}")
    demos = []
    for i in range(int(n_demos)):
        duration = rng.uniform(*cfg.duration_range)
        n = max(2, int(round(duration * cfg.rate_hz)))
        t = np.arange(n) / cfg.rate_hz
        u = t / t[-1]
        # monotone warp: u + a sin(2 pi u)/(2 pi) has derivative 1 + a cos(.) > 0 for |a| < 1
        a1, a2 = rng.uniform(-1, 1, 2) * cfg.warp_strength
        phase = (
            u + a1 * np.sin(2 * np.pi * u) / (2 * np.pi) + a2 * np.sin(4 * np.pi * u) / (4 * np.pi)
        )
        offset = rng.normal(0.0, cfg.via_jitter, 4)
        pos, quat, grip = pick_place_reference(phase, cfg, offset)
        pos = pos + rng.normal(0.0, cfg.position_noise, pos.shape)
        dq = np.concatenate([rng.normal(0.0, cfg.angle_noise / 2, (n, 3)), np.ones((n, 1))], 1)
        quat = quat_sign_continuous(quat_normalize(quat_multiply(quat_normalize(dq), quat)))
        grip = np.clip(grip + rng.normal(0.0, cfg.gripper_noise, n), 0.0, None)
        demos.append(
            Demonstration(
                t=t,
                keypoints=np.full((n, 21, 3), np.nan),
                valid=np.ones(n, bool),
                position=pos,
                quaternion=quat,
                gripper=grip,
                grasp=grip < (cfg.open_width + cfg.object_width) / 2,
                meta={
                    "source": "synthetic",
                    "generator": "dexlfd.datasets.pick_place_demonstrations",
                    "index": i,
                    "units": {"t": "s", "position": "m", "gripper": "m"},
                    "note": "SYNTHETIC pick-and-place demonstration, not a recording",
                },
                frame="panda_base",
            )
        )
    return demos
