"""MCAP bags read back by an independent reader (``mcap`` + ``mcap-ros2-support``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dexlfd.cli import main
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io import Plan, Rollout, load_demonstration
from dexlfd.io.rosbag import export_plan_rosbag, export_rollout_rosbag, read_rosbag

mcap_reader = pytest.importorskip("mcap_ros2.reader", reason="mcap-ros2-support not installed")

FINGERS = ["panda_finger_joint1", "panda_finger_joint2"]


def _read_mcap(bag: Path) -> dict[str, list]:
    """``{topic: [(log_time_ns, schema name, message), ...]}`` with mcap's own reader."""
    (file,) = sorted(bag.glob("*.mcap"))
    out: dict[str, list] = {}
    for m in mcap_reader.read_ros2_messages(str(file)):
        out.setdefault(m.channel.topic, []).append((m.log_time_ns, m.schema.name, m.ros_msg))
    return out


def _xyz(pose) -> list[float]:
    return [pose.position.x, pose.position.y, pose.position.z]


def _xyzw(pose) -> list[float]:
    o = pose.orientation
    return [o.x, o.y, o.z, o.w]


def _plan(rng: np.random.Generator, n: int = 40) -> Plan:
    t = np.linspace(0.0, 1.3, n)
    pos = rng.normal(size=(n, 3))
    return Plan(
        t=t,
        position=pos,
        velocity=rng.normal(size=(n, 3)),
        acceleration=rng.normal(size=(n, 3)),
        quaternion=Rotation.random(n, random_state=5).as_quat(),
        angular_velocity=rng.normal(size=(n, 3)),
        gripper=rng.uniform(0, 0.08, n),
    )


def test_plan_mcap_is_standard_and_exact(tmp_path: Path, rng: np.random.Generator) -> None:
    plan = _plan(rng)
    bag = export_plan_rosbag(plan, tmp_path / "plan_bag", stamp_origin_ns=7 * 10**17)
    assert [p.name for p in sorted(bag.iterdir())] == ["metadata.yaml", "plan_bag.mcap"]
    msgs = _read_mcap(bag)
    poses = msgs["/dexlfd/plan/pose"]
    assert {name for _, name, _ in poses} == {"geometry_msgs/msg/PoseStamped"}
    np.testing.assert_array_equal([_xyz(m.pose) for *_, m in poses], plan.position)
    np.testing.assert_array_equal([_xyzw(m.pose) for *_, m in poses], plan.quaternion)
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for *_, m in poses])
    np.testing.assert_array_equal(stamps, [ns for ns, *_ in poses])
    np.testing.assert_allclose((stamps - 7 * 10**17) * 1e-9, plan.t, atol=1e-9)
    assert poses[0][2].header.frame_id == "panda_link0"
    grip = msgs["/dexlfd/plan/gripper"]  # stamped: the finger joints, each half the opening
    assert {name for _, name, _ in grip} == {"sensor_msgs/msg/JointState"}
    np.testing.assert_array_equal([m.header.stamp.nanosec for *_, m in grip],
                                  [m.header.stamp.nanosec for *_, m in poses])  # fmt: skip
    np.testing.assert_array_equal([2 * m.position[0] for *_, m in grip], plan.gripper)
    ((_, schema, path),) = msgs["/dexlfd/plan/path"]
    assert schema == "nav_msgs/msg/Path"
    np.testing.assert_array_equal([_xyz(p.pose) for p in path.poses], plan.position)
    twist = msgs["/dexlfd/plan/twist"][5][2].twist
    np.testing.assert_array_equal(
        [twist.angular.x, twist.angular.y, twist.angular.z], plan.angular_velocity[5]
    )


def test_rollout_mcap_joint_states(tmp_path: Path, rng: np.random.Generator) -> None:
    n = 25
    quat = Rotation.random(n, random_state=6).as_quat()
    ro = Rollout(
        t=np.arange(n) * 1e-3,
        q=rng.normal(size=(n, 7)),
        dq=rng.normal(size=(n, 7)),
        tau=rng.normal(size=(n, 7)),
        ee_position=rng.normal(size=(n, 3)),
        ee_quaternion=quat,
        ref_position=rng.normal(size=(n, 3)),
        ref_quaternion=quat,
        gripper=np.full(n, 0.04),
    )
    msgs = _read_mcap(export_rollout_rosbag(ro, tmp_path / "ro", stamp_origin_ns=0))
    js = msgs["/joint_states"]
    assert js[0][1] == "sensor_msgs/msg/JointState"
    assert list(js[0][2].name) == [f"panda_joint{i}" for i in range(1, 8)] + FINGERS
    for field, want in (("position", ro.q), ("velocity", ro.dq), ("effort", ro.tau)):
        np.testing.assert_array_equal([list(getattr(m, field))[:7] for *_, m in js], want)
    np.testing.assert_array_equal([list(m.position)[7:] for *_, m in js], np.full((n, 2), 0.02))
    grip = msgs["/dexlfd/gripper"]
    assert grip[0][1] == "sensor_msgs/msg/JointState" and list(grip[0][2].name) == FINGERS
    ee = [_xyz(m.pose) for *_, m in msgs["/dexlfd/ee_pose"]]
    np.testing.assert_array_equal(ee, ro.ee_position)
    ((_, schema, traj),) = msgs["/dexlfd/joint_trajectory"]
    assert schema == "trajectory_msgs/msg/JointTrajectory" and len(traj.points) == n


