"""Figures of the real-arm path: the same lift over the Franka protocol and on MuJoCo."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from dexlfd.io import Rollout
from dexlfd.viz._mpl import pyplot, save_figure

__all__ = ["plot_protocol_vs_mujoco"]

_COLORS = {"pd": "tab:blue", "sm-pd": "tab:orange", "ntsm-pd": "tab:green"}


def plot_protocol_vs_mujoco(
    runs: Mapping[tuple[str, float, str], Rollout],
    path: str | os.PathLike[str],
    *,
    title: str = "",
) -> Path:
    """Tracking error in z per payload (columns): over the protocol (solid) vs MuJoCo (dashed).

    Parameters
    ----------
    runs : mapping
        ``(controller, payload [kg], backend)`` → rollout, backend ``"protocol"``
        or ``"mujoco"``.
    path : path-like
        PNG to write.
    title : str
        Suptitle (e.g. the plants' description).

    Returns
    -------
    Path
        The written file.
    """
    plt = pyplot()
    payloads = sorted({k[1] for k in runs})
    controllers = list(dict.fromkeys(k[0] for k in runs))
    fig, axes = plt.subplots(
        1, len(payloads), figsize=(5.2 * len(payloads), 3.8), sharey=True, squeeze=False
    )
    for j, m in enumerate(payloads):
        ax = axes[0, j]
        for c in controllers:
            for backend, style in (("protocol", "-"), ("mujoco", "--")):
                ro = runs.get((c, m, backend))
                if ro is None:
                    continue
                ez = 1e3 * (ro.ee_position[:, 2] - ro.ref_position[:, 2])
                ax.plot(ro.t, ez, style, color=_COLORS.get(c), lw=1.0, label=f"{c}, {backend}")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.grid(alpha=0.3)
        ax.set_title("without object" if m == 0 else f"{m:g} kg unknown payload")
        ax.set_xlabel("t [s]")
    axes[0, 0].set_ylabel("z − z_d [mm]")
    axes[0, 0].legend(fontsize=7, loc="lower left")
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return save_figure(fig, Path(path), dpi=120)
