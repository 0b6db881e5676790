"""Export plans, rollouts and demonstrations to ROS 2 bags (pure Python, via ``rosbags``).

A bag is stored as MCAP (``storage="mcap"``, the ROS 2 default since Iron; one
``<name>.mcap`` file plus ``metadata.yaml``) or SQLite (``storage="db3"``);
bag format version 8 either way. Topics written (frame ``panda_link0``, the
Panda base; ROS 2 Humble message definitions):

plan
    ``/dexlfd/plan/pose`` (``geometry_msgs/msg/PoseStamped``), ``/dexlfd/plan/twist``
    (``geometry_msgs/msg/TwistStamped``) and ``/dexlfd/plan/gripper``
    (``sensor_msgs/msg/JointState``: the two finger joints, each half the opening [m]),
    one message per sample; ``/tf`` from ``panda_link0`` to the frame
    ``dexlfd_plan_target`` (the planned TCP pose, drawn by RViz's TF display); and one
    ``/dexlfd/plan/path`` (``nav_msgs/msg/Path``) holding every pose (at most 10,000,
    spread evenly, of a longer plan).
demonstration
    ``/dexlfd/demo/ee_pose`` (``PoseStamped``), ``/dexlfd/demo/gripper`` (finger
    ``JointState``) and ``/tf`` to ``dexlfd_demo_ee`` at every sample where the hand
    was seen (``valid``), and one ``/dexlfd/demo/path`` (``nav_msgs/msg/Path``; at most
    10,000 poses). Messages are made as they are written: memory stays bounded.
rollout
    ``/robot_description`` (``std_msgs/msg/String``: the packaged franka_ros URDF,
    latched), ``/joint_states`` (``sensor_msgs/msg/JointState``: the 7 arm joints'
    position, velocity, effort and the 2 finger joints' positions), ``/tf`` (every
    moving joint's transform from the URDF and the joint positions, what
    ``robot_state_publisher`` would publish) and ``/tf_static`` (the fixed joints:
    flange, hand, TCP; latched), so RViz and Foxglove draw the arm from the bag alone;
    ``/dexlfd/gripper`` (finger ``JointState``: the measured opening),
    ``/dexlfd/ee_pose`` and ``/dexlfd/ref_pose`` (``PoseStamped``), and
    one ``/dexlfd/joint_trajectory`` (``trajectory_msgs/msg/JointTrajectory``) holding
    the executed joint path, so it can be replayed by a ROS 2 trajectory controller.
    Messages are made as they are written (the trajectory, one message, at once).

Time base: a stamp is ``stamp_origin_ns + t`` with the record's own time ``t``
[s]. The default origin, :data:`RUN_EPOCH_NS`, is the same for every bag, so the bags
of one run (a plan and its rollout start at ``t = 0`` together) share one time base:
play them together with ``ros2 bag play --clock`` and ``use_sim_time``.

Every topic's ``offered_qos_profiles`` in ``metadata.yaml`` (and the MCAP channel
metadata) is the QoS its publisher would offer: reliable and volatile, keep-last,
except the latched ``/tf_static`` and ``/robot_description`` (transient local,
depth 1), which a late subscriber such as RViz still receives.

A bag is a folder; it is written into a temporary sibling folder and renamed,
so an interrupted export never leaves a partial bag under the final name.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io._atomic import atomic_folder
from dexlfd.io._ros_msgs import BASE_FRAME, Msgs, qos, rosbags_module, typestore
from dexlfd.io._urdf_tf import FINGER_JOINTS, joint_transforms, panda_joints, panda_urdf
from dexlfd.io.demonstration import Demonstration
from dexlfd.io.plan import Plan
from dexlfd.io.rollout import Rollout

__all__ = [
    "BAG_STORAGES",
    "DEFAULT_JOINT_NAMES",
    "RUN_EPOCH_NS",
    "export_demonstration_rosbag",
    "export_plan_rosbag",
    "export_rollout_rosbag",
    "read_rosbag",
]

DEFAULT_JOINT_NAMES = tuple(f"panda_joint{i}" for i in range(1, 8))  # franka_ros naming
BAG_STORAGES = ("mcap", "db3")  # the first is the default
_NS = 1_000_000_000
# the default stamp of t = 0, shared by every bag (of a run): ROS time 1 s, not 0,
# which tf2 reads as "the latest transform"
RUN_EPOCH_NS = _NS
_NAME_MAX = 255  # bytes of one file name on Linux/macOS file systems
MAX_PATH_POSES = 10_000  # poses of a path message (the outline RViz draws)
_SQLITE_PATH_MAX = 512  # bytes of a path SQLite's unix VFS opens (SQLITE_MAX_PATHNAME)


# ROS 2 time is int32 seconds: stamps stay below this
_MAX_STAMP_NS = (2**31 - 1) * _NS


def _stamps(t: FloatArray, origin_ns: int | None) -> list[int]:
    """ROS stamps [ns] of the times ``t`` [s]: ``origin_ns`` (default :data:`RUN_EPOCH_NS`) + ``t``.

    A time axis that is itself a clock far from 0 (Unix seconds, say) would overflow
    ROS's int32 seconds when added to the origin: it is then counted from its first
    sample, and a :class:`~dexlfd.errors.InvalidFile` names what still cannot fit.
    """
    origin = RUN_EPOCH_NS if origin_ns is None else int(origin_ns)
    t = np.asarray(t, dtype=np.float64)
    first = float(t[0]) if t.size else 0.0
    if t.size and origin + round(float(t[-1]) * _NS) > _MAX_STAMP_NS:
        t = t - first
    stamps = [origin + int(round(x * _NS)) for x in t]
    if stamps and not 0 <= min(stamps) <= max(stamps) <= _MAX_STAMP_NS:
        raise InvalidFile(
            f"stamps from {min(stamps)} ns to {max(stamps)} ns do not fit ROS 2 time "
            f"(0 to {_MAX_STAMP_NS} ns): a time axis in seconds, an origin before 2038"
        )
    return stamps


def _write_bag(
    path: Path, topics: dict[str, str], messages: Iterable[tuple[str, int, Any]], storage: str
) -> Path:
    rosbag2 = rosbags_module("rosbag2")
    StoragePlugin = rosbag2.StoragePlugin
    if storage not in BAG_STORAGES:
        raise InvalidInput(f"bag storage must be one of {BAG_STORAGES}, got {storage!r}")
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    ts = typestore()
    path = Path(path)
    if path.exists():
        raise InvalidFile(f"{path}: already exists; a ROS 2 bag is a new folder (remove it first)")
    # the storage file inside is named after the bag (NAME.mcap; NAME.db3, which SQLite
    # also needs as NAME.db3-journal while writing): that name must fit one file name
    tail = ".mcap" if storage == "mcap" else ".db3-journal"
    try:
        path.name.encode()
    except UnicodeEncodeError:
        raise InvalidFile(
            f"{path}: a ROS 2 bag folder's name must be UTF-8 text (its metadata.yaml names "
            "its file after it)"
        ) from None
    if len(os.fsencode(path.name)) + len(tail) > _NAME_MAX:
        raise InvalidFile(
            f"{path}: a ROS 2 bag folder's name is at most {_NAME_MAX - len(tail)} bytes "
            f"(its file is named after it, NAME{tail})"
        )
    with atomic_folder(path) as tmp:
        opened = tmp.absolute() / f"{path.name}{tail}"
        if storage == "db3" and len(os.fsencode(opened)) > _SQLITE_PATH_MAX:
            raise InvalidFile(
                f"{path}: SQLite opens paths of at most {_SQLITE_PATH_MAX} bytes and this bag's "
                "file would be longer while it is written: a shorter name or folder, or MCAP"
            )
        _write_messages(tmp, plugin, ts, topics, messages)
    return path


def _write_messages(
    folder: Path,
    plugin: Any,
    ts: Any,
    topics: dict[str, str],
    messages: Iterable[tuple[str, int, Any]],
) -> None:
    """Write ``messages`` (in time order; made one by one) into a new bag ``folder``."""
    Writer = rosbags_module("rosbag2").Writer
    with Writer(folder, version=8, storage_plugin=plugin) as writer:
        conns = {
            topic: writer.add_connection(
                topic, msgtype, typestore=ts, offered_qos_profiles=qos(topic)
            )
            for topic, msgtype in topics.items()
        }
        for topic, ns, msg in messages:
            writer.write(conns[topic], ns, ts.serialize_cdr(msg, topics[topic]))


_JOINT_STATE = "sensor_msgs/msg/JointState"


def _fingers(m: Msgs, ns: int, opening: float) -> Any:
    """The gripper as the two finger joints' ``JointState`` (each half the opening [m])."""
    half = 0.5 * float(opening)
    return m.joint_state(ns, list(FINGER_JOINTS), np.array([half, half]))


