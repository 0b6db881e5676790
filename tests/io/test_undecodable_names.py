"""File names that are not UTF-8 (legal bytes on Linux) are written, or refused in one line."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from dexlfd.cli import main
from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import save_demonstration


def _name(tmp_path: Path, stem: bytes) -> Path:
    """``tmp_path / stem`` with ``stem``'s bytes as they are; skipped where names must be text."""
    path = tmp_path / os.fsdecode(stem)
    try:
        path.touch()
    except (OSError, UnicodeEncodeError):
        pytest.skip("this file system only takes UTF-8 file names")
    path.unlink()
    return path


def test_npz_outputs_and_a_lerobot_dataset_with_undecodable_names(tmp_path: Path) -> None:
    pytest.importorskip("pyarrow")
    demos = pick_place_demonstrations(2, np.random.default_rng(3))
    inputs = [str(save_demonstration(tmp_path / f"d{i}.npz", d)) for i, d in enumerate(demos)]
    model = _name(tmp_path, b"m\xff.npz")
    assert main(["learn", *inputs, "--k", "3", "-o", str(model), "-q"]) == 0
    assert model.is_file()
    assert not [p for p in tmp_path.iterdir() if ".dexlfd-part" in p.name]
    dataset = _name(tmp_path, b"ds\xfe")
    assert main(["export", inputs[0], "--format", "lerobot", "-o", str(dataset), "-q"]) == 0
    again = tmp_path / "m2.npz"
    assert main(["learn", str(dataset), "--k", "2", "-o", str(again), "-q"]) == 0
    assert again.is_file()


def test_a_bag_whose_name_is_not_text_is_refused_in_one_line(tmp_path: Path, capsys) -> None:
    pytest.importorskip("rosbags")
    one = pick_place_demonstrations(1, np.random.default_rng(4))[0]
    demo = save_demonstration(tmp_path / "d.npz", one)
    bag = _name(tmp_path, b"b\xff")
    assert main(["export", str(demo), "--format", "mcap", "-o", str(bag)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("dexlfd export: error: ") and "must be UTF-8 text" in err[-1]
    assert "Traceback" not in "\n".join(err) and sorted(p.name for p in tmp_path.iterdir()) == [
        "d.npz"
    ]
