from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.errors import InvalidFile
from dexlfd.io import Plan, Rollout
from dexlfd.io.csv import export_csv
from dexlfd.io.rosbag import export_plan_rosbag, export_rollout_rosbag, read_rosbag


def _plan(rng: np.random.Generator, n: int = 50) -> Plan:
    t = np.linspace(0.0, 2.0, n)
    pos = rng.normal(size=(n, 3))
    return Plan(
        t=t,
        position=pos,
        velocity=np.gradient(pos, t, axis=0),
        acceleration=rng.normal(size=(n, 3)),
        quaternion=Rotation.random(n, random_state=3).as_quat(),
        angular_velocity=rng.normal(size=(n, 3)),
        gripper=rng.uniform(0, 0.08, n),
    )


def _rollout(rng: np.random.Generator, n: int = 30) -> Rollout:
    q4 = Rotation.random(n, random_state=4).as_quat()
    return Rollout(
        t=np.arange(n) * 1e-3 + 0.9995,
        q=rng.normal(size=(n, 7)),
        dq=rng.normal(size=(n, 7)),
        tau=rng.normal(size=(n, 7)),
        ee_position=rng.normal(size=(n, 3)),
        ee_quaternion=q4,
        ref_position=rng.normal(size=(n, 3)),
        ref_quaternion=q4,
        gripper=np.zeros(n),
    )


def test_plan_bag_round_trip(tmp_path: Path, rng: np.random.Generator) -> None:
    plan = _plan(rng)
    bag = export_plan_rosbag(plan, tmp_path / "plan_bag", stamp_origin_ns=10**18)
    msgs = read_rosbag(bag)
    poses = msgs["/dexlfd/plan/pose"]
    assert len(poses) == plan.n_samples
    pos = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z] for _, m in poses])
    np.testing.assert_array_equal(pos, plan.position)
    stamps = np.array([ns for ns, _ in poses])
    np.testing.assert_allclose((stamps - 10**18) * 1e-9, plan.t, atol=1e-9)
    assert poses[0][1].header.frame_id == "panda_link0"
    grip = np.array([m.data for _, m in msgs["/dexlfd/plan/gripper"]])
    np.testing.assert_array_equal(grip, plan.gripper)


def test_rollout_bag_round_trip(tmp_path: Path, rng: np.random.Generator) -> None:
    ro = _rollout(rng)
    msgs = read_rosbag(export_rollout_rosbag(ro, tmp_path / "ro", stamp_origin_ns=0))
    js = msgs["/joint_states"]
    np.testing.assert_array_equal(np.array([m.position for _, m in js]), ro.q)
    np.testing.assert_array_equal(np.array([m.effort for _, m in js]), ro.tau)
    assert list(js[0][1].name) == [f"panda_joint{i}" for i in range(1, 8)]
    ((_, traj),) = msgs["/dexlfd/joint_trajectory"]
    assert len(traj.points) == ro.n_samples
    tfs = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in traj.points])
    np.testing.assert_allclose(tfs, ro.t - ro.t[0], atol=1e-9)


def test_existing_bag_is_not_clobbered(tmp_path: Path, rng: np.random.Generator) -> None:
    (tmp_path / "bag").mkdir()
    with pytest.raises(InvalidFile, match="already exists"):
        export_plan_rosbag(_plan(rng), tmp_path / "bag")
    with pytest.raises(InvalidFile, match="not a readable ROS 2 bag"):
        read_rosbag(tmp_path / "bag")
    assert [p.name for p in tmp_path.iterdir()] == ["bag"]


def test_csv_columns_and_values(tmp_path: Path, rng: np.random.Generator) -> None:
    plan = _plan(rng, 7)
    path = export_csv(plan, tmp_path / "plan.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:4] == ["t [s]", "position_x [m]", "position_y [m]", "position_z [m]"]
    assert "quaternion_w" in header
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], plan.t, rtol=1e-8)  # %.9g text
    np.testing.assert_allclose(table[:, 1:4], plan.position, rtol=1e-8)
    ro = _rollout(rng, 5)
    header = export_csv(ro, tmp_path / "ro.csv").read_text().splitlines()[0].split(",")
    assert "q_6 [rad]" in header and "tau_0 [N m]" in header
