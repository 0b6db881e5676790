"""Data sets: seeded synthetic demonstrations and loaders of public real data."""

from __future__ import annotations

from dexlfd.datasets.hands import (
    HandModelConfig,
    demonstration_with_hand,
    hand_keypoints_from_pose,
)
from dexlfd.datasets.synthetic import (
    PickPlaceConfig,
    pick_place_demonstrations,
    pick_place_reference,
)

__all__ = [
    "HandModelConfig",
    "PickPlaceConfig",
    "demonstration_with_hand",
    "hand_keypoints_from_pose",
    "pick_place_demonstrations",
    "pick_place_reference",
]
