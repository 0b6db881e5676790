"""Save/load time of the file contracts, LeRobot dataset export and MCAP bag round trip.

The LeRobot figures use the demo's six synthetic demonstrations (``dexlfd synth -n 6``)
and, when the LeRobot environment exists (``make lerobot-env``), lerobot's own loader.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from dexlfd.datasets import pick_place_demonstrations
from dexlfd.io import load_demonstration, save_demonstration

REPO = Path(__file__).resolve().parents[1]


def _size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def bench_npz(demos: list, tmp: Path) -> None:
    path = tmp / "d.npz"
    save_t, load_t = [], []
    for _ in range(20):
        t0 = time.perf_counter()
        save_demonstration(path, demos[0])
        t1 = time.perf_counter()
        load_demonstration(path)
        save_t.append(t1 - t0)
        load_t.append(time.perf_counter() - t1)
    save_ms, load_ms = np.median(save_t) * 1e3, np.median(load_t) * 1e3
    print(f"demonstration save {save_ms:.2f} ms, load {load_ms:.2f} ms")


def bench_lerobot(demos: list, tmp: Path) -> None:
    from dexlfd.io._lerobot_env import (
        LeRobotUnavailable,
        default_lerobot_root,
        lerobot_python,
        load_with_lerobot,
    )
    from dexlfd.io.lerobot import export_lerobot, import_lerobot

    t0 = time.perf_counter()
    out = export_lerobot(demos, tmp / "lerobot")
    t1 = time.perf_counter()
    back = import_lerobot(out)
    t2 = time.perf_counter()
    frames = sum(d.n_samples for d in demos)
    pairs = zip(back.records, demos, strict=True)
    err = max(float(np.max(np.abs(a.position - b.position))) for a, b in pairs)
    kib = _size(out) / 1024
    print(
        f"LeRobot v3.0 export of {len(demos)} demos ({frames} frames): {kib:.0f} KiB, "
        f"export {(t1 - t0) * 1e3:.0f} ms, dexlfd import {(t2 - t1) * 1e3:.0f} ms, "
        f"max |position error| {err:.2e} m (float32)"
    )
    python = lerobot_python(default_lerobot_root())
    if not (python.parent.parent / ".installed").is_file():
        print(f"  lerobot loader: skipped (no environment at {python.parent.parent})")
        return
    try:
        got = load_with_lerobot(python, out, tmp / "hf")
    except LeRobotUnavailable as exc:
        print(f"  lerobot loader failed: {exc}")
        return
    print(
        f"  lerobot {got['lerobot_version']} LeRobotDataset: "
        f"import lerobot {got['import_s']:.1f} s, open dataset {got['open_s']:.2f} s, "
        f"read all {got['num_frames']} frames "
        f"{got['iterate_s']:.2f} s"
    )


def bench_mcap(tmp: Path) -> None:
    from scipy.spatial.transform import Rotation

    from dexlfd.io import Plan
    from dexlfd.io.rosbag import export_plan_rosbag

    try:
        from mcap_ros2.reader import read_ros2_messages
    except ImportError:
        print("MCAP: mcap-ros2-support not installed, skipped")
        return
    rng = np.random.default_rng(0)
    n = 1000
    t = np.arange(n) / 100.0
    plan = Plan(
        t=t,
        position=rng.normal(size=(n, 3)),
        velocity=rng.normal(size=(n, 3)),
        acceleration=rng.normal(size=(n, 3)),
        quaternion=Rotation.random(n, random_state=1).as_quat(),
        angular_velocity=rng.normal(size=(n, 3)),
        gripper=rng.uniform(0, 0.08, n),
    )
    for storage in ("mcap", "db3"):
        t0 = time.perf_counter()
        bag = export_plan_rosbag(plan, tmp / f"plan_{storage}", stamp_origin_ns=0, storage=storage)
        t1 = time.perf_counter()
        line = f"plan bag ({n} samples, {storage}): write {(t1 - t0) * 1e3:.0f} ms, "
        line += f"{_size(bag) / 1024:.0f} KiB"
        if storage == "mcap":
            t2 = time.perf_counter()
            file = str(next(bag.glob("*.mcap")))
            pts = [m.ros_msg.pose.position for m in read_ros2_messages(file, "/dexlfd/plan/pose")]
            pos = np.array([[p.x, p.y, p.z] for p in pts])
            t3 = time.perf_counter()
            err = float(np.max(np.abs(pos - plan.position)))
            line += f", read (mcap-ros2-support) {(t3 - t2) * 1e3:.0f} ms"
            line += f", max abs error {err:.1e} m"
        print(line)


_ROLLOUT_BAG = """
import resource, sys, time
from pathlib import Path
import numpy as np
from dexlfd.io import Rollout
from dexlfd.io.rosbag import export_rollout_rosbag
n, out = int(sys.argv[1]), Path(sys.argv[2])
rng = np.random.default_rng(0)
quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
ro = Rollout(t=np.arange(n) * 1e-3, q=rng.normal(size=(n, 7)), dq=rng.normal(size=(n, 7)),
             tau=rng.normal(size=(n, 7)), ee_position=rng.normal(size=(n, 3)),
             ee_quaternion=quat, ref_position=rng.normal(size=(n, 3)), ref_quaternion=quat,
             gripper=np.full(n, 0.04))
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
export_rollout_rosbag(ro, out)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(f"{time.perf_counter() - t0:.1f} {base / 1024:.0f} {peak / 1024:.0f}")
"""


def bench_rollout_bag(tmp: Path, n: int = 60_000) -> None:
    """Peak memory of a long rollout's bag (a 60 s rollout at 1 kHz), in a fresh process."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    out = subprocess.run(
        [sys.executable, "-c", _ROLLOUT_BAG, str(n), str(tmp / "rollout_bag")],
        env=env, capture_output=True, text=True, check=True,
    ).stdout.split()  # fmt: skip
    secs, base, peak = (float(v) for v in out)
    print(
        f"rollout bag ({n} samples, mcap): write {secs:.1f} s, peak RSS {peak:.0f} MB "
        f"({base:.0f} MB before the export), {_size(tmp / 'rollout_bag') / 2**20:.0f} MiB"
    )


def main() -> None:
    demos = pick_place_demonstrations(6, np.random.default_rng(0))
    with tempfile.TemporaryDirectory() as tmp:
        bench_npz(demos, Path(tmp))
        bench_mcap(Path(tmp))
        bench_rollout_bag(Path(tmp))
        bench_lerobot(demos, Path(tmp))


if __name__ == "__main__":
    main()
