"""Figures and videos of the capture stage.

* :class:`OverlayWriter`: the input video with the tracked skeleton drawn on it.
* :func:`annotate_overlay`: once the demonstration is known, marks on that video
  the hand recorded (its skeleton in yellow, its track) and the grasp state.
* :func:`plot_hand_3d`: one frame's 21 landmarks in 3-D (cf. thesis Fig. 4.3 c).
* :func:`plot_motion`: position, yaw/pitch/roll and gripper opening over time
  with the grasp phases shaded (cf. thesis Figs. 4.5 and 4.11).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd.capture.tracking import HAND_CONNECTIONS
from dexlfd.errors import InvalidFile
from dexlfd.intervals import true_runs
from dexlfd.io import Demonstration, atomic_write
from dexlfd.io.video import VideoWriter

__all__ = [
    "OverlayWriter",
    "annotate_overlay",
    "draw_skeleton",
    "label_scale",
    "plot_hand_3d",
    "plot_motion",
    "save_capture_figures",
]

logger = logging.getLogger(__name__)


def label_scale(shape: tuple[int, ...]) -> float:
    """OpenCV font scale for an image of ``shape`` (h, w, ...).

    0.8 at 720 px high, a line about 1/24 of the height (readable from 120x120 to
    1280x720 and above); at least 0.25.
    """
    return max(0.25, 0.8 * min(shape[0], shape[1] * 9 / 16) / 720)


def put_label(
    img: np.ndarray, text: str | tuple[str, ...], row: int = 0, color=(255, 255, 255)
) -> None:
    """Write ``text`` in place on a dark band, line ``row`` from the top.

    The font is scaled to the image (:func:`label_scale`); of several texts, the first
    that fits the width is written (the last one otherwise).
    """
    import cv2

    fs = label_scale(img.shape)
    thick = max(1, round(2 * fs))
    options = (text,) if isinstance(text, str) else text
    line = options[-1]
    for line in options:
        (w, h), base = cv2.getTextSize(line, cv2.FONT_HERSHEY_SIMPLEX, fs, thick)
        if w <= img.shape[1] - 2:
            break
    pad = max(1, round(4 * fs))
    y0 = row * (h + base + 2 * pad)
    cv2.rectangle(img, (0, y0), (w + 2 * pad, y0 + h + base + 2 * pad), (0, 0, 0), -1)
    cv2.putText(img, line, (pad, y0 + pad + h), cv2.FONT_HERSHEY_SIMPLEX, fs, color, thick,
                cv2.LINE_AA)  # fmt: skip


def _skeleton(img: np.ndarray, uv: np.ndarray, line=(0, 200, 0), joint=(220, 0, 0)) -> None:
    import cv2

    scale = max(1, min(img.shape[0], img.shape[1]) // 360)
    pts = np.round(uv).astype(int)
    for a, b in HAND_CONNECTIONS:
        cv2.line(img, tuple(pts[a]), tuple(pts[b]), line, scale, cv2.LINE_AA)
    for k, p in enumerate(pts):
        r = (2 if k in (0, 4, 8) else 1) * scale + 1
        cv2.circle(img, tuple(p), r, joint, -1, cv2.LINE_AA)


def draw_skeleton(rgb: np.ndarray, uv_px: np.ndarray, label: str = "") -> np.ndarray:
    """A copy of ``rgb`` with MediaPipe's skeleton (green lines, red joints) drawn on it."""
    img = np.ascontiguousarray(rgb).copy()
    uv = np.asarray(uv_px, dtype=np.float64)
    if np.isfinite(uv).all():
        _skeleton(img, uv)
    if label:
        put_label(img, label, 0, (255, 80, 80))
    return img


OVERLAY_MAX_WIDTH_PX = 1280  # wider frames are scaled down for the overlay video


