"""Figures of the planning stage, like thesis Figs. 5.4-5.8.

* :func:`plot_paths`: 3-D paths of the learned mean and one or more plans, with
  start/goal markers and obstacles, plus x, y, z, quaternion and gripper over time
  (Fig. 5.4, 5.8).
* :func:`plot_obstacle_profile`: the coordinate along each obstacle's avoidance
  direction over time, nominal vs planned, the obstacle as a grey block over the
  interval where the path passes it, the demonstrations' spread (mean ± 2σ) and the
  variance weight (Figs. 5.5-5.7).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.io import LearnedModel, Plan
from dexlfd.io.plan_facts import ObstaclePass
from dexlfd.viz._mpl import pyplot, save_figure

__all__ = ["plot_obstacle_comparison", "plot_obstacle_profile", "plot_paths", "plot_plan"]

_AXIS = {"x": 0, "y": 1, "z": 2}


def _box_edges(center: Sequence[float], size: Sequence[float]) -> list[np.ndarray]:
    c = np.asarray(center)
    h = 0.5 * np.asarray(size)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    pts = c + corners * h
    edges = []
    for i in range(8):
        for j in range(i + 1, 8):
            if np.sum(corners[i] != corners[j]) == 1:
                edges.append(pts[[i, j]])
    return edges


def _draw_obstacles(ax: Any, obstacles: Sequence[ObstaclePass]) -> None:
    for ob in obstacles:
        if ob.type == "box" and ob.size is not None:
            for e in _box_edges(ob.center, ob.size):
                ax.plot(e[:, 0], e[:, 1], e[:, 2], color="0.4", lw=1)
        else:
            u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, np.pi, 12))
            r = float(ob.radius or 0.0)
            c = ob.center
            ax.plot_wireframe(
                c[0] + r * np.cos(u) * np.sin(v),
                c[1] + r * np.sin(u) * np.sin(v),
                c[2] + r * np.cos(v),
                color="0.5",
                lw=0.5,
            )


def _phase(model: LearnedModel) -> np.ndarray:
    """The model's time as phase 0..1."""
    return (model.t - model.t[0]) / (model.t[-1] - model.t[0])


def _demo_band(ax: Any, model: LearnedModel, k: int, *, alpha: float) -> None:
    """The demonstrations' mean ± 2σ of coordinate ``k`` over the model's phase 0..1."""
    tm = _phase(model)
    sd = np.sqrt(np.maximum(model.cov[:, k, k], 0.0))
    ax.fill_between(
        tm, model.mean[:, k] - 2 * sd, model.mean[:, k] + 2 * sd,
        color="C0", alpha=alpha, label="demonstrations: mean ± 2σ",
    )  # fmt: skip