def _target_tf(m: Msgs, ns: int, p: FloatArray, q: FloatArray, frame: str) -> Any:
    """``/tf`` from the base to ``frame`` at one pose (RViz draws the frame's axes)."""
    return m.tf([m.transform(ns, BASE_FRAME, frame, p, q)])


def _path(m: Msgs, stamps: list[int], p: FloatArray, q: FloatArray) -> Any:
    """``nav_msgs/Path`` of the poses: every one, or :data:`MAX_PATH_POSES` spread evenly.

    The path is the motion's outline for RViz (every sample is in the pose topic); a
    record of millions of samples keeps it, and the memory it takes, bounded.
    """
    keep = np.unique(np.linspace(0, len(stamps) - 1, min(len(stamps), MAX_PATH_POSES)).round())
    idx = keep.astype(np.intp)
    return m.path([stamps[i] for i in idx], p[idx], q[idx])


def export_plan_rosbag(
    plan: Plan,
    path: str | os.PathLike[str],
    *,
    stamp_origin_ns: int | None = None,
    storage: str = "mcap",
) -> Path:
    """Write ``plan`` as a ROS 2 bag folder at ``path``.

    ``stamp_origin_ns`` is the ROS time of ``plan.t == 0`` [ns]; default
    :data:`RUN_EPOCH_NS` (the time base of every bag of a run).
    ``storage`` is ``"mcap"`` (default) or ``"db3"`` (SQLite).
    """
    m = Msgs(typestore())
    topics = {
        "/dexlfd/plan/pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/plan/twist": "geometry_msgs/msg/TwistStamped",
        "/dexlfd/plan/gripper": _JOINT_STATE,
        "/dexlfd/plan/path": "nav_msgs/msg/Path",
        "/tf": "tf2_msgs/msg/TFMessage",
    }
    stamps = _stamps(plan.t, stamp_origin_ns)

    def messages() -> Iterator[tuple[str, int, Any]]:  # in time order, made as written
        yield "/dexlfd/plan/path", stamps[0], _path(m, stamps, plan.position, plan.quaternion)
        for i, ns in enumerate(stamps):
            p, q = plan.position[i], plan.quaternion[i]
            yield "/dexlfd/plan/pose", ns, m.pose_stamped(ns, p, q)
            yield (
                "/dexlfd/plan/twist",
                ns,
                m.twist_stamped(ns, plan.velocity[i], plan.angular_velocity[i]),
            )
            yield "/dexlfd/plan/gripper", ns, _fingers(m, ns, plan.gripper[i])
            yield "/tf", ns, _target_tf(m, ns, p, q, "dexlfd_plan_target")

    return _write_bag(Path(path), topics, messages(), storage)


