"""Collecting a tracker's output, frame by frame, into a landmark recording.

:class:`LandmarkLog` is what ``record --save-landmarks`` fills while the video is
tracked; its :meth:`LandmarkLog.recording` is the
:class:`~dexlfd.capture.landmark_recording.LandmarkRecording` that is saved and
replayed later.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.camera_models import Intrinsics
from dexlfd.capture.landmark_recording import N_LANDMARKS, LandmarkRecording, selfie_code
from dexlfd.capture.tracking import HandObservation
from dexlfd.errors import InvalidInput

__all__ = ["LandmarkLog"]


@dataclass
class LandmarkLog:
    """Collects a tracker's output frame by frame into a :class:`LandmarkRecording`.

    ``add`` once per tracked frame (the time, every hand found, the frame's size);
    ``recording`` stacks them (slots: the most hands seen in one frame, at least 2).
    """

    mirrored: bool = False
    times: list[float] = field(default_factory=list)
    hands: list[list[HandObservation]] = field(default_factory=list)
    size: tuple[int, int] | None = None
    depths: dict[int, list[FloatArray]] = field(default_factory=dict)  # frame -> per hand

    def add_depth(self, depths: Sequence[FloatArray]) -> None:
        """The depth [m] at each landmark of the last frame's hands (its tracker order)."""
        if not self.times or len(depths) != len(self.hands[-1]):
            raise InvalidInput("landmark recording: depths must follow the frame's hands")
        self.depths[len(self.times) - 1] = [np.asarray(d, dtype=np.float64) for d in depths]

    def add(self, t: float, hands: Sequence[HandObservation], size_px: tuple[int, int]) -> None:
        """One tracked frame: time [s], the hands in tracker order, ``(width, height)``."""
        if self.size is None:
            self.size = (int(size_px[0]), int(size_px[1]))
        elif self.size != tuple(size_px):
            raise InvalidInput(
                f"landmark recording: frames change size ({self.size} -> {tuple(size_px)})"
            )
        self.times.append(float(t))
        self.hands.append(list(hands))

    def recording(
        self,
        camera_motion: FloatArray | None = None,
        meta: dict[str, Any] | None = None,
        *,
        native_size_px: tuple[int, int] | None = None,
        intrinsics: Intrinsics | None = None,
    ) -> LandmarkRecording:
        """The frames added so far as a :class:`LandmarkRecording` (with those facts)."""
        n = len(self.times)
        if n == 0 or self.size is None:
            raise InvalidInput("landmark recording: no frame was tracked")
        m = max(2, max(len(h) for h in self.hands))
        image = np.full((n, m, N_LANDMARKS, 3), np.nan)
        world = np.full((n, m, N_LANDMARKS, 3), np.nan)
        labels = np.full((n, m), -1, dtype=np.int8)
        scores = np.full((n, m), np.nan)
        w, h = self.size
        for i, frame_hands in enumerate(self.hands):
            for slot, obs in enumerate(frame_hands):
                image[i, slot, :, :2] = obs.uv_px / np.array([w, h], dtype=np.float64)
                image[i, slot, :, 2] = obs.z_rel
                world[i, slot] = obs.world_m
                labels[i, slot] = selfie_code(obs, self.mirrored)
                scores[i, slot] = obs.score
        again = np.array(
            [[k < len(f) and f[k].redetected for k in range(m)] for f in self.hands], dtype=bool
        )
        cue = np.array(
            [[f[k].carry if k < len(f) else np.nan for k in range(m)] for f in self.hands],
            dtype=np.float64,
        )
        depth = None
        if self.depths:
            depth = np.full((n, m, N_LANDMARKS), np.nan)
            for i, per_hand in self.depths.items():
                for slot, d in enumerate(per_hand):
                    depth[i, slot] = d
        return LandmarkRecording(
            t_s=np.asarray(self.times),
            image_xyz=image,
            world_xyz_m=world,
            label_selfie=labels,
            label_score=scores,
            frame_size_px=np.array([w, h], dtype=np.int64),
            camera_motion=camera_motion,
            depth_m=depth,
            redetected=again if again.any() else None,
            carry_cue=cue if np.isfinite(cue).any() else None,
            native_size_px=native_size_px,
            intrinsics=intrinsics,
            meta=dict(meta or {}),
        )
