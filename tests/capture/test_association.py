"""Hand tracks across frames, the choice of the working hand, the mirroring convention."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dexlfd.capture import CaptureConfig, LiftConfig, TrackerConfig, open_source, track_source
from dexlfd.capture.association import HandAssociator, choose_track, hand_activity
from dexlfd.capture.tracking import HandObservation
from dexlfd.errors import InvalidInput


def _hand(centre: tuple[float, float], label: str, size: float = 40.0) -> HandObservation:
    """A hand-shaped set of 21 pixels around ``centre`` (wrist below, fingers up)."""
    rng = np.random.default_rng(0)
    uv = np.array(centre) + rng.normal(0, 0.3 * size, (21, 2))
    uv[0] = (centre[0], centre[1] + 0.5 * size)
    uv[9] = (centre[0], centre[1] - 0.5 * size)
    return HandObservation(uv, np.zeros(21), np.zeros((21, 3)), label, 0.9)


def test_tracks_survive_crossing_label_flips_and_short_losses() -> None:
    """Two hands swap sides; MediaPipe's order and labels are shuffled; ids follow the hands."""
    assoc = HandAssociator()
    xs = np.linspace(100, 500, 41)  # hand A moves right, hand B left; they cross at 300
    ids_a, ids_b = [], []
    for i, xa in enumerate(xs):
        xb = 600 - xa
        a = _hand((xa, 200 + 3 * i), "right" if i % 7 else "left")  # label flips now and then
        b = _hand((xb, 260 - 3 * i), "left")
        hands = [b, a] if i % 2 else [a, b]  # detection order is arbitrary
        if 20 <= i < 24:
            hands = [b]  # hand A lost for 4 frames (0.13 s at 30 fps) near the crossing
        out = dict((id(h), k) for k, h in assoc.update(hands, i / 30))
        if id(a) in out:
            ids_a.append(out[id(a)])
        ids_b.append(out[id(b)])
    assert set(ids_a) == {ids_a[0]} and set(ids_b) == {ids_b[0]} and ids_a[0] != ids_b[0]


def test_a_hand_far_away_after_a_long_loss_is_a_new_track() -> None:
    assoc = HandAssociator()
    ((k0, _),) = assoc.update([_hand((100, 100), "right")], 0.0)
    ((k1, _),) = assoc.update([_hand((110, 100), "right")], 0.5)  # near: same hand
    ((k2, _),) = assoc.update([_hand((600, 400), "right")], 3.0)  # far and 2.5 s later
    assert k0 == k1 != k2


def test_choose_the_working_hand_and_refuse_a_missing_label() -> None:
    rng = np.random.default_rng(1)
    n = 60
    base = np.stack([_hand((0, 0), "right").uv_px] * n)
    working = base + np.linspace(0, 200, n)[:, None, None] * np.array([1.0, 0.3])  # carries
    idle = base + 400 + rng.normal(0, 0.5, base.shape)  # resting, only jitter
    acts = [
        hand_activity(0, idle, ["left"] * n, n),
        hand_activity(1, working, ["right"] * n, n),
    ]
    best, why, warning = choose_track(acts, "auto")
    assert warning is None  # one hand acts (or none): no two-hands warning
    assert best.track == 1 and "right hand" in why and best.travel > 3 > 0.1 > acts[0].travel
    assert choose_track(acts, "left")[0].track == 0
    with pytest.raises(InvalidInput, match="hand left: no left hand") as err:
        choose_track([acts[1]], "left")
    # the CLI names its flag
    from dexlfd.cli import _build_parser, _subparser, error_text

    cli = error_text(err.value, _subparser(_build_parser(), "record").get_default("_params"))
    assert cli.startswith("--hand left: no left hand") and "mirrored" in cli


def test_mirroring_convention_on_the_real_right_hand(hand_video: Path) -> None:
    """This real RIGHT hand is "right" on the unmirrored video (default) and "left" with
    mirrored=True, whatever each MediaPipe API's own label convention (the legacy API assumes
    a selfie image; the Tasks API, the default backend, does not)."""
    from dexlfd.capture.tracking import make_tracker

    with open_source(hand_video, max_frames=1, resize_width=640) as src:
        rgb = next(iter(src)).rgb
    labels = {}
    for mirrored in (False, True):
        cfg = TrackerConfig(static_image_mode=True, mirrored=mirrored)
        with make_tracker(cfg) as tracker:
            labels[mirrored] = [h.handedness for h in tracker.detect(rgb, 0.0)]
    assert labels == {False: ["right"], True: ["left"]}


def _two_hand_video(hand_video: Path, path: Path) -> None:
    """Left half: the real right hand closing into a fist and pinching (frames 240-330);
    right half: its mirror image (a left hand) frozen at frame 0, idle."""
    import cv2

    with open_source(hand_video, max_frames=331, resize_width=480) as src:
        frames = [f.rgb for f in src]
    idle = frames[0][:, ::-1]
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), 15.0, (960, 270))
    for rgb in frames[240:331:3]:
        vw.write(cv2.cvtColor(np.concatenate([rgb, idle], axis=1), cv2.COLOR_RGB2BGR))
    vw.release()


def test_auto_follows_the_working_hand_of_two_real_hands(hand_video: Path, tmp_path: Path) -> None:
    video = tmp_path / "two.mp4"
    _two_hand_video(hand_video, video)
    cfg = CaptureConfig(
        tracker=TrackerConfig(max_num_hands=2), lift=LiftConfig(model="assumed_depth")
    )
    chosen = {}
    for hand in ("auto", "left"):
        with open_source(video) as src:
            series = track_source(src, cfg, hand=hand)
        choice = series.hand_choice  # a typed field of the series, not meta
        assert choice is not None and "hand_choice" not in series.meta
        assert len([a for a in choice.tracks if a.seen > 0.5]) == 2  # both followed
        x = np.nanmedian(series.uv_px[series.valid, 0, 0])
        chosen[hand] = (choice.hand, x < 480)
    assert chosen == {"auto": ("right", True), "left": ("left", False)}
