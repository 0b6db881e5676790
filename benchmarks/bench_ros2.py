"""ROS 2 publish rate and latency on loopback: dexlfd's publisher to a subscriber process.

The publisher (:class:`dexlfd.io.ros2.Ros2Publisher`) writes ``sensor_msgs/JointState``
(the 1 kHz robot-state stream) and ``geometry_msgs/PoseStamped``, each stamped with
the wall time at writing; a subscriber process (the tests' ``tests/io/ros2_subscriber.py``
through ``ros2_latency_subscriber.py``) decodes every message and notes when it
arrived. Latency = arrival - stamp (same clock, same machine); rate = messages /
publishing time. Both on Cyclone DDS confined to ``lo``. Needs ``pip install 'dexlfd[ros2]'``.

    PYTHONPATH=src python benchmarks/bench_ros2.py [--n 5000]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
LOOPBACK = (
    "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/>"
    "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30"
    "</MaxAutoParticipantIndex><Peers><Peer Address='127.0.0.1'/></Peers></Discovery>"
    "</Domain></CycloneDDS>"
)


def run(n: int, paced_hz: float | None) -> dict[str, float]:
    """Publish ``n`` JointStates (and n/10 poses) as fast as possible or at ``paced_hz``."""
    import cyclonedds

    from dexlfd.io.ros2 import TOPICS, Ros2Publisher

    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "dds.xml"
        cfg.write_text(LOOPBACK)
        domain = str(150 + os.getpid() % 50)
        os.environ["CYCLONEDDS_URI"], os.environ["ROS_DOMAIN_ID"] = cfg.as_uri(), domain
        dds_site = str(Path(cyclonedds.__file__).resolve().parents[1])
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), dds_site])}
        received = Path(tmp) / "received.jsonl"
        sub = subprocess.Popen(
            [sys.executable, str(ROOT / "benchmarks/ros2_latency_subscriber.py"), domain,
             str(received)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
        )  # fmt: skip
        assert sub.stdout is not None and sub.stdout.readline().strip() == "READY"
        q = np.linspace(-0.5, 0.5, 7)
        with Ros2Publisher() as pub:
            pub.subscribers("joint_states")  # discovery before the clock starts
            t0 = time.perf_counter()
            for k in range(n):
                if paced_hz:
                    while time.perf_counter() - t0 < k / paced_hz:
                        pass
                pub.publish_state(time.time(), q, q)
            wall = time.perf_counter() - t0
        sub.communicate("done\n", timeout=120)
        msgs = [json.loads(line) for line in received.read_text().splitlines()]
    states = [m for m in msgs if m["topic"] == TOPICS["joint_states"]]
    lat = np.array([m["recv"] - m["stamp"] for m in states]) * 1e3
    return {
        "sent": n, "received": len(states), "rate_hz": n / wall,
        "lat_median_ms": float(np.median(lat)), "lat_p99_ms": float(np.percentile(lat, 99)),
        "lat_max_ms": float(lat.max()),
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=5000)
    args = ap.parse_args()
    for paced in (None, 1000.0, 100.0):
        n = args.n if paced != 100.0 else args.n // 10
        r = run(n, paced)
        label = "as fast as possible" if paced is None else f"paced at {paced:g} Hz"
        print(
            f"JointState {label}: {r['received']}/{r['sent']} received, publish rate "
            f"{r['rate_hz']:.0f} Hz, latency median {r['lat_median_ms']:.3f} ms, p99 "
            f"{r['lat_p99_ms']:.3f} ms, max {r['lat_max_ms']:.3f} ms"
        )


if __name__ == "__main__":
    main()