def plot_paths(
    model: LearnedModel,
    plans: Sequence[Plan],
    path: str | os.PathLike[str],
    labels: Sequence[str] | None = None,
    title: str = "Learned mean and planned motions",
) -> Path:
    """Write a figure of the 3-D paths and the channels over time; returns the path."""
    plt = pyplot()
    labels = list(labels) if labels is not None else [f"plan {i + 1}" for i in range(len(plans))]
    fig = plt.figure(figsize=(15, 8))
    gs = fig.add_gridspec(3, 4, width_ratios=[1.2, 1.2, 1, 1])
    ax3 = fig.add_subplot(gs[:, 0:2], projection="3d")
    mp = model.mean[:, :3]
    ax3.plot(mp[:, 0], mp[:, 1], mp[:, 2], "k--", lw=2, label="learned mean (GMR)")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    allpts = [mp]
    for i, (p, lab) in enumerate(zip(plans, labels, strict=True)):
        col = colors[i % len(colors)]
        ax3.plot(*p.position.T, color=col, lw=1.5, label=lab)
        ax3.scatter(*p.position[0], color=col, marker="o")
        ax3.scatter(*p.position[-1], color=col, marker="*", s=80)
        _draw_obstacles(ax3, p.obstacle_passes)
        allpts.append(p.position)
    pts = np.concatenate(allpts)
    span = np.ptp(pts, axis=0)
    # near-equal scaling so metres look like metres, without squashing a thin axis
    ax3.set_box_aspect(np.maximum(span, 0.4 * span.max()))
    ax3.locator_params(nbins=4)
    ax3.set_xlabel("x [m]")
    ax3.set_ylabel("y [m]")
    ax3.set_zlabel("z [m]")
    ax3.legend(loc="upper left", fontsize=8)
    ax3.set_title("path (o start, * goal)")
    tm = _phase(model)
    for k, name in enumerate("xyz"):
        ax = fig.add_subplot(gs[k, 2])
        ax.plot(tm, mp[:, k], "k--", lw=2)
        for i, p in enumerate(plans):
            ax.plot(p.t / p.t[-1], p.position[:, k], color=colors[i % len(colors)], lw=1.2)
        ax.set_ylabel(f"{name} [m]")
        ax.grid(alpha=0.3)
    ax.set_xlabel("phase t / T [-]")
    axq = fig.add_subplot(gs[0:2, 3])
    for j, name in enumerate("xyzw"):
        axq.plot(tm, model.mean[:, 3 + j], "k--", lw=1)
        for i, p in enumerate(plans):
            axq.plot(p.t / p.t[-1], p.quaternion[:, j], color=colors[i % len(colors)], lw=1)
        axq.text(1.01, model.mean[-1, 3 + j], f"q{name}", fontsize=8)
    axq.set_title("quaternion (x, y, z, w)")
    axq.grid(alpha=0.3)
    axg = fig.add_subplot(gs[2, 3])
    axg.plot(tm, model.mean[:, 7], "k--", lw=2)
    for i, p in enumerate(plans):
        axg.plot(p.t / p.t[-1], p.gripper, color=colors[i % len(colors)], lw=1.2)
    axg.set_ylabel("gripper opening [m]")
    axg.set_xlabel("phase t / T [-]")
    axg.grid(alpha=0.3)
    fig.suptitle(title)
    fig.subplots_adjust(wspace=0.4, hspace=0.35, left=0.02, right=0.97)
    return save_figure(fig, Path(path))


def plot_obstacle_profile(
    model: LearnedModel, plan: Plan, path: str | os.PathLike[str], title: str | None = None
) -> Path:
    """Write the avoidance-direction profile of a plan with obstacles (Figs. 5.5-5.7)."""
    plt = pyplot()
    obstacles = plan.obstacle_passes
    nominal = np.asarray(plan.extras.get("nominal_position", plan.position))
    tb = plan.t / plan.t[-1]
    fig, axes = plt.subplots(
        max(1, len(obstacles)), 1, figsize=(9, 4 * max(1, len(obstacles))), squeeze=False
    )
    for ax, ob in zip(axes[:, 0], obstacles or [None], strict=True):
        direction = "+z" if ob is None else ob.direction_used
        k = _AXIS[direction[1]]
        sign = 1.0 if direction[0] == "+" else -1.0
        _demo_band(ax, model, k, alpha=0.15)
        ax.plot(tb, nominal[:, k], "k--", label="DMP without obstacle")
        ax.plot(tb, plan.position[:, k], "C3", lw=2, label="variance-avoidance DMP")
        if ob is not None:
            margin = float(ob.margin or 0.0)
            if ob.type == "box" and ob.size is not None:
                c, s = np.asarray(ob.center), np.asarray(ob.size)
                lo, hi = c - s / 2 - margin, c + s / 2 + margin
                inside = np.all(
                    [
                        (nominal[:, a] >= lo[a]) & (nominal[:, a] <= hi[a])
                        for a in range(3)
                        if a != k
                    ],
                    axis=0,
                )
                top = c[k] + sign * s[k] / 2
                bottom = c[k] - sign * s[k] / 2
            else:
                c, r = np.asarray(ob.center), float(ob.radius or 0.0)
                perp = np.linalg.norm(np.delete(nominal - c, k, axis=1), axis=1)
                inside = perp <= r
                top, bottom = c[k] + sign * r, c[k] - sign * r
            if inside.any():
                t0, t1 = tb[inside][0], tb[inside][-1]
                ax.fill_between(
                    [t0, t1], [bottom] * 2, [top] * 2, color="0.6", alpha=0.6, label="obstacle"
                )
            disp = np.max(sign * (plan.position[:, k] - nominal[:, k]))
            clear = float("nan") if ob.min_clearance is None else ob.min_clearance
            ax.set_title(
                f"{ob.type} avoided along {direction}: max displacement {disp:.3f} m, "
                f"clearance {clear:.3f} m "
                f"(margin {margin:.3f} m)\n{_gain_text(ob)}",
                fontsize=10,
            )
        ax.set_ylabel(f"{'xyz'[k]} [m]")
        ax.grid(alpha=0.3)
        if "variance_level" in plan.extras:
            ax2 = ax.twinx()
            ax2.plot(tb, plan.extras["variance_level"], color="C2", lw=1, alpha=0.7)
            ax2.set_ylim(0.0, 1.0)
            ax2.set_ylabel("normalised variance ν [-]", color="C2")
        ax.legend(loc="lower center", fontsize=8)
    axes[-1, 0].set_xlabel("phase t / T [-]")
    if title:
        fig.suptitle(title)
    fig.subplots_adjust(wspace=0.4, hspace=0.35, left=0.02, right=0.97)
    return save_figure(fig, Path(path))


