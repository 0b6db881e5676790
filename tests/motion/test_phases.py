"""Phases of a hand's track on synthetic hands with known answers (closed forms).

A hand is built joint by joint: four fingers bent by a given angle at every joint, the
thumb tip open (beside the hand), on the index tip (closed) or against the index's side
(flat hand), and moved along a known palm path. Speeds and travel are in hand lengths.
"""

from __future__ import annotations

import numpy as np
import pytest

from dexlfd.errors import InvalidInput
from dexlfd.io.demonstration_facts import Capture, HandChoice, TrackFigures
from dexlfd.motion import (
    GraspConfig,
    MotionConfig,
    PhaseConfig,
    demonstration_from_keypoints,
    finger_curl,
    hand_closure,
    quality_report,
    split_demonstration,
    track_phases,
    trim_demonstration,
)
from dexlfd.motion.phases import episode_bounds

FPS = 30.0
HAND_M = 0.09  # wrist to middle MCP [m]
LIFT_M = 0.08  # a carry's lift [m]


def hand(bend_deg: float, thumb: str) -> np.ndarray:
    """21 landmarks [m] of a hand with its fingers bent ``bend_deg`` at each joint."""
    kp = np.zeros((21, 3))
    a = np.radians(bend_deg)
    for f, x in enumerate((0.03, 0.01, -0.01, -0.03)):
        base = 5 + 4 * f
        p = np.array([x, HAND_M if f else 0.085, 0.0])
        kp[base] = p
        ang = 0.0
        for j, length in enumerate((0.04, 0.025, 0.02)):
            ang += a
            p = p + length * np.array([0.0, np.cos(ang), -np.sin(ang)])
            kp[base + j + 1] = p
    index_tip = kp[8]
    tip = {
        "open": np.array([0.1, 0.06, 0.0]),
        "closed": index_tip + np.array([0.0, 0.0, 0.01]),
        "flat": np.array([0.045, 0.13, 0.0]),
    }[thumb]
    kp[1] = (0.02, 0.02, 0.0)
    kp[2] = kp[1] + 0.4 * (tip - kp[1])
    kp[3] = kp[1] + 0.7 * (tip - kp[1])
    kp[4] = tip
    return kp


def track(segments: list[tuple[float, str, float, float]], rng: np.random.Generator):
    """Landmarks of a hand doing ``segments``: (duration s, thumb, bend deg, x velocity m/s)."""
    frames, x = [], 0.0
    for dur, thumb, bend, vx in segments:
        n = int(round(dur * FPS))
        for k in range(n):
            # a closed hand moving carries its object up off the table and sets it down
            # (LIFT_M at the middle; the camera frame's y points down)
            up = LIFT_M * np.sin(np.pi * k / n) if thumb == "closed" and vx else 0.0
            frames.append(hand(bend, thumb) + np.array([x, -up, 0.0]))
            x += vx / FPS
    kp = np.stack(frames) + rng.normal(0, 0.0005, (len(frames), 21, 3))
    return np.arange(len(frames)) / FPS, kp


OPEN, CLOSED, FLAT = ("open", 5.0), ("closed", 60.0), ("flat", 3.0)


def seg(dur: float, shape: tuple[str, float], vx: float = 0.0) -> tuple[float, str, float, float]:
    return (dur, shape[0], shape[1], vx)


def phases_of(t, kp, **kw):
    return track_phases(t, kp, np.ones(t.size, bool), world_m=kp, **kw)


def test_curl_and_closure_of_open_closed_and_flat_hands() -> None:
    assert finger_curl(hand(0.0, "open")) == pytest.approx(0.0, abs=1e-6)
    assert finger_curl(hand(60.0, "closed")) == pytest.approx(60.0, abs=1e-6)
    ratio = np.array([1.3, 0.1, 0.5])
    curl = np.array([0.0, 60.0, 3.0])  # open, wrapped, flat (thumb on the index's side)
    c = hand_closure(ratio, curl, GraspConfig(level_percentiles=(0, 100)))
    np.testing.assert_allclose(c.closure[:2], [0.0, 1.0])
    assert c.aperture[2] > 0.5 and c.closure[2] <= GraspConfig().open_below  # flat: never closed
    with pytest.raises(InvalidInput, match="open_below"):
        GraspConfig(open_below=0.6, close_above=0.5)


