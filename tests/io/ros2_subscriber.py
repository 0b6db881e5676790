"""A ROS 2-style subscriber process: decodes every message of dexlfd's topics, one JSON line each.

    python ros2_subscriber.py DOMAIN_ID OUT.jsonl

Prints ``READY`` once its readers exist, then writes per message a JSON line
``{"topic", "stamp", ...}`` to OUT.jsonl (a file, not a pipe, so a full pipe never
stalls the reader). ``main(on_message)`` lets a caller add fields to each line (the
latency benchmark adds the time of receipt; the tests read no clock).
It stops when a line ``done`` arrives on its standard input: the caller sends it once
its publisher has closed, and a publisher closes only after its subscribers have
acknowledged every message (reliable QoS), so a last ``take`` finds them all; no
clock decides when the stream has ended.
Its QoS are ROS 2's defaults, except the plan's joint trajectory (transient local,
as a ROS 2 subscriber to a latched topic asks for).
"""

import json
import select
import sys
from collections.abc import Callable
from typing import Any

from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from dexlfd.io import _ros2_msgs as m
from dexlfd.io.ros2 import TOPICS, dds_topic


def _told_done() -> bool:
    """True once the caller wrote ``done`` on standard input (or closed it)."""
    if not select.select([sys.stdin], [], [], 0)[0]:
        return False
    line = sys.stdin.readline()
    return line.strip() == "done" or line == ""


def main(on_message: Callable[[dict[str, Any]], None] | None = None) -> None:
    domain, out_path = int(sys.argv[1]), sys.argv[2]
    out_file = open(out_path, "w")  # noqa: SIM115 - open for the whole run
    dp = DomainParticipant(domain)
    ws = WaitSet(dp)
    readers = {}
    for key, kind in (
        ("joint_trajectory", m.JointTrajectory),
        ("pose", m.PoseStamped),
        ("joint_states", m.JointState),
    ):
        latched = key == "joint_trajectory"
        qos = Qos(
            Policy.Reliability.Reliable(duration(seconds=1)),
            Policy.Durability.TransientLocal if latched else Policy.Durability.Volatile,
            Policy.History.KeepLast(1 if latched else 1000),
        )
        topic = Topic(dp, dds_topic(TOPICS[key]), kind, qos=qos)
        reader = DataReader(dp, topic, qos=qos)
        ws.attach(ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any))
        readers[key] = reader
    print("READY", flush=True)
    done = False
    while not done:
        ws.wait(duration(milliseconds=100))
        done = _told_done()  # before the take: everything acknowledged is taken below
        for key, reader in readers.items():
            for s in reader.take(N=100_000):
                if not hasattr(s, "header"):  # a writer left (InvalidSample): no data
                    continue
                out = {
                    "topic": TOPICS[key],
                    "stamp": s.header.stamp.sec + 1e-9 * s.header.stamp.nanosec,
                    "frame": s.header.frame_id,
                }
                if on_message is not None:
                    on_message(out)
                if key == "pose":
                    p, q = s.pose.position, s.pose.orientation
                    out["p"], out["q"] = [p.x, p.y, p.z], [q.x, q.y, q.z, q.w]
                elif key == "joint_states":
                    out["name"], out["position"] = list(s.name), list(s.position)
                    out["velocity"], out["effort"] = list(s.velocity), list(s.effort)
                else:
                    out["joint_names"] = list(s.joint_names)
                    out["positions"] = [list(pt.positions) for pt in s.points]
                    out["t"] = [
                        pt.time_from_start.sec + 1e-9 * pt.time_from_start.nanosec
                        for pt in s.points
                    ]
                out_file.write(json.dumps(out) + "\n")
    out_file.close()


if __name__ == "__main__":
    main()