class OverlayWriter:
    """Write RGB frames with the skeleton to an ``.mp4``; the file appears only on success.

    Frames wider than ``OVERLAY_MAX_WIDTH_PX`` are scaled down (the overlay is for
    checking the tracking by eye; the landmarks are drawn at the scaled size).

    Frames go through :class:`dexlfd.io.video.VideoWriter` (H.264, browser-playable) to
    a temporary file in the target folder, renamed into place by :meth:`close` when no
    exception is pending (a failed run leaves nothing).
    """

    def __init__(self, path: str | os.PathLike[str], fps: float) -> None:
        self.path = Path(path)
        if not self.path.parent.is_dir():
            raise InvalidFile(
                f"overlay video {self.path}: folder {self.path.parent} does not exist",
                param="overlay",
            )
        self.fps = float(fps) if fps and fps > 0 else 30.0
        self._writer = VideoWriter(self.path, self.fps)  # H.264, the one browser-playable writer
        self.n_frames = 0

    def write(self, rgb: np.ndarray, uv_px: np.ndarray | None, label: str = "") -> None:
        """Append one frame (RGB) with the landmarks ``uv_px`` (21, 2) or None."""
        import cv2

        w0 = rgb.shape[1]
        if w0 > OVERLAY_MAX_WIDTH_PX:  # encoding full 1080p frames would halve record's speed
            s = OVERLAY_MAX_WIDTH_PX / w0
            rgb = cv2.resize(rgb, (OVERLAY_MAX_WIDTH_PX, round(rgb.shape[0] * s)),
                             interpolation=cv2.INTER_LINEAR)  # fmt: skip
            uv_px = None if uv_px is None else np.asarray(uv_px) * s
        img = rgb if uv_px is None else draw_skeleton(rgb, uv_px, label)
        self._writer.write(img)
        self.n_frames += 1

    def close(self, ok: bool = True) -> None:
        """Finish the file; keep it only when ``ok`` and frames were written."""
        self._writer.close(ok=ok)

    def __enter__(self) -> OverlayWriter:
        return self

    def __exit__(self, exc_type: object, *rest: object) -> None:
        self.close(ok=exc_type is None)


def annotate_overlay(path: str | os.PathLike[str], demo: Demonstration) -> Path:
    """Mark on the overlay video ``path`` what was recorded, once it is known.

    ``path`` was written by :class:`OverlayWriter` while tracking (every frame's first
    hand, MediaPipe's label). Added per frame: the recorded hand's skeleton in yellow
    and a second label line ``recorded: <hand> hand (track k), grasp CLOSED|open``
    (``rec R#k CLOSED`` on small frames), ``... not seen``, or ``trimmed`` outside the
    kept span. Streamed frame by frame and replaced atomically.
    """
    import cv2

    path = Path(path)
    trim = demo.trim
    start = trim.start if trim is not None and trim.moved else 0
    choice = None if demo.capture is None else demo.capture.hand_choice
    hand = (choice.hand if choice else None) or (demo.motion.hand if demo.motion else "?")
    who = f"{hand} hand"
    short = who[0].upper()
    if choice is not None and choice.track is not None:
        who += f" (track {choice.track})"
        short += f"#{choice.track}"
    size = demo.image_size
    uv_all = demo.extras.get("uv_px")
    cap = cv2.VideoCapture(str(path))
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    mode = path.stat().st_mode & 0o777
    writer = VideoWriter(path, fps)  # H.264; replaces ``path`` only when closed cleanly
    ok = False
    try:
        i = 0
        while True:
            ok, bgr = cap.read()
            if not ok:
                break
            img = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
            k = i - start
            if not 0 <= k < demo.n_samples:
                text: tuple[str, ...] = ("trimmed (not in the demonstration)", "trimmed")
            elif not demo.valid[k]:
                text = (f"recorded: {who}, not seen", f"rec {short}: not seen")
            else:
                state = "CLOSED" if demo.grasp[k] else "open"
                text = (f"recorded: {who}, grasp {state}", f"rec {short} {state}")
                if uv_all is not None and np.isfinite(uv_all[k]).all():
                    s = img.shape[1] / size[0] if size else 1.0
                    _skeleton(img, np.asarray(uv_all[k]) * s, (255, 220, 0), (255, 220, 0))
            put_label(img, text, 1, (255, 220, 0))
            writer.write(img)
            i += 1
        ok = True
    finally:
        cap.release()
        if writer.close(ok=ok) is not None:
            os.chmod(path, mode)
    return path


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    try:
        atomic_write(path, lambda fh: fig.savefig(fh, format="png", dpi=110))
    finally:
        plt.close(fig)
    return path


