"""Figures of raw demonstrations: 3-D paths and the 8 channels over time."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io import Demonstration
from dexlfd.viz._mpl import pyplot, save_figure

__all__ = ["plot_demonstrations"]


def _equal_aspect(ax: Any, points: FloatArray) -> None:
    """Metric 3-D axes: one metre is as long on every axis."""
    p = points[np.isfinite(points).all(axis=1)]
    centre = (p.max(axis=0) + p.min(axis=0)) / 2
    half = max(float(np.ptp(p, axis=0).max()) / 2, 1e-3)
    ax.set(
        xlim=(centre[0] - half, centre[0] + half),
        ylim=(centre[1] - half, centre[1] + half),
        zlim=(centre[2] - half, centre[2] + half),
    )
    ax.set_box_aspect((1, 1, 1))


_CHANNELS = ("x [m]", "y [m]", "z [m]", "qx", "qy", "qz", "qw", "gripper [m]")


def plot_demonstrations(demos: Sequence[Demonstration], path: str | Path) -> Path:
    """Plot the demonstrations' 3-D paths and channels over time into one PNG."""
    plt = pyplot()
    fig = plt.figure(figsize=(13, 6.5))
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    axes = [fig.add_subplot(4, 3, 3 * (i // 2) + 2 + i % 2) for i in range(8)]
    for k, demo in enumerate(demos):
        color = f"C{k % 10}"
        p = demo.position
        ax3.plot(p[:, 0], p[:, 1], p[:, 2], color=color, lw=1, label=f"demo {k}")
        for i, ax in enumerate(axes):
            ax.plot(demo.t, demo.pose[:, i], color=color, lw=0.8)
    ax3.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title="end-effector paths")
    _equal_aspect(ax3, np.concatenate([d.position for d in demos]))
    ax3.legend(fontsize=7, loc="upper left")
    for i, ax in enumerate(axes):
        ax.set_ylabel(_CHANNELS[i], fontsize=8)
        ax.tick_params(labelsize=7)
        if i >= 6:
            ax.set_xlabel("t [s]", fontsize=8)
    source = {str(d.meta.get("source", "?")) for d in demos}
    fig.suptitle(f"{len(demos)} demonstrations (source: {', '.join(sorted(source))})")
    return save_figure(fig, path)
