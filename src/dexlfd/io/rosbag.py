"""Export plans, rollouts and demonstrations to ROS 2 bags (pure Python, via ``rosbags``).

A bag is stored as MCAP (``storage="mcap"``, the ROS 2 default since Iron; one
``<name>.mcap`` file plus ``metadata.yaml``) or SQLite (``storage="db3"``);
bag format version 8 either way. Topics written (frame ``panda_link0``, the
Panda base; ROS 2 Humble message definitions):

plan
    ``/dexlfd/plan/pose`` (``geometry_msgs/msg/PoseStamped``), ``/dexlfd/plan/twist``
    (``geometry_msgs/msg/TwistStamped``) and ``/dexlfd/plan/gripper``
    (``std_msgs/msg/Float64``, opening [m]), one message per sample, and one
    ``/dexlfd/plan/path`` (``nav_msgs/msg/Path``) holding every pose (RViz draws it).
demonstration
    ``/dexlfd/demo/ee_pose`` (``PoseStamped``) and ``/dexlfd/demo/gripper``
    (``Float64`` [m]) at every sample where the hand was seen (``valid``), and one
    ``/dexlfd/demo/path`` (``nav_msgs/msg/Path``) of those poses.
rollout
    ``/joint_states`` (``sensor_msgs/msg/JointState``: position, velocity, effort),
    ``/dexlfd/ee_pose`` and ``/dexlfd/ref_pose`` (``PoseStamped``), and one
    ``/dexlfd/joint_trajectory`` (``trajectory_msgs/msg/JointTrajectory``) holding
    the executed joint path, so it can be replayed by a ROS 2 trajectory controller.

A bag is a folder; it is written into a temporary sibling folder and renamed,
so an interrupted export never leaves a partial bag under the final name.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidFile, InvalidInput
from dexlfd.io._atomic import atomic_folder
from dexlfd.io.demonstration import Demonstration
from dexlfd.io.plan import Plan
from dexlfd.io.rollout import Rollout

__all__ = [
    "BAG_STORAGES",
    "DEFAULT_JOINT_NAMES",
    "export_demonstration_rosbag",
    "export_plan_rosbag",
    "export_rollout_rosbag",
    "read_rosbag",
]

DEFAULT_JOINT_NAMES = tuple(f"panda_joint{i}" for i in range(1, 8))  # franka_ros naming
BASE_FRAME = "panda_link0"
BAG_STORAGES = ("mcap", "db3")  # the first is the default
_NS = 1_000_000_000
_NAME_MAX = 255  # bytes of one file name on Linux/macOS file systems
_SQLITE_PATH_MAX = 512  # bytes of a path SQLite's unix VFS opens (SQLITE_MAX_PATHNAME)


def _rosbags(module: str) -> Any:
    """``rosbags.<module>``, or the one-line message naming the ``ros`` extra."""
    from dexlfd._extras import import_extra

    return import_extra(f"rosbags.{module}", "ROS 2 bags")


def _typestore() -> Any:
    typesys = _rosbags("typesys")
    return typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)


class _Msgs:
    """Message constructors bound to one typestore."""

    def __init__(self, ts: Any) -> None:
        self.ts = ts
        self.T = ts.types

    def stamp(self, ns: int) -> Any:
        return self.T["builtin_interfaces/msg/Time"](sec=ns // _NS, nanosec=ns % _NS)

    def header(self, ns: int) -> Any:
        return self.T["std_msgs/msg/Header"](stamp=self.stamp(ns), frame_id=BASE_FRAME)

    def pose_stamped(self, ns: int, p: FloatArray, q: FloatArray) -> Any:
        T = self.T
        pose = T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=float(p[2])),
            orientation=T["geometry_msgs/msg/Quaternion"](
                x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
            ),
        )
        return T["geometry_msgs/msg/PoseStamped"](header=self.header(ns), pose=pose)

    def twist_stamped(self, ns: int, v: FloatArray, w: FloatArray) -> Any:
        T = self.T
        vec = T["geometry_msgs/msg/Vector3"]
        twist = T["geometry_msgs/msg/Twist"](
            linear=vec(x=float(v[0]), y=float(v[1]), z=float(v[2])),
            angular=vec(x=float(w[0]), y=float(w[1]), z=float(w[2])),
        )
        return T["geometry_msgs/msg/TwistStamped"](header=self.header(ns), twist=twist)

    def path(self, stamps: list[int], p: FloatArray, q: FloatArray) -> Any:
        poses = [self.pose_stamped(ns, p[i], q[i]) for i, ns in enumerate(stamps)]
        return self.T["nav_msgs/msg/Path"](header=self.header(stamps[0]), poses=poses)


# ROS 2 time is int32 seconds: stamps stay below this
_MAX_STAMP_NS = (2**31 - 1) * _NS


def _stamps(t: FloatArray, origin_ns: int | None) -> list[int]:
    """ROS stamps [ns] of the times ``t`` [s]: ``origin_ns`` (default now) + ``t``.

    A time axis that is itself a clock far from 0 (Unix seconds, say) would overflow
    ROS's int32 seconds when added to the origin: it is then counted from its first
    sample, and a :class:`~dexlfd.errors.InvalidFile` names what still cannot fit.
    """
    origin = time.time_ns() if origin_ns is None else int(origin_ns)
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
    path: Path, topics: dict[str, str], messages: list[tuple[str, int, Any]], storage: str
) -> Path:
    rosbag2 = _rosbags("rosbag2")
    StoragePlugin = rosbag2.StoragePlugin
    if storage not in BAG_STORAGES:
        raise InvalidInput(f"bag storage must be one of {BAG_STORAGES}, got {storage!r}")
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    ts = _typestore()
    path = Path(path)
    if path.exists():
        raise InvalidFile(f"{path}: already exists; a ROS 2 bag is a new folder (remove it first)")
    # the storage file inside is named after the bag (NAME.mcap; NAME.db3, which SQLite
    # also needs as NAME.db3-journal while writing): that name must fit one file name
    tail = ".mcap" if storage == "mcap" else ".db3-journal"
    if len(path.name.encode()) + len(tail) > _NAME_MAX:
        raise InvalidFile(
            f"{path}: a ROS 2 bag folder's name is at most {_NAME_MAX - len(tail)} bytes "
            f"(its file is named after it, NAME{tail})"
        )
    with atomic_folder(path) as tmp:
        opened = tmp.absolute() / f"{path.name}{tail}"
        if storage == "db3" and len(str(opened).encode()) > _SQLITE_PATH_MAX:
            raise InvalidFile(
                f"{path}: SQLite opens paths of at most {_SQLITE_PATH_MAX} bytes and this bag's "
                "file would be longer while it is written: a shorter name or folder, or MCAP"
            )
        _write_messages(tmp, plugin, ts, topics, messages)
    return path


def _write_messages(
    folder: Path, plugin: Any, ts: Any, topics: dict[str, str], messages: list[tuple[str, int, Any]]
) -> None:
    """Write ``messages`` into a new bag ``folder`` with the storage ``plugin``."""
    Writer = _rosbags("rosbag2").Writer
    with Writer(folder, version=8, storage_plugin=plugin) as writer:
        conns = {
            topic: writer.add_connection(topic, msgtype, typestore=ts)
            for topic, msgtype in topics.items()
        }
        for topic, ns, msg in messages:
            writer.write(conns[topic], ns, ts.serialize_cdr(msg, topics[topic]))


def export_plan_rosbag(
    plan: Plan,
    path: str | os.PathLike[str],
    *,
    stamp_origin_ns: int | None = None,
    storage: str = "mcap",
) -> Path:
    """Write ``plan`` as a ROS 2 bag folder at ``path``.

    ``stamp_origin_ns`` is the ROS time of ``plan.t == 0`` [ns]; default: now.
    ``storage`` is ``"mcap"`` (default) or ``"db3"`` (SQLite).
    """
    m = _Msgs(_typestore())
    topics = {
        "/dexlfd/plan/pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/plan/twist": "geometry_msgs/msg/TwistStamped",
        "/dexlfd/plan/gripper": "std_msgs/msg/Float64",
        "/dexlfd/plan/path": "nav_msgs/msg/Path",
    }
    float64 = m.T["std_msgs/msg/Float64"]
    stamps = _stamps(plan.t, stamp_origin_ns)
    messages: list[tuple[str, int, Any]] = [
        ("/dexlfd/plan/path", stamps[0], m.path(stamps, plan.position, plan.quaternion))
    ]
    for i, ns in enumerate(stamps):
        messages.append(
            ("/dexlfd/plan/pose", ns, m.pose_stamped(ns, plan.position[i], plan.quaternion[i]))
        )
        messages.append(
            (
                "/dexlfd/plan/twist",
                ns,
                m.twist_stamped(ns, plan.velocity[i], plan.angular_velocity[i]),
            )
        )
        messages.append(("/dexlfd/plan/gripper", ns, float64(data=float(plan.gripper[i]))))
    return _write_bag(Path(path), topics, messages, storage)


def export_demonstration_rosbag(
    demo: Demonstration,
    path: str | os.PathLike[str],
    *,
    stamp_origin_ns: int | None = None,
    storage: str = "mcap",
) -> Path:
    """Write the end-effector motion of ``demo`` as a ROS 2 bag folder at ``path``.

    Only samples where the hand was seen (``demo.valid``) become messages.
    ``stamp_origin_ns`` is the ROS time of ``demo.t == 0`` [ns]; default: now.
    """
    idx = np.flatnonzero(demo.valid)
    if idx.size == 0:
        raise InvalidInput("demonstration has no valid sample (the hand was never seen)")
    m = _Msgs(_typestore())
    topics = {
        "/dexlfd/demo/ee_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/demo/gripper": "std_msgs/msg/Float64",
        "/dexlfd/demo/path": "nav_msgs/msg/Path",
    }
    float64 = m.T["std_msgs/msg/Float64"]
    stamps = _stamps(demo.t[idx], stamp_origin_ns)
    pos, quat = demo.position[idx], demo.quaternion[idx]
    messages: list[tuple[str, int, Any]] = [
        ("/dexlfd/demo/path", stamps[0], m.path(stamps, pos, quat))
    ]
    for k, ns in enumerate(stamps):
        messages.append(("/dexlfd/demo/ee_pose", ns, m.pose_stamped(ns, pos[k], quat[k])))
        messages.append(("/dexlfd/demo/gripper", ns, float64(data=float(demo.gripper[idx[k]]))))
    return _write_bag(Path(path), topics, messages, storage)


def export_rollout_rosbag(
    rollout: Rollout,
    path: str | os.PathLike[str],
    *,
    joint_names: Sequence[str] = DEFAULT_JOINT_NAMES,
    stamp_origin_ns: int | None = None,
    storage: str = "mcap",
) -> Path:
    """Write ``rollout`` as a ROS 2 bag folder at ``path`` (see module docstring)."""
    if len(joint_names) != rollout.q.shape[1]:
        raise InvalidFile(
            f"joint_names must name {rollout.q.shape[1]} joints, got {len(joint_names)}"
        )
    m = _Msgs(_typestore())
    T = m.T
    topics = {
        "/joint_states": "sensor_msgs/msg/JointState",
        "/dexlfd/ee_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/ref_pose": "geometry_msgs/msg/PoseStamped",
        "/dexlfd/joint_trajectory": "trajectory_msgs/msg/JointTrajectory",
    }
    names = list(joint_names)
    stamps = _stamps(rollout.t, stamp_origin_ns)
    messages: list[tuple[str, int, Any]] = []
    for i, ns in enumerate(stamps):
        js = T["sensor_msgs/msg/JointState"](
            header=m.header(ns),
            name=names,
            position=np.ascontiguousarray(rollout.q[i]),
            velocity=np.ascontiguousarray(rollout.dq[i]),
            effort=np.ascontiguousarray(rollout.tau[i]),
        )
        messages.append(("/joint_states", ns, js))
        ee = m.pose_stamped(ns, rollout.ee_position[i], rollout.ee_quaternion[i])
        messages.append(("/dexlfd/ee_pose", ns, ee))
        ref = m.pose_stamped(ns, rollout.ref_position[i], rollout.ref_quaternion[i])
        messages.append(("/dexlfd/ref_pose", ns, ref))
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
    traj = T["trajectory_msgs/msg/JointTrajectory"](
        header=m.header(stamps[0]), joint_names=names, points=points
    )
    messages.append(("/dexlfd/joint_trajectory", stamps[0], traj))
    messages.sort(key=lambda item: item[1])
    return _write_bag(Path(path), topics, messages, storage)


def read_rosbag(path: str | os.PathLike[str]) -> dict[str, list[tuple[int, Any]]]:
    """Read every message of a ROS 2 bag (MCAP or SQLite): ``{topic: [(ns, message), ...]}``."""
    AnyReader = _rosbags("highlevel").AnyReader
    ReaderError = _rosbags("rosbag2.errors").ReaderError
    path = Path(path)
    out: dict[str, list[tuple[int, Any]]] = {}
    try:
        with AnyReader([path], default_typestore=_typestore()) as reader:
            for conn, ns, raw in reader.messages():
                out.setdefault(conn.topic, []).append((ns, reader.deserialize(raw, conn.msgtype)))
    except (ReaderError, OSError) as exc:
        raise InvalidFile(f"{path}: not a readable ROS 2 bag: {exc}") from exc
    return out
