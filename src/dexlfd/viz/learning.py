"""Figures of the learning stage, after thesis Figs. 4.6–4.10 and 4.13–4.18.

* ``dtw_example.png``: the worked DTW example of §4.3.2 (distance matrix,
  accumulated cost with the optimal path, correspondence) — Figs. 4.6–4.10.
* ``dtw_correspondence.png``: matched samples of two demonstrations — Fig. 4.13.
* ``alignment.png``: every channel before and after DTW alignment — Figs. 4.14–4.15.
* ``gmm.png``: GMM components as 2σ ellipses in (t, channel) planes — Fig. 4.16.
* ``gmr.png``: GMR mean ± 2σ with the aligned demonstrations — Figs. 4.17–4.18.
* ``quality.png``: each demonstration's DTW distance to the reference, robust
  z-scores and outlier flags (not in the thesis).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray, IntArray
from dexlfd.learn import POSE_CHANNELS, LearnedTrajectory, LearnResult
from dexlfd.learn.dtw import accumulated_cost, dtw
from dexlfd.panda import GRIPPER_OPENING_MAX
from dexlfd.viz._mpl import pyplot, save_figure

__all__ = [
    "THESIS_DTW_EXAMPLE",
    "plot_alignment",
    "plot_dtw_correspondence",
    "plot_dtw_example",
    "plot_gmm",
    "plot_gmr",
    "plot_learning",
    "plot_quality",
]

# thesis §4.3.2
THESIS_DTW_EXAMPLE = (
    np.array([0.1, 0.2, 0.5, 0.5, 0.3, 0.1, 0.1, 0.1, 0.2, 0.3]),
    np.array([0.1, 0.1, 0.2, 0.3, 0.4, 0.5, 0.3, 0.2, 0.1, 0.2]),
)
_POSE_LABELS = ("x [m]", "y [m]", "z [m]", "qx", "qy", "qz", "qw", "gripper [m]")


def _labels(d: int, labels: Sequence[str] | None) -> list[str]:
    if labels is not None:
        return list(labels)
    if d == len(POSE_CHANNELS):
        return list(_POSE_LABELS)
    return [f"x{c}" for c in range(d)]


def _grid(plt: Any, d: int, width: float = 11.0, row_h: float = 1.9) -> tuple[Any, list[Any]]:
    cols = 2 if d > 3 else 1
    rows = int(np.ceil(d / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(width, row_h * rows + 0.8), squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[d:]:
        ax.set_visible(False)
    return fig, flat[:d]


def plot_dtw_example(path: str | Path) -> Path:
    """The thesis's worked DTW example (Figs. 4.6–4.10) with our optimal path."""
    A, B = THESIS_DTW_EXAMPLE
    E = np.abs(B[:, None] - A[None, :])  # rows b_i, columns a_j as in Fig. 4.7
    C = accumulated_cost(B, A)
    res = dtw(B, A)
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    for ax, M, title in ((axes[0], E, "distance E (Fig. 4.7)"), (axes[1], C, "accumulated C")):
        ax.imshow(M, origin="lower", cmap="Greys", vmin=0, vmax=M.max() * 1.6)
        for i in range(M.shape[0]):
            for j in range(M.shape[1]):
                ax.text(j, i, f"{M[i, j]:.1f}", ha="center", va="center", fontsize=7)
        ax.set(
            xticks=range(10),
            yticks=range(10),
            xticklabels=[f"a{j + 1}" for j in range(10)],
            yticklabels=[f"b{i + 1}" for i in range(10)],
            title=title,
        )
    axes[1].plot(res.path[:, 1], res.path[:, 0], "r-o", ms=3, lw=1.5)
    axes[1].set_title(f"accumulated C with optimal path\ncost {res.cost:.2f} (Figs. 4.8–4.9)")
    ax = axes[2]
    off = 0.6
    ax.plot(np.arange(1, 11), A + off, "b-o", label="A (shifted up)")
    ax.plot(np.arange(1, 11), B, "g-o", label="B")
    for i, j in res.path:
        ax.plot([j + 1, i + 1], [A[j] + off, B[i]], "k:", lw=0.8)
    ax.set(title="correspondence (Fig. 4.10)", xlabel="sample")
    ax.legend(fontsize=8)
    fig.suptitle("DTW worked example of thesis §4.3.2")
    return save_figure(fig, path)