def _gain_text(ob: ObstaclePass) -> str:
    """The coupling gain actually used (Eq. 5.7 weight) and the thesis's weight."""
    if ob.gain is None:
        return "no coupling (the path does not meet the obstacle)"
    kind = "shaped coupling" if ob.coupling == "shaped" else "thesis coupling"
    nan = float("nan")
    weight = nan if ob.thesis_weight is None else ob.thesis_weight
    nu = nan if ob.variance_level is None else ob.variance_level
    return f"{kind}: gain {ob.gain:.2f} (thesis k2·ν {weight:.2f}, ν {nu:.2f})"


def plot_plan(model: LearnedModel, plan: Plan, folder: str | os.PathLike[str]) -> list[Path]:
    """The CLI's figures: ``plan_paths.png`` and, with obstacles, ``plan_obstacles.png``."""
    folder = Path(folder)
    out = [plot_paths(model, [plan], folder / "plan_paths.png", labels=["plan"])]
    if plan.obstacle_passes:
        out.append(plot_obstacle_profile(model, plan, folder / "plan_obstacles.png"))
    return out


def plot_obstacle_comparison(
    model: LearnedModel,
    plans: Sequence[Plan],
    labels: Sequence[str],
    path: str | os.PathLike[str],
    axis: str = "z",
    title: str = "",
) -> Path:
    """One coordinate over phase for several plans, each with its obstacles as blocks.

    Like thesis Fig. 5.5 (obstacles of different heights) and Figs. 5.6-5.7 (the
    same obstacle where the demonstrations varied more or less).
    """
    plt = pyplot()
    k = _AXIS[axis]
    fig, ax = plt.subplots(figsize=(9, 4.5))
    _demo_band(ax, model, k, alpha=0.12)
    first = plans[0]
    nominal = np.asarray(first.extras.get("nominal_position", first.position))
    ax.plot(first.t / first.t[-1], nominal[:, k], "k--", label="DMP without obstacle")
    hatches = ["//", "", "xx", ".."]
    for i, (p, lab) in enumerate(zip(plans, labels, strict=True)):
        col = f"C{i + 1}"
        tb = p.t / p.t[-1]
        nom = np.asarray(p.extras.get("nominal_position", p.position))
        disp = np.max(p.position[:, k] - nom[:, k])
        extra = "".join(
            f", clearance {ob.min_clearance:.3f} m, gain {ob.gain:.2f}"
            for ob in p.obstacle_passes[:1]
            if ob.gain is not None and ob.min_clearance is not None
        )
        ax.plot(tb, p.position[:, k], color=col, lw=2,
                label=f"{lab} (displacement {disp:.3f} m{extra})")  # fmt: skip
        for ob in p.obstacle_passes:
            if ob.type != "box" or ob.size is None:
                continue
            c, s = np.asarray(ob.center), np.asarray(ob.size)
            over = np.all(
                [np.abs(nom[:, a] - c[a]) <= s[a] / 2 for a in range(3) if a != k], axis=0
            )
            if over.any():
                ax.bar(
                    0.5 * (tb[over][0] + tb[over][-1]),
                    s[k],
                    width=tb[over][-1] - tb[over][0],
                    bottom=c[k] - s[k] / 2,
                    color="0.75",
                    edgecolor=col,
                    hatch=hatches[i % len(hatches)],
                    alpha=0.7,
                )
    ax.set_xlabel("phase t / T [-]")
    ax.set_ylabel(f"{axis} [m]")
    ax.set_ylim(bottom=max(0.0, ax.get_ylim()[0]))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, Path(path))