def test_close_at_a_stop_carry_and_open_is_one_pick_and_place(rng) -> None:
    # idle 1 s, reach 1 s, close at the object (stopped) 0.5 s, carry 1.5 s, place and open
    t, kp = track(
        [seg(1.0, OPEN), seg(1.0, OPEN, 0.2), seg(0.5, CLOSED), seg(1.5, CLOSED, 0.2),
         seg(0.5, CLOSED), seg(0.5, OPEN), seg(1.0, OPEN, -0.2), seg(1.0, OPEN)],
        rng,
    )  # fmt: skip
    ph, _ = phases_of(t, kp)
    assert [e.kind for e in ph.episodes] == ["pick_and_place"]
    (e,) = ph.episodes
    assert e.grasp_start == pytest.approx(60, abs=2)  # the closing, at the stop
    assert e.release == pytest.approx(135, abs=2)  # the first open frame
    assert ph.grasp.sum() == pytest.approx(75, abs=3) and ph.grasp[e.grasp_start : e.release].all()
    names = np.array(["unseen", "idle", "reach", "grasp", "release", "retreat"])[ph.phase]
    assert names[45] == "reach" and names[100] == "grasp" and names[170] == "retreat"
    assert names[10] == "idle" and names[-5] == "idle" and (names == "release").any()


def test_a_flat_hand_sliding_is_a_push_not_a_grasp(rng) -> None:
    t, kp = track(
        [seg(1.0, OPEN), seg(0.5, FLAT), seg(1.5, FLAT, 0.2), seg(0.5, FLAT), seg(1.0, OPEN)],
        rng,
    )
    ph, res = phases_of(t, kp)
    assert not ph.grasp.any() and not res.grasp.any()  # never closed
    assert [e.kind for e in ph.episodes] == ["push"]
    assert 25 <= ph.episodes[0].grasp_start <= 35
    assert "contact, no grasp" in ph.episodes[0].reason


def test_close_and_carry_without_opening_is_not_a_pick_and_place(rng) -> None:
    t, kp = track([seg(1.0, OPEN), seg(0.5, CLOSED), seg(2.0, CLOSED, 0.2), seg(1.0, CLOSED)], rng)
    ph, _ = phases_of(t, kp)
    assert [e.kind for e in ph.episodes] == ["no_release"] and ph.pick_and_places == []
    assert ph.episodes[0].release is None and ph.grasp[-1]


def test_a_hand_that_closes_without_carrying_or_while_moving_never_grasps(rng) -> None:
    # a fist made and opened in place (the real video's fists): closed, nothing carried
    t, kp = track([seg(1.0, OPEN), seg(1.0, CLOSED), seg(1.0, OPEN), seg(1.0, CLOSED)], rng)
    ph, _ = phases_of(t, kp)
    assert ph.episodes == [] and not ph.grasp.any()
    # closed all the way while moving, never stopping: no object was taken
    t, kp = track([seg(1.0, OPEN, 0.3), seg(2.0, CLOSED, 0.3), seg(1.0, OPEN, 0.3)], rng)
    assert phases_of(t, kp)[0].episodes == []


def test_a_hand_closing_in_the_air_grasps_where_it_stops(rng) -> None:
    # closes 0.5 s before reaching the object, then stops, carries, places and opens
    t, kp = track(
        [seg(1.0, OPEN), seg(0.5, OPEN, 0.2), seg(0.5, CLOSED, 0.2), seg(0.5, CLOSED),
         seg(1.5, CLOSED, 0.2), seg(0.5, CLOSED), seg(1.0, OPEN)],
        rng,
    )  # fmt: skip
    (e,) = phases_of(t, kp)[0].episodes
    assert e.kind == "pick_and_place" and e.grasp_start == pytest.approx(60, abs=4)


def test_two_pick_and_places_split_at_the_midpoint_and_keep_the_time_axis(rng) -> None:
    one = [seg(0.5, CLOSED), seg(1.0, CLOSED, 0.2), seg(0.5, CLOSED), seg(0.5, OPEN)]
    t, kp = track(
        [seg(1.0, OPEN), seg(0.5, OPEN, 0.2), *one, seg(1.0, OPEN, -0.2), seg(0.5, OPEN),
         *one, seg(1.0, OPEN)],
        rng,
    )  # fmt: skip
    ph, _ = phases_of(t, kp)
    assert [e.kind for e in ph.episodes] == ["pick_and_place"] * 2
    e1, e2 = ph.episodes
    mid = (e1.release + e2.grasp_start + 1) // 2
    assert (e1.start, e1.stop, e2.start, e2.stop) == (0, mid, mid, t.size)
    assert episode_bounds([(10, 20), (40, 60), (70, 80)], 100) == [(0, 30), (30, 65), (65, 100)]
    # through the motion stage: one demonstration each, on the recording's clock
    demo = demonstration_from_keypoints(t, kp, cfg=MotionConfig(grasp_method="closure"))
    assert demo.phases.n_pick_and_place == 2
    pieces = split_demonstration(demo)
    assert [p.episode.index for p in pieces] == [1, 2]
    (a1, b1), (a2, b2) = (p.source_frames for p in pieces)
    # each within its own bounds, holding its grasp and release, on the recording's clock
    assert 0 <= a1 <= e1.grasp_start and e1.release < b1 <= mid <= a2 <= e2.grasp_start
    assert e2.release < b2 <= t.size and pieces[1].t[0] == pytest.approx(t[a2])
    for p in pieces:
        q = quality_report(trim_demonstration(p))
        assert q.pick_and_place is not None
        assert not any("pick-and-place" in w for w in q.warnings), q.warnings
    # the whole recording holds two: not one demonstration, said with the frames
    q = quality_report(demo)
    assert not q.usable and any(w.startswith("2 pick-and-places (frames") for w in q.warnings)