def plot_dtw_correspondence(
    t_a: FloatArray,
    x_a: FloatArray,
    t_b: FloatArray,
    x_b: FloatArray,
    path_ab: IntArray,
    path: str | Path,
    *,
    label: str = "z [m]",
    names: tuple[str, str] = ("demonstration A", "demonstration B"),
    max_lines: int = 60,
) -> Path:
    """Two series of one channel with dotted lines between DTW-matched samples (Fig. 4.13)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 4.2))
    span = max(float(np.ptp(x_a)), float(np.ptp(x_b)), 1e-9)
    off = 1.2 * span
    ax.plot(t_a, x_a + off, "b-", lw=1.5, label=f"{names[0]} (shifted up by {off:.3g})")
    ax.plot(t_b, x_b, "g-", lw=1.5, label=names[1])
    step = max(1, path_ab.shape[0] // max_lines)
    for i, j in path_ab[::step]:
        ax.plot([t_a[i], t_b[j]], [x_a[i] + off, x_b[j]], "k:", lw=0.7)
    ax.set(xlabel="t [s]", ylabel=label, title="DTW correspondence between two demonstrations")
    ax.legend(fontsize=8, loc="best")
    return save_figure(fig, path)


def plot_alignment(
    traj: LearnedTrajectory, path: str | Path, labels: Sequence[str] | None = None
) -> Path:
    """Every channel before (left) and after (right) DTW alignment (Figs. 4.14–4.15)."""
    d = traj.mean.shape[1]
    names = _labels(d, labels)
    plt = pyplot()
    fig, axes = plt.subplots(d, 2, figsize=(12, 1.6 * d + 0.8), squeeze=False, sharex="col")
    ref = traj.alignment.reference_index
    for k, (t, x) in enumerate(traj.series):
        style = {"color": f"C{k % 10}", "lw": 2.0 if k == ref else 0.9}
        for c in range(d):
            axes[c, 0].plot(t, x[:, c], **style, label=f"{k}" + (" (ref)" if k == ref else ""))
            axes[c, 1].plot(traj.t_reference, traj.alignment.aligned[k, :, c], **style)
    for c in range(d):
        axes[c, 0].set_ylabel(names[c], fontsize=8)
        for ax in axes[c]:
            ax.tick_params(labelsize=7)
    axes[0, 0].set_title("before DTW (own time)")
    axes[0, 1].set_title(f"after DTW (on reference {ref}'s time steps)")
    axes[-1, 0].set_xlabel("t [s]")
    axes[-1, 1].set_xlabel("t [s]")
    # one legend for every panel, below the figure: inside one it covered demonstrations
    handles, names_k = axes[0, 0].get_legend_handles_labels()
    fig.tight_layout()  # the figure's bottom edge just below the time labels
    fig.legend(handles, names_k, title="demonstration", fontsize=7, title_fontsize=7,
               ncol=min(len(names_k), 10), loc="upper center", bbox_to_anchor=(0.5, 0.0),
               frameon=False)  # fmt: skip
    return save_figure(fig, path)


def _ellipse(mu: FloatArray, S: FloatArray, n_sigma: float = 2.0, n: int = 60) -> FloatArray:
    vals, vecs = np.linalg.eigh(S)
    a = np.linspace(0, 2 * np.pi, n)
    circle = np.stack([np.cos(a), np.sin(a)])
    return (mu[:, None] + vecs @ (n_sigma * np.sqrt(np.maximum(vals, 0))[:, None] * circle)).T


def plot_gmm(
    traj: LearnedTrajectory, path: str | Path, labels: Sequence[str] | None = None
) -> Path:
    """Aligned data and the GMM's components as 2σ ellipses in (t, channel) planes (Fig. 4.16)."""
    gmm = traj.gmm_result.gmm
    d = traj.mean.shape[1]
    names = _labels(d, labels)
    plt = pyplot()
    fig, axes = _grid(plt, d)
    aligned = traj.alignment.aligned[traj.used]
    for c, ax in enumerate(axes):
        for x in aligned:
            ax.plot(traj.t_reference, x[:, c], ".", color="0.55", ms=1.5)
        for k in range(gmm.n_components):
            idx = [0, c + 1]
            e = _ellipse(gmm.means[k, idx], gmm.covariances[k][np.ix_(idx, idx)])
            ax.plot(e[:, 0], e[:, 1], "g-", lw=1.3)
            ax.plot(*gmm.means[k, idx], "g+", ms=6)
        ax.set_ylabel(names[c], fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes[-2:]:
        ax.set_xlabel("t [s]")
    res = traj.gmm_result
    fig.suptitle(
        f"GMM, K={gmm.n_components} (2σ ellipses): {res.n_iter} EM iterations, "
        f"converged={res.converged}, log-likelihood {res.log_likelihood:.1f}"
    )
    return save_figure(fig, path)


def plot_gmr(
    traj: LearnedTrajectory,
    path: str | Path,
    labels: Sequence[str] | None = None,
    *,
    show_demos: bool = True,
) -> Path:
    """GMR mean ± 2σ per channel, with the aligned demonstrations dashed (Figs. 4.17–4.18)."""
    d = traj.mean.shape[1]
    names = _labels(d, labels)
    plt = pyplot()
    fig, axes = _grid(plt, d)
    sd = np.sqrt(np.maximum(np.diagonal(traj.cov, axis1=1, axis2=2), 0.0))
    for c, ax in enumerate(axes):
        if show_demos:
            for k, x in enumerate(traj.alignment.aligned):
                ax.plot(
                    traj.t_reference,
                    x[:, c],
                    "--",
                    lw=0.8,
                    color=f"C{k % 10}" if traj.used[k] else "0.6",
                )
        lo, hi = traj.mean[:, c] - 2 * sd[:, c], traj.mean[:, c] + 2 * sd[:, c]
        if names[c].startswith("gripper"):  # shown within the opening's physical range
            lo, hi = (np.clip(v, 0.0, GRIPPER_OPENING_MAX) for v in (lo, hi))
        ax.fill_between(
            traj.t,
            lo,
            hi,
            color="C0",
            alpha=0.25,
            lw=0,
        )
        ax.plot(traj.t, traj.mean[:, c], "b-", lw=1.8)
        ax.set_ylabel(names[c], fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in axes[-2:]:
        ax.set_xlabel("t [s]")
    n_used = int(traj.used.sum())
    fig.suptitle(
        f"GMR mean (solid) ± 2σ (shaded) and {n_used} aligned demonstration"
        f"{'' if n_used == 1 else 's'} (dashed)"
        + ("" if n_used == len(traj.used) else "; grey: excluded")
        + (
            f"; gripper band clipped to 0..{GRIPPER_OPENING_MAX:g} m"
            if "gripper" in names[-1]
            else ""
        )
    )
    return save_figure(fig, path)


def plot_quality(
    traj: LearnedTrajectory, path: str | Path, names: Sequence[str] | None = None
) -> Path:
    """Bar chart of the DTW distance of each demonstration to the reference, outliers red."""
    q = traj.quality
    N = q.distances.shape[0]
    labels = list(names) if names is not None else [str(i) for i in range(N)]
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(max(5.0, 0.7 * N + 2), 3.6))
    colors = [
        "tab:green" if i == q.reference_index else ("tab:red" if q.outlier[i] else "tab:blue")
        for i in range(N)
    ]
    ax.bar(range(N), q.distances, color=colors)
    for i in range(N):
        text = "ref" if i == q.reference_index else f"z={q.robust_z[i]:.1f}"
        if not traj.used[i]:
            text += "\nexcluded"
        ax.text(i, q.distances[i], text, ha="center", va="bottom", fontsize=7)
    ax.set_xticks(range(N), labels, rotation=30, ha="right", fontsize=7)
    ax.set_ylabel("normalised DTW distance (scaled units)")
    title = f"distance to the reference; red: robust z > {q.threshold:g}"
    if q.modes is not None:
        title += f"; TWO MODES (separation {q.mode_separation:.1f})"
    elif q.note:
        title += f"\n({q.note})"
    ax.set_title(title, fontsize=9)
    ax.margins(y=0.2)
    return save_figure(fig, path)


def plot_learning(
    result: LearnResult | LearnedTrajectory,
    folder: str | Path,
    labels: Sequence[str] | None = None,
    callback: Callable[[Path], None] | None = None,
) -> list[Path]:
    """Write all learning figures into ``folder``; returns their paths.

    ``callback(path)`` is called as each figure is written (a progress bar).
    """
    traj = result.trajectory if isinstance(result, LearnResult) else result
    folder = Path(folder)
    out = _Written(callback)
    out.append(plot_dtw_example(folder / "dtw_example.png"))
    al = traj.alignment
    ref = al.reference_index
    others = [i for i in range(len(traj.series)) if i != ref]
    if others:
        other = others[0]
        d = traj.mean.shape[1]
        c = 2 if d == len(POSE_CHANNELS) else 0  # z, as in the thesis's Fig. 4.13
        t_o, x_o = traj.series[other]
        t_r, x_r = traj.series[ref]
        out.append(
            plot_dtw_correspondence(
                t_o,
                x_o[:, c],
                t_r,
                x_r[:, c],
                al.paths[other],
                folder / "dtw_correspondence.png",
                label=_labels(d, labels)[c],
                names=(f"demonstration {other}", f"reference {ref}"),
            )
        )
    out.append(plot_alignment(traj, folder / "alignment.png", labels))
    out.append(plot_gmm(traj, folder / "gmm.png", labels))
    out.append(plot_gmr(traj, folder / "gmr.png", labels))
    out.append(plot_quality(traj, folder / "quality.png"))
    return list(out)


class _Written(list[Path]):
    """The figures written so far; ``callback(path)`` told of each as it is added."""

    def __init__(self, callback: Callable[[Path], None] | None) -> None:
        super().__init__()
        self._callback = callback

    def append(self, path: Path) -> None:
        """Add ``path`` and tell the callback."""
        super().append(path)
        if self._callback is not None:
            self._callback(path)