def export_demonstration_rosbag(
    demo: Demonstration,
    path: str | os.PathLike[str],
    *,
    stamp_origin_ns: int | None = None,
    storage: str = "mcap",
) -> Path:
    """Write the end-effector motion of ``demo`` as a ROS 2 bag folder at ``path``.

    Only samples where the hand was seen (``demo.valid``) become messages.
    ``stamp_origin_ns`` is the ROS time of ``demo.t == 0`` [ns]; default
    :data:`RUN_EPOCH_NS`.
    """
    idx = np.flatnonzero(demo.valid)
    if idx.size == 0:
        raise InvalidInput("demonstration has no valid sample (the hand was never seen)")
    m = Msgs(typestore())
    topics = {
        "/dexlfd/demo/ee_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/demo/gripper": _JOINT_STATE,
        "/dexlfd/demo/path": "nav_msgs/msg/Path",
        "/tf": "tf2_msgs/msg/TFMessage",
    }
    stamps = _stamps(demo.t[idx], stamp_origin_ns)
    pos, quat = demo.position[idx], demo.quaternion[idx]

    def messages() -> Iterator[tuple[str, int, Any]]:  # in time order, made as written
        yield "/dexlfd/demo/path", stamps[0], _path(m, stamps, pos, quat)
        for k, ns in enumerate(stamps):
            yield "/dexlfd/demo/ee_pose", ns, m.pose_stamped(ns, pos[k], quat[k])
            yield "/dexlfd/demo/gripper", ns, _fingers(m, ns, demo.gripper[idx[k]])
            yield "/tf", ns, _target_tf(m, ns, pos[k], quat[k], "dexlfd_demo_ee")

    return _write_bag(Path(path), topics, messages(), storage)


