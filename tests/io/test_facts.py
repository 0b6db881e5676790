"""Typed facts: JSON round trips, and every malformed value refused in one line."""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from typing import ClassVar, Literal

import numpy as np
import pytest

from dexlfd.errors import InvalidFile
from dexlfd.io._facts import Fact, from_json, unit_of
from dexlfd.io._npz import ArraySpec
from dexlfd.io._record import Record


@dataclass(frozen=True)
class _Box(Fact):
    centre_m: tuple[float, float, float] = field(metadata={"unit": "m"})
    kind: Literal["box", "sphere"] = "box"
    label: str | None = None


@dataclass(frozen=True)
class _Scene(Fact):
    boxes: tuple[_Box, ...] = ()
    margin_m: float = field(default=0.02, metadata={"unit": "m"})
    counts: dict[str, int] = field(default_factory=dict)
    ok: bool = True


@dataclass(frozen=True, eq=False)
class _Track(Record):
    KIND: ClassVar[str] = "track"
    VERSION: ClassVar[int] = 2
    SPECS: ClassVar[dict[str, ArraySpec]] = {"t": ArraySpec(("n",), unit="s")}
    FACTS: ClassVar[tuple[str, ...]] = ("scene",)

    t: np.ndarray
    meta: dict = field(default_factory=dict)
    extras: dict = field(default_factory=dict)
    scene: _Scene | None = None

    @classmethod
    def _facts_from_meta(cls, meta, version, where):  # version 1 kept the scene in meta
        if version >= 2 or "scene" not in meta:
            return {}, meta
        rest = dict(meta)
        return {"scene": rest.pop("scene")}, rest


def _scene() -> _Scene:
    return _Scene(
        boxes=(_Box((0.4, -0.1, 0.05)), _Box((0.5, 0.2, 0.3), "sphere", "lamp")),
        margin_m=0.03,
        counts={"a": 2},
    )


def test_a_fact_survives_json_and_keeps_its_unit() -> None:
    scene = _scene()
    text = json.dumps(scene.to_json())
    assert _Scene.from_json(json.loads(text), "x") == scene
    assert unit_of(_Box, "centre_m") == "m"
    assert unit_of(_Box, "kind") == ""


@pytest.mark.parametrize(
    ("obj", "message"),
    [
        ({"boxes": [{"centre_m": [0.1, 0.2]}]}, "f.boxes[0].centre_m must be a list of 3"),
        ({"boxes": [{"centre_m": [0.1, "x", 0.3]}]}, "boxes[0].centre_m[1] must be a finite"),
        ({"boxes": [{"centre_m": [0.1, 0.2, 0.3], "kind": "cone"}]}, "one of 'box', 'sphere'"),
        ({"boxes": [{}]}, "boxes[0]: missing entry 'centre_m'"),
        ({"margin_m": True}, "margin_m must be a finite number"),
        ({"margin_m": float("nan")}, "margin_m must be a finite number"),
        ({"counts": {"a": 1.5}}, "counts.a must be an integer"),
        ({"ok": 1}, "ok must be true or false"),
        ({"colour": "red"}, "unknown entry 'colour'"),
        ([], "f must be a JSON object"),
    ],
)
def test_a_malformed_fact_is_one_line_naming_its_path(obj: object, message: str) -> None:
    with pytest.raises(InvalidFile, match=message.replace("[", r"\[").replace("]", r"\]")):
        from_json(_Scene, obj, "f")


def test_a_record_writes_its_facts_and_reads_them_back(tmp_path) -> None:
    track = _Track(t=np.array([0.0, 0.1, 0.2]), meta={"source": "made here"}, scene=_scene())
    path = track._save(tmp_path / "track.npz")
    back = _Track._load(path)
    assert back.scene == track.scene
    assert "scene" not in back.meta
    with zipfile.ZipFile(path) as zf:
        assert "facts.npy" in zf.namelist()


def test_an_older_file_has_its_facts_lifted_out_of_meta(tmp_path) -> None:
    from dexlfd.io._npz import save_npz

    path = save_npz(
        tmp_path / "old.npz", "track", 1, {"t": np.array([0.0, 0.1, 0.2])},
        {"scene": _scene().to_json(), "source": "old"},
    )  # fmt: skip
    back = _Track._load(path)
    assert back.scene == _scene()
    assert back.meta["source"] == "old" and "scene" not in back.meta


def test_a_damaged_fact_in_a_file_names_the_file_and_the_entry(tmp_path) -> None:
    from dexlfd.io._npz import save_npz

    bad = {"scene": {"boxes": [{"centre_m": [0.1, 0.2, "x"]}]}}
    path = save_npz(tmp_path / "bad.npz", "track", 2, {"t": np.array([0.0, 0.1, 0.2])}, {}, bad)
    with pytest.raises(InvalidFile, match=r"bad\.npz: facts\.scene\.boxes\[0\]\.centre_m\[2\]"):
        _Track._load(path)
    path = save_npz(
        tmp_path / "odd.npz", "track", 2, {"t": np.array([0.0, 0.1, 0.2])}, {}, {"x": 1}
    )
    with pytest.raises(InvalidFile, match="unknown fact 'x'"):
        _Track._load(path)


def test_a_non_finite_fact_is_refused_before_anything_is_written(tmp_path) -> None:
    track = _Track(t=np.array([0.0, 0.1, 0.2]), scene=_Scene(margin_m=float("inf")))
    with pytest.raises(InvalidFile, match="non-finite"):
        track._save(tmp_path / "inf.npz")
    assert not list(tmp_path.iterdir())
