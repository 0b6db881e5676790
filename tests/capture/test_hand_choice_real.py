"""The hand that does the task, chosen on a real two-hand video (skips without the
recordings that do not ship).

The card slide (10 fps, 98 frames, 480x480, a fixed camera looking down): the image-left
hand (the person's right) slides a red card on a white cube with one finger, pinches it
as it overhangs (closed about frame 62), carries it onto the table (frames 84-86) and
never opens before the video ends. The other hand hangs at the right border doing
nothing; its relaxed fingers read closed to the skeleton in frames 5-16, where it is
mostly out of the picture.
"""

from __future__ import annotations

from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def test_the_card_hand_is_recorded_and_its_pinch_is_no_pick_and_place(shared_data: Path) -> None:
    from dexlfd.apps.record import RecordConfig, record_demonstration

    video = shared_data / "videos" / "hudor_card_slide.mp4"
    if not video.is_file():
        pytest.skip(f"{video} not found")
    res = record_demonstration(str(video), RecordConfig())
    # the hand that holds the card, never released: no demonstration
    assert res.hand == "right"
    assert not any(d.quality is not None and d.quality.usable for d in res.demos)
    (q,) = [d.quality for d in res.demos if d.quality is not None]
    assert not q.pick_and_place
    never = [w for w in q.warnings if w.startswith("no pick-and-place: a grasp never released")]
    assert never and "frames" in never[0]
    assert not any(w.startswith(("hand lost", "not the acting hand")) for w in q.warnings)
    # the hanging hand is named as not acting: the picture shows it carry nothing
    (note,) = [n for n in q.notes if "the left hand does not" in n]
    assert note.startswith("the right hand acts")
    choice = res.demo.capture.hand_choice if res.demo.capture else None
    assert choice is not None
    by_track = {a.track: a for a in choice.tracks}
    chosen, other = by_track[choice.track], [a for a in choice.tracks if a.track != choice.track]
    assert chosen.shown_carries == 1 and chosen.pick_and_places == 0
    assert [a.shown_carries for a in other if a.carries] == [0]
