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
    "carried_open",
    "carried_span",
    "grasp_episode",
    "lift_evidence",
    "loosened_holds",
    "open_grasps",
    "pushes",
    "runs",
    "seen_open",
    "shows_carrying",
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


def _move_kinds(
    moves: list[tuple[int, int]], carry: FloatArray, cfg: PhaseConfig
) -> list[bool | None]:
    """Each move: carrying (True), empty (False) or unknown (None) by its median cue."""
    kinds: list[bool | None] = []
    for a, z in moves:
        c = carry[a:z][np.isfinite(carry[a:z])]
        med = float(np.median(c)) if c.size >= cfg.min_cue_frames else np.nan
        kinds.append(
            True if med >= cfg.carry_above else False if med < cfg.carry_empty_below else None
        )
    return kinds


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
    kinds = _move_kinds(moves, carry, cfg)
    if True not in kinds:
        return None if False in kinds else (g0, None)
    first = kinds.index(True)
    last = len(kinds) - 1 - kinds[::-1].index(True)
    empty_before = [k for k in range(first) if kinds[k] is False]
    empty_after = [k for k in range(last + 1, len(kinds)) if kinds[k] is False]
    start = moves[empty_before[-1]][1] if empty_before else g0
    left = moves[empty_after[0]][0] if empty_after else None
    return start, left


def shows_carrying(grasp: BoolArray, a: int, b: int, carry: FloatArray, cfg: PhaseConfig) -> bool:
    """True when the pixels show the grasp ``grasp[a:b]`` carrying.

    Over its frames with a carry cue (where the palm moved), ``min_cue_frames`` or more,
    the median cue is at least ``carry_above``: something beside the hand moves with it.

    False for a grasp the picture does not back: nothing moves with the closed hand (a
    relaxed empty hand read closed) or too few cues to tell (a hand mostly unseen, or
    still).
    """
    c = np.asarray(carry[a:b], dtype=np.float64)[np.asarray(grasp[a:b], dtype=bool)]
    c = c[np.isfinite(c)]
    return bool(c.size >= cfg.min_cue_frames and np.median(c) >= cfg.carry_above)


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


def _smoothed(x: FloatArray, k: int = 5) -> FloatArray:
    """Running median over ``k`` samples (edges: the samples there)."""
    if x.size < k:
        return x
    h = k // 2
    mid = np.median(np.lib.stride_tricks.sliding_window_view(x, k), axis=1)
    return np.concatenate([x[:h], mid, x[-h:]])


def lift_evidence(
    points: FloatArray, a: int, b: int, seen: BoolArray, length: float
) -> tuple[float, float]:
    """``(rise, growth)``: how far the hand carried the object off its support over ``[a, b)``.

    An object slid or dragged along a table moves on its plane, and a straight path on
    a plane is a straight line in the picture: the palm stays on the line from where it
    grasped to where it let go. A lift leaves it: ``rise`` is the palm's largest height
    above that line [hand lengths], "up" being the image's (and the camera frame's)
    -y; ``growth`` is the hand's largest apparent size (wrist, index and little-finger
    knuckles: the palm's triangle) over the size interpolated between the two ends,
    for a camera looking down, to which a lift brings the hand closer. Both from the
    seen frames, median-filtered over 5 (landmark jumps); ``(nan, nan)`` with fewer
    than 5 seen frames.
    """
    p = np.asarray(points, dtype=np.float64)
    idx = np.arange(a, b)
    idx = idx[seen[idx] & np.isfinite(p[idx][:, (0, 5, 9, 13, 17), :2]).all(axis=(1, 2))]
    if idx.size < 5:
        return float("nan"), float("nan")
    palm = p[idx][:, (0, 5, 9, 13, 17), :2].mean(axis=1)
    palm = np.stack([_smoothed(palm[:, 0]), _smoothed(palm[:, 1])], axis=1)
    p0, p1 = palm[0], palm[-1]
    chord = p1 - p0
    span = float(np.linalg.norm(chord))
    if span < length:  # put back about where it was taken: the height over the start
        rise = float(np.max(p0[1] - palm[:, 1]))
    else:
        normal = np.array([chord[1], -chord[0]]) / span  # perpendicular, pointing up
        if normal[1] > 0:
            normal = -normal
        rise = float(np.max((palm - p0) @ normal))
    tri = p[idx][:, (0, 5, 17), :2]
    size = _smoothed(
        np.linalg.norm(tri[:, 0] - tri[:, 1], axis=1)
        + np.linalg.norm(tri[:, 1] - tri[:, 2], axis=1)
        + np.linalg.norm(tri[:, 2] - tri[:, 0], axis=1)
    )
    s = np.linspace(0.0, 1.0, idx.size)
    ends = size[0] + (size[-1] - size[0]) * s
    growth = float(np.max(size / np.maximum(ends, 1e-12)))
    return rise / length, growth