def _robot_tf(
    m: Msgs, ns0: int, q: FloatArray, fingers: FloatArray
) -> tuple[Any, Callable[[int, int], Any]]:
    """``/tf_static`` (the fixed joints, once) and ``/tf`` of sample ``i`` (the moving joints).

    Each joint's transform from the packaged URDF (:mod:`dexlfd.io._urdf_tf`) at the
    joint positions ``q`` ``(n, 7)`` [rad] and finger positions ``fingers`` ``(n,)`` [m].
    Returns the static message and ``tf(i, ns)``, which makes sample ``i``'s message.
    """
    position = {name: q[:, j] for j, name in enumerate(DEFAULT_JOINT_NAMES)}
    position.update({name: fingers for name in FINGER_JOINTS})
    static, moving = [], []
    for joint in panda_joints():
        if joint.type == "fixed":
            p, r = joint_transforms(joint)
            static.append(m.transform(ns0, joint.parent, joint.child, p[0], r[0]))
            continue
        if joint.mimic is not None:
            leader, mult, offset = joint.mimic
            value = mult * position[leader] + offset
        else:
            value = position[joint.name]
        p, r = joint_transforms(joint, value)
        moving.append((joint, p, r))

    def tf(i: int, ns: int) -> Any:
        return m.tf([m.transform(ns, j.parent, j.child, p[i], r[i]) for j, p, r in moving])

    return m.tf(static), tf


def _joint_trajectory(m: Msgs, rollout: Rollout, names: list[str], ns0: int) -> Any:
    T = m.T
    duration = T["builtin_interfaces/msg/Duration"]
    empty = np.zeros(0)
    points = [
        T["trajectory_msgs/msg/JointTrajectoryPoint"](
            positions=np.ascontiguousarray(rollout.q[i]),
            velocities=np.ascontiguousarray(rollout.dq[i]),
            accelerations=empty,
            effort=empty,
            time_from_start=duration(
                sec=int(rollout.t[i] - rollout.t[0]),
                nanosec=int(round(((rollout.t[i] - rollout.t[0]) % 1.0) * _NS)) % _NS,
            ),
        )
        for i in range(rollout.n_samples)
    ]
    return T["trajectory_msgs/msg/JointTrajectory"](
        header=m.header(ns0), joint_names=names, points=points
    )


