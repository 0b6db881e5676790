"""One hand keeps one track through long losses and label flips (low-resolution video)."""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.capture import CaptureConfig, LiftConfig, TrackerConfig, open_source, track_source
from dexlfd.capture.association import AssociationConfig, HandAssociator
from dexlfd.capture.tracking import HandObservation

from ..conftest import SHARED

MIMICPLAY = SHARED / "data" / "mimicplay_play_cam1.mp4"
MIMICPLAY2 = SHARED / "data" / "mimicplay_play_cam2.mp4"


def _hand(centre: tuple[float, float], label: str, size: float = 12.0, score: float = 0.9):
    uv = np.zeros((21, 2)) + np.array(centre)
    uv[0] = (centre[0], centre[1] + 0.5 * size)
    uv[9] = (centre[0], centre[1] - 0.5 * size)
    return HandObservation(uv, np.zeros(21), np.zeros((21, 3)), label, score)


def test_a_hand_lost_for_seconds_near_where_it_left_keeps_its_track() -> None:
    """8 fps, a 12-px hand: lost 1.6 s and 2.8 s, labels flipping; one track throughout."""
    assoc = HandAssociator()
    ids = []
    for i in range(146):
        if 56 <= i < 66 or 102 <= i < 124:  # 1.25 s and 2.75 s without a detection
            continue
        x = 60 + 10 * np.sin(i / 10)
        label = "left" if (i // 9) % 2 else "right"  # MediaPipe's label flips on tiny hands
        ((k, _),) = assoc.update([_hand((x, 50 + 5 * np.cos(i / 7)), label)], i / 8)
        ids.append(k)
    assert set(ids) == {ids[0]}


def test_the_gate_still_grows_slowly_and_duplicates_count_once() -> None:
    cfg = AssociationConfig()
    assoc = HandAssociator(cfg)
    ((k0, _),) = assoc.update([_hand((100, 100), "right", 40)], 0.0)
    # 2 s unseen: accepts max_jump + reacquire_speed * 1 s = 4 hand lengths, not 6
    ((k1, _),) = assoc.update([_hand((100, 340), "right", 40)], 2.0)
    assert k1 != k0
    # the same hand detected twice (1 px apart): one id, the confident detection kept
    a, b = _hand((100, 341), "right", 40, 0.6), _hand((101, 341), "left", 40, 0.95)
    out = assoc.update([a, b], 2.1)
    assert [(k, h) for k, h in out] == [(k1, b)]


@pytest.mark.slow
@pytest.mark.parametrize("video", [MIMICPLAY, MIMICPLAY2], ids=["cam1", "cam2"])
def test_the_real_low_resolution_arm_is_one_track(video) -> None:
    """mimicplay_play_cam1/2 (120x120, 8 fps): one arm, MediaPipe sees it in ~55 % of
    frames, loses it for up to 2.75 s, calls it "left" in about half of them and sometimes
    detects it twice. Before the growing gate, the majority label and the duplicate rule
    it became 5 (cam1; the kept one seen in 28 %) and 9 (cam2; 11 %) tracks."""
    if not video.is_file():
        pytest.skip(f"{video} not found (../shared/data/)")
    cfg = CaptureConfig(tracker=TrackerConfig(max_num_hands=2), lift=LiftConfig(model="pnp"))
    with open_source(video) as src:
        series = track_source(src, cfg, hand="auto")
    assert series.hand_choice is not None
    tracks = series.hand_choice.tracks
    assert len(tracks) == 1
    assert tracks[0].seen == pytest.approx(series.valid.mean()) and tracks[0].seen > 0.5


def test_after_a_long_loss_the_gate_is_capped_and_the_other_hand_stays_out() -> None:
    """Lost 20 s: the gate stops at max_gate; the other label comes back only nearby."""
    cfg = AssociationConfig()
    assoc = HandAssociator(cfg)
    ((k0, _),) = assoc.update([_hand((100, 100), "right", 40)], 0.0)
    # 20 s unseen: uncapped, the gate would be 3 + 19 = 22 hand lengths; capped at 8
    ((k1, _),) = assoc.update([_hand((100, 100 + 12 * 40), "right", 40)], 20.0)
    assert cfg.max_gate < 12 and k1 != k0
    assoc = HandAssociator(cfg)
    ((k0, _),) = assoc.update([_hand((100, 100), "right", 40)], 0.0)
    # 5 s unseen: a left hand 5 hand lengths away (within the grown gate of its own
    # label, 3 + 4 = 7) is another hand, not the lost right one
    ((k1, _),) = assoc.update([_hand((100, 100 + 5 * 40), "left", 40)], 5.0)
    assert k1 != k0
    # the right hand at that distance is taken back; a flipped label only near where it left
    ((k2, _),) = assoc.update([_hand((300, 100), "right", 40)], 5.1)
    assert k2 == k0
    ((k3, _),) = assoc.update([_hand((310, 110), "left", 40)], 8.0)
    assert k3 == k0


def test_two_hands_crossing_with_different_labels_stay_two() -> None:
    """Palms 0.6 hand lengths apart: the same label is one hand, different labels are two."""
    a, b = _hand((100, 100), "right", 40, 0.9), _hand((124, 100), "left", 40, 0.8)
    assert len(HandAssociator().update([a, b], 0.0)) == 2
    c = _hand((124, 100), "right", 40, 0.8)
    assert [h for _, h in HandAssociator().update([a, c], 0.0)] == [a]
