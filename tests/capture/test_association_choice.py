"""The hand that does the task is chosen, and a hand's broken track is joined again."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

from dexlfd.capture.association import (
    AssociationConfig,
    TrackActivity,
    chain_tracks,
    choose_track,
)
from dexlfd.errors import InvalidInput


def _act(track: int, label: str, seen: float, score: float, pp: int = 0, carries: int = 0):
    return TrackActivity(track, label, 1.0, seen, score, 0.0, score, pp, carries)


def test_the_hand_that_picks_and_places_beats_the_hand_seen_most() -> None:
    # an idle raised hand seen in every frame, moving a little; the acting hand in 38 %
    idle = _act(0, "left", 1.0, 3.0)
    acting = _act(1, "right", 0.38, 1.0, pp=1, carries=1)
    best, why, warning = choose_track([idle, acting])
    assert best.track == 1 and why.startswith("the hand that does the task") and warning is None
    # without what the hands do, the old rule (activity) picks the idle hand
    assert choose_track([idle, replace(acting, pick_and_places=0, carries=0)])[0].track == 0
    # a grasp that carries (no release) still beats a hand that only moves
    assert choose_track([idle, replace(acting, pick_and_places=0)])[0].track == 1


def test_two_acting_hands_are_named_and_the_requested_one_recorded() -> None:
    bag = _act(0, "left", 0.9, 2.0, pp=0, carries=1)  # holds a bag up to the end
    chips = _act(1, "right", 0.7, 1.0, pp=1, carries=1)
    best, _, warning = choose_track([bag, chips])
    assert best.track == 1
    assert warning is not None and warning.startswith("two hands act")
    assert "1 pick-and-place" in warning and "without a release" in warning
    best, why, warning = choose_track([bag, chips], "left")
    assert best.track == 0 and why.startswith("requested left hand")
    assert warning is not None and warning.endswith("recorded the requested left hand")
    with pytest.raises(InvalidInput, match="hand left: no left hand"):
        choose_track([chips], "left")


def test_a_grasp_the_pixels_show_beats_a_pick_and_place_the_skeleton_alone_reads() -> None:
    # a hand at the border, mostly out of the picture: its relaxed fingers read closed, a
    # pick-and-place to the skeleton, and nothing beside it moves with it; the other hand
    # carries a card it never lets go, the card's pixels following it
    hanging = _act(1, "left", 0.85, 1.0, pp=1, carries=1)
    card = replace(_act(0, "right", 1.0, 1.0, pp=0, carries=1), shown_carries=1)
    best, why, warning = choose_track([hanging, card])
    assert best.track == 0 and why.startswith("the hand that does the task")
    assert warning is not None and warning.startswith("the right hand acts (track 0: 1 grasp")
    assert "the left hand does not (track 1: its 1 pick-and-place(s) only the" in warning
    assert choose_track([hanging, card], "left")[0].track == 1  # asked for: recorded
    # without the pixels (a landmark recording without them) the skeleton's ranking stays
    assert choose_track([hanging, replace(card, shown_carries=0)])[0].track == 1
    # both shown: the pick-and-place first, and both hands act
    both = [replace(hanging, shown_pick_and_places=1, shown_carries=1), card]
    best, _, warning = choose_track(both)
    assert best.track == 1 and warning is not None and warning.startswith("two hands act")


@dataclass(frozen=True)
class _Det:
    uv_px: np.ndarray
    handedness: str


def _det(x: float, y: float, label: str, size: float = 50.0) -> _Det:
    uv = np.zeros((21, 2))
    uv[:, 0], uv[:, 1] = x, y
    uv[9, 1] = y - size  # the middle MCP: hand length `size` px
    return _Det(uv, label)


def test_a_track_broken_by_a_fast_blurred_move_is_joined_again() -> None:
    t = np.arange(100) / 30.0
    tracks = {
        0: {i: _det(100 + 5 * i, 300, "right") for i in range(0, 47)},  # acting hand ...
        1: {i: _det(900, 300, "left") for i in range(100)},  # the other hand, still
        2: {i: _det(100 + 5 * i, 300, "right") for i in range(55, 100)},  # ... found again
    }
    chains = chain_tracks(t, tracks)
    assert len(chains) == 2
    acting = [c for c in chains.values() if 0 in c][0]
    assert sorted(acting) == [*range(47), *range(55, 100)]


def test_a_piece_taken_by_the_other_hands_track_goes_back_to_its_hand() -> None:
    """After a long loss the associator may give a hand to the other hand's track; the
    piece is cut off there and continues the chain it is nearest to."""
    t = np.arange(230) / 30.0
    chips = {i: _det(650, 400 + i, "right", 66) for i in range(0, 154)}
    bag = {i: _det(1200, 480, "left", 46) for i in range(0, 70)}
    bag.update({i: _det(800, 420, "left", 66) for i in range(213, 227)})  # the chips hand
    chains = chain_tracks(t, {0: bag, 1: chips}, AssociationConfig())
    hand = [c for c in chains.values() if 0 in c and 220 in c]
    assert hand and sorted(hand[0])[-1] == 226 and 150 in hand[0]
    assert [c for c in chains.values() if 60 in c and 150 not in c]  # the bag hand alone
