"""Live ROS 2 topics without a ROS installation: plans and robot states over DDS.

ROS 2 nodes talk DDS; with ROS 2's type names (``pkg::msg::dds_::Name_``, see
:mod:`dexlfd.io._ros2_msgs`), its topic prefix (``rt/``) and its QoS, messages a
plain ``cyclonedds`` participant writes are received by any ROS 2 node on the same
network and ``ROS_DOMAIN_ID`` (``ros2 topic echo``, RViz, a trajectory controller).
Topics (frame ``panda_link0``, the Panda base, as in :mod:`dexlfd.io.rosbag`):

``/dexlfd/plan/joint_trajectory`` (``trajectory_msgs/msg/JointTrajectory``)
    The plan's joint path (its inverse kinematics), one message; *latched*
    (reliable, transient local, keep last 1: a node that subscribes later, while
    this process runs, still gets it), as ``/robot_description`` is.
``/dexlfd/plan/pose`` (``geometry_msgs/msg/PoseStamped``)
    The desired TCP pose per sample (header stamp = plan start + t); ROS 2's
    default QoS (reliable, volatile, keep last 10).
``/joint_states`` (``sensor_msgs/msg/JointState``)
    The robot's joint positions, velocities and torques; default QoS.

Nobody listening is not an error: :meth:`Ros2Publisher.publish_plan` and
:meth:`Ros2Publisher.publish_states` go on and log one warning per topic.

References
----------
.. [1] ROS 2 design, "Topic and Service name mapping to DDS",
   https://design.ros2.org/articles/topic_and_service_names.html
.. [2] ROS 2 documentation, "Quality of Service settings" (defaults: reliable,
   volatile, keep last 10).
"""

from __future__ import annotations

import logging
import os
import time
from types import ModuleType
from typing import Any, cast

import numpy as np

from dexlfd._types import FloatArray
from dexlfd.errors import InvalidInput
from dexlfd.io.plan import Plan
from dexlfd.panda import ARM_JOINT_NAMES, N_JOINTS

__all__ = [
    "FRAME_ID",
    "TOPICS",
    "Ros2Publisher",
    "dds_topic",
    "decimate",
    "import_cyclonedds",
    "stamp",
]

logger = logging.getLogger(__name__)

FRAME_ID = "panda_link0"
TOPICS = {
    "joint_trajectory": "/dexlfd/plan/joint_trajectory",
    "pose": "/dexlfd/plan/pose",
    "joint_states": "/joint_states",
}
SETTLE_S = 0.5  # [s] after a subscriber is discovered, before the first message (a busy host)
MAX_DOMAIN_ID = 232  # ROS 2: domain ids 0..232 on Linux (port ranges)


def import_cyclonedds() -> ModuleType:
    """Import ``cyclonedds`` or raise :class:`DependencyNotInstalled` naming the extra."""
    from dexlfd._extras import import_extra

    return import_extra("cyclonedds", "live ROS 2 topics (--ros2-publish)")


def dds_topic(ros_topic: str) -> str:
    """The DDS topic of a ROS 2 topic: ``/a/b`` -> ``rt/a/b`` ([1])."""
    return "rt" + ros_topic


def stamp(t: float) -> tuple[int, int]:
    """``builtin_interfaces/Time`` (sec, nanosec) of ``t`` [s] >= 0."""
    ns = int(round(t * 1e9))
    return ns // 1_000_000_000, ns % 1_000_000_000


def _domain_id(domain_id: int | None) -> int:
    if domain_id is None:
        text = os.environ.get("ROS_DOMAIN_ID", "0") or "0"
        try:
            domain_id = int(text)
        except ValueError:
            raise InvalidInput(f"ROS_DOMAIN_ID must be an integer, got {text!r}") from None
    if not 0 <= domain_id <= MAX_DOMAIN_ID:
        raise InvalidInput(f"ROS 2 domain id must be in 0..{MAX_DOMAIN_ID}, got {domain_id}")
    return domain_id


