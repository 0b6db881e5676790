"""Real MediaPipe landmark recordings for tests and benchmarks (numpy only).

Each file holds what MediaPipe Hands reported per frame on a real pick-and-place video
(up to two hand slots per frame), with a person's annotation of the acting hand, its
grasps and the object's travel. :func:`load_acting_hand` keeps one hand per frame: the
slot on the annotated image side at the first frame (and after a loss), then the slot
nearest to the last pick (a simple rule for the tests; the capture stage has its own
hand association).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# ../shared beside the checkout; DEXLFD_SHARED overrides it (e.g. from a git worktree)
_BESIDE = Path(__file__).resolve().parents[2] / ".." / "shared"
SHARED = Path(os.environ.get("DEXLFD_SHARED", _BESIDE))
DATA = SHARED / "data" / "landmarks"

# image side of the acting hand ("left", "right", or "top": rearrange's idle hand sits at the
# right edge, below the acting one); annotated grasps (close, last closed) and travel [m]
ANNOTATION: dict[str, tuple[str, tuple[tuple[int, int, float], ...], bool]] = {
    "breakfast": ("left", ((26, 74, 0.20), (94, 132, 0.22), (152, 197, 0.32)), True),
    "rearrange": ("top", ((30, 104, 0.35), (146, 214, 0.40)), False),  # camera moves
    "llama": ("left", ((35, 104, 0.25),), True),
    "plush_toy": ("left", ((34, 61, 0.28),), True),
    "bagging": ("left", ((132, 212, 0.38),), True),
}
NAMES = tuple(ANNOTATION)


@dataclass(frozen=True)
class ActingHand:
    """One recording's acting hand, frame by frame (NaN where not picked)."""

    name: str
    t: np.ndarray  # (n,) [s]
    uv_px: np.ndarray  # (n, 21, 2) [px], corner convention
    world_m: np.ndarray  # (n, 21, 3) [m]
    score: np.ndarray  # (n,)
    valid: np.ndarray  # (n,) bool
    size: tuple[int, int]  # width, height [px]
    grasps: tuple[tuple[int, int, float], ...]
    judge_travel: bool


def path(name: str) -> Path:
    """The file of recording ``name``."""
    return DATA / f"{name}.npz"


def load_acting_hand(name: str, max_jump: float = 0.2, reseed_after: int = 10) -> ActingHand:
    """The acting hand of recording ``name`` (see the module docstring).

    A frame whose nearest slot lies farther than ``max_jump`` (in normalised image
    units) from the last pick has only the other hand in view: it is left empty.
    After ``reseed_after`` frames without a pick the side rule picks again.
    """
    side, grasps, judge = ANNOTATION[name]
    with np.load(path(name)) as d:
        t = d["t_s"].astype(float)
        img = d["image_xyz"].astype(float)
        world = d["world_xyz_m"].astype(float)
        score = d["label_score"].astype(float)
        w, h = (int(v) for v in d["frame_size_px"])
    n = t.size
    uv = np.full((n, 21, 2), np.nan)
    wm = np.full((n, 21, 3), np.nan)
    sc = np.full(n, np.nan)
    valid = np.zeros(n, bool)
    last, last_i = None, 0
    for i in range(n):
        slots = [s for s in range(img.shape[1]) if np.isfinite(img[i, s, :, :2]).all()]
        if not slots:
            continue
        centres = {s: img[i, s, [0, 5, 9, 13, 17], :2].mean(axis=0) for s in slots}
        pick = min(slots, key=lambda s: _side_key(centres[s], side))
        if last is not None and i - last_i <= reseed_after:
            pick = min(slots, key=lambda s: float(np.linalg.norm(centres[s] - last)))
            if np.linalg.norm(centres[pick] - last) > max_jump:
                continue  # only the other hand in view
        last, last_i = centres[pick], i
        uv[i] = img[i, pick, :, :2] * (w, h)
        wm[i] = world[i, pick]
        sc[i] = score[i, pick]
        valid[i] = True
    return ActingHand(name, t, uv, wm, sc, valid, (w, h), grasps, judge)


def _side_key(centre: np.ndarray, side: str) -> float:
    """Smaller for a palm centre (normalised x, y) nearer the image ``side``."""
    return float({"left": centre[0], "right": -centre[0], "top": centre[1]}[side])
