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
    with np.load(path(name), allow_pickle=False) as d:
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


# ---------------------------------------------------------------- figures


def wrist_steps(keypoints: np.ndarray) -> np.ndarray:
    """Frame-to-frame wrist steps [m] between consecutive frames that both have a wrist."""
    p = keypoints[:, 0]
    both = np.isfinite(p).all(axis=1)
    pair = both[1:] & both[:-1]
    return np.linalg.norm(np.diff(p, axis=0), axis=1)[pair]


def orientation_steps_deg(keypoints: np.ndarray) -> np.ndarray:
    """Frame-to-frame turns of the palm frame (wrist, index and little-finger MCPs) [deg]."""
    from dexlfd.motion import palm_matrix_from_keypoints
    from dexlfd.rotations import rotation_angle

    R = palm_matrix_from_keypoints(keypoints, "right")
    both = np.isfinite(R).all(axis=(1, 2))
    pair = np.flatnonzero(both[1:] & both[:-1])
    return np.degrees([float(rotation_angle(R[i + 1], R[i])) for i in pair])


def palm_size_px(uv_px: np.ndarray) -> np.ndarray:
    """The palm's image size per frame [px]: the larger RMS spread of its landmarks.

    The palm landmarks (wrist, MCPs) spread along their major axis, which a turn of the
    palm foreshortens least: a size that follows the distance more than the turn.
    """
    palm = uv_px[:, [0, 5, 9, 13, 17]]
    c = palm - palm.mean(axis=1, keepdims=True)
    ok = np.isfinite(c).all(axis=(1, 2))
    out = np.full(uv_px.shape[0], np.nan)
    cov = np.einsum("nki,nkj->nij", c[ok], c[ok]) / c.shape[1]
    out[ok] = np.sqrt(np.linalg.eigvalsh(cov)[:, -1])
    return out


def frozen_fraction(
    keypoints_cam: np.ndarray,
    uv_px: np.ndarray,
    window: int = 10,
    max_depth_change_m: float = 0.003,
    min_scale_change: float = 0.1,
) -> float:
    """Fraction of ``window``-frame spans whose depth is held while the hand moves in depth.

    A span is *frozen* when the wrist's camera depth moves by less than
    ``max_depth_change_m`` in all over it (the sum of its frame-to-frame changes) while
    the palm's image size (3-frame median) changes by more than ``min_scale_change``
    (relative): the hand came nearer or went away but the depth did not follow.
    """
    z = keypoints_cam[:, 0, 2]
    size = palm_size_px(uv_px)
    r = np.full(size.size, np.nan)
    for i in range(size.size):
        near = size[max(0, i - 1) : i + 2]
        if np.isfinite(near).any():
            r[i] = np.nanmedian(near)
    n = z.size - window
    if n <= 0:
        return 0.0
    a, b = np.arange(n), np.arange(n) + window
    ok = np.isfinite(z[a]) & np.isfinite(z[b]) & np.isfinite(r[a]) & np.isfinite(r[b])
    if not ok.any():
        return 0.0
    dz = np.abs(np.diff(z))
    moved_z = np.array([np.sum(dz[i : i + window]) for i in range(n)])  # NaN across a gap
    ok &= np.isfinite(moved_z)
    held = moved_z < max_depth_change_m
    moved = np.abs(np.log(r[b] / r[a])) > min_scale_change
    return float(np.mean((held & moved)[ok]))


def travel_ratios(keypoints: np.ndarray, hand: ActingHand) -> list[float]:
    """Wrist displacement between each annotated grasp and release over its annotation.

    Positions are the median over 5 frames around each annotated frame.
    """
    p = keypoints[:, 0]

    def at(i: int) -> np.ndarray:
        with np.errstate(all="ignore"):
            return np.nanmedian(p[max(i - 2, 0) : i + 3], axis=0)

    return [float(np.linalg.norm(at(b) - at(a)) / ref) for a, b, ref in hand.grasps]


def per_frame_pnp(hand: ActingHand, hfov_deg: float = 60.0) -> np.ndarray:
    """Today's per-frame lift (:class:`PnPTracker`, camera frame) of the acting hand."""
    from dexlfd.capture import Intrinsics
    from dexlfd.capture.rgb_lifting import PnPTracker

    K = Intrinsics.from_fov(*hand.size, hfov_deg)
    tracker = PnPTracker()
    out = np.full((hand.t.size, 21, 3), np.nan)
    for i in range(hand.t.size):
        if hand.valid[i]:
            out[i] = tracker.lift(hand.uv_px[i], hand.world_m[i], K)
        else:
            tracker.reset()
    return out


# the palm's ten distances (wrist, index/middle/ring/little MCP) and the fingers' bones
# long enough to read (proximal and middle phalanges, the thumb's metacarpal and proximal
# phalanx, the wrist to the thumb's base)
BONES: tuple[tuple[int, int], ...] = (
    *((a, b) for i, a in enumerate((0, 5, 9, 13, 17)) for b in (0, 5, 9, 13, 17)[i + 1 :]),
    (5, 6), (9, 10), (13, 14), (17, 18), (6, 7), (10, 11), (14, 15), (18, 19),
    (1, 2), (2, 3), (0, 1),
)  # fmt: skip


def bone_depth(
    uv_px: np.ndarray,
    depth_m: np.ndarray,
    f_px: float,
    quantile: float = 90.0,
    least: int = 2,
    min_px: float = 6.0,
) -> np.ndarray:
    """Each frame's depth read from its least foreshortened bones ``(n,)`` [m] (NaN: none).

    A rigid bone of length ``L`` at depth ``z`` spans at most ``f L / z`` pixels (exactly
    that when square to the line of sight), so every bone bounds the depth from above and
    the bones that read it nearest are the least foreshortened. Each bone's length is its
    apparent metric size ``l z / f`` at ``quantile`` over the clip at the given depth
    ``depth_m`` (a bone only ever reads shorter than it is): the reading has that depth's
    level (its scale) and the pixels' own change from frame to frame, the whole hand
    growing or shrinking in the image. The mean of the ``least`` nearest readings of the
    bones at least ``min_px`` long in the frame (NaN with fewer, or without a depth).
    """
    uv = np.asarray(uv_px, dtype=np.float64)
    z = np.asarray(depth_m, dtype=np.float64)
    a, b = np.array(BONES).T
    lp = np.linalg.norm(uv[:, a] - uv[:, b], axis=-1)
    with np.errstate(invalid="ignore"):
        lp = np.where(np.isfinite(lp) & (lp >= min_px), lp, np.nan)
    out = np.full(z.size, np.nan)
    have = np.isfinite(z) & (z > 0) & np.isfinite(lp).any(axis=1)
    apparent = lp[have] * z[have, None] / f_px
    read = np.isfinite(apparent).sum(axis=0) >= 5  # a bone seen in fewer frames has none
    if not read.any():
        return out
    length = np.full(len(BONES), np.nan)
    length[read] = np.nanpercentile(apparent[:, read], quantile, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        each = np.sort(f_px * length[None] / lp, axis=1)  # NaN sort last
    enough = have & np.isfinite(each[:, :least]).all(axis=1)
    out[enough] = each[enough, :least].mean(axis=1)
    return out
