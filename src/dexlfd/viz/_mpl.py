"""Lazy matplotlib import with the non-interactive Agg backend and a clear error."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dexlfd.errors import DependencyNotInstalled

__all__ = ["pyplot", "save_figure"]


def pyplot() -> Any:
    """Return ``matplotlib.pyplot`` using the Agg backend (no display needed)."""
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - matplotlib is a dependency
        raise DependencyNotInstalled("matplotlib", "plotting") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | Path, dpi: int = 120) -> Path:
    """Save ``fig`` atomically as PNG and close it."""
    from dexlfd.io import atomic_write

    path = Path(path)
    try:
        atomic_write(path, lambda fh: fig.savefig(fh, format="png", dpi=dpi, bbox_inches="tight"))
    finally:
        pyplot().close(fig)
    return path