def test_the_verdict_names_a_grasp_without_release_and_a_push_with_frames(rng) -> None:
    cfg = MotionConfig(grasp_method="closure")
    t, kp = track([seg(1.0, OPEN), seg(0.5, CLOSED), seg(2.0, CLOSED, 0.2), seg(1.0, CLOSED)], rng)
    q = quality_report(demonstration_from_keypoints(t, kp, cfg=cfg))
    assert not q.usable
    assert any(w.startswith("no pick-and-place: a grasp never released (frames 30-") for w in
               q.warnings)  # fmt: skip
    t, kp = track([seg(1.0, OPEN), seg(0.5, FLAT), seg(1.5, FLAT, 0.2), seg(1.0, OPEN)], rng)
    q = quality_report(demonstration_from_keypoints(t, kp, cfg=cfg))
    assert any("a push (frames" in w for w in q.warnings) and not q.usable


def test_phase_config_is_checked() -> None:
    with pytest.raises(InvalidInput, match="stop_speed"):
        PhaseConfig(stop_speed=0)
    with pytest.raises(InvalidInput, match="flat_ratio_closed"):
        PhaseConfig(flat_ratio_closed=1.5)


def test_trim_keeps_the_release_and_the_verdict_reads_depth_and_the_hand(rng) -> None:
    from dataclasses import replace

    # the hand places, opens and the tracker loses it 0.2 s later (still in view, unseen)
    t, kp = track(
        [seg(1.0, OPEN), seg(0.5, OPEN, 0.2), seg(0.5, CLOSED), seg(1.5, CLOSED, 0.2),
         seg(0.5, CLOSED), seg(0.2, OPEN), seg(0.5, OPEN)],
        rng,
    )  # fmt: skip
    valid = np.ones(t.size, bool)
    valid[126:] = False  # 15 of 141 frames
    kp[~valid] = np.nan
    cfg = MotionConfig(grasp_method="closure", euler_mode="palm")
    demo = demonstration_from_keypoints(t, kp, valid, cfg=cfg)
    (e,) = demo.phases.episodes
    assert e.kind == "pick_and_place" and e.release == pytest.approx(120, abs=2)
    cut = trim_demonstration(demo)
    a, b = cut.source_frames
    assert a <= e.grasp_start and b > e.release  # the release is kept
    q = quality_report(cut)
    assert q.usable, q.warnings
    # hand lost is judged over every frame before the trim (the tail was unseen)
    assert q.detection_rate_recorded == pytest.approx(126 / t.size)
    # a per-frame depth uncertainty, when recorded, is read
    std = np.full(cut.n_samples, 0.3)
    bad = quality_report(replace(cut, extras={**cut.extras, "depth_std": std}))
    assert not bad.usable and any(w.startswith("implausible depth") for w in bad.warnings)
    fine = quality_report(replace(cut, extras={**cut.extras, "depth_std": 0.02 + 0 * std}))
    assert fine.usable
    # the recorded hand does nothing while another hand picks and places
    tracks = (TrackFigures(0, "left", 1.0, 1.0, 0.1, 0.1, 0.1, pick_and_places=0),
              TrackFigures(1, "right", 1.0, 1.0, 5.0, 2.0, 9.0, pick_and_places=1))  # fmt: skip
    choice = HandChoice(hand="left", reason="requested left hand", track=0, tracks=tracks)
    other = replace(cut, capture=Capture(hand_choice=choice))
    assert any(w.startswith("not the acting hand") for w in quality_report(other).warnings)
    # ... unless the pixels show the recorded hand carry and not the other's pick-and-place
    shown = (replace(tracks[0], carries=1, shown_carries=1), tracks[1])
    choice = replace(choice, tracks=shown)
    other = replace(cut, capture=Capture(hand_choice=choice))
    assert not any(w.startswith("not the acting") for w in quality_report(other).warnings)


