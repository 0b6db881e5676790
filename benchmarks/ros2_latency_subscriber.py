"""The tests' ROS 2 subscriber (``tests/io/ros2_subscriber.py``) with each message's
time of receipt added as ``recv`` [s, wall clock], for ``bench_ros2.py``.

    python ros2_latency_subscriber.py DOMAIN_ID OUT.jsonl
"""

import importlib.util
import time
from pathlib import Path

SUBSCRIBER = Path(__file__).resolve().parents[1] / "tests" / "io" / "ros2_subscriber.py"


def _stamp_receipt(out: dict) -> None:
    out["recv"] = time.time()


if __name__ == "__main__":
    spec = importlib.util.spec_from_file_location("ros2_subscriber", SUBSCRIBER)
    assert spec is not None and spec.loader is not None
    subscriber = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(subscriber)
    subscriber.main(_stamp_receipt)
