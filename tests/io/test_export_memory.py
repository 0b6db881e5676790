"""Exports stream: the memory they take does not grow with the record's length."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from dexlfd.io import Demonstration, rosbag
from dexlfd.io import csv as csv_export


def _demo(n: int) -> Demonstration:
    t = np.arange(n) / 100.0
    pos = np.column_stack([0.4 + 0.1 * np.sin(t), 0.1 * np.cos(t), np.full(n, 0.2)])
    return Demonstration(t=t, keypoints=np.repeat(pos[:, None, :], 21, axis=1),
                         valid=np.ones(n, bool), position=pos,
                         quaternion=np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)),
                         gripper=np.full(n, 0.06), grasp=np.zeros(n, bool))  # fmt: skip


def _peak_bytes(write) -> int:
    tracemalloc.start()
    try:
        write()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_bag_of_four_times_the_samples_takes_about_the_same_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(rosbag, "MAX_PATH_POSES", 50)
    rosbag.export_demonstration_rosbag(_demo(10), tmp_path / "warm")  # type store, plugins
    # both longer than one MCAP chunk (1 MiB, buffered by the writer)
    short, long = _demo(3000), _demo(12000)
    peak_short = _peak_bytes(lambda: rosbag.export_demonstration_rosbag(short, tmp_path / "a"))
    peak_long = _peak_bytes(lambda: rosbag.export_demonstration_rosbag(long, tmp_path / "b"))
    # every message held at once grew the peak by ~3 kB a sample (35 MB here); made as
    # written, it grows by less than the record's own arrays (a stamp and pose copy each)
    record_growth = sum(
        getattr(long, k).nbytes - getattr(short, k).nbytes
        for k in ("t", "keypoints", "valid", "position", "quaternion", "gripper", "grasp")
    )
    assert peak_long - peak_short < record_growth
    bag = rosbag.read_rosbag(tmp_path / "b")
    assert len(bag["/dexlfd/demo/ee_pose"]) == 12000 and len(bag["/tf"]) == 12000
    (path,) = bag["/dexlfd/demo/path"]
    poses = path[1].poses
    assert len(poses) == 50  # the outline, from the first to the last sample
    assert poses[0].pose.position.x == pytest.approx(long.position[0, 0])
    assert poses[-1].pose.position.x == pytest.approx(long.position[-1, 0])
    stamps = [ns for ns, _ in bag["/dexlfd/demo/ee_pose"]]
    assert stamps == sorted(stamps)


def test_csv_is_written_in_chunks_with_the_same_text(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    short, long = _demo(1500), _demo(6000)
    whole = (csv_export.export_csv(long, tmp_path / "whole.csv")).read_text()
    monkeypatch.setattr(csv_export, "CHUNK_ROWS", 250)
    peak_short = _peak_bytes(lambda: csv_export.export_csv(short, tmp_path / "a.csv"))
    peak_long = _peak_bytes(lambda: csv_export.export_csv(long, tmp_path / "b.csv"))
    assert peak_long < 1.5 * peak_short
    text = (tmp_path / "b.csv").read_text()
    assert text == whole and len(text.splitlines()) == 6001
    # the numbers, to the 9 digits written
    table = np.loadtxt(tmp_path / "b.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], long.t, rtol=1e-8)