class Ros2Publisher:
    """Publish plans and joint states as ROS 2 messages (a context manager).

    Parameters
    ----------
    domain_id : int, optional
        ROS 2 domain (default ``ROS_DOMAIN_ID``, else 0).
    discovery_s : float
        How long to wait for a subscriber before the first message of a topic [s]
        (DDS discovery takes ~0.1-1 s); nobody by then: one warning, publish anyway.
    """

    def __init__(self, domain_id: int | None = None, discovery_s: float = 1.0) -> None:
        self.domain_id = _domain_id(domain_id)
        if not (np.isfinite(discovery_s) and discovery_s >= 0):
            raise InvalidInput(f"discovery_s must be >= 0 s, got {discovery_s!r}")
        self.discovery_s = float(discovery_s)
        dds = import_cyclonedds()
        from cyclonedds.domain import DomainParticipant

        from dexlfd.io import _ros2_msgs as msgs

        self._dds, self.msgs = dds, cast(Any, msgs)  # IDL structs: untyped constructors
        self._participant: Any = DomainParticipant(self.domain_id)
        self._writers: dict[str, Any] = {}
        self._nobody = False  # a topic found no subscriber (warned once)

    def __enter__(self) -> Ros2Publisher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self, ack_timeout_s: float = 2.0) -> None:
        """Wait (up to ``ack_timeout_s``) for subscribers to acknowledge, then leave."""
        from cyclonedds.util import duration

        for w in self._writers.values():
            if w.get_matched_subscriptions():
                w.wait_for_acks(duration(seconds=ack_timeout_s))
        self._writers.clear()
        self._participant = None

    # -- writers ----------------------------------------------------------------------
    def _writer(self, key: str) -> Any:
        if key in self._writers:
            return self._writers[key]
        from cyclonedds.pub import DataWriter
        from cyclonedds.qos import Policy, Qos
        from cyclonedds.topic import Topic
        from cyclonedds.util import duration

        msgs = self.msgs
        kind = {"joint_trajectory": msgs.JointTrajectory, "pose": msgs.PoseStamped,
                "joint_states": msgs.JointState}[key]  # fmt: skip
        latched = key == "joint_trajectory"
        qos = Qos(
            Policy.Reliability.Reliable(duration(seconds=1)),
            Policy.Durability.TransientLocal if latched else Policy.Durability.Volatile,
            Policy.History.KeepLast(1 if latched else 10),
            Policy.DataRepresentation(use_cdrv0_representation=True),  # XCDR1, as ROS 2's rmw
        )
        topic = Topic(self._participant, dds_topic(TOPICS[key]), kind, qos=qos)
        writer = DataWriter(self._participant, topic, qos=qos)
        self._writers[key] = writer
        self._await_subscriber(key, writer)
        return writer

    def _await_subscriber(self, key: str, writer: Any) -> bool:
        """Wait up to ``discovery_s`` for a subscriber; say once if nobody listens.

        After one topic found nobody, the others do not wait again (the run goes on).
        """
        deadline = time.monotonic() + (0.0 if self._nobody else self.discovery_s)
        while not writer.get_matched_subscriptions():
            if time.monotonic() >= deadline:
                if not self._nobody:
                    self._nobody = True
                    logger.warning(
                        "ROS 2: nobody subscribes to %s on domain %d; publishing anyway "
                        "(said once)", TOPICS[key], self.domain_id,
                    )  # fmt: skip
                return False
            time.sleep(0.01)
        # the writer has seen the reader; the reader may not have seen the writer yet and
        # would drop a volatile sample sent now: give the match a moment to settle
        time.sleep(SETTLE_S)
        return True

    def subscribers(self, key: str) -> int:
        """How many subscriptions the topic ``key`` of :data:`TOPICS` has matched."""
        return len(self._writer(key).get_matched_subscriptions())

    # -- messages ---------------------------------------------------------------------
    def _header(self, t: float) -> Any:
        sec, nanosec = stamp(t)
        return self.msgs.Header(self.msgs.Time(sec, nanosec), FRAME_ID)

    def publish_plan(
        self,
        plan: Plan,
        joint_path: tuple[FloatArray, FloatArray] | None = None,
        t0: float = 0.0,
        rate_hz: float = 100.0,
    ) -> int:
        """Publish the plan: its joint trajectory (if given) and its poses.

        Parameters
        ----------
        plan : Plan
        joint_path : (t (m,), q (m, 7)), optional
            The plan's joint positions [rad] at plan times [s] (its inverse
            kinematics); the JointTrajectory's points (velocities by differences).
        t0 : float
            Header stamp of the plan's start [s] (e.g. ``time.time()``).
        rate_hz : float
            Poses per second of plan time (decimated, first and last kept), > 0.

        Returns
        -------
        int
            Messages written.
        """
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise InvalidInput(f"rate_hz must be > 0, got {rate_hz!r}")
        msgs, count = self.msgs, 0
        if joint_path is not None:
            t_q, q = (np.asarray(a, dtype=np.float64) for a in joint_path)
            if q.ndim != 2 or q.shape[1] != N_JOINTS or t_q.shape != (len(q),) or len(q) < 2:
                raise InvalidInput(
                    f"joint_path must be t (m,) and q (m, 7), m >= 2; got {t_q.shape}, {q.shape}"
                )
            dq = np.gradient(q, t_q, axis=0)
            points = [
                msgs.JointTrajectoryPoint(
                    q[k].tolist(),
                    dq[k].tolist(),
                    [],
                    [],
                    msgs.Duration(*stamp(float(t_q[k] - plan.t[0]))),
                )  # fmt: skip
                for k in range(len(q))
            ]
            traj = msgs.JointTrajectory(self._header(t0), list(ARM_JOINT_NAMES), points)
            self._writer("joint_trajectory").write(traj)
            count += 1
        writer = self._writer("pose")
        for k in decimate(plan.t, rate_hz):
            p, quat = plan.position[k], plan.quaternion[k]  # quaternion (x, y, z, w)
            pose = msgs.Pose(msgs.Point(*map(float, p)), msgs.Quaternion(*map(float, quat)))
            writer.write(msgs.PoseStamped(self._header(t0 + float(plan.t[k] - plan.t[0])), pose))
            count += 1
        return count

    def publish_state(
        self, t: float, q: FloatArray, dq: FloatArray, tau: FloatArray | None = None
    ) -> None:
        """One ``sensor_msgs/JointState`` at time ``t`` [s] (stamp)."""
        effort = [] if tau is None else np.asarray(tau, dtype=np.float64).tolist()
        msg = self.msgs.JointState(
            self._header(t), list(ARM_JOINT_NAMES), np.asarray(q, dtype=np.float64).tolist(),
            np.asarray(dq, dtype=np.float64).tolist(), effort,
        )  # fmt: skip
        self._writer("joint_states").write(msg)


def decimate(t: FloatArray, rate_hz: float) -> list[int]:
    """Indices of ``t`` at most ``rate_hz`` apart, always with the first and the last."""
    step = 1.0 / rate_hz
    slots = np.floor((t - t[0]) / step + 1e-9)
    keep = np.flatnonzero(np.diff(slots, prepend=-1.0) > 0)
    out = keep.tolist()
    if out[-1] != len(t) - 1:
        out.append(len(t) - 1)
    return out
