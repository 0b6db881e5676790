"""Exports stream: the memory they take does not grow with the record's length."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from dexlfd.io import Demonstration, Rollout, rosbag
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


def _rollout(n: int, duplicate_stamp: bool = False) -> Rollout:
    rng = np.random.default_rng(n)
    t = np.arange(n) * 1e-3
    if duplicate_stamp:  # two samples 0.1 ns apart share one stamp [ns]
        t[3] = t[2] + 1e-10
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    return Rollout(t=t, q=rng.normal(size=(n, 7)), dq=rng.normal(size=(n, 7)),
                   tau=rng.normal(size=(n, 7)), ee_position=rng.normal(size=(n, 3)),
                   ee_quaternion=quat, ref_position=rng.normal(size=(n, 3)),
                   ref_quaternion=quat, gripper=np.full(n, 0.04))  # fmt: skip


def _rollout_messages_all_at_once(ro: Rollout) -> list:
    """What the rollout bag held before it streamed: every message made, then sorted."""
    from dexlfd.io._ros_msgs import Msgs, typestore
    from dexlfd.io._urdf_tf import FINGER_JOINTS, panda_urdf

    m = Msgs(typestore())
    names = [*rosbag.DEFAULT_JOINT_NAMES, *FINGER_JOINTS]
    stamps = rosbag._stamps(ro.t, None)
    fingers = 0.5 * ro.gripper
    static, tf = rosbag._robot_tf(m, stamps[0], ro.q, fingers)
    messages = [("/robot_description", stamps[0], m.string(panda_urdf())),
                ("/tf_static", stamps[0], static)]  # fmt: skip
    messages += [("/tf", ns, tf(i, ns)) for i, ns in enumerate(stamps)]
    for i, ns in enumerate(stamps):
        f, z = np.full(2, fingers[i]), np.zeros(2)
        js = m.joint_state(ns, names, np.r_[ro.q[i], f], np.r_[ro.dq[i], z], np.r_[ro.tau[i], z])
        messages += [("/joint_states", ns, js),
                     ("/dexlfd/gripper", ns, rosbag._fingers(m, ns, ro.gripper[i])),
                     ("/dexlfd/ee_pose", ns, m.pose_stamped(ns, ro.ee_position[i],
                                                            ro.ee_quaternion[i])),
                     ("/dexlfd/ref_pose", ns, m.pose_stamped(ns, ro.ref_position[i],
                                                             ro.ref_quaternion[i]))]  # fmt: skip
    trajectory = rosbag._joint_trajectory(m, ro, list(rosbag.DEFAULT_JOINT_NAMES), stamps[0])
    messages.append(("/dexlfd/joint_trajectory", stamps[0], trajectory))
    messages.sort(key=lambda item: item[1])
    return messages


@pytest.mark.parametrize("duplicate_stamp", [False, True])
def test_a_streamed_rollout_bag_is_the_file_it_was_when_built_at_once(
    tmp_path: Path, duplicate_stamp: bool
) -> None:
    ro = _rollout(40, duplicate_stamp)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    streamed = rosbag.export_rollout_rosbag(ro, tmp_path / "a" / "ro")
    topics = {
        "/robot_description": "std_msgs/msg/String",
        "/tf_static": "tf2_msgs/msg/TFMessage",
        "/tf": "tf2_msgs/msg/TFMessage",
        "/joint_states": "sensor_msgs/msg/JointState",
        "/dexlfd/gripper": "sensor_msgs/msg/JointState",
        "/dexlfd/ee_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/ref_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/joint_trajectory": "trajectory_msgs/msg/JointTrajectory",
    }
    at_once = rosbag._write_bag(
        tmp_path / "b" / "ro", topics, _rollout_messages_all_at_once(ro), "mcap"
    )
    for name in ("ro.mcap", "metadata.yaml"):
        assert (streamed / name).read_bytes() == (at_once / name).read_bytes(), name


def test_a_rollout_bag_made_as_written_grows_far_less_than_one_made_at_once(
    tmp_path: Path,
) -> None:
    """Only the one trajectory message (every point) grows with the rollout's length."""
    rosbag.export_rollout_rosbag(_rollout(10), tmp_path / "warm")  # type store, plugins
    short, long = _rollout(400), _rollout(1600)  # both longer than one 1 MiB MCAP chunk

    def streamed(ro: Rollout, name: str) -> int:
        return _peak_bytes(lambda: rosbag.export_rollout_rosbag(ro, tmp_path / name))

    def at_once(ro: Rollout) -> int:
        return _peak_bytes(lambda: _rollout_messages_all_at_once(ro))

    growth = streamed(long, "b") - streamed(short, "a")
    growth_at_once = at_once(long) - at_once(short)  # the messages alone, none written
    assert growth < 0.5 * growth_at_once
    bag = rosbag.read_rosbag(tmp_path / "b")
    assert len(bag["/joint_states"]) == 1600 and len(bag["/tf"]) == 1600
