"""ROS 2 message constructors and QoS profiles for the bags of :mod:`dexlfd.io.rosbag`.

Messages are built with ``rosbags``' ROS 2 Humble typestore. The QoS profiles are
what a ROS 2 publisher of each topic offers (``rclcpp``'s defaults: reliable, volatile,
keep-last 10; ``/tf`` keep-last 100 as ``tf2_ros``; ``/tf_static`` and
``/robot_description`` latched: transient local, keep-last 1, as
``tf2_ros::StaticTransformBroadcaster`` and ``robot_state_publisher`` offer them).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dexlfd._types import FloatArray

__all__ = ["BASE_FRAME", "LATCHED", "Msgs", "qos", "rosbags_module", "typestore"]

BASE_FRAME = "panda_link0"
LATCHED = ("/tf_static", "/robot_description")  # transient-local topics
_NS = 1_000_000_000
_INFINITE = (2147483647, 4294967295)  # rmw's "infinite" duration, as rosbag2 writes it


def rosbags_module(module: str) -> Any:
    """``rosbags.<module>``, or the one-line message naming the ``ros`` extra."""
    from dexlfd._extras import import_extra

    return import_extra(f"rosbags.{module}", "ROS 2 bags")


def typestore() -> Any:
    """The ROS 2 Humble typestore."""
    typesys = rosbags_module("typesys")
    return typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)


def qos(topic: str) -> list[Any]:
    """The offered QoS profiles of ``topic`` (one publisher) for ``add_connection``."""
    ifc = rosbags_module("interfaces")
    latched = topic in LATCHED
    inf = ifc.QosTime(*_INFINITE)
    return [
        ifc.Qos(
            history=ifc.QosHistory.KEEP_LAST,
            depth=1 if latched else 100 if topic == "/tf" else 10,
            reliability=ifc.QosReliability.RELIABLE,
            durability=(
                ifc.QosDurability.TRANSIENT_LOCAL if latched else ifc.QosDurability.VOLATILE
            ),
            deadline=inf,
            lifespan=inf,
            liveliness=ifc.QosLiveliness.AUTOMATIC,
            liveliness_lease_duration=inf,
            avoid_ros_namespace_conventions=False,
        )
    ]


class Msgs:
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

    def vec3(self, v: FloatArray) -> Any:
        return self.T["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    def transform(self, ns: int, parent: str, child: str, p: FloatArray, q: FloatArray) -> Any:
        """A ``geometry_msgs/msg/TransformStamped`` from ``parent`` to ``child``."""
        T = self.T
        rot = T["geometry_msgs/msg/Quaternion"](
            x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
        )
        header = T["std_msgs/msg/Header"](stamp=self.stamp(ns), frame_id=parent)
        return T["geometry_msgs/msg/TransformStamped"](
            header=header,
            child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](translation=self.vec3(p), rotation=rot),
        )

    def tf(self, transforms: list[Any]) -> Any:
        return self.T["tf2_msgs/msg/TFMessage"](transforms=transforms)

    def joint_state(
        self,
        ns: int,
        names: list[str],
        position: FloatArray,
        velocity: FloatArray | None = None,
        effort: FloatArray | None = None,
    ) -> Any:
        """A ``sensor_msgs/msg/JointState`` (empty velocity/effort when not given)."""
        empty = np.zeros(0)

        def arr(x: FloatArray | None) -> np.ndarray:
            return empty if x is None else np.ascontiguousarray(x, dtype=np.float64)

        return self.T["sensor_msgs/msg/JointState"](
            header=self.header(ns), name=names, position=arr(position),
            velocity=arr(velocity), effort=arr(effort),
        )  # fmt: skip

    def string(self, text: str) -> Any:
        return self.T["std_msgs/msg/String"](data=text)