def test_cli_default_is_mcap_db3_kept_and_readers_agree(tmp_path: Path) -> None:
    assert main(["synth", "-n", "1", "-o", str(tmp_path)]) == 0
    src = tmp_path / "demo_00.npz"
    demo = load_demonstration(src)
    demo_bytes = src.read_bytes()
    assert main(["export", str(src), "-o", str(tmp_path / "m")]) == 0
    assert main(["export", str(src), "-o", str(tmp_path / "s"), "--format", "db3"]) == 0
    assert src.read_bytes() == demo_bytes  # the input is never touched
    assert [p.suffix for p in (tmp_path / "m").iterdir() if p.suffix != ".yaml"] == [".mcap"]
    assert [p.suffix for p in (tmp_path / "s").iterdir() if p.suffix != ".yaml"] == [".db3"]
    valid = demo.valid
    independent = _read_mcap(tmp_path / "m")["/dexlfd/demo/ee_pose"]
    np.testing.assert_array_equal([_xyz(m.pose) for *_, m in independent], demo.position[valid])
    np.testing.assert_array_equal([_xyzw(m.pose) for *_, m in independent], demo.quaternion[valid])
    for bag in ("m", "s"):  # rosbags reads both storages to the same numbers
        msgs = read_rosbag(tmp_path / bag)
        np.testing.assert_array_equal(
            [_xyz(m.pose) for _, m in msgs["/dexlfd/demo/ee_pose"]], demo.position[valid]
        )
        np.testing.assert_array_equal(
            [2 * m.position[0] for _, m in msgs["/dexlfd/demo/gripper"]], demo.gripper[valid]
        )
        ((_, path),) = msgs["/dexlfd/demo/path"]
        assert len(path.poses) == int(valid.sum())


def test_bad_storage_and_bag_inputs(tmp_path: Path, rng: np.random.Generator, capsys) -> None:
    with pytest.raises(InvalidInput, match="storage"):
        export_plan_rosbag(_plan(rng), tmp_path / "x", storage="bag")
    assert not (tmp_path / "x").exists()
    assert main(["synth", "-n", "2", "-o", str(tmp_path)]) == 0
    demos = [str(tmp_path / f"demo_0{i}.npz") for i in range(2)]
    assert main(["export", *demos, "-o", str(tmp_path / "b"), "--format", "mcap"]) == 1
    assert "takes one input file" in capsys.readouterr().err
    assert main(["learn", *demos, "-o", str(tmp_path / "model.npz"), "--k", "2"]) == 0
    assert main(["export", str(tmp_path / "model.npz"), "-o", str(tmp_path / "mb")]) == 1
    assert "no ROS 2 export" in capsys.readouterr().err
    assert not (tmp_path / "b").exists() and not (tmp_path / "mb").exists()


def test_a_time_axis_that_is_a_unix_clock_still_exports(tmp_path: Path) -> None:
    """t near 1.7e9 s (a clock, not from 0) plus a present-day origin: counted from t[0]."""
    n = 5
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
    z7, z3 = np.zeros((n, 7)), np.zeros((n, 3))
    ro = Rollout(t=1.7e9 + np.arange(n) * 1e-3, q=z7, dq=z7, tau=z7, ee_position=z3,
                 ee_quaternion=quat, ref_position=z3, ref_quaternion=quat,
                 gripper=np.full(n, 0.04))  # fmt: skip
    origin = 1_764_000_000 * 10**9  # 2025-11
    msgs = _read_mcap(export_rollout_rosbag(ro, tmp_path / "ro", stamp_origin_ns=origin))
    stamps = [m.header.stamp for *_, m in msgs["/joint_states"]]
    got = [s.sec * 10**9 + s.nanosec for s in stamps]
    # float64 holds 1.7e9 s to ~0.2 us: the steps keep that precision
    np.testing.assert_allclose(np.subtract(got, origin), np.arange(n) * 10**6, atol=1e3)