def export_rollout_rosbag(
    rollout: Rollout,
    path: str | os.PathLike[str],
    *,
    joint_names: Sequence[str] = DEFAULT_JOINT_NAMES,
    stamp_origin_ns: int | None = None,
    storage: str = "mcap",
) -> Path:
    """Write ``rollout`` as a ROS 2 bag folder at ``path`` (see module docstring).

    ``/joint_states`` holds the 7 arm joints (``joint_names``) and the 2 finger joints
    (each half of ``rollout.gripper``); ``/tf`` and ``/tf_static`` follow the packaged
    URDF, whose joint names are franka_ros's (:data:`DEFAULT_JOINT_NAMES`).
    ``stamp_origin_ns``: the ROS time of ``rollout.t == 0`` [ns], default
    :data:`RUN_EPOCH_NS`.
    """
    if len(joint_names) != rollout.q.shape[1]:
        raise InvalidFile(
            f"joint_names must name {rollout.q.shape[1]} joints, got {len(joint_names)}"
        )
    m = Msgs(typestore())
    topics = {
        "/robot_description": "std_msgs/msg/String",
        "/tf_static": "tf2_msgs/msg/TFMessage",
        "/tf": "tf2_msgs/msg/TFMessage",
        "/joint_states": _JOINT_STATE,
        "/dexlfd/gripper": _JOINT_STATE,
        "/dexlfd/ee_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/ref_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/joint_trajectory": "trajectory_msgs/msg/JointTrajectory",
    }
    names = list(joint_names) + list(FINGER_JOINTS)
    stamps = _stamps(rollout.t, stamp_origin_ns)
    fingers = 0.5 * np.asarray(rollout.gripper, dtype=np.float64)
    static, tf = _robot_tf(m, stamps[0], rollout.q, fingers)
    zero2 = np.zeros(2)

    def sample(i: int, ns: int) -> Iterator[tuple[str, int, Any]]:
        f = np.array([fingers[i], fingers[i]])
        yield "/joint_states", ns, m.joint_state(
            ns, names, np.concatenate([rollout.q[i], f]),
            np.concatenate([rollout.dq[i], zero2]), np.concatenate([rollout.tau[i], zero2]),
        )  # fmt: skip
        yield "/dexlfd/gripper", ns, _fingers(m, ns, rollout.gripper[i])
        yield (
            "/dexlfd/ee_pose",
            ns,
            m.pose_stamped(ns, rollout.ee_position[i], rollout.ee_quaternion[i]),
        )
        yield (
            "/dexlfd/ref_pose",
            ns,
            m.pose_stamped(ns, rollout.ref_position[i], rollout.ref_quaternion[i]),
        )

    def messages() -> Iterator[tuple[str, int, Any]]:  # in time order, made as written
        # samples sharing a stamp: every /tf first, then each sample's other topics; the
        # description, the static frames and the whole trajectory go with the first stamp
        for first, group in _runs_of_equal(stamps):
            if first == 0:
                yield "/robot_description", stamps[0], m.string(panda_urdf())
                yield "/tf_static", stamps[0], static
            for i in group:
                yield "/tf", stamps[i], tf(i, stamps[i])
            for i in group:
                yield from sample(i, stamps[i])
            if first == 0:
                trajectory = _joint_trajectory(m, rollout, list(joint_names), stamps[0])
                yield "/dexlfd/joint_trajectory", stamps[0], trajectory

    return _write_bag(Path(path), topics, messages(), storage)


def _runs_of_equal(stamps: list[int]) -> Iterator[tuple[int, range]]:
    """``(first index, indices)`` of each run of equal values in the sorted ``stamps``."""
    start = 0
    for i in range(1, len(stamps) + 1):
        if i == len(stamps) or stamps[i] != stamps[start]:
            yield start, range(start, i)
            start = i


def read_rosbag(path: str | os.PathLike[str]) -> dict[str, list[tuple[int, Any]]]:
    """Read every message of a ROS 2 bag (MCAP or SQLite): ``{topic: [(ns, message), ...]}``."""
    AnyReader = rosbags_module("highlevel").AnyReader
    ReaderError = rosbags_module("rosbag2.errors").ReaderError
    path = Path(path)
    out: dict[str, list[tuple[int, Any]]] = {}
    try:
        with AnyReader([path], default_typestore=typestore()) as reader:
            for conn, ns, raw in reader.messages():
                out.setdefault(conn.topic, []).append((ns, reader.deserialize(raw, conn.msgtype)))
    except (ReaderError, OSError) as exc:
        raise InvalidFile(f"{path}: not a readable ROS 2 bag: {exc}") from exc
    return out
