"""dexlfd: learning robust Franka Panda motions from a few videos of a human hand."""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__"]