def carried_open(
    seen: BoolArray,
    still: BoolArray,
    carry: FloatArray,
    points: FloatArray,
    length: float,
    busy: BoolArray,
    cfg: PhaseConfig,
) -> list[Found]:
    """Grasps the skeleton never sees closed, read from what moves with the hand.

    A mug held by a rim pinch (thumb inside, fingers outside) or an object hiding the
    fingers that hold it leaves the hand's closure low, but the object's pixels follow
    the hand. Outside the frames ``busy`` (the grasps and episodes found already),
    consecutive moves of the hand that carry (median cue at least ``carry_above``; moves
    of unknown cue between them kept, an empty one ends the carry) are a pick-and-place
    when together they carry the palm ``min_carry`` hand lengths, lift the object off
    its support (:func:`lift_evidence`) and are followed by an empty move (the hand
    leaving without it): the grasp starts where the hand arrived at the stop the first
    carrying move leaves from, the release is where the empty hand leaves.
    """
    moves = runs(seen & ~still)
    kinds = _move_kinds(moves, carry, cfg)
    palm = np.asarray(points, dtype=np.float64)[:, (0, 5, 9, 13, 17), :].mean(axis=1)
    out: list[Found] = []
    k = 0
    while k < len(moves):
        a = moves[k][0]
        if kinds[k] is not True or busy[a : moves[k][1]].any():
            k += 1
            continue
        first = last = k
        j = k + 1
        while (
            j < len(moves) and kinds[j] is not False and not busy[moves[j][0] : moves[j][1]].any()
        ):
            last = j if kinds[j] is True else last
            j += 1
        k = j
        end = moves[last][1]
        if j >= len(moves) or kinds[j] is not False or busy[end : moves[j][0]].any():
            continue  # not seen leaving empty: no release seen
        release = moves[j][0]
        # the hand took the object in the stop before it left with it (from its arrival)
        start = moves[first - 1][1] if first > 0 and not busy[moves[first - 1][1] : a].any() else a
        moved = travel(palm, length, a, end, seen)
        rise, growth = lift_evidence(points, a, end, seen, length)
        if moved < cfg.min_carry or not (rise >= cfg.min_lift or growth >= cfg.min_lift_growth):
            continue
        why = (
            f"carried {moved:.1f} hand lengths, lifted {rise:.1f}, by a hand the skeleton "
            "reads open (the pixels beside it follow it), release"
        )
        out.append(("pick_and_place", start, release, why, release))
    return out


def grasp_episode(
    g0: int,
    stop: int,
    release: int | None,
    moved: float,
    points: FloatArray,
    seen: BoolArray,
    length: float,
    grasp: BoolArray,
    cfg: PhaseConfig,
) -> Found:
    """The episode of a closed run that carries (``grasp`` set in place, but on a drag).

    A pick-and-place, a grasp never released (``release`` None), or a drag: released
    without a lift (:func:`lift_evidence`).
    """
    end = stop if release is None else release
    txt = f"carry {moved:.1f} hand lengths"
    rise, growth = lift_evidence(points, g0, end, seen, length)
    if release is not None and rise < cfg.min_lift and not growth >= cfg.min_lift_growth:
        # the object never left its support: slid along it
        return ("drag", g0, release, f"grasp, {txt} without a lift (rose {rise:.2f}): a drag", end)
    grasp[g0:end] = True
    if release is None:
        return ("no_release", g0, None, f"grasp, {txt}, never released", stop)
    return ("pick_and_place", g0, release, f"grasp, {txt}, release", release)


def open_grasps(
    found: list[Found],
    grasp: BoolArray,
    seen: BoolArray,
    still: BoolArray,
    carry: FloatArray,
    points: FloatArray,
    length: float,
    cfg: PhaseConfig,
) -> list[Found]:
    """Grasps the pixels show outside the episodes ``found`` (``grasp`` set in place)."""
    busy = grasp.copy()
    for _, g0, _, _, stop in found:
        busy[g0:stop] = True
    out = carried_open(seen, still, carry, points, length, busy, cfg)
    for e in out:
        grasp[e[1] : e[2]] = True
    return out
