"""The figure of a taught task: the plan with the object, its supports and the learned path."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.io import LearnedModel, Plan
from dexlfd.viz._mpl import pyplot, save_figure

__all__ = ["plot_task_plan"]


def _box(ax: Any, center: Any, size: Any, axes: tuple[int, int], **style: Any) -> None:
    from matplotlib.patches import Rectangle

    i, j = axes
    corner = (center[i] - size[i] / 2, center[j] - size[j] / 2)
    ax.add_patch(Rectangle(corner, size[i], size[j], **style))


def plot_task_plan(
    model: LearnedModel,
    plan: Plan,
    object_size: Sequence[float],
    path: str | os.PathLike[str],
) -> Path:
    """Top (x-y) and side (x-z) views of the plan, the object at pick and place, supports.

    The plan's path is drawn solid where the gripper holds the object and dotted
    elsewhere; the learned mean (the demonstrations moved to the new pick) dashed with
    its 2-sigma spread (ellipses along it); the object (``object_size`` [m], centred on
    the TCP) at the pick and the place; the supports and obstacles as grey and red boxes.
    """
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    held = np.zeros(plan.n_samples, bool) if plan.grasp is None else np.asarray(plan.grasp)
    p = plan.position
    mean = model.mean[:, :3]
    sd = np.sqrt(np.clip(np.diagonal(model.cov[:, :3, :3], axis1=1, axis2=2), 0, None))
    for ax, (i, j), title in zip(axes, ((0, 1), (0, 2)), ("top view", "side view"), strict=True):
        ax.plot(mean[:, i], mean[:, j], "k--", lw=1.2, label="learned mean (demonstrations)")
        from matplotlib.patches import Ellipse

        for n, k in enumerate(range(0, mean.shape[0], max(1, mean.shape[0] // 40))):
            ax.add_patch(
                Ellipse(
                    (mean[k, i], mean[k, j]),
                    4 * sd[k, i],
                    4 * sd[k, j],
                    lw=0,
                    color="0.5",
                    alpha=0.12,
                    label="model ±2σ" if n == 0 else None,
                )
            )
        ax.plot(*p[:, [i, j]].T, ":", color="C0", lw=1.2, label="plan, gripper open")
        carry = np.where(held, p[:, j], np.nan)
        ax.plot(p[:, i], carry, color="C1", lw=2.2, label="plan, object held")
        ax.plot(*p[0, [i, j]], "o", color="C0", label="start (ready pose)")
        for name, pose, color in (("pick", plan.pick_pose, "C2"), ("place", plan.place_pose,
                                                                   "C3")):  # fmt: skip
            if pose is None:
                continue
            _box(ax, pose[:3], object_size, (i, j), facecolor=color, alpha=0.5, edgecolor=color,
                 zorder=3, label=f"object at the {name}")  # fmt: skip
        for k, s in enumerate(plan.supports):
            _box(ax, s.center, s.size, (i, j), facecolor="0.75", edgecolor="0.4",
                 label="support" if k == 0 else None)  # fmt: skip
        for k, ob in enumerate(plan.obstacles):
            size = getattr(ob, "size", None) or (2 * getattr(ob, "radius", 0.0),) * 3
            _box(ax, ob.center, size, (i, j), facecolor="none", edgecolor="red",
                 label="obstacle" if k == 0 else None)  # fmt: skip
        if j == 2:
            ax.axhline(0.0, color="0.3", lw=1, label="table (z = 0)")
        ax.set(xlabel="x [m]", ylabel="xyz"[j] + " [m]", title=title)
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=5)
    fig.subplots_adjust(bottom=0.2)
    fig.suptitle(f"Plan to the new pick and place ({plan.t[-1] - plan.t[0]:.1f} s), base frame")
    return save_figure(fig, Path(path))
