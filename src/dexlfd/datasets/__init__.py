"""Data sets: seeded synthetic demonstrations and loaders of public real data."""

from __future__ import annotations

from dexlfd.datasets.synthetic import (
    PickPlaceConfig,
    pick_place_demonstrations,
    pick_place_reference,
)

__all__ = ["PickPlaceConfig", "pick_place_demonstrations", "pick_place_reference"]
