"""The task's structure in one hand's track: idle, reach, grasp and carry, release, retreat.

A pick-and-place is read from what the hand does, not from one threshold:

* the hand is *closed* where its closure (:func:`dexlfd.motion.grasp.hand_closure`:
  aperture and finger curl against the hand's own levels) is high; a flat hand
  (straight fingers) is never closed;
* a closed run is a **grasp** only when the hand closes at a stop (at the object:
  the palm's speed is below ``stop_speed`` hand lengths/s at the closing or within
  ``stop_window_s`` before it, as the fingers close while the hand lifts; a run
  that closes in the air starts at its first stop instead, and one that never
  stops is no grasp), **carries** (the palm travels at least ``min_carry`` hand
  lengths while closed) and lasts ``min_grasp_s``;
* with the pixels' **carry cue** (:mod:`dexlfd.capture.carry_cue`), the moves of a
  closed run are judged by what moves with the hand: a run whose measured moves are all
  empty (nothing beside the hand follows it) is no grasp (a hover, a relaxed hand
  moving); moves before the first carrying one are the reach (the grasp starts at the
  stop after them) and moves after the last carrying one the retreat (the object was
  left at the stop before: the release is where the empty hand leaves, even if the
  fingers never open); without the cue the skeleton rules below stay;
* the grasp ends with a **release** when the hand is seen open again; a closed run
  broken by a loss of the hand keeps its state until the hand is seen again (the
  hand that comes back open released the object during the loss);
* the frames before a grasp back to the last stop are the **reach**, the frames
  after the release until the hand stops again the **retreat** (the release itself
  lasts while the hand stays at the place, at most ``release_s``); the rest is idle.

An **episode** is one grasp with its reach and retreat: ``"pick_and_place"`` (grasp,
carry, release), ``"no_release"`` (a grasp never released: a pour, a held bag),
``"push"`` (a flat hand, thumb against the index and fingers straight, moved over
``min_carry`` hand lengths from a stop: contact without a grasp) or ``"drag"`` (a
released grasp whose object never left its support: the palm stays on the picture's
line from the grasp to the release, as a path along a table does, and the hand never
comes closer to a camera looking down; :func:`~dexlfd.motion.grasp_evidence.lift_evidence`).
Only pick-and-places
are demonstrations; the others are reported with their frame range.

Speeds and travel are in hand lengths (wrist to middle-finger MCP), from the image
landmarks when given (no metric depth needed), else from the 3-D ones.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from dexlfd._types import BoolArray, FloatArray
from dexlfd._validation import check_positive
from dexlfd.errors import InvalidInput
from dexlfd.io.demonstration_facts import Phases, TaskEpisode
from dexlfd.motion.grasp import (
    GraspConfig,
    GraspResult,
    HandClosure,
    aperture_ratio,
    detect_grasp,
    finger_curl,
)
from dexlfd.motion.grasp_evidence import (
    Found,
    carried_span,
    grasp_episode,
    loosened_holds,
    open_grasps,
    pushes,
    runs,
    seen_open,
    shows_carrying,
    travel,
)

__all__ = [
    "EPISODE_KINDS",
    "PHASES",
    "Episode",
    "HandPhases",
    "PhaseConfig",
    "episode_bounds",
    "hand_phases",
    "palm_speed",
    "track_actions",
    "track_phases",
]

PHASES = ("unseen", "idle", "reach", "grasp", "release", "retreat")
EPISODE_KINDS = ("pick_and_place", "no_release", "push", "drag")
_PALM = (0, 5, 9, 13, 17)  # wrist and the four finger MCPs


@dataclass(frozen=True, slots=True)
class PhaseConfig:
    """Settings of :func:`hand_phases` (speeds and distances in hand lengths)."""

    stop_speed: float = 1.5  # the palm is stopped below this [hand lengths/s]
    stop_window_s: float = 0.2  # a hand closing this soon after a stop grasps there [s]
    min_carry: float = 1.0  # a grasp carries the palm at least this far [hand lengths]
    min_grasp_s: float = 0.5  # a released grasp lasts at least this long [s]
    release_s: float = 0.5  # longest release (hand open, still at the place) [s]
    min_still_s: float = 0.2  # a reach starts / a retreat ends after a stop this long [s]
    flat_ratio_closed: float = 0.5  # push: aperture part of the closure above this ...
    flat_curl_deg: float = 20.0  # ... with the fingers bent less than this [deg]
    min_push_s: float = 0.3  # push: the flat hand moves for at least this long [s]
    # a release is seen: the hand seen open in at least half of the frames of this long
    # after the grasp ends, and in 2 at least [s] (one open frame before the hand is lost,
    # or the video ends, is not a release)
    min_open_s: float = 0.3
    # pixel cue (capture.carry_cue: the fraction of the corners beside the hand moving with
    # it): a move of the closed hand is empty below this median, carries from the next up.
    # One split, a quarter of the ring following the hand: on the three lfo videos empty
    # moves read 0.02-0.19 and carrying ones 0.33-1.0; the midpoint fitted on any two of
    # them (0.20, 0.26, 0.31) classifies every move of the third right
    carry_empty_below: float = 0.25
    carry_above: float = 0.25
    min_cue_frames: int = 3  # frames with a cue a move needs to be judged by it
    # a loosened hold (grasp_evidence.loosened_holds): an open stretch at one place with
    # the fingers still bent (median curl part >= hold_curl) and the hand not open
    # (median closure >= hold_closure) does not end the grasp. Only the shelf video has
    # one; every recording's figures are the same for hold_curl 0.3-0.5 and hold_closure
    # 0.15-0.25 (the middle of that range is used)
    hold_curl: float = 0.4
    hold_closure: float = 0.2
    # a lift (grasp_evidence.lift_evidence): the palm rises this far above the line from
    # the grasp to the release [hand lengths], or the hand looks this much bigger than at
    # its ends (a camera looking down); else the object was slid along its support (a
    # drag). Every real lift here rises 1.4-3.9 hand lengths
    min_lift: float = 0.5
    min_lift_growth: float = 1.25

    def __post_init__(self) -> None:
        for name in ("stop_speed", "min_carry"):
            check_positive(getattr(self, name), name)
        for name in ("stop_window_s", "release_s", "min_still_s", "min_push_s", "min_grasp_s",
                     "min_open_s"):  # fmt: skip
            check_positive(getattr(self, name), name, strict=False)
        check_positive(self.flat_curl_deg, "flat_curl_deg")
        if not 0 < self.flat_ratio_closed < 1:
            raise InvalidInput(f"flat_ratio_closed must be in (0, 1), got {self.flat_ratio_closed}")


@dataclass(frozen=True, slots=True)
class Episode:
    """One grasp (or push) with its reach and retreat; frames ``[start, stop)``.

    ``grasp_start`` is the first grasping frame, ``release`` the first frame seen
    open after it (None without a release); ``reason`` says what it is in words.
    ``[task_start, task_stop)`` are the frames of the task itself, from the reach's
    first frame to the retreat's end (the hand still again); ``[start, stop)`` also
    holds the idle frames shared with the neighbouring episodes. None: not known
    (an episode made by hand).
    """

    kind: str  # one of EPISODE_KINDS
    start: int
    stop: int
    grasp_start: int
    release: int | None
    reason: str
    task_start: int | None = None
    task_stop: int | None = None

    @property
    def is_pick_and_place(self) -> bool:
        """True for a grasp, a carry and a release."""
        return self.kind == "pick_and_place"

    def to_dict(self, t: FloatArray | None = None) -> dict[str, Any]:
        """JSON-able form (with times [s] when ``t`` is given)."""
        d: dict[str, Any] = asdict(self)
        if t is not None:
            d["grasp_start_s"] = float(t[self.grasp_start])
            d["release_s"] = None if self.release is None else float(t[self.release])
        return d


@dataclass(frozen=True, slots=True)
class HandPhases:
    """The phases of one track and its episodes."""

    phase: np.ndarray  # (n,) int8, index into PHASES
    grasp: BoolArray  # (n,) True on the grasps (with or without a release)
    episodes: list[Episode] = field(default_factory=list)
    speed: FloatArray | None = None  # (n,) palm speed [hand lengths/s], NaN where unseen

    @property
    def pick_and_places(self) -> list[Episode]:
        """The episodes that are demonstrations."""
        return [e for e in self.episodes if e.is_pick_and_place]

    def describe(self, t: FloatArray) -> Phases:
        """The summary a demonstration keeps (its typed ``phases``)."""
        return Phases(
            episodes=tuple(TaskEpisode.from_json(e.to_dict(t), "phases") for e in self.episodes),
            n_pick_and_place=len(self.pick_and_places),
            phase_frames={p: int(np.sum(self.phase == k)) for k, p in enumerate(PHASES)},
        )


def _palm_and_length(points: FloatArray) -> tuple[FloatArray, float]:
    p = np.asarray(points, dtype=np.float64)
    palm = p[:, _PALM, :].mean(axis=1)
    length = np.linalg.norm(p[:, 9] - p[:, 0], axis=-1)
    ok = np.isfinite(length) & (length > 0)
    return palm, float(np.median(length[ok])) if ok.any() else 1.0


def palm_speed(t: FloatArray, points: FloatArray, valid: BoolArray) -> FloatArray:
    """Palm-centre speed [hand lengths/s] over the seen frames, NaN elsewhere.

    ``points`` ``(n, 21, d)``: image landmarks [px] or 3-D ones, any unit (divided by
    the median hand length). The palm centre is median-filtered over 3 seen frames
    (one-frame landmark jumps) before central differences.
    """
    t = np.asarray(t, dtype=np.float64)
    palm, length = _palm_and_length(points)
    v = np.asarray(valid, dtype=bool) & np.isfinite(palm).all(axis=1)
    out = np.full(t.size, np.nan)
    idx = np.flatnonzero(v)
    if idx.size < 2:
        return out
    pc = palm[idx] / length
    if idx.size >= 3:
        med = np.median(np.stack([pc[:-2], pc[1:-1], pc[2:]]), axis=0)
        pc = np.concatenate([pc[:1], med, pc[-1:]])
    vel = np.gradient(pc, t[idx], axis=0)
    out[idx] = np.linalg.norm(vel, axis=1)
    return out


def _still(speed: FloatArray, seen: BoolArray, cfg: PhaseConfig) -> BoolArray:
    """Seen frames where the palm is stopped."""
    return seen & (np.nan_to_num(speed, nan=np.inf) < cfg.stop_speed)


def hand_phases(
    t: FloatArray,
    closed: BoolArray,
    points: FloatArray,
    valid: BoolArray,
    *,
    curl: FloatArray | None = None,
    ratio_part: FloatArray | None = None,
    cfg: PhaseConfig | None = None,
    carry: FloatArray | None = None,
    closure: HandClosure | None = None,
) -> HandPhases:
    """Phases and episodes of one hand's track (see the module docstring).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Times [s], increasing.
    closed : ndarray of bool, shape (n,)
        Where the hand is closed (``detect_grasp(..., method="closure")``).
    points : ndarray, shape (n, 21, d)
        Landmarks giving the palm's motion: image [px] (d = 2) or 3-D (d = 3).
    valid : ndarray of bool, shape (n,)
        Frames where the hand is seen.
    curl : ndarray, shape (n,), optional
        Finger curl [deg]; with ``ratio_part`` (the aperture part of the closure,
        0 open .. 1 closed), flat-hand pushes are found.
    cfg : PhaseConfig, optional
    carry : ndarray, shape (n,), optional
        The pixels' carry cue (NaN where unmeasured); None: the skeleton only.
    closure : HandClosure, optional
        The closure behind ``closed``: with it a loosened hold (fingers still bent
        around the object, only the thumb apart) does not end a grasp.

    Returns
    -------
    HandPhases
    """
    cfg = cfg or PhaseConfig()
    t = np.asarray(t, dtype=np.float64)
    n = t.size
    seen = np.asarray(valid, dtype=bool)
    closed = np.asarray(closed, dtype=bool) & np.ones(n, bool)
    speed = palm_speed(t, points, seen)
    palm, length = _palm_and_length(points)
    still = _still(speed, seen, cfg)
    seen_idx = np.flatnonzero(seen)
    if closure is not None:
        closed = loosened_holds(closed, closure.closure, closure.curl, palm, length, seen, cfg)
    grasp = np.zeros(n, bool)
    found: list[Found] = []
    for a, b in runs(closed):
        sa = seen_idx[(seen_idx >= a) & (seen_idx < b)]
        if sa.size == 0:
            continue
        # a grasp closes at the object, where the hand stops: the closing itself when
        # the hand is stopped then or has just left a stop (the fingers close as it
        # lifts); a hand closing in the air before a stop grasps at that stop
        before = still & (t >= t[a] - cfg.stop_window_s) & (t <= t[a])
        in_run = np.flatnonzero(still[a:b]) + a
        if before.any() or _at_stop(a, still, seen):
            g0 = a
        elif in_run.size:
            g0 = int(in_run[0])
        else:
            continue  # closed while moving, never at an object
        left = None  # a release the pixels show (the empty hand leaves)
        if carry is not None:
            span = carried_span(g0, b, still, seen, carry, cfg)
            if span is None:
                continue  # moved closed, nothing moved with it
            g0, left = span
        stop = b if left is None else left
        moved = travel(palm, length, g0, stop, seen)
        if moved < cfg.min_carry:
            continue  # closed without carrying anything
        end = seen_idx[seen_idx < stop][-1]  # last closed frame seen
        if t[end] - t[g0] < cfg.min_grasp_s - 1e-9 and stop < n:
            continue  # too short to hold and carry an object
        # a loss ending the run: the release is the first frame seen open after it, once
        # the hand is seen open long enough to be sure
        release = left if left is not None else seen_open(t, closed, seen_idx, b, cfg)
        found.append(grasp_episode(g0, stop, release, moved, points, seen, length, grasp, cfg))
    if carry is not None:
        found += open_grasps(found, grasp, seen, still, carry, points, length, cfg)
    found += pushes(t, seen, still, palm, length, grasp, curl, ratio_part, cfg)
    found.sort(key=lambda e: e[1])
    phase = np.where(seen, PHASES.index("idle"), PHASES.index("unseen")).astype(np.int8)
    episodes = _episodes(t, found, grasp, still, seen, phase, cfg)
    return HandPhases(phase, grasp, episodes, speed)


def _at_stop(i: int, still: BoolArray, seen: BoolArray) -> bool:
    """True when the hand is stopped at frame ``i`` (or at its nearest seen frames)."""
    idx = np.flatnonzero(seen)
    near = idx[np.argsort(np.abs(idx - i), kind="stable")[:3]]
    return bool(still[near].sum() >= 2)


def _last_still_before(i: int, still: BoolArray, t: FloatArray, cfg: PhaseConfig) -> int:
    """First frame of the motion ending at ``i``: after the last stop of ``min_still_s``."""
    for a, b in reversed(runs(still[:i])):
        if t[b - 1] - t[a] >= cfg.min_still_s - 1e-9:
            return b
    return 0


def _first_still_after(i: int, still: BoolArray, t: FloatArray, cfg: PhaseConfig) -> int:
    """End (exclusive) of the motion starting at ``i``: where a stop of ``min_still_s`` begins."""
    for a, b in runs(still[i:]):
        if t[i + b - 1] - t[i + a] >= cfg.min_still_s - 1e-9:
            return i + a
    return t.size


def _episodes(
    t: FloatArray,
    found: list[Found],
    grasp: BoolArray,
    still: BoolArray,
    seen: BoolArray,
    phase: np.ndarray,
    cfg: PhaseConfig,
) -> list[Episode]:
    """Episodes with their reach and retreat; ``phase`` is filled in place (owned here)."""
    n = t.size
    bounds = episode_bounds([(g0, stop) for _, g0, _, _, stop in found], n)
    episodes = []
    for (kind, g0, g1, why, stop), (lo, hi) in zip(found, bounds, strict=True):
        end = stop if g1 is None else g1
        reach0 = max(_last_still_before(g0, ~grasp & still, t, cfg), lo)
        phase[reach0:g0] = PHASES.index("reach")
        phase[g0:end] = PHASES.index("grasp")
        back = hi
        if g1 is not None:
            leave = g1
            while leave < hi and leave < n and still[leave] and t[leave] - t[g1] < cfg.release_s:
                leave += 1
            leave = max(leave, g1 + 1)
            phase[g1:leave] = PHASES.index("release")
            back = min(_first_still_after(leave, still, t, cfg), hi) if leave < n else n
            phase[leave:back] = PHASES.index("retreat")
        episodes.append(Episode(kind, lo, hi, g0, g1, why, reach0, max(back, end)))
    phase[~seen] = PHASES.index("unseen")
    return episodes


def episode_bounds(grasps: list[tuple[int, int]], n: int) -> list[tuple[int, int]]:
    """``[start, stop)`` of each episode: cut at the midpoints between consecutive grasps.

    ``grasps`` are ``(grasp_start, release)`` frames in time order; the first episode
    starts at 0, the last ends at ``n``; between two, the frames from a release to the
    next grasp are shared at their midpoint (each keeps its retreat and reach).
    """
    out = []
    for k, (g0, _) in enumerate(grasps):
        lo = 0 if k == 0 else (grasps[k - 1][1] + g0 + 1) // 2
        hi = n if k == len(grasps) - 1 else (grasps[k][1] + grasps[k + 1][0] + 1) // 2
        out.append((int(lo), int(max(hi, lo + 1))))
    return out


def track_phases(
    t: FloatArray,
    points: FloatArray,
    valid: BoolArray,
    *,
    world_m: FloatArray | None = None,
    uv_px: FloatArray | None = None,
    grasp_cfg: GraspConfig | None = None,
    cfg: PhaseConfig | None = None,
    carry: FloatArray | None = None,
) -> tuple[HandPhases, GraspResult]:
    """Closure and phases of one track from its landmarks.

    Parameters
    ----------
    t : ndarray, shape (n,)
    points : ndarray, shape (n, 21, 3)
        3-D landmarks (any rigid frame); NaN where unseen.
    valid : ndarray of bool, shape (n,)
    world_m : ndarray, shape (n, 21, 3), optional
        MediaPipe's world landmarks: the finger curl and 3-D aperture read them
        (they do not depend on the monocular depth); default ``points``.
    uv_px : ndarray, shape (n, 21, 2), optional
        Image landmarks [px]: the aperture's image half and the palm's motion read
        them (default: the 3-D landmarks).
    grasp_cfg : GraspConfig, optional
        Its ``method`` is ignored: the closure is used.
    cfg : PhaseConfig, optional
    carry : ndarray, shape (n,), optional
        The pixels' carry cue per frame (:func:`hand_phases`).
    """
    from dataclasses import replace

    shape3 = np.asarray(points).shape
    shape = world_m if world_m is not None and np.shape(world_m) == shape3 else points
    uv = uv_px if uv_px is not None and np.shape(uv_px)[:2] == shape3[:2] else None
    v = np.asarray(valid, dtype=bool)
    ratio = np.where(v, aperture_ratio(shape, uv), np.nan)
    curl = np.where(v, finger_curl(shape), np.nan)
    gcfg = replace(grasp_cfg or GraspConfig(), method="closure")
    gap = np.full(ratio.shape, np.nan)
    res = detect_grasp(t, gap, ratio, gcfg, curl=curl)
    closure = res.closure
    if closure is None:  # pragma: no cover - the closure method always returns it
        raise InvalidInput("grasp method closure returned no closure")
    phases = hand_phases(
        t,
        res.grasp,
        uv if uv is not None else points,
        v,
        curl=curl,
        ratio_part=closure.aperture,
        cfg=cfg,
        carry=carry,
        closure=closure,
    )
    return phases, res


def track_actions(
    t: FloatArray,
    uv_px: FloatArray,
    world_m: FloatArray,
    valid: BoolArray,
    carry: FloatArray | None = None,
) -> tuple[int, int, int, int]:
    """What one track does: the capture stage's hand judge.

    ``(pick_and_places, carries, shown pick_and_places, shown carries)``: ``carries``
    counts every grasp that carries (with or without a release); the shown ones are
    those the pixels show carrying: something beside the closed hand moves with it
    (``carry``, the carry cue, NaN where unmeasured; none without it;
    :func:`~dexlfd.motion.grasp_evidence.shows_carrying`). See
    :func:`dexlfd.capture.track_source` (``judge``).
    """
    cfg = PhaseConfig()
    seen = np.asarray(valid, dtype=bool)
    if carry is not None and not np.isfinite(carry).any():
        carry = None  # no cue measured: the skeleton alone, as without one
    phases, _ = track_phases(t, world_m, seen, world_m=world_m, uv_px=uv_px, carry=carry, cfg=cfg)
    grasps = [e for e in phases.episodes if e.kind in ("pick_and_place", "no_release")]
    shown = [False] * len(grasps)
    if carry is not None:
        shown = [shows_carrying(phases.grasp, e.start, e.stop, carry, cfg) for e in grasps]
    pnp = [e.is_pick_and_place for e in grasps]
    return sum(pnp), len(grasps), sum(p and s for p, s in zip(pnp, shown, strict=True)), sum(shown)
