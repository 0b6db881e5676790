"""Which detection is which hand over time, and which hand does the task.

MediaPipe returns up to ``max_num_hands`` hands per frame in no fixed order, and
its handedness label can flip for a frame (two hands crossing, a hand seen from
the side). :class:`HandAssociator` gives each detection a persistent track id by
continuity: the cost of matching a detection to a track is the distance between
their palm centres in hand lengths (wrist to middle-finger MCP, in pixels), plus
a small penalty when the handedness labels differ; the cheapest assignment wins.
A track survives a short loss (``max_missing_s``) and takes back the hand that
reappears near where it left.

:func:`hand_activity` scores a track by how much it works (how far its palm
travels, in hand lengths, plus how much its aperture changes), and
:func:`choose_track` picks the working hand (``hand="auto"``) or the track whose
majority label is the requested hand (``"right"``/``"left"``).

Labels name the person's hand on an ordinary, unmirrored camera image (the
tracker corrects MediaPipe's selfie convention; see :mod:`dexlfd.capture.tracking`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.capture.tracking import HandObservation
from dexlfd.errors import InvalidInput

__all__ = [
    "AssociationConfig",
    "HandAssociator",
    "TrackActivity",
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
    max_missing_s: float = 1.0  # a track unseen longer than this is free for a new hand [s]

    def __post_init__(self) -> None:
        for name in ("max_jump", "label_penalty", "max_missing_s"):
            if not getattr(self, name) >= 0:
                raise InvalidInput(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass
class _Track:
    centre: FloatArray
    length: float
    label: str
    last_t: float


class HandAssociator:
    """Persistent ids for the hands of a stream: ``update(hands, t) -> [(id, hand), ...]``."""

    def __init__(self, cfg: AssociationConfig | None = None) -> None:
        self.cfg = cfg or AssociationConfig()
        self._tracks: dict[int, _Track] = {}
        self._next = 0

    def _cost(self, tr: _Track, h: HandObservation) -> float:
        d = float(np.linalg.norm(palm_centre(h.uv_px) - tr.centre)) / tr.length
        return d + (self.cfg.label_penalty if h.handedness != tr.label else 0.0)

    def update(self, hands: list[HandObservation], t: float) -> list[tuple[int, HandObservation]]:
        """Track ids for this frame's detections (new ids for hands far from every track)."""
        live = {k: tr for k, tr in self._tracks.items() if t - tr.last_t <= self.cfg.max_missing_s}
        ids = list(live)
        best: list[tuple[int, int]] = []
        best_cost = np.inf
        n = min(len(ids), len(hands))
        # the cheapest one-to-one matching (at most a few hands: enumerate)
        for chosen in itertools.permutations(range(len(ids)), n):
            for dets in itertools.combinations(range(len(hands)), n):
                pairs = list(zip(chosen, dets, strict=True))
                pairs = [
                    (i, j)
                    for i, j in pairs
                    if self._cost(live[ids[i]], hands[j]) <= self.cfg.max_jump
                ]
                cost = sum(self._cost(live[ids[i]], hands[j]) for i, j in pairs)
                key = (-len(pairs), cost)
                if key < (-len(best), best_cost):
                    best, best_cost = pairs, cost
        out: dict[int, int] = {j: ids[i] for i, j in best}
        for j in range(len(hands)):
            if j not in out:
                out[j] = self._next
                self._next += 1
        for j, h in enumerate(hands):
            self._tracks[out[j]] = _Track(
                palm_centre(h.uv_px), _hand_length(h.uv_px), h.handedness, t
            )
        return [(out[j], hands[j]) for j in range(len(hands))]


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

    def describe(self) -> str:
        """One line for logs and the quality report."""
        return (
            f"{self.label} hand (track {self.track}): palm travel {self.travel:.2f} hand "
            f"lengths, aperture change {self.aperture_change:.2f}, seen in "
            f"{100 * self.seen:.0f} % of frames"
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


def choose_track(activities: list[TrackActivity], hand: str = "auto") -> tuple[TrackActivity, str]:
    """The track to record and why (one sentence).

    ``hand="auto"``: the highest activity score. ``"right"``/``"left"``: among the
    tracks with that majority label, the most active; :class:`InvalidInput` when
    no track carries that label (never records the other hand under its name).
    """
    if not activities:
        raise InvalidInput("no hand track to choose from")
    ranked = sorted(activities, key=lambda a: a.score, reverse=True)
    if hand == "auto":
        best = ranked[0]
        why = f"most active of {len(ranked)} hand(s): {best.describe()}"
        if len(ranked) > 1:
            why += f"; next: {ranked[1].describe()}"
        return best, why
    if hand not in ("right", "left"):
        raise InvalidInput(f"hand must be auto, right or left, got {hand!r}")
    pool = [a for a in ranked if a.label == hand]
    if not pool:
        seen = ", ".join(sorted({a.label for a in ranked}))
        raise InvalidInput(
            f"requested hand {hand}: no {hand} hand in this recording (the tracker saw only: "
            f"{seen}; labels assume an unmirrored camera: a selfie view needs "
            "TrackerConfig.mirrored, or requested hand auto)"
        )
    return pool[0], f"requested {hand} hand: {pool[0].describe()}"
