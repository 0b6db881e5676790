"""`record` on real MediaPipe recordings: the task's structure, the hand, the files written.

The five real pick-and-place recordings (MediaPipe's landmarks of real videos, annotated by
a person) are replayed through the whole record pipeline after the tracker
(:mod:`_landmark_replay`); the tests skip, naming the path, when they are absent.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dexlfd.apps import record as record_app
from dexlfd.apps.record import RecordConfig, RecordJob, RecordResult, episode_paths, record_job
from dexlfd.cli import main
from dexlfd.io import load_demonstration, save_demonstration

from ._landmark_replay import ANNOTATION, iou, record_landmarks

EXPECTED = {"breakfast": 3, "rearrange": 2, "llama": 1, "plush_toy": 1, "bagging": 1}


@pytest.fixture(scope="module")
def recorded() -> dict:
    return {}


def _get(recorded: dict, name: str):
    if name not in recorded:
        recorded[name] = record_landmarks(name)
    return recorded[name]


@pytest.mark.parametrize("name", list(EXPECTED))
def test_pick_and_places_found_and_each_grasp_matches_the_annotation(recorded, name) -> None:
    t_s, demos = _get(recorded, name)
    phases = demos[0].phases
    found = [(e.grasp_start, e.release - 1) for e in phases.episodes if e.kind == "pick_and_place"]
    assert len(found) == EXPECTED[name] == len(demos)
    for grasp in ANNOTATION[name]:
        assert max(iou(grasp, f) for f in found) >= 0.7, (name, grasp, found)
    # every demonstration holds its own pick-and-place, on the recording's clock
    for k, d in enumerate(demos, start=1):
        q = d.quality
        assert q.pick_and_place is not None and d.episode.index == k
        a, b = d.source_frames
        np.testing.assert_allclose(d.t, t_s[a:b])
        assert not any("pick-and-place" in w for w in q.warnings), q.warnings


@pytest.mark.parametrize("name", ["breakfast", "plush_toy"])
def test_the_open_idle_hand_never_grasps_and_the_acting_hand_is_recorded(recorded, name) -> None:
    """breakfast: a flat hand resting on the table; plush_toy: a raised, open, still hand.

    Both are seen in more frames than (or as many as) the acting hand."""
    _, demos = _get(recorded, name)
    choice = demos[0].meta["capture"]["hand_choice"]
    chosen = [a for a in choice["tracks"] if a["track"] == choice["track"]][0]
    idle = [a for a in choice["tracks"] if a["track"] != choice["track"] and a["seen"] > 0.5]
    assert chosen["pick_and_places"] >= 1
    assert idle and all(a["carries"] == 0 and a["pick_and_places"] == 0 for a in idle)
    assert max(a["seen"] for a in idle) >= chosen["seen"]
    assert choice["warning"] is None
    # the acting hand is the one on the image's left in both videos
    uv = np.concatenate([d.extras["uv_px"][d.valid] for d in demos])
    assert np.nanmedian(uv[:, 0, 0]) < 0.5 * demos[0].meta["capture"]["image_size"][0]


def test_two_acting_hands_are_reported_and_the_pick_and_place_hand_recorded(recorded) -> None:
    _, demos = _get(recorded, "bagging")
    choice = demos[0].meta["capture"]["hand_choice"]
    assert choice["warning"] and choice["warning"].startswith("two hands act")
    acting = [a for a in choice["tracks"] if a["carries"]]
    assert len(acting) == 2 and sum(a["pick_and_places"] for a in acting) == 1
    assert demos[0].quality.notes == (choice["warning"],)
    # the chips hand is lost for ~2 s during the carry: found, but said, with the frames
    q = demos[0].quality
    assert not q.usable and any(w.startswith("hand lost") and "frames" in w
                                   for w in q.warnings)  # fmt: skip


def test_a_later_demonstration_keeps_its_seconds_through_the_file(recorded, tmp_path) -> None:
    _, demos = _get(recorded, "breakfast")
    second = demos[1]
    a, _ = second.source_frames
    assert a > 60 and second.t[0] == pytest.approx(a / 30.0, abs=1e-6)
    back = load_demonstration(save_demonstration(tmp_path / "b-2.npz", second))
    np.testing.assert_array_equal(back.t, second.t)
    assert back.episode.index == 2


def test_learning_accepts_demonstrations_that_do_not_start_at_zero(demos) -> None:
    from dexlfd.learn import LearnConfig, learn_from_demonstrations

    cfg = LearnConfig(n_components=6)
    base = learn_from_demonstrations(demos, cfg, np.random.default_rng(0))
    shifted = [replace(d, t=d.t + 12.5 + 3 * k) for k, d in enumerate(demos)]
    moved = learn_from_demonstrations(shifted, cfg, np.random.default_rng(0))
    np.testing.assert_allclose(moved.model.t, base.model.t, atol=1e-9)  # aligned from 0
    np.testing.assert_allclose(moved.model.mean, base.model.mean, atol=1e-9)


def _fake_result(demos: list) -> RecordResult:
    q = [d.quality for d in demos]
    return RecordResult(demos[0], 219, 0.9, "right", 1.0, "pnp", q[0], tuple(demos), tuple(q))


def test_record_job_writes_one_file_per_pick_and_place(
    recorded, tmp_path, monkeypatch, caplog
) -> None:
    _, demos = _get(recorded, "breakfast")
    monkeypatch.setattr(record_app, "record_demonstration", lambda *a, **k: _fake_result(demos))
    out = tmp_path / "breakfast.npz"
    outcome = record_job(RecordJob("breakfast.mp4", str(out), RecordConfig(), split=True))
    assert outcome.ok and [Path(p).name for p in outcome.outputs] == [
        "breakfast-1.npz",
        "breakfast-2.npz",
        "breakfast-3.npz",
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == [Path(p).name for p in outcome.outputs]
    starts = [load_demonstration(p).t[0] for p in outcome.outputs]
    assert starts == sorted(starts) and starts[1] > 2.0
    assert len(outcome.qualities) == 3
    # -o FILE.npz: the first pick-and-place, and a warning naming the folder form
    single = tmp_path / "one" / "first.npz"
    single.parent.mkdir()
    with caplog.at_level("WARNING", logger="dexlfd.apps.record"):
        outcome = record_job(RecordJob("breakfast.mp4", str(single), RecordConfig()))
    assert outcome.outputs == (str(single),) and list(single.parent.iterdir()) == [single]
    assert "3 pick-and-places found; wrote the first" in caplog.text and "split=True" in caplog.text
    assert load_demonstration(single).episode.index == 1


def test_episode_paths() -> None:
    assert episode_paths("out/a.npz", 1) == ["out/a.npz"]
    assert episode_paths("out/a.npz", 2) == ["out/a-1.npz", "out/a-2.npz"]


def test_a_folder_output_never_replaces_a_file_it_did_not_write(tmp_path, capsys) -> None:
    """`record a.mp4 b.mp4 -o out/` with an unrelated out/a.npz (or out/b-2.npz): refused
    before any work, the file untouched."""
    for name in ("a.mp4", "b.mp4"):
        (tmp_path / name).write_bytes(b"not a video")
    out = tmp_path / "out"
    out.mkdir()
    for taken in ("a.npz", "b-2.npz"):
        keep = out / taken
        keep.write_bytes(b"someone else's file")
        code = main(["record", str(tmp_path / "a.mp4"), str(tmp_path / "b.mp4"), "-o", str(out)])
        err = capsys.readouterr().err
        assert code != 0 and f"{keep} already exists" in err and "Traceback" not in err
        assert keep.read_bytes() == b"someone else's file"
        keep.unlink()
    (out / "a-notes.npz").write_bytes(b"x")  # not a name this run writes: no refusal here
    code = main(["record", str(tmp_path / "a.mp4"), str(tmp_path / "b.mp4"), "-o", str(out)])
    assert "already exists" not in capsys.readouterr().err
