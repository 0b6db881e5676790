"""Figures of raw demonstrations: 3-D paths and the 8 channels over time."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io import Demonstration
from dexlfd.viz._mpl import pyplot, save_figure

__all__ = ["demonstrations_figure", "plot_demonstrations"]


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


def _source_name(source: object) -> str:
    """A source as its file name (a recording's full path says nothing in a title)."""
    text = str(source)
    return Path(text).name if ("/" in text or "\\" in text) else text


def demonstrations_figure(demos: Sequence[Demonstration]) -> Any:
    """The figure of :func:`plot_demonstrations` (3-D paths beside the channels over time).

    The 3-D axes have few ticks, small tick labels and their axis labels padded clear
    of them; the title names the sources by file name.
    """
    from matplotlib.ticker import MaxNLocator

    plt = pyplot()
    fig = plt.figure(figsize=(14, 6.5))
    grid = fig.add_gridspec(4, 3, width_ratios=(1.4, 1, 1), wspace=0.45, hspace=0.35)
    ax3 = fig.add_subplot(grid[:, 0], projection="3d")
    axes = [fig.add_subplot(grid[i // 2, 1 + i % 2]) for i in range(8)]
    for k, demo in enumerate(demos):
        color = f"C{k % 10}"
        p = demo.position
        ax3.plot(p[:, 0], p[:, 1], p[:, 2], color=color, lw=1, label=f"demo {k}")
        for i, ax in enumerate(axes):
            ax.plot(demo.t, demo.pose[:, i], color=color, lw=0.8)
    ax3.set_title("end-effector paths", fontsize=10)
    for axis, name in zip((ax3.xaxis, ax3.yaxis, ax3.zaxis), "xyz", strict=True):
        axis.set_major_locator(MaxNLocator(4))
        axis.set_label_text(f"{name} [m]", fontsize=8)
        axis.labelpad = 10
    ax3.tick_params(labelsize=6, pad=2)
    _equal_aspect(ax3, np.concatenate([d.position for d in demos]))
    ax3.legend(fontsize=7, loc="upper left")
    for i, ax in enumerate(axes):
        ax.set_ylabel(_CHANNELS[i], fontsize=8)
        ax.tick_params(labelsize=7)
        if i >= 6:
            ax.set_xlabel("t [s]", fontsize=8)
    source = {_source_name(d.meta.get("source", "?")) for d in demos}
    plural = "" if len(demos) == 1 else "s"
    fig.suptitle(f"{len(demos)} demonstration{plural} (source: {', '.join(sorted(source))})")
    return fig


def plot_demonstrations(demos: Sequence[Demonstration], path: str | Path) -> Path:
    """Plot the demonstrations' 3-D paths and channels over time into one PNG."""
    return save_figure(demonstrations_figure(demos), path)
