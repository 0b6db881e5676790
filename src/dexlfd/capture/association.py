"""Which detection is which hand over time, and which hand does the task.

MediaPipe returns up to ``max_num_hands`` hands per frame in no fixed order, and
its handedness label can flip for a frame (two hands crossing, a hand seen from
the side). :class:`HandAssociator` gives each detection a persistent track id by
continuity: the cost of matching a detection to a track is the distance between
their palm centres in hand lengths (wrist to middle-finger MCP, in pixels), plus
a small penalty when the handedness label differs from the track's (score-weighted)
majority label, so a one-frame label flip does not move a hand to another track;
the assignment matching the most detections at the least total cost wins. A track
survives a short loss (``max_missing_s``) and takes back the hand that reappears
near where it left; after a longer loss the distance it accepts grows with the
time unseen (``reacquire_speed``), so on low-resolution video, where the tracker
loses a hand for seconds, the hand that comes back near where it left keeps its
track instead of becoming a new one. Two detections of one hand (MediaPipe
sometimes returns the same hand twice) count once: the more confident is kept.

At the end of a recording :func:`chain_tracks` joins the pieces of one hand that
the tracker lost and found again elsewhere (a fast hand blurred for a few frames
starts a new track; a hand found again after seconds may be taken by the other
hand's track): every track is cut at its losses longer than ``max_missing_s`` and
each piece continues the earlier chain it is closest to (palm distance in hand
lengths plus seconds unseen), or starts its own.

:func:`hand_activity` scores a track by how much it works (how far its palm
travels, in hand lengths, plus how much its aperture changes); a caller that can
read the task's structure adds what the hand does (``pick_and_places``,
``carries``: see :func:`dexlfd.motion.phases.hand_phases`). :func:`choose_track`
picks the hand that does the task (``hand="auto"``): a hand with a pick-and-place
(grasp, carry, release) before one that only grasps and carries, before the most
active; or the track whose majority label is the requested hand
(``"right"``/``"left"``). When two hands grasp and carry it says so.

Labels name the person's hand on an ordinary, unmirrored camera image (the
tracker corrects MediaPipe's selfie convention; see :mod:`dexlfd.capture.tracking`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol, TypeVar

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.tracking import HandObservation
from dexlfd.errors import InvalidInput

__all__ = [
    "AssociationConfig",
    "HandAssociator",
    "TrackActivity",
    "chain_tracks",
    "choose_track",
    "hand_activity",
    "palm_centre",
]

PALM = (0, 5, 9, 13, 17)  # wrist and the four finger MCPs


def palm_centre(uv_px: FloatArray) -> FloatArray:
    """Mean of the wrist and the four MCP landmarks [px], shape ``(..., 2)``."""
    return np.asarray(uv_px, dtype=np.float64)[..., PALM, :].mean(axis=-2)


def _hand_length(uv_px: FloatArray) -> float:
    uv = np.asarray(uv_px, dtype=np.float64)
    return max(float(np.linalg.norm(uv[9] - uv[0])), 1.0)


@dataclass(frozen=True, slots=True)
class AssociationConfig:
    """Settings of :class:`HandAssociator`."""

    max_jump: float = 3.0  # a detection further than this many hand lengths starts a new track
    label_penalty: float = 0.5  # added cost when the handedness label differs [hand lengths]
    max_missing_s: float = 1.0  # unseen up to this long, a track accepts max_jump [s] ...
    reacquire_speed: float = 1.0  # ... then max_jump + this * (longer time) [hand lengths/s]
    max_gate: float = 8.0  # ... never beyond this [hand lengths]; grows for its own label only
    duplicate: float = 0.75  # palm centres closer than this [mean hand length] are one hand
    duplicate_other_label: float = 0.5  # ... this close when the two labels differ

    def __post_init__(self) -> None:
        for name in (
            "max_jump",
            "label_penalty",
            "max_missing_s",
            "reacquire_speed",
            "max_gate",
            "duplicate",
            "duplicate_other_label",
        ):
            if not getattr(self, name) >= 0:
                raise InvalidInput(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass
class _Track:
    centre: FloatArray
    length: float
    last_t: float
    votes: dict[str, float] = field(default_factory=dict)  # label -> summed detection score

    @property
    def label(self) -> str:
        """The score-weighted majority of the labels seen so far."""
        return max(sorted(self.votes), key=lambda k: self.votes[k])

    def see(self, h: HandObservation, t: float, shape: tuple[FloatArray, float]) -> None:
        """``h`` seen at ``t``; ``shape``: its palm centre and hand length."""
        self.centre, self.length = shape
        self.last_t = t
        self.votes[h.handedness] = self.votes.get(h.handedness, 0.0) + max(float(h.score), 1e-3)


def _shape(h: HandObservation) -> tuple[FloatArray, float]:
    """Palm centre [px] and hand length [px] of ``h``."""
    return palm_centre(h.uv_px), _hand_length(h.uv_px)


def _distinct(
    hands: list[tuple[HandObservation, tuple[FloatArray, float]]],
    duplicate: float,
    other_label: float,
) -> list[tuple[HandObservation, tuple[FloatArray, float]]]:
    """``hands`` (each with its :func:`_shape`) without second detections of one hand.

    The more confident one is kept. Two detections are one hand when their palm
    centres are closer than ``duplicate`` mean hand lengths with the same label, or
    ``other_label`` with different labels (MediaPipe's double detection of one tiny
    hand): two real hands crossing keep both.
    """
    kept: list[tuple[HandObservation, tuple[FloatArray, float]]] = []
    for h, (c, size) in sorted(hands, key=lambda hs: -float(hs[0].score)):
        if all(
            np.linalg.norm(c - kc)
            >= (duplicate if k.handedness == h.handedness else other_label) * (size + ks) / 2
            for k, (kc, ks) in kept
        ):
            kept.append((h, (c, size)))
    return [hs for hs in hands if any(hs[0] is k for k, _ in kept)]  # detection order kept


class HandAssociator:
    """Persistent ids for the hands of a stream: ``update(hands, t) -> [(id, hand), ...]``."""

    def __init__(self, cfg: AssociationConfig | None = None) -> None:
        self.cfg = cfg or AssociationConfig()
        self._tracks: dict[int, _Track] = {}
        self._next = 0

    def _cost(self, tr: _Track, h: HandObservation, centre: FloatArray, t: float) -> float:
        """Distance [hand lengths] of ``h`` (palm centre ``centre``) + label penalty.

        Inf beyond the track's gate. The gate grows after ``max_missing_s`` unseen, up
        to ``max_gate``, for a detection with the track's own (majority) label only:
        after a long loss the other label is taken back only within ``max_jump`` (near
        where the hand left; MediaPipe flips the label of tiny hands).
        """
        d = float(np.linalg.norm(centre - tr.centre)) / tr.length
        label = tr.label
        gate = self.cfg.max_jump
        if h.handedness == label:
            unseen = max(t - tr.last_t - self.cfg.max_missing_s, 0.0)
            gate = max(min(gate + self.cfg.reacquire_speed * unseen, self.cfg.max_gate), gate)
        if d > gate:
            return np.inf
        return d + (self.cfg.label_penalty if h.handedness != label else 0.0)

    def update(self, hands: list[HandObservation], t: float) -> list[tuple[int, HandObservation]]:
        """Track ids for this frame's detections (new ids for hands far from every track).

        Duplicate detections of one hand are dropped (see :class:`AssociationConfig`).
        """
        shaped = _distinct(
            [(h, _shape(h)) for h in hands], self.cfg.duplicate, self.cfg.duplicate_other_label
        )
        ids = list(self._tracks)
        out: dict[int, int] = {}
        if ids and shaped:
            from scipy.optimize import linear_sum_assignment  # slow to import: only when needed

            cost = np.array(
                [[self._cost(self._tracks[k], h, c, t) for h, (c, _) in shaped] for k in ids]
            )
            feasible = np.isfinite(cost)
            # most matches first, then the least cost: a bonus larger than any total cost
            bonus = 1.0 + float(np.where(feasible, cost, 0.0).sum())
            rows, cols = linear_sum_assignment(np.where(feasible, cost - bonus, 0.0))
            out = {int(j): ids[i] for i, j in zip(rows, cols, strict=True) if feasible[i, j]}
        for j, (h, shape) in enumerate(shaped):
            if j not in out:
                out[j] = self._next
                self._tracks[self._next] = _Track(shape[0], 1.0, t)
                self._next += 1
            self._tracks[out[j]].see(h, t, shape)
        return [(out[j], shaped[j][0]) for j in range(len(shaped))]


@dataclass(frozen=True, slots=True)
class TrackActivity:
    """How much one tracked hand works, and its majority label."""

    track: int
    label: str  # "right" or "left" (majority of the frame labels)
    label_agreement: float  # fraction of its frames with that label
    seen: float  # fraction of the recording's frames with this hand
    travel: float  # extent of the palm's path, in hand lengths (5-95 % box diagonal)
    aperture_change: float  # 95th minus 5th percentile of the aperture ratio [-]
    score: float  # seen * (travel + 2 * aperture_change)
    pick_and_places: int = 0  # grasp, carry and release episodes (set by the caller)
    carries: int = 0  # grasps that carry, released or not (set by the caller)
    # of each, the ones the pixels show carrying: something beside the closed hand moves
    # with it (the carry cue; set by the caller, 0 without a cue)
    shown_pick_and_places: int = 0
    shown_carries: int = 0

    @property
    def acts(self) -> bool:
        """True when this hand grasps and carries something."""
        return self.carries > 0

    @property
    def does(self) -> str:
        """What the hand does, in a few words."""
        if self.pick_and_places:
            return f"{self.pick_and_places} pick-and-place(s)"
        if self.carries:
            return f"{self.carries} grasp(s) without a release"
        return "no grasp"

    def describe(self) -> str:
        """One line for logs and the quality report."""
        return (
            f"{self.label} hand (track {self.track}): {self.does}, palm travel "
            f"{self.travel:.1f} hand lengths, seen in {100 * self.seen:.0f} % of frames"
        )


def _rank(a: TrackActivity) -> tuple[bool, bool, bool, bool, float]:
    """What the hand does first (pick-and-place, then grasp and carry), then activity.

    What the pixels show it carry comes before what the skeleton alone reads.
    """
    return (
        a.shown_pick_and_places > 0,
        a.shown_carries > 0,
        a.pick_and_places > 0,
        a.carries > 0,
        a.score,
    )


def _two_hands(a: TrackActivity, b: TrackActivity) -> str:
    """The line naming two hands that grasp: both act, or the pixels show one only."""
    if a.shown_carries and not b.shown_carries:
        return (
            f"the {a.label} hand acts (track {a.track}: {a.does}, the pixels beside it "
            f"move with it); the {b.label} hand does not (track {b.track}: its {b.does} "
            "only the skeleton reads, the pixels show nothing carried: a relaxed empty "
            "hand read closed?)"
        )
    return (
        f"two hands act: the {a.label} hand (track {a.track}: {a.does}) and the "
        f"{b.label} hand (track {b.track}: {b.does})"
    )


def hand_activity(track: int, uv_px: FloatArray, labels: list[str], n_frames: int) -> TrackActivity:
    """Activity of one track from its landmarks ``(m, 21, 2)`` [px] in the frames it was seen."""
    uv = np.asarray(uv_px, dtype=np.float64)
    if uv.shape[0] == 0:
        return TrackActivity(track, "right", 0.0, 0.0, 0.0, 0.0, 0.0)
    length = float(np.median(np.linalg.norm(uv[:, 9] - uv[:, 0], axis=1)))
    length = max(length, 1.0)
    c = palm_centre(uv)
    lo, hi = np.percentile(c, [5, 95], axis=0)
    travel = float(np.linalg.norm(hi - lo)) / length
    num = np.linalg.norm(uv[:, 4] - uv[:, 8], axis=1)
    den = np.maximum(np.linalg.norm(uv[:, 9] - uv[:, 0], axis=1), 1e-9)
    ap = np.percentile(num / den, [5, 95])
    change = float(ap[1] - ap[0])
    n_right = sum(lab == "right" for lab in labels)
    label = "right" if n_right >= len(labels) - n_right else "left"
    agree = max(n_right, len(labels) - n_right) / max(len(labels), 1)
    seen = uv.shape[0] / max(n_frames, 1)
    return TrackActivity(track, label, agree, seen, travel, change, seen * (travel + 2.0 * change))


def choose_track(
    activities: list[TrackActivity], hand: str = "auto"
) -> tuple[TrackActivity, str, str | None]:
    """The track to record, why (one sentence), and a warning when two hands act.

    ``hand="auto"``: a hand with a pick-and-place first, then one that grasps and
    carries, then the highest activity score; grasps the pixels show carrying (the
    carry cue: something beside the hand moves with it) first, as a relaxed empty hand
    can read closed to the skeleton. ``"right"``/``"left"``: among the
    tracks with that majority label, ranked alike; :class:`InvalidInput` when no
    track carries that label (never records the other hand under its name). The
    warning (None when at most one hand grasps and carries) names both hands, or the
    one the pixels show acting and the one they do not.
    """
    if not activities:
        raise InvalidInput("no hand track to choose from")
    ranked = sorted(activities, key=_rank, reverse=True)
    acting = [a for a in ranked if a.acts]
    warning = None
    if len(acting) > 1:
        a, b = acting[0], acting[1]
        warning = _two_hands(a, b)
    if hand == "auto":
        best = ranked[0]
        what = "the hand that does the task" if best.acts else "most active"
        why = f"{what} of {len(ranked)} hand(s): {best.describe()}"
        if len(ranked) > 1:
            why += f"; next: {ranked[1].describe()}"
        if warning:
            warning += f"; recorded the {best.label} hand (choose one with the hand setting)"
        return best, why, warning
    if hand not in ("right", "left"):
        raise InvalidInput(f"hand must be auto, right or left, got {hand!r}")
    pool = [a for a in ranked if a.label == hand]
    if not pool:
        seen = ", ".join(sorted({a.label for a in ranked}))
        raise InvalidInput(
            f"hand {hand}: no {hand} hand in this recording (the tracker saw only: "
            f"{seen}; labels assume an unmirrored camera: a selfie view needs it mirrored, "
            "or hand auto)",
            param="hand",
        )
    if warning:
        warning += f"; recorded the requested {hand} hand"
    return pool[0], f"requested {hand} hand: {pool[0].describe()}", warning


class _Seen(Protocol):
    @property
    def uv_px(self) -> FloatArray: ...

    @property
    def handedness(self) -> str: ...


T = TypeVar("T", bound=_Seen)


def chain_tracks(
    times: FloatArray,
    tracks: Mapping[int, Mapping[int, T]],
    cfg: AssociationConfig | None = None,
    max_chain_gap_s: float = 5.0,
) -> dict[int, dict[int, T]]:
    """Tracks cut at their long losses and re-joined into one chain per hand.

    Parameters
    ----------
    times : ndarray, shape (n,)
        Frame times [s].
    tracks : mapping
        ``{track id: {frame index: detection}}``; a detection has ``uv_px`` (21, 2)
        and ``handedness``.
    cfg : AssociationConfig, optional
        ``max_missing_s`` (a longer loss cuts a track), ``max_gate`` (farthest join
        [hand lengths]) and ``label_penalty``.
    max_chain_gap_s : float
        Longest loss a chain is continued over [s].

    Returns
    -------
    dict
        ``{chain id: {frame index: detection}}``, ids 0, 1, ... in order of first
        appearance. Pieces never overlap in time within a chain.
    """
    cfg = cfg or AssociationConfig()
    t = np.asarray(times, dtype=np.float64)
    pieces: list[tuple[int, list[int]]] = []
    for k, rows in tracks.items():
        frames = sorted(rows)
        cut = [0] + [
            j for j in range(1, len(frames)) if t[frames[j]] - t[frames[j - 1]] > cfg.max_missing_s
        ]
        for a, b in zip(cut, cut[1:] + [len(frames)], strict=True):
            pieces.append((k, frames[a:b]))
    pieces.sort(key=lambda p: (p[1][0], p[0]))
    chains: list[tuple[int, list[tuple[int, list[int]]]]] = []  # first track, pieces
    for k, frames in pieces:
        first = tracks[k][frames[0]]
        best, best_cost = None, np.inf
        for c, (_, members) in enumerate(chains):
            lk, lf = members[-1][0], members[-1][1][-1]
            if lf >= frames[0]:
                continue  # the chain is still seen: another hand
            gap = float(t[frames[0]] - t[lf])
            last = tracks[lk][lf]
            size = 0.5 * (_hand_length(first.uv_px) + _hand_length(last.uv_px))
            dist = float(np.linalg.norm(palm_centre(first.uv_px) - palm_centre(last.uv_px))) / size
            if gap > max_chain_gap_s or dist > cfg.max_gate:
                continue
            cost = dist + gap + (cfg.label_penalty if first.handedness != last.handedness else 0)
            if cost < best_cost:
                best, best_cost = c, cost
        if best is None:
            chains.append((k, [(k, frames)]))
        else:
            chains[best][1].append((k, frames))
    return {
        c: {i: tracks[k][i] for k, frames in members for i in frames}
        for c, (_, members) in enumerate(chains)
    }