def test_the_judge_counts_the_grasps_the_pixels_show_carrying(rng) -> None:
    from dexlfd.motion.phases import track_actions

    # closes at a stop, carries 2 s, never opens
    t, kp = track([seg(1.0, OPEN), seg(0.5, CLOSED), seg(2.0, CLOSED, 0.2), seg(1.0, CLOSED)], rng)
    seen, uv = np.ones(t.size, bool), 2000.0 * kp[..., :2]
    carrying = np.full(t.size, np.nan)
    carrying[45:105] = 0.6  # the object's pixels follow the moving hand
    assert track_actions(t, uv, kp, seen, carrying) == (0, 1, 0, 1)
    # the skeleton alone, or a cue in one frame only (a hand out of the picture): not shown
    assert track_actions(t, uv, kp, seen) == (0, 1, 0, 0)
    one = np.where(np.arange(t.size) == 60, 0.0, np.nan)
    assert track_actions(t, uv, kp, seen, one) == (0, 1, 0, 0)
    # nothing moves with it: no grasp at all (a relaxed empty hand read closed)
    assert track_actions(t, uv, kp, seen, np.where(np.isnan(carrying), np.nan, 0.0))[1] == 0


def test_a_loosened_hold_at_the_place_is_not_a_release(rng) -> None:
    # carried and set down; then the thumb leaves the object while the fingers stay bent
    # around it (the hand reads half open) for 1 s at the place; then the hand closes on
    # it once more and really opens and leaves
    loose = ("open", 31.0)  # thumb apart, fingers still bent (curl part 0.47, closure 0.29)
    head = [seg(1.0, OPEN), seg(1.0, OPEN, 0.2), seg(0.5, CLOSED), seg(1.5, CLOSED, 0.2),
            seg(0.5, CLOSED)]  # fmt: skip
    tail = [seg(0.3, CLOSED), seg(0.5, OPEN), seg(1.0, OPEN, -0.2), seg(1.0, OPEN)]
    t, kp = track([*head, seg(1.0, loose), *tail], rng)
    phases, _ = phases_of(t, kp)
    (e,) = phases.episodes
    assert e.kind == "pick_and_place"
    assert e.release == pytest.approx(135 + 30 + 9, abs=3)  # the real opening
    # the same stretch with the fingers straight is a release where it starts
    t, kp = track([*head, seg(1.0, OPEN), *tail], rng)
    first = phases_of(t, kp)[0].episodes[0]
    assert first.kind == "pick_and_place" and first.release == pytest.approx(135, abs=3)
    # and a loosened hand that moves away (over a hand length) has let go
    t, kp = track([*head, seg(1.0, loose, 0.2), *tail], rng)
    moved = phases_of(t, kp)[0].episodes[0]
    assert moved.release == pytest.approx(135, abs=3)


def test_an_object_slid_along_the_table_is_a_drag_not_a_pick_and_place(rng) -> None:
    # grasp, carry 1.5 s at 0.2 m/s and release: lifted (the helper lifts closed moves)
    # and the same with the hand kept on the table (a straight path in the picture)
    segments = [seg(1.0, OPEN), seg(1.0, OPEN, 0.2), seg(0.5, CLOSED), seg(1.5, CLOSED, 0.2),
                seg(0.5, CLOSED), seg(0.5, OPEN), seg(1.0, OPEN, -0.2), seg(1.0, OPEN)]  # fmt: skip
    t, lifted = track(segments, rng)
    (e,) = phases_of(t, lifted)[0].episodes
    assert e.kind == "pick_and_place"
    flat = lifted.copy()
    flat[75:120, :, 1] -= flat[75:120, :1, 1] - flat[74, 0, 1]  # the lift taken out
    ph, _ = phases_of(t, flat)
    (d,) = ph.episodes
    assert d.kind == "drag" and "a drag" in d.reason
    assert not ph.grasp.any()
    # dragged away from the camera on a table seen obliquely: the picture's path is a
    # straight slanted line, still no lift; a lift halfway is one
    slanted = flat.copy()
    s = np.clip((np.arange(t.size) - 75) / 45.0, 0.0, 1.0)
    slanted[:, :, 1] -= 0.15 * s[:, None]
    assert [e.kind for e in phases_of(t, slanted)[0].episodes] == ["drag"]
    hump = slanted.copy()
    hump[75:120, :, 1] -= 0.06 * np.sin(np.pi * np.arange(45) / 45)[:, None]
    assert [e.kind for e in phases_of(t, hump)[0].episodes] == ["pick_and_place"]
    # a camera looking down sees a lift as the hand growing (coming closer)
    grow = flat.copy()
    scale = 1.0 + 0.4 * np.sin(np.pi * np.arange(45) / 45)
    wrist = grow[75:120, :1]
    grow[75:120] = wrist + (grow[75:120] - wrist) * scale[:, None, None]
    assert [e.kind for e in phases_of(t, grow)[0].episodes] == ["pick_and_place"]
