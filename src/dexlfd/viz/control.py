"""Figures of the control stage: the lift comparison (Fig. 5.9), one rollout, the grid.

The grid is the pick-and-place generalisation over the table.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.io import Rollout
from dexlfd.viz._mpl import envelope_indices, pyplot, save_figure

if TYPE_CHECKING:
    from dexlfd.experiments.generalize import GeneralizeResult
    from dexlfd.experiments.payload import PayloadResult
    from dexlfd.experiments.payload_montecarlo import MonteCarloResult

__all__ = ["plot_generalize", "plot_payload_lift", "plot_payload_monte_carlo", "plot_rollout"]

_COLORS = {
    "pd": "tab:blue", "sm-pd": "tab:orange", "ntsm-pd": "tab:green",
    "ntsm-pd-i": "tab:red", "ntsm-pd-dob": "tab:purple", "pd-dob": "tab:brown",
    "impedance": "tab:gray", "joint-pd": "tab:olive",
}  # fmt: skip


def plot_payload_lift(result: PayloadResult, path: str | os.PathLike[str]) -> Path:
    """TCP height z during the lift per payload (columns), desired dashed; errors below.

    Mirrors Fig. 5.9 of the thesis (a) without object, (b) 0.45 kg, (c) 1.2 kg.
    """
    plt = pyplot()
    cfg = result.config
    payloads = list(cfg.payloads)
    fig, axes = plt.subplots(
        2, len(payloads), figsize=(4.6 * len(payloads), 6.4), sharex=True,
        gridspec_kw={"height_ratios": [2, 1.3]}, squeeze=False,
    )  # fmt: skip
    for j, m in enumerate(payloads):
        ax, axe = axes[0, j], axes[1, j]
        first = result.rollouts[(cfg.controllers[0], m)]
        ax.plot(first.t, first.ref_position[:, 2], "k--", lw=1.6, label="desired")
        for c in cfg.controllers:
            ro = result.rollouts[(c, m)]
            col = _COLORS.get(c)
            ax.plot(ro.t, ro.ee_position[:, 2], color=col, lw=1.1, label=c)
            axe.plot(ro.t, 1e3 * (ro.ee_position[:, 2] - ro.ref_position[:, 2]), color=col, lw=1.0)
        z0 = first.ref_position[0, 2]
        win = first.ref_position[:, 2] >= z0 + cfg.clearance
        for a in (ax, axe):
            if win.any():  # a plan that never rises by the clearance has no window
                a.axvspan(first.t[win][0], first.t[win][-1], color="0.92", zorder=0)
            a.grid(alpha=0.3)
        label = "(a) without object" if m == 0 else f"({chr(97 + j)}) {m:g} kg object"
        ax.set_title(label)
        ax.set_ylabel("z [m]")
        axe.set_ylabel("z − z_d [mm]")
        axe.set_xlabel("t [s]")
        axe.axhline(0.0, color="k", lw=0.6)
    axes[0, 0].legend(fontsize=8, loc="upper left")
    fig.suptitle(
        "Lift over an obstacle, unknown payload (grey band: metrics window); simulated Panda, "
        f"realistic plant (friction, {100 * cfg.model_error:.0f} % model error, noise, delay)",
        fontsize=10,
    )
    fig.tight_layout()
    return save_figure(fig, Path(path), dpi=120)


def _series(ax: Any, t: FloatArray, y: FloatArray, columns: int, *args: Any, **kw: Any) -> None:
    """``ax.plot(t, y, ...)`` of the samples that show at ``columns`` pixel columns.

    A 1 kHz rollout has 10-30 samples a pixel column: the line through the lowest and
    highest of each half column (:func:`~dexlfd.viz._mpl.envelope_indices`) looks the
    same, its spikes kept (half columns: a noisy torque's band is drawn as dark as by
    all its samples, by one column's two it was lighter), and costs less to draw.
    """
    keep = envelope_indices(y, columns)
    ax.plot(t[keep], y[keep], *args, **kw)


def plot_rollout(rollout: Rollout, path: str | os.PathLike[str]) -> Path:
    """Position tracking (x, y, z), position/orientation error and joint torques."""
    plt = pyplot()
    t = rollout.t
    dpi = 110
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    columns = 2 * int(fig.get_figwidth() * dpi)  # half-pixel bins: wider than any panel
    for i, (name, col) in enumerate(zip("xyz", ("tab:red", "tab:green", "tab:blue"), strict=True)):
        _series(axes[0], t, rollout.ee_position[:, i], columns, color=col, label=f"{name}")
        _series(axes[0], t, rollout.ref_position[:, i], columns, "--", color=col, lw=0.9)
    axes[0].set_ylabel("TCP position [m]")
    # the legends right of the panels: inside, the curves they name ran under them
    outside = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}
    axes[0].legend(fontsize=8, title="solid: actual\ndashed: desired", title_fontsize=8, **outside)
    err = 1e3 * np.linalg.norm(rollout.ee_position - rollout.ref_position, axis=1)
    _series(axes[1], t, err, columns, color="k")
    axes[1].set_ylabel("|p − p_d| [mm]")
    rot = rollout.extras.get("orientation_error")
    if rot is not None:
        _series(axes[2], t, np.degrees(rot), columns, color="tab:purple")
    axes[2].set_ylabel("orientation error [deg]")
    for j in range(rollout.tau.shape[1]):  # the colour cycle's order, as one plot of all
        _series(axes[3], t, rollout.tau[:, j], columns, lw=0.8, label=f"joint {j + 1}")
    axes[3].legend(fontsize=7, **outside)
    axes[3].set_ylabel("τ commanded [N·m]")
    axes[3].set_xlabel("t [s]")
    name = rollout.controller or "?"
    payload = rollout.payload_kg or 0.0
    title = f"controller {name}, payload {payload:g} kg"
    if rollout.stopped:
        title += f" — STOPPED: {rollout.stopped}"
    axes[0].set_title(title, fontsize=10)
    for a in axes:
        a.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, Path(path), dpi=dpi)


def plot_payload_monte_carlo(result: MonteCarloResult, path: str | os.PathLike[str]) -> Path:
    """Monte-Carlo payload study: ΔE per trial, and per-controller means with intervals.

    Left: ΔE of every trial against the object's mass. Right: the means of E_OB
    and ΔE per controller with their confidence intervals.
    """
    plt = pyplot()
    cfg = result.config
    fig, (ax, axm) = plt.subplots(1, 2, figsize=(12.5, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    for c in cfg.base.controllers:
        pts = [(t.draw.payload_kg, 1e3 * r.delta_e_m) for t in result.trials for r in t.rows
               if r.controller == c and r.stopped is None and np.isfinite(r.delta_e_m)]  # fmt: skip
        if pts:
            m, de = np.array(pts).T
            ax.scatter(m, de, s=14, color=_COLORS.get(c), label=c, alpha=0.8)
    ax.set_yscale("symlog", linthresh=0.1)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("object mass [kg]")
    ax.set_ylabel("ΔE = E_OB − E_NOB [mm] (symlog)")
    ax.set_title("(a) each trial: a random plant")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    names = [s.controller for s in result.summary]
    y = np.arange(len(names))
    for k, (metric, label, dy) in enumerate((("e_ob_m", "E_OB", -0.15), ("delta_e_m", "ΔE", 0.15))):
        mean = np.array([1e3 * s.stats[metric].mean for s in result.summary])
        low = np.array([1e3 * s.stats[metric].low for s in result.summary])
        high = np.array([1e3 * s.stats[metric].high for s in result.summary])
        err = np.vstack([mean - low, high - mean])
        axm.errorbar(mean, y + dy, xerr=np.nan_to_num(err), fmt="os"[k], capsize=3,
                     label=f"{label} mean ± {100 * cfg.level:g} % CI")  # fmt: skip
    axm.set_yticks(y, names)
    axm.invert_yaxis()
    axm.set_xscale("symlog", linthresh=0.1)
    axm.set_xlabel("[mm] (symlog)")
    axm.set_title(f"(b) over {len(result.trials)} trials")
    axm.grid(alpha=0.3)
    axm.legend(fontsize=8)
    fig.suptitle(
        "Payload Monte-Carlo: z-axis RMSE while the object is carried (Eq. 5.27); random mass, "
        "model error, noise, delay and seeds per trial",
        fontsize=10,
    )
    fig.tight_layout()
    return save_figure(fig, Path(path), dpi=120)


def plot_generalize(result: GeneralizeResult, path: str | os.PathLike[str]) -> Path:
    """Success and placement error over the table, one panel per (controller, payload).

    Each pair is a line from its pick (circle) to its place (square), coloured by the
    placement error [mm] and labelled with it; a failed run's place is a red cross. The
    panels show the table to scale (equal axes) with the pick and place areas shaded, as
    seen from behind the robot (y to the left).
    """
    plt = pyplot()
    runs = result.runs
    keys = [(c, m) for c in result.config.controllers for m in result.config.payloads]
    areas = {"pick area": result.config.pick_area, "place area": result.config.place_area}
    corners = [(x, y) for (xs, ys) in areas.values() for x in xs for y in ys]
    points = np.array(corners + [p[:2] for pair in result.pairs for p in pair[:2]])
    pad = 0.05  # [m] around the areas and the outermost pick/place
    lo, hi = points.min(axis=0) - pad, points.max(axis=0) + pad  # (x, y) [m]
    aspect = (hi[0] - lo[0]) / (hi[1] - lo[1])  # panel height / width
    width = 4.2
    fig, axes = plt.subplots(
        1, len(keys), figsize=(width * len(keys) + 1.2, width * aspect + 1.3),
        squeeze=False, layout="constrained",
    )  # fmt: skip
    cmap = plt.get_cmap("viridis")
    vmax = 20.0  # [mm] the placement tolerance
    for ax, (ctrl, m) in zip(axes[0], keys, strict=True):
        rows = [r for r in runs if r["controller"] == ctrl and r["payload_kg"] == m]
        for name, ((x0, x1), (y0, y1)) in areas.items():
            ax.add_patch(plt.Rectangle((y0, x0), y1 - y0, x1 - x0, color="0.9", zorder=0))
            ax.text((y0 + y1) / 2, x0 - 0.01, name, ha="center", va="top", fontsize=7)
        ok = 0
        for r in rows:
            pick, place = result.pairs[r["pair"]]
            pl = r.get("placement") or {}
            err = pl.get("place_error_m")
            success = bool(pl.get("success"))
            ok += success
            color = cmap(min(1.0, (1e3 * err) / vmax)) if err is not None else "0.6"
            ax.plot([pick[1], place[1]], [pick[0], place[0]], color=color, lw=0.8, alpha=0.7)
            ax.plot(pick[1], pick[0], "o", color=color, ms=4)
            if success:
                ax.plot(place[1], place[0], "s", color=color, ms=6)
            else:
                ax.plot(place[1], place[0], "x", color="red", ms=8, mew=2)
            if err is not None:
                ax.annotate(
                    f"{1e3 * err:.1f}", (place[1], place[0]), xytext=(0, 6),
                    textcoords="offset points", ha="center", fontsize=7,
                )  # fmt: skip
        label = "0 kg (10 g box)" if m == 0 else f"{m:g} kg"
        ax.set_title(f"{ctrl}, {label}\n{ok}/{len(rows)} placed within 2 cm", fontsize=10)
        ax.set_xlabel("y [m] (base frame)")
        ax.set_ylabel("x [m]")
        ax.set_xlim(hi[1], lo[1])  # y to the left, as seen from behind the robot
        ax.set_ylim(lo[0], hi[0])
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0.0, vmax))
    fig.colorbar(sm, ax=axes[0].tolist(), label="placement error [mm]", shrink=0.9)
    fig.suptitle("pick (o) -> place (square, error in mm); red x: not placed", fontsize=10)
    return save_figure(fig, Path(path))
