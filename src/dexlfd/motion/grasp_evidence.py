"""What decides a grasp's ends besides the closure: the release seen, the pixels, pushes.

Helpers of :func:`dexlfd.motion.phases.hand_phases` (see its module docstring): a
release must be *seen* (:func:`seen_open`), the pixels' carry cue tells a closed
hand's empty moves from its carrying ones (:func:`carried_span`,
:mod:`dexlfd.capture.carry_cue`), and a flat hand moved from a stop is a push
(:func:`pushes`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from dexlfd._types import BoolArray, FloatArray

if TYPE_CHECKING:
    from dexlfd.motion.phases import PhaseConfig

__all__ = [
    "carried_span",
    "loosened_holds",
    "pushes",
    "runs",
    "seen_open",
    "travel",
]

# an episode found: kind, grasp start, release (None: none), reason, end of its grasp
Found = tuple[str, int, int | None, str, int]


def runs(mask: BoolArray) -> list[tuple[int, int]]:
    """``[(a, b), ...]``: the runs of True, ``b`` exclusive."""
    m = np.concatenate([[0], np.asarray(mask, dtype=np.int8), [0]])
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def travel(palm: FloatArray, length: float, a: int, b: int, seen: BoolArray) -> float:
    """Extent [hand lengths] of the palm's path over the seen frames of ``[a, b)``."""
    p = palm[a:b][seen[a:b]]
    if p.shape[0] < 2:
        return 0.0
    return float(np.linalg.norm(p.max(axis=0) - p.min(axis=0))) / length


def carried_span(
    g0: int, b: int, still: BoolArray, seen: BoolArray, carry: FloatArray, cfg: PhaseConfig
) -> tuple[int, int | None] | None:
    """``(grasp start, release or None)`` of a closed run ``[g0, b)`` by the carry cue.

    Its moves (runs of seen, moving frames) are *carrying* (median cue at least
    ``carry_above``), *empty* (below ``carry_empty_below``) or unknown (fewer than
    ``min_cue_frames`` cues, or in between). None: no move carries and one is empty.
    Empty moves before the first carrying one are the reach (the grasp starts at the
    stop after the last of them), empty moves after the last carrying one the retreat
    (the release is where the first of them starts).
    """
    moves = [(a + g0, z + g0) for a, z in runs((seen & ~still)[g0:b])]
    kinds: list[bool | None] = []
    for a, z in moves:
        c = carry[a:z][np.isfinite(carry[a:z])]
        med = float(np.median(c)) if c.size >= cfg.min_cue_frames else np.nan
        kinds.append(
            True if med >= cfg.carry_above else False if med < cfg.carry_empty_below else None
        )
    if True not in kinds:
        return None if False in kinds else (g0, None)
    first = kinds.index(True)
    last = len(kinds) - 1 - kinds[::-1].index(True)
    empty_before = [k for k in range(first) if kinds[k] is False]
    empty_after = [k for k in range(last + 1, len(kinds)) if kinds[k] is False]
    start = moves[empty_before[-1]][1] if empty_before else g0
    left = moves[empty_after[0]][0] if empty_after else None
    return start, left


def seen_open(
    t: FloatArray, closed: BoolArray, seen_idx: np.ndarray, b: int, cfg: PhaseConfig
) -> int | None:
    """The release after a closed run ending at ``b``: its first open frame, or None.

    After the hand is first seen open again, it must be seen open in 2 frames at least,
    and in half of the frames of the next ``min_open_s`` (until it closes again); else
    the opening was not seen (a last frame before a loss or the video's end, a flicker).
    """
    if b >= t.size:
        return None
    later = seen_idx[seen_idx >= b]
    if later.size == 0:
        return None
    first = int(later[0])
    nxt = np.flatnonzero(closed[first:])
    end = first + int(nxt[0]) if nxt.size else t.size
    window = np.flatnonzero((t >= t[first]) & (t <= t[first] + cfg.min_open_s + 1e-9))
    window = window[window < end]
    opened = np.intersect1d(window, later)
    if opened.size < 2 or 2 * opened.size < window.size:
        return None
    return first


def pushes(
    t: FloatArray,
    seen: BoolArray,
    still: BoolArray,
    palm: FloatArray,
    length: float,
    grasp: BoolArray,
    curl: FloatArray | None,
    ratio_part: FloatArray | None,
    cfg: PhaseConfig,
) -> list[Found]:
    """Flat-hand pushes: thumb against the index, fingers straight, moved from a stop."""
    if curl is None or ratio_part is None:
        return []
    flat = (
        seen
        & ~grasp
        & (np.nan_to_num(ratio_part, nan=0.0) > cfg.flat_ratio_closed)
        & (np.nan_to_num(curl, nan=np.inf) < cfg.flat_curl_deg)
    )
    out: list[Found] = []
    for a, b in runs(flat):
        if t[b - 1] - t[a] < cfg.min_push_s - 1e-9:
            continue
        near = still & (t >= t[a] - cfg.stop_window_s) & (t <= t[b - 1])
        moved = travel(palm, length, a, b, seen)
        if near.any() and moved >= cfg.min_carry:
            out.append(
                ("push", a, b, f"a flat hand moved {moved:.1f} hand lengths: contact, no grasp", b)
            )
    return out


def loosened_holds(
    closed: BoolArray,
    closure: FloatArray,
    curl_part: FloatArray,
    palm: FloatArray,
    length: float,
    seen: BoolArray,
    cfg: PhaseConfig,
) -> BoolArray:
    """``closed`` with the open stretches of a loosened hold filled in.

    A hand holding an object the camera sees it wrap (the thumb hidden behind it, a
    set-down pushing it into place) can read open for a while: the thumb-index
    aperture widens while the fingers stay bent around the object. An open stretch
    between two closed runs is still the grasp when, over its seen frames, the
    fingers stay bent (median curl part at least ``hold_curl``), the hand is not
    open (median closure at least ``hold_closure``) and the palm stays at one place
    (it moves less than ``min_carry`` hand lengths): the fingers never let go.
    """
    out = np.asarray(closed, dtype=bool).copy()
    rr = runs(out)
    for (_, b1), (a2, _) in zip(rr, rr[1:], strict=False):
        idx = np.arange(b1, a2)
        idx = idx[seen[idx]]
        c, k = closure[idx], curl_part[idx]
        c, k = c[np.isfinite(c)], k[np.isfinite(k)]
        if c.size == 0 or k.size == 0:
            continue  # a loss: the state is kept over it anyway
        if (
            float(np.median(c)) >= cfg.hold_closure
            and float(np.median(k)) >= cfg.hold_curl
            and travel(palm, length, b1, a2, seen) < cfg.min_carry
        ):
            out[b1:a2] = True
    return out
