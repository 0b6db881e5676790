"""A demonstration's typed facts: written as facts, checked on load, read from version-1 meta."""

from __future__ import annotations

import zipfile
from dataclasses import replace
from pathlib import Path

import pytest

from dexlfd.errors import InvalidFile
from dexlfd.io import Demonstration, load_demonstration, save_demonstration
from dexlfd.io._npz import save_npz
from dexlfd.io.demonstration_facts import (
    AppliedFrame,
    Episode,
    OtherEpisode,
    Outside,
    Phases,
    Quality,
    RecordingSummary,
    TaskEpisode,
    Trim,
    Trimmed,
)

PICK = TaskEpisode("pick_and_place", 0, 40, 10, 30, "grasp, carry, release", 2, 38, 0.3, 1.0)
HOLD = TaskEpisode("no_release", 40, 60, 45, None, "a grasp never released")
EYE = ((1.0, 0.0, 0.0, 0.1), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, 0.0, 0.0, 1.0))


def _facts() -> dict:
    episode = Episode(
        **{f: getattr(PICK, f) for f in TaskEpisode.__dataclass_fields__},
        index=1,
        of=1,
        others=(OtherEpisode("no_release", 45, None, "a grasp never released"),),
        outside=Outside(0, 2, 60),
        recording_frames=(0, 60),
    )
    return {
        "frame": "panda_base",
        "task_frame": AppliedFrame(EYE, 1.0, "camera (no extrinsics)", "demonstrations"),
        "source_frames": (0, 40),
        "phases": Phases((PICK, HOLD), 1, {"reach": 8, "grasp": 20}),
        "episode": episode,
        "trim": Trim(True, 0, 40, 40, 0.1, 1.2, 0.0, 0.0, 1.0, {"margin_s": 0.3}),
        "recording": RecordingSummary(60, 0.95),
        "quality": Quality(
            usable=True,
            notes=("a note",),
            n_frames=40,
            source_frames=(0, 40),
            episode=episode,
            pick_and_place=PICK,
            grasp_intervals_s=((0.3, 0.97),),
            jitter_mm=None,
            trimmed=Trimmed(0.0, 0.0),
        ),
    }


def test_the_facts_survive_a_file_and_leave_meta_to_provenance(tmp_path: Path, demos) -> None:
    demo = replace(demos[0], meta={"source": "made here"}, **_facts())
    path = save_demonstration(tmp_path / "d.npz", demo)
    back = load_demonstration(path)
    for name in Demonstration.FACTS:
        assert getattr(back, name) == getattr(demo, name), name
    assert back.meta["source"] == "made here"
    assert not set(back.meta) & set(Demonstration.FACTS)
    with zipfile.ZipFile(path) as zf:
        assert "facts.npy" in zf.namelist()


def test_a_version_1_file_has_its_facts_read_from_meta(tmp_path: Path, demos) -> None:
    facts = {k: v.to_json() if hasattr(v, "to_json") else v for k, v in _facts().items()}
    applied = facts.pop("task_frame")
    meta = {**facts, "task_frame": {**applied, "uncertainty": {"up_deg": 1.5}}, "source": "old"}
    d = demos[0]
    arrays = {k: getattr(d, k) for k in Demonstration.SPECS}
    path = save_npz(tmp_path / "v1.npz", "demonstration", 1, arrays, meta)
    back = load_demonstration(path)
    for name, value in _facts().items():
        assert getattr(back, name) == value, name
    # the task frame's provenance stays provenance
    assert back.meta["task_frame"] == {"uncertainty": {"up_deg": 1.5}}
    assert set(back.meta) == {"kind", "software", "source", "task_frame"}


def test_a_version_1_pick_and_place_read_from_grasp_flags_loads(tmp_path: Path, demos) -> None:
    d = demos[0]
    arrays = {k: getattr(d, k) for k in Demonstration.SPECS}
    quality = {"usable": True, "pick_and_place": {"grasp_start": 3, "release": 9}}
    path = save_npz(tmp_path / "v1.npz", "demonstration", 1, arrays, {"quality": quality})
    q = load_demonstration(path).quality
    assert q is not None and (q.pick_and_place.grasp_start, q.pick_and_place.release) == (3, 9)


@pytest.mark.parametrize(
    ("facts", "message"),
    [
        ({"quality": {"usable": "yes"}}, r"facts\.quality\.usable must be true or false"),
        ({"source_frames": [0, 1.5]}, r"facts\.source_frames\[1\] must be an integer"),
        (
            {"phases": {"episodes": [{**PICK.to_json(), "kind": "pour"}]}},
            r"facts\.phases\.episodes\[0\]\.kind must be one of",
        ),
        ({"trim": {"moved": True}}, r"facts\.trim: missing entry 'start'"),
        ({"frame": 3}, r"facts\.frame must be a string"),
        (
            {"recording": {"n_frames": 3, "detection_rate": 1.0, "x": 1}},
            r"facts\.recording: unknown entry 'x'",
        ),
    ],
)
def test_a_damaged_fact_is_one_line_naming_the_file_and_entry(
    tmp_path: Path, demos, facts: dict, message: str
) -> None:
    d = demos[0]
    arrays = {k: getattr(d, k) for k in Demonstration.SPECS}
    path = save_npz(tmp_path / "bad.npz", "demonstration", 2, arrays, {}, facts)
    with pytest.raises(InvalidFile, match=r"bad\.npz: " + message):
        load_demonstration(path)