def test_a_bag_folder_name_leaves_room_for_its_file(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """The bag's file is named after its folder (NAME.mcap): that name must fit too."""
    longest = tmp_path / ("b" * 250)
    export_plan_rosbag(_plan(rng), longest)
    assert (longest / f"{longest.name}.mcap").is_file()
    with pytest.raises(InvalidFile, match=r"folder's name is at most 250 bytes"):
        export_plan_rosbag(_plan(rng), tmp_path / ("c" * 251))
    # SQLite opens paths of at most 512 bytes, the temporary folder's included
    with pytest.raises(InvalidFile, match=r"SQLite opens paths of at most 512 bytes"):
        export_plan_rosbag(_plan(rng), tmp_path / ("d" * 240), storage="db3")
    assert sorted(p.name for p in tmp_path.iterdir()) == [longest.name]


def _matrix(tf) -> np.ndarray:
    r, p = tf.transform.rotation, tf.transform.translation
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
    m[:3, 3] = [p.x, p.y, p.z]
    return m


def test_rollout_bag_draws_the_arm_tf_chain_is_the_dh_tcp(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """/tf + /tf_static from the URDF compose to the TCP of the thesis's DH table.

    The DH forward kinematics (Table 3.1) is independent of the URDF the bag's
    transforms come from; both must put the TCP at the same pose. The latched topics
    are offered transient-local and /robot_description is the packaged URDF.
    """
    import yaml

    from dexlfd.panda import Q_MAX, Q_MIN
    from dexlfd.robot import dh_tcp

    n = 12
    q = rng.uniform(Q_MIN, Q_MAX, size=(n, 7))
    T = dh_tcp(q)
    quat = Rotation.from_matrix(T[:, :3, :3]).as_quat()
    z7 = np.zeros((n, 7))
    ro = Rollout(t=np.arange(n) * 0.01, q=q, dq=z7, tau=z7, ee_position=T[:, :3, 3],
                 ee_quaternion=quat, ref_position=T[:, :3, 3], ref_quaternion=quat,
                 gripper=np.linspace(0.0, 0.08, n))  # fmt: skip
    bag = export_rollout_rosbag(ro, tmp_path / "ro")
    msgs = _read_mcap(bag)
    assert "<robot" in msgs["/robot_description"][0][2].data
    ((_, _, static),) = msgs["/tf_static"]
    assert len(msgs["/tf"]) == n
    for i, (_, schema, moving) in enumerate(msgs["/tf"]):
        assert schema == "tf2_msgs/msg/TFMessage"
        frames = {tf.child_frame_id: tf for tf in [*static.transforms, *moving.transforms]}
        frame, m = "panda_hand_tcp", np.eye(4)
        while frame != "panda_link0":  # walk up the tree to the base
            m = _matrix(frames[frame]) @ m
            frame = frames[frame].header.frame_id
        np.testing.assert_allclose(m, T[i], atol=1e-9)
        finger = frames["panda_leftfinger"].transform.translation.y
        assert finger == pytest.approx(ro.gripper[i] / 2)
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    durability = {
        t["topic_metadata"]["name"]: yaml.safe_load(t["topic_metadata"]["offered_qos_profiles"])[0][
            "durability"
        ]
        for t in meta["topics_with_message_count"]
    }
    assert durability.pop("/tf_static") == durability.pop("/robot_description") == 1
    assert set(durability.values()) == {2}  # volatile


def test_bags_of_one_run_share_one_time_base(tmp_path: Path, rng: np.random.Generator) -> None:
    """A plan and its rollout, exported separately by default, start at the same stamp."""
    plan = _plan(rng)
    n = plan.n_samples
    z7, z3 = np.zeros((n, 7)), np.zeros((n, 3))
    ro = Rollout(t=plan.t, q=z7, dq=z7, tau=z7, ee_position=z3, ee_quaternion=plan.quaternion,
                 ref_position=z3, ref_quaternion=plan.quaternion, gripper=plan.gripper)  # fmt: skip
    p = _read_mcap(export_plan_rosbag(plan, tmp_path / "p"))["/dexlfd/plan/pose"]
    r = _read_mcap(export_rollout_rosbag(ro, tmp_path / "r"))["/dexlfd/ee_pose"]
    assert [ns for ns, *_ in p] == [ns for ns, *_ in r]
    assert p[0][0] > 0  # ROS time 0 means "latest" to tf2
