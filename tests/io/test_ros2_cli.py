"""``--ros2-publish`` without a DDS: what the commands do before any message is sent."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from dexlfd._commands._ros2 import StateTap
from dexlfd.cli import main
from dexlfd.control import LoopConfig, make_controller, track
from dexlfd.io import save_plan
from dexlfd.plan.moves import lift_plan
from dexlfd.robot import MujocoPandaModel, PlantConfig


class _Recorder:
    def __init__(self) -> None:
        self.states: list[tuple[float, np.ndarray]] = []

    def publish_state(self, t: float, q: np.ndarray, dq: np.ndarray) -> None:
        self.states.append((t, q.copy()))


def test_state_tap_publishes_the_measured_state_at_the_rate_in_simulated_time() -> None:
    plan = lift_plan(2.0, z_high=0.32, y_start=-0.08, y_end=0.08)
    rec = _Recorder()
    tap = StateTap(MujocoPandaModel(), rec, rate_hz=100.0, loop_rate_hz=1000.0)
    ro = track(plan, make_controller("pd"), tap, PlantConfig(), LoopConfig(q_noise=0.0),
               rng=np.random.default_rng(0))  # fmt: skip
    t = np.array([s[0] for s in rec.states])
    np.testing.assert_allclose(t, 0.01 * np.arange(len(t)), atol=1e-12)
    assert len(t) == -(-ro.n_samples // 10)  # every 10th of the run's ticks
    # tick k's state is the rollout's sample k (no position noise here)
    for k in (0, 10, 20):
        np.testing.assert_allclose(rec.states[k // 10][1], ro.q[k], atol=1e-12)


def test_missing_ros2_extra_is_said_before_planning(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setitem(sys.modules, "cyclonedds", None)
    plan_file = save_plan(tmp_path / "plan.npz", lift_plan(1.0))
    out = tmp_path / "r.npz"
    assert main(["simulate", str(plan_file), "-o", str(out), "--ros2-publish", "-q"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith("pip install 'dexlfd[ros2]'")
    assert not out.exists()


@pytest.mark.parametrize("rate", ["0", "1001", "x"])
def test_ros2_rate_is_checked(tmp_path: Path, rate: str, capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "p.npz", "-o", str(tmp_path / "r.npz"), "--ros2-rate-hz", rate])
    assert exc.value.code == 2
    assert "--ros2-rate-hz" in capsys.readouterr().err
