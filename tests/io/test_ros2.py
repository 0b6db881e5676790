"""Live ROS 2 topics: a subscriber process on the loopback interface decodes every message.

Both sides use Cyclone DDS confined to ``lo`` (unicast discovery to 127.0.0.1) on a
domain of their own, so parallel runs do not hear each other. Skips without the
``cyclonedds`` package (``pip install 'dexlfd[ros2]'``).
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

cyclonedds = pytest.importorskip("cyclonedds", reason="pip install 'dexlfd[ros2]'")

from dexlfd.cli import main  # noqa: E402
from dexlfd.io import save_plan  # noqa: E402
from dexlfd.io.ros2 import TOPICS, decimate, stamp  # noqa: E402
from dexlfd.panda import ARM_JOINT_NAMES  # noqa: E402
from dexlfd.plan.moves import lift_plan  # noqa: E402

HERE = Path(__file__).resolve().parent
LOOPBACK = (
    "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/>"
    "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30"
    "</MaxAutoParticipantIndex><Peers><Peer Address='127.0.0.1'/></Peers></Discovery>"
    "</Domain></CycloneDDS>"
)


@pytest.fixture
def dds_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    domain = str(100 + os.getpid() % 100)  # a domain of this run only
    cfg = tmp_path / "cyclonedds.xml"
    cfg.write_text(LOOPBACK)
    monkeypatch.setenv("CYCLONEDDS_URI", cfg.as_uri())
    monkeypatch.setenv("ROS_DOMAIN_ID", domain)
    src = str(Path(__file__).resolve().parents[2] / "src")
    dds_site = str(Path(cyclonedds.__file__).resolve().parents[1])
    return {**os.environ, "PYTHONPATH": os.pathsep.join([src, dds_site])}


def _subscriber(env: dict[str, str], out: Path) -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [sys.executable, str(HERE / "ros2_subscriber.py"), env["ROS_DOMAIN_ID"], str(out)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=env,
    )  # fmt: skip
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "READY", proc.stderr.read() if proc.stderr else ""
    return proc


def _messages(proc: subprocess.Popen[str], out: Path) -> list[dict]:
    # the publisher has closed (its subscribers acknowledged every message): stop
    _, err = proc.communicate("done\n", timeout=600)  # a hang guard, not a speed limit
    assert proc.returncode == 0, err
    return [json.loads(line) for line in out.read_text().splitlines() if line.strip()]


def test_simulate_publishes_plan_and_state_to_a_subscriber(dds_env, tmp_path) -> None:
    plan = lift_plan(1.0, z_high=0.32, y_start=-0.05, y_end=0.05)
    plan_file = save_plan(tmp_path / "plan.npz", plan)
    received = tmp_path / "received.jsonl"
    proc = _subscriber(dds_env, received)
    try:
        rc = main(["simulate", str(plan_file), "-o", str(tmp_path / "r.npz"), "--ros2-publish",
                   "--ros2-rate-hz", "50", "-q"])  # fmt: skip
    finally:
        msgs = _messages(proc, received)
    assert rc == 0
    by_topic: dict[str, list[dict]] = {}
    for m in msgs:
        by_topic.setdefault(m["topic"], []).append(m)
        assert m["frame"] == "panda_link0"
    # every pose of the plan at 50 Hz arrived, in order, with the plan's positions
    poses = by_topic[TOPICS["pose"]]
    idx = decimate(plan.t, 50.0)
    assert len(poses) == len(idx)
    np.testing.assert_allclose([p["p"] for p in poses], plan.position[idx], atol=1e-12)
    np.testing.assert_allclose([p["q"] for p in poses], plan.quaternion[idx], atol=1e-12)
    dt = np.diff([p["stamp"] for p in poses])
    # stamps are ns; the subscriber sums sec + 1e-9 nanosec of an epoch time in a float64,
    # whose resolution there is ~2.4e-7 s
    np.testing.assert_allclose(dt, np.diff(plan.t[idx]), atol=1e-6)
    # one joint trajectory: the plan's inverse kinematics, reaching its TCP poses
    (traj,) = by_topic[TOPICS["joint_trajectory"]]
    assert traj["joint_names"] == list(ARM_JOINT_NAMES)
    from dexlfd.robot import MujocoPandaModel

    model = MujocoPandaModel()
    q_end = np.array(traj["positions"][-1])
    np.testing.assert_allclose(model.tcp_pose(q_end)[0], plan.position[-1], atol=1e-4)
    assert traj["t"][-1] == pytest.approx(plan.t[-1] - plan.t[0], abs=0.02)
    # the simulated robot's state, at 50 Hz of simulated time, from t = 0 to the end
    states = by_topic[TOPICS["joint_states"]]
    t_states = np.array([s["stamp"] for s in states])
    np.testing.assert_allclose(t_states, 0.02 * np.arange(len(states)), atol=2e-9)
    assert t_states[-1] >= plan.t[-1] - 0.02 - 1e-9
    q_mid = np.array(states[len(states) // 2]["position"])
    k = int(round(t_states[len(states) // 2] * 100))  # plan at 100 Hz (lift_plan's rate)
    assert np.linalg.norm(model.tcp_pose(q_mid)[0] - plan.position[min(k, len(plan.t) - 1)]) < 0.01


def test_nobody_listening_the_run_goes_on_and_says_so_once(dds_env, tmp_path, caplog) -> None:
    plan_file = save_plan(tmp_path / "plan.npz", lift_plan(1.0, z_high=0.32))
    out = tmp_path / "r.npz"
    with caplog.at_level(logging.WARNING):
        rc = main(["simulate", str(plan_file), "-o", str(out), "--ros2-publish"])
    assert rc == 0 and out.exists()
    said = [r for r in caplog.records if "nobody subscribes" in r.getMessage()]
    assert len(said) == 1, [r.getMessage() for r in said]


def test_stamp_and_decimation() -> None:
    assert stamp(1.5) == (1, 500_000_000)
    assert stamp(0.0) == (0, 0)
    t = np.linspace(0.0, 1.0, 1001)
    idx = decimate(t, 100.0)
    assert idx[0] == 0 and idx[-1] == 1000 and len(idx) == 101
