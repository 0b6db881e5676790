"""Each pick-and-place is a demonstration of its own: other episodes and unseen frames
outside it are reported, never a veto (synthetic hands with known answers)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dexlfd.io.demonstration_facts import TaskEpisode
from dexlfd.motion import MotionConfig, demonstration_from_keypoints, episode_demonstrations
from dexlfd.motion.episodes import episode_span

from .test_phases import CLOSED, OPEN, seg, track

CFG = MotionConfig(grasp_method="closure", euler_mode="palm")
# idle, reach, close at the object, carry, place, open, retreat, idle
PICK_AND_PLACE = [
    seg(1.0, OPEN), seg(1.0, OPEN, 0.2), seg(0.5, CLOSED), seg(1.5, CLOSED, 0.2),
    seg(0.5, CLOSED), seg(0.5, OPEN), seg(1.0, OPEN, -0.2), seg(1.0, OPEN),
]  # fmt: skip


def test_a_pick_and_place_then_a_hold_without_release_is_one_usable_demonstration(rng) -> None:
    # after the clean pick-and-place the hand closes, stops, moves on closed and is
    # never seen open again: "a grasp without a release"
    hold = [seg(0.5, CLOSED), seg(1.5, CLOSED, 0.2), seg(1.0, CLOSED)]
    t, kp = track(PICK_AND_PLACE + hold, rng)
    demo = demonstration_from_keypoints(t, kp, cfg=CFG)
    kinds = [e.kind for e in demo.phases.episodes]
    assert kinds == ["pick_and_place", "no_release"]
    (good,) = episode_demonstrations(demo)
    q = good.quality
    assert q.usable, q.warnings
    pp, held = demo.phases.episodes
    a, b = good.source_frames
    assert a <= pp.grasp_start and pp.release < b <= held.grasp_start
    assert any("a grasp never released (frame" in n for n in q.notes), q.notes
    # the whole recording, judged as one, is not a demonstration (the hold vetoes it)
    from dexlfd.motion import quality_report

    whole = quality_report(demo)
    assert not whole.usable and any("never released" in w for w in whole.warnings)


def test_unseen_frames_before_and_after_the_task_are_reported_not_a_veto(rng) -> None:
    # a raised, blurred hand before and after: seen in every third frame for 2 s each
    t, kp = track([seg(2.0, OPEN, 0.3)] + PICK_AND_PLACE + [seg(2.0, OPEN, -0.3)], rng)
    valid = np.ones(t.size, bool)
    blurred = np.r_[0:60, t.size - 60 : t.size]
    valid[blurred[blurred % 3 != 0]] = False
    kp[~valid] = np.nan
    demo = demonstration_from_keypoints(t, kp, valid, cfg=CFG)
    pieces = episode_demonstrations(demo)
    assert len(pieces) == 1
    q = pieces[0].quality
    assert q.usable, q.warnings
    assert any(n.startswith("hand unseen in") for n in q.notes), q.notes
    # the same hand lost for 0.7 s in the middle of the carry is not usable, named
    lost = valid.copy()
    g0 = demo.phases.episodes[0].grasp_start
    lost[g0 + 15 : g0 + 36] = False
    kp2 = np.where(lost[:, None, None], kp, np.nan)
    demo2 = demonstration_from_keypoints(t, kp2, lost, cfg=CFG)
    qs = [p.quality for p in episode_demonstrations(demo2)]
    assert not any(q2.usable for q2 in qs)
    assert any(w.startswith("hand lost") for q2 in qs for w in q2.warnings)


def test_episode_span_stays_out_of_long_losses_and_neighbours() -> None:
    t = np.arange(200) / 30.0
    valid = np.ones(200, bool)
    valid[20:50] = False  # 1 s unseen before the reach
    valid[170:185] = False  # 0.5 s unseen after the retreat
    e = TaskEpisode("pick_and_place", 10, 190, 80, 120, "made here", task_start=30, task_stop=150)
    a, b = episode_span(t, valid, e, margin_s=0.3)
    assert a == 50  # after the long loss, not the task's start minus the margin
    assert b == 159  # the task's last frame (149) plus 0.3 s (9 frames), exclusive
    # bounds of the neighbouring episodes are never crossed; the grasp always kept
    assert episode_span(t, valid, replace(e, start=70, stop=130)) == (70, 130)
    # a loss over the grasp is the carry's: it never cuts the demonstration
    assert episode_span(t, np.zeros(200, bool), e, margin_s=0.0) == (30, 150)


def test_one_open_frame_before_the_hand_is_lost_is_not_a_release(rng) -> None:
    # grasp, carry, set down and the hand is seen open in one last frame, then never
    # again (the video ends): a set-down without a release seen
    t, kp = track(PICK_AND_PLACE[:5] + [seg(0.1, OPEN), seg(1.0, OPEN)], rng)
    valid = np.ones(t.size, bool)
    valid[136:] = False
    kp[~valid] = np.nan
    demo = demonstration_from_keypoints(t, kp, valid, cfg=CFG)
    kinds = [e.kind for e in demo.phases.episodes]
    assert kinds == ["no_release"], kinds
    q = episode_demonstrations(demo)[0].quality
    assert not q.usable and any("never released" in w for w in q.warnings)
    # seen open for 0.2 s before the loss: a release
    valid[136:142] = True
    kp2 = np.where(
        valid[:, None, None], track(PICK_AND_PLACE[:5] + [seg(1.1, OPEN)], rng)[1], np.nan
    )
    demo2 = demonstration_from_keypoints(t, kp2, valid, cfg=CFG)
    assert [e.kind for e in demo2.phases.episodes] == ["pick_and_place"]


def _with_cue(segments, cues, rng):
    """Landmarks of ``segments`` and a carry cue per frame: each segment's value (NaN
    while the hand is still, as the cue is)."""
    t, kp = track(segments, rng)
    cue = np.concatenate(
        [np.full(int(round(d * 30)), c) for (d, *_), c in zip(segments, cues, strict=True)]
    )
    return t, kp, cue


def test_the_pixels_tell_the_reach_and_the_retreat_of_a_relaxed_closed_hand(rng) -> None:
    from dexlfd.motion import track_phases

    # a relaxed hand closes at rest, reaches closed (nothing moves with it), stops at the
    # object, carries it (the object's pixels follow), stops, leaves empty, then opens
    segments = [
        seg(1.0, OPEN), seg(0.5, CLOSED), seg(1.0, CLOSED, 0.2), seg(0.5, CLOSED),
        seg(1.5, CLOSED, 0.2), seg(0.5, CLOSED), seg(1.0, CLOSED, -0.2), seg(1.0, OPEN),
    ]  # fmt: skip
    nan = np.nan
    t, kp, cue = _with_cue(segments, [nan, nan, 0.05, nan, 0.8, nan, 0.05, nan], rng)
    ones = np.ones(t.size, bool)
    skeleton, _ = track_phases(t, kp, ones, world_m=kp)  # the skeleton alone: all closed
    (e,) = skeleton.episodes
    assert e.grasp_start == pytest.approx(30, abs=3) and e.release == pytest.approx(180, abs=3)
    pixels, _ = track_phases(t, kp, ones, world_m=kp, carry=cue)
    (e,) = pixels.episodes
    assert e.kind == "pick_and_place"
    assert e.grasp_start == pytest.approx(75, abs=3)  # the stop at the object
    assert e.release == pytest.approx(150, abs=3)  # where the empty hand leaves
    # the same hand moving closed with nothing following it: a hover, no grasp
    hover, _ = track_phases(t, kp, ones, world_m=kp, carry=np.where(np.isnan(cue), nan, 0.05))
    assert hover.episodes == [] and not hover.grasp.any()


def test_a_hand_that_leaves_the_frame_mid_carry_is_never_usable(rng) -> None:
    # grasp and carry, then the hand leaves the picture (never seen again)
    t, kp = track(PICK_AND_PLACE, rng)
    valid = np.ones(t.size, bool)
    valid[100:] = False  # mid-carry (the carry runs over frames 75-120)
    kp[~valid] = np.nan
    demo = demonstration_from_keypoints(t, kp, valid, cfg=CFG)
    qs = [d.quality for d in episode_demonstrations(demo)]
    assert not any(q.usable for q in qs)
    words = " ".join(w for q in qs for w in q.warnings)
    assert "frames" in words and ("never released" in words or "hand lost" in words), words


def test_a_grasp_the_skeleton_reads_open_is_found_from_what_moves_with_the_hand(rng) -> None:
    from dexlfd.motion import track_phases

    # a rim pinch: the fingers never close to the skeleton, but the object's pixels follow
    # the hand from the stop at the object, lifted, to the stop at the place; the empty
    # hand then leaves (nothing follows it)
    segments = [seg(1.0, OPEN), seg(1.0, OPEN, 0.2), seg(0.5, OPEN), seg(1.5, OPEN, 0.2),
                seg(0.5, OPEN), seg(1.0, OPEN, -0.2), seg(1.0, OPEN)]  # fmt: skip
    nan = np.nan
    t, kp, cue = _with_cue(segments, [nan, 0.05, nan, 0.8, nan, 0.05, nan], rng)
    lifted = kp.copy()
    lifted[75:120, :, 1] -= 0.08 * np.sin(np.pi * np.arange(45) / 45)[:, None]
    ones = np.ones(t.size, bool)
    skeleton, _ = track_phases(t, lifted, ones, world_m=lifted)
    assert skeleton.episodes == []  # never closed
    pixels, _ = track_phases(t, lifted, ones, world_m=lifted, carry=cue)
    (e,) = pixels.episodes
    assert e.kind == "pick_and_place" and "reads open" in e.reason
    assert e.grasp_start == pytest.approx(60, abs=3)  # the hand arrived at the object
    assert e.release == pytest.approx(135, abs=3)  # where the empty hand leaves
    assert pixels.grasp[70:130].all() and not pixels.grasp[:55].any()
    # slid along the table (no lift), nothing following the hand, or never seen leaving
    # empty (the video ends at the place): no pick-and-place
    assert track_phases(t, kp, ones, world_m=kp, carry=cue)[0].episodes == []
    empty = np.where(np.isnan(cue), nan, 0.05)
    assert track_phases(t, lifted, ones, world_m=lifted, carry=empty)[0].episodes == []
    cut = slice(0, 130)
    ended, _ = track_phases(t[cut], lifted[cut], ones[cut], world_m=lifted[cut], carry=cue[cut])
    assert ended.episodes == []