def plot_hand_3d(
    demo: Demonstration, path: str | os.PathLike[str], frame: int | None = None
) -> Path:
    """3-D view of the hand at ``frame`` (default: the first seen frame) with its skeleton."""
    import matplotlib.pyplot as plt

    valid = np.flatnonzero(demo.valid)
    if frame is None:
        frame = int(valid[0]) if valid.size else 0
    kp = demo.keypoints[frame]
    fig = plt.figure(figsize=(6, 5.5))
    ax = fig.add_subplot(projection="3d")
    for a, b in HAND_CONNECTIONS:
        ax.plot(*kp[[a, b]].T, color="tab:green", lw=2)
    ax.scatter(*kp.T, color="tab:red", s=18)
    for k in (0, 4, 8):
        ax.text(*kp[k], f" {k}", color="tab:blue")
    # wrist trajectory for context; the axes hold the hand and the whole path
    wrist = demo.position[demo.valid]
    ax.plot(*wrist.T, color="0.6", lw=0.8, label="wrist path")
    pts = np.concatenate([kp, wrist])
    pts = pts[np.isfinite(pts).all(axis=1)]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    ctr = (lo + hi) / 2
    r = max(0.06, 0.5 * float(np.max(hi - lo)) * 1.05)
    ax.set_xlim(ctr[0] - r, ctr[0] + r)
    ax.set_ylim(ctr[1] - r, ctr[1] + r)
    ax.set_zlim(ctr[2] - r, ctr[2] + r)
    ax.set_box_aspect((1, 1, 1))
    from matplotlib.ticker import MaxNLocator

    # few, small tick labels and the axis labels padded clear of them (they overlapped)
    for axis, name in zip((ax.xaxis, ax.yaxis, ax.zaxis), "xyz", strict=True):
        axis.set_major_locator(MaxNLocator(4))
        axis.set_label_text(f"{name} [m]")
        axis.labelpad = 12
    ax.tick_params(labelsize=7, pad=2)
    approx = demo.depth_approximate
    ax.set_title(
        f"hand at t = {demo.t[frame]:.2f} s (frame {frame})"
        + (" — approximate depth" if approx else "")
    )
    ax.legend(loc="upper left", fontsize=8)
    return _save(fig, Path(path))


def plot_motion(demo: Demonstration, path: str | os.PathLike[str]) -> Path:
    """Position, yaw/pitch/roll [deg] and gripper opening over time; grasp shaded."""
    import matplotlib.pyplot as plt

    t = demo.t
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for k, name in enumerate("xyz"):
        axes[0].plot(t, demo.position[:, k], label=name)
    axes[0].set_ylabel("wrist position [m]")
    euler = demo.extras.get("euler")
    if euler is not None:
        for k, name in enumerate(("yaw ψ", "pitch θ", "roll φ")):
            axes[1].plot(t, np.degrees(euler[:, k]), label=name)
    axes[1].set_ylabel("angle [deg]")
    axes[2].plot(t, demo.gripper * 100, color="k", label="thumb–index $d_{ti}$")
    grasp = demo.meta.get("grasp", {})  # the levels read (provenance, drawn as lines)
    method = "absolute" if demo.motion is None else demo.motion.grasp_method
    thr = None if demo.motion is None else demo.motion.grasp_threshold
    if method == "absolute" and thr is not None:
        axes[2].axhline(thr * 100, color="tab:red", ls="--", lw=1, label="grasp threshold")
    ratio = demo.extras.get("aperture_ratio")
    ax2 = None
    if ratio is not None and method in ("adaptive", "ratio"):
        ax2 = axes[2].twinx()
        ax2.plot(t, ratio, color="tab:purple", lw=1, label="aperture / hand size")
        for key, ls in (("close_below", "--"), ("open_above", ":")):
            if grasp.get(key) is not None:
                ax2.axhline(grasp[key], color="tab:red", ls=ls, lw=1, label=key.replace("_", " "))
        ax2.set_ylabel("aperture ratio [-]")
    axes[2].set_ylabel("gripper opening [cm]")
    axes[2].set_xlabel("time [s]")
    for i, ax in enumerate(axes):
        _shade(ax, t, demo.grasp)
        _shade(ax, t, ~demo.valid, color="0.85")
        handles, labels = ax.get_legend_handles_labels()
        right = 1.01
        if i == 2 and ax2 is not None:  # one legend for both scales, past the right one's
            more = ax2.get_legend_handles_labels()
            handles, labels, right = handles + more[0], labels + more[1], 1.12
        if handles:  # right of the panel: inside, it covered the curves' ends
            ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(right, 1.0),
                      borderaxespad=0.0, fontsize=8)  # fmt: skip
        ax.grid(alpha=0.3)
    rate = float(demo.valid.mean()) * 100
    approx = demo.depth_approximate
    fig.suptitle(
        f"{Path(str(demo.meta.get('source', ''))).name}: hand seen in {rate:.0f} % of frames"
        + (" (approximate depth)" if approx else "")
        + "\nshaded: grasp (tan), no hand (grey)"
    )
    fig.tight_layout()
    return _save(fig, Path(path))


def _shade(ax: Any, t: np.ndarray, mask: np.ndarray, color: str = "tan") -> None:
    for a, b in true_runs(mask):
        ax.axvspan(t[a], t[b - 1], color=color, alpha=0.35, lw=0)


def save_capture_figures(demo: Demonstration, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``hand_3d.png`` and ``motion.png`` into ``out_dir`` (created if needed)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    valid = np.flatnonzero(demo.valid)
    mid = int(valid[valid.size // 2]) if valid.size else 0
    return [plot_hand_3d(demo, out / "hand_3d.png", mid), plot_motion(demo, out / "motion.png")]
